//! Grinding a disk cutter's teeth to their profile by 3+2-axis linear interpolation on a
//! machining centre: seed 001 (Milutinovic et al., Tehnika 2022, section 4).
//!
//! The cutter's frame (the seed's G58): `Z` along the cutter's axis from its side face (`Z = 0`
//! to the width `b_g`), `X` radial through the tooth's tip, `Y` tangential. The tooth's
//! profile lies in the axial plane `XZ`; its cutting edge lies on the rake face.
//!
//! - **The edge on the rake face.** The rake face contains the cutter's axis direction and,
//!   in the `XY` plane, the line through the tip `(R_a, 0)` at the rake angle `gamma` to the
//!   radius. The edge point `K_s` of a profile point `K_p` at radius `rho` is where that
//!   line meets the circle of radius `rho`: turned about the axis by the angle
//!   `A = atan2(Y_s, X_s)` it passes through `K_p` as the cutter turns (the seed: "the
//!   coordinates of the edge follow from the angle of axis A"; `Z_s = Z_p`; `X_s` a little
//!   less than `X_p`). From `(R_a - s cos gamma)^2 + (s sin gamma)^2 = rho^2`:
//!   `s = R_a cos gamma - sqrt(rho^2 - R_a^2 sin^2 gamma)`,
//!   `X_s = R_a - s cos gamma`, `Y_s = -s sin gamma` (the face leans back from the cut).
//! - **The wheel.** A wheel of radius `R_t` with a rounded edge of radius `r_t` is steered
//!   by the centre `C_T` of that rounding: it lies `r_t` from the edge point along the
//!   profile's outward normal (its `Z` and `X` parts), and `Y_c = Y_s` less `R_f sin alpha` (the
//!   seed's figure 9: the wheel lowered by `R_f sin alpha`, `R_f` the cutter's radius, gives
//!   the clearance angle `alpha`). At a corner of the profile (a join that is not tangent)
//!   the rounding rolls around the corner: centres on the circle of radius `r_t` about it,
//!   within the chord tolerance, so that the linear moves do not cut into the corner.
//! - **3+2 axes.** The wheel's centre moves by linear interpolation (`G1`) through those
//!   points, the profile from `Z = 0` to `Z = b_g`; the cutter is indexed by its dividing head
//!   (`A`) for each tooth and the table's `B` stays at 0 (the seed tilts `B` for undercut
//!   profiles, which a gear cutter's tooth space does not have). Not checked here: the
//!   wheel's body against the rest of the tooth (collision), the grinding allowance per
//!   pass.

use crate::geometry::Point;
use crate::profile::{Primitive, discretise};
use std::fmt::Write as _;

/// The grinding set-up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grinding {
    pub outside_radius_mm: f64,
    pub rake_deg: f64,
    pub clearance_deg: f64,
    pub wheel_radius_mm: f64,
    pub wheel_edge_radius_mm: f64,
    pub cutter_teeth: u32,
    /// Discretisation along the axis (seed 001: "from Z = 0 to Z = b_g").
    pub spacing_mm: f64,
    pub chord_tolerance_mm: f64,
}

/// One point of the path: the profile point, its edge point on the rake face and the
/// wheel's centre, in the cutter's frame (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    /// `Z` (axial, from the side face) and `X` (radius) of the profile point.
    pub profile: [f64; 2],
    /// `X_s, Y_s, Z_s` of the edge point.
    pub edge: [f64; 3],
    /// The turn that brings the edge point into the axial plane, deg.
    pub a_deg: f64,
    /// `X_c, Y_c, Z_c` of the wheel's rounding centre.
    pub wheel: [f64; 3],
    /// A node of the profile (or a point of the rounding's roll around a corner).
    pub node: bool,
}

/// Why no path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GrindError {
    /// A value out of range (named).
    OutOfRange(&'static str),
    /// The rake face does not reach this radius (`rho < R_a sin gamma`).
    RakeMissesRadius { r_mm: f64 },
}

impl std::fmt::Display for GrindError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GrindError::OutOfRange(name) => write!(f, "{name} is out of range"),
            GrindError::RakeMissesRadius { r_mm } => write!(
                f,
                "the rake face does not reach the profile's radius {r_mm:.3} mm (a smaller rake angle)"
            ),
        }
    }
}

