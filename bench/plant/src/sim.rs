//! Core against plant, in one process, faster than real time.
//!
//! Each cycle k: the plant runs to SYNC k (at `k T` plus a random jitter), takes the
//! outputs of cycle k-1 and latches its feedback; the controller steps on that feedback.
//! The trace row of cycle k holds the plant's true positions at SYNC k.

use crate::config::PlantConfig;
use crate::plant::{Injection, Plant, Start, Workpiece};
use hob_control::egb::Coupling;
use hob_control::events::Event;
use hob_control::program::CycleProgram;
use hob_control::{
    AxisFeedback, Command, ControlParams, Controller, CycleInputs, CycleOutputs, HomeAxes,
    SpindleAngleSource, Status,
};
use hob_gearing::units::arcsec_to_um_at_radius;
use hob_setup::config::machine::MachineConfig;
use hob_setup::planner::Plan;
use serde::Serialize;

/// A trace row's state: the sequencer state's code in the contract between processes
/// (`hob_ipc::codec::State`), the controller's own type (the wire's vocabulary).
pub use hob_ipc::codec::State as RowState;
/// The trace format and per-pass statistics are the logger's (`hob log export|report`).
pub use hob_logger::trace::{PassSummary, SummaryBuilder, TRACE_HEADER, TraceRow};

/// Options of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimOptions {
    pub cross_coupling: bool,
    pub angle_source: SpindleAngleSource,
    pub single: bool,
    /// Give up after this much simulated time.
    pub max_time_s: f64,
    /// For comparisons only: synchronism windows so wide that they never hold the feed or
    /// fault the cut (to measure what a configuration without the predictor would cut).
    pub windows_off: bool,
    /// The ISO 1328-1 grade the predicted gear of each pass is judged against.
    pub grade: u8,
    /// The pitch compensation the gearbox applies (issue 34); none: off.
    pub pitch_compensation: Option<hob_control::pitch_comp::PitchCompensation>,
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            cross_coupling: true,
            angle_source: SpindleAngleSource::Predicted,
            single: false,
            max_time_s: 7200.0,
            windows_off: false,
            grade: 5,
            pitch_compensation: None,
        }
    }
}

/// `summary.json`.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Summary {
    pub cross_coupling: bool,
    pub predictor: bool,
    pub pitch_radius_mm: f64,
    /// ISO 1328-1 grade 5 single pitch tolerance of this gear.
    pub grade5_single_pitch_um: f64,
    /// A quarter of it: the controller's bound.
    pub bound_um: f64,
    pub passes: Vec<PassSummary>,
    pub max_sync_err_um: f64,
    pub max_sync_err_arcsec: f64,
    pub total_time_s: f64,
    pub completed: bool,
    pub fault: Option<String>,
    /// Frames that missed their SYNC: position TPDOs, target RPDOs
    /// (`simulation.tpdo_late_rate`, `rpdo_late_rate`).
    pub late_frames: [u64; 2],
    /// A disk cutter's simulated profile error: its largest side deflection in each pass,
    /// `[pass, um]` (tooth-by-tooth with `[tool.disk]` and `workpiece.material`).
    pub cutter_profile_error_um: Vec<[f64; 2]>,
    /// The gearbox's tooth phase of the blank (deg; none before its first engagement): a
    /// pitch compensation measured on this gear cuts the next one at it.
    pub tooth_phase_deg: Option<f64>,
}

/// When the drives act on each SYNC against its nominal instant. The SYNC itself arrives
/// with uniform jitter of `simulation.sync_jitter_us`, or late by a draw from
/// `simulation.sync_late_quantiles_us` (a measured wake-up histogram). Drives without a
/// SYNC PLL latch their positions and restart their interpolation at each arrival. Drives
/// with one (`simulation.drive_clock_slew_percent`) run their cycle on their own clock and
/// steer its phase toward the arrivals by at most the slew per period, as a Kollmorgen AKD
/// does (its 16 kHz interrupt lengthened or shortened by `FBUS.COMPTIME`, 150 ns of 62.5 us),
/// so they act at a smoothed instant and the jitter reaches the axes only through that
/// steering. Deterministic for `simulation.seed`; shared by the in-process simulation and
/// the virtual machine on the bus.
#[derive(Debug, Clone)]
pub struct SyncTiming {
    jitter_s: f64,
    /// `simulation.sync_late_quantiles_us` (empty: uniform `jitter_s`).
    late_quantiles_us: Vec<[f64; 2]>,
    rng: u64,
    /// The most the drives' clock phase moves per period, s (None: no PLL).
    pll_step_s: Option<f64>,
    /// The drives' cycle against the nominal SYNC instant, s.
    drive_phase_s: f64,
}

