//! The tooth space a disk cutter must cut: a gear's involute flanks, its form circle and its
//! root, in the plane of the cutter's axis.
//!
//! A disk cutter plunged through a spur gear's face cuts in the gear's transverse plane. For
//! a helical gear it cuts in the normal plane, where the space is approximately that of a
//! spur gear of the virtual number of teeth `z / cos^3(beta)` in the normal module (the
//! classical choice for form cutters; the module cutter numbers are chosen the same way).
//!
//! Gear coordinates: `x` across the space (tangential, the cutter's axis), `y` outward along
//! the space's centre line from the gear's axis.

use crate::geometry::Point;

/// The gear, as the cutter sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gear {
    pub teeth: u32,
    pub normal_module_mm: f64,
    pub pressure_angle_deg: f64,
    /// Profile shift coefficient `x` (0 for a standard gear).
    pub profile_shift: f64,
    pub helix_deg: f64,
}

/// Why a gear has no tooth space to design a cutter for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SpaceError {
    /// Fewer than 5 teeth, a module or pressure angle out of range, a helix of 45 deg or more.
    OutOfRange,
    /// The involute's form circle lies at or beyond the tip circle: no active flank.
    NoActiveFlank,
}

impl std::fmt::Display for SpaceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SpaceError::OutOfRange => write!(
                f,
                "the gear is out of range (at least 5 teeth, module > 0, pressure angle 10-35 deg, helix under 45 deg, shift within +-1)"
            ),
            SpaceError::NoActiveFlank => {
                write!(
                    f,
                    "the gear has no active involute (its form circle reaches its tip circle)"
                )
            }
        }
    }
}

/// The tooth space's radii and its flank.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Space {
    pub gear: Gear,
    /// Teeth of the spur gear the cutter sees (`z / cos^3 beta`).
    pub virtual_teeth: f64,
    pub pitch_radius_mm: f64,
    pub base_radius_mm: f64,
    /// Tip circle: `r + m (1 + x)`.
    pub tip_radius_mm: f64,
    /// Root circle: `r - m (1.25 - x)` (ISO 53 basic rack: dedendum 1.25 m).
    pub root_radius_mm: f64,
    /// Where the active involute starts: the form circle a standard mating gear's tip
    /// (addendum 1.0 m) reaches, `sqrt(r_b^2 + (r sin a - m (1 - x) / sin a)^2)`, not below
    /// the base circle.
    pub form_radius_mm: f64,
    /// Half the tooth's thickness at the pitch circle over the pitch radius, rad.
    half_tooth_rad: f64,
    pressure_angle_rad: f64,
}

fn inv(a: f64) -> f64 {
    a.tan() - a
}

impl Space {
    pub fn new(gear: Gear) -> Result<Self, SpaceError> {
        let (m, alpha_deg, beta_deg, x) = (
            gear.normal_module_mm,
            gear.pressure_angle_deg,
            gear.helix_deg,
            gear.profile_shift,
        );
        let in_range = gear.teeth >= 5
            && m.is_finite()
            && m > 0.0
            && (10.0..=35.0).contains(&alpha_deg)
            && beta_deg.is_finite()
            && beta_deg.abs() < 45.0
            && x.is_finite()
            && x.abs() <= 1.0;
        if !in_range {
            return Err(SpaceError::OutOfRange);
        }
        let alpha = alpha_deg.to_radians();
        let virtual_teeth = f64::from(gear.teeth) / beta_deg.to_radians().cos().powi(3);
        let r = 0.5 * m * virtual_teeth;
        let rb = r * alpha.cos();
        let form = (rb * rb + (r * alpha.sin() - m * (1.0 - x) / alpha.sin()).powi(2))
            .sqrt()
            .max(rb);
        let s = Space {
            gear,
            virtual_teeth,
            pitch_radius_mm: r,
            base_radius_mm: rb,
            tip_radius_mm: r + m * (1.0 + x),
            root_radius_mm: r - m * (1.25 - x),
            form_radius_mm: form,
            half_tooth_rad: (0.5 * std::f64::consts::PI + 2.0 * x * alpha.tan()) * m / (2.0 * r),
            pressure_angle_rad: alpha,
        };
        if s.form_radius_mm >= s.tip_radius_mm {
            return Err(SpaceError::NoActiveFlank);
        }
        Ok(s)
    }

    /// Half the space's angle at radius `r` (at or above the base circle), rad.
    pub fn half_space_rad(&self, r: f64) -> f64 {
        let alpha_r = (self.base_radius_mm / r).min(1.0).acos();
        std::f64::consts::PI / self.virtual_teeth
            - (self.half_tooth_rad + inv(self.pressure_angle_rad) - inv(alpha_r))
    }

