//! `hob-lab`: the commands that need the simulated machine, kept out of the product
//! binaries. `hob demo`, `hob simulate` and `hob can run` run this binary with the same
//! arguments; it can be called directly too (`hob-lab demo`). `hob-lab check` (the
//! simulated checker on a recorded cut) is called only directly: `hob check` checks a
//! program.
//!
//! Exit status as `hob`: 0 done; 2 refused; 1 anything else.

mod can_run;
mod check;
mod demo;
mod demo_compensate;
mod demo_hmi;
mod simulate;

use clap::{Parser, Subcommand};
use hob_cli::util::{Failure, emit, load_machine, machine_path, parse_jog};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, Parser)]
#[command(
    name = "hob",
    bin_name = "hob",
    version,
    about = "hob with the simulated machine: demo, simulate, check, can run (binary hob-lab)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Cut a program on the virtual machine with the real-time service, logger and
    /// watchdog as separate processes; prints the summary, last line `log: PATH`. With
    /// --hmi: cut nothing, serve the touch HMI beside them until Ctrl-C. With --compensate:
    /// cut, measure, compensate, cut again.
    Demo(DemoOpts),
    /// Run a program against the simulated machine; write DIR/trace.csv and DIR/summary.json.
    Simulate {
        /// Program file (TOML).
        program: PathBuf,
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// Plant (simulated machine) parameters.
        #[arg(long, value_name = "FILE", default_value = "config/plant.toml")]
        plant: PathBuf,
        /// Cross-coupling compensation off.
        #[arg(long)]
        no_ccc: bool,
        /// Follow the last measured spindle angle instead of the predicted one.
        #[arg(long)]
        no_predictor: bool,
        /// Run the single-mode pass instead of the automatic cycle.
        #[arg(long)]
        single: bool,
        /// For comparisons: synchronism windows never hold the feed or fault the cut.
        #[arg(long)]
        no_windows: bool,
        /// The ISO 1328-1 grade (1-11) the predicted gear is judged against.
        #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u8).range(1..=11))]
        grade: u8,
        /// Output directory.
        #[arg(long, value_name = "DIR", default_value = "out/simulate")]
        out: PathBuf,
    },
    /// The simulated machine's gear checker on a cut recorded over the bus: the log's last
    /// cut joined with hob-sim's truth beside it (truth.csv), measured at one or more
    /// heights around mid-face; one checker's file per height (DIR/measurement-N.csv), the
    /// files `hob compensate --measurement` reads.
    Check {
        /// The log directory (hob-logger's), with hob-sim's truth.csv in it.
        #[arg(long, value_name = "DIR")]
        log: PathBuf,
        /// The program the gear was cut with.
        #[arg(long, value_name = "FILE")]
        program: PathBuf,
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// Where the checker's files go.
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Heights measured, one feed apart around mid-face (a two-start hob wants two or more).
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=50))]
        heights: u32,
        /// The checker's noise draw.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// The master over SocketCAN in lockstep with the drives.
    Can {
        #[command(subcommand)]
        command: CanCommand,
        /// SocketCAN interface [default: can.interface of the machine configuration].
        #[arg(long, global = true)]
        iface: Option<String>,
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE", global = true)]
        machine: Option<PathBuf>,
        /// SDO timeout per frame, ms (accepted as `hob can` does; the run uses its own).
        #[arg(long, default_value_t = 100, global = true)]
        timeout_ms: u64,
    },
}

