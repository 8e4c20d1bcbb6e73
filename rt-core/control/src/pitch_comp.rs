//! The gear's pitch compensation (issue 34): what a measured gear says the table did wrong
//! where each gap passed the hob, taken off the table's target on the next gear.
//!
//! Two parts, each a function of what it repeats with:
//! - the table's repeatable error (the worm wheel's eccentricity and pitch errors, the worm's
//!   runout), sampled at `n` equally spaced table angles (the measured gear's gaps) and
//!   interpolated linearly between them, periodic over a turn;
//! - the hob's once-per-turn error (its axial runout, seen with more than one start), a sine
//!   of the spindle's angle.
//!
//! The offset is what the table's target gets, deg: minus the errors. A gear cut with the
//! compensation has its gaps where the measured gear had them: the gearbox takes a new
//! blank's tooth phase from the compensation ([`PitchCompensation::phase_deg`]), so both
//! parts meet the gaps at the angles they were measured at.
//!
//! Built and validated at start-up (allocation-free after), evaluated in the cycle with a
//! bounded number of operations.

/// The most points a table may have (a gear of up to this many teeth samples it once each).
pub const MAX_POINTS: usize = 512;
/// The largest offset a compensation may ask of the table, deg (72 arcsec, 105 um at the
/// shipped wheel's 300 mm: beyond a worm wheel of ISO 1328-1 grade 8, which wants a repair,
/// not a compensation).
pub const MAX_OFFSET_DEG: f64 = 0.02;

/// Why a compensation is refused (named after the part of it that is wrong).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CompensationError {
    /// Fewer than 3 points or more than [`MAX_POINTS`].
    PointCount,
    /// A point or a coefficient is not finite.
    NotFinite,
    /// A point or the hob term's amplitude exceeds [`MAX_OFFSET_DEG`].
    TooLarge,
}

impl CompensationError {
    pub fn text(self) -> &'static str {
        match self {
            CompensationError::PointCount => "the table must have 3 to 512 points",
            CompensationError::NotFinite => "a value is not a finite number",
            CompensationError::TooLarge => "an offset is larger than 0.02 deg (72 arcsec)",
        }
    }
}

/// A pitch compensation the gearbox applies.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PitchCompensation {
    /// The table angle of point 0, deg; point i is `360 i / n` further.
    first_deg: f64,
    n: usize,
    #[serde(with = "hob_gearing::serde_arrays")]
    offsets_deg: [f64; MAX_POINTS],
    /// The hob's term: `cos_deg cos(spindle) + sin_deg sin(spindle)`, deg of the table.
    hob_cos_deg: f64,
    hob_sin_deg: f64,
    /// The tooth phase (gearbox phase, mod the pitch) of the gear it was measured on.
    phase_deg: f64,
}

impl PitchCompensation {
    /// From the table's offsets at `first_deg + 360 i / n` (deg), the hob's term and the
    /// tooth phase of the measured cut. Refused when a value is not finite, the points are
    /// fewer than 3 or more than [`MAX_POINTS`], or an offset exceeds [`MAX_OFFSET_DEG`].
    pub fn new(
        first_deg: f64,
        offsets_deg: &[f64],
        hob_cos_deg: f64,
        hob_sin_deg: f64,
        phase_deg: f64,
    ) -> Result<Self, CompensationError> {
        let n = offsets_deg.len();
        if !(3..=MAX_POINTS).contains(&n) {
            return Err(CompensationError::PointCount);
        }
        let scalars = [first_deg, hob_cos_deg, hob_sin_deg, phase_deg];
        if offsets_deg.iter().chain(&scalars).any(|v| !v.is_finite()) {
            return Err(CompensationError::NotFinite);
        }
        if offsets_deg.iter().any(|v| v.abs() > MAX_OFFSET_DEG)
            || hob_cos_deg.hypot(hob_sin_deg) > MAX_OFFSET_DEG
        {
            return Err(CompensationError::TooLarge);
        }
        let mut table = [0.0; MAX_POINTS];
        table[..n].copy_from_slice(offsets_deg);
        Ok(Self {
            first_deg,
            n,
            offsets_deg: table,
            hob_cos_deg,
            hob_sin_deg,
            phase_deg,
        })
    }

