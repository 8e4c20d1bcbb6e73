//! The spindle encoder's once-per-turn error, identified while the spindle turns and taken
//! out of its reading.
//!
//! An encoder's code disc is never exactly centred: its reading is off by a sine of the
//! angle, once per turn (a 2500-line encoder of the Heidenhain ERN/ROD 400 kind is
//! specified at +-1/20 of its grating period, 26 arcsec). The table follows the spindle
//! through the gearbox, so the table carries that sine divided by the ratio; with a
//! multi-start hob the teeth are generated at different phases of the hob's turn and the
//! sine becomes a pitch error between them (docs/accuracy.md, "The spindle encoder").
//!
//! The error is fixed to the disc, so it is fixed to the encoder's counts for as long as the
//! controller runs (the counter is incremental: after a power cycle the phase is new, so it
//! is identified anew at each start-up, not stored). Over every four turns of the spindle
//! the readings are fitted by least squares, each sample weighted by a Hann window over
//! the four turns, with a quadratic in time (the motion: speed and a steady acceleration)
//! plus a sine and a cosine of the reading (the error): five parameters, normal equations
//! accumulated sample by sample in a fixed 5x5 matrix and solved (Cholesky) once per fit.
//! A fit that leaves more than a count of RMS residual was not a quadratic motion (a speed
//! change) and is dropped; the accepted fits' sine and cosine are averaged with a
//! forgetting time constant. The fit reads the raw counts, so the correction it applies
//! never feeds back into what it learns. Quantisation (130 arcsec a count on 2500 lines)
//! is noise that the fit over hundreds of samples and the averaging over fits remove.
//!
//! Allocation-free (fixed-size matrices), bounded work per cycle; the correction is
//! limited to [`MAX_CORRECTION_DEG`].

use hob_setup::config::machine::commissioning::SpindleSwing;
use nalgebra::{Matrix5, Vector5};

/// The largest correction the identifier applies (a tenth of a degree: four times the
/// specified error of the 2500-line encoder; larger is a broken encoder, not eccentricity).
pub const MAX_CORRECTION_DEG: f64 = 0.1;

/// Each fit spans this many turns, its samples weighted by a Hann window over them: the
/// cut's torque ripple is a whole harmonic of the turn (the gash frequency), and without
/// the taper it leaks into the once-per-turn sine through the quadratic (a 0.2 % ripple
/// at 6 per turn made 7 arcsec of a 26 arcsec error).
const TURNS_PER_FIT: f64 = 4.0;

/// A fit must hold at least this many samples (600 rpm at 1 kHz) ...
const MIN_SAMPLES_PER_FIT: u32 = 400;

/// ... and take at most this long (60 rpm): slower, the quadratic no longer holds the
/// motion over the fit and the VFD's slip dominates.
const MAX_FIT_S: f64 = 4.0;

/// A fit that leaves more RMS residual than this many counts is dropped.
const MAX_RESIDUAL_COUNTS: f64 = 1.0;

/// One fit's normal equations (over `TURNS_PER_FIT` turns).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
struct Fit {
    start_deg: f64,
    samples: u32,
    elapsed_s: f64,
    ata: Matrix5<f64>,
    atb: Vector5<f64>,
    btb: f64,
    /// Sum of the samples' weights.
    weight: f64,
}

impl Fit {
    fn new(start_deg: f64) -> Self {
        Self {
            start_deg,
            samples: 0,
            elapsed_s: 0.0,
            ata: Matrix5::zeros(),
            atb: Vector5::zeros(),
            btb: 0.0,
            weight: 0.0,
        }
    }

    fn add(&mut self, reading_deg: f64) {
        let (s, c) = reading_deg.to_radians().sin_cos();
        let t = self.elapsed_s;
        let row = Vector5::new(1.0, t, t * t, s, c);
        let y = reading_deg - self.start_deg;
        let progress = (y.abs() / (360.0 * TURNS_PER_FIT)).min(1.0);
        let w = (std::f64::consts::PI * progress).sin().powi(2);
        self.ata += w * row * row.transpose();
        self.atb += w * row * y;
        self.btb += w * y * y;
        self.weight += w;
        self.samples += 1;
    }

