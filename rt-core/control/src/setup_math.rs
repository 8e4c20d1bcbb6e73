//! The set-up computations behind the operator's commands: work offsets from a touch-off,
//! whether a touch-off is plausible enough to apply without the operator's confirmation,
//! and the limits of the overrides. Pure functions of `Copy` values, usable in the loop.

use crate::fault::Axis;

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

/// The loaded blank as a touch-off judges it (mm; radii from the table's axis, heights
/// above the table face: the loop's work coordinates).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Blank {
    pub outside_diameter_mm: f64,
    /// The program's total depth: the root cylinder (the outside diameter less twice this,
    /// over the face) is material whatever the cut has done to the part.
    pub total_depth_mm: f64,
    /// The toothed part's bottom and top faces above the table face.
    pub face_bottom_mm: f64,
    pub face_top_mm: f64,
}

/// How far a hob of tip diameter `tool_tip_diameter_mm`, its axis at centre distance
/// `x_mm` and height `y_mm` (horizontal, swivel A = 0), reaches into the blank's root
/// cylinder (mm; negative: that far clear of it). In the plane of the table's axis and
/// the common normal the hob's outline is the circle of its tip radius around (X, Y), the
/// root cylinder the rectangle from the axis to the root radius over the face: the reach
/// is the tip radius less the circle centre's distance from the rectangle.
///
/// The root cylinder, not the outside diameter: a part being finished has its gaps cut,
/// and the hob may stand in one (up to the total depth inside the outside diameter).
pub fn reach_into_root_mm(blank: &Blank, tool_tip_diameter_mm: f64, x_mm: f64, y_mm: f64) -> f64 {
    let root_radius = (0.5 * blank.outside_diameter_mm - blank.total_depth_mm).max(0.0);
    let dx = (x_mm.abs() - root_radius).max(0.0);
    let dz = (blank.face_bottom_mm - y_mm)
        .max(y_mm - blank.face_top_mm)
        .max(0.0);
    0.5 * tool_tip_diameter_mm - dx.hypot(dz)
}

/// A touch-off as the operator entered it and the machine stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TouchOffInput {
    /// X (the gauge's diameter) or Y (the height of its top face above the table face).
    pub axis: Axis,
    pub gauge_mm: f64,
    /// The touched axis' referenced position (the work position less its offset).
    pub machine_mm: f64,
    /// Its work offset now.
    pub old_offset_mm: f64,
    /// The other axis' work position (Y for an X touch-off, X for a Y one), `None` when
    /// it is not referenced.
    pub other_work_mm: Option<f64>,
    pub tool_tip_diameter_mm: f64,
    pub blank: Blank,
    /// `setup.touch_off_confirm_mm`.
    pub confirm_mm: f64,
}

/// Why the loop asks before applying a touch-off: each check that failed, with its
/// figure (mm); `None` where the check passed or does not apply.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Doubts {
    /// (a) X only: the gauge's diameter less the loaded blank's outside diameter, when
    /// the hob's tip would stand more than the limit off the blank (half of it).
    pub gauge_less_blank_mm: Option<f64>,
    /// (b) The offset's change from the previous one, when more than the limit.
    pub change_mm: Option<f64>,
    /// (c) How far the hob would reach into the blank's root cylinder with the new offset
    /// where the axes stand ([`reach_into_root_mm`]), when more than the limit.
    pub into_blank_mm: Option<f64>,
}

impl Doubts {
    pub fn any(&self) -> bool {
        self.gauge_less_blank_mm.is_some() || self.change_mm.is_some() || self.into_blank_mm.is_some()
    }
}

/// A touch-off judged: the offset it would set, from which, and the loop's doubts.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TouchOff {
    pub axis: Axis,
    pub gauge_mm: f64,
    pub old_offset_mm: f64,
    pub new_offset_mm: f64,
    /// The limit the doubts were judged by (`setup.touch_off_confirm_mm`).
    pub confirm_mm: f64,
    pub doubts: Doubts,
}

