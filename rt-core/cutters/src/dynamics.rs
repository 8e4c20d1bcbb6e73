//! The disk cutter's dynamics and its side deflection in the cut: seed 003 (Hrytsai,
//! Hromniuk, Lviv Polytechnic, 2015), taken by its equations, not its figures
//! (docs/plans/disk-cutters.md derives its worked example: its stated stiffness, time
//! constants and frequency do not follow from its own equations).
//!
//! - The side component of the cutting force lags the chip: `P1 = K / (1 + T_P p) a` (the
//!   seed's first equation), here with the chip's force from the Kienzle law domain.md
//!   section 8 uses, `F = k_c1.1 b a^(1 - m_c)` (chip thickness `a` on the side edge, width
//!   `b`), and `T_P = cot(Phi) (C_L / a_c) a xi / V` with the seed's rheological values for
//!   steel ([tau] 1100 MPa, rake 6.5 deg: shear angle 38 deg, `C_L / a_c = 1.63 / 1.62`,
//!   chip compression 1.4; its example, a = 0.5 mm at 100 m/min, gives 5.4e-4 s).
//! - The cutter is a second-order link, `(T1^2 p^2 + T2 p + 1) y = P / C` (1), with the axial
//!   stiffness at its outside radius `C = 3 E b^3 / R_a^2` (6), `T1 = sqrt(m / C)` (7),
//!   `T2 = lambda / pi T1` (8), `f = 1 / (2 pi T1)` (9); damping ratio `T2 / (2 T1) =
//!   lambda / (2 pi)`. Equation (6) is what the seed computes with; it does not follow from
//!   its beam equations (4)-(5), which give `E b^3 sqrt(2 y R - y^2) / (2 R^3)`: a measured
//!   stiffness (a tap test gives `f` and `lambda` directly) is better than either.
//! - The side force of each tooth rises from nothing to `F` and falls again at the
//!   tooth-passing frequency `f_z`: a mean `F / 2` and a fundamental of amplitude `F / 2`.
//!   The cutter's largest side deflection, its flank's profile error (the seed's figure 1),
//!   is `F / (2 C) (1 + |A(f_z)|)` with the link's amplification and the force's lag
//!   `|A| = 1 / sqrt((1 - r^2)^2 + (2 zeta r)^2) / sqrt(1 + (2 pi f_z T_P)^2)`, `r = f_z / f`.
//! - Overload: at that peak the cutter body carries the elastic load `C y_max`. Equation (6)
//!   is the stiffness `3 E I / R_a^3` of a cantilever of length `R_a` with `I = R_a b^3`; the
//!   same beam's bending stress at its root is `(F R_a)(b / 2) / I = F / (2 b^2)`, so the body
//!   takes `2 b^2 [sigma]` at an allowable bending stress `[sigma]` ([`CutterBody::load_limit_n`]).
//!   That beam is as wide as 12 radii (more than the disk's circumference): the stress is
//!   an optimistic estimate and `[sigma]` must carry the margin.

use std::f64::consts::{PI, TAU};

/// The cutter as a body: seed 003's inputs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutterBody {
    pub width_mm: f64,
    pub outside_diameter_mm: f64,
    /// The cutter unit's vibrating mass (the seed: 10 kg).
    pub mass_kg: f64,
    /// Young's modulus of the cutter's material (alloy steel 2.1e5 MPa).
    pub youngs_modulus_mpa: f64,
    /// Logarithmic decrement of its free vibration (the seed: 0.3).
    pub log_decrement: f64,
    pub teeth: u32,
}

/// The cutter link's constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    /// Axial stiffness at the outside radius, N/mm (eq. 6).
    pub stiffness_n_mm: f64,
    pub t1_s: f64,
    pub t2_s: f64,
    pub natural_frequency_hz: f64,
    pub damping_ratio: f64,
}

/// The allowable bending stress of a cutter body when none is given, MPa: an assumption,
/// not a sourced figure, well below what hardened high-speed steel takes in bending; the
/// cutter's maker should state it.
pub const DEFAULT_ALLOWABLE_BENDING_MPA: f64 = 400.0;

/// Why no figures: a value out of its range (named).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutOfRange(pub &'static str);

