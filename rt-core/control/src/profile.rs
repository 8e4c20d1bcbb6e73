//! Online trajectory generation for moves out of the cut: each cycle, one bounded step
//! towards a target with speed and acceleration limits (trapezoidal velocity). No
//! allocation, constant work per call.

/// Limits and timing of one linear axis.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LinearLimits {
    pub soft_min_mm: f64,
    pub soft_max_mm: f64,
    pub rapid_mm_s: f64,
    pub accel_mm_s2: f64,
    pub max_following_error_mm: f64,
}

/// One axis' commanded position and speed.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Profile {
    pub position: f64,
    pub velocity: f64,
}

impl Profile {
    pub fn at(position: f64) -> Self {
        Self {
            position,
            velocity: 0.0,
        }
    }

    /// Advances one period `dt_s` towards `target` with `max_speed` (per s) and `accel`
    /// (per s^2); returns `true` once at the target and at rest.
    pub fn step_towards(&mut self, target: f64, max_speed: f64, accel: f64, dt_s: f64) -> bool {
        let dist = target - self.position;
        let dv = accel * dt_s;
        if dist.abs() <= 0.5 * dv * dt_s && self.velocity.abs() <= dv {
            self.position = target;
            self.velocity = 0.0;
            return true;
        }
        // Fastest speed from which the remaining distance can still be braked, taking
        // the discrete step into account.
        let brake = (2.0 * accel * dist.abs()).sqrt() - 0.5 * dv;
        let wanted = dist.signum() * max_speed.min(brake.max(0.0));
        let change = (wanted - self.velocity).clamp(-dv, dv);
        let v_new = self.velocity + change;
        let mut next = self.position + 0.5 * (self.velocity + v_new) * dt_s;
        // Never step past the target.
        if (target - next) * dist < 0.0 {
            next = target;
        }
        self.position = next;
        self.velocity = v_new;
        false
    }

    /// Brings the speed to zero with `accel`; returns `true` when stopped.
    pub fn step_stop(&mut self, accel: f64, dt_s: f64) -> bool {
        let dv = accel * dt_s;
        let v_new = if self.velocity.abs() <= dv {
            0.0
        } else {
            self.velocity - self.velocity.signum() * dv
        };
        self.position += 0.5 * (self.velocity + v_new) * dt_s;
        self.velocity = v_new;
        v_new == 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn reaches_the_target_within_limits(
            start in -200.0f64..200.0, target in -200.0f64..200.0, v0 in -20.0f64..20.0,
            vmax in 5.0f64..60.0, accel in 20.0f64..500.0,
        ) {
            let dt = 0.001;
            let mut p = Profile { position: start, velocity: v0.clamp(-vmax, vmax) };
            let mut done = false;
            for _ in 0..200_000 {
                let before = p;
                done = p.step_towards(target, vmax, accel, dt);
                prop_assert!(p.velocity.abs() <= vmax + 1e-9);
                prop_assert!((p.velocity - before.velocity).abs() <= accel * dt + 1e-9);
                if done { break; }
            }
            prop_assert!(done);
            prop_assert_eq!(p.position, target);
        }
    }

    #[test]
    fn stops_with_bounded_deceleration() {
        let mut p = Profile {
            position: 0.0,
            velocity: 50.0,
        };
        let mut n = 0;
        while !p.step_stop(50.0, 0.001) {
            n += 1;
        }
        assert!((999..=1000).contains(&n), "{n}");
        assert!((p.position - 25.0).abs() < 0.05);
    }
}
