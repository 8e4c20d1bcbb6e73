//! The disk cutter's side deflection in the tooth-by-tooth cycle, integrated in time
//! (issue 17): seed 003's force lag `T_P dP/dt = F(t) - P` and cutter link
//! `T1^2 y'' + T2 y' + y = P / C`, with the constants of `hob_cutters::dynamics` (the same
//! model as the planner; the planner takes its closed-form steady state, this integrates it).
//!
//! The side force is the plant's own: one flank's chip (the worst case the planner also
//! takes, unbalanced), its thickness the axial feed per cutter tooth from the Y slide's real
//! speed and the spindle's, its width the flank engaged to the real depth (`depth /
//! cos(alpha)`), Kienzle's `k_c1.1 b a^(1 - m_c)`; each tooth's force rises and falls at the
//! tooth-passing frequency, `F (1 - cos(phase)) / 2` with the phase from the spindle's turning.
//! Each physics step is integrated exactly for its input held (the oscillator's transition
//! in closed form), so a cutter ringing at kilohertz needs no smaller step.

use hob_cutters::dynamics::{Link, Material, force_lag_s};
use std::f64::consts::TAU;

/// The disk cutter in the plant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiskCutter {
    pub link: Link,
    pub material: Material,
    pub pressure_angle_deg: f64,
    pub teeth: u32,
    pub outside_diameter_mm: f64,
}

/// Its state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutterLink {
    pub cutter: DiskCutter,
    /// The side deflection, mm, and its rate, mm/s.
    pub y_mm: f64,
    pub v_mm_s: f64,
    /// The lagging side force, N.
    pub force_n: f64,
    /// The teeth's phase, rad.
    phase_rad: f64,
    /// The axial feed averaged over a tooth's period (the chip is what the slide advanced
    /// between two teeth, not its speed at an instant: the ways' stick-slip), mm/s.
    feed_mm_s: f64,
    /// The largest deflection since [`CutterLink::take_peak`], mm.
    peak_mm: f64,
}

impl CutterLink {
    pub fn new(cutter: DiskCutter) -> Self {
        Self {
            cutter,
            y_mm: 0.0,
            v_mm_s: 0.0,
            force_n: 0.0,
            phase_rad: 0.0,
            feed_mm_s: 0.0,
            peak_mm: 0.0,
        }
    }

    /// One step of `dt_s` with the full side force `full_force_n` lagging by `lag_s`,
    /// the teeth passing at `tooth_hz`.
    pub fn advance_with(&mut self, dt_s: f64, full_force_n: f64, lag_s: f64, tooth_hz: f64) {
        self.phase_rad = (self.phase_rad + TAU * tooth_hz * dt_s).rem_euclid(TAU);
        let target = 0.5 * full_force_n * (1.0 - self.phase_rad.cos());
        let k = if lag_s > 0.0 {
            1.0 - (-dt_s / lag_s).exp()
        } else {
            1.0
        };
        self.force_n += (target - self.force_n) * k;
        // y'' = w^2 (u - y) - 2 zeta w y', u = P / C: exact for u held over the step.
        let l = &self.cutter.link;
        let w = 1.0 / l.t1_s;
        let zeta = l.damping_ratio;
        let u = self.force_n / l.stiffness_n_mm;
        let wd = w * (1.0 - zeta * zeta).max(0.0).sqrt();
        let sigma = zeta * w;
        let (s, c) = (wd * dt_s).sin_cos();
        let e = (-sigma * dt_s).exp();
        let (x0, v0) = (self.y_mm - u, self.v_mm_s);
        self.y_mm = u + e * (x0 * (c + sigma / wd * s) + v0 * s / wd);
        self.v_mm_s = e * (-x0 * w * w / wd * s + v0 * (c - sigma / wd * s));
        self.peak_mm = self.peak_mm.max(self.y_mm.abs());
    }

