//! Aligning the gearbox to a part whose gaps are already cut, by touching both flanks of a
//! gap with a hob tooth (the table lost its position in an interrupted cut, or a pre-cut
//! part is to be finished on its own gaps).
//!
//! With the spindle and the hob standing still and a hob tooth in a gap, the operator
//! turns the table (jog B) one way until a flank of the gap touches the tooth (a feeler,
//! a paint mark, the drive's torque), then the other way until the other flank touches.
//! At each touch the loop notes the tooth phase `table - coupled(spindle, Y)` of the
//! gearbox's law (module `egb`) from the measured angles; the gap's centre is the middle
//! of the two, and the hob cuts the same gaps when the gearbox engages on it. The
//! phase's unit is the table's degree, as the gearbox's: the touches are taken within
//! one gap, so their difference is taken within half a pitch either way; a touch with the
//! table turned positive must lie above the one turned negative (the flanks are not
//! crossed), else it is refused and nothing changes. The command's handler is
//! `Controller::touch_flank` (module `commands`).

/// Spindle speed below which it counts as standing still, deg/s (0.1 rpm).
pub const STANDSTILL_DEG_S: f64 = 0.6;

/// The gap's centre and the play between the flanks (deg) from the phases noted with the
/// table turned negative and positive; `None` when the positive touch is not above the
/// negative one within half a pitch (the flanks crossed, or not the same gap).
pub fn gap_centre_deg(turned_negative: f64, turned_positive: f64, pitch_deg: f64) -> Option<(f64, f64)> {
    let d = turned_positive - turned_negative;
    let play = d - (d / pitch_deg).round() * pitch_deg;
    (play.is_finite() && play > 0.0).then_some((turned_negative + play / 2.0, play))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_centre_is_the_middle_of_the_touches_within_a_pitch() {
        assert_eq!(gap_centre_deg(10.0, 12.0, 20.0), Some((11.0, 2.0)));
        // Noted a whole pitch apart (the table turned past a tooth in between): the same.
        assert_eq!(gap_centre_deg(10.0, 32.0, 20.0), Some((11.0, 2.0)));
        assert_eq!(gap_centre_deg(10.0, -8.0, 20.0), Some((11.0, 2.0)));
        // Crossed: the positive touch below the negative one.
        assert_eq!(gap_centre_deg(12.0, 10.0, 20.0), None);
        assert_eq!(gap_centre_deg(10.0, 10.0, 20.0), None);
        assert_eq!(gap_centre_deg(f64::NAN, 10.0, 20.0), None);
    }

    proptest! {
        #[test]
        fn any_gap_is_found_from_its_flanks_wherever_the_phase_wraps(
            centre in -720.0f64..720.0, play in 0.01f64..5.0, z in 8u32..200, turns_neg in -3i32..3, turns_pos in -3i32..3,
        ) {
            let pitch = 360.0 / f64::from(z);
            // A gap's play is less than half a pitch (the gap is about half of it).
            let play = play.min(0.49 * pitch);
            let neg = centre - play / 2.0 + f64::from(turns_neg) * pitch;
            let pos = centre + play / 2.0 + f64::from(turns_pos) * pitch;
            let (c, p) = gap_centre_deg(neg, pos, pitch).unwrap();
            let off = c - centre;
            prop_assert!((off - (off / pitch).round() * pitch).abs() < 1e-9);
            prop_assert!((p - play).abs() < 1e-9);
        }
    }
}