impl std::fmt::Display for OutOfRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} is out of range", self.0)
    }
}

fn positive(v: f64, name: &'static str) -> Result<f64, OutOfRange> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(OutOfRange(name))
    }
}

impl CutterBody {
    /// The side load the body takes at the allowable bending stress `allowable_mpa`, N:
    /// `2 b^2 [sigma]` (the beam of equation 6, see the module's notes).
    pub fn load_limit_n(&self, allowable_mpa: f64) -> Result<f64, OutOfRange> {
        let b = positive(self.width_mm, "width_mm")?;
        Ok(2.0 * b * b * positive(allowable_mpa, "allowable_bending_mpa")?)
    }

    /// Seed 003's equations (6)-(9).
    pub fn link(&self) -> Result<Link, OutOfRange> {
        let b = positive(self.width_mm, "width_mm")?;
        let r = 0.5 * positive(self.outside_diameter_mm, "outside_diameter_mm")?;
        let m = positive(self.mass_kg, "mass_kg")?;
        let e = positive(self.youngs_modulus_mpa, "youngs_modulus_mpa")?;
        let lambda = positive(self.log_decrement, "log_decrement")?;
        if self.teeth == 0 {
            return Err(OutOfRange("teeth"));
        }
        let c = 3.0 * e * b.powi(3) / (r * r);
        let t1 = (m / (c * 1000.0)).sqrt();
        let t2 = lambda / PI * t1;
        Ok(Link {
            stiffness_n_mm: c,
            t1_s: t1,
            t2_s: t2,
            natural_frequency_hz: 1.0 / (TAU * t1),
            damping_ratio: t2 / (2.0 * t1),
        })
    }
}

/// The workpiece material's cutting coefficients (Kienzle: domain.md section 8).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    pub kc11_n_mm2: f64,
    pub mc: f64,
}

/// The side edge's cut.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SideCut {
    /// Chip thickness on the side edge, mm.
    pub chip_thickness_mm: f64,
    /// The side edge's engaged length, mm.
    pub chip_width_mm: f64,
    pub cutting_speed_m_min: f64,
}

/// What the cutter does in that cut.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deflection {
    /// The side force at full chip, N.
    pub side_force_n: f64,
    pub force_lag_s: f64,
    pub cutter_rpm: f64,
    pub tooth_passing_hz: f64,
    /// Tooth-passing over natural frequency.
    pub frequency_ratio: f64,
    /// `|A(f_z)|`: the link's amplification with the force's lag.
    pub amplification: f64,
    /// The largest side deflection, um: the flank's predicted profile error.
    pub profile_error_um: f64,
    /// The load on the cutter body at that deflection, `C y_max`, N.
    pub peak_load_n: f64,
}

/// Seed 003's shear angle, chip contact length over chip thickness and chip compression
/// (steel, [tau] 1100 MPa, rake 6.5 deg).
const SHEAR_ANGLE_DEG: f64 = 38.0;
const CONTACT_OVER_CHIP: f64 = 1.63 / 1.62;
const CHIP_COMPRESSION: f64 = 1.4;

/// The force's lag `T_P = cot(Phi) (C_L / a_c) a xi / V`, s.
pub fn force_lag_s(chip_thickness_mm: f64, cutting_speed_m_min: f64) -> f64 {
    let v_mm_s = cutting_speed_m_min * 1000.0 / 60.0;
    CONTACT_OVER_CHIP * chip_thickness_mm * CHIP_COMPRESSION / (SHEAR_ANGLE_DEG.to_radians().tan() * v_mm_s)
}

