//! A disk cutter's profile: a chain of line and arc primitives in its axial plane (seed 001:
//! "complex profiles of disk and shank cutters are built from straight and circular
//! segments, primitives"), validated and discretised along the cutter's axis with the node
//! points, where one primitive meets the next, kept exactly.
//!
//! Coordinates `[u, r]` in mm: `u` along the cutter's axis from its mid-plane, `r` the
//! radius from its axis. The chain runs across the cutter's width, `u` rising (seed 001
//! discretises "from Z = 0 to Z = b_g"): every primitive advances along the axis.

use crate::geometry::Point;
use serde::{Deserialize, Serialize};
use std::fmt;

/// The sense an arc turns from its start to its end, seen with `u` to the right and `r` up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ArcSense {
    Clockwise,
    CounterClockwise,
}

/// One primitive. `tangent` says the primitive must leave its start along the direction the
/// one before arrives in (checked, to 1e-4 rad); the first primitive's is ignored.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Primitive {
    Line {
        start_mm: [f64; 2],
        end_mm: [f64; 2],
        #[serde(default)]
        tangent: bool,
    },
    /// The shorter of the two arcs of `radius_mm` from `start_mm` to `end_mm` turning in
    /// `sense` (at most a half circle: split longer ones).
    Arc {
        start_mm: [f64; 2],
        end_mm: [f64; 2],
        radius_mm: f64,
        sense: ArcSense,
        #[serde(default)]
        tangent: bool,
    },
}

fn p(a: [f64; 2]) -> Point {
    Point::new(a[0], a[1])
}

impl Primitive {
    pub fn start(&self) -> Point {
        match self {
            Primitive::Line { start_mm, .. } | Primitive::Arc { start_mm, .. } => p(*start_mm),
        }
    }

    pub fn end(&self) -> Point {
        match self {
            Primitive::Line { end_mm, .. } | Primitive::Arc { end_mm, .. } => p(*end_mm),
        }
    }

    fn tangent_flag(&self) -> bool {
        match self {
            Primitive::Line { tangent, .. } | Primitive::Arc { tangent, .. } => *tangent,
        }
    }

    /// An arc's centre and signed sweep (positive counter-clockwise), rad; None for a line
    /// or an arc whose chord is longer than its diameter.
    pub fn arc(&self) -> Option<(Point, f64)> {
        let Primitive::Arc { radius_mm, sense, .. } = *self else {
            return None;
        };
        let (s, e) = (self.start(), self.end());
        let chord = e.minus(s);
        let half = 0.5 * chord.norm();
        if radius_mm.is_nan() || radius_mm <= 0.0 || half > radius_mm * (1.0 + 1e-12) || half == 0.0 {
            return None;
        }
        let h = (radius_mm * radius_mm - half * half).max(0.0).sqrt();
        let side = match sense {
            ArcSense::CounterClockwise => 1.0,
            ArcSense::Clockwise => -1.0,
        };
        let centre = s.plus(chord.scale(0.5)).plus(chord.unit().perp().scale(side * h));
        let sweep = 2.0 * (half / radius_mm).min(1.0).asin() * side;
        Some((centre, sweep))
    }

    /// The point at share `t` (0..=1) of the primitive.
    pub fn at(&self, t: f64) -> Point {
        match self.arc() {
            None => self.start().plus(self.end().minus(self.start()).scale(t)),
            Some((c, sweep)) => {
                let v = self.start().minus(c);
                let (sn, cs) = (sweep * t).sin_cos();
                c.plus(Point::new(v.x * cs - v.y * sn, v.x * sn + v.y * cs))
            }
        }
    }

    /// The unit direction of travel at share `t`.
    pub fn direction(&self, t: f64) -> Point {
        match self.arc() {
            None => self.end().minus(self.start()).unit(),
            Some((c, sweep)) => {
                let radial = self.at(t).minus(c).unit();
                if sweep > 0.0 {
                    radial.perp()
                } else {
                    radial.perp().scale(-1.0)
                }
            }
        }
    }

