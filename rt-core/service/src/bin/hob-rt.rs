//! `hob-rt`: the real-time service. Start-up (may allocate, block and fail): machine
//! configuration, CAN bus boot, shared-memory ports, command and stats threads; then
//! `mlockall`, stack pre-fault, core pinning, SCHED_FIFO, and the 1 kHz loop.
//!
//! Exit status: 0 stopped on request; 2 refused configuration or arguments; 3 real-time
//! set-up incomplete with `--require-rt`; 1 anything else (bus, shared memory).

use hob_can_transport::shm::open_bus;
use hob_control::{ControlParams, Controller};
use hob_ipc::StatsSample;
use hob_process_image::master::boot;
use hob_process_image::plan::BusPlan;
use hob_rt_os as rt;
use hob_rt_os::RtReport;
use hob_rt_os::alloc_guard::{self, CountingAllocator};
use hob_service::commands;
use hob_service::cycle::{LoopCounters, RtLoop};
use hob_service::stats::{self, StatsTiming};
use hob_setup::config::machine::MachineConfig;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

const USAGE: &str =
    "usage: hob-rt [--machine FILE] [--iface IFACE|shm] [--require-rt] [--cycles N] [--hgrm DIR]

  --machine FILE  machine configuration [default: config/machine.toml, then /etc/hob/machine.toml]
  --iface IFACE   CAN interface (can0, vcan0) or `shm` for the shared-memory virtual bus
                  [default: can.interface of the configuration]
  --require-rt    refuse to run without SCHED_FIFO, the pinned core and locked memory
  --cycles N      stop after N cycles (benchmarks)
  --hgrm DIR      at exit, write the loop's histograms to DIR: wake.hgrm, compute.hgrm
                  (percentile text, us), wake.hist, compute.hist (every value, ns) and
                  hob-rt.json (cycles, overruns, real-time set-up)

Environment: HOB_INSTANCE names the shared-memory bus instance (default main).";

#[derive(Debug, Default)]
struct Args {
    machine: Option<PathBuf>,
    iface: Option<String>,
    require_rt: bool,
    cycles: Option<u64>,
    hgrm: Option<PathBuf>,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args::default();
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = |name: &str| it.next().ok_or_else(|| format!("{name} needs a value"));
        match arg.as_str() {
            "--machine" => a.machine = Some(value("--machine")?.into()),
            "--iface" => a.iface = Some(value("--iface")?),
            "--require-rt" => a.require_rt = true,
            "--cycles" => {
                let v = value("--cycles")?;
                a.cycles = Some(v.parse().map_err(|_| format!("--cycles: not a number: {v}"))?);
            }
            "--hgrm" => a.hgrm = Some(value("--hgrm")?.into()),
            "-h" | "--help" => return Err(String::new()),
            other => return Err(format!("unknown argument {other}")),
        }
    }
    Ok(a)
}

fn machine_path(a: &Args) -> PathBuf {
    a.machine.clone().unwrap_or_else(|| {
        ["config/machine.toml", "/etc/hob/machine.toml"]
            .iter()
            .map(PathBuf::from)
            .find(|p| p.exists())
            .unwrap_or_else(|| PathBuf::from("config/machine.toml"))
    })
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) if e.is_empty() => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("hob-rt: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let path = machine_path(&args);
    let machine = match MachineConfig::load(&path) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("hob-rt: refused: {e}");
            return ExitCode::from(2);
        }
    };
    match run(&args, machine) {
        Ok(()) => ExitCode::SUCCESS,
        Err((code, e)) => {
            eprintln!("hob-rt: {e}");
            ExitCode::from(code)
        }
    }
}