impl SyncTiming {
    pub fn new(plant_cfg: &PlantConfig, period_s: f64) -> Self {
        let s = &plant_cfg.simulation;
        Self {
            jitter_s: s.sync_jitter_us * 1e-6,
            late_quantiles_us: s.sync_late_quantiles_us.clone(),
            rng: s.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
            pll_step_s: s.drive_clock_slew_percent.map(|pc| pc * 0.01 * period_s),
            drive_phase_s: 0.0,
        }
    }

    /// The next SYNC's arrival against its nominal instant, s.
    pub fn arrival(&mut self) -> f64 {
        let u = crate::rng::uniform(&mut self.rng);
        if self.late_quantiles_us.is_empty() {
            (2.0 * u - 1.0) * self.jitter_s
        } else {
            crate::config::quantile_value(&self.late_quantiles_us, u) * 1e-6
        }
    }

    /// The next SYNC: the instant the drives latch their positions and take their targets,
    /// against the nominal instant, s.
    pub fn draw(&mut self) -> f64 {
        let arrival = self.arrival();
        match self.pll_step_s {
            None => arrival,
            Some(step) => {
                // The drive's cycle ends at its own clock's instant; the SYNC it then sees
                // pulls the next one toward the arrival, by at most the slew.
                let acted = self.drive_phase_s;
                self.drive_phase_s += (arrival - acted).clamp(-step, step);
                acted
            }
        }
    }
}

/// Frames that miss their SYNC (`simulation.tpdo_late_rate`, `rpdo_late_rate`), drawn
/// per drive and cycle: a late position TPDO leaves the master's image of that drive as it
/// was, not fresh (the master holds a frame that comes a SYNC late, `hob_process_image`); a
/// late target RPDO leaves the drive with the target it already had. Deterministic for
/// `simulation.seed`, independent of the SYNC timing's draws.
#[derive(Debug, Clone)]
pub struct FrameTiming {
    tpdo_late_rate: f64,
    rpdo_late_rate: f64,
    rng: u64,
    /// The targets each drive (B, X, Y) has taken.
    held_targets: Option<[i32; 3]>,
    /// What the master last received.
    last_inputs: Option<CycleInputs>,
    /// Late TPDOs and RPDOs so far.
    pub late: [u64; 2],
}

impl FrameTiming {
    pub fn new(plant_cfg: &PlantConfig) -> Self {
        let s = &plant_cfg.simulation;
        Self {
            tpdo_late_rate: s.tpdo_late_rate,
            rpdo_late_rate: s.rpdo_late_rate,
            rng: s.seed.wrapping_mul(0xD1B5_4A32_D192_ED03) | 1,
            held_targets: None,
            last_inputs: None,
            late: [0; 2],
        }
    }

    fn late(&mut self, rate: f64) -> bool {
        rate > 0.0 && crate::rng::uniform(&mut self.rng) < rate
    }

    /// The outputs as the drives take them at this SYNC.
    pub fn at_drives(&mut self, mut o: CycleOutputs) -> CycleOutputs {
        let mut targets = [o.table_target_counts, o.x_target_counts, o.y_target_counts];
        if let Some(held) = self.held_targets {
            for (t, h) in targets.iter_mut().zip(held) {
                if self.late(self.rpdo_late_rate) {
                    *t = h;
                    self.late[1] += 1;
                }
            }
        }
        self.held_targets = Some(targets);
        [o.table_target_counts, o.x_target_counts, o.y_target_counts] = targets;
        o
    }

