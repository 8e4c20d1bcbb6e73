//! A servo axis as drives really behave: cyclic synchronous position (targets applied at
//! SYNC, linear interpolation between SYNCs), a P position loop with velocity
//! feed-forward around a PI velocity loop of finite bandwidth, a torque limit, encoder
//! quantisation. Loads are reflected rigidly; the work's own elasticity is
//! [`crate::worklink`].

use std::f64::consts::TAU;

/// Fixed parameters of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoParams {
    /// Inertia the motor sees rigidly (rotor, plus a rigidly reflected load).
    pub inertia_kg_m2: f64,
    /// The inertia the drive's gains are tuned for (its autotune's estimate): the loops'
    /// bandwidths hold for the true inertia only where the two agree.
    pub tuned_inertia_kg_m2: f64,
    pub counts_per_rad: f64,
    pub peak_torque_nm: f64,
    pub velocity_loop_hz: f64,
    pub position_loop_hz: f64,
    pub velocity_feed_forward: f64,
    /// Coulomb (sliding) friction at the motor.
    pub friction_nm: f64,
    /// Friction at rest (breakaway), at the motor: at least `friction_nm`; it falls to it
    /// over `stribeck_rad_s` (Stribeck).
    pub static_friction_nm: f64,
    pub stribeck_rad_s: f64,
    /// Constant load at the motor (gravity on a vertical axis).
    pub constant_load_nm: f64,
    /// A holding brake when disabled (vertical axis).
    pub brake: bool,
    /// The loops' sample period, s (the torque is held between samples).
    pub loop_period_s: f64,
    /// The motor feedback the loops read, counts per rad (finer than `counts_per_rad`,
    /// what the drive reports).
    pub feedback_counts_per_rad: f64,
    /// Low-pass on the speed estimate, Hz.
    pub velocity_filter_hz: f64,
    /// How much later than one period after its SYNC the reference reaches a target, s
    /// (negative: sooner, extrapolating): the drive's delay beyond the interpolation.
    pub extra_delay_s: f64,
}

/// The drive's loop gains, as a drive's parameters name them: the PI velocity loop's
/// proportional gain and integral time (`ki = kp / Ti`), the P position loop's gain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoGains {
    pub velocity_kp_nm_s_per_rad: f64,
    pub velocity_integral_time_s: f64,
    pub position_kv_per_s: f64,
}

/// One servo axis in motor coordinates (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Servo {
    p: ServoParams,
    kp_v: f64,
    ki_v: f64,
    kv: f64,
    pub motor_rad: f64,
    pub motor_rad_s: f64,
    integral: f64,
    /// The targets of the last three SYNCs, oldest first.
    target_prev2_counts: f64,
    target_prev_counts: f64,
    target_counts: f64,
    since_sync_s: f64,
    period_s: f64,
    /// Time since the loops' last sample, s.
    since_loop_s: f64,
    /// The feedback at the last sample, rad (quantised).
    feedback_prev_rad: f64,
    /// The filtered speed estimate, rad/s.
    speed_estimate_rad_s: f64,
    /// The torque the loops output at their last sample, held until the next.
    torque_nm: f64,
    pub enabled: bool,
    /// The drive's power stage has power (safety chain).
    pub enabled_power: bool,
    pub fault: bool,
    /// Locked by a clamp: does not move.
    pub locked: bool,
    /// External torque at the motor, Nm.
    pub disturbance_nm: f64,
    /// The process's load at the motor (the cut's force on a slide), Nm, against the
    /// positive direction.
    pub process_load_nm: f64,
}

impl Servo {
    pub fn new(p: ServoParams, position_rad: f64, period_s: f64) -> Self {
        let j = p.tuned_inertia_kg_m2;
        let wv = TAU * p.velocity_loop_hz;
        let counts = (position_rad * p.counts_per_rad).floor();
        Self {
            p,
            kp_v: j * wv,
            ki_v: j * wv * wv / 4.0,
            kv: TAU * p.position_loop_hz,
            motor_rad: position_rad,
            motor_rad_s: 0.0,
            integral: 0.0,
            target_prev2_counts: counts,
            target_prev_counts: counts,
            target_counts: counts,
            since_sync_s: 0.0,
            period_s,
            since_loop_s: p.loop_period_s,
            feedback_prev_rad: (position_rad * p.feedback_counts_per_rad).floor() / p.feedback_counts_per_rad,
            speed_estimate_rad_s: 0.0,
            torque_nm: 0.0,
            enabled: false,
            enabled_power: true,
            fault: false,
            locked: false,
            disturbance_nm: 0.0,
            process_load_nm: 0.0,
        }
    }