/// The cutter's side deflection in `cut`.
pub fn deflection(body: &CutterBody, material: &Material, cut: &SideCut) -> Result<Deflection, OutOfRange> {
    let link = body.link()?;
    let a = positive(cut.chip_thickness_mm, "chip_thickness_mm")?;
    let b = positive(cut.chip_width_mm, "chip_width_mm")?;
    let v = positive(cut.cutting_speed_m_min, "cutting_speed_m_min")?;
    let kc = positive(material.kc11_n_mm2, "kc11_n_mm2")?;
    if !(0.0..1.0).contains(&material.mc) {
        return Err(OutOfRange("mc"));
    }
    let force = kc * b * a.powf(1.0 - material.mc);
    let lag = force_lag_s(a, v);
    let rpm = v * 1000.0 / (PI * body.outside_diameter_mm);
    let fz = f64::from(body.teeth) * rpm / 60.0;
    let r = fz / link.natural_frequency_hz;
    let zeta = link.damping_ratio;
    let amplification = 1.0
        / ((1.0 - r * r).powi(2) + (2.0 * zeta * r).powi(2)).sqrt()
        / (1.0 + (TAU * fz * lag).powi(2)).sqrt();
    let profile_error_um = force / (2.0 * link.stiffness_n_mm) * (1.0 + amplification) * 1000.0;
    let peak_load_n = link.stiffness_n_mm * profile_error_um / 1000.0;
    Ok(Deflection {
        side_force_n: force,
        force_lag_s: lag,
        cutter_rpm: rpm,
        tooth_passing_hz: fz,
        frequency_ratio: r,
        amplification,
        profile_error_um,
        peak_load_n,
    })
}