impl TouchOff {
    /// How far the offset moves (new less old), mm.
    pub fn change_mm(&self) -> f64 {
        self.new_offset_mm - self.old_offset_mm
    }
}

/// Judges a touch-off: the offset it sets ([`x_offset_from_touch`],
/// [`y_offset_from_touch`]) and whether it is plausible, or `None` when that offset is
/// absurd (a value not finite, a gauge of no size, an offset beyond [`MAX_OFFSET_MM`]): the
/// loop refuses those even when confirmed. Each check below passes within the limit
/// `confirm_mm`, so one number says how far an operator's input may move the work unasked:
///
/// - (a) against the loaded blank, X only: the hob's tip on the gauge is half the
///   difference of the diameters off the blank's outside diameter (the gauge is usually the
///   blank itself; a ring of another size is confirmed once). A Y gauge is a block or the
///   blank's top face, which the program does not say: (c) and (b) judge it.
/// - (b) against the previous offset: a referenced axis' offset is the reference's error
///   (plus the ways' warmth) and changes by hundredths between touch-offs, whatever the
///   tool or the blank (both are in the formula). The first touch-off after the machine
///   file's state is lost compares with 0.
/// - (c) against where the axes stand: with the new offset, the hob's outline (its tip
///   circle around the new work position of the touched axis and the other axis' work
///   position) must not reach into the blank's root cylinder; with the other axis not
///   referenced, an X touch-off takes the hob at the face's height and a Y touch-off skips
///   the check (nothing says whether the hob is over the blank).
pub fn check_touch_off(t: &TouchOffInput) -> Option<TouchOff> {
    let (new_offset_mm, gauge_less_blank_mm, reach) = match t.axis {
        Axis::X => {
            let o = x_offset_from_touch(t.machine_mm, t.gauge_mm, t.tool_tip_diameter_mm)?;
            let off = t.gauge_mm - t.blank.outside_diameter_mm;
            let y = t.other_work_mm.unwrap_or(t.blank.face_bottom_mm);
            let reach = reach_into_root_mm(&t.blank, t.tool_tip_diameter_mm, t.machine_mm + o, y);
            (o, (0.5 * off.abs() > t.confirm_mm).then_some(off), Some(reach))
        }
        Axis::Y => {
            let o = y_offset_from_touch(t.machine_mm, t.gauge_mm, t.tool_tip_diameter_mm)?;
            let reach = t
                .other_work_mm
                .map(|x| reach_into_root_mm(&t.blank, t.tool_tip_diameter_mm, x, t.machine_mm + o));
            (o, None, reach)
        }
        Axis::B => return None,
    };
    let change = new_offset_mm - t.old_offset_mm;
    // A blank of no size or a limit that is no number makes every judgement void.
    let sane = t.confirm_mm.is_finite() && t.old_offset_mm.is_finite() && change.is_finite();
    sane.then_some(TouchOff {
        axis: t.axis,
        gauge_mm: t.gauge_mm,
        old_offset_mm: t.old_offset_mm,
        new_offset_mm,
        confirm_mm: t.confirm_mm,
        doubts: Doubts {
            gauge_less_blank_mm,
            change_mm: (change.abs() > t.confirm_mm).then_some(change),
            into_blank_mm: reach.filter(|r| r.is_nan() || *r > t.confirm_mm),
        },
    })
}

/// A confirmation stands for the offset it was shown to within this (mm): three counts of
/// X or Y at rest (0.33 um each), which a servo holding against the ways' static friction
/// may move between the question and the answer.
pub const CONFIRM_MATCH_MM: f64 = 0.001;

/// The loop's memory of touch-offs: the last one judged (the answer names its figures) and
/// the one it asked the operator to confirm.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TouchOffs {
    pub last: Option<TouchOff>,
    pub asked: Option<TouchOff>,
}