    /// The space's right flank (the left flank of the tooth to the right) at radius `r`.
    pub fn flank_point(&self, r: f64) -> Point {
        let eta = self.half_space_rad(r);
        Point::new(r * eta.sin(), r * eta.cos())
    }

    /// The flank point at share `t` of the active involute's roll angle (0 the form circle,
    /// 1 the tip circle): the involute's natural parameter, so that equal shares are equal
    /// turns of its generating line.
    pub fn active_point(&self, t: f64) -> Point {
        self.flank_point(self.active_radius(t))
    }

    /// The radius at share `t` of the active involute's roll angle.
    pub fn active_radius(&self, t: f64) -> f64 {
        let rb = self.base_radius_mm;
        let roll = |r: f64| ((r / rb).powi(2) - 1.0).max(0.0).sqrt();
        let (a, b) = (roll(self.form_radius_mm), roll(self.tip_radius_mm));
        let u = a + (b - a) * t;
        rb * (1.0 + u * u).sqrt()
    }

    /// The unit normal of the right flank at radius `r`, pointing into the space (towards
    /// the centre line): the involute's normal is tangent to the base circle.
    pub fn flank_normal_into_space(&self, r: f64) -> Point {
        let eps = 1e-6 * self.pitch_radius_mm;
        let (lo, hi) = ((r - eps).max(self.base_radius_mm), r + eps);
        let tangent = self.flank_point(hi).minus(self.flank_point(lo)).unit();
        // The tangent rises outward; into the space is to its left (towards -x).
        tangent.perp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spur(z: u32, m: f64) -> Gear {
        Gear {
            teeth: z,
            normal_module_mm: m,
            pressure_angle_deg: 20.0,
            profile_shift: 0.0,
            helix_deg: 0.0,
        }
    }

    #[test]
    fn the_space_is_half_a_pitch_wide_at_the_pitch_circle() {
        // A standard spur gear: tooth and space are equal at the pitch circle, each half the
        // circular pitch pi m (z24 m8: 12.566 mm of arc, half-angle pi / (2 z)).
        let s = Space::new(spur(24, 8.0)).unwrap();
        assert!((s.pitch_radius_mm - 96.0).abs() < 1e-12);
        let eta = s.half_space_rad(96.0);
        assert!((eta - std::f64::consts::PI / 48.0).abs() < 1e-12, "{eta}");
        assert!((2.0 * 96.0 * eta - 4.0 * std::f64::consts::PI).abs() < 1e-9);
        // Radii by hand: r_b = 96 cos 20 = 90.210, tip 104, root 86.
        assert!((s.base_radius_mm - 90.2105).abs() < 1e-4);
        assert_eq!((s.tip_radius_mm, s.root_radius_mm), (104.0, 86.0));
        // Form circle: sqrt(90.2105^2 + (96 sin 20 - 8 / sin 20)^2)
        // = sqrt(8137.93 + (32.834 - 23.390)^2) = 90.703.
        assert!((s.form_radius_mm - 90.703).abs() < 1e-3, "{}", s.form_radius_mm);
        // The space widens outward.
        assert!(s.half_space_rad(104.0) > s.half_space_rad(96.0));
    }

    #[test]
    fn the_flank_is_an_involute_of_the_base_circle() {
        // The involute's normal is tangent to the base circle: the distance from the gear's
        // axis to the normal line through any flank point is r_b.
        let s = Space::new(spur(17, 5.0)).unwrap();
        for k in 0..=10 {
            let r = s.active_radius(f64::from(k) / 10.0);
            let q = s.flank_point(r);
            let n = s.flank_normal_into_space(r);
            let distance = q.cross(n).abs();
            assert!((distance - s.base_radius_mm).abs() < 1e-5, "{r}: {distance}");
        }
    }

    #[test]
    fn helical_gears_are_seen_in_the_normal_plane_and_bad_gears_refused() {
        let mut g = spur(31, 3.0);
        g.helix_deg = 20.0;
        let s = Space::new(g).unwrap();
        assert!((s.virtual_teeth - 31.0 / 20f64.to_radians().cos().powi(3)).abs() < 1e-12);
        assert_eq!(Space::new(spur(3, 3.0)), Err(SpaceError::OutOfRange));
        let mut g = spur(20, 3.0);
        g.pressure_angle_deg = f64::NAN;
        assert_eq!(Space::new(g), Err(SpaceError::OutOfRange));
    }
}
