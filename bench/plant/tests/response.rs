//! `hob commission response` on the simulated machine (issue 33's step 2): the table's
//! target swung by the loop's own excitation (`Command::ExciteTable`) at the procedure's
//! frequencies, the motor's response read from the loop's status every cycle as the state
//! stream carries it, each point estimated by the product's own code
//! (`hob_commission::response`).
#![allow(clippy::unwrap_used)]

mod common;

use hob_commission::response::frf::{self, Point, Reading};
use hob_commission::response::{self, ResponseOptions, analysis, bode, fit, model};
use hob_control::{Command, Direction, State};
use hob_plant::config::PlantConfig;
use hob_setup::config::machine::TableDriveModel;

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
    let mut points = sweep(&mut sim, &o.first_sweep());
    let i = (0..points.len())
        .min_by(|&a, &b| points[a].response.norm().total_cmp(&points[b].response.norm()))
        .unwrap();
    let refined = o.refinement(points[i - 1].frequency_hz, points[i + 1].frequency_hz);
    points.extend(sweep(&mut sim, &refined));
    points.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    points
}

/// The plant's own mechanism and drive loops, as the model reads them.
fn truth(plant: &PlantConfig) -> (model::Mechanism, model::DriveLoops, model::CspTiming) {
    let t = &plant.table;
    let m = model::Mechanism {
        motor_inertia_kg_m2: t.motor_inertia_kg_m2 + t.worm_inertia_kg_m2,
        table_inertia_kg_m2: t.table_inertia_kg_m2,
        mesh_stiffness_nm_per_rad: t.worm.stiffness_nm_rad,
        mesh_damping_nm_s_per_rad: 0.0,
        worm_ratio: 75.0,
    };
    let m = model::Mechanism {
        mesh_damping_nm_s_per_rad: m.damping_for_modal_ratio_nm_s_per_rad(t.worm.damping_ratio),
        ..m
    };
    let d = model::DriveLoops::from_bandwidths(
        m.rigid_inertia_kg_m2(),
        t.velocity_loop_hz,
        t.position_loop_hz,
        f64::from(plant.drives.loop_us) * 1e-6,
        plant.drives.velocity_filter_hz,
    );
    let csp = model::CspTiming {
        sync_period_s: 1e-3,
        extra_delay_s: plant.drives.extra_delay_s(1e-3),
    };
    (m, d, csp)
}

/// On the shipped plant (its drive tuned 74/16 Hz on the two-way worm): the sweep shows the
/// mesh's dip; the mechanism fitted to it, with the drive's gains and the motor side's
/// inertia given, puts the present tuning's margins near those of the plant's true
/// mechanism; and the gains proposed on the fitted mechanism keep their margins on the
/// true one (what a builder trusts when he writes them to the drive).
#[test]
fn the_fitted_mechanism_checks_the_tuning_and_proposes_gains_safe_on_the_true_one() {
    // The shipped plant (10 arcsec of play), and one without play: there the fit must find
    // the mechanism itself; with play it finds an equivalent, softer one (the swing of an
    // arcsec crosses part of the play), and what it says of the drive must still hold.
    for backlash_arcsec in [10.0, 0.0] {
        let mut plant = common::plant();
        plant.table.worm.backlash_arcsec = backlash_arcsec;
        println!("== {backlash_arcsec} arcsec of play");
        let fitted = check_on(&plant);
        if backlash_arcsec == 0.0 {
            let m = truth(&plant).0;
            let (fa, ta) = (model::mesh_modes(&fitted).0, model::mesh_modes(&m).0);
            assert!((fa / ta - 1.0).abs() < 0.03, "anti-resonance {fa} of {ta}");
            assert!((fitted.table_inertia_kg_m2 / m.table_inertia_kg_m2 - 1.0).abs() < 0.05);
            assert!((fitted.mesh_stiffness_nm_per_rad / m.mesh_stiffness_nm_per_rad - 1.0).abs() < 0.1);
        }
    }
}