    /// The drives' answers to this SYNC as the master has them.
    pub fn at_master(&mut self, mut i: CycleInputs) -> CycleInputs {
        if let Some(last) = self.last_inputs {
            if self.late(self.tpdo_late_rate) {
                // B's TPDO carries the spindle encoder.
                i.spindle_counts = last.spindle_counts;
                i.table = AxisFeedback {
                    fresh: false,
                    ..last.table
                };
                self.late[0] += 1;
            }
            if self.late(self.tpdo_late_rate) {
                i.x = AxisFeedback {
                    fresh: false,
                    ..last.x
                };
                self.late[0] += 1;
            }
            if self.late(self.tpdo_late_rate) {
                i.y = AxisFeedback {
                    fresh: false,
                    ..last.y
                };
                self.late[0] += 1;
            }
        }
        self.last_inputs = Some(i);
        i
    }
}

/// A closed-loop run: controller, plant, clock.
#[derive(Debug)]
pub struct Simulation {
    pub controller: Controller,
    pub plant: Plant,
    period_s: f64,
    timing: SyncTiming,
    frames: FrameTiming,
    cycle: u64,
    outputs: CycleOutputs,
    pub events: Vec<Event>,
    /// The disk cutter's largest side deflection in each pass, `[pass, um]`.
    pub cutter_peaks_um: Vec<[f64; 2]>,
}

impl Simulation {
    /// A machine at rest at `start`, powered up (the controller's init runs in `run`).
    pub fn new(machine: &MachineConfig, plant_cfg: &PlantConfig, start: Start, gashes: u32) -> Self {
        let params = ControlParams::from_machine(machine);
        Self {
            controller: Controller::new(params),
            plant: Plant::new(plant_cfg, machine, start, gashes),
            period_s: params.period_s,
            timing: SyncTiming::new(plant_cfg, params.period_s),
            frames: FrameTiming::new(plant_cfg),
            cycle: 0,
            outputs: CycleOutputs::default(),
            events: Vec::new(),
            cutter_peaks_um: Vec::new(),
        }
    }

    /// Frames late so far: position TPDOs, target RPDOs (`simulation.*_late_rate`).
    pub fn late_frames(&self) -> [u64; 2] {
        self.frames.late
    }

    /// A machine at rest with the program's blank on the table (start position, gashes,
    /// workpiece geometry).
    pub fn for_program(
        machine: &MachineConfig,
        plant_cfg: &PlantConfig,
        program: &CycleProgram,
        plan: &Plan,
        job: &hob_setup::job::Program,
    ) -> Self {
        let mut sim = Self::new(
            machine,
            plant_cfg,
            start_for(program),
            job.tool.gashes.max(1) as u32,
        );
        sim.plant.set_workpiece(workpiece_for(
            program,
            plan,
            job.workpiece.face_width_mm,
            job.tool.outside_diameter_mm,
        ));
        if let Some(c) = disk_cutter_of(job) {
            sim.plant.set_disk_cutter(c);
        }
        sim
    }

    /// One cycle; returns the trace row of this SYNC.
    pub fn step(&mut self) -> TraceRow {
        self.step_with(&mut |c, i| c.step(i))
    }

    /// One cycle with the controller's step called through `step` (benchmarks time it or
    /// count its instructions per sequencer state); returns the trace row of this SYNC.
    pub fn step_with(
        &mut self,
        step: &mut dyn FnMut(&mut Controller, &CycleInputs) -> CycleOutputs,
    ) -> TraceRow {
        let t_sync = self.cycle as f64 * self.period_s;
        let latch = t_sync + self.timing.draw();
        self.plant.advance_to(latch.max(self.plant.time_s()));
        self.plant.apply(&self.frames.at_drives(self.outputs));
        let inputs: CycleInputs = self.frames.at_master(self.plant.latch());
        let row = self.row(t_sync);
        if let Some(peak) = self.plant.take_cutter_peak_um()
            && row.pass > 0
        {
            let pass = f64::from(row.pass);
            match self.cutter_peaks_um.last_mut() {
                Some(last) if last[0] == pass => last[1] = last[1].max(peak),
                _ => self.cutter_peaks_um.push([pass, peak]),
            }
        }
        self.outputs = step(&mut self.controller, &inputs);
        while let Some(e) = self.controller.events().pop() {
            self.events.push(e);
        }
        self.cycle += 1;
        row
    }

