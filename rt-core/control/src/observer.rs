//! The spindle angle from a quantised encoder: unwrap, observe, predict.
//!
//! The table must follow the spindle angle at the instant its command takes effect, one
//! cycle plus the drive delay after the angle was latched (docs/domain.md section 3: one
//! cycle late is ~55 um at the pitch circle at 212 rpm). A third-order tracking observer
//! (a critically damped g-h-k filter) estimates angle, speed and acceleration from the
//! counts; quantisation (1 count = 0.036 deg) is noise it filters, not an error it keeps.

/// Extends a wrapping 32-bit counter to a continuous 64-bit one (`hob_gearing::units`).
pub use hob_gearing::units::Unwrapper;

/// Spindle state estimated by [`SpindleObserver`].
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpindleEstimate {
    pub angle_deg: f64,
    pub speed_deg_s: f64,
    pub accel_deg_s2: f64,
}

impl SpindleEstimate {
    /// The angle `horizon_s` after the estimate's instant.
    pub fn predict_deg(&self, horizon_s: f64) -> f64 {
        self.angle_deg + self.speed_deg_s * horizon_s + 0.5 * self.accel_deg_s2 * horizon_s * horizon_s
    }
}

/// Critically damped third-order tracking observer (fading-memory g-h-k filter).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpindleObserver {
    period_s: f64,
    g: f64,
    h: f64,
    k: f64,
    state: Option<SpindleEstimate>,
}

impl SpindleObserver {
    /// An observer of bandwidth `bandwidth_hz` sampled every `period_s`.
    pub fn new(period_s: f64, bandwidth_hz: f64) -> Self {
        let theta = (-std::f64::consts::TAU * bandwidth_hz * period_s).exp();
        let one = 1.0 - theta;
        Self {
            period_s,
            g: 1.0 - theta * theta * theta,
            h: 1.5 * one * one * (1.0 + theta),
            k: 0.5 * one * one * one,
            state: None,
        }
    }

    /// The same observer with the gains of another bandwidth, its state kept (a replay's
    /// "what if": `hob replay --observer-bandwidth-hz`).
    pub fn with_bandwidth(&self, bandwidth_hz: f64) -> Self {
        Self {
            state: self.state,
            ..Self::new(self.period_s, bandwidth_hz)
        }
    }

    /// Forgets the state (the next measurement starts it again at rest).
    pub fn reset(&mut self) {
        self.state = None;
    }

    /// Feeds the angle measured at this cycle's sync instant; returns the estimate for
    /// that instant.
    pub fn update(&mut self, measured_deg: f64) -> SpindleEstimate {
        let t = self.period_s;
        let est = match self.state {
            None => SpindleEstimate {
                angle_deg: measured_deg,
                ..SpindleEstimate::default()
            },
            Some(s) => {
                let x = s.predict_deg(t);
                let v = s.speed_deg_s + s.accel_deg_s2 * t;
                let r = measured_deg - x;
                SpindleEstimate {
                    angle_deg: x + self.g * r,
                    speed_deg_s: v + self.h * r / t,
                    accel_deg_s2: s.accel_deg_s2 + 2.0 * self.k * r / (t * t),
                }
            }
        };
        self.state = Some(est);
        est
    }

    /// No measurement this cycle (its frame was late): the estimate moves on by its own
    /// speed and acceleration.
    pub fn coast(&mut self) -> SpindleEstimate {
        let t = self.period_s;
        let est = self
            .state
            .map_or_else(SpindleEstimate::default, |s| SpindleEstimate {
                angle_deg: s.predict_deg(t),
                speed_deg_s: s.speed_deg_s + s.accel_deg_s2 * t,
                accel_deg_s2: s.accel_deg_s2,
            });
        self.state = Some(est);
        est
    }

