//! The electronic-gearbox law (docs/domain.md section 3):
//!
//! ```text
//! phi_B = phi_B0 + s_i (z0/z) (theta_C - theta_C0) + s_d 360 sin(beta) / (pi m_n z) (Y - Y0)
//! Y     = Y0 + s_f f (z0/z) (theta_C - theta_C0) / 360
//! ```
//!
//! All angles in degrees, `Y` in mm. [`GearboxLaw`] is `Copy` and allocation-free.

use super::signs::GearboxSigns;
use std::f64::consts::PI;

/// Table turns (revolutions) per hob turn: `z0 / z`.
pub fn egb_ratio(starts: u32, teeth: u32) -> f64 {
    f64::from(starts) / f64::from(teeth)
}

/// Extra table rotation per mm of axial travel for a helical gear:
/// `360 sin(beta) / (pi m_n z)` deg/mm; 0 for a spur gear.
pub fn differential_deg_per_mm(helix_deg: f64, normal_module_mm: f64, teeth: u32) -> f64 {
    360.0 * helix_deg.to_radians().sin() / (PI * normal_module_mm * f64::from(teeth))
}

/// Lead of the gear's helix `L = pi m_n z / sin(beta)`; `None` for a spur gear.
pub fn helix_lead_mm(helix_deg: f64, normal_module_mm: f64, teeth: u32) -> Option<f64> {
    let s = helix_deg.to_radians().sin();
    (s.abs() > 0.0).then(|| PI * normal_module_mm * f64::from(teeth) / s)
}

/// Reference (pitch) diameter of a gear: `m_n z / cos(beta)`.
pub fn pitch_diameter_mm(normal_module_mm: f64, teeth: u32, helix_deg: f64) -> f64 {
    normal_module_mm * f64::from(teeth) / helix_deg.to_radians().cos()
}

/// The gearbox law of one job, with its signs resolved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GearboxLaw {
    /// `z0 / z`.
    pub ratio: f64,
    /// `360 sin(beta) / (pi m_n z)`, deg/mm, unsigned.
    pub differential_deg_per_mm: f64,
    /// Axial feed per table revolution, mm.
    pub feed_mm_per_rev: f64,
    pub signs: GearboxSigns,
}

impl GearboxLaw {
    /// Table angle (deg) relative to the engagement point for a spindle travel
    /// `spindle_delta_deg` and an axial travel `y_delta_mm` since engagement.
    pub fn table_delta_deg(&self, spindle_delta_deg: f64, y_delta_mm: f64) -> f64 {
        self.signs.s_i() * self.ratio * spindle_delta_deg
            + self.signs.s_d() * self.differential_deg_per_mm * y_delta_mm
    }

    /// Axial travel (mm) tied to the table's base rotation for a spindle travel; the
    /// spindle turning in its set sense feeds in the feed direction.
    pub fn axial_delta_mm(&self, spindle_delta_deg: f64) -> f64 {
        let forward_deg = self.signs.spindle.sign() * spindle_delta_deg;
        self.signs.s_f() * self.feed_mm_per_rev * self.ratio * forward_deg / 360.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signs::{CutMethod, GearboxSigns, Hand, SignInputs, StartSide};
    use proptest::prelude::*;

    fn law(z0: u32, z: u32, beta: f64, m: f64, gear_hand: Hand, start: StartSide) -> GearboxLaw {
        GearboxLaw {
            ratio: egb_ratio(z0, z),
            differential_deg_per_mm: differential_deg_per_mm(beta, m, z),
            feed_mm_per_rev: 2.0,
            signs: GearboxSigns::derive(SignInputs {
                hob_hand: Hand::Right,
                gear_hand: Some(gear_hand),
                start,
                method: CutMethod::Climb,
            }),
        }
    }

    #[test]
    fn spur_has_no_differential_and_no_lead() {
        assert_eq!(differential_deg_per_mm(0.0, 5.0, 17), 0.0);
        assert_eq!(helix_lead_mm(0.0, 5.0, 17), None);
    }

    #[test]
    fn pitch_diameter_of_the_thesis_gear() {
        assert!((pitch_diameter_mm(5.0, 17, 0.0) - 85.0).abs() < 1e-12);
    }

    proptest! {
        #[test]
        fn table_turns_once_when_the_spindle_turns_z_over_z0(
            z0 in 1u32..=4, z in 5u32..=200, beta in 0.0f64..40.0, m in 0.5f64..10.0,
        ) {
            let l = law(z0, z, beta, m, Hand::Right, StartSide::Top);
            let spindle_deg = 360.0 * f64::from(z) / f64::from(z0);
            let table = l.table_delta_deg(spindle_deg, 0.0);
            prop_assert!((table.abs() - 360.0).abs() < 1e-9, "table {table}");
        }

        #[test]
        fn one_helix_lead_of_axial_travel_adds_one_table_turn(
            z in 5u32..=200, beta in 1.0f64..40.0, m in 0.5f64..10.0,
            left in any::<bool>(),
        ) {
            let hand = if left { Hand::Left } else { Hand::Right };
            let l = law(1, z, beta, m, hand, StartSide::Bottom);
            let lead = helix_lead_mm(beta, m, z).unwrap();
            let table = l.table_delta_deg(0.0, lead);
            prop_assert!((table.abs() - 360.0).abs() < 1e-9, "table {table}");
        }

        #[test]
        fn axial_feed_per_table_turn_is_f(
            z0 in 1u32..=4, z in 5u32..=200, top in any::<bool>(),
        ) {
            let start = if top { StartSide::Top } else { StartSide::Bottom };
            let l = law(z0, z, 0.0, 5.0, Hand::Right, start);
            let spindle_deg = l.signs.spindle.sign() * 360.0 * f64::from(z) / f64::from(z0);
            let y = l.axial_delta_mm(spindle_deg);
            prop_assert!((y.abs() - 2.0).abs() < 1e-9);
            prop_assert_eq!(y > 0.0, !top, "feed direction follows the start side");
        }

        #[test]
        fn the_tooth_space_stays_under_the_hob_along_a_helix(
            z in 5u32..=200, beta in 1.0f64..40.0, m in 0.5f64..10.0,
            left in any::<bool>(), dy in -50.0f64..50.0,
        ) {
            // A tooth space of a right-hand gear at height y sits at angle +360 y / L in
            // the table frame (left-hand: -). After the table turns by the differential,
            // the space at the new height must be back at the hob (angle 0).
            let hand = if left { Hand::Left } else { Hand::Right };
            let l = law(1, z, beta, m, hand, StartSide::Top);
            let lead = helix_lead_mm(beta, m, z).unwrap();
            let space_deg = hand.sign() * 360.0 * dy / lead;
            let at_hob = space_deg + l.table_delta_deg(0.0, dy);
            prop_assert!(at_hob.abs() < 1e-9);
        }
    }
}