    /// The fitted sine and cosine (deg) and the fit's RMS residual (deg).
    fn solve(&self) -> Option<(f64, f64, f64)> {
        let beta = self.ata.cholesky()?.solve(&self.atb);
        let rss = (self.btb - beta.dot(&self.atb)).max(0.0);
        Some((beta[3], beta[4], (rss / self.weight).sqrt()))
    }
}

/// The once-per-turn correction of the spindle encoder, identified online.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EccentricityIdentifier {
    period_s: f64,
    /// Forgetting time constant, s (0: identification off, the reading passes unchanged).
    time_constant_s: f64,
    count_deg: f64,
    fit: Option<Fit>,
    /// The correction's sine and cosine components, deg of spindle.
    sin_deg: f64,
    cos_deg: f64,
    /// Fits accepted, and dropped (their residual: not a quadratic motion). A fit that
    /// took too long or held too few samples is restarted without counting.
    accepted: u32,
    dropped: u32,
    /// The spindle's true swing beside the error, as commissioning told them apart (`hob
    /// commission encoder`): each fit keeps only the encoder's share of its sine. None:
    /// all of it is taken for the encoder's error.
    swing: Option<SpindleSwing>,
}

impl EccentricityIdentifier {
    /// Sampled every `period_s`, readings quantised to `count_deg`, forgetting with time
    /// constant `time_constant_s` (0: off).
    pub fn new(period_s: f64, time_constant_s: f64, count_deg: f64) -> Self {
        Self {
            period_s,
            time_constant_s,
            count_deg,
            fit: None,
            sin_deg: 0.0,
            cos_deg: 0.0,
            accepted: 0,
            dropped: 0,
            swing: None,
        }
    }

    /// Keeps only the encoder's share of each fit, the spindle's true `swing` left in the
    /// reading for the table to follow.
    pub fn with_swing(mut self, swing: Option<SpindleSwing>) -> Self {
        self.swing = swing;
        self
    }

    /// The correction for a reading (deg of spindle): what to subtract from it.
    pub fn correction_deg(&self, reading_deg: f64) -> f64 {
        let (s, c) = reading_deg.to_radians().sin_cos();
        self.sin_deg * s + self.cos_deg * c
    }

    /// Amplitude of the correction identified so far, arcsec of spindle.
    pub fn amplitude_arcsec(&self) -> f64 {
        self.sin_deg.hypot(self.cos_deg) * 3600.0
    }

    /// The correction's sine and cosine components, arcsec of spindle: the correction is
    /// `sin * sin(reading) + cos * cos(reading)`.
    pub fn components_arcsec(&self) -> (f64, f64) {
        (self.sin_deg * 3600.0, self.cos_deg * 3600.0)
    }

    /// Fits accepted into the identification so far, and fits dropped.
    pub fn fits(&self) -> (u32, u32) {
        (self.accepted, self.dropped)
    }

    /// Takes this cycle's raw reading (deg, continuous), learning from it where it is
    /// `fresh` (a held reading is not a measurement; the fit's clock still runs); returns
    /// the reading less the correction identified so far.
    pub fn update(&mut self, reading_deg: f64, fresh: bool) -> f64 {
        if self.time_constant_s > 0.0 {
            self.learn(reading_deg, fresh);
        }
        reading_deg - self.correction_deg(reading_deg)
    }