/// The sweep, the analysis, the present tuning's margins against the truth's and the
/// proposal's margins on the true mechanism; the fitted mechanism.
fn check_on(plant: &PlantConfig) -> model::Mechanism {
    let plant = plant.clone();
    let points = measured(&plant);
    let (m, d, csp) = truth(&plant);
    for p in &points {
        let h = fit::response(&m, &d, 1e-3, 2e-3 + csp.extra_delay_s, p.frequency_hz);
        println!(
            "{:8.2} Hz {:8.2} dB {:8.1} deg +-{:.4}  swing {:.5} deg   linear model {:8.2} dB {:8.1} deg",
            p.frequency_hz,
            p.magnitude_db(),
            p.phase_deg(),
            p.uncertainty,
            p.amplitude_deg,
            20.0 * h.norm().log10(),
            h.arg().to_degrees()
        );
    }
    let dip = points
        .iter()
        .map(|p| p.magnitude_db())
        .fold(f64::INFINITY, f64::min);
    assert!(dip < -3.0, "no dip of the mesh's mode: {dip:.2} dB");
    let drive = TableDriveModel {
        motor_side_inertia_kg_m2: m.motor_inertia_kg_m2,
        loop_us: plant.drives.loop_us,
        speed_filter_hz: plant.drives.velocity_filter_hz,
    };
    let a = analysis::analyse(points, analysis::gains_of(&d), &drive, 75.0, 1e-3).unwrap();
    print!("{}", analysis::report(&a));
    if let Ok(dir) = std::env::var("HOB_RESPONSE_SVG") {
        std::fs::write(dir, bode::svg(&a)).unwrap();
    }
    let fitted = a.fitted.mechanism;
    println!("true {m:?}\nmodes true {:?}", model::mesh_modes(&m));
    let margins = |s: model::Stability| match s {
        model::Stability::Stable { velocity, cascade } => (velocity, cascade),
        other => panic!("{other:?}"),
    };
    let (v_fit, c_fit) = margins(a.present_stability);
    let (v_true, c_true) = margins(model::stability(&m, &d));
    println!("present tuning: fitted {v_fit:?} {c_fit:?}\n true {v_true:?} {c_true:?}");
    assert!((v_fit.gain_margin_db - v_true.gain_margin_db).abs() < 1.0);
    assert!((v_fit.phase_margin_deg - v_true.phase_margin_deg).abs() < 6.0);
    println!("fitted {fitted:?}");
    let (v, c) = margins(model::stability(&m, &a.proposed.loops));
    println!("proposed, on the true mechanism: {v:?} {c:?}");
    assert!(v.at_least(5.0, 40.0) && c.at_least(5.0, 35.0), "{v:?} {c:?}");
    fitted
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

/// A fault mid-swing (an X drive's) stops it: the machine faulted, the swing's offset fading
/// over a few cycles instead of jumping, then none left; a swing asked for during the cut
/// is refused and changes nothing.
#[test]
fn a_fault_mid_swing_fades_it_and_a_cut_refuses_it() {
    use hob_control::fault::{Axis, Refusal};
    use hob_plant::plant::Injection;
    let (job, cycle, plan) = common::short_spur(&[]);
    let mut sim = common::powered_up_on(&common::plant(), &job, &cycle, &plan);
    let excite = Command::ExciteTable {
        frequency_hz: 20.0,
        creep: Direction::Positive,
    };
    for _ in 0..5 {
        assert_eq!(sim.command(excite), Ok(()));
        common::run(&mut sim, 0.1, |_| false);
    }
    sim.plant.inject(Injection::DriveFault(Axis::X));
    let run = common::run(&mut sim, 0.3, |_| false);
    assert_eq!(run.rows.last().unwrap().state, State::Faulted);
    let cmds: Vec<f64> = run.rows.iter().map(|r| r.table_cmd_deg).collect();
    let largest_step = cmds.windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max);
    // The swing's own steps at 20 Hz (2 pi f A per ms) and the creep's: no jump beyond them.
    let swing_step = std::f64::consts::TAU * 20.0 * hob_control::jog::EXCITE_MAX_DEG * 1e-3;
    let creep_step = hob_control::jog::EXCITE_CREEP_DEG_S * 1e-3;
    assert!(
        largest_step <= swing_step + 1.2 * creep_step,
        "a step of {largest_step} deg"
    );
    let tail = &cmds[cmds.len() - 50..];
    assert!(
        tail.iter().all(|c| (c - tail[0]).abs() < 1e-9),
        "still swinging: {tail:?}"
    );
    sim.plant.clear_injections();
    common::repair_and_reset(&mut sim);
    assert_eq!(sim.command(Command::Start { single: false }), Ok(()));
    common::run(&mut sim, 60.0, |r| r.state == State::Cut);
    assert_eq!(sim.command(excite), Err(Refusal::CycleRunning));
}