    /// Length along the primitive, mm.
    pub fn length_mm(&self) -> f64 {
        match (self, self.arc()) {
            (Primitive::Arc { radius_mm, .. }, Some((_, sweep))) => radius_mm * sweep.abs(),
            _ => self.start().dist(self.end()),
        }
    }

    /// The largest radius from the cutter's axis anywhere on the primitive.
    pub fn max_r_mm(&self) -> f64 {
        let ends = self.start().y.max(self.end().y);
        match (self, self.arc()) {
            (Primitive::Arc { radius_mm, .. }, Some((c, sweep))) => {
                // The circle's top (direction +r) if the arc passes it.
                let a0 = self.start().minus(c);
                let a0 = a0.y.atan2(a0.x);
                let top = std::f64::consts::FRAC_PI_2;
                let mut d = (top - a0).rem_euclid(std::f64::consts::TAU);
                if sweep < 0.0 {
                    d = std::f64::consts::TAU - d;
                }
                if d <= sweep.abs() {
                    ends.max(c.y + radius_mm)
                } else {
                    ends
                }
            }
            _ => ends,
        }
    }
}

/// Why a profile is refused; the primitive is numbered from 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ProfileError {
    Empty,
    NotFinite {
        primitive: usize,
    },
    /// Zero length.
    Degenerate {
        primitive: usize,
    },
    /// The chord is longer than the arc's diameter.
    RadiusTooSmall {
        primitive: usize,
        radius_mm: f64,
        chord_mm: f64,
    },
    /// The primitive does not start where the one before ends.
    Gap {
        primitive: usize,
        gap_mm: f64,
    },
    /// Marked tangent, but it turns by this much at its start.
    NotTangent {
        primitive: usize,
        angle_deg: f64,
    },
    /// It goes back along the cutter's axis (or runs across it) somewhere.
    NotAdvancing {
        primitive: usize,
    },
    /// It reaches beyond the cutter's outside radius.
    OutsideDiameter {
        primitive: usize,
        r_mm: f64,
        outside_radius_mm: f64,
    },
    /// It reaches inside the cutter's axis.
    BelowAxis {
        primitive: usize,
        r_mm: f64,
    },
}

impl fmt::Display for ProfileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ProfileError::Empty => write!(f, "the profile has no primitive"),
            ProfileError::NotFinite { primitive } => {
                write!(f, "primitive {primitive}: a coordinate or radius is not a number")
            }
            ProfileError::Degenerate { primitive } => {
                write!(f, "primitive {primitive}: starts where it ends")
            }
            ProfileError::RadiusTooSmall {
                primitive,
                radius_mm,
                chord_mm,
            } => write!(
                f,
                "primitive {primitive}: an arc of radius {radius_mm} mm cannot span {chord_mm:.4} mm"
            ),
            ProfileError::Gap { primitive, gap_mm } => write!(
                f,
                "primitive {primitive}: starts {gap_mm:.4} mm from where primitive {} ends",
                primitive - 1
            ),
            ProfileError::NotTangent { primitive, angle_deg } => write!(
                f,
                "primitive {primitive}: marked tangent but turns by {angle_deg:.3} deg where it meets primitive {}",
                primitive - 1
            ),
            ProfileError::NotAdvancing { primitive } => write!(
                f,
                "primitive {primitive}: goes back along the cutter's axis (the profile must advance across the width)"
            ),
            ProfileError::OutsideDiameter {
                primitive,
                r_mm,
                outside_radius_mm,
            } => write!(
                f,
                "primitive {primitive}: reaches radius {r_mm:.3} mm, beyond the cutter's outside radius {outside_radius_mm:.3} mm"
            ),
            ProfileError::BelowAxis { primitive, r_mm } => {
                write!(
                    f,
                    "primitive {primitive}: reaches radius {r_mm:.3} mm, inside the cutter's axis"
                )
            }
        }
    }
}

