//! Whether a cutter's profile cuts a gear's tooth space: the largest distance of the space's
//! active involute (both flanks) from the profile, with the cutter's tip on the gear's root
//! circle and its mid-plane on the space's centre line.

use crate::geometry::Point;
use crate::profile::Primitive;
use crate::space::Space;

/// Samples per flank.
const SAMPLES: u32 = 400;

/// How far a profile is from a gear's involute.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// The largest distance, um.
    pub deviation_um: f64,
    /// The gear radius where it is.
    pub at_gear_radius_mm: f64,
}

/// The distance from `q` to a primitive.
pub fn distance_mm(prim: &Primitive, q: Point) -> f64 {
    let (s, e) = (prim.start(), prim.end());
    let ends = q.dist(s).min(q.dist(e));
    match prim.arc() {
        None => {
            let d = e.minus(s);
            let t = (q.minus(s).dot(d) / d.dot(d)).clamp(0.0, 1.0);
            q.dist(s.plus(d.scale(t)))
        }
        Some((c, sweep)) => {
            // Within the arc's sweep: the distance to its circle; else to its nearer end.
            let (a, b) = (s.minus(c), q.minus(c));
            let mut angle = a.cross(b).atan2(a.dot(b));
            if sweep < 0.0 {
                angle = -angle;
            }
            if angle >= 0.0 && angle <= sweep.abs() {
                let r = c.dist(s);
                (q.dist(c) - r).abs()
            } else {
                ends
            }
        }
    }
}

/// The fit of `profile` (a cutter of `outside_radius_mm`) to `space`.
pub fn fit(space: &Space, profile: &[Primitive], outside_radius_mm: f64) -> Fit {
    let to_cutter = |q: Point| Point::new(q.x, outside_radius_mm + space.root_radius_mm - q.y);
    let mut worst = Fit {
        deviation_um: 0.0,
        at_gear_radius_mm: space.form_radius_mm,
    };
    for k in 0..=SAMPLES {
        let t = f64::from(k) / f64::from(SAMPLES);
        let right = space.active_point(t);
        for q in [right, right.mirror_x()] {
            let c = to_cutter(q);
            let d = profile
                .iter()
                .map(|p| distance_mm(p, c))
                .fold(f64::INFINITY, f64::min)
                * 1000.0;
            if d > worst.deviation_um {
                worst = Fit {
                    deviation_um: d,
                    at_gear_radius_mm: space.active_radius(t),
                };
            }
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::design;
    use crate::space::Gear;

    fn gear(z: u32) -> Gear {
        Gear {
            teeth: z,
            normal_module_mm: 8.0,
            pressure_angle_deg: 20.0,
            profile_shift: 0.0,
            helix_deg: 0.0,
        }
    }

    #[test]
    fn a_designed_profile_fits_its_gear_by_its_arcs_deviation() {
        let d = design(gear(24), 2, 40.0).unwrap();
        let f = fit(&d.space, &d.profile, 40.0);
        // The arcs' own deviation, sampled at other points: within a tenth of a um.
        assert!(
            (f.deviation_um - d.deviation_um).abs() < 0.1,
            "{f:?} {}",
            d.deviation_um
        );
    }

    #[test]
    fn a_cutter_for_another_tooth_count_is_seen_not_to_fit() {
        // The module cutter for z 24 on a z 40 gear: the flanks' curvature differs.
        let d = design(gear(24), 3, 40.0).unwrap();
        let other = Space::new(gear(40)).unwrap();
        let f = fit(&other, &d.profile, 40.0);
        assert!(f.deviation_um > 20.0 * d.deviation_um, "{f:?}");
    }

    #[test]
    fn the_distance_to_a_primitive_by_hand() {
        let line = Primitive::Line {
            start_mm: [0.0, 0.0],
            end_mm: [10.0, 0.0],
            tangent: false,
        };
        assert!((distance_mm(&line, Point::new(5.0, 3.0)) - 3.0).abs() < 1e-12);
        assert!((distance_mm(&line, Point::new(13.0, 4.0)) - 5.0).abs() < 1e-12);
        // A quarter arc of radius 5 about the origin, clockwise from (-5, 0) to (0, 5).
        let arc = Primitive::Arc {
            start_mm: [-5.0, 0.0],
            end_mm: [0.0, 5.0],
            radius_mm: 5.0,
            sense: crate::profile::ArcSense::Clockwise,
            tangent: false,
        };
        assert!((distance_mm(&arc, Point::new(-3.0, 4.0).scale(2.0)) - 5.0).abs() < 1e-12);
        // Outside its sweep: to the nearer end.
        assert!((distance_mm(&arc, Point::new(5.0, 0.0)) - 50f64.sqrt()).abs() < 1e-12);
    }
}
