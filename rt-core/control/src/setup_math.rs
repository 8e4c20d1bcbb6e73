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

/// Where "continue" re-enters the cut of a pass that stopped with the hob's axis at
/// `stopped_y_mm` ("repositioning"). Each tooth gap meets the hob once per table
/// revolution, `feed_per_table_rev_mm` further along Y each time, so at the stop every gap
/// had been cut by the hob at some Y within that distance behind it, and at every Y before
/// (spaced by the feed). Back in the gaps at least that far behind the stop, synchronised
/// onto the same gaps, the hob meets only what it cut already, but for the crests of the
/// feed marks between two of its passes (`RE_ENTRY_CLEARANCE_MM` is taken at feed). The
/// stated `overlap_mm` is added behind that. `feed_sign` is the direction of the feed in
/// the cut. None when that is at or before the pass's start (the pass is cut again whole).
pub fn resume_y_mm(
    stopped_y_mm: f64,
    y_start_mm: f64,
    feed_per_table_rev_mm: f64,
    feed_sign: f64,
    overlap_mm: f64,
) -> Option<f64> {
    let y = stopped_y_mm - feed_sign * (feed_per_table_rev_mm.abs() + overlap_mm);
    (y.is_finite() && feed_sign * (y - y_start_mm) > 0.0).then_some(y)
}

/// Re-entering an interrupted cut, X comes in at rapid to this far outside the pass's
/// depth and the rest at the pass's own feed: the crests of the feed marks left between
/// two passes of the hob through a gap (at most `f^2 sin(alpha) / (4 d)`, 68 um for
/// 8 mm per revolution with an 80 mm hob) are cut like a chip of the pass, not at rapid.
pub const RE_ENTRY_CLEARANCE_MM: f64 = 0.5;

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
    fn continue_re_enters_a_feed_and_the_overlap_behind_the_stop() {
        // Fed upwards from 31.8 mm, stopped at 66.8 mm, 8 mm per table turn, overlap 2 mm.
        assert_eq!(resume_y_mm(66.8, 31.8, 8.0, 1.0, 2.0), Some(66.8 - 10.0));
        // Fed downwards: behind the stop is above it.
        assert_eq!(resume_y_mm(40.0, 90.0, 8.0, -1.0, 2.0), Some(50.0));
        // Too near the start: the pass again from its start.
        assert_eq!(resume_y_mm(40.0, 31.8, 8.0, 1.0, 2.0), None);
        assert_eq!(resume_y_mm(f64::NAN, 31.8, 8.0, 1.0, 2.0), None);
    }

    proptest! {
        /// The re-entry lies strictly between the pass's start and the stop, a feed and
        /// the overlap behind the stop.
        #[test]
        fn the_re_entry_is_inside_the_cut_part(
            start in -100.0f64..100.0,
            cut in 0.0f64..200.0,
            feed in 0.0f64..20.0,
            overlap in 0.0f64..10.0,
            up in any::<bool>(),
        ) {
            let sign = if up { 1.0 } else { -1.0 };
            let stopped = start + sign * cut;
            match resume_y_mm(stopped, start, feed, sign, overlap) {
                Some(y) => {
                    prop_assert!(sign * (y - start) > 0.0);
                    prop_assert!((sign * (stopped - y) - (feed + overlap)).abs() <= 1e-9);
                }
                None => prop_assert!(cut <= feed + overlap + 1e-9),
            }
        }
    }

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