fn run(args: &Args, machine: MachineConfig) -> Result<(), (u8, String)> {
    let stop = rt::termination_flag();
    let iface = args
        .iface
        .clone()
        .unwrap_or_else(|| machine.can.interface.clone());
    let mut bus = open_bus(&iface, "hob-rt-can").map_err(|e| (1, e))?;
    let plan = BusPlan::from_machine(&machine);
    let booted = boot(&plan, &mut *bus, Duration::from_millis(500))
        .map_err(|e| (1, format!("bus boot on {iface}: {e}")))?;
    for i in &booted.nodes {
        eprintln!(
            "hob-rt: node {} \"{}\" operational{}",
            i.node,
            i.name,
            if i.csp() { ", CSP" } else { "" }
        );
    }

    // Shared-memory ports before the memory lock (MCL_FUTURE and a small RLIMIT_MEMLOCK
    // would make these mappings fail).
    let node = hob_ipc::node("hob-rt").map_err(|e| (1, e.to_string()))?;
    let state_pub = hob_ipc::open_state(&node)
        .and_then(|s| hob_ipc::publisher(&s, "state publisher"))
        .map_err(|e| (1, e.to_string()))?;
    let events_pub = hob_ipc::open_events(&node)
        .and_then(|s| hob_ipc::publisher(&s, "events publisher"))
        .map_err(|e| (1, e.to_string()))?;

    let (thread_box, loop_box) = commands::mailboxes();
    let (loop_timing, stats_timing) = stats::circulation();
    let counters = Arc::new(LoopCounters::default());
    let threads_stop = Arc::new(AtomicBool::new(false));

    let (ready_tx, ready_rx) = std::sync::mpsc::channel::<()>();
    let rt_report: Arc<std::sync::OnceLock<RtReport>> = Arc::new(std::sync::OnceLock::new());
    let cmd_thread = {
        let stop = Arc::clone(&threads_stop);
        let machine = machine.clone();
        let ready_tx = ready_tx.clone();
        std::thread::Builder::new()
            .name("hob-rt-commands".into())
            .spawn(move || {
                let ready = || {
                    let _ = ready_tx.send(());
                };
                rt::keep_off_core(machine.service.loop_core);
                if let Err(e) = commands::serve(&machine, &thread_box, &stop, ready) {
                    eprintln!("hob-rt: {e}");
                }
            })
            .map_err(|e| (1, format!("command thread: {e}")))?
    };
    let stats_thread = {
        let stop = Arc::clone(&threads_stop);
        let counters = Arc::clone(&counters);
        let period_ns = u64::from(machine.control.cycle_period_us) * 1000;
        let rt_report = Arc::clone(&rt_report);
        let ready_tx = ready_tx.clone();
        let bus_kind = u8::from(iface == "shm");
        let loop_core = machine.service.loop_core;
        std::thread::Builder::new()
            .name("hob-rt-stats".into())
            .spawn(move || {
                rt::keep_off_core(loop_core);
                stats_loop(
                    stats_timing,
                    &counters,
                    &stop,
                    period_ns,
                    &rt_report,
                    bus_kind,
                    &ready_tx,
                )
            })
            .map_err(|e| (1, format!("stats thread: {e}")))?
    };

    // Real-time set-up of this (the loop's) thread, after the helper threads exist (they
    // must not inherit the loop's core and priority) and have made their ports.
    let waited = (0..2).all(|_| ready_rx.recv_timeout(Duration::from_secs(10)).is_ok());
    if !waited {
        return Err((1, "the command and stats threads did not start".into()));
    }
    let mut report = RtReport::default();
    alloc_guard::prepare_pool();
    rt::lock_memory(&mut report);
    rt::prefault_stack(512 * 1024);
    rt::pin(machine.service.loop_core, &mut report);
    rt::set_fifo(machine.service.loop_priority, &mut report);
    // Held until the process exits (the loop's run and the controlled stop).
    let _idle_request = rt::hold_cpu_dma_latency(machine.service.cpu_dma_latency_us, &mut report);
    let kernel_rt = rt::kernel_is_preempt_rt();
    if !report.is_complete() {
        eprintln!("hob-rt: ************************************************************");
        eprintln!("hob-rt: DEGRADED: the loop runs without full real-time set-up:");
        for p in &report.problems {
            eprintln!("hob-rt:   - {p}");
        }
        eprintln!("hob-rt: ************************************************************");
        if args.require_rt {
            return Err((3, "--require-rt: refusing to run degraded".into()));
        }
    }
    if !kernel_rt {
        eprintln!(
            "hob-rt: note: the kernel is not PREEMPT_RT (/sys/kernel/realtime): latencies are not bounded"
        );
    }

    let _ = rt_report.set(report.clone());
    let controller = Controller::new(ControlParams::from_machine(&machine));
    let mut cyclic = booted.cyclic;
    if cyclic.hear_own_sync(&mut *bus) {
        eprintln!(
            "hob-rt: {iface} echoes our SYNCs in bus order: each TPDO is matched to the SYNC it answers"
        );
    } else {
        eprintln!(
            "hob-rt: {iface} cannot echo our SYNCs in order: TPDOs are matched by counting the SYNCs each drive owes"
        );
    }
    let mut lp = RtLoop::new(
        controller,
        cyclic,
        bus,
        state_pub,
        events_pub,
        loop_box,
        loop_timing,
        Arc::clone(&counters),
    );
    let summary = format!(
        "hob-rt started on {iface}: {}, {}, {}{}{}",
        report
            .fifo_priority
            .map_or("no SCHED_FIFO".into(), |p| format!("SCHED_FIFO {p}")),
        report.core.map_or("not pinned".into(), |c| format!("core {c}")),
        if report.memory_locked {
            "memory locked"
        } else {
            "memory not locked"
        },
        report
            .cpu_dma_latency_us
            .map_or(", idle states not limited".into(), |us| format!(
                ", idle exit latency <= {us} us"
            )),
        if kernel_rt { ", PREEMPT_RT" } else { "" }
    );
    eprintln!("hob-rt: {summary}");
    lp.message(&summary);
    lp.run(stop, args.cycles);
    lp.message("hob-rt stopped");
    let status = lp.controller.status();
    drop(lp);

    threads_stop.store(true, Ordering::Relaxed);
    let _ = cmd_thread.join();
    let total = stats_thread
        .join()
        .map_err(|_| (1, "stats thread panicked".to_string()))?;
    let w = stats::percentiles(&total.wake_ns);
    let c = stats::percentiles(&total.compute_ns);
    eprintln!(
        "hob-rt: stopped in state {} after {} cycles, {} overruns; in cycles: {} system heap allocations, {} pool blocks",
        status.state.name(),
        status.cycle,
        counters.overruns.load(Ordering::Relaxed),
        alloc_guard::counts().map_or(0, |c| c.0),
        alloc_guard::counts().map_or(0, |c| c.1)
    );
    eprintln!(
        "hob-rt: wake latency us: p50 {:.1} p99 {:.1} p99.9 {:.1} max {:.1}; compute us: p50 {:.1} p99.99 {:.1} max {:.1}",
        w.p50_ns as f64 / 1e3,
        w.p99_ns as f64 / 1e3,
        w.p999_ns as f64 / 1e3,
        w.max_ns as f64 / 1e3,
        c.p50_ns as f64 / 1e3,
        c.p9999_ns as f64 / 1e3,
        c.max_ns as f64 / 1e3
    );
    if let Some(dir) = &args.hgrm {
        std::fs::create_dir_all(dir).map_err(|e| (1, format!("{}: {e}", dir.display())))?;
        let summary = format!(
            "{{\"cycles\": {}, \"overruns\": {}, \"period_ns\": {}, \"fifo_priority\": {}, \"core\": {}, \"memory_locked\": {}, \"cpu_dma_latency_us\": {}, \"preempt_rt\": {}, \"iface\": \"{}\", \"system_allocations_in_cycles\": {}, \"pool_blocks_in_cycles\": {}, \"final_state\": \"{}\"}}\n",
            total.wake_ns.len(),
            counters.overruns.load(Ordering::Relaxed),
            u64::from(machine.control.cycle_period_us) * 1000,
            report.fifo_priority.unwrap_or(0),
            report.core.map_or(-1, i64::from),
            report.memory_locked,
            report
                .cpu_dma_latency_us
                .map_or("null".into(), |us| us.to_string()),
            kernel_rt,
            iface.escape_default(),
            alloc_guard::counts().map_or(0, |c| c.0),
            alloc_guard::counts().map_or(0, |c| c.1),
            status.state.name()
        );
        let files = [
            ("wake.hgrm", stats::hgrm(&total.wake_ns)),
            ("compute.hgrm", stats::hgrm(&total.compute_ns)),
            ("wake.hist", stats::counts_text(&total.wake_ns)),
            ("compute.hist", stats::counts_text(&total.compute_ns)),
            ("hob-rt.json", summary),
        ];
        for (name, text) in files {
            let p = dir.join(name);
            std::fs::write(&p, text).map_err(|e| (1, format!("{}: {e}", p.display())))?;
        }
    }
    Ok(())
}