    fn learn(&mut self, reading: f64, fresh: bool) {
        if let Some(fit) = &mut self.fit {
            fit.elapsed_s += self.period_s;
        }
        if !fresh {
            return;
        }
        let fit = self.fit.get_or_insert_with(|| Fit::new(reading));
        fit.add(reading);
        let done = (reading - fit.start_deg).abs() >= 360.0 * TURNS_PER_FIT;
        if !done && fit.elapsed_s <= MAX_FIT_S {
            return;
        }
        // Too slow (not done in time) or too fast (too few samples) is not a fit that
        // failed: it restarts without counting.
        if done && fit.samples >= MIN_SAMPLES_PER_FIT {
            // The fit's mean speed: the swing's share of its sine depends on it. A reading
            // that counts down sees every once-per-turn sine mirrored (the conjugate), the
            // record's share with it.
            let rpm = (reading - fit.start_deg) / fit.elapsed_s.max(self.period_s) / 6.0;
            let share = match self.swing {
                None => Some((1.0, 0.0)),
                Some(sw) => sw
                    .encoder_share(rpm.abs())
                    .map(|(re, im)| if rpm < 0.0 { (re, -im) } else { (re, im) }),
            };
            match (fit.solve(), share) {
                (Some((s, c, rms)), Some((fr, fi))) if rms <= MAX_RESIDUAL_COUNTS * self.count_deg => {
                    // The encoder's share: (s + ic) (fr + i fi).
                    let (s, c) = (s * fr - c * fi, s * fi + c * fr);
                    self.accepted += 1;
                    // The first fits are averaged evenly, then each weighs by its time.
                    let w = (1.0 / f64::from(self.accepted))
                        .max(1.0 - (-fit.elapsed_s / self.time_constant_s).exp());
                    self.sin_deg = (self.sin_deg + w * (s - self.sin_deg))
                        .clamp(-MAX_CORRECTION_DEG, MAX_CORRECTION_DEG);
                    self.cos_deg = (self.cos_deg + w * (c - self.cos_deg))
                        .clamp(-MAX_CORRECTION_DEG, MAX_CORRECTION_DEG);
                }
                _ => self.dropped += 1,
            }
        }
        *fit = Fit::new(reading);
        fit.add(reading);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observer::SpindleObserver;
    use proptest::prelude::*;

    const COUNT_DEG: f64 = 0.036; // 10 000 counts a turn

    /// The reading of an encoder with a once-per-turn error (`amp_arcsec`, `phase_rad`)
    /// on a spindle at `rpm` with a speed ripple at the gash frequency.
    fn reading(t: f64, rpm: f64, amp_arcsec: f64, phase_rad: f64) -> (f64, f64) {
        let w = rpm * 6.0;
        let truth =
            w * t + 0.002 * w / (std::f64::consts::TAU * 35.0) * (std::f64::consts::TAU * 35.0 * t).sin();
        let read = truth + amp_arcsec / 3600.0 * (truth.to_radians() + phase_rad).sin();
        ((read / COUNT_DEG).floor() * COUNT_DEG, truth)
    }

    /// Runs `seconds` at `rpm` through the identifier and the main observer as the loop
    /// runs them; returns the once-per-turn part of the main estimate's error against the
    /// truth over the last two seconds, arcsec (with the identifier, and without), and the
    /// identifier.
    fn run(
        rpm: f64,
        amp_arcsec: f64,
        phase_rad: f64,
        seconds: f64,
        time_constant_s: f64,
    ) -> (f64, f64, EccentricityIdentifier) {
        let mut id = EccentricityIdentifier::new(0.001, time_constant_s, COUNT_DEG);
        let (mut main, mut plain) = (
            SpindleObserver::new(0.001, 10.0),
            SpindleObserver::new(0.001, 10.0),
        );
        let n = (seconds * 1000.0) as u32;
        let (mut with, mut without) = ([0.0f64; 2], [0.0f64; 2]);
        let mut samples = 0.0;
        for k in 0..n {
            let t = f64::from(k) * 0.001;
            let (read, truth) = reading(t, rpm, amp_arcsec, phase_rad);
            let est = main.update(id.update(read, true));
            let p = plain.update(read);
            if k + 2000 > n {
                let (s, c) = truth.to_radians().sin_cos();
                let (a, b) = (est.angle_deg - truth, p.angle_deg - truth);
                with = [with[0] + a * s, with[1] + a * c];
                without = [without[0] + b * s, without[1] + b * c];
                samples += 1.0;
            }
        }
        let amplitude = |x: [f64; 2]| 2.0 * x[0].hypot(x[1]) / samples * 3600.0;
        (amplitude(with), amplitude(without), id)
    }

    #[test]
    fn the_specified_error_is_identified_and_taken_out() {
        for (rpm, phase) in [(200.0, 1.0), (140.0, 4.0), (350.0, 2.5)] {
            let (with, without, id) = run(rpm, 26.0, phase, 15.0, 5.0);
            // The true error 26 sin(angle + phase) = 26 cos(phase) sin + 26 sin(phase) cos.
            let (s, c) = id.components_arcsec();
            let miss = (s - 26.0 * f64::cos(phase)).hypot(c - 26.0 * f64::sin(phase));
            println!(
                "{rpm} rpm: identified {:.1} arcsec, {miss:.1} from the truth; once-per-turn part of the estimate's error {with:.1} arcsec with, {without:.1} without",
                id.amplitude_arcsec()
            );
            assert!(miss < 4.0, "{rpm} rpm: {miss} arcsec from the true error");
            assert!(with < 0.5 * without, "{with} against {without}");
        }
    }

    /// The identified sine at `rpm` (complex S + iC, arcsec) of an encoder erring by 26
    /// arcsec on a spindle that truly swings once per turn, as a torque against slip and
    /// inertia moves it (written here apart from `SpindleSwing`: `1 / (i W (1 + i W tau))`),
    /// by an identifier told of the swing or not.
    ///
    /// `reversed`: the encoder counts down as the spindle turns (its polarity), and every
    /// once-per-turn sine of its reading is the conjugate.
    fn identified_beside_a_swing(rpm: f64, told: bool, reversed: bool) -> ((f64, f64), (f64, f64)) {
        let (tau, reference_rpm) = (0.012, 200.0);
        // The swing at the reference: 30 arcsec, 110 deg from the error's phase.
        let (swing, at) = (30.0f64, 110f64.to_radians());
        let g = |rpm: f64| {
            let w = rpm * std::f64::consts::TAU / 60.0;
            let (re, im) = (-w * w * tau, w);
            let n = re * re + im * im;
            (re / n, -im / n)
        };
        let mul = |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
        let (g1, g0) = (g(rpm), g(reference_rpm));
        let n0 = g0.0 * g0.0 + g0.1 * g0.1;
        // In the counter's frame, turned by 2 rad from the error's own.
        let frame = (2f64.cos(), 2f64.sin());
        let error = mul((26.0, 0.0), frame);
        let swing_now = mul(
            mul(
                (swing * at.cos(), swing * at.sin()),
                mul(g1, (g0.0 / n0, -g0.1 / n0)),
            ),
            frame,
        );
        let sine = |z: (f64, f64), a_deg: f64| {
            let (s, c) = a_deg.to_radians().sin_cos();
            (z.0 * s + z.1 * c) / 3600.0
        };
        let record = hob_setup::config::machine::commissioning::SpindleSwing {
            error_arcsec: 26.0,
            swing_sin_arcsec: swing * at.cos(),
            swing_cos_arcsec: swing * at.sin(),
            tau_s: tau,
            reference_rpm,
        };
        let mut id = EccentricityIdentifier::new(0.001, 5.0, COUNT_DEG).with_swing(told.then_some(record));
        for k in 0..20_000 {
            let steady = rpm * 6.0 * f64::from(k) * 0.001;
            let truth = steady + sine(swing_now, steady);
            let read = truth + sine(error, truth);
            let read = if reversed { -read } else { read };
            id.update((read / COUNT_DEG).floor() * COUNT_DEG, true);
        }
        let error = if reversed { (error.0, -error.1) } else { error };
        (id.components_arcsec(), error)
    }

    #[test]
    fn told_of_the_swing_it_corrects_only_the_encoders_error() {
        // Not whole counts a sample (15 at 90 rpm, 35 at 210): the quantisation would lock
        // to the angle and the identifier find three times the error.
        for (rpm, reversed) in [(93.7, false), (141.3, false), (207.9, false), (141.3, true)] {
            let (told, error) = identified_beside_a_swing(rpm, true, reversed);
            let (untold, _) = identified_beside_a_swing(rpm, false, reversed);
            let miss = |c: (f64, f64)| (c.0 - error.0).hypot(c.1 - error.1);
            println!(
                "{rpm} rpm{}: {:.1} arcsec from the error told of the swing, {:.1} untold",
                if reversed { " counting down" } else { "" },
                miss(told),
                miss(untold)
            );
            assert!(miss(told) < 2.6, "{rpm} rpm: {} arcsec off told", miss(told));
            assert!(miss(untold) > 10.0, "{rpm} rpm: the swing made no difference");
        }
    }

    #[test]
    fn off_passes_the_reading_unchanged() {
        let mut id = EccentricityIdentifier::new(0.001, 0.0, COUNT_DEG);
        for k in 0..5000 {
            let r = f64::from(k) * 1.2;
            assert_eq!(id.update(r, true), r);
        }
        assert_eq!(id.amplitude_arcsec(), 0.0);
    }

    #[test]
    fn below_the_identification_speed_nothing_is_learnt() {
        // 20 rpm: a turn takes 3 s, longer than a quadratic holds the motion.
        let (_, _, id) = run(20.0, 26.0, 0.3, 10.0, 1.0);
        assert_eq!(id.fits(), (0, 0));
        assert_eq!(id.amplitude_arcsec(), 0.0);
    }

    #[test]
    fn a_speed_change_within_a_turn_is_dropped_not_learnt() {
        // The VFD ramps 0 -> 200 rpm in 1 s, then holds: the ramp's start and end fall
        // inside turns that no quadratic fits.
        let mut id = EccentricityIdentifier::new(0.001, 1.0, COUNT_DEG);
        let mut angle = 0.0f64;
        let mut speed = 0.0f64;
        for k in 0..6000 {
            let accel = if k < 1000 { 1200.0 } else { 0.0 };
            speed += accel * 0.001;
            angle += speed * 0.001;
            id.update((angle / COUNT_DEG).floor() * COUNT_DEG, true);
        }
        let (accepted, dropped) = id.fits();
        assert!(
            accepted >= 3 && dropped >= 1,
            "{accepted} accepted, {dropped} dropped"
        );
        assert!(id.amplitude_arcsec() < 5.0, "{}", id.amplitude_arcsec());
    }

    #[test]
    fn a_perfect_encoder_gets_no_correction_to_speak_of() {
        let (with, _, id) = run(200.0, 0.0, 0.0, 15.0, 5.0);
        println!(
            "perfect encoder: identified {:.1} arcsec, once-per-turn error {with:.1}",
            id.amplitude_arcsec()
        );
        assert!(id.amplitude_arcsec() < 5.0, "{}", id.amplitude_arcsec());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]
        #[test]
        fn the_correction_is_bounded_and_finite(
            rpm in 130.0f64..400.0,
            amp in 0.0f64..2000.0,
            phase in 0.0f64..6.3,
        ) {
            let (_, _, id) = run(rpm, amp, phase, 3.0, 0.5);
            prop_assert!(id.fits().0 > 0);
            prop_assert!(id.amplitude_arcsec().is_finite());
            prop_assert!(id.amplitude_arcsec() <= MAX_CORRECTION_DEG * 3600.0 * std::f64::consts::SQRT_2 + 1e-9);
        }
    }
}