    /// [`Self::new`] from a stored compensation's arcsec of the table (the table's offsets
    /// and the hob's term; the first angle and the tooth phase in deg): the one conversion
    /// `hob compensate` checks with and `hob-rt` loads with.
    pub fn from_arcsec(
        first_deg: f64,
        offsets_arcsec: &[f64],
        hob_cos_arcsec: f64,
        hob_sin_arcsec: f64,
        phase_deg: f64,
    ) -> Result<Self, CompensationError> {
        if offsets_arcsec.len() > MAX_POINTS {
            return Err(CompensationError::PointCount);
        }
        let mut offsets_deg = [0.0; MAX_POINTS];
        for (deg, arcsec) in offsets_deg.iter_mut().zip(offsets_arcsec) {
            *deg = arcsec / 3600.0;
        }
        Self::new(
            first_deg,
            &offsets_deg[..offsets_arcsec.len()],
            hob_cos_arcsec / 3600.0,
            hob_sin_arcsec / 3600.0,
            phase_deg,
        )
    }

    /// The tooth phase the measured gear was cut at (deg, the gearbox's phase).
    pub fn phase_deg(&self) -> f64 {
        self.phase_deg
    }

    pub fn points(&self) -> &[f64] {
        &self.offsets_deg[..self.n]
    }

    /// The offset for the table at `table_deg` and the spindle at `spindle_deg`, deg.
    pub fn offset_deg(&self, table_deg: f64, spindle_deg: f64) -> f64 {
        let spacing = 360.0 / self.n as f64;
        let u = ((table_deg - self.first_deg) / spacing).rem_euclid(self.n as f64);
        // rem_euclid can round up to n itself for a tiny negative argument.
        let i = (u.floor() as usize).min(self.n - 1);
        let f = (u - i as f64).clamp(0.0, 1.0);
        let a = self.offsets_deg[i];
        let b = self.offsets_deg[(i + 1) % self.n];
        let (s, c) = spindle_deg.to_radians().sin_cos();
        a + f * (b - a) + self.hob_cos_deg * c + self.hob_sin_deg * s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_is_interpolated_periodically_and_the_hob_term_added() {
        let c = PitchCompensation::new(10.0, &[0.001, 0.002, -0.001, 0.0], 0.0, 0.0, 0.0).unwrap();
        assert!((c.offset_deg(10.0, 0.0) - 0.001).abs() < 1e-15);
        assert!((c.offset_deg(55.0, 0.0) - 0.0015).abs() < 1e-15);
        assert!((c.offset_deg(10.0 + 360.0 * 3.0 + 180.0, 0.0) + 0.001).abs() < 1e-15);
        // Between the last point and the first, across the turn.
        assert!((c.offset_deg(10.0 - 45.0, 0.0) - 0.0005).abs() < 1e-15);
        assert!((c.offset_deg(-1e-13 + 10.0, 0.0) - 0.001).abs() < 1e-9);
        let h = PitchCompensation::new(0.0, &[0.0; 3], 0.001, 0.002, 5.0).unwrap();
        assert!((h.offset_deg(7.0, 0.0) - 0.001).abs() < 1e-15);
        assert!((h.offset_deg(7.0, 90.0 + 720.0) - 0.002).abs() < 1e-12);
        assert_eq!(h.phase_deg(), 5.0);
        let a = PitchCompensation::from_arcsec(0.0, &[3.6, -7.2, 0.0], 3.6, 0.0, 5.0).unwrap();
        assert_eq!(a.points(), &[0.001, -0.002, 0.0]);
        assert_eq!(a.offset_deg(0.0, 0.0), 0.002);
        assert_eq!(
            PitchCompensation::from_arcsec(0.0, &[0.0; MAX_POINTS + 1], 0.0, 0.0, 0.0),
            Err(CompensationError::PointCount)
        );
    }

    #[test]
    fn a_bad_table_is_refused() {
        assert_eq!(
            PitchCompensation::new(0.0, &[0.0; 2], 0.0, 0.0, 0.0),
            Err(CompensationError::PointCount)
        );
        assert_eq!(
            PitchCompensation::new(0.0, &[0.0; MAX_POINTS + 1], 0.0, 0.0, 0.0),
            Err(CompensationError::PointCount)
        );
        assert_eq!(
            PitchCompensation::new(0.0, &[0.0, f64::NAN, 0.0], 0.0, 0.0, 0.0),
            Err(CompensationError::NotFinite)
        );
        assert_eq!(
            PitchCompensation::new(0.0, &[0.0; 3], 0.0, 0.0, f64::INFINITY),
            Err(CompensationError::NotFinite)
        );
        assert_eq!(
            PitchCompensation::new(0.0, &[0.0, 0.03, 0.0], 0.0, 0.0, 0.0),
            Err(CompensationError::TooLarge)
        );
        assert_eq!(
            PitchCompensation::new(0.0, &[0.0; 3], 0.015, 0.015, 0.0),
            Err(CompensationError::TooLarge)
        );
    }
}
