//! Plane geometry of the profile: points, the circle through three points, a fillet
//! between two lines.

use serde::{Deserialize, Serialize};

/// A point (or vector) in a plane, mm.
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize, Serialize)]
pub struct Point {
    pub x: f64,
    pub y: f64,
}

impl Point {
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    pub fn minus(self, o: Point) -> Point {
        Point::new(self.x - o.x, self.y - o.y)
    }

    pub fn plus(self, o: Point) -> Point {
        Point::new(self.x + o.x, self.y + o.y)
    }

    pub fn scale(self, k: f64) -> Point {
        Point::new(self.x * k, self.y * k)
    }

    pub fn dot(self, o: Point) -> f64 {
        self.x * o.x + self.y * o.y
    }

    /// The z component of the cross product (positive: `o` is counter-clockwise of `self`).
    pub fn cross(self, o: Point) -> f64 {
        self.x * o.y - self.y * o.x
    }

    pub fn norm(self) -> f64 {
        self.x.hypot(self.y)
    }

    pub fn dist(self, o: Point) -> f64 {
        self.minus(o).norm()
    }

    /// The unit vector along this one (zero stays zero).
    pub fn unit(self) -> Point {
        let n = self.norm();
        if n > 0.0 { self.scale(1.0 / n) } else { self }
    }

    /// Turned a quarter counter-clockwise.
    pub fn perp(self) -> Point {
        Point::new(-self.y, self.x)
    }

    /// Mirrored in the y axis.
    pub fn mirror_x(self) -> Point {
        Point::new(-self.x, self.y)
    }

    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }
}

/// The circle through three points: centre and radius (None when they are on a line).
pub fn circle_through(a: Point, b: Point, c: Point) -> Option<(Point, f64)> {
    let d = 2.0 * (a.x * (b.y - c.y) + b.x * (c.y - a.y) + c.x * (a.y - b.y));
    let scale = a.dist(b).max(b.dist(c)).max(a.dist(c));
    if d.abs() <= 1e-12 * scale * scale {
        return None;
    }
    let (a2, b2, c2) = (a.dot(a), b.dot(b), c.dot(c));
    let centre = Point::new(
        (a2 * (b.y - c.y) + b2 * (c.y - a.y) + c2 * (a.y - b.y)) / d,
        (a2 * (c.x - b.x) + b2 * (a.x - c.x) + c2 * (b.x - a.x)) / d,
    );
    Some((centre, centre.dist(a)))
}

/// The fillet of radius `r` in the corner where a line through `p1` along `d1` meets a line
/// through `p2` along `d2`, on the side both directions point away from: its centre and
/// the two tangent points (on the first line, on the second). None for parallel lines.
pub fn fillet(p1: Point, d1: Point, p2: Point, d2: Point, r: f64) -> Option<(Point, Point, Point)> {
    let (d1, d2) = (d1.unit(), d2.unit());
    let denom = d1.cross(d2);
    if denom.abs() < 1e-12 {
        return None;
    }
    // The corner: p1 + t d1 = p2 + s d2.
    let t = p2.minus(p1).cross(d2) / denom;
    let corner = p1.plus(d1.scale(t));
    // The lines leave the corner along -d1 (back to p1) and +d2 (on to p2); the fillet's
    // centre lies on the bisector of those two, at r / sin(half the angle between them).
    let (a, b) = (d1.scale(-1.0), d2);
    let half = 0.5 * a.dot(b).clamp(-1.0, 1.0).acos();
    let along = r / half.tan();
    let t1 = corner.plus(a.scale(along));
    let t2 = corner.plus(b.scale(along));
    let bisector = a.plus(b).unit();
    let centre = corner.plus(bisector.scale(r / half.sin()));
    Some((centre, t1, t2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_circle_through_three_points_of_a_circle_is_that_circle() {
        let (c, r) = (Point::new(3.0, -2.0), 7.5);
        let on = |deg: f64| {
            let a = deg.to_radians();
            Point::new(c.x + r * a.cos(), c.y + r * a.sin())
        };
        let (got, gr) = circle_through(on(10.0), on(100.0), on(250.0)).unwrap();
        assert!(got.dist(c) < 1e-12 && (gr - r).abs() < 1e-12, "{got:?} {gr}");
        assert!(circle_through(Point::new(0.0, 0.0), Point::new(1.0, 1.0), Point::new(2.0, 2.0)).is_none());
    }

    #[test]
    fn a_fillet_in_a_right_angle_touches_both_lines_at_its_radius() {
        // Down the y axis to the origin, then along +x: the corner at the origin.
        let (centre, t1, t2) = fillet(
            Point::new(0.0, 10.0),
            Point::new(0.0, -1.0),
            Point::new(10.0, 0.0),
            Point::new(1.0, 0.0),
            2.0,
        )
        .unwrap();
        assert!(centre.dist(Point::new(2.0, 2.0)) < 1e-12, "{centre:?}");
        assert!(t1.dist(Point::new(0.0, 2.0)) < 1e-12, "{t1:?}");
        assert!(t2.dist(Point::new(2.0, 0.0)) < 1e-12, "{t2:?}");
    }
}