/// How far apart consecutive primitives may be, mm.
pub const JOIN_TOLERANCE_MM: f64 = 1e-6;
/// How much a tangent join may turn, rad.
pub const TANGENT_TOLERANCE_RAD: f64 = 1e-4;

/// Checks a chain against a cutter of `outside_radius_mm`; the first problem found.
pub fn validate(chain: &[Primitive], outside_radius_mm: f64) -> Result<(), ProfileError> {
    if chain.is_empty() {
        return Err(ProfileError::Empty);
    }
    for (i, prim) in chain.iter().enumerate() {
        let n = i + 1;
        let finite = prim.start().is_finite()
            && prim.end().is_finite()
            && !matches!(prim, Primitive::Arc { radius_mm, .. } if !radius_mm.is_finite());
        if !finite {
            return Err(ProfileError::NotFinite { primitive: n });
        }
        if prim.start().dist(prim.end()) <= JOIN_TOLERANCE_MM {
            return Err(ProfileError::Degenerate { primitive: n });
        }
        if let Primitive::Arc { radius_mm, .. } = *prim
            && prim.arc().is_none()
        {
            return Err(ProfileError::RadiusTooSmall {
                primitive: n,
                radius_mm,
                chord_mm: prim.start().dist(prim.end()),
            });
        }
        if i > 0 {
            let before = &chain[i - 1];
            let gap_mm = before.end().dist(prim.start());
            if gap_mm > JOIN_TOLERANCE_MM {
                return Err(ProfileError::Gap { primitive: n, gap_mm });
            }
            if prim.tangent_flag() {
                let (a, b) = (before.direction(1.0), prim.direction(0.0));
                let angle = a.cross(b).atan2(a.dot(b)).abs();
                if angle > TANGENT_TOLERANCE_RAD {
                    return Err(ProfileError::NotTangent {
                        primitive: n,
                        angle_deg: angle.to_degrees(),
                    });
                }
            }
        }
        // Advancing along the axis: sampled (an arc may turn back past its vertical tangent).
        let samples = 64;
        let mut last = prim.start().x;
        for k in 1..=samples {
            let u = prim.at(f64::from(k) / f64::from(samples)).x;
            if u <= last {
                return Err(ProfileError::NotAdvancing { primitive: n });
            }
            last = u;
        }
        let r_max = prim.max_r_mm();
        if r_max > outside_radius_mm + JOIN_TOLERANCE_MM {
            return Err(ProfileError::OutsideDiameter {
                primitive: n,
                r_mm: r_max,
                outside_radius_mm,
            });
        }
        let r_min = prim.start().y.min(prim.end().y);
        if r_min <= 0.0 {
            return Err(ProfileError::BelowAxis {
                primitive: n,
                r_mm: r_min,
            });
        }
    }
    Ok(())
}

/// A point of the discretised profile.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ProfilePoint {
    pub u_mm: f64,
    pub r_mm: f64,
    /// Where one primitive meets the next (or the chain's ends): kept exactly.
    pub node: bool,
    /// The primitive it lies on (a node: the one it ends, or for the first point, starts)
    /// and its share along it.
    pub primitive: usize,
    pub share: f64,
}