    /// The loops' gains in use (at start-up from the parameters' bandwidths: kp = J w_v,
    /// ki = J w_v^2 / 4, so Ti = 4 / w_v; kv = 2 pi `position_loop_hz`).
    pub fn gains(&self) -> ServoGains {
        ServoGains {
            velocity_kp_nm_s_per_rad: self.kp_v,
            velocity_integral_time_s: self.kp_v / self.ki_v,
            position_kv_per_s: self.kv,
        }
    }

    /// Changes the loops' gains at once, as a drive does when its parameters are written
    /// while it runs. Bumpless in the integral: it is held as a torque, so a new integral
    /// time changes only how fast it moves from here; the proportional part steps with
    /// the new gain times the present error, as a real drive's does. Gains that are not
    /// finite and positive are ignored (the caller checks them; the dictionary refuses
    /// them by SDO).
    pub fn set_gains(&mut self, g: ServoGains) {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        if !(ok(g.velocity_kp_nm_s_per_rad) && ok(g.velocity_integral_time_s) && ok(g.position_kv_per_s)) {
            return;
        }
        self.kp_v = g.velocity_kp_nm_s_per_rad;
        self.ki_v = g.velocity_kp_nm_s_per_rad / g.velocity_integral_time_s;
        self.kv = g.position_kv_per_s;
    }

    /// The torque the loops hold since their last sample, Nm (0 while disabled).
    pub fn torque_nm(&self) -> f64 {
        self.torque_nm
    }

    /// Encoder reading (quantised).
    pub fn position_counts(&self) -> i64 {
        (self.motor_rad * self.p.counts_per_rad).floor() as i64
    }

    /// Motor speed, encoder counts per second.
    pub fn velocity_counts_s(&self) -> f64 {
        self.motor_rad_s * self.p.counts_per_rad
    }

    /// At SYNC: the new target takes effect, interpolated over the next period.
    pub fn apply_target(&mut self, target_counts: i64) {
        self.target_prev2_counts = self.target_prev_counts;
        self.target_prev_counts = self.target_counts;
        self.target_counts = target_counts as f64;
        self.since_sync_s = 0.0;
        if !self.enabled || self.fault {
            // A disabled drive follows its actual position (no jump on enable).
            let c = self.position_counts() as f64;
            self.target_prev2_counts = c;
            self.target_prev_counts = c;
            self.target_counts = c;
        }
    }

    /// The interpolated reference, counts, and its segment's speed, counts/s, at
    /// `since_sync_s` after the last SYNC: the segment from the previous target to this
    /// SYNC's, reached one period (plus `extra_delay_s`) after it; later, held at the
    /// target; earlier, the segment before; with a negative extra delay, extrapolated.
    fn reference_counts(&self, since_sync_s: f64) -> (f64, f64) {
        let share = (since_sync_s - self.p.extra_delay_s) / self.period_s;
        let (from, to, f) = if share < 0.0 {
            (
                self.target_prev2_counts,
                self.target_prev_counts,
                (share + 1.0).max(0.0),
            )
        } else {
            let most = 1.0 + (-self.p.extra_delay_s / self.period_s).max(0.0);
            (self.target_prev_counts, self.target_counts, share.min(most))
        };
        (from + (to - from) * f, (to - from) / self.period_s)
    }

