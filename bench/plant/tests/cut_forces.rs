//! The cut's force on the hob slide: along the gear's axis, against the teeth's motion at
//! the cut (`hob_gearing::signs`: they push the work along it, the hob back). In the
//! project's climb hobbing the teeth move with the feed, so the slide is pushed back against
//! its feed; in conventional hobbing it is pulled along it.
#![allow(clippy::unwrap_used)]

mod common;

use common::{powered_up, short_spur};
use hob_control::Command;
use hob_plant::sim::RowState as State;

/// The Y motor's process load in the cut (positive: pushing the slide down), its mean, and
/// the feed's sense (+1 up).
fn y_load_in_cut(method: &str) -> (f64, f64) {
    let (job, cycle, plan) = short_spur(&[("method = \"climb\"", method)]);
    let mut sim = powered_up(&job, &cycle, &plan);
    sim.command(Command::Start { single: false }).unwrap();
    let (mut sum, mut n) = (0.0, 0u32);
    for _ in 0..600_000 {
        let row = sim.step();
        if row.state == State::Cut && sim.plant.cutting() {
            sum += sim.plant.y.process_load_nm;
            n += 1;
        }
        if matches!(row.state, State::Idle | State::Faulted) {
            break;
        }
    }
    assert!(sim.controller.status().fault.is_none(), "{method}");
    assert!(n > 1000, "{method}: {n} cycles in the cut");
    let feed = (plan.passes[0].y_end_mm - plan.passes[0].y_start_mm).signum();
    (sum / f64::from(n), feed)
}

#[test]
fn the_cut_pushes_the_hob_slide_back_in_climb_and_along_its_feed_in_conventional() {
    let (climb, feed) = y_load_in_cut("method = \"climb\"");
    // From the top: the feed is down; the slide is pushed up, against it.
    assert_eq!(feed, -1.0);
    assert!(climb < 0.0, "climb: {climb} Nm");
    let (conventional, feed) = y_load_in_cut("method = \"conventional\"");
    assert_eq!(feed, -1.0);
    assert!(conventional > 0.0, "conventional: {conventional} Nm");
    // The same cut, the same force (the depth and the feed per turn are the same).
    assert!(
        (climb + conventional).abs() < 0.2 * conventional,
        "{climb} against {conventional} Nm"
    );
}
