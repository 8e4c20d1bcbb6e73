//! X-axis shapes along the face width (docs/domain.md section 4): crowning and 2D contour.
//!
//! Both give an X offset (mm, negative = deeper, i.e. a smaller centre distance) as a
//! function of the position along the face, `face_mm` = 0 at the bottom face of the
//! toothed part. Fixed-size, `Copy`, allocation-free: evaluated in the 1 kHz loop.

/// Most points a contour may hold (fixed so the loop never allocates).
pub const MAX_CONTOUR_POINTS: usize = 64;

/// Arc radius for a crowning height `h` over face width `b`: `R = (b/2)^2 / (2h) + h/2`.
pub fn crowning_radius_mm(height_mm: f64, face_width_mm: f64) -> f64 {
    let half = face_width_mm / 2.0;
    half * half / (2.0 * height_mm) + height_mm / 2.0
}

/// Crowning height for an arc radius `R` over face width `b`: `h = R - sqrt(R^2 - (b/2)^2)`.
/// `None` when the radius is smaller than half the face width.
pub fn crowning_height_mm(radius_mm: f64, face_width_mm: f64) -> Option<f64> {
    let half = face_width_mm / 2.0;
    (radius_mm >= half).then(|| radius_mm - (radius_mm * radius_mm - half * half).sqrt())
}

/// A circular crowning arc: the programmed depth holds at mid-face, the ends are cut
/// deeper by `height_mm`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Crowning {
    pub height_mm: f64,
    pub radius_mm: f64,
    pub face_width_mm: f64,
}

impl Crowning {
    pub fn from_height(height_mm: f64, face_width_mm: f64) -> Self {
        Self {
            height_mm,
            radius_mm: crowning_radius_mm(height_mm, face_width_mm),
            face_width_mm,
        }
    }

    /// X offset at `face_mm` along the face; held at the end value outside the face.
    pub fn x_offset_mm(&self, face_mm: f64) -> f64 {
        let half = self.face_width_mm / 2.0;
        let u = (face_mm - half).clamp(-half, half);
        let r = self.radius_mm;
        // r - sqrt(r^2 - u^2) written to keep precision for r >> u.
        -(u * u) / (r + (r * r - u * u).sqrt())
    }
}

/// A piecewise-linear X offset through operator-entered (face position, offset) points.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Contour {
    #[serde(with = "crate::serde_arrays")]
    points: [(f64, f64); MAX_CONTOUR_POINTS],
    len: usize,
}

/// Why a list of points is not a contour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContourError {
    /// Fewer than two points.
    TooFew,
    /// More than [`MAX_CONTOUR_POINTS`].
    TooMany,
    /// Point `index` is not strictly above the previous one along the face, or not finite.
    NotIncreasing { index: usize },
}

impl Contour {
    /// A contour through `points` (`[face_mm, x_offset_mm]`), strictly increasing in face
    /// position.
    pub fn new(points: &[[f64; 2]]) -> Result<Self, ContourError> {
        if points.len() < 2 {
            return Err(ContourError::TooFew);
        }
        if points.len() > MAX_CONTOUR_POINTS {
            return Err(ContourError::TooMany);
        }
        let mut out = [(0.0, 0.0); MAX_CONTOUR_POINTS];
        for (i, p) in points.iter().enumerate() {
            let finite = p[0].is_finite() && p[1].is_finite();
            if !finite || (i > 0 && p[0] <= points[i - 1][0]) {
                return Err(ContourError::NotIncreasing { index: i });
            }
            out[i] = (p[0], p[1]);
        }
        Ok(Self {
            points: out,
            len: points.len(),
        })
    }

    pub fn points(&self) -> &[(f64, f64)] {
        &self.points[..self.len]
    }

    /// X offset at `face_mm`, linear between points, held at the end values outside.
    pub fn x_offset_mm(&self, face_mm: f64) -> f64 {
        let pts = self.points();
        let (first, last) = (pts[0], pts[self.len - 1]);
        if face_mm <= first.0 {
            return first.1;
        }
        if face_mm >= last.0 {
            return last.1;
        }
        // Bounded: at most MAX_CONTOUR_POINTS comparisons.
        let i = pts.partition_point(|p| p.0 <= face_mm);
        let (a, b) = (pts[i - 1], pts[i]);
        a.1 + (b.1 - a.1) * (face_mm - a.0) / (b.0 - a.0)
    }
}

