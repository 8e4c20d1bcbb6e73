//! Move times with a trapezoidal velocity profile (speed and acceleration limits).

/// Time to travel `distance` (any unit) from rest to rest with speed limit
/// `max_speed_per_s` and acceleration `accel_per_s2` (same unit per s, per s^2).
pub fn move_time_s(distance: f64, max_speed_per_s: f64, accel_per_s2: f64) -> f64 {
    let d = distance.abs();
    if d == 0.0 {
        return 0.0;
    }
    let ramp_distance = max_speed_per_s * max_speed_per_s / accel_per_s2;
    if d >= ramp_distance {
        d / max_speed_per_s + max_speed_per_s / accel_per_s2
    } else {
        2.0 * (d / accel_per_s2).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn rapid_of_the_thesis_y_axis() {
        // 3 m/min = 50 mm/s, 50 mm/s^2: 1 s to rapid, 50 mm spent ramping.
        assert!((move_time_s(100.0, 50.0, 50.0) - 3.0).abs() < 1e-12);
        assert!((move_time_s(50.0, 50.0, 50.0) - 2.0).abs() < 1e-12);
        // Triangular profile below 50 mm.
        assert!((move_time_s(12.5, 50.0, 50.0) - 1.0).abs() < 1e-12);
        assert_eq!(move_time_s(0.0, 50.0, 50.0), 0.0);
    }

    proptest! {
        #[test]
        fn longer_moves_never_take_less_time(a in 0.0f64..500.0, b in 0.0f64..500.0) {
            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
            prop_assert!(move_time_s(lo, 50.0, 50.0) <= move_time_s(hi, 50.0, 50.0) + 1e-12);
        }

        #[test]
        fn never_faster_than_the_speed_limit_allows(d in 0.001f64..500.0) {
            prop_assert!(move_time_s(d, 50.0, 50.0) >= d / 50.0);
        }
    }
}
