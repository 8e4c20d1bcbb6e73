//! The set-up computations behind the operator's commands: work offsets from a touch-off
//! and the limits of the overrides. Pure functions of `Copy` values, usable in the loop.

/// Work offsets: a position the loop works in (the program's centre distance X, the hob
/// axis height Y above the table face) is the drive's referenced position plus these.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Offsets {
    pub x_mm: f64,
    pub y_mm: f64,
}

/// Largest offset a touch-off may set: beyond it the reference (or the entered gauge) is
/// wrong, not the calibration.
pub const MAX_OFFSET_MM: f64 = 50.0;

/// The X offset after touching the hob's tip to a gauge (a blank or ring) of diameter
/// `gauge_diameter_mm` centred on the table: there the centre distance is the gauge's
/// radius plus the hob's tip radius. `x_machine_mm` is the referenced X at the touch.
pub fn x_offset_from_touch(
    x_machine_mm: f64,
    gauge_diameter_mm: f64,
    tool_tip_diameter_mm: f64,
) -> Option<f64> {
    let valid = gauge_diameter_mm.is_finite()
        && gauge_diameter_mm > 0.0
        && tool_tip_diameter_mm.is_finite()
        && tool_tip_diameter_mm > 0.0
        && x_machine_mm.is_finite();
    let offset = 0.5 * (gauge_diameter_mm + tool_tip_diameter_mm) - x_machine_mm;
    (valid && offset.abs() <= MAX_OFFSET_MM).then_some(offset)
}

/// The Y offset after touching the hob's lowest tip (its axis horizontal, swivel A = 0)
/// to the top face of a gauge standing on the table face, `gauge_height_mm` high: there
/// the hob axis is the gauge's height plus the tip radius above the table face.
pub fn y_offset_from_touch(
    y_machine_mm: f64,
    gauge_height_mm: f64,
    tool_tip_diameter_mm: f64,
) -> Option<f64> {
    let valid = gauge_height_mm.is_finite()
        && gauge_height_mm >= 0.0
        && tool_tip_diameter_mm.is_finite()
        && tool_tip_diameter_mm > 0.0
        && y_machine_mm.is_finite();
    let offset = gauge_height_mm + 0.5 * tool_tip_diameter_mm - y_machine_mm;
    (valid && offset.abs() <= MAX_OFFSET_MM).then_some(offset)
}

/// The ranges of the overrides (fractions: 1.0 is 100 %).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OverrideLimits {
    pub feed_min: f64,
    pub feed_max: f64,
    pub spindle_min: f64,
    pub spindle_max: f64,
}

impl OverrideLimits {
    /// The feed override for `percent`, or `None` outside the range.
    pub fn feed(&self, percent: f64) -> Option<f64> {
        let f = percent / 100.0;
        (f.is_finite() && (self.feed_min..=self.feed_max).contains(&f)).then_some(f)
    }

    /// The spindle override for `percent`, or `None` outside the range.
    pub fn spindle(&self, percent: f64) -> Option<f64> {
        let f = percent / 100.0;
        (f.is_finite() && (self.spindle_min..=self.spindle_max).contains(&f)).then_some(f)
    }
}

/// Share of the table's maximum speed the gearbox may use with an override: the rest is
/// for the differential of a helical gear and the phase corrections.
pub const TABLE_SPEED_SHARE: f64 = 0.9;

/// The spindle speed for a programmed `programmed_rpm` under `override_factor`, never
/// above the spindle's maximum nor so fast that the table (at `ratio` table turns per
/// spindle turn) would exceed its share of `table_max_deg_s`.
pub fn overridden_spindle_rpm(
    programmed_rpm: f64,
    override_factor: f64,
    spindle_max_rpm: f64,
    ratio: f64,
    table_max_deg_s: f64,
) -> f64 {
    let wanted = programmed_rpm * override_factor;
    let by_table = if ratio.abs() > 0.0 {
        TABLE_SPEED_SHARE * table_max_deg_s / (6.0 * ratio.abs())
    } else {
        f64::INFINITY
    };
    // Never below what was programmed because of the table: the planner already checked
    // the programmed speed against the table.
    wanted
        .min(spindle_max_rpm.max(programmed_rpm))
        .min(by_table.max(programmed_rpm))
        .max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn touching_a_ring_sets_the_centre_distance() {
        // Hob 70 mm touching a 100 mm ring: centre distance 85 mm. The reference said 84.6.
        let o = x_offset_from_touch(84.6, 100.0, 70.0).unwrap();
        assert!((o - 0.4).abs() < 1e-12);
        assert!((84.6 + o - 85.0).abs() < 1e-12);
        // A gauge that would need an absurd offset is refused.
        assert_eq!(x_offset_from_touch(200.0, 100.0, 70.0), None);
        assert_eq!(x_offset_from_touch(84.6, -1.0, 70.0), None);
        assert_eq!(x_offset_from_touch(84.6, f64::NAN, 70.0), None);
    }

    #[test]
    fn touching_a_gauge_face_sets_the_height() {
        // Hob 70 mm on a 50 mm gauge: hob axis 85 mm above the table face; reference 86.
        let o = y_offset_from_touch(86.0, 50.0, 70.0).unwrap();
        assert!((86.0 + o - 85.0).abs() < 1e-12);
        assert_eq!(y_offset_from_touch(86.0, -0.1, 70.0), None);
    }

    #[test]
    fn overrides_outside_their_range_are_refused() {
        let l = OverrideLimits {
            feed_min: 0.0,
            feed_max: 1.2,
            spindle_min: 0.5,
            spindle_max: 1.2,
        };
        assert_eq!(l.feed(0.0), Some(0.0));
        assert_eq!(l.feed(120.0), Some(1.2));
        assert_eq!(l.feed(120.1), None);
        assert_eq!(l.feed(-1.0), None);
        assert_eq!(l.spindle(49.0), None);
        assert_eq!(l.spindle(f64::NAN), None);
        assert_eq!(l.spindle(100.0), Some(1.0));
    }

    proptest! {
        #[test]
        fn a_touch_off_puts_the_touched_position_on_the_gauge(
            x in 20.0f64..260.0, d in 40.0f64..400.0, tool in 60.0f64..80.0,
        ) {
            if let Some(o) = x_offset_from_touch(x, d, tool) {
                prop_assert!((x + o - 0.5 * (d + tool)).abs() < 1e-9);
                prop_assert!(o.abs() <= MAX_OFFSET_MM);
            } else {
                prop_assert!((0.5 * (d + tool) - x).abs() > MAX_OFFSET_MM);
            }
        }

        #[test]
        fn the_overridden_spindle_never_exceeds_the_machine(
            rpm in 10.0f64..200.0, f in 0.5f64..1.2, ratio in 0.01f64..0.5, table_max in 20.0f64..200.0,
        ) {
            let max_rpm = 212.2;
            let out = overridden_spindle_rpm(rpm, f, max_rpm, ratio, table_max);
            prop_assert!(out <= (rpm * f).max(0.0) + 1e-9);
            prop_assert!(out <= max_rpm.max(rpm) + 1e-9);
            let table_limit = TABLE_SPEED_SHARE * table_max / (6.0 * ratio);
            prop_assert!(out <= table_limit.max(rpm) + 1e-9);
            // Slowing down is always possible.
            if f <= 1.0 {
                prop_assert!((out - rpm * f).abs() < 1e-9);
            }
        }
    }
}
