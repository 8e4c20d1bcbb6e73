//! The spindle encoder's error told apart from a true once-per-turn variation of the
//! spindle's speed, from runs at several constant speeds.
//!
//! The encoder's code disc is never exactly centred: its reading errs by a fixed function of
//! the angle, harmonics 1, 2, 3 per turn of a few to 40 arcsec. The spindle may also *truly*
//! vary its speed once per turn (an unbalance torque `T sin(theta + phi)` against the VFD's
//! slip: `J theta'' + D (theta' - w_sync) = T sin(theta + phi)`), and the encoder reads that
//! variation correctly. A controller that takes a true variation for an encoder error
//! "corrects" it away, and the table then no longer follows the spindle. One speed cannot
//! tell them apart (both are a sine of the angle); several can, because they scale
//! differently with the speed:
//!
//! - the encoder's error is fixed to the disc: the same complex amplitude `a_k` at every
//!   speed;
//! - a true variation is the torque through the spindle's dynamics, `T * G(W)` with
//!   `G(W) = 1 / (i W (1 + i W tau))` (`W` in rad/s, `tau = J/D`): `tau = 0` is a pure slip
//!   damper (the swing goes as `1/W`), a large `tau` is inertia-dominated (`1/W^2`).
//!
//! [`fit_speed`] fits one constant-speed run; [`separate`] fits the once-per-turn amplitudes
//! of the runs (at least 3 speeds spanning a factor 2) as `a1 + b g_tau(W)`. The machine
//! file's record of it (`[commissioning.spindle_encoder]`, `SpindleSwing::encoder_share` in
//! `hob-config`) gives the loop's single-speed identifier the factor to apply to what it
//! sees, at any speed, to keep only the encoder's part.
//!
//! # The complex convention
//!
//! A harmonic `k` of an error, `S sin(k theta) + C cos(k theta)` (`theta` the reading, rad),
//! is the complex number `z = S + i C`; `amp sin(k theta + phi)` is `amp e^{i phi}`, i.e.
//! the error is `Im(z e^{i k theta})`. A linear system `G` driven by a torque `z_T` (in that
//! form) answers `z_T * G(W)`. Shifting the counter's zero by `delta` multiplies every
//! harmonic `k` by `e^{-i k delta}`: once-per-turn amplitudes all turn by the same unit
//! complex, so their *ratios* (and the phase of one relative to another) survive a power
//! cycle of the incremental counter while their absolute phases do not. [`Harmonic`]
//! carries such a `z`, in arcsec.
//!
//! Pure: no I/O, no clock; the caller latches the readings.

use hob_setup::config::machine::commissioning::swing_scale;
use nalgebra::{Cholesky, Complex, Matrix2, SMatrix, SVector, Vector2};

/// Below this speed the spindle's slip and the VFD's own ripple dominate a run, and a block
/// of whole turns takes so long that a cubic no longer holds the motion.
const MIN_RPM: f64 = 30.0;

/// A block spans the whole number of turns that lasts closest to this (at least
/// [`MIN_TURNS_PER_BLOCK`]): short enough for a cubic in time to hold a slow drift of the
/// slip (a +-0.2 % drift over ten seconds leaves a few arcsec), long enough that the cubic
/// and the harmonics stay apart (over whole turns they are nearly orthogonal).
const BLOCK_S: f64 = 2.0;

/// Fewer than two turns and the cubic and the once-per-turn harmonic become collinear.
const MIN_TURNS_PER_BLOCK: u32 = 2;

/// A run must give this many blocks: the spread of their speeds is the steadiness check, and
/// averaging them is what beats the quantisation down.
const MIN_BLOCKS: u32 = 3;

/// A block whose RMS residual is more than this many times the blocks' median is a glitch,
/// left out: a step of the reading against its time (a SYNC the simulated drives read late
/// together with the next advances their physics once for two cycles: at 64 rpm a step of
/// 0.38 deg; one such step in a 20 s run put the once-per-turn part 24 arcsec off in a test,
/// and a loaded host's run found 6.6 arcsec of 15 at 64 rpm), a knock.
/// Where every block is as bad, none is dropped and the residual refuses the run.
const GLITCH_RESIDUAL: f64 = 2.0;

/// A block needs this many samples for its 10 parameters to be more than interpolated.
const MIN_BLOCK_SAMPLES: usize = 60;

/// Blocks' mean speeds may differ by this fraction of the run's speed: a true variation
/// scales with the speed (up to `1/W^2`), so a run whose speed wandered by more does not
/// stand for one speed. A VFD's slip drifts by a few tenths of a percent.
const MAX_SPEED_SPREAD: f64 = 0.02;

/// Above this RMS residual, in counts, the motion was not a cubic plus harmonics 1..3 of the
/// reading (a vibration, a speed step, lost counts): quantisation alone leaves 0.29 count.
const MAX_RESIDUAL_COUNTS: f64 = 1.0;

/// [`separate`] needs this many distinct speeds (two complex unknowns and `tau`) ...
const MIN_SPEEDS: u32 = 3;

/// ... speeds within this fraction of each other count as one ...
const SAME_SPEED: f64 = 0.05;

/// ... spanning at least this factor: over a narrower span `1/W` and `1/W^2` both look
/// like a constant plus a slope, and the constant (the encoder's error) is not determined.
const MIN_SPAN: f64 = 2.0;

/// The `tau` grid: 0, then log-spaced from `10^TAU_DECADES.0` to `10^TAU_DECADES.1` s with
/// [`TAU_PER_DECADE`] points a decade. Below 1 ms the dynamics are a pure damper at any
/// spindle speed (`W tau < 0.03` at 300 rpm); above 10 s they are pure inertia.
const TAU_DECADES: (f64, f64) = (-3.0, 1.0);
const TAU_PER_DECADE: u32 = 20;

const ARCSEC_PER_DEG: f64 = 3600.0;

/// A swing is claimed only when it lowers the chi-square of the speeds' once-per-turn parts
/// by more than this (the 95 % point of chi-square with 2 degrees of freedom: the swing's
/// complex amplitude; its tau is not counted, which makes the test a little keen).
const NO_SWING_CHI2: f64 = 5.99;

/// One latched reading of the spindle encoder: time (s, from any origin) and the raw
/// continuous reading (deg, not wrapped, quantised to the encoder's count).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    pub t_s: f64,
    pub deg: f64,
}

/// A harmonic of an error in arcsec: `sin_arcsec * sin(k theta) + cos_arcsec * cos(k theta)`,
/// the complex number `sin_arcsec + i cos_arcsec` (the module's convention). The arithmetic
/// is complex arithmetic; a product or quotient of two harmonics is meaningful only as a
/// ratio.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Harmonic {
    pub sin_arcsec: f64,
    pub cos_arcsec: f64,
}

impl Harmonic {
    pub const fn new(sin_arcsec: f64, cos_arcsec: f64) -> Self {
        Self {
            sin_arcsec,
            cos_arcsec,
        }
    }

    /// `amplitude_arcsec * sin(k theta + phase)`.
    pub fn from_polar(amplitude_arcsec: f64, phase_deg: f64) -> Self {
        let (s, c) = phase_deg.to_radians().sin_cos();
        Self::new(amplitude_arcsec * c, amplitude_arcsec * s)
    }

    pub fn amplitude_arcsec(&self) -> f64 {
        self.sin_arcsec.hypot(self.cos_arcsec)
    }

    /// The phase `phi` of `amp sin(k theta + phi)`, deg in (-180, 180]. Absolute phases
    /// depend on the counter's zero (new at each power-up); differences do not.
    pub fn phase_deg(&self) -> f64 {
        self.cos_arcsec.atan2(self.sin_arcsec).to_degrees()
    }

    /// The complex conjugate.
    pub fn conj(self) -> Self {
        Self::new(self.sin_arcsec, -self.cos_arcsec)
    }

    /// `self / other`, none where `other` is zero (or either is not finite).
    pub fn checked_div(self, other: Self) -> Option<Self> {
        let q = self.complex() / other.complex();
        (q.re.is_finite() && q.im.is_finite()).then(|| Self::from_complex(q))
    }

    fn complex(self) -> Complex<f64> {
        Complex::new(self.sin_arcsec, self.cos_arcsec)
    }

    fn from_complex(z: Complex<f64>) -> Self {
        Self::new(z.re, z.im)
    }
}