/// The profile as points along the cutter's axis (a validated chain): on each primitive,
/// evenly spaced in `u` at most `spacing_mm` apart, and on arcs closer still where the chord
/// between neighbours would leave the arc by more than `chord_tolerance_mm`; the node points
/// exactly as given.
pub fn discretise(chain: &[Primitive], spacing_mm: f64, chord_tolerance_mm: f64) -> Vec<ProfilePoint> {
    let mut out = Vec::new();
    for (i, prim) in chain.iter().enumerate() {
        if i == 0 {
            let s = prim.start();
            out.push(ProfilePoint {
                u_mm: s.x,
                r_mm: s.y,
                node: true,
                primitive: 0,
                share: 0.0,
            });
        }
        let width = prim.end().x - prim.start().x;
        let steps = (width / spacing_mm).ceil().max(1.0) as usize;
        // Evenly in u, then on arcs halved where the sagitta R (1 - cos(a / 2)) of a chord
        // over angle a would exceed the tolerance (near a steep tangent even steps in u
        // are large steps along the arc).
        let mut shares: Vec<f64> = (0..=steps)
            .map(|k| match k {
                0 => 0.0,
                k if k == steps => 1.0,
                k => share_at_u(prim, prim.start().x + width * k as f64 / steps as f64),
            })
            .collect();
        if let (Primitive::Arc { radius_mm, .. }, Some((_, sweep))) = (prim, prim.arc()) {
            let max_angle = 2.0 * (1.0 - (chord_tolerance_mm / radius_mm).min(1.0)).acos();
            if max_angle > 0.0 {
                let max_share = max_angle / sweep.abs();
                let mut refined = vec![0.0];
                for w in shares.windows(2) {
                    let parts = ((w[1] - w[0]) / max_share).ceil().max(1.0) as usize;
                    for j in 1..=parts {
                        refined.push(w[0] + (w[1] - w[0]) * j as f64 / parts as f64);
                    }
                }
                shares = refined;
            }
        }
        let last = shares.len() - 1;
        for (k, &t) in shares.iter().enumerate().skip(1) {
            let node = k == last;
            let q = if node { prim.end() } else { prim.at(t) };
            out.push(ProfilePoint {
                u_mm: q.x,
                r_mm: q.y,
                node,
                primitive: i,
                share: t,
            });
        }
    }
    out
}