/// The cutting speeds (m/min, in `step_m_min` steps from `from` to `to`) at which the
/// predicted profile error stays within `limit_um`, as closed intervals.
pub fn speed_ranges(
    body: &CutterBody,
    material: &Material,
    cut: &SideCut,
    (from, to, step_m_min): (f64, f64, f64),
    limit_um: f64,
) -> Result<Vec<(f64, f64)>, OutOfRange> {
    positive(step_m_min, "step_m_min")?;
    let mut out: Vec<(f64, f64)> = Vec::new();
    let mut open: Option<f64> = None;
    let n = ((to - from) / step_m_min).floor().max(0.0) as u32;
    let mut last = from;
    for k in 0..=n {
        let v = from + f64::from(k) * step_m_min;
        let ok = deflection(
            body,
            material,
            &SideCut {
                cutting_speed_m_min: v,
                ..*cut
            },
        )?
        .profile_error_um
            <= limit_um;
        match (ok, open) {
            (true, None) => open = Some(v),
            (false, Some(start)) => {
                out.push((start, last));
                open = None;
            }
            _ => {}
        }
        last = v;
    }
    if let Some(start) = open {
        out.push((start, last));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seed 003's first cutter: unit 10 kg, width 2.5 mm, outside diameter 200 mm,
    /// E 2.1e5 MPa, lambda 0.3 (its 45 teeth from figure 5).
    fn seed_cutter() -> CutterBody {
        CutterBody {
            width_mm: 2.5,
            outside_diameter_mm: 200.0,
            mass_kg: 10.0,
            youngs_modulus_mpa: 2.1e5,
            log_decrement: 0.3,
            teeth: 45,
        }
    }

    #[test]
    fn the_seeds_cutters_by_its_own_equations() {
        // docs/plans/disk-cutters.md: C = 3 x 2.1e5 x 2.5^3 / 100^2 = 984.4 N/mm (the seed
        // says 3 kN/mm), T1 = sqrt(10 / 0.984e6) = 3.19 ms (it says 0.058 s), T2 =
        // 0.3 / pi T1 = 0.30 ms, f = 49.9 Hz (it says 12.6 Hz).
        let l = seed_cutter().link().unwrap();
        assert!((l.stiffness_n_mm - 984.375).abs() < 1e-9, "{l:?}");
        assert!((l.t1_s - 3.187e-3).abs() < 1e-6, "{l:?}");
        assert!((l.t2_s - 0.3044e-3).abs() < 1e-6, "{l:?}");
        assert!((l.natural_frequency_hz - 49.94).abs() < 0.01, "{l:?}");
        assert!((l.damping_ratio - 0.3 / TAU).abs() < 1e-12);
        // Its second: width 4 mm, diameter 160 mm: C = 6300 N/mm, T1 = 1.26 ms, 126 Hz.
        let l = CutterBody {
            width_mm: 4.0,
            outside_diameter_mm: 160.0,
            ..seed_cutter()
        }
        .link()
        .unwrap();
        assert!((l.stiffness_n_mm - 6300.0).abs() < 1e-9, "{l:?}");
        assert!(
            (l.t1_s - 1.260e-3).abs() < 1e-6 && (l.natural_frequency_hz - 126.3).abs() < 0.1,
            "{l:?}"
        );
    }

    #[test]
    fn the_force_lag_is_the_seeds_at_its_example() {
        // a = 0.5 mm at 100 m/min: 5.4e-4 s.
        let t = force_lag_s(0.5, 100.0);
        assert!((t - 5.4e-4).abs() < 0.05e-4, "{t}");
    }

    /// Steel (domain.md section 8) and a 0.05 x 5 mm side chip at 1 m/min: far below any
    /// resonance, static.
    fn steel_at_1_m_min() -> (Material, SideCut) {
        (
            Material {
                kc11_n_mm2: 2600.0,
                mc: 0.26,
            },
            SideCut {
                chip_thickness_mm: 0.05,
                chip_width_mm: 5.0,
                cutting_speed_m_min: 1.0,
            },
        )
    }

    #[test]
    fn the_deflection_is_static_far_below_resonance_and_peaks_at_it() {
        let body = seed_cutter();
        let (steel, cut) = steel_at_1_m_min();
        // At 1 m/min the teeth pass at 45 x 1.59 rpm / 60 = 1.19 Hz: static, F / C.
        let d = deflection(&body, &steel, &cut).unwrap();
        let force = 2600.0 * 5.0 * 0.05f64.powf(0.74);
        assert!((d.side_force_n - force).abs() < 1e-9);
        assert!((d.amplification - 1.0).abs() < 0.01, "{d:?}");
        assert!((d.profile_error_um - force / 984.375 * 1000.0).abs() < 0.01 * d.profile_error_um);
        // At resonance (f_z = 49.9 Hz: 41.8 m/min) about 1 / (2 zeta) = 10.5, less the lag.
        let v_res = 49.94 * 60.0 / 45.0 * std::f64::consts::PI * 200.0 / 1000.0;
        let at = deflection(
            &body,
            &steel,
            &SideCut {
                cutting_speed_m_min: v_res,
                ..cut
            },
        )
        .unwrap();
        assert!((at.frequency_ratio - 1.0).abs() < 1e-3, "{at:?}");
        assert!(at.amplification > 9.5 && at.amplification < 10.6, "{at:?}");
        // The speeds that keep the error within twice the static one avoid the resonance.
        let ranges = speed_ranges(&body, &steel, &cut, (1.0, 200.0, 0.5), 2.0 * d.profile_error_um).unwrap();
        assert!(ranges.len() >= 2, "{ranges:?}");
        assert!(
            ranges.iter().all(|&(a, b)| !(a..=b).contains(&v_res)),
            "{ranges:?}"
        );
        assert_eq!(ranges[0].0, 1.0);
    }

    #[test]
    fn the_load_limit_by_hand() {
        // b 2.5 mm, [sigma] 300 MPa: 2 x 6.25 x 300 = 3750 N; at 3750 N eq. 6's beam
        // (I = R b^3 = 100 x 15.625 mm^4) sees M = 3750 x 100 N mm at 1.25 mm from its axis:
        // 375 000 x 1.25 / 1562.5 = 300 MPa.
        let limit = seed_cutter().load_limit_n(300.0).unwrap();
        assert!((limit - 3750.0).abs() < 1e-9, "{limit}");
        assert!((limit * 100.0 * 1.25 / (100.0 * 2.5f64.powi(3)) - 300.0).abs() < 1e-9);
        assert_eq!(
            seed_cutter().load_limit_n(0.0),
            Err(OutOfRange("allowable_bending_mpa"))
        );
        // The peak load is the stiffness times the peak deflection: statically the mean force
        // and its fundamental, F.
        let (steel, cut) = steel_at_1_m_min();
        let d = deflection(&seed_cutter(), &steel, &cut).unwrap();
        assert!(
            (d.peak_load_n - d.side_force_n).abs() < 0.01 * d.side_force_n,
            "{d:?}"
        );
    }

    #[test]
    fn bad_values_are_named() {
        let mut b = seed_cutter();
        b.mass_kg = f64::NAN;
        assert_eq!(b.link(), Err(OutOfRange("mass_kg")));
        b = seed_cutter();
        b.teeth = 0;
        assert_eq!(b.link(), Err(OutOfRange("teeth")));
    }
}
