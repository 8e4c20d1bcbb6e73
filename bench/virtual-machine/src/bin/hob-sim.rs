//! `hob-sim`: the virtual hobbing machine as its own process on a CAN interface.
//!
//! Emulates the three drives and the I/O coupler of `config/machine.toml` around the
//! physics of `config/plant.toml`, in lockstep with the master's SYNC. Faults are injected
//! from the command line (`--fault`, `--fault-in-cut`) or, with `--control`, one per line
//! on standard input: `drive-fault x`, `estop`, `chain-open`, `limit y min`, `no-lube`,
//! `obstruct y`, `vfd-fault`, `drop 0.2`, `delay 3`, `silent 2`, `garbage 4`, and `clear`
//! (every injected fault repaired).

use clap::Parser;
use hob_canopen::bus::CanBus;
use hob_canopen::frame::Frame;
use hob_control::program::CycleProgram;
use hob_plant::config::PlantConfig;
use hob_plant::plant::Start;
use hob_setup::config::Problems;
use hob_setup::planner;
use hob_virtual_machine::runner::{SYNC_SILENCE, serve_waiting};
use hob_virtual_machine::virtual_machine::{VirtualMachine, VmFault};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

#[derive(Debug, Parser)]
#[command(name = "hob-sim", about = "the virtual hobbing machine on a CAN bus")]
struct Args {
    /// SocketCAN interface, or `shm` for the shared-memory virtual CAN bus.
    #[arg(long, default_value = "vcan0")]
    iface: String,
    #[arg(long, default_value = "config/machine.toml")]
    machine: PathBuf,
    #[arg(long, default_value = "config/plant.toml")]
    plant: PathBuf,
    /// The program whose blank is on the table (cutting load, start position, hob gashes).
    #[arg(long)]
    program: Option<PathBuf>,
    /// Inject a fault at once. Repeatable.
    #[arg(long)]
    fault: Vec<String>,
    /// Inject a fault once the tool has been in the work for 2000 SYNCs.
    #[arg(long)]
    fault_in_cut: Option<String>,
    /// Read faults from standard input, one per line.
    #[arg(long)]
    control: bool,
    /// SCHED_FIFO priority (0: normal scheduling). Real drives answer every SYNC within
    /// microseconds; a simulator that the OS schedules late looks like lost TPDOs to a
    /// real-time master (`hob demo` runs it at 75, below `hob-rt`).
    #[arg(long, default_value_t = 0)]
    rt_priority: u32,
    /// Pin to this core. Without it the simulator keeps off the loop's core
    /// (`service.loop_core`) where there is another: real drives are separate hardware.
    #[arg(long)]
    core: Option<u32>,
    /// Exit after this many seconds without any frame (0: never).
    #[arg(long, default_value_t = 0.0)]
    idle_exit_s: f64,
    /// Run on the loop's core (`service.loop_core`), in place of `--core` and
    /// `--rt-priority`: waiting one SCHED_FIFO priority below the loop, so it runs while the
    /// loop sleeps, and reading and answering one above it, so the master cannot run
    /// between the simulator reading a SYNC and answering it, as it cannot interrupt real
    /// drives. Also set by the environment variable HOB_SIM_BESIDE_LOOP=1 (`hob demo`
    /// passes it on). For a machine whose CPUs stall (an emulated guest), where an answer
    /// from a simulator on a CPU of its own can come after the next SYNC. Never for timing
    /// measurements: an answer due when the loop wakes delays it.
    #[arg(long)]
    beside_loop: bool,
    /// Honest incremental encoders: every drive's counter (0x6064) starts at 0 at power-on
    /// and X and Y stand at a random position within their travel (from the plant's
    /// `simulation.seed`); the master must home X and Y (CiA 402 mode 6). The same as
    /// `simulation.drive_counters = "incremental"` in the plant file. Without either, the
    /// counters read the machine position as if referenced before.
    #[arg(long)]
    incremental: bool,
    /// With incremental counters, X and Y power up within MM of their home position (a
    /// short referencing: for runs on a slow clock, the emulated guest's fault cases). Also
    /// set by the environment variable HOB_SIM_NEAR_HOME_MM. Sets
    /// `simulation.power_on_near_home_mm`.
    #[arg(long, value_name = "MM")]
    power_on_near_home: Option<f64>,
    /// Write the machine's truth to FILE, one row per SYNC (`hob_logger::truth`): the
    /// drive's and the blank's true error against the gearbox law of `--program` (which
    /// it needs). Put beside the logger's recording as `truth.csv`, `hob log report`
    /// grades the cut by it.
    #[arg(long, value_name = "FILE", requires = "program")]
    truth: Option<PathBuf>,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hob-sim: {e}");
            ExitCode::from(2)
        }
    }
}