/// The edge point on the rake face of the profile point at radius `rho`: `(X_s, Y_s)`.
pub fn edge_point(outside_radius_mm: f64, rake_deg: f64, rho_mm: f64) -> Result<(f64, f64), GrindError> {
    let g = rake_deg.to_radians();
    let ra = outside_radius_mm;
    let disc = rho_mm * rho_mm - (ra * g.sin()).powi(2);
    if disc < 0.0 {
        return Err(GrindError::RakeMissesRadius { r_mm: rho_mm });
    }
    let s = ra * g.cos() - disc.sqrt();
    Ok((ra - s * g.cos(), -s * g.sin()))
}

fn check(g: &Grinding) -> Result<(), GrindError> {
    let ok = |v: f64, lo: f64, hi: f64| v.is_finite() && v >= lo && v <= hi;
    for (v, lo, hi, name) in [
        (g.outside_radius_mm, 1.0, 1000.0, "outside_radius_mm"),
        (g.rake_deg, -20.0, 30.0, "rake_deg"),
        (g.clearance_deg, 0.0, 30.0, "clearance_deg"),
        (g.wheel_radius_mm, 1.0, 500.0, "wheel_radius_mm"),
        (g.wheel_edge_radius_mm, 0.01, 50.0, "wheel_edge_radius_mm"),
        (g.spacing_mm, 0.001, 10.0, "spacing_mm"),
        (g.chord_tolerance_mm, 1e-5, 1.0, "chord_tolerance_mm"),
    ] {
        if !ok(v, lo, hi) {
            return Err(GrindError::OutOfRange(name));
        }
    }
    if g.cutter_teeth == 0 || g.cutter_teeth > 500 {
        return Err(GrindError::OutOfRange("cutter_teeth"));
    }
    Ok(())
}

/// The path for one tooth of a validated profile.
pub fn path(profile: &[Primitive], g: &Grinding) -> Result<Vec<PathPoint>, GrindError> {
    check(g)?;
    let pts = discretise(profile, g.spacing_mm, g.chord_tolerance_mm);
    let z0 = pts.first().map_or(0.0, |q| q.u_mm);
    let lowered = g.outside_radius_mm * g.clearance_deg.to_radians().sin();
    let point = |p: Point, normal: Point, node: bool| -> Result<PathPoint, GrindError> {
        let (xs, ys) = edge_point(g.outside_radius_mm, g.rake_deg, p.y)?;
        // The rounding's centre: offset from the edge point along the profile's normal, in
        // the edge point's plane (`Y_c = Y_s`, the seed), lowered for the clearance.
        let off = normal.scale(g.wheel_edge_radius_mm);
        Ok(PathPoint {
            profile: [p.x - z0, p.y],
            edge: [xs, ys, p.x - z0],
            a_deg: ys.atan2(xs).to_degrees(),
            wheel: [xs + off.y, ys - lowered, p.x + off.x - z0],
            node,
        })
    };
    let mut out = Vec::with_capacity(pts.len());
    for (k, q) in pts.iter().enumerate() {
        let prim = &profile[q.primitive];
        let p = Point::new(q.u_mm, q.r_mm);
        let normal = prim.direction(q.share).perp();
        out.push(point(p, normal, q.node)?);
        // A corner: roll the rounding around it to the next primitive's normal.
        if q.node && k > 0 && q.primitive + 1 < profile.len() {
            let next = profile[q.primitive + 1].direction(0.0).perp();
            let turn = normal.cross(next).atan2(normal.dot(next));
            let max_step = 2.0 * (1.0 - (g.chord_tolerance_mm / g.wheel_edge_radius_mm).min(1.0)).acos();
            let steps = (turn.abs() / max_step.max(1e-9)).ceil() as usize;
            for j in 1..=steps {
                let a = turn * j as f64 / steps as f64;
                let (sn, cs) = a.sin_cos();
                let n = Point::new(normal.x * cs - normal.y * sn, normal.x * sn + normal.y * cs);
                out.push(point(p, n, true)?);
            }
        }
    }
    Ok(out)
}