impl std::ops::Add for Harmonic {
    type Output = Self;
    fn add(self, other: Self) -> Self {
        Self::from_complex(self.complex() + other.complex())
    }
}

impl std::ops::Sub for Harmonic {
    type Output = Self;
    fn sub(self, other: Self) -> Self {
        Self::from_complex(self.complex() - other.complex())
    }
}

impl std::ops::Neg for Harmonic {
    type Output = Self;
    fn neg(self) -> Self {
        Self::new(-self.sin_arcsec, -self.cos_arcsec)
    }
}

/// The complex product (a harmonic times a ratio).
impl std::ops::Mul for Harmonic {
    type Output = Self;
    fn mul(self, other: Self) -> Self {
        Self::from_complex(self.complex() * other.complex())
    }
}

impl std::ops::Mul<f64> for Harmonic {
    type Output = Self;
    fn mul(self, factor: f64) -> Self {
        Self::new(self.sin_arcsec * factor, self.cos_arcsec * factor)
    }
}

/// One constant speed fitted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedFit {
    /// The run's mean speed as measured (the VFD's slip included), signed with the direction.
    pub rpm: f64,
    /// Harmonics 1, 2, 3 per turn of the reading: the encoder's error plus, at 1 per turn,
    /// the true variation at this speed.
    pub harmonics: [Harmonic; 3],
    /// RMS residual over all blocks' samples, arcsec (quantisation alone: count / sqrt 12).
    pub residual_arcsec: f64,
    /// Blocks fitted and averaged.
    pub blocks: u32,
    /// Samples in those blocks.
    pub samples: u32,
    /// The standard error of `harmonics[0]` (complex, RMS of its distance), arcsec: from
    /// the blocks' scatter about their mean, and never below white quantisation noise
    /// (`residual * sqrt(2 / samples)`).
    pub once_sigma_arcsec: f64,
    /// Blocks left out as glitches (see [`GLITCH_RESIDUAL`]).
    pub dropped_blocks: u32,
}

/// The encoder's error told apart from a true variation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Separation {
    /// The encoder's error, harmonics 1, 2, 3. Harmonic 1 is the separated `a1`; 2 and 3 are
    /// the speed fits' samples-weighted mean: a true variation at 2 or 3 per turn is not
    /// modelled (an unbalance drives once per turn; a 2-per-turn torque would be taken for
    /// the encoder's error here).
    pub encoder: [Harmonic; 3],
    /// The true once-per-turn variation at `reference_rpm` (`T * G(W_ref)`), in the same
    /// frame (counter zero) as `encoder[0]`.
    pub variation: Harmonic,
    /// The speed `variation` is given at, signed as the fits' `rpm`.
    pub reference_rpm: f64,
    /// `tau = J/D` of the best fit, s (0: a pure slip damper). Undetermined, and meaningless,
    /// when `variation` is near zero.
    pub tau_s: f64,
    /// RMS of the once-per-turn model's misfit over the speeds (weighted by each speed's
    /// noise), arcsec.
    pub misfit_arcsec: f64,
    /// How far `encoder[0]` may be from the truth, arcsec: its standard error at the chosen
    /// `tau` plus the spread of it over every `tau` the speeds cannot reject (chi-square
    /// within 1 of the best).
    pub error_uncertainty_arcsec: f64,
}

impl Separation {
    /// The variation relative to the encoder's error's phase, `b * conj(a1) / |a1|`: what
    /// survives a new counter zero, and what the machine file's record keeps. Where `a1` is exactly
    /// zero there is no phase to refer to and `variation` is returned as it is (the share is
    /// then zero whatever its phase).
    pub fn variation_relative(&self) -> Harmonic {
        let a1 = self.encoder[0];
        let amplitude = a1.amplitude_arcsec();
        if amplitude > 0.0 && amplitude.is_finite() {
            self.variation * a1.conj() * (1.0 / amplitude)
        } else {
            self.variation
        }
    }

    /// The result in words, for the commissioning report.
    pub fn text(&self) -> String {
        let a = &self.encoder;
        let relative = self.variation_relative();
        let mut out = format!(
            "encoder error (fixed to the code disc): 1/turn {:.1} +- {:.1} arcsec at {:.0} deg, \
             2/turn {:.1} arcsec at {:.0} deg, 3/turn {:.1} arcsec at {:.0} deg\n",
            a[0].amplitude_arcsec(),
            self.error_uncertainty_arcsec,
            a[0].phase_deg(),
            a[1].amplitude_arcsec(),
            a[1].phase_deg(),
            a[2].amplitude_arcsec(),
            a[2].phase_deg(),
        );
        out += &format!(
            "true once-per-turn speed variation: a swing of {:.1} arcsec at {:.0} rpm, \
             {:+.0} deg from the error's phase; tau = J/D {:.3} s",
            self.variation.amplitude_arcsec(),
            self.reference_rpm,
            relative.phase_deg(),
            self.tau_s,
        );
        if self.variation.amplitude_arcsec() < self.misfit_arcsec.max(1.0) {
            out += " (no variation to speak of: tau undetermined)";
        }
        out += &format!(
            "\nmisfit of the once-per-turn model over the speeds: {:.1} arcsec RMS\n\
             (absolute phases follow the counter's zero, new at each power-up; only their \
             differences carry over)",
            self.misfit_arcsec
        );
        out
    }
}

/// Why a fit gave no result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FitError {
    /// An argument that is not a number, a count that is not positive, a reference speed
    /// of zero.
    Invalid { what: &'static str },
    /// Readings whose time does not increase (at the reading with this index).
    TimeNotIncreasing { index: usize },
    /// Too few readings in all, or too few left in whole blocks (gaps).
    TooFewSamples { samples: usize, needed: usize },
    /// The run is slower than the fit holds.
    TooSlow { rpm: f64, min_rpm: f64 },
    /// The run is too short for enough blocks at its speed.
    TooShort { rpm: f64, turns: f64, needed_turns: f64 },
    /// The blocks' mean speeds differ by more than allowed.
    NotSteady {
        rpm: f64,
        spread_percent: f64,
        block_turns: u32,
    },
    /// The fit leaves more than about a count of residual.
    Residual {
        rpm: f64,
        residual_arcsec: f64,
        limit_arcsec: f64,
    },
    /// Fewer distinct speeds than the separation needs.
    TooFewSpeeds { speeds: u32, needed: u32 },
    /// The speeds span less than the separation needs.
    NarrowSpan { span: f64, needed: f64 },
    /// The least squares had no unique solution.
    Singular,
}

impl std::fmt::Display for FitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            FitError::Invalid { what } => write!(f, "not a valid input: {what}"),
            FitError::TimeNotIncreasing { index } => write!(
                f,
                "the readings' times do not increase (at reading {index}): not one recording"
            ),
            FitError::TooFewSamples { samples, needed } => write!(
                f,
                "too few readings to fit ({samples} in whole blocks, at least {needed} needed): \
                 too many lost samples, or a run too short"
            ),
            FitError::TooSlow { rpm, min_rpm } => write!(
                f,
                "the spindle turned at {rpm:.1} rpm: below {min_rpm:.0} rpm its slip is not \
                 steady enough to fit"
            ),
            FitError::TooShort {
                rpm,
                turns,
                needed_turns,
            } => write!(
                f,
                "the {rpm:.0} rpm run was too short ({turns:.1} turns, at least \
                 {needed_turns:.0} needed)"
            ),
            FitError::NotSteady {
                rpm,
                spread_percent,
                block_turns,
            } => write!(
                f,
                "the spindle's speed changed within the {rpm:.0} rpm run (fits {block_turns} \
                 turns apart differ by {spread_percent:.1} %)"
            ),
            FitError::Residual {
                rpm,
                residual_arcsec,
                limit_arcsec,
            } => write!(
                f,
                "the {rpm:.0} rpm run does not fit a steady turn plus the encoder's error \
                 ({residual_arcsec:.0} arcsec RMS left, at most {limit_arcsec:.0}): a \
                 vibration, a speed step or lost counts"
            ),
            FitError::TooFewSpeeds { speeds, needed } => write!(
                f,
                "{speeds} distinct speeds measured: telling the encoder's error from a true \
                 variation needs at least {needed}"
            ),
            FitError::NarrowSpan { span, needed } => write!(
                f,
                "the speeds span a factor {span:.2}: telling the encoder's error from a true \
                 variation needs at least {needed:.0}"
            ),
            FitError::Singular => write!(f, "the fit has no unique solution"),
        }
    }
}