fn run(a: Args) -> Result<(), String> {
    let machine = hob_store::files::load_machine(&a.machine).map_err(|e| e.to_string())?;
    let mut plant = PlantConfig::load(&a.plant).map_err(|e| e.to_string())?;
    if a.incremental {
        plant.simulation.drive_counters = hob_plant::config::DriveCounters::Incremental;
    }
    let near_env = std::env::var("HOB_SIM_NEAR_HOME_MM")
        .ok()
        .filter(|v| !v.is_empty());
    let near = match (a.power_on_near_home, near_env) {
        (Some(mm), _) => Some(mm),
        (None, Some(v)) => Some(
            v.parse::<f64>()
                .map_err(|_| format!("HOB_SIM_NEAR_HOME_MM={v}: not a number of mm"))?,
        ),
        (None, None) => None,
    };
    if let Some(mm) = near {
        if !(mm.is_finite() && mm > 0.0) {
            return Err(format!(
                "--power-on-near-home {mm}: must be a distance above 0 mm"
            ));
        }
        plant.simulation.power_on_near_home_mm = Some(mm);
    }
    let mut start = Start {
        x_mm: 150.0,
        y_mm: 150.0,
        table_deg: 0.0,
    };
    let mut gashes = 10;
    let mut workpiece = None;
    // The gearbox law of the program (without its phase) and its gear, for the truth.
    let mut law = None;
    if let Some(p) = &a.program {
        let (job, src) = hob_store::files::read_program(p).map_err(|e| e.to_string())?;
        let mut problems = Problems::new();
        let cycle = CycleProgram::build(&job, &machine, &mut problems);
        let plan = planner::plan(&job, &machine, &mut problems);
        let (Some(cycle), Some(plan)) = (cycle, plan) else {
            return Err(problems
                .into_result(p, &src)
                .err()
                .map_or_else(|| "program refused".into(), |e| e.to_string()));
        };
        start = hob_plant::sim::start_for(&cycle);
        law = Some((
            cycle.ratio_signed,
            cycle.differential_signed_deg_per_mm,
            hob_logger::truth::Gear {
                teeth: plan.teeth,
                face_width_mm: job.workpiece.face_width_mm,
                pitch_radius_mm: cycle.pitch_diameter_mm / 2.0,
                normal_module_mm: cycle.normal_module_mm,
                starts: plan.starts,
            },
        ));
        gashes = job.tool.gashes.max(1) as u32;
        workpiece = Some(hob_plant::sim::workpiece_for(
            &cycle,
            &plan,
            job.workpiece.face_width_mm,
            job.tool.outside_diameter_mm,
        ));
    }
    let mut faults = a
        .fault
        .iter()
        .map(|f| VmFault::parse(f))
        .collect::<Result<Vec<_>, _>>()?;
    let in_cut = a.fault_in_cut.as_deref().map(VmFault::parse).transpose()?;
    let mut vm = VirtualMachine::new(&machine, &plant, start, gashes);
    if let Some(w) = workpiece {
        vm.plant.set_workpiece(w);
    }
    for f in faults.drain(..) {
        vm.inject(f);
    }
    let beside_loop = a.beside_loop || std::env::var("HOB_SIM_BESIDE_LOOP").is_ok_and(|v| v == "1");
    // Priorities to wait at and to answer at.
    let (core, rt_priority, answer_priority) = if beside_loop {
        // The validation keeps service.loop_priority within 1 ..= 98.
        let (below, above) = (
            machine.service.loop_priority.saturating_sub(1).max(1),
            machine.service.loop_priority + 1,
        );
        eprintln!(
            "hob-sim: beside the loop: core {}, waiting at SCHED_FIFO {below}, answering at {above}",
            machine.service.loop_core
        );
        (Some(machine.service.loop_core), below, Some(above))
    } else {
        (a.core, a.rt_priority, None)
    };
    if let Some(core) = core {
        let mut r = hob_rt_os::RtReport::default();
        hob_rt_os::pin(core, &mut r);
        for p in &r.problems {
            eprintln!("hob-sim: {p}");
        }
    } else {
        hob_rt_os::keep_off_core(machine.service.loop_core);
    }
    if rt_priority > 0 {
        let mut r = hob_rt_os::RtReport::default();
        if let Some(p) = answer_priority {
            // Once at start-up to report whether it may: the loop below sets it silently.
            hob_rt_os::set_fifo(p, &mut r);
        }
        hob_rt_os::set_fifo(rt_priority, &mut r);
        for p in &r.problems {
            eprintln!("hob-sim: {p}");
        }
    }
    let truth = match (&a.truth, law) {
        (Some(path), Some((ratio, differential, gear))) => {
            Some((truth_writer(path, gear)?, ratio, differential))
        }
        _ => None,
    };
    let mut truth_syncs = 0;
    let mut bus = hob_can_transport::shm::open_bus(&a.iface, "hob-sim-can")?;
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    if a.control {
        std::thread::spawn(move || {
            for line in std::io::stdin().lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
    }
    eprintln!(
        "hob-sim: nodes {:?} on {}",
        hob_process_image::plan::BusPlan::from_machine(&machine).nodes(),
        a.iface
    );
    let mut last_idle = Instant::now();
    let mut last_frame = Instant::now();
    let mut last_sync = (vm.syncs(), Instant::now());
    let mut out: Vec<Frame> = Vec::new();
    let mut batch: Vec<Frame> = Vec::new();
    let mut superseded = (0, Instant::now());
    let mut in_cut = in_cut;
    // SIGTERM or SIGINT ends the run cleanly: the shared-memory virtual CAN bus's endpoint
    // is removed as it goes (killed by the signal, it would leave its files behind).
    let stop = hob_rt_os::termination_flag();
    vm.power_on(&mut out);
    while !stop.load(std::sync::atomic::Ordering::Relaxed) {
        while let Ok(line) = rx.try_recv() {
            match VmFault::parse(&line) {
                Ok(f) => {
                    eprintln!("hob-sim: injecting {f:?}");
                    vm.inject(f);
                }
                Err(e) => eprintln!("hob-sim: {e}"),
            }
        }
        if let Some(f) = in_cut
            && vm.cutting_syncs() >= 2000
        {
            eprintln!("hob-sim: injecting {f:?} in the cut after {} SYNCs", vm.syncs());
            vm.inject(f);
            in_cut = None;
        }
        if let Some(p) = answer_priority {
            fifo(p);
        }
        let served = serve_waiting(&mut vm, bus.as_mut(), &mut batch, &mut out);
        if answer_priority.is_some() {
            fifo(rt_priority);
        }
        // The machine as it stood at the SYNC (the period's physics are still owed).
        if let Some((tx, ratio, differential)) = &truth
            && vm.syncs() != truth_syncs
        {
            truth_syncs = vm.syncs();
            let p = &vm.plant;
            let law_deg = ratio * p.spindle_deg() + differential * p.y_mm();
            let _ = tx.send(hob_logger::truth::TruthRow {
                sync_ns: hob_rt_os::now_ns(),
                table_drive_deg: p.table_drive_deg(),
                y_mm: p.y_mm(),
                drive_err_arcsec: (p.table_drive_deg() - law_deg) * 3600.0,
                blank_err_arcsec: (p.blank_deg() - law_deg) * 3600.0,
            });
        }
        // The answers are on the bus: now the period's physics.
        vm.settle();
        let busy = served.map_err(|e| e.to_string())? > 0;
        if busy {
            last_frame = Instant::now();
        }
        if vm.superseded_syncs() != superseded.0 && superseded.1.elapsed() > Duration::from_secs(5) {
            // Scheduled late: say so, at most every 5 s (the master sees the lost frames).
            eprintln!(
                "hob-sim: {} of {} SYNCs read late together with a later one: not answered",
                vm.superseded_syncs(),
                vm.syncs()
            );
            superseded = (vm.superseded_syncs(), Instant::now());
        }
        if vm.syncs() != last_sync.0 {
            last_sync = (vm.syncs(), Instant::now());
            last_idle = Instant::now();
        } else if last_sync.1.elapsed() > SYNC_SILENCE {
            vm.idle(last_idle.elapsed().as_secs_f64(), &mut out);
            last_idle = Instant::now();
        }
        for f in out.drain(..) {
            let _ = bus.send(&f);
        }
        if a.idle_exit_s > 0.0 && last_frame.elapsed().as_secs_f64() > a.idle_exit_s {
            eprintln!(
                "hob-sim: no frame for {} s, exiting after {} SYNCs ({} read late with a later one: not answered)",
                a.idle_exit_s,
                vm.syncs(),
                vm.superseded_syncs()
            );
            return Ok(());
        }
        if !busy {
            // Wakes when a frame arrives (SocketCAN), or polls again after 50 us.
            bus.wait_for_frame(Duration::from_millis(5));
        }
    }
    eprintln!("hob-sim: stopped after {} SYNCs", vm.syncs());
    Ok(())
}

/// The truth file's writer: a thread of its own (the simulator answers SYNCs), fed rows
/// over a channel, flushing at least every half second.
fn truth_writer(
    path: &std::path::Path,
    gear: hob_logger::truth::Gear,
) -> Result<std::sync::mpsc::Sender<hob_logger::truth::TruthRow>, String> {
    use std::io::Write as _;
    let file = std::fs::File::create(path).map_err(|e| format!("--truth {}: {e}", path.display()))?;
    let mut w = std::io::BufWriter::new(file);
    hob_logger::truth::write_head(&mut w, gear).map_err(|e| format!("--truth {}: {e}", path.display()))?;
    let (tx, rx) = std::sync::mpsc::channel::<hob_logger::truth::TruthRow>();
    let shown = path.display().to_string();
    std::thread::spawn(move || {
        let mut flushed = Instant::now();
        loop {
            let r = match rx.recv_timeout(Duration::from_millis(200)) {
                Ok(row) => writeln!(w, "{}", row.csv()),
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => Ok(()),
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break,
            };
            let r = r.and_then(|()| {
                if flushed.elapsed() > Duration::from_millis(500) {
                    flushed = Instant::now();
                    w.flush()
                } else {
                    Ok(())
                }
            });
            if let Err(e) = r {
                eprintln!("hob-sim: --truth {shown}: {e}; no more truth is written");
                return;
            }
        }
        let _ = w.flush();
    });
    Ok(tx)
}

/// Sets this thread's SCHED_FIFO priority (the start-up reported whether it may).
fn fifo(priority: u32) {
    let mut r = hob_rt_os::RtReport::default();
    hob_rt_os::set_fifo(priority, &mut r);
}
