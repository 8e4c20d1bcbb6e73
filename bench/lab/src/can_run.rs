//! `hob can run`: the master in lockstep with the drives over SocketCAN (commissioning, and
//! the vcan tests against `hob-sim`).

use hob_can_transport::SystemClock;
use hob_control::fault::Axis;
use hob_control::program::CycleProgram;
use hob_control::{Command, ControlParams, Controller, HomeAxes, State};
use hob_master::boot;
use hob_process_image::plan::BusPlan;
use hob_setup::config::Problems;
use hob_setup::config::machine::MachineConfig;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

/// What `hob can run` does.
pub struct RunArgs<'a> {
    pub iface: &'a str,
    pub program: Option<&'a Path>,
    pub jogs: &'a [(Axis, f64)],
    pub single: bool,
    pub max_s: f64,
}

/// `hob can run`: the master over SocketCAN in lockstep with the drives: boot, power-up,
/// jogs, then the program; prints what happened. `Err((exit code, text))`.
pub fn run(machine: &MachineConfig, a: &RunArgs<'_>) -> Result<String, (u8, String)> {
    let program = match a.program {
        Some(p) => {
            let (job, src) = hob_store::files::read_program(p).map_err(|e| (2, e.to_string()))?;
            let mut problems = Problems::new();
            match CycleProgram::build(&job, machine, &mut problems) {
                Some(c) => Some(c),
                None => {
                    return Err((
                        2,
                        problems
                            .into_result(p, &src)
                            .err()
                            .map_or_else(|| "refused".into(), |e| e.to_string()),
                    ));
                }
            }
        }
        None => None,
    };
    let mut bus = hob_cli::can::open(a.iface).map_err(|e| (1, e))?;
    let plan = BusPlan::from_machine(machine);
    let booted = boot(
        &plan,
        &mut bus,
        &mut SystemClock::new(),
        Duration::from_millis(500),
    )
    .map_err(|e| (1, format!("boot: {e}")))?;
    let infos = &booted.nodes;
    let mut o = String::new();
    for i in infos {
        let _ = writeln!(
            o,
            "node {}: \"{}\" 0x{:08X} operational{}",
            i.node,
            i.name,
            i.device_type,
            if i.csp() { ", CSP" } else { "" }
        );
    }
    let controller = Controller::new(ControlParams::from_machine(machine));
    let mut r = Runner {
        m: hob_virtual_machine::runner::MasterLoop::new(controller, booted.cyclic, bus),
        states: Vec::new(),
        cycles: 0,
        max_cycles: (a.max_s / plan.cycle_s) as u64,
        emcy: Vec::new(),
    };
    while r.step() != State::Idle {
        if r.out_of_time() || r.m.controller.status().state == State::Faulted {
            return Err((
                3,
                format!("{o}power-up did not finish: {:?}", r.m.controller.status().fault),
            ));
        }
    }
    r.settle();
    let _ = writeln!(o, "power-up done");
    // The drives count from wherever the machine stood: X and Y reference by their own
    // homing (CiA 402 mode 6, over the bus) before anything but a slow jog.
    r.m.controller
        .command(Command::Home { axes: HomeAxes::Both })
        .map_err(|e| (2, format!("{o}home refused: {e:?}")))?;
    while r.step() != State::Idle {
        if r.out_of_time() || r.m.controller.status().state == State::Faulted {
            return Err((
                3,
                format!(
                    "{o}referencing did not finish: {:?}",
                    r.m.controller.status().fault
                ),
            ));
        }
    }
    r.settle();
    let s = r.m.controller.status();
    let _ = writeln!(o, "referenced: X {:.3} mm, Y {:.3} mm", s.x_mm, s.y_mm);
    for &(axis, distance) in a.jogs {
        let before = r.m.controller.status();
        r.m.controller
            .command(Command::Jog { axis, distance })
            .map_err(|e| (2, format!("{o}jog refused: {e:?}")))?;
        while r.step() != State::Idle && !r.out_of_time() {}
        r.settle();
        let after = r.m.controller.status();
        let (b, c) = match axis {
            Axis::X => (before.x_mm, after.x_mm),
            Axis::Y => (before.y_mm, after.y_mm),
            Axis::B => (before.table_deg, after.table_deg),
        };
        let _ = writeln!(
            o,
            "jog {} {distance:+.3}: the drive reports {:+.4} ({b:.4} -> {c:.4})",
            axis.name(),
            c - b
        );
    }
    let mut result = Ok(());
    if let Some(p) = program {
        r.m.controller
            .load(p)
            .map_err(|e| (2, format!("{o}load refused: {e:?}")))?;
        r.m.controller
            .command(Command::Start { single: a.single })
            .map_err(|e| (2, format!("{o}start refused: {e:?}")))?;
        r.states.clear();
        loop {
            let s = r.step();
            if s == State::Idle || s == State::Faulted || r.out_of_time() {
                break;
            }
        }
        r.settle();
        let names: Vec<&str> = r.states.iter().map(|s| s.name()).collect();
        let _ = writeln!(o, "states: {}", names.join(" "));
        let status = r.m.controller.status();
        match status.fault {
            Some(f) => {
                let _ = writeln!(o, "fault: {f:?}");
                result = Err(3);
            }
            None if status.state == State::Idle => {
                let _ = writeln!(o, "cycle done");
            }
            None => {
                let _ = writeln!(o, "cycle not finished in {} s", a.max_s);
                result = Err(3);
            }
        }
    }
    let s = r.m.controller.status();
    let axes = [Axis::B, Axis::X, Axis::Y];
    let pick = |flags: [bool; 3], silent: bool| -> String {
        let names: Vec<&str> = axes
            .iter()
            .zip(flags)
            .zip(s.drives_silent)
            .filter(|((_, f), q)| *f && *q == silent)
            .map(|((a, _), _)| a.name())
            .collect();
        if names.is_empty() {
            "none".to_string()
        } else {
            names.join(" ")
        }
    };
    let _ = writeln!(
        o,
        "outputs: pc_ok {} spindle {} coolant {}; drives in operation enabled: {}; silent (state unknown, power removed by the open safety chain): {}",
        s.outputs.pc_ok_relay,
        s.outputs.spindle_run_forward || s.outputs.spindle_run_reverse,
        s.outputs.coolant_pump,
        pick(s.drives_enabled, false),
        pick([true; 3], true)
    );
    let cycles = r.cycles;
    for e in &r.emcy {
        let _ = writeln!(o, "{e}");
    }
    let _ = writeln!(o, "cycles: {cycles}");
    match result {
        Ok(()) => Ok(o),
        Err(code) => Err((code, o)),
    }
}

/// The lockstep loop of `hob can run`, with the states it passed.
struct Runner {
    m: hob_virtual_machine::runner::MasterLoop<hob_can_transport::SocketCan>,
    states: Vec<State>,
    cycles: u64,
    max_cycles: u64,
    emcy: Vec<String>,
}

impl Runner {
    fn step(&mut self) -> State {
        self.m.cycle();
        self.cycles += 1;
        // EMCYs are shown to the operator with the error code's meaning.
        let mut events = [None; hob_master::BUS_EVENTS];
        let n = self.m.cyclic.take_events(&mut events);
        for e in events[..n].iter().flatten() {
            if let hob_master::BusEvent::Emcy(e) = e {
                self.emcy
                    .push(format!("EMCY node {}: 0x{:04X} {}", e.node, e.code, e.text()));
            }
        }
        let s = self.m.controller.status().state;
        if self.states.last() != Some(&s) {
            self.states.push(s);
        }
        s
    }

    fn out_of_time(&self) -> bool {
        self.cycles > self.max_cycles
    }

    /// A few hundred cycles for the drives to follow the last commands.
    fn settle(&mut self) {
        for _ in 0..500 {
            self.step();
        }
    }
}