    /// One physics step of the cut: the chip from the slides' and the spindle's real motion.
    /// `depth_mm` 0 (out of the cut): no force.
    pub fn advance(&mut self, dt_s: f64, depth_mm: f64, axial_feed_mm_s: f64, spindle_rev_s: f64) {
        let c = self.cutter;
        let tooth_hz = f64::from(c.teeth) * spindle_rev_s.abs();
        if tooth_hz > 0.0 {
            self.feed_mm_s += (axial_feed_mm_s.abs() - self.feed_mm_s) * (dt_s * tooth_hz).min(1.0);
        }
        let (force, lag) = if depth_mm > 0.0 && tooth_hz > 0.0 && self.feed_mm_s > 0.0 {
            let a = self.feed_mm_s / tooth_hz;
            let b = depth_mm / c.pressure_angle_deg.to_radians().cos();
            let v_m_min = spindle_rev_s.abs() * std::f64::consts::PI * c.outside_diameter_mm * 60.0 / 1000.0;
            (
                c.material.kc11_n_mm2 * b * a.powf(1.0 - c.material.mc),
                force_lag_s(a, v_m_min),
            )
        } else {
            (0.0, 0.0)
        };
        self.advance_with(dt_s, force, lag, tooth_hz);
    }

    /// The largest deflection since the last call, um; starts anew.
    pub fn take_peak_um(&mut self) -> f64 {
        let p = self.peak_mm * 1000.0;
        self.peak_mm = 0.0;
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hob_cutters::dynamics::{CutterBody, SideCut, deflection};

    /// Seed 003's thin cutter (984 N/mm, 49.9 Hz, 45 teeth) in steel.
    fn seed() -> (CutterBody, Material) {
        (
            CutterBody {
                width_mm: 2.5,
                outside_diameter_mm: 200.0,
                mass_kg: 10.0,
                youngs_modulus_mpa: 2.1e5,
                log_decrement: 0.3,
                teeth: 45,
            },
            Material {
                kc11_n_mm2: 2600.0,
                mc: 0.26,
            },
        )
    }

    /// The time integration's steady peak against the planner's closed form: below, near and
    /// above resonance.
    #[test]
    fn integrated_in_time_it_peaks_where_the_closed_form_says() {
        let (body, material) = seed();
        let link = body.link().unwrap();
        for ratio in [0.3, 0.96, 1.5] {
            let tooth_hz = ratio * link.natural_frequency_hz;
            let rpm = tooth_hz * 60.0 / 45.0;
            let speed = rpm * std::f64::consts::PI * 200.0 / 1000.0;
            let cut = SideCut {
                chip_thickness_mm: 0.01,
                chip_width_mm: 2.0,
                cutting_speed_m_min: speed,
            };
            let d = deflection(&body, &material, &cut).unwrap();
            let mut c = CutterLink::new(DiskCutter {
                link,
                material,
                pressure_angle_deg: 20.0,
                teeth: 45,
                outside_diameter_mm: 200.0,
            });
            // 100 us steps (the plant's), 8 s: the transient (time constant T1 / zeta,
            // 67 ms) long gone; then the peak over the last second.
            let dt = 1e-4;
            for k in 0..80_000 {
                c.advance_with(dt, d.side_force_n, d.force_lag_s, tooth_hz);
                if k == 70_000 {
                    c.take_peak_um();
                }
            }
            let peak = c.take_peak_um();
            let err = (peak - d.profile_error_um).abs() / d.profile_error_um;
            assert!(
                err < 0.02,
                "ratio {ratio}: integrated {peak:.1} um, closed form {:.1} um",
                d.profile_error_um
            );
        }
    }

    #[test]
    fn out_of_the_cut_it_settles_to_nothing() {
        let (body, material) = seed();
        let mut c = CutterLink::new(DiskCutter {
            link: body.link().unwrap(),
            material,
            pressure_angle_deg: 20.0,
            teeth: 45,
            outside_diameter_mm: 200.0,
        });
        for _ in 0..10_000 {
            c.advance(1e-4, 2.0, 0.5, 0.5);
        }
        assert!(c.take_peak_um() > 1.0);
        for _ in 0..20_000 {
            c.advance(1e-4, 0.0, 0.0, 0.5);
        }
        assert!(c.y_mm.abs() < 1e-6 && c.force_n.abs() < 1e-6, "{c:?}");
    }
}