/// The X shape of a job: a crowning arc, a contour, both superimposed, or neither.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct XShape {
    pub crowning: Option<Crowning>,
    pub contour: Option<Contour>,
}

impl XShape {
    /// X offset at `face_mm` along the face: the sum of the crowning and contour offsets.
    pub fn x_offset_mm(&self, face_mm: f64) -> f64 {
        self.crowning.map_or(0.0, |c| c.x_offset_mm(face_mm))
            + self.contour.map_or(0.0, |c| c.x_offset_mm(face_mm))
    }

    /// Whether X moves during the cut (it must not be clamped then).
    pub fn moves_x(&self) -> bool {
        self.crowning.is_some() || self.contour.is_some()
    }

    /// Most negative offset over the face (the deepest point), 0 when straight.
    pub fn min_offset_mm(&self) -> f64 {
        let crowning = self.crowning.map_or(0.0, |c| -c.height_mm);
        let contour = self
            .contour
            .map_or(0.0, |c| c.points().iter().map(|p| p.1).fold(0.0, f64::min));
        crowning + contour
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn radius_and_height_are_inverse() {
        let r = crowning_radius_mm(0.02, 40.0);
        assert!((r - 10000.01).abs() < 1e-9, "{r}");
        let h = crowning_height_mm(r, 40.0).unwrap();
        assert!((h - 0.02).abs() < 1e-12);
        assert_eq!(crowning_height_mm(10.0, 40.0), None);
    }

    #[test]
    fn contour_interpolates_linearly_and_holds_the_ends() {
        let c = Contour::new(&[[0.0, 0.0], [20.0, -0.01], [40.0, 0.0]]).unwrap();
        assert_eq!(c.x_offset_mm(-5.0), 0.0);
        assert!((c.x_offset_mm(10.0) + 0.005).abs() < 1e-15);
        assert!((c.x_offset_mm(20.0) + 0.01).abs() < 1e-15);
        assert!((c.x_offset_mm(30.0) + 0.005).abs() < 1e-15);
        assert_eq!(c.x_offset_mm(45.0), 0.0);
    }

    #[test]
    fn contour_refuses_bad_point_lists() {
        assert_eq!(Contour::new(&[[0.0, 0.0]]), Err(ContourError::TooFew));
        assert_eq!(
            Contour::new(&[[0.0, 0.0], [10.0, 0.0], [10.0, 0.1]]),
            Err(ContourError::NotIncreasing { index: 2 })
        );
        let many = vec![[0.0, 0.0]; MAX_CONTOUR_POINTS + 1];
        assert_eq!(Contour::new(&many), Err(ContourError::TooMany));
    }

    proptest! {
        #[test]
        fn crowning_is_zero_mid_face_and_minus_height_at_both_ends(
            h in 0.001f64..0.5, b in 5.0f64..300.0,
        ) {
            let c = Crowning::from_height(h, b);
            prop_assert!(c.x_offset_mm(b / 2.0).abs() < 1e-12);
            prop_assert!((c.x_offset_mm(0.0) + h).abs() < 1e-9);
            prop_assert!((c.x_offset_mm(b) + h).abs() < 1e-9);
        }

        #[test]
        fn crowning_is_a_circle_of_its_radius(
            h in 0.001f64..0.5, b in 5.0f64..300.0, f in 0.0f64..1.0,
        ) {
            let c = Crowning::from_height(h, b);
            let face = f * b;
            // The points (face, offset) lie on the circle of radius R centred at
            // (b/2, -R): u^2 + (R + offset)^2 = R^2 with u = face - b/2.
            let u = face - b / 2.0;
            let off = c.x_offset_mm(face);
            let r = c.radius_mm;
            prop_assert!((u * u + (r + off) * (r + off) - r * r).abs() < 1e-6 * r);
            prop_assert!(off <= 0.0 && off >= -h - 1e-12);
        }

        #[test]
        fn contour_passes_through_its_points(
            ys in proptest::collection::vec(0.1f64..10.0, 2..20),
            xs in proptest::collection::vec(-0.1f64..0.1, 20),
        ) {
            let mut face = 0.0;
            let pts: Vec<[f64; 2]> = ys.iter().zip(&xs).map(|(dy, x)| { face += dy; [face, *x] }).collect();
            let c = Contour::new(&pts).unwrap();
            for p in &pts {
                prop_assert!((c.x_offset_mm(p[0]) - p[1]).abs() < 1e-12);
            }
        }
    }
}