impl std::error::Error for FitError {}

/// Parameters of one block's fit: Legendre polynomials 0..3 of the centred, scaled time,
/// then `sin(k r), cos(k r)` for k = 1..3.
const PARAMETERS: usize = 10;

/// One block's result.
#[derive(Debug, Clone, Copy)]
struct BlockFit {
    /// Harmonics 1..3, deg, as `sin + i cos`.
    harmonics_deg: [Complex<f64>; 3],
    residual_sq_deg2: f64,
    samples: usize,
    speed_deg_s: f64,
}

fn block_row(t_mid_s: f64, half_span_s: f64, r: &Reading) -> [f64; PARAMETERS] {
    let u = (r.t_s - t_mid_s) / half_span_s;
    let theta = r.deg.to_radians();
    let (s1, c1) = theta.sin_cos();
    let (s2, c2) = (2.0 * theta).sin_cos();
    let (s3, c3) = (3.0 * theta).sin_cos();
    [
        1.0,
        u,
        0.5 * (3.0 * u * u - 1.0),
        0.5 * (5.0 * u * u * u - 3.0 * u),
        s1,
        c1,
        s2,
        c2,
        s3,
        c3,
    ]
}

/// Least squares of one block: the reading as a cubic in time (the motion over a couple of
/// seconds: speed, the slip's slow drift) plus harmonics 1..3 of the reading itself (the
/// error, and a true variation, are functions of the angle, not of time). Time is centred
/// and scaled to [-1, 1] and the cubic written in Legendre polynomials, so the normal
/// equations stay conditioned; the reading is taken from the block's first so the numbers
/// stay small. None where the block's equations are singular.
fn fit_block(block: &[Reading]) -> Option<BlockFit> {
    let (first, last) = (block.first()?, block.last()?);
    let t_mid_s = 0.5 * (first.t_s + last.t_s);
    let half_span_s = 0.5 * (last.t_s - first.t_s);
    if half_span_s <= 0.0 {
        return None;
    }
    let mut ata = [[0.0; PARAMETERS]; PARAMETERS];
    let mut atb = [0.0; PARAMETERS];
    for r in block {
        let row = block_row(t_mid_s, half_span_s, r);
        let y = r.deg - first.deg;
        for i in 0..PARAMETERS {
            atb[i] += row[i] * y;
            for j in i..PARAMETERS {
                ata[i][j] += row[i] * row[j];
            }
        }
    }
    let ata =
        SMatrix::<f64, PARAMETERS, PARAMETERS>::from_fn(|i, j| if i <= j { ata[i][j] } else { ata[j][i] });
    let atb = SVector::<f64, PARAMETERS>::from_row_slice(&atb);
    let chol = Cholesky::new(ata)?;
    // A near-singular block (a gap over most of a turn) passes Cholesky with a tiny pivot:
    // refuse it rather than trust its harmonics.
    let l = chol.l_dirty();
    for i in 0..PARAMETERS {
        let pivot = l[(i, i)] * l[(i, i)];
        if pivot.is_nan() || pivot <= 1e-9 * ata[(i, i)] {
            return None;
        }
    }
    let beta = chol.solve(&atb);
    let mut residual_sq_deg2 = 0.0;
    for r in block {
        let row = block_row(t_mid_s, half_span_s, r);
        let model: f64 = row.iter().zip(beta.iter()).map(|(a, b)| a * b).sum();
        let e = r.deg - first.deg - model;
        residual_sq_deg2 += e * e;
    }
    Some(BlockFit {
        harmonics_deg: [
            Complex::new(beta[4], beta[5]),
            Complex::new(beta[6], beta[7]),
            Complex::new(beta[8], beta[9]),
        ],
        residual_sq_deg2,
        samples: block.len(),
        speed_deg_s: (last.deg - first.deg) / (last.t_s - first.t_s),
    })
}

/// The once-per-turn part's standard error from the blocks' scatter about `mean`
/// (samples-weighted, n - 1 of them free), floored at white noise of the residual, arcsec.
fn once_sigma_arcsec(fits: &[BlockFit], mean: Harmonic, residual_arcsec: f64, samples: usize) -> f64 {
    let mean = mean.complex() / ARCSEC_PER_DEG;
    let scatter_deg2: f64 = fits
        .iter()
        .map(|f| (f.harmonics_deg[0] - mean).norm_sqr() * f.samples as f64)
        .sum::<f64>()
        / samples as f64
        / (fits.len() as f64 - 1.0).max(1.0);
    let white_arcsec = residual_arcsec * (2.0 / samples as f64).sqrt();
    (scatter_deg2.sqrt() * ARCSEC_PER_DEG).max(white_arcsec)
}

/// `fits` without the glitches among them ([`GLITCH_RESIDUAL`]), and how many those were.
fn without_glitches(fits: Vec<BlockFit>) -> (Vec<BlockFit>, u32) {
    let rms = |f: &BlockFit| (f.residual_sq_deg2 / f.samples.max(1) as f64).sqrt();
    let mut all: Vec<f64> = fits.iter().map(rms).collect();
    all.sort_by(f64::total_cmp);
    let Some(&median) = all.get(all.len() / 2) else {
        return (fits, 0);
    };
    let before = fits.len();
    let kept: Vec<BlockFit> = fits
        .into_iter()
        .filter(|f| rms(f) <= GLITCH_RESIDUAL * median)
        .collect();
    // Bounded by the run's blocks.
    let dropped = u32::try_from(before - kept.len()).unwrap_or(u32::MAX);
    (kept, dropped)
}

/// Each whole block of `block_deg` of the run (`progress`: how far a reading is from the
/// first, in the run's direction) fitted; a block with too few samples or no fit is left out.
fn fit_blocks(
    readings: &[Reading],
    block_deg: f64,
    whole_blocks: f64,
    progress: impl Fn(&Reading) -> f64,
) -> Vec<BlockFit> {
    let mut fits = Vec::new();
    let mut start = 0;
    let mut b = 0.0;
    while b < whole_blocks {
        let (lo, hi) = (b * block_deg, (b + 1.0) * block_deg);
        while start < readings.len() && progress(&readings[start]) < lo {
            start += 1;
        }
        let mut end = start;
        while end < readings.len() && progress(&readings[end]) < hi {
            end += 1;
        }
        let block = &readings[start..end];
        if block.len() >= MIN_BLOCK_SAMPLES
            && let Some(fit) = fit_block(block)
        {
            fits.push(fit);
        }
        start = end;
        b += 1.0;
    }
    fits
}

