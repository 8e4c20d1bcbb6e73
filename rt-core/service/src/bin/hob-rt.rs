//! `hob-rt`: the real-time service. Start-up (may allocate, block and fail): machine
//! configuration, CAN bus boot, shared-memory ports, command and stats threads; then
//! `mlockall`, stack pre-fault, core pinning, SCHED_FIFO, and the 1 kHz loop: the stages
//! of `hob_service::lifecycle`, in the order its types allow.
//!
//! Exit status: 0 stopped on request; 2 refused configuration or arguments; 3 real-time
//! set-up incomplete with `--require-rt`; 1 anything else (bus, shared memory).

use hob_rt_os::alloc_guard::CountingAllocator;
use hob_service::lifecycle::{self, Settings};
use hob_setup::config::machine::MachineConfig;
use std::path::PathBuf;
use std::process::ExitCode;

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

const USAGE: &str =
    "usage: hob-rt [--machine FILE] [--iface IFACE|shm] [--require-rt] [--cycles N] [--hgrm DIR]
              [--state-file FILE] [--flight-dir DIR]

  --machine FILE  machine configuration [default: config/machine.toml, then /etc/hob/machine.toml]
  --iface IFACE   CAN interface (can0, vcan0) or `shm` for the shared-memory virtual bus
                  [default: can.interface of the configuration]
  --require-rt    refuse to run without SCHED_FIFO, the pinned core and locked memory
  --cycles N      stop after N cycles (benchmarks)
  --hgrm DIR      at exit, write the loop's histograms to DIR: wake.hgrm, compute.hgrm
                  (percentile text, us), wake.hist, compute.hist (every value, ns) and
                  hob-rt.json (cycles, overruns, real-time set-up)
  --state-file FILE  the work offsets [default: state.file of the configuration]
  --flight-dir DIR   where the flight recorder's records go (on a fault, at the stop, on
                  `hob record`; `hob replay FILE`) [default: flight/ beside the state file]

Environment: HOB_INSTANCE names the instance of the shared-memory services (default main).";

#[derive(Debug, Default)]
struct Args {
    machine: Option<PathBuf>,
    iface: Option<String>,
    require_rt: bool,
    cycles: Option<u64>,
    hgrm: Option<PathBuf>,
    state_file: Option<PathBuf>,
    flight_dir: Option<PathBuf>,
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
            "--state-file" => a.state_file = Some(value("--state-file")?.into()),
            "--flight-dir" => a.flight_dir = Some(value("--flight-dir")?.into()),
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
    let machine = match hob_store::files::load_machine(&path) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("hob-rt: refused: {e}");
            return ExitCode::from(2);
        }
    };
    match run(&args, machine) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hob-rt: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

/// The service's life: configure (machine, bus boot) -> activate (ports, helper threads,
/// real-time set-up) -> run (the loop) -> stop (helpers joined, figures written).
fn run(args: &Args, machine: MachineConfig) -> Result<(), lifecycle::Failure> {
    let stop = hob_rt_os::termination_flag();
    let settings = Settings {
        iface: args.iface.clone(),
        require_rt: args.require_rt,
        state_file: args.state_file.clone(),
        flight_dir: args.flight_dir.clone(),
    };
    lifecycle::configure(machine, &settings)?
        .activate()?
        .run(stop, args.cycles)
        .finish(args.hgrm.as_deref())
}
