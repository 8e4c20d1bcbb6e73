//! How long the loaded program still runs, for the operator's AUTOMATIC screen: from the
//! plan, the pass the loop is in, where Y stands and the feed override. An estimate: the
//! current pass's feed stroke at the overridden feed for the Y still to go, its other
//! motions (rapids, plunges, ramps) in proportion, the later passes as planned at 100 %,
//! and the cycle's start and end (spindle ramps, the way home) in proportion to the passes
//! left. Not for tooth-by-tooth cycles, whose Y strokes repeat per tooth.

use super::Plan;
use crate::job::CycleKind;

/// Seconds left, or `None` when there is no estimate: no pass under way (`pass` 0 or past
/// the last), a feed override of 0 (held: it stops), or a tooth-by-tooth cycle.
pub fn time_left_s(plan: &Plan, pass: u32, y_mm: f64, feed_override_percent: f64) -> Option<f64> {
    if plan.cycle == CycleKind::ToothByTooth
        || feed_override_percent.is_nan()
        || feed_override_percent <= 0.0
        || !y_mm.is_finite()
    {
        return None;
    }
    let idx = usize::try_from(pass).ok()?.checked_sub(1)?;
    let cur = plan.passes.get(idx)?;
    let all_passes_s: f64 = plan.passes.iter().map(|p| p.pass_time_s).sum();
    let later_s: f64 = plan.passes[idx + 1..].iter().map(|p| p.pass_time_s).sum();
    let stroke_mm = cur.y_end_mm - cur.y_start_mm;
    let done = if stroke_mm.abs() > 1e-9 {
        ((y_mm - cur.y_start_mm) / stroke_mm).clamp(0.0, 1.0)
    } else {
        1.0
    };
    let feed_s = if cur.axial_feed_mm_min > 0.0 {
        stroke_mm.abs() / cur.axial_feed_mm_min * 60.0
    } else {
        0.0
    };
    let other_s = (cur.pass_time_s - feed_s).max(0.0);
    let this_pass_s = (1.0 - done) * (feed_s * 100.0 / feed_override_percent + other_s);
    let left_passes_s = (1.0 - done) * cur.pass_time_s + later_s;
    let frame_s = (plan.total_time_s - all_passes_s).max(0.0);
    let share = if all_passes_s > 0.0 {
        left_passes_s / all_passes_s
    } else {
        0.0
    };
    Some(this_pass_s + later_s + frame_s * share)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::machine::shipped_for_tests;
    use std::path::Path;

    fn plan() -> Plan {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/programs/spur-z17-m5.toml");
        crate::planner::plan_source(
            &p,
            &std::fs::read_to_string(&p).expect("read"),
            &shipped_for_tests(),
        )
        .expect("the shipped program")
    }

    #[test]
    fn at_the_start_it_is_the_planned_cycle_time_and_it_falls_to_nothing() {
        let plan = plan();
        let first = &plan.passes[0];
        let start = time_left_s(&plan, 1, first.y_start_mm, 100.0).expect("an estimate");
        assert!(
            (start - plan.total_time_s).abs() < 1e-6,
            "{start} s against {} s",
            plan.total_time_s
        );
        // Along every pass it only falls.
        let mut last = f64::INFINITY;
        for (i, p) in plan.passes.iter().enumerate() {
            for k in 0..=20 {
                let y = p.y_start_mm + (p.y_end_mm - p.y_start_mm) * f64::from(k) / 20.0;
                let t = time_left_s(&plan, i as u32 + 1, y, 100.0).expect("an estimate");
                assert!(t <= last + 1e-9, "pass {} at Y {y}: {t} s after {last} s", i + 1);
                last = t;
            }
        }
        assert!(last.abs() < 1e-9, "{last} s left at the end of the last pass");
    }

    #[test]
    fn half_the_feed_doubles_the_stroke_still_to_cut() {
        let plan = plan();
        let n = plan.passes.len() as u32;
        let p = &plan.passes[n as usize - 1];
        let mid = 0.5 * (p.y_start_mm + p.y_end_mm);
        let full = time_left_s(&plan, n, mid, 100.0).expect("an estimate");
        let half = time_left_s(&plan, n, mid, 50.0).expect("an estimate");
        let stroke_left_s = 0.5 * (p.y_end_mm - p.y_start_mm).abs() / p.axial_feed_mm_min * 60.0;
        assert!(
            (half - full - stroke_left_s).abs() < 1e-6,
            "{full} s at 100 %, {half} s at 50 %"
        );
        assert_eq!(time_left_s(&plan, n, mid, 0.0), None, "held at 0 %: no end");
        assert_eq!(time_left_s(&plan, 0, mid, 100.0), None, "no pass under way");
        assert_eq!(time_left_s(&plan, n + 1, mid, 100.0), None);
    }
}
