//! `hob commission response` on the simulated machine (issue 33's step 2): the table's
//! target swung by the loop's own excitation (`Command::ExciteTable`) at the procedure's
//! frequencies, the motor's response read from the loop's status every cycle as the state
//! stream carries it, each point estimated by the product's own code
//! (`hob_commission::response`).
#![allow(clippy::unwrap_used)]

mod common;

use hob_commission::response::frf::{self, Point, Reading};
use hob_commission::response::{self, ResponseOptions};
use hob_control::{Command, Direction, State};
use hob_plant::config::PlantConfig;

/// The response at each of `freqs`, as the procedure holds and reads it.
fn sweep(sim: &mut hob_plant::sim::Simulation, freqs: &[f64]) -> Vec<Point> {
    let period_s = 1e-3;
    let mut out = Vec::new();
    for &f in freqs {
        let fade_cycles = ((hob_control::jog::EXCITE_FADE_S + response::SETTLE_S) / period_s) as usize;
        let read_cycles = (response::read_s(f) / period_s) as usize;
        let mut readings = Vec::new();
        let mut k = 0usize;
        while k < fade_cycles + read_cycles {
            if k.is_multiple_of(100) {
                assert_eq!(
                    sim.command(Command::ExciteTable {
                        frequency_hz: f,
                        creep: Direction::Positive
                    }),
                    Ok(()),
                    "{f} Hz"
                );
            }
            sim.step();
            if k >= fade_cycles {
                let s = sim.controller.status();
                readings.push(Reading {
                    command_deg: s.table_cmd_deg,
                    table_deg: s.table_deg,
                });
            }
            k += 1;
        }
        assert_eq!(sim.command(Command::JogRelease), Ok(()));
        common::run(sim, 2.0, |r| r.state == State::Idle);
        out.push(frf::point(f, period_s, &readings).unwrap());
    }
    out
}

fn measured(plant: &PlantConfig) -> Vec<Point> {
    let (job, cycle, plan) = common::short_spur(&[]);
    let mut sim = common::powered_up_on(plant, &job, &cycle, &plan);
    let o = ResponseOptions::default();
    sweep(&mut sim, &o.first_sweep())
}

#[test]
fn the_shipped_table_drive_responds_with_the_mesh_dip() {
    let points = measured(&common::plant());
    for p in &points {
        println!(
            "{:8.2} Hz {:8.2} dB {:8.1} deg +-{:.4}  swing {:.5} deg",
            p.frequency_hz,
            p.magnitude_db(),
            p.phase_deg(),
            p.uncertainty,
            p.amplitude_deg
        );
    }
}

#[test]
fn the_excitation_is_refused_outside_its_range_and_beside_another_and_fades_out() {
    let (job, cycle, plan) = common::short_spur(&[]);
    let mut sim = common::powered_up_on(&common::plant(), &job, &cycle, &plan);
    let excite = |f| Command::ExciteTable {
        frequency_hz: f,
        creep: Direction::Negative,
    };
    use hob_control::fault::Refusal;
    for f in [0.1, 251.0, f64::NAN, -5.0] {
        assert_eq!(sim.command(excite(f)), Err(Refusal::BadValue), "{f} Hz");
    }
    let before = sim.controller.status().table_cmd_deg;
    assert_eq!(sim.command(excite(40.0)), Ok(()));
    common::run(&mut sim, 0.05, |_| false);
    assert_eq!(sim.controller.status().state, State::Jog);
    assert_eq!(sim.command(excite(41.0)), Err(Refusal::JogActive));
    assert_eq!(
        sim.command(Command::Start { single: false }),
        Err(Refusal::JogActive)
    );
    // Not renewed: the dead-man fades it out, and the machine is idle again with the
    // table's target where the creep took it (no swing left).
    let run = common::run(&mut sim, 3.0, |r| r.state == State::Idle);
    assert_eq!(run.rows.last().unwrap().state, State::Idle);
    let s = sim.controller.status();
    let crept = before - s.table_cmd_deg;
    assert!(crept > 0.0 && crept < 0.6 * 1.0, "crept {crept} deg");
    let later = common::run(&mut sim, 0.2, |_| false);
    assert!(later.rows.iter().all(|r| r.state == State::Idle));
    assert_eq!(
        sim.controller.status().table_cmd_deg,
        s.table_cmd_deg,
        "no swing left at rest"
    );
}