/// The G-code program: for each tooth, index the dividing head (`A`), approach above the
/// first point, grind along the path by `G1`, retract. Coordinates in the cutter's frame
/// (`G58`), mm.
pub fn gcode(name: &str, path: &[PathPoint], g: &Grinding, feed_mm_min: f64) -> String {
    let mut o = String::new();
    let clear = g.wheel_radius_mm.max(g.wheel_edge_radius_mm) + 5.0;
    let _ = writeln!(o, "%");
    let _ = writeln!(o, "(hob cutter grind: {name})");
    let _ = writeln!(
        o,
        "(3+2-axis grinding of a profile disk cutter, seed 001: the wheel's edge-rounding centre by linear moves)"
    );
    let _ = writeln!(
        o,
        "(cutter outside radius {:.3}, teeth {}, rake {} deg, clearance {} deg; wheel radius {:.3}, edge radius {:.3})",
        g.outside_radius_mm,
        g.cutter_teeth,
        g.rake_deg,
        g.clearance_deg,
        g.wheel_radius_mm,
        g.wheel_edge_radius_mm
    );
    let _ = writeln!(
        o,
        "(X radial, Y tangential, Z axial from the side face; A the dividing head, B 0)"
    );
    let _ = writeln!(o, "G21 G90 G17 G58");
    let _ = writeln!(o, "G0 B0");
    let Some(first) = path.first() else {
        let _ = writeln!(o, "M30");
        return o;
    };
    for tooth in 0..g.cutter_teeth {
        let a = 360.0 * f64::from(tooth) / f64::from(g.cutter_teeth);
        let _ = writeln!(o, "(tooth {} of {})", tooth + 1, g.cutter_teeth);
        let _ = writeln!(
            o,
            "G0 X{:.4} Y{:.4} Z{:.4}",
            first.wheel[0] + clear,
            first.wheel[1],
            first.wheel[2]
        );
        let _ = writeln!(o, "G0 A{a:.4}");
        let _ = writeln!(
            o,
            "G1 X{:.4} Y{:.4} Z{:.4} F{feed_mm_min:.0}",
            first.wheel[0], first.wheel[1], first.wheel[2]
        );
        for p in &path[1..] {
            let _ = writeln!(o, "G1 X{:.4} Y{:.4} Z{:.4}", p.wheel[0], p.wheel[1], p.wheel[2]);
        }
        let last = path[path.len() - 1];
        let _ = writeln!(o, "G0 X{:.4}", last.wheel[0] + clear);
    }
    let _ = writeln!(o, "M30");
    let _ = writeln!(o, "%");
    o
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::ArcSense;

    fn setup(rake: f64) -> Grinding {
        Grinding {
            outside_radius_mm: 40.0,
            rake_deg: rake,
            clearance_deg: 0.0,
            wheel_radius_mm: 50.0,
            wheel_edge_radius_mm: 1.0,
            cutter_teeth: 3,
            spacing_mm: 0.5,
            chord_tolerance_mm: 0.001,
        }
    }

    #[test]
    fn the_edge_point_by_hand() {
        // Zero rake: the edge is the profile.
        let (x, y) = edge_point(40.0, 0.0, 30.0).unwrap();
        assert!((x - 30.0).abs() < 1e-12 && y.abs() < 1e-12);
        // Rake 10 deg, R_a 40, rho 30: s = 40 cos 10 - sqrt(900 - 1600 sin^2 10) = 10.208,
        // X_s = 40 - s cos 10 = 29.947, Y_s = -s sin 10 = -1.7726.
        let (x, y) = edge_point(40.0, 10.0, 30.0).unwrap();
        assert!((x - 29.947).abs() < 1e-3 && (y + 1.7726).abs() < 1e-4, "{x} {y}");
        assert!((x.hypot(y) - 30.0).abs() < 1e-12);
        assert_eq!(
            edge_point(40.0, 30.0, 10.0),
            Err(GrindError::RakeMissesRadius { r_mm: 10.0 })
        );
    }

    #[test]
    fn a_straight_profile_is_ground_from_one_rounding_radius_above_it() {
        // A flat top at radius 40 from u = -5 to 5: the centre path is the line at 41.
        let chain = [Primitive::Line {
            start_mm: [-5.0, 40.0],
            end_mm: [5.0, 40.0],
            tangent: false,
        }];
        let p = path(&chain, &setup(0.0)).unwrap();
        assert_eq!(p.len(), 21);
        for q in &p {
            assert!(
                (q.wheel[0] - 41.0).abs() < 1e-12 && q.wheel[1].abs() < 1e-12,
                "{q:?}"
            );
        }
        // Z from the side face: 0 to the width.
        assert_eq!((p[0].wheel[2], p[20].wheel[2]), (0.0, 10.0));
        // The clearance lowers the wheel by R_f sin(alpha): 40 sin 6 = 4.181 mm.
        let mut g = setup(0.0);
        g.clearance_deg = 6.0;
        let p = path(&chain, &g).unwrap();
        assert!((p[0].wheel[1] + 40.0 * 6f64.to_radians().sin()).abs() < 1e-12);
    }

    #[test]
    fn a_single_arc_is_ground_along_its_offset_and_corners_are_rolled_around() {
        // A convex arc of radius 5 about (0, 35), from (-5, 35) over (0, 40) to (5, 35): with
        // zero rake the centres lie on the circle of radius 5 + 1 about (0, 35).
        let chain = [
            Primitive::Arc {
                start_mm: [-5.0, 35.0],
                end_mm: [0.0, 40.0],
                radius_mm: 5.0,
                sense: ArcSense::Clockwise,
                tangent: false,
            },
            Primitive::Arc {
                start_mm: [0.0, 40.0],
                end_mm: [5.0, 35.0],
                radius_mm: 5.0,
                sense: ArcSense::Clockwise,
                tangent: true,
            },
        ];
        let p = path(&chain, &setup(0.0)).unwrap();
        for q in &p {
            let d = (q.wheel[2] - 5.0).hypot(q.wheel[0] - 35.0);
            assert!((d - 6.0).abs() < 1e-9, "{q:?}");
        }
        // A corner: a trapezoid's top meets its flank at 70 deg: the rounding rolls around the
        // corner, every centre there 1 mm from it.
        let t = 20f64.to_radians().tan() * 10.0;
        let chain = [
            Primitive::Line {
                start_mm: [-5.0 - t, 30.0],
                end_mm: [-5.0, 40.0],
                tangent: false,
            },
            Primitive::Line {
                start_mm: [-5.0, 40.0],
                end_mm: [5.0, 40.0],
                tangent: false,
            },
        ];
        let p = path(&chain, &setup(0.0)).unwrap();
        let corner_z = t;
        let around: Vec<&PathPoint> = p
            .iter()
            .filter(|q| ((q.wheel[2] - corner_z).hypot(q.wheel[0] - 40.0) - 1.0).abs() < 1e-9)
            .collect();
        assert!(around.len() > 10, "{}", around.len());
        // No centre is closer than the rounding to the corner (no gouge).
        for q in &p {
            assert!((q.wheel[2] - corner_z).hypot(q.wheel[0] - 40.0) >= 1.0 - 1e-9);
        }
    }

    #[test]
    fn a_symmetric_space_gives_a_symmetric_program_for_every_tooth() {
        let d = crate::design::design(
            crate::space::Gear {
                teeth: 24,
                normal_module_mm: 8.0,
                pressure_angle_deg: 20.0,
                profile_shift: 0.0,
                helix_deg: 0.0,
            },
            2,
            40.0,
        )
        .unwrap();
        let p = path(&d.profile, &setup(0.0)).unwrap();
        let width = p[p.len() - 1].wheel[2] + p[0].wheel[2];
        let n = p.len();
        for k in 0..n {
            let (a, b) = (p[k], p[n - 1 - k]);
            assert!((a.wheel[0] - b.wheel[0]).abs() < 1e-6, "{k}: {a:?} {b:?}");
            assert!((a.wheel[2] + b.wheel[2] - width).abs() < 1e-6, "{k}");
        }
        let code = gcode("z24 m8", &p, &setup(0.0), 200.0);
        assert_eq!(code.matches("G0 A").count(), 3);
        assert!(code.contains("G0 A120.0000") && code.contains("G0 A240.0000"));
        assert_eq!(code.matches("\nG1 ").count(), 3 * n);
        assert!(code.trim_end().ends_with('%'));
        // Only linear moves: no circular interpolation.
        assert!(!code.lines().any(|l| l.starts_with("G2 ") || l.starts_with("G3 ")));
    }
}