/// Fits one constant-speed run: blocks of whole turns (the number lasting closest to 2 s, at
/// least 2 turns; at least 3 blocks), each a least-squares fit of the reading as a cubic in
/// time plus harmonics 1..3 of the reading; the harmonics averaged over the blocks
/// (weighted by samples); the residual the RMS over all their samples.
///
/// Whole turns make the harmonics nearly orthogonal to the cubic, and blocks (rather than
/// one fit over the run) let a cubic follow the slip's slow drift, and let the blocks' speeds
/// show whether the run was steady. Samples may have gaps and need not be evenly spaced (a
/// block left with too few samples, or too ill-conditioned, is skipped). Refuses a run that
/// is too short, slower than 30 rpm, not steady (blocks' mean speeds differ by more than
/// 2 %), or whose residual exceeds a count (`count_deg`).
pub fn fit_speed(readings: &[Reading], count_deg: f64) -> Result<SpeedFit, FitError> {
    if !(count_deg.is_finite() && count_deg > 0.0) {
        return Err(FitError::Invalid {
            what: "the encoder's count must be a positive number of degrees",
        });
    }
    if readings.iter().any(|r| !(r.t_s.is_finite() && r.deg.is_finite())) {
        return Err(FitError::Invalid {
            what: "a reading that is not a number",
        });
    }
    if let Some(i) = readings.windows(2).position(|w| w[1].t_s <= w[0].t_s) {
        return Err(FitError::TimeNotIncreasing { index: i + 1 });
    }
    let needed = MIN_BLOCK_SAMPLES * MIN_BLOCKS as usize;
    let (first, last) = match (readings.first(), readings.last()) {
        (Some(f), Some(l)) if readings.len() >= needed => (*f, *l),
        _ => {
            return Err(FitError::TooFewSamples {
                samples: readings.len(),
                needed,
            });
        }
    };
    let travel_deg = last.deg - first.deg;
    let rpm = travel_deg / (last.t_s - first.t_s) / 6.0;
    if rpm.abs() < MIN_RPM {
        return Err(FitError::TooSlow {
            rpm,
            min_rpm: MIN_RPM,
        });
    }
    // Whole turns lasting closest to BLOCK_S; a float to integer conversion of a value
    // bounded by the run's length.
    let block_turns = ((rpm.abs() / 60.0 * BLOCK_S).round() as u32).max(MIN_TURNS_PER_BLOCK);
    let block_deg = 360.0 * f64::from(block_turns);
    let direction = travel_deg.signum();
    let progress = |r: &Reading| direction * (r.deg - first.deg);
    let whole_blocks = (travel_deg.abs() / block_deg).floor();
    if whole_blocks < f64::from(MIN_BLOCKS) {
        return Err(FitError::TooShort {
            rpm,
            turns: travel_deg.abs() / 360.0,
            needed_turns: f64::from(MIN_BLOCKS * block_turns),
        });
    }

    let (fits, dropped_blocks) = without_glitches(fit_blocks(readings, block_deg, whole_blocks, progress));
    let samples: usize = fits.iter().map(|f| f.samples).sum();
    if fits.len() < MIN_BLOCKS as usize {
        return Err(FitError::TooFewSamples { samples, needed });
    }

    let speeds = fits.iter().map(|f| f.speed_deg_s);
    let max = speeds.clone().fold(f64::NEG_INFINITY, f64::max);
    let min = speeds.fold(f64::INFINITY, f64::min);
    let spread = (max - min) / (rpm.abs() * 6.0);
    if spread > MAX_SPEED_SPREAD {
        return Err(FitError::NotSteady {
            rpm,
            spread_percent: 100.0 * spread,
            block_turns,
        });
    }

    let residual_arcsec =
        (fits.iter().map(|f| f.residual_sq_deg2).sum::<f64>() / samples as f64).sqrt() * ARCSEC_PER_DEG;
    let limit_arcsec = MAX_RESIDUAL_COUNTS * count_deg * ARCSEC_PER_DEG;
    if residual_arcsec.is_nan() || residual_arcsec > limit_arcsec {
        return Err(FitError::Residual {
            rpm,
            residual_arcsec,
            limit_arcsec,
        });
    }

    let mut harmonics = [Harmonic::default(); 3];
    for (k, h) in harmonics.iter_mut().enumerate() {
        let sum: Complex<f64> = fits.iter().map(|f| f.harmonics_deg[k] * f.samples as f64).sum();
        *h = Harmonic::from_complex(sum * (ARCSEC_PER_DEG / samples as f64));
    }
    let once_sigma_arcsec = once_sigma_arcsec(&fits, harmonics[0], residual_arcsec, samples);
    Ok(SpeedFit {
        once_sigma_arcsec,
        dropped_blocks,
        rpm,
        harmonics,
        residual_arcsec,
        // Bounded by the run's length in blocks and samples (u32 holds days at 1 kHz).
        blocks: u32::try_from(fits.len()).unwrap_or(u32::MAX),
        samples: u32::try_from(samples).unwrap_or(u32::MAX),
    })
}

/// `G(W) / G(W_ref)` at signed speeds (hob-config's `swing_scale`, what the loop applies
/// the record with): how a true variation at `rpm` compares with the same torque's at
/// `reference_rpm`.
fn relative_response(rpm: f64, reference_rpm: f64, tau_s: f64) -> Complex<f64> {
    let (re, im) = swing_scale(rpm, reference_rpm, tau_s);
    Complex::new(re, im)
}

/// The once-per-turn model fitted for one `tau`.
#[derive(Debug, Clone, Copy)]
struct OncePerTurn {
    a1: Complex<f64>,
    b: Complex<f64>,
    misfit_arcsec: f64,
    tau_s: f64,
    chi2: f64,
    a1_sigma_arcsec: f64,
}

/// Weighted complex least squares of `c_j = a1 + b g_j`: the 2x2 Hermitian normal
/// equations, solved by Cholesky. None where `g` does not vary over the speeds.
fn fit_once_per_turn(
    c: &[Complex<f64>],
    rpm: &[f64],
    weights: &[f64],
    reference_rpm: f64,
    tau_s: f64,
) -> Option<OncePerTurn> {
    let g: Vec<Complex<f64>> = rpm
        .iter()
        .map(|r| relative_response(*r, reference_rpm, tau_s))
        .collect();
    let (mut s0, mut s1, mut s2) = (0.0, Complex::new(0.0, 0.0), 0.0);
    let (mut r0, mut r1) = (Complex::new(0.0, 0.0), Complex::new(0.0, 0.0));
    for ((gj, cj), wj) in g.iter().zip(c).zip(weights) {
        s0 += wj;
        s1 += gj * *wj;
        s2 += gj.norm_sqr() * wj;
        r0 += cj * *wj;
        r1 += gj.conj() * cj * *wj;
    }
    // det = s0 s2 - |s1|^2 >= 0 (Cauchy-Schwarz), zero when g is the same at every speed.
    let det = s0 * s2 - s1.norm_sqr();
    if det.is_nan() || det <= 1e-9 * s0 * s2 {
        return None;
    }
    let n = Matrix2::new(Complex::new(s0, 0.0), s1, s1.conj(), Complex::new(s2, 0.0));
    let x = n.cholesky()?.solve(&Vector2::new(r0, r1));
    let (a1, b) = (x[0], x[1]);
    let sq: f64 = g
        .iter()
        .zip(c)
        .zip(weights)
        .map(|((gj, cj), wj)| (cj - a1 - b * gj).norm_sqr() * wj)
        .sum();
    let misfit_arcsec = (sq / s0).sqrt();
    misfit_arcsec.is_finite().then_some(OncePerTurn {
        a1,
        b,
        misfit_arcsec,
        tau_s,
        // With weights 1 / sigma^2: the chi-square, and a1's variance (N^-1)_00 = s2 / det.
        chi2: sq,
        a1_sigma_arcsec: (s2 / det).sqrt(),
    })
}

/// The `tau` grid: 0, then log-spaced.
fn tau_grid() -> Vec<f64> {
    let points = ((TAU_DECADES.1 - TAU_DECADES.0) * f64::from(TAU_PER_DECADE)).round() as i32;
    std::iter::once(0.0)
        .chain((0..=points).map(|i| 10f64.powf(TAU_DECADES.0 + f64::from(i) / f64::from(TAU_PER_DECADE))))
        .collect()
}

/// At least [`MIN_SPEEDS`] distinct speeds, spanning at least [`MIN_SPAN`].
fn check_speeds(fits: &[SpeedFit]) -> Result<(), FitError> {
    let mut speeds: Vec<f64> = fits.iter().map(|f| f.rpm.abs()).collect();
    speeds.sort_by(f64::total_cmp);
    let mut distinct = 0u32;
    let mut last = f64::NEG_INFINITY;
    for s in &speeds {
        if *s > last * (1.0 + SAME_SPEED) {
            distinct += 1;
            last = *s;
        }
    }
    if distinct < MIN_SPEEDS {
        return Err(FitError::TooFewSpeeds {
            speeds: distinct,
            needed: MIN_SPEEDS,
        });
    }
    let span = match (speeds.first(), speeds.last()) {
        (Some(lo), Some(hi)) => hi / lo,
        _ => 1.0,
    };
    if span < MIN_SPAN {
        return Err(FitError::NarrowSpan {
            span,
            needed: MIN_SPAN,
        });
    }
    Ok(())
}

