//! Shared set-up of the closed-loop tests: the shipped machine and plant, example
//! programs (optionally edited), a powered-up simulation.
#![allow(dead_code, clippy::unwrap_used)]

use hob_control::Command;
use hob_control::events::Event;
use hob_control::program::CycleProgram;
use hob_plant::config::PlantConfig;
use hob_plant::sim::{RowState as State, Simulation, TraceRow, start_for, workpiece_for};
use hob_setup::config::Problems;
use hob_setup::config::machine::MachineConfig;
use hob_setup::job::Program;
use hob_setup::planner::{self, Plan};
use std::path::{Path, PathBuf};

pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

pub fn machine() -> MachineConfig {
    hob_store::files::load_machine(&root().join("config/machine.toml")).unwrap()
}

pub fn plant() -> PlantConfig {
    PlantConfig::load(&root().join("config/plant.toml")).unwrap()
}

/// An example program with textual edits applied to its source.
pub fn program(name: &str, edits: &[(&str, &str)]) -> (Program, CycleProgram, Plan) {
    program_on(&machine(), name, edits)
}

/// [`program`] for machine `m`.
pub fn program_on(m: &MachineConfig, name: &str, edits: &[(&str, &str)]) -> (Program, CycleProgram, Plan) {
    let mut src = std::fs::read_to_string(root().join("config/programs").join(name)).unwrap();
    for (from, to) in edits {
        assert!(src.contains(from), "{name} has no {from:?}");
        src = src.replace(from, to);
    }
    let job: Program = toml::from_str(&src).unwrap();
    let mut p = Problems::new();
    let cycle = CycleProgram::build(&job, m, &mut p).unwrap_or_else(|| panic!("{:?}", p.as_slice()));
    let plan = planner::plan(&job, m, &mut p).unwrap();
    (job, cycle, plan)
}

/// A short spur job (shallow, narrow, fast feed) so that whole cycles run in a second.
pub fn short_spur(extra: &[(&str, &str)]) -> (Program, CycleProgram, Plan) {
    let mut edits = vec![
        ("face_width_mm = 40.0", "face_width_mm = 4.0"),
        ("allowance_mm = 2.0", "allowance_mm = 0.5"),
        ("total_depth_mm = 11.25", "total_depth_mm = 2.0"),
        ("finish_allowance_mm = 0.5", "finish_allowance_mm = 0.2"),
        ("rough_depths_mm = [6.0, 4.75]\n", ""),
        ("rough_passes = 2", "rough_passes = 1"),
        ("feed_mm_per_rev = 2.0", "feed_mm_per_rev = 8.0"),
        ("feed_mm_per_rev = 1.0", "feed_mm_per_rev = 6.0"),
        ("single_depth_mm = 5.0", "single_depth_mm = 1.0"),
    ];
    edits.extend_from_slice(extra);
    program("spur-z17-m5.toml", &edits)
}

/// A powered-up machine with `cycle` loaded; power-up rows are dropped.
pub fn powered_up(job: &Program, cycle: &CycleProgram, plan: &Plan) -> Simulation {
    powered_up_on(&plant(), job, cycle, plan)
}

/// [`powered_up`] on another plant.
pub fn powered_up_on(plant: &PlantConfig, job: &Program, cycle: &CycleProgram, plan: &Plan) -> Simulation {
    let mut sim = Simulation::new(&machine(), plant, start_for(cycle), job.tool.gashes as u32);
    sim.plant.set_workpiece(workpiece_for(
        cycle,
        plan,
        job.workpiece.face_width_mm,
        job.tool.outside_diameter_mm,
    ));
    assert!(sim.power_up(120.0, &mut |_| {}), "power-up");
    sim.controller.load(*cycle).unwrap();
    sim
}

/// Rows and events of a stretch of a run.
pub struct Run {
    pub rows: Vec<TraceRow>,
    pub events: Vec<Event>,
}

impl Run {
    /// The sequence of states, each once per visit.
    pub fn states(&self) -> Vec<State> {
        let mut out: Vec<State> = Vec::new();
        for r in &self.rows {
            if out.last() != Some(&r.state) {
                out.push(r.state);
            }
        }
        out
    }

    /// The faults raised during the stretch, in order.
    pub fn faults(&self) -> Vec<hob_control::fault::Fault> {
        self.events
            .iter()
            .filter_map(|e| match e.kind {
                hob_control::events::EventKind::Fault(f) => Some(f),
                _ => None,
            })
            .collect()
    }