    fn row(&self, t_s: f64) -> TraceRow {
        let s: Status = self.controller.status();
        let g = self.controller.gearbox();
        // The gearbox law for the true spindle angle and Y: where the table should be.
        let law_deg = match (g.coupling(), g.phase_target_deg()) {
            (Coupling::Synchronised, Some(target)) => Some(
                g.params()
                    .coupled_deg(self.plant.spindle_deg(), self.plant.y_mm())
                    + target,
            ),
            _ => None,
        };
        // The drive's motion against what the controller meant: the law plus the pitch
        // compensation's offset (0 without one), which is deliberate, not the controller's
        // error. The blank's error stays against the law: the gear is what it is.
        let compensation_deg = g.status().compensation_deg;
        let sync_err_arcsec =
            law_deg.map(|law| (self.plant.table_drive_deg() - law - compensation_deg) * 3600.0);
        let blank_err_arcsec = law_deg.map(|law| (self.plant.blank_deg() - law) * 3600.0);
        TraceRow {
            t_s,
            state: s.state,
            hold: s.hold,
            pass: s.pass,
            spindle_deg: self.plant.spindle_deg(),
            // The table as its drive turned it (the truth at the blank is blank_err_arcsec).
            table_deg: self.plant.table_drive_deg(),
            table_cmd_deg: s.table_cmd_deg,
            x_mm: self.plant.x_mm(),
            x_cmd_mm: s.x_cmd_mm,
            y_mm: self.plant.y_mm(),
            y_cmd_mm: s.y_cmd_mm,
            sync_err_arcsec,
            work_twist_arcsec: self.plant.work_twist_arcsec(),
            blank_err_arcsec,
            feed_override_percent: Some(s.feed_override_percent),
            spindle_override_percent: Some(s.spindle_override_percent),
            pitch_compensation: Some(s.pitch_compensation),
        }
    }

    /// Runs until the machine is ready to cut (or `max_s` passes): power-up, then X and
    /// Y referenced by their drives' homing, as an operator does after power-on.
    pub fn power_up(&mut self, max_s: f64, sink: &mut dyn FnMut(&TraceRow)) -> bool {
        self.power_up_with(max_s, sink, &mut |c, i| c.step(i))
    }

    /// [`Self::power_up`] through a step hook (see [`Self::step_with`]).
    pub fn power_up_with(
        &mut self,
        max_s: f64,
        sink: &mut dyn FnMut(&TraceRow),
        step: &mut dyn FnMut(&mut Controller, &CycleInputs) -> CycleOutputs,
    ) -> bool {
        let end = self.cycle + (max_s / self.period_s) as u64;
        let mut homing_asked = false;
        while self.cycle < end {
            let row = self.step_with(step);
            sink(&row);
            if row.state == RowState::Idle {
                let s = self.controller.status();
                if s.referenced == [true, true] {
                    return true;
                }
                if homing_asked || self.command(Command::Home { axes: HomeAxes::Both }).is_err() {
                    return false;
                }
                homing_asked = true;
            } else if row.state == RowState::Faulted {
                return false;
            }
        }
        false
    }

    /// Runs cycles until `done(row)` or `max_s`; returns whether `done` was reached.
    pub fn run_until(
        &mut self,
        max_s: f64,
        sink: &mut dyn FnMut(&TraceRow),
        done: &mut dyn FnMut(&TraceRow, &[Event]) -> bool,
    ) -> bool {
        self.run_until_with(max_s, sink, done, &mut |c, i| c.step(i))
    }

    /// [`Self::run_until`] through a step hook (see [`Self::step_with`]).
    pub fn run_until_with(
        &mut self,
        max_s: f64,
        sink: &mut dyn FnMut(&TraceRow),
        done: &mut dyn FnMut(&TraceRow, &[Event]) -> bool,
        step: &mut dyn FnMut(&mut Controller, &CycleInputs) -> CycleOutputs,
    ) -> bool {
        let end = self.cycle + (max_s / self.period_s) as u64;
        while self.cycle < end {
            let row = self.step_with(step);
            sink(&row);
            if done(&row, &self.events) {
                return true;
            }
        }
        false
    }