/// Separates the encoder's error from a true variation over the speed fits (at least 3
/// distinct speeds, spanning at least a factor 2): for each `tau` on a grid (0, and
/// log-spaced over 1e-3..10 s), the complex linear least squares of
/// `c1(W_j) = a1 + b g_tau(W_j)`, `g_tau(W) = G_tau(W) / G_tau(W_ref)`, each speed weighted
/// by its noise (`1 / once_sigma^2`). Where a swing does not lower the chi-square by more
/// than [`NO_SWING_CHI2`] against none at all, none is claimed and the error is the
/// weighted mean of the speeds. Otherwise, of the `tau`s whose chi-square is within 1 of the
/// least, the smallest is taken (a slip damper before an inertia, where the speeds cannot
/// tell them apart), and the spread of `a1` over them is added to its standard error as
/// [`Separation::error_uncertainty_arcsec`].
///
/// `b` is then the variation at `reference_rpm`, in the fits' frame. The fits' measured
/// speeds are used, so the VFD's slip is accounted for.
///
/// `a1` is an extrapolation to infinite speed (where a true variation vanishes), and how
/// far it can be trusted depends on how well the speeds show the curvature that tells
/// `1/W` from `1/W^2`: with 10 000 counts latched at 1 kHz each speed's amplitude carries
/// 0.5-0.75 arcsec of quantisation noise (10 s), and over 60-200 rpm with `tau` = 0.027 s
/// that curvature is about 1 arcsec. Without a true variation `a1` is found to 1-3 % over
/// any span; with one, a wide span, the top speed above all, is what makes the separation
/// hold, and the uncertainty says how well it did.
///
/// The loop's slow trim of the VFD's reference is not in the model: while the loop
/// identifies the once-per-turn sine (from 60 rpm, where the procedure runs) it takes it out
/// of what the trim sees (below, the trim moves the swing: 15 % at 32 rpm).
pub fn separate(fits: &[SpeedFit], reference_rpm: f64) -> Result<Separation, FitError> {
    if !(reference_rpm.is_finite() && reference_rpm != 0.0) {
        return Err(FitError::Invalid {
            what: "the reference speed must be a non-zero number of rpm",
        });
    }
    if fits.iter().any(|f| {
        !(f.rpm.is_finite() && f.rpm != 0.0)
            || f.harmonics
                .iter()
                .any(|h| !(h.sin_arcsec.is_finite() && h.cos_arcsec.is_finite()))
    }) {
        return Err(FitError::Invalid {
            what: "a speed fit that is not a number",
        });
    }
    check_speeds(fits)?;

    // Each speed weighted by its noise (the quantisation and the latch jitter grow with
    // speed differently; a slow speed's blocks are fewer).
    let weights: Vec<f64> = fits
        .iter()
        .map(|f| 1.0 / f.once_sigma_arcsec.max(1e-3).powi(2))
        .collect();
    let c: Vec<Complex<f64>> = fits.iter().map(|f| f.harmonics[0].complex()).collect();
    let rpm: Vec<f64> = fits.iter().map(|f| f.rpm).collect();
    let solve = |tau_s: f64| fit_once_per_turn(&c, &rpm, &weights, reference_rpm, tau_s);

    // Every tau on the grid; the least chi-square, and the smallest tau (the simplest
    // dynamics: a slip damper before an inertia) that the speeds cannot reject against it.
    // Over this machine's speeds (30-212 rpm) an inertia bends the swing's curve by about
    // an arcsec, the speeds' noise: the least chi-square alone picked a tau ten times the
    // simulated machine's and an error a third low; the spread of a1 over the taus that
    // fit is its uncertainty, stated.
    // First: do the speeds need a swing at all? Without one the error is the weighted
    // mean of every speed's once-per-turn part, known far better than any extrapolation.
    let sum_w: f64 = weights.iter().sum();
    let mean = c
        .iter()
        .zip(&weights)
        .map(|(cj, wj)| cj * *wj)
        .sum::<Complex<f64>>()
        / sum_w;
    let chi2_still: f64 = c
        .iter()
        .zip(&weights)
        .map(|(cj, wj)| (cj - mean).norm_sqr() * wj)
        .sum();
    let fitted: Vec<OncePerTurn> = tau_grid().into_iter().filter_map(solve).collect();
    let least = fitted.iter().map(|f| f.chi2).fold(f64::INFINITY, f64::min);
    let acceptable: Vec<&OncePerTurn> = fitted.iter().filter(|f| f.chi2 <= least + 1.0).collect();
    let best = **acceptable
        .iter()
        .min_by(|a, b| a.tau_s.total_cmp(&b.tau_s))
        .ok_or(FitError::Singular)?;
    let (best, error_uncertainty_arcsec) = if chi2_still - least <= NO_SWING_CHI2 {
        // No swing the speeds could not do without: none is claimed.
        let still = OncePerTurn {
            a1: mean,
            b: Complex::new(0.0, 0.0),
            misfit_arcsec: (chi2_still / sum_w).sqrt(),
            tau_s: 0.0,
            chi2: chi2_still,
            a1_sigma_arcsec: (1.0 / sum_w).sqrt(),
        };
        (still, still.a1_sigma_arcsec)
    } else {
        let spread = acceptable
            .iter()
            .map(|f| (f.a1 - best.a1).norm())
            .fold(0.0, f64::max);
        (best, best.a1_sigma_arcsec + spread)
    };
    let weights: Vec<f64> = weights.iter().map(|x| x / weights.iter().sum::<f64>()).collect();

    let mut encoder = [Harmonic::from_complex(best.a1); 3];
    for (k, e) in encoder.iter_mut().enumerate().skip(1) {
        let sum: Complex<f64> = fits
            .iter()
            .zip(&weights)
            .map(|(f, wj)| f.harmonics[k].complex() * *wj)
            .sum();
        *e = Harmonic::from_complex(sum / weights.iter().sum::<f64>());
    }
    Ok(Separation {
        encoder,
        variation: Harmonic::from_complex(best.b),
        reference_rpm,
        tau_s: best.tau_s,
        misfit_arcsec: best.misfit_arcsec,
        error_uncertainty_arcsec,
    })
}

#[cfg(test)]
mod tests {
    //! A spindle simulated from the physics, written apart from the fit (nothing shared but
    //! the public types): `J theta'' = D (w_sync - theta') + T sin(theta + phi)`, integrated
    //! in 0.1 ms steps and latched every 1 ms with a little jitter, the VFD's slip (constant,
    //! plus a slow drift), the encoder's error added and the reading quantised to 10 000
    //! counts a turn.

    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::PI;
    use std::sync::OnceLock;

    const COUNT_DEG: f64 = 0.036;
    const ARCSEC_PER_RAD: f64 = 180.0 / PI * 3600.0;
    /// The simulated machine's J/D, s.
    const TAU_S: f64 = 0.027;
    const SPEEDS_RPM: [f64; 4] = [60.0, 90.0, 130.0, 200.0];
    const REFERENCE_RPM: f64 = 200.0;

    /// splitmix64: the tests' own noise, reproducible.
    struct Rng(u64);

    impl Rng {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            (z >> 11) as f64 / (1u64 << 53) as f64
        }