    /// Index of the first row in `state`.
    pub fn first(&self, state: State) -> Option<usize> {
        self.rows.iter().position(|r| r.state == state)
    }
}

/// Runs until `done` or `max_s`.
pub fn run(sim: &mut Simulation, max_s: f64, mut done: impl FnMut(&TraceRow) -> bool) -> Run {
    let mut rows = Vec::new();
    let from = sim.events.len();
    sim.run_until(max_s, &mut |r| rows.push(*r), &mut |r, _| done(r));
    Run {
        rows,
        events: sim.events[from..].to_vec(),
    }
}

/// Starts and runs to the end of the cycle (idle or faulted).
pub fn run_cycle(sim: &mut Simulation, single: bool, max_s: f64) -> Run {
    sim.command(Command::Start { single }).unwrap();
    run(sim, max_s, |r| matches!(r.state, State::Idle | State::Faulted))
}

/// Whether `expected` appears in `states` in this order (other states may lie between).
pub fn in_order(states: &[State], expected: &[State]) -> bool {
    let mut it = states.iter();
    expected.iter().all(|e| it.any(|s| s == e))
}

/// The technician repairs the Y drive; the operator resets; back to idle.
pub fn repair_and_reset(sim: &mut Simulation) {
    sim.plant.y.fault = false;
    sim.command(Command::Reset).unwrap();
    let back = run(sim, 30.0, |r| r.state == State::Idle);
    assert_eq!(
        back.rows.last().unwrap().state,
        State::Idle,
        "{:?}",
        back.states()
    );
    assert_eq!(sim.controller.status().fault, None);
}

/// PC-OK on and the drives enabled, standing where they are (targets = their counters).
pub fn holding(p: &hob_plant::plant::Plant) -> hob_control::CycleOutputs {
    let i = p.latch();
    hob_control::CycleOutputs {
        table_target_counts: i.table.position_counts,
        x_target_counts: i.x.position_counts,
        y_target_counts: i.y.position_counts,
        drives_enabled: true,
        digital_outputs: 0x01,
        ..hob_control::CycleOutputs::default()
    }
}

/// The table drive's delay, us after the SYNC that applies a target, identified as `hob log
/// delay` does from the recording of the demo cut on `plant`, with `machine`'s
/// `control.drive_delay_us` predicted.
pub fn identified_drive_delay_us(machine: &MachineConfig, plant: &PlantConfig) -> f64 {
    use hob_logger::delay::{TableSample, identify};
    let (job, cycle, plan) = program_on(machine, "demo-short-spur-z17-m5.toml", &[]);
    // A trace row carries the command applied at its SYNC, computed the cycle before; a
    // recording carries each cycle's own command: shifted by one row to read as a log.
    let mut rows: Vec<(f64, f64, bool)> = Vec::new();
    let s = hob_plant::sim::run_program(
        machine,
        plant,
        &cycle,
        &plan,
        &job,
        &hob_plant::sim::SimOptions::default(),
        &mut |row| {
            rows.push((
                row.table_cmd_deg,
                row.table_deg,
                row.state == State::Cut && row.sync_err_arcsec.is_some(),
            ));
        },
    )
    .unwrap();
    let samples: Vec<TableSample> = rows
        .windows(2)
        .map(|w| TableSample {
            command_deg: w[1].0,
            actual_deg: w[0].1,
            in_cut: w[0].2 && w[1].2,
        })
        .collect();
    assert!(s.completed, "{:?}", s.fault);
    let assumed_s = f64::from(machine.control.drive_delay_us) * 1e-6;
    let d = identify(&samples, 1e-3, assumed_s).expect("a cut to identify from");
    println!("{}", hob_logger::delay::text(&d, assumed_s));
    d.drive_delay_s * 1e6
}

/// Plants whose hidden values are not the machine file's (issue 33): (the drives' true
/// delay us, the worm's backlash arcsec, the spindle encoder's error arcsec), none the
/// shipped.
pub const HIDDEN_PLANTS: [(u32, f64, f64); 3] = [(860, 6.0, 15.0), (1130, 25.0, 40.0), (1250, 50.0, 8.0)];

/// The shipped plant with those hidden values.
pub fn hidden_plant(delay_us: u32, backlash_arcsec: f64, encoder_arcsec: f64) -> PlantConfig {
    let mut plant = plant();
    plant.drives.delay_us = Some(delay_us);
    plant.table.worm.backlash_arcsec = backlash_arcsec;
    plant.spindle.encoder_error_arcsec = encoder_arcsec;
    plant
}