/// `hob demo`'s arguments.
#[derive(Debug, clap::Args)]
struct DemoOpts {
    /// Program file [default: config/programs/demo-short-spur-z17-m5.toml; with
    /// --compensate config/programs/demo-short-helical-z41-m2-2start.toml].
    program: Option<PathBuf>,
    /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
    #[arg(long, value_name = "FILE")]
    machine: Option<PathBuf>,
    /// The simulated machine's hidden values (its worm wheel's grade, the hob's runout).
    #[arg(long, value_name = "FILE", default_value = "config/plant.toml")]
    plant: PathBuf,
    /// CAN interface, or `shm` [default: vcan0 if it exists, else shm].
    #[arg(long)]
    iface: Option<String>,
    /// Log directory [default: $XDG_STATE_HOME/hob/demo-UNIXTIME, else
    /// ~/.local/state/hob/demo-UNIXTIME]: never the current directory.
    #[arg(long = "log-dir", alias = "log", value_name = "DIR")]
    log: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Bus and watchdog timing exactly as configured (for a PREEMPT_RT PC; a virtual
    /// machine's stalls trip them).
    #[arg(long)]
    strict: bool,
    /// Without --strict: bus silence tolerated before a fault, ms.
    #[arg(long, default_value_t = 100)]
    tolerance_ms: u32,
    /// Cut nothing: also start the touch HMI (hob-hmi) and print the address to open
    /// (`HMI: http://127.0.0.1:PORT/`); the operator does the job on the page. Runs
    /// until Ctrl-C or SIGTERM, then stops every process it started.
    #[arg(long)]
    hmi: bool,
    /// With --hmi: the HMI's port on 127.0.0.1 (0: any free port) [default: 8080].
    #[arg(long, requires = "hmi")]
    port: Option<u16>,
    /// Issue 34's loop: cut the first gear, measure it with the simulated gear checker,
    /// store the compensation (`hob compensate --yes`) in the demo's own directory,
    /// restart hob-rt, `hob pitch-compensation on`, cut the second gear, measure it;
    /// print both side by side and where the files are. Not with --hmi (which cuts
    /// nothing: the operator does the job on the page).
    #[arg(long, conflicts_with = "hmi")]
    compensate: bool,
    /// X and Y power up within MM of their home, for a short referencing (hob-sim
    /// --power-on-near-home) [default: anywhere in their travel].
    #[arg(long, value_name = "MM")]
    near_home: Option<f64>,
}

#[derive(Debug, Subcommand)]
enum CanCommand {
    /// Boot the bus, power up, jog, and run a program over it (lockstep with the drives).
    Run {
        /// Program to cut after the jogs.
        program: Option<PathBuf>,
        /// Jog before the program: AXIS=DISTANCE (x, y in mm; b in deg). Repeatable.
        #[arg(long, value_name = "AXIS=DISTANCE")]
        jog: Vec<String>,
        /// The single-mode pass instead of the automatic cycle.
        #[arg(long)]
        single: bool,
        /// Give up after this much machine time, s.
        #[arg(long, default_value_t = 600.0)]
        max_s: f64,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => f.report(),
    }
}

fn run(command: Command) -> Result<(), Failure> {
    match command {
        Command::Demo(d) => demo_command(d),
        Command::Simulate {
            program,
            machine,
            plant,
            no_ccc,
            no_predictor,
            single,
            no_windows,
            grade,
            out,
        } => {
            let machine = load_machine(machine.as_deref())?;
            let options = hob_plant::sim::SimOptions {
                cross_coupling: !no_ccc,
                angle_source: if no_predictor {
                    hob_control::SpindleAngleSource::LastMeasured
                } else {
                    hob_control::SpindleAngleSource::Predicted
                },
                single,
                windows_off: no_windows,
                grade,
                ..Default::default()
            };
            let args = simulate::Args {
                program: &program,
                plant: &plant,
                out: &out,
                options,
            };
            match simulate::run(&machine, &args) {
                Ok(line) => emit(&line),
                Err((true, e)) => {
                    eprintln!("hob: refused: {e}");
                    Err(Failure::Exit(2))
                }
                Err((false, e)) => Err(Failure::Other(e)),
            }
        }
        Command::Check {
            log,
            program,
            machine,
            out,
            heights,
            seed,
        } => {
            let machine = load_machine(machine.as_deref())?;
            let args = check::Args {
                log: &log,
                program: &program,
                out: &out,
                heights: heights as usize,
                seed,
            };
            match check::run(&machine, &args) {
                Ok(text) => emit(&text),
                Err(check::CheckError::Refused(e)) => {
                    eprintln!("hob: refused: check: {e}");
                    Err(Failure::Exit(2))
                }
                Err(check::CheckError::Failed(e)) => Err(Failure::Other(e)),
            }
        }
        Command::Can {
            command,
            iface,
            machine,
            timeout_ms: _,
        } => {
            let machine = load_machine(machine.as_deref())?;
            let iface = iface.unwrap_or_else(|| machine.can.interface.clone());
            let result = match command {
                CanCommand::Run {
                    program,
                    jog,
                    single,
                    max_s,
                } => {
                    let jogs = jog
                        .iter()
                        .map(|j| parse_jog(j))
                        .collect::<Result<Vec<_>, _>>()
                        .map_err(|e| (2, e));
                    match jogs {
                        Ok(jogs) => can_run::run(
                            &machine,
                            &can_run::RunArgs {
                                iface: &iface,
                                program: program.as_deref(),
                                jogs: &jogs,
                                single,
                                max_s,
                            },
                        ),
                        Err(e) => Err(e),
                    }
                }
            };
            match result {
                Ok(text) => emit(&text),
                Err((code, text)) => {
                    let _ = emit(&text);
                    eprintln!("hob: {}", text.lines().last().unwrap_or("failed"));
                    Err(Failure::Exit(code))
                }
            }
        }
    }
}

/// `hob demo`: the cut, `--hmi` or `--compensate`.
fn demo_command(d: DemoOpts) -> Result<(), Failure> {
    let DemoOpts {
        program,
        machine,
        plant,
        iface,
        log,
        quiet,
        strict,
        tolerance_ms,
        hmi,
        port,
        compensate,
        near_home,
    } = d;
    let machine_file = machine_path(machine.as_deref())?;
    let machine = hob_store::files::load_machine(&machine_file).map_err(Failure::Refused)?;
    let program = program.unwrap_or_else(|| {
        PathBuf::from(if compensate {
            demo_compensate::PROGRAM
        } else {
            demo::DEMO_PROGRAM
        })
    });
    let args = demo::DemoArgs {
        program: &program,
        machine_file: &machine_file,
        plant: &plant,
        iface: iface.as_deref(),
        log_dir: log.as_deref(),
        quiet,
        strict,
        tolerance_ms,
        near_home_mm: near_home,
    };
    let result = if hmi {
        demo_hmi::run(&machine, &args, port.unwrap_or(8080))
    } else if compensate {
        demo_compensate::run(&machine, &args)
    } else {
        demo::run(&machine, &args)
    };
    match result {
        Ok(text) => emit(&text),
        // A refusal (the program, the tolerance, or hob-rt refusing the load or the
        // start): the reasons on stderr, as every refusal.
        Err((2, text)) => {
            eprintln!("hob: refused: demo: {text}");
            Err(Failure::Exit(2))
        }
        Err((code, text)) => {
            let _ = emit(&text);
            eprintln!("hob: demo: {}", text.lines().next().unwrap_or("failed"));
            Err(Failure::Exit(code))
        }
    }
}