impl TouchOffs {
    /// Decides on a judged touch-off: the touch-off to apply (its `new_offset_mm` the
    /// offset), or `None`: ask the operator (the judged one is remembered as asked).
    ///
    /// Without doubts it applies. With doubts it applies only `confirmed`: the offset that
    /// was shown when the operator confirms the gauge the loop asked about (the same axis,
    /// gauge and previous offset) and the axis has not moved since by more than
    /// [`CONFIRM_MATCH_MM`]; if it has moved, the loop asks again with the new figures. A
    /// confirmation with nothing asked (`hob touch-off ... --confirm` at once) applies what
    /// it judges now, and the answer names it.
    pub fn decide(&mut self, judged: TouchOff, confirmed: bool) -> Option<TouchOff> {
        let asked = self.asked.take();
        let apply = if !judged.doubts.any() {
            Some(judged)
        } else if !confirmed {
            None
        } else {
            match asked {
                Some(a)
                    if a.axis == judged.axis
                        && a.gauge_mm.to_bits() == judged.gauge_mm.to_bits()
                        && a.old_offset_mm.to_bits() == judged.old_offset_mm.to_bits() =>
                {
                    ((a.new_offset_mm - judged.new_offset_mm).abs() <= CONFIRM_MATCH_MM).then_some(a)
                }
                _ => Some(judged),
            }
        };
        if apply.is_none() {
            self.asked = Some(judged);
        }
        self.last = Some(apply.unwrap_or(judged));
        apply
    }
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

    /// The thesis gear's blank (config/programs/spur-z17-m5.toml): outside diameter 95 mm,
    /// total depth 11.25 mm, the face 50 .. 90 mm above the table; a hob of 80 mm.
    const SPUR: Blank = Blank {
        outside_diameter_mm: 95.0,
        total_depth_mm: 11.25,
        face_bottom_mm: 50.0,
        face_top_mm: 90.0,
    };
    const HOB_MM: f64 = 80.0;
    const LIMIT_MM: f64 = 0.3;

    fn x_touch(gauge_mm: f64, machine_mm: f64, old_offset_mm: f64) -> TouchOffInput {
        TouchOffInput {
            axis: Axis::X,
            gauge_mm,
            machine_mm,
            old_offset_mm,
            other_work_mm: Some(70.0),
            tool_tip_diameter_mm: HOB_MM,
            blank: SPUR,
            confirm_mm: LIMIT_MM,
        }
    }

    fn y_touch(gauge_mm: f64, machine_mm: f64, old_offset_mm: f64, x_work_mm: Option<f64>) -> TouchOffInput {
        TouchOffInput {
            axis: Axis::Y,
            gauge_mm,
            machine_mm,
            old_offset_mm,
            other_work_mm: x_work_mm,
            ..x_touch(0.0, 0.0, 0.0)
        }
    }

    #[test]
    fn the_typo_of_issue_32_needs_a_confirmation_and_the_right_gauge_does_not() {
        // The blank measured 94.94 mm, the hob's tip on it: X (machine) 87.475 mm with the
        // offset -0.005 mm. 194.94 typed for 94.94 would set +49.995 mm, just within the
        // +-50 mm that was the only check.
        let typo = check_touch_off(&x_touch(194.94, 87.475, -0.005)).expect("within +-50 mm");
        assert!((typo.new_offset_mm - 49.995).abs() < 1e-9, "{typo:?}");
        assert!((typo.change_mm() - 50.0).abs() < 1e-9);
        let d = typo.doubts;
        assert!(d.any());
        assert!((d.gauge_less_blank_mm.unwrap() - 99.94).abs() < 1e-9, "{d:?}");
        assert!((d.change_mm.unwrap() - 50.0).abs() < 1e-9, "{d:?}");
        // With that offset the loop would think the hob 50 mm clear of the blank.
        assert_eq!(d.into_blank_mm, None, "{d:?}");
        let right = check_touch_off(&x_touch(94.94, 87.475, -0.005)).unwrap();
        assert!((right.new_offset_mm + 0.005).abs() < 1e-9);
        assert_eq!(right.doubts, Doubts::default(), "{right:?}");
    }