    /// Advances the physics by `dt_s`. The drive's loops sample at the start of the step
    /// once their period has passed since the last sample (the reference at the time
    /// since SYNC before the step, the feedback quantised, the speed estimated from the
    /// feedback's difference and filtered) and hold their torque until the next. (Sampling
    /// at the end of the step applied each target one step early: a delay of `period - dt`
    /// instead of the period the controller predicts for.)
    pub fn advance(&mut self, dt_s: f64) {
        let (reference, ff_counts_s) = self.reference_counts(self.since_sync_s);
        self.since_sync_s += dt_s;
        let active = self.enabled && !self.fault;
        if self.since_loop_s + 1e-12 >= self.p.loop_period_s {
            let elapsed = self.since_loop_s;
            self.since_loop_s = 0.0;
            let feedback_rad =
                (self.motor_rad * self.p.feedback_counts_per_rad).floor() / self.p.feedback_counts_per_rad;
            let raw = (feedback_rad - self.feedback_prev_rad) / elapsed;
            self.feedback_prev_rad = feedback_rad;
            let a = 1.0 - (-TAU * self.p.velocity_filter_hz * elapsed).exp();
            self.speed_estimate_rad_s += (raw - self.speed_estimate_rad_s) * a;
            let ff_rad_s = ff_counts_s / self.p.counts_per_rad;
            self.torque_nm = if active {
                let pos_err = reference / self.p.counts_per_rad - feedback_rad;
                let w_ref = self.kv * pos_err + self.p.velocity_feed_forward * ff_rad_s;
                let e = w_ref - self.speed_estimate_rad_s;
                let unclamped = self.kp_v * e + self.integral;
                let t = unclamped.clamp(-self.p.peak_torque_nm, self.p.peak_torque_nm);
                // Anti-windup: integrate only while not saturated.
                if t == unclamped {
                    self.integral += self.ki_v * e * elapsed;
                }
                t
            } else {
                0.0
            };
        }
        self.since_loop_s += dt_s;
        // Disabled, the power stage gives no torque at once (not at the next sample).
        let torque = if active { self.torque_nm } else { 0.0 };
        if !active {
            self.integral = 0.0;
        }
        if self.locked || (!active && self.p.brake) {
            self.motor_rad_s = 0.0;
            return;
        }
        let v = self.motor_rad_s;
        let stribeck = (-(v / self.p.stribeck_rad_s).powi(2)).exp();
        let level = self.p.friction_nm + (self.p.static_friction_nm - self.p.friction_nm) * stribeck;
        let friction = level * (v / 0.01).tanh();
        let acc = (torque - friction - self.p.constant_load_nm - self.disturbance_nm - self.process_load_nm)
            / self.p.inertia_kg_m2;
        self.motor_rad_s += acc * dt_s;
        self.motor_rad += self.motor_rad_s * dt_s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn servo() -> Servo {
        let p = ServoParams {
            inertia_kg_m2: 0.003,
            tuned_inertia_kg_m2: 0.003,
            counts_per_rad: 1e5,
            peak_torque_nm: 20.0,
            velocity_loop_hz: 400.0,
            position_loop_hz: 60.0,
            velocity_feed_forward: 1.0,
            friction_nm: 0.0,
            static_friction_nm: 0.0,
            stribeck_rad_s: 0.1,
            constant_load_nm: 0.5,
            brake: false,
            loop_period_s: 1.0 / 16_000.0,
            feedback_counts_per_rad: 1e6,
            velocity_filter_hz: 2000.0,
            extra_delay_s: 0.0,
        };
        Servo::new(p, 0.0, 1e-3)
    }

    #[test]
    fn the_start_up_gains_are_the_bandwidths_and_a_change_is_bumpless() {
        let mut s = servo();
        let g = s.gains();
        let wv = TAU * 400.0;
        assert!((g.velocity_kp_nm_s_per_rad - 0.003 * wv).abs() < 1e-12);
        assert!((g.velocity_integral_time_s - 4.0 / wv).abs() < 1e-15);
        assert!((g.position_kv_per_s - TAU * 60.0).abs() < 1e-12);
        // Hold against a constant load: the integral carries it.
        s.enabled = true;
        for _ in 0..16_000 {
            s.advance(1.0 / 16_000.0);
        }
        let held = s.integral;
        assert!((held - 0.5).abs() < 0.05, "{held}");
        let new = ServoGains {
            velocity_kp_nm_s_per_rad: 1.91,
            velocity_integral_time_s: 8.6e-3,
            position_kv_per_s: 100.5,
        };
        s.set_gains(new);
        assert_eq!(s.integral, held);
        let back = s.gains();
        assert!((back.velocity_integral_time_s - 8.6e-3).abs() < 1e-15);
        assert_eq!(back.position_kv_per_s, 100.5);
        // The torque does not jump at the next sample.
        let before = s.torque_nm();
        s.advance(1.0 / 16_000.0);
        assert!(
            (s.torque_nm() - before).abs() < 0.05,
            "{before} -> {}",
            s.torque_nm()
        );
        // Nonsense is ignored.
        s.set_gains(ServoGains {
            position_kv_per_s: 0.0,
            ..new
        });
        assert_eq!(s.gains().position_kv_per_s, 100.5);
    }
}