fn stats_loop(
    mut timing: StatsTiming,
    counters: &LoopCounters,
    stop: &AtomicBool,
    period_ns: u64,
    report: &std::sync::OnceLock<RtReport>,
    bus_kind: u8,
    ready: &std::sync::mpsc::Sender<()>,
) -> hob_service::stats::Timing {
    let publisher = hob_ipc::node("hob-rt-stats")
        .and_then(|n| {
            let p = hob_ipc::publisher(&hob_ipc::open_stats(&n)?, "stats publisher")?;
            Ok((n, p))
        })
        .map_err(|e| eprintln!("hob-rt: stats publisher: {e}"))
        .ok();
    let _ = ready.send(());
    let empty = RtReport::default();
    while !stop.load(Ordering::Relaxed) {
        timing.wait(Duration::from_millis(500));
        if let Some((_, p)) = &publisher {
            let report = report.get().unwrap_or(&empty);
            let s = StatsSample {
                cycle: counters.cycle.load(Ordering::Relaxed),
                period_ns,
                overruns: counters.overruns.load(Ordering::Relaxed),
                tx_errors: counters.tx_errors.load(Ordering::Relaxed),
                system_allocations_in_cycle: alloc_guard::counts().map_or(u64::MAX, |c| c.0),
                pool_allocations_in_cycle: alloc_guard::counts().map_or(0, |c| c.1),
                fifo_priority: report.fifo_priority.map_or(0, |p| p as i32),
                core: report.core.map_or(-1, |c| c as i32),
                memory_locked: u8::from(report.memory_locked),
                cpu_dma_latency_us: report.cpu_dma_latency_us.map_or(-1, |us| us as i32),
                bus_kind,
                ..timing.sample()
            };
            let _ = p.send_copy(s);
        }
    }
    timing.collect();
    timing.total
}