    #[test]
    fn a_re_touch_of_a_few_hundredths_is_applied_unasked() {
        // Last offset +0.10; the ways grew warm: the same blank touched 0.02 mm further out.
        let t = check_touch_off(&x_touch(95.0, 87.5 - 0.12, 0.10)).unwrap();
        assert!((t.change_mm() - 0.02).abs() < 1e-9);
        assert_eq!(t.doubts, Doubts::default());
        // A blank 0.36 mm under its nominal diameter (h11 at 95 mm is 0.22: generous) too.
        let small = check_touch_off(&x_touch(94.64, 0.5 * (94.64 + HOB_MM) - 0.1, 0.1)).unwrap();
        assert_eq!(small.doubts, Doubts::default(), "{small:?}");
    }

    #[test]
    fn absurd_values_are_never_judged() {
        for g in [f64::NAN, f64::INFINITY, -1.0, 0.0] {
            assert_eq!(check_touch_off(&x_touch(g, 87.5, 0.0)), None, "{g}");
        }
        // Beyond +-50 mm, however plausible the rest.
        assert_eq!(check_touch_off(&x_touch(95.0, 87.5 - 50.01, 50.0)), None);
        assert_eq!(check_touch_off(&y_touch(f64::NAN, 100.0, 0.0, None)), None);
        assert_eq!(check_touch_off(&y_touch(-0.1, 100.0, 0.0, None)), None);
        assert_eq!(
            check_touch_off(&TouchOffInput {
                axis: Axis::B,
                ..x_touch(95.0, 87.5, 0.0)
            }),
            None
        );
        assert_eq!(
            check_touch_off(&TouchOffInput {
                old_offset_mm: f64::NAN,
                ..x_touch(95.0, 87.5, 0.0)
            }),
            None
        );
    }

    #[test]
    fn a_y_gauge_is_judged_by_where_the_hob_stands_over_the_blank() {
        // The hob over the blank (its axis at X 50: the tip 10 mm from the table's axis),
        // its lowest tip on the top face, 90 mm: Y 130 mm. Offset +0.1 before and after.
        let top = check_touch_off(&y_touch(90.0, 129.9, 0.1, Some(50.0))).unwrap();
        assert_eq!(top.doubts, Doubts::default(), "{top:?}");
        // 80 typed for 90: the hob's tip 10 mm below the top face, its outline 7 mm into
        // the root cylinder (it clears the cylinder's edge by its roundness).
        let typo = check_touch_off(&y_touch(80.0, 129.9, 0.1, Some(50.0))).unwrap();
        assert!((typo.change_mm() + 10.0).abs() < 1e-9, "{typo:?}");
        let reach = typo.doubts.into_blank_mm.expect("inside the blank");
        assert!((reach - (40.0 - 13.75f64.hypot(30.0))).abs() < 1e-9, "{typo:?}");
        // Beside the blank (X 200) any height is a gauge block's: only the change judges.
        let beside = check_touch_off(&y_touch(30.0, 69.9, 0.1, Some(200.0))).unwrap();
        assert_eq!(beside.doubts, Doubts::default(), "{beside:?}");
        let beside_far = check_touch_off(&y_touch(30.0, 69.0, 0.1, Some(200.0))).unwrap();
        assert_eq!(beside_far.doubts.into_blank_mm, None);
        assert!((beside_far.doubts.change_mm.unwrap() - 0.9).abs() < 1e-9);
        // X not referenced: nothing says where the hob is; the change still judges.
        let unknown = check_touch_off(&y_touch(80.0, 129.9, 0.1, None)).unwrap();
        assert_eq!(unknown.doubts.into_blank_mm, None);
        assert!(unknown.doubts.change_mm.is_some());
    }