/// The share of an advancing primitive at axial position `u` (bisection).
fn share_at_u(prim: &Primitive, u: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if prim.at(mid).x < u {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(s: [f64; 2], e: [f64; 2]) -> Primitive {
        Primitive::Line {
            start_mm: s,
            end_mm: e,
            tangent: false,
        }
    }

    fn arc(s: [f64; 2], e: [f64; 2], r: f64, sense: ArcSense, tangent: bool) -> Primitive {
        Primitive::Arc {
            start_mm: s,
            end_mm: e,
            radius_mm: r,
            sense,
            tangent,
        }
    }

    /// A straight-sided profile: a trapezoid tooth, 20 deg flanks, 10 mm deep, a flat tip.
    fn trapezoid() -> Vec<Primitive> {
        let t = 20f64.to_radians().tan() * 10.0;
        vec![
            line([-5.0 - t, 40.0], [-5.0, 50.0]),
            line([-5.0, 50.0], [5.0, 50.0]),
            line([5.0, 50.0], [5.0 + t, 40.0]),
        ]
    }

    #[test]
    fn a_straight_sided_profile_is_valid_and_discretised_on_its_nodes() {
        let chain = trapezoid();
        assert_eq!(validate(&chain, 50.0), Ok(()));
        let pts = discretise(&chain, 0.5, 0.001);
        let nodes: Vec<&ProfilePoint> = pts.iter().filter(|q| q.node).collect();
        assert_eq!(nodes.len(), 4);
        assert_eq!((nodes[1].u_mm, nodes[1].r_mm), (-5.0, 50.0));
        assert_eq!((nodes[2].u_mm, nodes[2].r_mm), (5.0, 50.0));
        // At most 0.5 mm apart along the axis, on the lines (hand: the flank at u = -5 - t / 2
        // stands at r = 45).
        for w in pts.windows(2) {
            assert!(w[1].u_mm > w[0].u_mm && w[1].u_mm - w[0].u_mm <= 0.5 + 1e-9);
        }
        let t = 20f64.to_radians().tan() * 10.0;
        let mid = chain[0].at(share_at_u(&chain[0], -5.0 - t / 2.0));
        assert!((mid.y - 45.0).abs() < 1e-9, "{mid:?}");
        // Beyond the outside radius: refused with the figure.
        assert_eq!(
            validate(&chain, 49.0),
            Err(ProfileError::OutsideDiameter {
                primitive: 1,
                r_mm: 50.0,
                outside_radius_mm: 49.0
            })
        );
    }

    #[test]
    fn a_single_arc_tip_reaches_its_top_and_is_discretised_within_the_chord_tolerance() {
        // A full-radius tip: a half circle of radius 5 centred at (0, 45), clockwise from
        // (-5, 45) over the top (0, 50) to (5, 45).
        let chain = [
            arc([-5.0, 45.0], [0.0, 50.0], 5.0, ArcSense::Clockwise, false),
            arc([0.0, 50.0], [5.0, 45.0], 5.0, ArcSense::Clockwise, true),
        ];
        let (c, sweep) = chain[0].arc().unwrap();
        assert!(c.dist(Point::new(0.0, 45.0)) < 1e-12 && (sweep + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((chain[0].max_r_mm() - 50.0).abs() < 1e-12);
        assert_eq!(validate(&chain, 50.0), Ok(()));
        assert!(matches!(
            validate(&chain, 49.9),
            Err(ProfileError::OutsideDiameter { .. })
        ));
        let tol = 0.002;
        let pts = discretise(&chain, 1.0, tol);
        for w in pts.windows(2) {
            // The chord's middle is within the tolerance of the circle.
            let m = Point::new(0.5 * (w[0].u_mm + w[1].u_mm), 0.5 * (w[0].r_mm + w[1].r_mm));
            assert!(5.0 - m.dist(Point::new(0.0, 45.0)) <= tol + 1e-9);
        }
        for q in &pts {
            assert!((Point::new(q.u_mm, q.r_mm).dist(Point::new(0.0, 45.0)) - 5.0).abs() < 1e-9);
        }
        // The arc's length: a quarter circle.
        assert!((chain[0].length_mm() - 2.5 * std::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn each_defect_is_named_with_its_primitive() {
        let mut chain = trapezoid();
        chain[1] = line([-4.9, 50.0], [5.0, 50.0]);
        assert!(matches!(
            validate(&chain, 60.0),
            Err(ProfileError::Gap { primitive: 2, gap_mm }) if (gap_mm - 0.1).abs() < 1e-9
        ));
        let mut chain = trapezoid();
        chain[1] = Primitive::Line {
            start_mm: [-5.0, 50.0],
            end_mm: [5.0, 50.0],
            tangent: true,
        };
        assert!(matches!(
            validate(&chain, 60.0),
            Err(ProfileError::NotTangent { primitive: 2, angle_deg }) if (angle_deg - 70.0).abs() < 1e-9
        ));
        let chain = [arc([0.0, 40.0], [20.0, 40.0], 5.0, ArcSense::Clockwise, false)];
        assert!(matches!(
            validate(&chain, 60.0),
            Err(ProfileError::RadiusTooSmall { primitive: 1, .. })
        ));
        let chain = [line([5.0, 40.0], [0.0, 45.0])];
        assert_eq!(
            validate(&chain, 60.0),
            Err(ProfileError::NotAdvancing { primitive: 1 })
        );
        assert_eq!(validate(&[], 60.0), Err(ProfileError::Empty));
        let text = ProfileError::Gap {
            primitive: 2,
            gap_mm: 0.1,
        }
        .to_string();
        assert_eq!(text, "primitive 2: starts 0.1000 mm from where primitive 1 ends");
    }

    #[test]
    fn a_profile_reads_from_toml() {
        #[derive(Deserialize)]
        struct File {
            profile: Vec<Primitive>,
        }
        let f: File = toml::from_str(
            r#"
profile = [
  { kind = "line", start_mm = [-8.64, 40.0], end_mm = [-5.0, 50.0] },
  { kind = "arc", start_mm = [-5.0, 50.0], end_mm = [5.0, 50.0], radius_mm = 20.0, sense = "clockwise" },
]
"#,
        )
        .unwrap();
        assert_eq!(f.profile.len(), 2);
        assert!(matches!(
            f.profile[1],
            Primitive::Arc {
                sense: ArcSense::Clockwise,
                ..
            }
        ));
    }
}