    pub fn estimate(&self) -> SpindleEstimate {
        self.state.unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn coasting_continues_a_steady_rotation() {
        let mut o = SpindleObserver::new(0.001, 10.0);
        for k in 0..3000 {
            o.update(k as f64 * 0.7);
        }
        let before = o.estimate();
        let after = o.coast();
        assert!(
            (after.angle_deg - (before.angle_deg + 0.7)).abs() < 1e-6,
            "{before:?} {after:?}"
        );
        assert!((after.speed_deg_s - 700.0).abs() < 1e-3);
    }

    #[test]
    fn unwraps_across_the_32_bit_boundary() {
        let mut u = Unwrapper::default();
        assert_eq!(u.update(i32::MAX - 5), i64::from(i32::MAX) - 5);
        assert_eq!(u.update(i32::MIN + 4), i64::from(i32::MAX) + 5);
        assert_eq!(u.update(i32::MAX - 5), i64::from(i32::MAX) - 5);
    }

    /// True angle of a spindle turning at `rpm` with a speed ripple (a share of the speed,
    /// sinusoidal at `ripple_hz`).
    fn angle(t: f64, rpm: f64, ripple: f64, ripple_hz: f64) -> f64 {
        let w = rpm * 6.0;
        w * t
            + ripple * w / (std::f64::consts::TAU * ripple_hz)
                * (1.0 - (std::f64::consts::TAU * ripple_hz * t).cos())
    }

    /// That angle as the encoder reads it (1 count = 0.036 deg).
    fn counts(t: f64, rpm: f64, ripple: f64, ripple_hz: f64) -> f64 {
        (angle(t, rpm, ripple, ripple_hz) / 0.036).floor() * 0.036
    }

    #[test]
    fn prediction_beats_the_last_measured_angle_at_speed() {
        // The shipped observer (config/machine.toml: spindle_observer_bandwidth_hz = 10,
        // 1 ms cycle, horizon one cycle plus the 1 ms drive delay) at the thesis worst
        // case, 212 rpm, where the last measured angle is 2.5 deg late.
        //
        // Tolerance: the accuracy bound (bench/plant/tests/accuracy.rs, docs/accuracy.md)
        // is a quarter of the ISO 1328-1 grade-5 single pitch tolerance at the pitch
        // circle, f_p / 4 = (0.001 d + 0.4 m + 5) / 4 um. A spindle angle error e_C
        // becomes a table error e_C / z (single-start hob), r e_C / z = e_C m / 2 at the
        // pitch radius r = m z / 2: so the spindle may be wrong by at most
        // e_C = 2 (f_p / 4) / m rad. For the thesis gear (m = 5, z = 17, d = 85 mm):
        // f_p = 7.085 um, bound 1.771 um, e_C = 0.0406 deg of spindle (8.6 arcsec of
        // table). The predictor must keep its error within that bound on its own.
        //
        // Ripple: the plant's cutting torque ripple (config/plant.toml: 5 % of 31.84 Nm
        // at the gash frequency, 10 gashes: 35 Hz at 212 rpm) on 0.2 kg m2 is a speed
        // ripple of 1.59 / (0.2 x 2 pi x 35) = 0.036 rad/s, 0.16 % of 22.2 rad/s; 0.2 %
        // here.
        let (m, d, z) = (5.0, 85.0, 17.0);
        let bound_um = hob_gearing::iso1328::single_pitch_tolerance_um(d, m, 5) / 4.0;
        let pitch_radius_mm = d / 2.0;
        let tolerance_deg = (bound_um * 1e-3 / pitch_radius_mm * z).to_degrees();
        assert!((tolerance_deg - 0.0406).abs() < 1e-4, "{tolerance_deg}");
        let (rpm, ripple, ripple_hz) = (212.0, 0.002, 35.0);
        let horizon_s = 0.002;
        let mut obs = SpindleObserver::new(0.001, 10.0);
        let (mut worst_pred, mut worst_last) = (0.0f64, 0.0f64);
        for k in 0..3000 {
            let t = f64::from(k) * 0.001;
            let measured = counts(t, rpm, ripple, ripple_hz);
            let est = obs.update(measured);
            if k > 1000 {
                let truth = angle(t + horizon_s, rpm, ripple, ripple_hz);
                worst_pred = worst_pred.max((est.predict_deg(horizon_s) - truth).abs());
                worst_last = worst_last.max((measured - truth).abs());
            }
        }
        assert!(worst_last > 2.5, "{worst_last}");
        assert!(
            worst_pred < tolerance_deg,
            "prediction error {worst_pred} deg above {tolerance_deg} deg"
        );
    }

    proptest! {
        #[test]
        fn constant_speed_is_tracked_to_within_a_count(rpm in 2.0f64..250.0) {
            // The shipped bandwidth (config/machine.toml).
            let mut obs = SpindleObserver::new(0.001, 10.0);
            let mut est = SpindleEstimate::default();
            for k in 0..2000 {
                est = obs.update(counts(f64::from(k) * 0.001, rpm, 0.0, 1.0));
            }
            let truth = rpm * 6.0 * 1.999;
            prop_assert!((est.angle_deg - truth).abs() < 0.036 * 2.0, "{} vs {truth}", est.angle_deg);
            // Speed to 1 % or 1 deg/s: a count is 0.036 deg, at 2 rpm only 0.33 per cycle.
            prop_assert!((est.speed_deg_s - rpm * 6.0).abs() < 0.01 * rpm * 6.0 + 1.0);
        }
    }
}