    #[test]
    fn the_hob_may_stand_in_a_cut_gap_but_not_below_the_root() {
        // Touching the root of a cut gap (outside diameter less twice the depth): no reach.
        let root = 95.0 - 2.0 * 11.25;
        assert!(reach_into_root_mm(&SPUR, HOB_MM, 0.5 * (root + HOB_MM), 70.0).abs() < 1e-9);
        // 2 mm below it: 2 mm into the root cylinder.
        assert!((reach_into_root_mm(&SPUR, HOB_MM, 0.5 * (root + HOB_MM) - 2.0, 70.0) - 2.0).abs() < 1e-9);
        // Above the top face the reach is the tip's depth below it (here 1 mm).
        assert!((reach_into_root_mm(&SPUR, HOB_MM, 20.0, 90.0 + 40.0 - 1.0) - 1.0).abs() < 1e-9);
        // An X gauge below the root diameter at the face's height (a typo of 9.5 for 95):
        // it is off the blank and inside it.
        let t = check_touch_off(&x_touch(59.5, 0.5 * (59.5 + HOB_MM) - 0.1, 0.1)).unwrap();
        assert!(
            t.doubts.gauge_less_blank_mm.is_some() && t.doubts.into_blank_mm.is_some(),
            "{t:?}"
        );
    }

    fn judged(new_offset_mm: f64, doubted: bool) -> TouchOff {
        TouchOff {
            axis: Axis::X,
            gauge_mm: 194.94,
            old_offset_mm: -0.005,
            new_offset_mm,
            confirm_mm: LIMIT_MM,
            doubts: Doubts {
                change_mm: doubted.then_some(new_offset_mm + 0.005),
                ..Doubts::default()
            },
        }
    }

    #[test]
    fn a_confirmation_applies_the_offset_it_was_shown() {
        let mut m = TouchOffs::default();
        // Unconfirmed: asked, nothing applied.
        assert_eq!(m.decide(judged(49.995, true), false), None);
        assert_eq!(m.asked, Some(judged(49.995, true)));
        assert_eq!(m.last, Some(judged(49.995, true)));
        // Confirmed a cycle later, X a count further (0.33 um): the number shown applies.
        let applied = m.decide(judged(49.995_33, true), true).expect("confirmed");
        assert_eq!(applied.new_offset_mm.to_bits(), 49.995f64.to_bits());
        assert_eq!(m.last, Some(applied));
        assert_eq!(m.asked, None, "a confirmation is used once");
        // Asked again, then X jogged 0.5 mm before the confirmation: asked anew with the
        // new figures, nothing applied.
        assert_eq!(m.decide(judged(49.995, true), false), None);
        assert_eq!(m.decide(judged(50.495 - 1.0, true), true), None);
        assert_eq!(m.asked, Some(judged(49.495, true)));
        // ... and that one confirmed applies.
        assert_eq!(
            m.decide(judged(49.495, true), true).map(|t| t.new_offset_mm),
            Some(49.495)
        );
        // Confirmed at once, nothing asked before (the CLI's --confirm): applied as judged.
        let mut fresh = TouchOffs::default();
        assert_eq!(
            fresh.decide(judged(10.0, true), true).map(|t| t.new_offset_mm),
            Some(10.0)
        );
        // Without doubts a touch-off applies, confirmed or not, and forgets the question.
        let mut m = TouchOffs::default();
        assert_eq!(m.decide(judged(49.995, true), false), None);
        assert_eq!(
            m.decide(judged(0.01, false), false).map(|t| t.new_offset_mm),
            Some(0.01)
        );
        assert_eq!(m.asked, None);
        // Another gauge than the one asked about, confirmed: judged on its own.
        assert_eq!(m.decide(judged(49.995, true), false), None);
        let other = TouchOff {
            gauge_mm: 194.0,
            ..judged(49.5, true)
        };
        assert_eq!(m.decide(other, true), Some(other));
    }