        /// Uniform in [-1, 1).
        fn symmetric(&mut self) -> f64 {
            2.0 * self.uniform() - 1.0
        }
    }

    /// The hidden machine.
    #[derive(Debug, Clone, Copy)]
    struct Spindle {
        /// J/D, s.
        tau_s: f64,
        /// T/D, rad/s: the unbalance torque over the slip's damping.
        torque_rad_s: f64,
        torque_phase_deg: f64,
        /// The encoder's error, harmonics 1..3: (amplitude arcsec, phase deg) of
        /// `amp sin(k theta + phase)`.
        errors: [(f64, f64); 3],
        /// The shaft runs this fraction below the VFD's synchronous speed ...
        slip: f64,
        /// ... which drifts by this fraction, with this period.
        drift: f64,
        drift_period_s: f64,
        /// Latch time jitter, +- s.
        jitter_s: f64,
        seed: u64,
    }

    impl Spindle {
        fn new(errors: [(f64, f64); 3], swing_at_reference_arcsec: f64, torque_phase_deg: f64) -> Self {
            // The torque that swings the shaft by the given amount at the reference speed:
            // |x| = (T/D) / (W |1 + i W tau|).
            let w = REFERENCE_RPM * 2.0 * PI / 60.0;
            let torque_rad_s =
                swing_at_reference_arcsec / ARCSEC_PER_RAD * w * (1.0 + (w * TAU_S).powi(2)).sqrt();
            Spindle {
                tau_s: TAU_S,
                torque_rad_s,
                torque_phase_deg,
                errors,
                slip: 0.015,
                drift: 0.002,
                drift_period_s: 12.0,
                jitter_s: 5e-6,
                seed: 7,
            }
        }

        /// The error's harmonic k as `amp e^{i phase}`, arcsec.
        fn error(&self, k: usize) -> Complex<f64> {
            let (amp, phase_deg) = self.errors[k];
            Complex::from_polar(amp, phase_deg.to_radians())
        }

        /// The true swing at a shaft speed, arcsec, `(T/D) e^{i phi} / (i W (1 + i W tau))`.
        fn swing(&self, shaft_rpm: f64) -> Complex<f64> {
            let w = shaft_rpm * 2.0 * PI / 60.0;
            let torque = Complex::from_polar(self.torque_rad_s, self.torque_phase_deg.to_radians());
            torque / (Complex::new(0.0, w) * Complex::new(1.0, w * self.tau_s)) * ARCSEC_PER_RAD
        }

        /// Readings every 1 ms for `seconds`, the VFD set to `rpm(t)`, after a second to
        /// settle.
        fn run(&self, rpm: impl Fn(f64) -> f64, seconds: f64) -> Vec<Reading> {
            let mut rng = Rng(self.seed ^ (rpm(0.0) * 1000.0) as u64);
            let drift_phase = 2.0 * PI * rng.uniform();
            let (dt, inner, settle) = (1e-4, 10, 10_000);
            let w_sync = |t: f64| {
                rpm(t) * 2.0 * PI / 60.0
                    * (1.0 - self.slip)
                    * (1.0 + self.drift * (2.0 * PI * t / self.drift_period_s + drift_phase).sin())
            };
            let phi = self.torque_phase_deg.to_radians();
            let (mut theta, mut v) = (0.0f64, w_sync(0.0));
            let mut t = -(settle as f64) * dt;
            let step = |theta: &mut f64, v: &mut f64, t: &mut f64| {
                let a = (w_sync(t.max(0.0)) - *v + self.torque_rad_s * (*theta + phi).sin()) / self.tau_s;
                *v += a * dt;
                *theta += *v * dt;
                *t += dt;
            };
            for _ in 0..settle {
                step(&mut theta, &mut v, &mut t);
            }
            let samples = (seconds * 1000.0).round() as usize;
            let mut out = Vec::with_capacity(samples);
            for n in 0..samples {
                let latched = theta + v * self.jitter_s * rng.symmetric();
                let error_arcsec: f64 = self
                    .errors
                    .iter()
                    .enumerate()
                    .map(|(k, (amp, ph))| amp * ((k as f64 + 1.0) * latched + ph.to_radians()).sin())
                    .sum();
                let raw_deg = latched.to_degrees() + error_arcsec / 3600.0;
                out.push(Reading {
                    t_s: n as f64 * 1e-3,
                    deg: (raw_deg / COUNT_DEG).floor() * COUNT_DEG,
                });
                for _ in 0..inner {
                    step(&mut theta, &mut v, &mut t);
                }
            }
            out
        }
    }

    fn complex(h: Harmonic) -> Complex<f64> {
        Complex::new(h.sin_arcsec, h.cos_arcsec)
    }

    /// The three hidden machines of the separation test.
    fn cases() -> [(&'static str, Spindle); 3] {
        [
            (
                "a1 15, swing 20",
                Spindle::new([(15.0, 40.0), (6.0, 10.0), (3.0, -120.0)], 20.0, 100.0),
            ),
            (
                "a1 40, no swing",
                Spindle::new([(40.0, -70.0), (5.0, 150.0), (2.0, 30.0)], 0.0, 0.0),
            ),
            (
                "a1 12, swing 30",
                Spindle::new([(12.0, 200.0), (4.0, -45.0), (3.0, 80.0)], 30.0, -30.0),
            ),
        ]
    }

    /// Each case's four runs of 10 s, simulated once for all the tests.
    fn runs() -> &'static Vec<Vec<Vec<Reading>>> {
        static RUNS: OnceLock<Vec<Vec<Vec<Reading>>>> = OnceLock::new();
        RUNS.get_or_init(|| {
            cases()
                .iter()
                .map(|(_, sp)| SPEEDS_RPM.iter().map(|rpm| sp.run(|_| *rpm, 10.0)).collect())
                .collect()
        })
    }

    fn fits(runs: &[Vec<Reading>]) -> Vec<SpeedFit> {
        runs.iter()
            .map(|r| fit_speed(r, COUNT_DEG).expect("a steady run fits"))
            .collect()
    }

    #[test]
    fn fit_speed_finds_the_encoders_harmonics() {
        let sp = Spindle::new([(26.0, 75.0), (6.0, -160.0), (3.0, 20.0)], 0.0, 0.0);
        for rpm in SPEEDS_RPM {
            let readings = sp.run(|_| rpm, 10.0);
            // The same run with samples lost: one in ten at random and a 50 ms burst.
            let mut rng = Rng(3);
            let gappy: Vec<Reading> = readings
                .iter()
                .enumerate()
                .filter(|(i, _)| !(4000..4050).contains(i) && rng.uniform() > 0.1)
                .map(|(_, r)| *r)
                .collect();
            for (what, run) in [("whole", &readings), ("gaps", &gappy)] {
                let fit = fit_speed(run, COUNT_DEG).expect("fits");
                let found: Vec<String> = fit
                    .harmonics
                    .iter()
                    .enumerate()
                    .map(|(k, h)| {
                        let miss = (complex(*h) - sp.error(k)).norm();
                        format!(
                            "{:.2} at {:.0} deg (off {miss:.2})",
                            h.amplitude_arcsec(),
                            h.phase_deg()
                        )
                    })
                    .collect();
                println!(
                    "{rpm} rpm ({what}): measured {:.2} rpm, {} blocks, {} samples, residual {:.1} arcsec; {}",
                    fit.rpm,
                    fit.blocks,
                    fit.samples,
                    fit.residual_arcsec,
                    found.join(", ")
                );
                assert!((complex(fit.harmonics[0]) - sp.error(0)).norm() < 0.1 * 26.0);
                assert!((complex(fit.harmonics[1]) - sp.error(1)).norm() < 1.5);
                assert!((complex(fit.harmonics[2]) - sp.error(2)).norm() < 1.5);
                assert!((fit.rpm - rpm * 0.985).abs() < 0.01 * rpm);
                assert!(fit.residual_arcsec < 0.5 * COUNT_DEG * 3600.0);
            }
        }
    }

    /// A run whose reading steps once against its time (the drive's physics a period ahead
    /// of the loop's count from one cycle on, as the simulated drives under a loaded host
    /// did): the block with the step is left out, and the rest finds the error.
    #[test]
    fn a_block_with_a_step_of_the_reading_is_left_out() {
        let sp = Spindle::new([(15.0, 40.0), (4.0, 10.0), (2.0, -60.0)], 0.0, 0.0);
        let readings = sp.run(|_| 64.3, 20.0);
        // From 9 s on, each reading is the one latched a period earlier (and the repeated
        // one left out, as the procedure leaves a held reading out).
        let stepped: Vec<Reading> = readings
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != 9_000)
            .map(|(i, r)| Reading {
                t_s: r.t_s,
                deg: if i > 9_000 { readings[i - 1].deg } else { r.deg },
            })
            .collect();
        let whole = fit_speed(&readings, COUNT_DEG).expect("fits");
        let fit = fit_speed(&stepped, COUNT_DEG).expect("fits");
        let miss = (complex(fit.harmonics[0]) - sp.error(0)).norm();
        println!(
            "a step of one period at 9 s: {} of {} blocks left out, once per turn {miss:.2} arcsec off \
             ({} blocks left out of the run without it)",
            fit.dropped_blocks,
            fit.blocks + fit.dropped_blocks,
            whole.dropped_blocks
        );
        assert_eq!(fit.dropped_blocks, 1);
        assert_eq!(whole.dropped_blocks, 0);
        assert!(miss < 1.5, "{miss} arcsec off");
    }

    /// Separates a case's fits, prints what it found beside the hidden values, and returns
    /// how far off a1 and the swing at the reference speed are (complex distances, arcsec).
    fn separate_and_show(name: &str, sp: &Spindle, fits: &[SpeedFit]) -> (f64, f64, f64) {
        let sep = separate(fits, REFERENCE_RPM).expect("separates");
        let a1 = sp.error(0);
        let swing = sp.swing(REFERENCE_RPM);
        let a1_miss = (complex(sep.encoder[0]) - a1).norm();
        let swing_miss = (complex(sep.variation) - swing).norm();
        println!(
            "--- {name}: hidden a1 {:.1} at {:.0} deg, swing {:.1} at {:.0} deg at 200 rpm, tau {TAU_S} s",
            a1.norm(),
            a1.arg().to_degrees(),
            swing.norm(),
            swing.arg().to_degrees()
        );
        for f in fits {
            println!(
                "  {:.1} rpm: c1 {:.2} at {:.0} deg (hidden a1 + swing: {:.2}), residual {:.1}",
                f.rpm,
                f.harmonics[0].amplitude_arcsec(),
                f.harmonics[0].phase_deg(),
                (a1 + sp.swing(f.rpm)).norm(),
                f.residual_arcsec
            );
        }
        println!("{}", sep.text());
        println!(
            "  a1 off by {a1_miss:.2} arcsec ({:.0} %), swing off by {swing_miss:.2} arcsec, tau {:.4} s",
            100.0 * a1_miss / a1.norm(),
            sep.tau_s
        );
        for k in 1..3 {
            assert!((complex(sep.encoder[k]) - sp.error(k)).norm() < 1.5);
        }
        (a1_miss, swing_miss, sep.error_uncertainty_arcsec)
    }

    /// The commissioning's speeds, 60 to 200 rpm, 10 s each. Without a true variation the
    /// error is found within 1-3 % (none claimed). With one (tau 0.027 s here), a1 is an
    /// extrapolation to infinite speed through a curvature in 1/W that the noise (0.5-0.75
    /// arcsec on each speed's c1) barely shows: the least misfit alone missed by 13-14 %
    /// median over 16 seeds and by 67 % at worst, where tau near 0 won. The separation now
    /// says so: its uncertainty holds the miss, and is then far above 10 % (the procedure
    /// refuses to write such a record).
    #[test]
    fn separate_at_60_to_200_rpm() {
        for ((name, sp), runs) in cases().iter().zip(runs()) {
            let (a1_miss, swing_miss, uncertainty) = separate_and_show(name, sp, &fits(runs));
            if sp.torque_rad_s == 0.0 {
                assert!(a1_miss < 0.1 * sp.errors[0].0, "{name}: a1 off by {a1_miss}");
                assert!(swing_miss < 1.0, "{name}: swing off by {swing_miss}");
                assert!(uncertainty < 0.1 * sp.errors[0].0, "{name}: +- {uncertainty}");
            } else {
                assert!(
                    a1_miss <= uncertainty,
                    "{name}: a1 off by {a1_miss}, +- {uncertainty}"
                );
                assert!(
                    swing_miss < uncertainty + 3.0,
                    "{name}: swing off by {swing_miss}"
                );
            }
        }
    }

    /// A wider span, 40 to 400 rpm, 15 s each: the top speed brings the data near the
    /// extrapolation's end (the swing 10 arcsec at 400 rpm) and the bottom one shows the
    /// curvature. Over 32 seeds the worst miss was 7 % (a1 15 with a 20 arcsec swing, and
    /// a1 12 with 30), the swing's worst 1.2 arcsec.
    #[test]
    fn separate_over_a_wide_span() {
        let speeds_rpm = [40.0, 60.0, 90.0, 130.0, 200.0, 300.0, 400.0];
        for (name, sp) in cases() {
            let fits: Vec<SpeedFit> = speeds_rpm
                .iter()
                .map(|rpm| fit_speed(&sp.run(|_| *rpm, 15.0), COUNT_DEG).expect("fits"))
                .collect();
            let (a1_miss, swing_miss, _) = separate_and_show(name, &sp, &fits);
            assert!(a1_miss < 0.1 * sp.errors[0].0, "{name}: a1 off by {a1_miss}");
            assert!(swing_miss < 2.0, "{name}: swing off by {swing_miss}");
        }
    }

    #[test]
    fn the_misfit_over_tau() {
        // Not an assertion of shape: printed for the record (cargo test -- --nocapture).
        for ((name, _), runs) in cases().iter().zip(runs()) {
            let fits = fits(runs);
            let c: Vec<Complex<f64>> = fits.iter().map(|f| complex(f.harmonics[0])).collect();
            let rpm: Vec<f64> = fits.iter().map(|f| f.rpm).collect();
            let weights = vec![1.0; fits.len()];
            let row: Vec<String> = [
                0.0, 0.001, 0.003, 0.01, 0.02, 0.027, 0.04, 0.07, 0.1, 0.3, 1.0, 10.0,
            ]
            .iter()
            .filter_map(|tau| {
                fit_once_per_turn(&c, &rpm, &weights, REFERENCE_RPM, *tau)
                    .map(|s| format!("{tau}: {:.2} (a1 {:.1})", s.misfit_arcsec, s.a1.norm()))
            })
            .collect();
            println!("{name}: misfit (arcsec) over tau (s): {}", row.join(", "));
        }
    }

    #[test]
    fn one_speed_alone_is_off_by_the_swing() {
        let (name, sp) = cases()[0];
        for (rpm, run) in SPEEDS_RPM.iter().zip(&runs()[0]) {
            let fit = fit_speed(run, COUNT_DEG).expect("fits");
            let off = (complex(fit.harmonics[0]) - sp.error(0)).norm();
            let swing = sp.swing(fit.rpm).norm();
            println!(
                "{name}, {rpm} rpm alone: found {:.1} arcsec for a {:.1} arcsec error, off by {off:.1} (the swing there {swing:.1})",
                fit.harmonics[0].amplitude_arcsec(),
                sp.errors[0].0
            );
            assert!((off - swing).abs() < 3.0);
            assert!(off > 0.5 * sp.errors[0].0);
        }
    }

    /// `G(W)/G(W_ref)` written out again for the test: `G(W) = 1 / (i W (1 + i W tau))`.
    fn g(rpm: f64, reference_rpm: f64, tau_s: f64) -> Complex<f64> {
        let big_g = |w: f64| 1.0 / (Complex::new(0.0, w) * Complex::new(1.0, w * tau_s));
        big_g(rpm * PI / 30.0) / big_g(reference_rpm * PI / 30.0)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// The separation as the machine file records it (`super::super::record`, rounded as
        /// written) gives the loop's identifier (`SpindleSwing::encoder_share`, hob-config)
        /// the factor that leaves the encoder's part of what it sees at any speed, in any
        /// counter frame: the two sides' conventions (phase, frame, G) agree.
        #[test]
        fn the_record_leaves_the_loop_the_encoders_part(
            a1_arcsec in 1.0f64..60.0,
            a1_phase_deg in -180.0f64..180.0,
            b_arcsec in 0.0f64..60.0,
            b_phase_deg in -180.0f64..180.0,
            tau_s in prop_oneof![Just(0.0), 1e-3f64..10.0],
            reference_rpm in 30.0f64..210.0,
            rpm in 30.0f64..210.0,
        ) {
            // In the identifier's frame (any counter zero): c = a1 + b g(W).
            let a1 = Complex::from_polar(a1_arcsec, a1_phase_deg.to_radians());
            let b = Complex::from_polar(b_arcsec, b_phase_deg.to_radians());
            let bg = b * g(rpm, reference_rpm, tau_s);
            let c = a1 + bg;
            let separation = Separation {
                encoder: [Harmonic::new(a1.re, a1.im), Harmonic::default(), Harmonic::default()],
                variation: Harmonic::new(b.re, b.im),
                reference_rpm,
                tau_s,
                misfit_arcsec: 0.0,
                error_uncertainty_arcsec: 0.0,
            };
            let text = super::super::proposal("", &separation, &[60.0, 120.0, 200.0], "2026-11-29T02:00:00Z");
            let record: hob_setup::config::machine::commissioning::SpindleEncoderRecord =
                toml::from_str::<toml::Table>(&text)
                    .ok()
                    .and_then(|t| t.get("commissioning")?.get("spindle_encoder").cloned())
                    .and_then(|v| v.try_into().ok())
                    .expect("the proposal's record reads back");
            let conditioned = c.norm() / a1.norm().max(bg.norm());
            match record.swing().encoder_share(rpm) {
                Some((re, im)) => {
                    let corrected = c * Complex::new(re, im);
                    // The record is written rounded (0.01 arcsec, 0.1 deg, 0.1 ms of tau).
                    prop_assert!((corrected - a1).norm() <= 0.02 * (1.0 + a1.norm() + bg.norm()) / conditioned.max(0.1),
                        "c {c} share {re} {im} gives {corrected}, a1 {a1}");
                }
                None => prop_assert!(conditioned <= 0.11, "refused at {conditioned}"),
            }
        }
    }

    #[test]
    fn fit_speed_refuses_what_it_cannot_fit() {
        let sp = Spindle::new([(26.0, 75.0), (6.0, -160.0), (3.0, 20.0)], 20.0, 0.0);
        // 2 s at 130 rpm: 4.3 turns, three blocks of 4 turns needed.
        let short = sp.run(|_| 130.0, 2.0);
        let e = fit_speed(&short, COUNT_DEG).expect_err("too short");
        println!("{e}");
        assert!(matches!(e, FitError::TooShort { .. }), "{e:?}");
        // The VFD ramping from 100 to 140 rpm over the run.
        let ramp = sp.run(|t| 100.0 + 4.0 * t, 10.0);
        let e = fit_speed(&ramp, COUNT_DEG).expect_err("not steady");
        println!("{e}");
        assert!(
            matches!(e, FitError::NotSteady { spread_percent, .. } if spread_percent > 10.0),
            "{e:?}"
        );
        // 20 rpm.
        let slow = sp.run(|_| 20.0, 15.0);
        let e = fit_speed(&slow, COUNT_DEG).expect_err("too slow");
        println!("{e}");
        assert!(matches!(e, FitError::TooSlow { .. }), "{e:?}");
        // A 0.1 deg vibration at 37 Hz on top: not a cubic plus harmonics of the angle.
        let shaken: Vec<Reading> = sp
            .run(|_| 130.0, 10.0)
            .iter()
            .map(|r| Reading {
                t_s: r.t_s,
                deg: r.deg + 0.1 * (2.0 * PI * 37.0 * r.t_s).sin(),
            })
            .collect();
        let e = fit_speed(&shaken, COUNT_DEG).expect_err("residual");
        println!("{e}");
        assert!(matches!(e, FitError::Residual { .. }), "{e:?}");
        // Samples lost over most of the run.
        let sparse: Vec<Reading> = sp.run(|_| 130.0, 10.0).into_iter().step_by(200).collect();
        let e = fit_speed(&sparse, COUNT_DEG).expect_err("too few");
        println!("{e}");
        assert!(matches!(e, FitError::TooFewSamples { .. }), "{e:?}");
        // Time going backwards, a nonsense count.
        let mut backwards = short.clone();
        backwards.swap(100, 101);
        assert_eq!(
            fit_speed(&backwards, COUNT_DEG),
            Err(FitError::TimeNotIncreasing { index: 101 })
        );
        assert!(matches!(fit_speed(&short, 0.0), Err(FitError::Invalid { .. })));
    }

    #[test]
    fn separate_refuses_too_few_or_too_close_speeds() {
        let fit = |rpm: f64| SpeedFit {
            rpm,
            harmonics: [
                Harmonic::new(10.0, 5.0 + 100.0 / rpm),
                Harmonic::default(),
                Harmonic::default(),
            ],
            residual_arcsec: 37.0,
            blocks: 5,
            samples: 10_000,
            once_sigma_arcsec: 0.5,
            dropped_blocks: 0,
        };
        let e = separate(&[fit(60.0), fit(200.0)], 200.0).expect_err("two speeds");
        println!("{e}");
        assert_eq!(e, FitError::TooFewSpeeds { speeds: 2, needed: 3 });
        // Three fits, two of them the same speed.
        let e = separate(&[fit(60.0), fit(61.0), fit(200.0)], 200.0).expect_err("two distinct");
        assert_eq!(e, FitError::TooFewSpeeds { speeds: 2, needed: 3 });
        let e = separate(&[fit(100.0), fit(130.0), fit(180.0)], 200.0).expect_err("narrow");
        println!("{e}");
        assert!(
            matches!(e, FitError::NarrowSpan { span, .. } if (span - 1.8).abs() < 1e-9),
            "{e:?}"
        );
        assert!(separate(&[fit(60.0), fit(90.0), fit(130.0)], 200.0).is_ok());
        assert!(matches!(
            separate(&[fit(60.0), fit(90.0), fit(130.0)], 0.0),
            Err(FitError::Invalid { .. })
        ));
    }

    #[test]
    fn harmonic_convention() {
        // amp sin(theta + phi) = amp cos(phi) sin(theta) + amp sin(phi) cos(theta).
        let h = Harmonic::from_polar(10.0, 30.0);
        assert!((h.sin_arcsec - 10.0 * 30f64.to_radians().cos()).abs() < 1e-12);
        assert!((h.cos_arcsec - 5.0).abs() < 1e-12);
        assert!((h.phase_deg() - 30.0).abs() < 1e-12);
        assert!((h.amplitude_arcsec() - 10.0).abs() < 1e-12);
        let q = (h * Harmonic::from_polar(2.0, 15.0)).checked_div(Harmonic::from_polar(4.0, 45.0));
        let q = q.expect("non-zero");
        assert!((q.amplitude_arcsec() - 5.0).abs() < 1e-12 && q.phase_deg().abs() < 1e-12);
        assert_eq!(h.checked_div(Harmonic::default()), None);
    }

    #[test]
    fn a_reversed_spindle_mirrors_the_harmonics() {
        // The same runs read backwards (the counter counting down): rpm negative, every
        // harmonic its conjugate (sin(-k r) = -sin(k r)), the separation at -200 rpm the
        // conjugate of the one at +200.
        let plain = fits(&runs()[0]);
        let mirrored: Vec<SpeedFit> = runs()[0]
            .iter()
            .map(|run| {
                let back: Vec<Reading> = run
                    .iter()
                    .map(|r| Reading {
                        t_s: r.t_s,
                        deg: -r.deg,
                    })
                    .collect();
                fit_speed(&back, COUNT_DEG).expect("fits")
            })
            .collect();
        for (p, m) in plain.iter().zip(&mirrored) {
            assert!((p.rpm + m.rpm).abs() < 1e-9);
            for k in 0..3 {
                assert!((complex(p.harmonics[k]).conj() - complex(m.harmonics[k])).norm() < 1e-6);
            }
        }
        let (p, m) = (
            separate(&plain, REFERENCE_RPM).expect("separates"),
            separate(&mirrored, -REFERENCE_RPM).expect("separates"),
        );
        assert!((complex(p.encoder[0]).conj() - complex(m.encoder[0])).norm() < 1e-4);
        assert!((complex(p.variation).conj() - complex(m.variation)).norm() < 1e-4);
    }

    /// The separation of case 0 with the counter's zero moved by `delta_deg`.
    fn separation_shifted(delta_deg: f64) -> (Vec<SpeedFit>, Separation) {
        let fits: Vec<SpeedFit> = runs()[0]
            .iter()
            .map(|run| {
                let shifted: Vec<Reading> = run
                    .iter()
                    .map(|r| Reading {
                        t_s: r.t_s,
                        deg: r.deg + delta_deg,
                    })
                    .collect();
                fit_speed(&shifted, COUNT_DEG).expect("fits")
            })
            .collect();
        let sep = separate(&fits, REFERENCE_RPM).expect("separates");
        (fits, sep)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(8))]

        #[test]
        fn a_new_counter_zero_changes_only_phases(delta_deg in -10_000.0f64..10_000.0) {
            static PLAIN: OnceLock<(Vec<SpeedFit>, Separation)> = OnceLock::new();
            let (fits0, sep0) = PLAIN.get_or_init(|| separation_shifted(0.0));
            let (fits, sep) = separation_shifted(delta_deg);
            // To rounding: the per-speed fits agree to 1e-9 arcsec; the separation's tau is a
            // golden-section minimum of a flat misfit, found to about 1e-8 s, and a1 moves by
            // some 400 arcsec per second of tau.
            let same = |a: f64, b: f64| (a - b).abs() < 1e-4;
            for (f0, f) in fits0.iter().zip(&fits) {
                for k in 0..3 {
                    prop_assert!(same(f0.harmonics[k].amplitude_arcsec(), f.harmonics[k].amplitude_arcsec()));
                    // Harmonic k turns by -k delta.
                    let turned = complex(f0.harmonics[k])
                        * Complex::from_polar(1.0, -(k as f64 + 1.0) * delta_deg.to_radians());
                    prop_assert!((turned - complex(f.harmonics[k])).norm() < 1e-4);
                }
                prop_assert!(same(f0.residual_arcsec, f.residual_arcsec));
            }
            for k in 0..3 {
                prop_assert!(same(sep0.encoder[k].amplitude_arcsec(), sep.encoder[k].amplitude_arcsec()));
            }
            prop_assert!(same(sep0.variation.amplitude_arcsec(), sep.variation.amplitude_arcsec()));
            let (r0, r) = (sep0.variation_relative(), sep.variation_relative());
            prop_assert!((complex(r0) - complex(r)).norm() < 1e-4, "{r0:?} {r:?}");
            prop_assert!((sep0.tau_s - sep.tau_s).abs() <= 1e-5 * sep0.tau_s.max(1e-3));
        }
    }
}