    /// The outputs of the last cycle (to be applied at the next SYNC).
    pub fn last_outputs(&self) -> CycleOutputs {
        self.outputs
    }

    pub fn command(&mut self, c: Command) -> Result<(), hob_control::fault::Refusal> {
        self.controller.command(c)
    }

    pub fn inject(&mut self, i: Injection) {
        self.plant.inject(i);
    }

    pub fn time_s(&self) -> f64 {
        self.cycle as f64 * self.period_s
    }
}

/// Where the plant starts for a program: X beyond the safe position, Y above the start.
pub fn start_for(program: &CycleProgram) -> Start {
    let first = program.passes()[0];
    Start {
        x_mm: program.x_safe_mm + 10.0,
        y_mm: first.y_start_mm + 5.0,
        table_deg: 0.0,
    }
}

/// What the plant must know of the job.
pub fn workpiece_for(
    program: &CycleProgram,
    plan: &Plan,
    face_width_mm: f64,
    tool_diameter_mm: f64,
) -> Workpiece {
    Workpiece {
        x_surface_mm: program.x_surface_mm,
        face_bottom_mm: program.face_bottom_mm,
        face_top_mm: program.face_bottom_mm + face_width_mm,
        tool_diameter_mm,
        pitch_radius_mm: plan.pitch_diameter_mm / 2.0,
    }
}

/// A tooth-by-tooth program's disk cutter with what its dynamics need (`[tool.disk]` with
/// `mass_kg`, `workpiece.material`); None otherwise.
pub fn disk_cutter_of(job: &hob_setup::job::Program) -> Option<crate::cutter::DiskCutter> {
    let t = &job.tool;
    let disk = t
        .disk
        .as_ref()
        .filter(|_| t.kind == hob_setup::job::ToolKind::Disk)?;
    let m = job.workpiece.material.as_ref()?;
    let teeth = u32::try_from(t.gashes).ok()?;
    let link = hob_cutters::dynamics::CutterBody {
        width_mm: t.length_mm,
        outside_diameter_mm: t.outside_diameter_mm,
        mass_kg: disk.mass_kg?,
        youngs_modulus_mpa: disk.youngs_modulus_mpa,
        log_decrement: disk.log_decrement,
        teeth,
    }
    .link()
    .ok()?;
    Some(crate::cutter::DiskCutter {
        link,
        material: hob_cutters::dynamics::Material {
            kc11_n_mm2: m.kc11_n_mm2,
            mc: m.mc,
        },
        pressure_angle_deg: t.pressure_angle_deg,
        teeth,
        outside_diameter_mm: t.outside_diameter_mm,
    })
}

/// Per-pass statistics of a plan's gear, with the gear each pass leaves predicted at the
/// ISO 1328-1 grade `grade`.
pub fn summary_builder(plan: &Plan, grade: u8) -> SummaryBuilder {
    SummaryBuilder::for_gear(plan.pitch_diameter_mm / 2.0, plan.normal_module_mm).predicting(
        plan.teeth,
        plan.starts,
        plan.face_width_mm,
        grade,
    )
}

/// The run's `summary.json` from the per-pass statistics of its trace.
pub fn finish_summary(
    builder: SummaryBuilder,
    plan_pitch_radius_mm: f64,
    options: &SimOptions,
    total_time_s: f64,
    completed: bool,
    fault: Option<String>,
) -> Summary {
    let r = plan_pitch_radius_mm;
    let (passes, tol) = builder.passes();
    let max_arcsec = passes.iter().map(|p| p.sync_err_max_arcsec).fold(0.0, f64::max);
    Summary {
        cross_coupling: options.cross_coupling,
        predictor: options.angle_source == SpindleAngleSource::Predicted,
        pitch_radius_mm: r,
        grade5_single_pitch_um: tol,
        bound_um: tol / 4.0,
        max_sync_err_arcsec: max_arcsec,
        max_sync_err_um: arcsec_to_um_at_radius(max_arcsec, r),
        passes,
        total_time_s,
        completed,
        fault,
        late_frames: [0; 2],
        cutter_profile_error_um: Vec::new(),
        tooth_phase_deg: None,
    }
}