    proptest! {
        #[test]
        fn a_re_touch_of_the_blank_within_its_tolerance_never_asks(
            od in 40.0f64..400.0, tool in 40.0f64..120.0, reference_error in -5.0f64..5.0,
            tolerance in -0.36f64..0.36, scatter in -0.02f64..0.02, y in 50.0f64..90.0,
        ) {
            // The blank as turned (within h11 of its nominal diameter up to 400 mm), the hob
            // on it; the previous offset right within the ways' warmth and a touch's scatter.
            let blank = Blank { outside_diameter_mm: od, total_depth_mm: 0.1 * od, ..SPUR };
            let actual = od + tolerance;
            let machine = 0.5 * (actual + tool) - reference_error;
            let t = check_touch_off(&TouchOffInput {
                gauge_mm: actual,
                machine_mm: machine,
                old_offset_mm: reference_error + scatter,
                other_work_mm: Some(y),
                tool_tip_diameter_mm: tool,
                blank,
                ..x_touch(0.0, 0.0, 0.0)
            }).expect("plausible");
            prop_assert!((machine + t.new_offset_mm - 0.5 * (actual + tool)).abs() < 1e-9);
            prop_assert_eq!(t.doubts, Doubts::default());
        }

        #[test]
        fn a_gauge_wrong_by_a_millimetre_or_more_always_asks(
            od in 40.0f64..400.0, tool in 40.0f64..120.0, reference_error in -5.0f64..5.0,
            wrong in 1.0f64..200.0, negative: bool, y_axis: bool,
        ) {
            // The hob on the blank (X) or on a block beside it (Y), the previous offset
            // right; the operator types the gauge a millimetre or more off.
            let wrong = if negative { -wrong } else { wrong };
            let blank = Blank { outside_diameter_mm: od, total_depth_mm: 0.1 * od, ..SPUR };
            let input = if y_axis {
                let h = 30.0;
                TouchOffInput {
                    axis: Axis::Y,
                    gauge_mm: h + wrong,
                    machine_mm: h + 0.5 * tool - reference_error,
                    other_work_mm: Some(0.5 * (od + tool) + 20.0),
                    ..x_touch(0.0, 0.0, 0.0)
                }
            } else {
                TouchOffInput {
                    gauge_mm: od + wrong,
                    machine_mm: 0.5 * (od + tool) - reference_error,
                    ..x_touch(0.0, 0.0, 0.0)
                }
            };
            let input = TouchOffInput { old_offset_mm: reference_error, tool_tip_diameter_mm: tool, blank, ..input };
            if let Some(t) = check_touch_off(&input) {
                prop_assert!(t.doubts.any(), "{:?}", t);
                prop_assert!(t.doubts.change_mm.is_some());
            }
        }

        #[test]
        fn no_number_that_is_none_is_ever_judged(
            bits in any::<u64>(), axis_y: bool, confirmed: bool,
        ) {
            let g = f64::from_bits(bits);
            let input = TouchOffInput {
                axis: if axis_y { Axis::Y } else { Axis::X },
                ..x_touch(g, 87.5, 0.0)
            };
            match check_touch_off(&input) {
                Some(t) => {
                    prop_assert!(g.is_finite() && t.new_offset_mm.abs() <= MAX_OFFSET_MM);
                    let mut m = TouchOffs::default();
                    // Whatever is applied was judged or shown, never anything else.
                    if let Some(a) = m.decide(t, confirmed) {
                        prop_assert!(confirmed || !t.doubts.any());
                        prop_assert_eq!(a, t);
                    }
                }
                None => {
                    let offset = if axis_y { g + 40.0 - 87.5 } else { 0.5 * (g + 80.0) - 87.5 };
                    let no_size = if axis_y { g < 0.0 } else { g <= 0.0 };
                    prop_assert!(!g.is_finite() || no_size || offset.abs() > MAX_OFFSET_MM, "{}", g);
                }
            }
        }

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
