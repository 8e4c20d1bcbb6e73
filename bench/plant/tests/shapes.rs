//! X follows the crowning arc and the contour in the cut, to 0.1 um in the command, and
//! the simulated slide follows the command.
#![allow(clippy::unwrap_used)]

mod common;

use common::{powered_up, run_cycle, short_spur};
use hob_plant::sim::RowState as State;

const BOTTOM_MM: f64 = 50.0;

fn check(edits: &[(&str, &str)], expected_offset_mm: impl Fn(f64) -> f64) {
    let mut all = vec![("face_width_mm = 4.0", "face_width_mm = 20.0")];
    all.extend_from_slice(edits);
    let (job, cycle, plan) = short_spur(&all);
    let mut sim = powered_up(&job, &cycle, &plan);
    let r = run_cycle(&mut sim, false, 600.0);
    assert!(
        r.events
            .iter()
            .any(|e| e.kind == hob_control::events::EventKind::CycleDone),
        "the cycle must finish (every pass cut): {:?} {:?}",
        r.states(),
        r.faults()
    );
    let mut worst_cmd = 0.0f64;
    let mut worst_actual = 0.0f64;
    let mut checked = 0;
    for row in r.rows.iter().filter(|x| x.state == State::Cut) {
        let pass = &plan.passes[row.pass as usize - 1];
        let expected = pass.x_mm + expected_offset_mm(row.y_cmd_mm - BOTTOM_MM);
        worst_cmd = worst_cmd.max((row.x_cmd_mm - expected).abs());
        worst_actual = worst_actual.max((row.x_mm - row.x_cmd_mm).abs());
        checked += 1;
    }
    println!(
        "X command off the shape by at most {:.3e} mm, slide off its command by {:.3e} mm",
        worst_cmd, worst_actual
    );
    assert!(checked > 10_000);
    assert!(worst_cmd <= 1e-4, "command {worst_cmd} mm off the shape");
    assert!(worst_actual <= 1e-3, "slide {worst_actual} mm off the command");
}

#[test]
fn x_follows_the_crowning_arc() {
    // h = 0.05 mm over b = 20 mm: R = 100 / 0.1 + 0.025 = 1000.025 mm.
    let (h, b) = (0.05, 20.0);
    let r = (b / 2.0f64).powi(2) / (2.0 * h) + h / 2.0;
    check(
        &[(
            "crowning = { height_mm = 0.02 }",
            "crowning = { height_mm = 0.05 }",
        )],
        |face| {
            let u = (face - b / 2.0).clamp(-b / 2.0, b / 2.0);
            -(r - (r * r - u * u).sqrt())
        },
    );
}

#[test]
fn x_follows_the_contour() {
    check(
        &[(
            "crowning = { height_mm = 0.02 }",
            "contour = [[0.0, -0.02], [10.0, 0.0], [15.0, -0.005], [20.0, -0.02]]",
        )],
        |face| {
            let pts = [(0.0, -0.02), (10.0, 0.0), (15.0, -0.005), (20.0, -0.02)];
            if face <= 0.0 {
                return -0.02;
            }
            if face >= 20.0 {
                return -0.02;
            }
            let i = pts.iter().position(|p| p.0 > face).unwrap();
            let (a, b) = (pts[i - 1], pts[i]);
            a.1 + (b.1 - a.1) * (face - a.0) / (b.0 - a.0)
        },
    );
}