/// Runs a whole program: power-up, load, start, until done or a fault; every row goes to
/// `sink`. Returns the summary.
pub fn run_program(
    machine_in: &MachineConfig,
    plant_cfg: &PlantConfig,
    program: &CycleProgram,
    plan: &Plan,
    job: &hob_setup::job::Program,
    options: &SimOptions,
    sink: &mut dyn FnMut(&TraceRow),
) -> Result<Summary, String> {
    let mut machine = machine_in.clone();
    if options.windows_off {
        machine.gearbox.fine_window_arcsec = 1e9;
        machine.gearbox.coarse_window_arcsec = 2e9;
    }
    let machine = &machine;
    let mut sim = Simulation::for_program(machine, plant_cfg, program, plan, job);
    sim.controller.set_angle_source(options.angle_source);
    let mut builder = summary_builder(plan, options.grade);
    let period = sim.period_s;
    let mut both = |row: &TraceRow| {
        builder.add(row, period);
        sink(row);
    };
    if !sim.power_up(180.0, &mut both) {
        let s = sim.controller.status();
        return Err(format!(
            "the machine was not powered up and referenced within 180 s (state {}, referenced X {} Y {}, fault {:?})",
            s.state.name(),
            s.referenced[0],
            s.referenced[1],
            s.fault
        ));
    }
    sim.controller
        .load(*program)
        .map_err(|r| format!("program refused: {r:?}"))?;
    sim.controller.set_cross_coupling(options.cross_coupling);
    if let Some(c) = options.pitch_compensation {
        if !sim.controller.load_pitch_compensation(Some(c)) {
            return Err("the pitch compensation was refused: the gearbox is coupled".to_string());
        }
        sim.command(Command::PitchCompensation { on: true })
            .map_err(|r| format!("the pitch compensation was refused: {r:?}"))?;
    }
    sim.command(Command::Start {
        single: options.single,
    })
    .map_err(|r| format!("start refused: {r:?}"))?;
    let completed = sim.run_until(options.max_time_s, &mut both, &mut |row, _| {
        matches!(row.state, RowState::Idle | RowState::Faulted)
    });
    let fault = sim.controller.status().fault.map(|f| format!("{f:?}"));
    let completed = completed && fault.is_none();
    let total = sim.time_s();
    Ok(Summary {
        tooth_phase_deg: sim.controller.gearbox().recorded_phase_deg(),
        late_frames: sim.late_frames(),
        cutter_profile_error_um: sim.cutter_peaks_um.clone(),
        ..finish_summary(
            builder,
            plan.pitch_diameter_mm / 2.0,
            options,
            total,
            completed,
            fault,
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn plant(jitter_us: f64, measured: bool, slew_percent: Option<f64>) -> PlantConfig {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/plant.toml");
        let mut p: PlantConfig = toml::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        p.simulation.sync_jitter_us = jitter_us;
        p.simulation.sync_late_quantiles_us = if measured {
            crate::config::MEASURED_VM_SYNC_LATE_US.to_vec()
        } else {
            Vec::new()
        };
        p.simulation.drive_clock_slew_percent = slew_percent;
        p
    }

    fn spread_us(draws: &[f64]) -> (f64, f64) {
        let mean = draws.iter().sum::<f64>() / draws.len() as f64;
        let var = draws.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / draws.len() as f64;
        (mean * 1e6, var.sqrt() * 1e6)
    }

    #[test]
    fn without_a_pll_the_drives_act_at_each_arrival() {
        let p = plant(20.0, false, None);
        let (mut a, mut b) = (SyncTiming::new(&p, 1e-3), SyncTiming::new(&p, 1e-3));
        for _ in 0..1000 {
            assert_eq!(a.draw(), b.arrival());
        }
        let draws: Vec<f64> = (0..20_000).map(|_| a.draw()).collect();
        let (mean, sd) = spread_us(&draws);
        // Uniform +-20 us: mean 0, standard deviation 20 / sqrt(3) = 11.5 us.
        assert!(mean.abs() < 0.5 && (sd - 11.55).abs() < 0.3, "{mean} {sd}");
    }

    #[test]
    fn a_pll_smooths_the_jitter_and_settles_on_the_typical_lateness() {
        // AKD: 0.24 % of 1 ms = 2.4 us per period at most.
        let mut t = SyncTiming::new(&plant(20.0, false, Some(0.24)), 1e-3);
        let draws: Vec<f64> = (0..20_000).map(|_| t.draw()).collect();
        for w in draws.windows(2) {
            assert!((w[1] - w[0]).abs() <= 2.4e-6 + 1e-12, "slew exceeded: {w:?}");
        }
        let (mean, sd) = spread_us(&draws);
        // Less than half the arrivals' 11.5 us (a walk of +-2.4 us steps around them).
        assert!(mean.abs() < 1.0 && sd < 5.8, "uniform: {mean} {sd}");
        // The VM's measured lateness (p50 15 us, a long tail): the drives settle near the
        // median, where as many SYNCs come earlier as later, and the tail moves them little.
        let mut t = SyncTiming::new(&plant(20.0, true, Some(0.24)), 1e-3);
        let draws: Vec<f64> = (0..20_000).map(|_| t.draw()).skip(100).collect();
        let (mean, sd) = spread_us(&draws);
        assert!((mean - 15.0).abs() < 3.0 && sd < 5.8, "measured: {mean} {sd}");
        let mut raw = SyncTiming::new(&plant(20.0, true, None), 1e-3);
        let arrivals: Vec<f64> = (0..20_000).map(|_| raw.draw()).collect();
        assert!(spread_us(&arrivals).1 > 3.0 * sd);
    }

    #[test]
    fn late_frames_hold_what_was_there_at_their_rate() {
        let mut p = plant(20.0, false, Some(0.24));
        p.simulation.tpdo_late_rate = 0.01;
        p.simulation.rpdo_late_rate = 0.02;
        let mut f = FrameTiming::new(&p);
        let (mut held_targets, mut stale) = (0, 0);
        let mut received = (0, 0);
        for k in 0..20_000i32 {
            let o = CycleOutputs {
                table_target_counts: k,
                x_target_counts: 2 * k,
                y_target_counts: -k,
                ..CycleOutputs::default()
            };
            let a = f.at_drives(o);
            // A late target leaves the drive with the one it took a cycle before.
            for (got, sent) in [
                (a.table_target_counts, k),
                (a.x_target_counts, 2 * k),
                (a.y_target_counts, -k),
            ] {
                if got != sent {
                    held_targets += 1;
                    assert!(got < sent.max(-sent) && k > 0, "{got} {sent}");
                }
            }
            let mut i = CycleInputs {
                spindle_counts: 3 * k,
                ..CycleInputs::default()
            };
            i.table.position_counts = k;
            i.table.fresh = true;
            i.x.fresh = true;
            i.y.fresh = true;
            let m = f.at_master(i);
            if !m.table.fresh {
                stale += 1;
                // B's TPDO carries the spindle: both are the last received.
                assert_eq!((m.table.position_counts, m.spindle_counts), received);
            } else {
                received = (k, 3 * k);
                assert_eq!((m.table.position_counts, m.spindle_counts), received);
            }
            stale += u64::from(!m.x.fresh) + u64::from(!m.y.fresh);
        }
        assert_eq!(f.late, [stale, held_targets]);
        // 3 drives x 20 000 cycles at 1 % and 2 %: 600 and 1200, binomial sd 24 and 34.
        assert!((500..700).contains(&stale), "{stale}");
        assert!((1050..1350).contains(&held_targets), "{held_targets}");
        // None at the shipped rates.
        let mut f = FrameTiming::new(&plant(20.0, false, Some(0.24)));
        for _ in 0..1000 {
            f.at_drives(CycleOutputs::default());
            f.at_master(CycleInputs::default());
        }
        assert_eq!(f.late, [0, 0]);
    }
}
