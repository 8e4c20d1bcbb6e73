//! `hob`: the command-line frontend of the hob controller.
//!
//! Exit status: 0 done; 2 refused (an invalid program or machine configuration, or bad
//! arguments: the message names the file, position, key and limit); 1 anything else.

mod can;
mod demo;
mod doctor;
mod log;
mod render;
mod service;
mod simulate;

use clap::{Parser, Subcommand};
use hob_setup::config::LoadError;
use hob_setup::config::machine::MachineConfig;
use hob_setup::planner::plan_file;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Default machine configuration, looked up in this order when `--machine` is not given.
const MACHINE_DEFAULTS: [&str; 2] = ["config/machine.toml", "/etc/hob/machine.toml"];

#[derive(Debug, Parser)]
#[command(name = "hob", version, about = "hob: CNC for gear hobbing machines")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Cut a program on the virtual machine with the real-time service, logger and
    /// watchdog as separate processes; prints the summary, last line `log: PATH`.
    Demo {
        /// Program file [default: config/programs/demo-short-spur-z17-m5.toml].
        program: Option<PathBuf>,
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        #[arg(long, value_name = "FILE", default_value = "config/plant.toml")]
        plant: PathBuf,
        /// CAN interface, or `shm` [default: vcan0 if it exists, else shm].
        #[arg(long)]
        iface: Option<String>,
        /// Log directory [default: hob-logs/demo-UNIXTIME].
        #[arg(long, value_name = "DIR")]
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
    },
    /// Is this PC ready for the 1 ms loop? RT kernel, core isolation, governor, limits,
    /// CAN interface, shared memory, clock source, a short cyclictest; the fix for each.
    Doctor {
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// Length of the cyclictest run (0: skip it).
        #[arg(long, default_value_t = 10)]
        cyclictest_seconds: u32,
        /// The findings as JSON.
        #[arg(long)]
        json: bool,
    },
    /// The running service's state, alarms, loop timing and recent events.
    Status {
        /// Keep printing a line every half second, and every event.
        #[arg(long)]
        watch: bool,
        #[arg(long)]
        json: bool,
    },
    /// Load a program into the running service (checked there against its machine).
    Load { program: PathBuf },
    /// Start the loaded program.
    Start {
        /// Only the single-mode pass.
        #[arg(long)]
        single: bool,
    },
    /// Feed hold.
    Hold,
    /// Resume after feed hold.
    Resume,
    /// Cycle stop: out of the cut, gearbox out, spindle off.
    Stop,
    /// Clear a fault whose cause is gone.
    Reset,
    /// Move an axis by a distance (mm, or deg for B) while idle.
    Jog {
        axis: String,
        #[arg(allow_hyphen_values = true)]
        distance: f64,
    },
    /// Read recorded logs of hob-logger.
    Log {
        #[command(subcommand)]
        command: LogCommand,
    },
    /// Plan a program: gearbox ratio, differential, hob swivel, passes, speeds, times.
    Plan {
        /// Program file (TOML).
        program: PathBuf,
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
        /// Print the plan as JSON.
        #[arg(long)]
        json: bool,
    },
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
        /// Output directory.
        #[arg(long, value_name = "DIR", default_value = "out/simulate")]
        out: PathBuf,
    },
    /// Worst-case CAN bus load per cycle of the configured PDO set; refused above the limit.
    BusLoad {
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
    },
    /// Commissioning tools for the CAN bus (scan, SDO, dump, a run over the bus).
    Can {
        #[command(subcommand)]
        command: CanCommand,
        /// SocketCAN interface [default: can.interface of the machine configuration].
        #[arg(long, global = true)]
        iface: Option<String>,
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE", global = true)]
        machine: Option<PathBuf>,
        /// SDO timeout per frame, ms.
        #[arg(long, default_value_t = 100, global = true)]
        timeout_ms: u64,
    },
    /// Validate a program against the machine (and the machine configuration itself).
    Check {
        /// Program file (TOML); without it only the machine configuration is checked.
        program: Option<PathBuf>,
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
    },
}

#[derive(Debug, Subcommand)]
enum CanCommand {
    /// The nodes that answer: NMT state, device type, identity, name, CSP support.
    Scan,
    /// SDO upload and download (expedited and segmented); aborts in words.
    Sdo {
        #[command(subcommand)]
        op: SdoOp,
    },
    /// Live decoded view of the bus, or of a `candump -L` file.
    Dump {
        /// Decode this capture instead of the live bus.
        #[arg(long, value_name = "FILE")]
        file: Option<PathBuf>,
        /// Stop after this many frames.
        #[arg(long)]
        count: Option<usize>,
    },
    /// Check a `candump -L` capture against the bus schedule (and, given the program that
    /// was cut, the gearbox law from its frames).
    CheckCapture {
        file: PathBuf,
        #[arg(long)]
        program: Option<PathBuf>,
    },
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

#[derive(Debug, Subcommand)]
enum LogCommand {
    /// Write a recorded log as CSV: the columns of `hob simulate`'s trace.csv up to
    /// sync_err_arcsec, then the cycle counter and the other recorded values.
    Export {
        dir: PathBuf,
        /// CSV (the only format; required for clarity).
        #[arg(long)]
        csv: bool,
        /// Output file [default: standard output].
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
    },
    /// Per-pass synchronisation error statistics of a recorded cut.
    Report { dir: PathBuf },
}

#[derive(Debug, Subcommand)]
enum SdoOp {
    Read {
        node: u8,
        index: String,
        sub: String,
        #[arg(long = "type", value_enum, default_value = "hex")]
        ty: can::SdoType,
    },
    Write {
        node: u8,
        index: String,
        sub: String,
        value: String,
        #[arg(long = "type", value_enum, default_value = "u32")]
        ty: can::SdoType,
    },
}

/// Why a command failed, and with which exit status.
enum Failure {
    Refused(LoadError),
    Other(String),
    /// Already reported.
    Exit(u8),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Refused(e)) => {
            eprintln!("hob: refused: {e}");
            ExitCode::from(2)
        }
        Err(Failure::Other(e)) => {
            eprintln!("hob: error: {e}");
            ExitCode::FAILURE
        }
        Err(Failure::Exit(code)) => ExitCode::from(code),
    }
}

fn service_result(r: Result<String, (u8, String)>) -> Result<(), Failure> {
    match r {
        Ok(text) => emit(&format!("{}\n", text.trim_end())),
        Err((2, text)) => {
            eprintln!("hob: refused: {text}");
            Err(Failure::Exit(2))
        }
        Err((code, text)) => {
            eprintln!("hob: {text}");
            Err(Failure::Exit(code))
        }
    }
}

fn run(command: Command) -> Result<(), Failure> {
    use hob_ipc::command as code;
    match command {
        Command::Demo {
            program,
            machine,
            plant,
            iface,
            log,
            quiet,
            strict,
            tolerance_ms,
        } => {
            let machine_file = machine_path(machine.as_deref())?;
            let machine = MachineConfig::load(&machine_file).map_err(Failure::Refused)?;
            let program = program.unwrap_or_else(|| PathBuf::from(demo::DEMO_PROGRAM));
            let args = demo::DemoArgs {
                program: &program,
                machine_file: &machine_file,
                plant: &plant,
                iface: iface.as_deref(),
                log_dir: log.as_deref(),
                quiet,
                strict,
                tolerance_ms,
            };
            match demo::run(&machine, &args) {
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
        Command::Doctor {
            machine,
            cyclictest_seconds,
            json,
        } => {
            let machine = load_machine(machine.as_deref())?;
            let findings = doctor::run(&machine, cyclictest_seconds);
            if json {
                emit(
                    &(serde_json::to_string_pretty(&findings).map_err(|e| Failure::Other(e.to_string()))?
                        + "\n"),
                )?;
            } else {
                emit(&doctor::text(&findings))?;
            }
            if findings.iter().any(|f| f.level == doctor::Level::Fail) {
                Err(Failure::Exit(1))
            } else {
                Ok(())
            }
        }
        Command::Status { watch, json } => service_result(service::status(watch, json)),
        Command::Load { program } => service_result(service::load(&program)),
        Command::Start { single } => service_result(service::request(&service::start(single))),
        Command::Hold => service_result(service::request(&service::simple(code::FEED_HOLD))),
        Command::Resume => service_result(service::request(&service::simple(code::RESUME))),
        Command::Stop => service_result(service::request(&service::simple(code::STOP))),
        Command::Reset => service_result(service::request(&service::simple(code::RESET))),
        Command::Jog { axis, distance } => {
            service_result(service::jog(&axis, distance).and_then(|r| service::request(&r)))
        }
        Command::Log { command } => match command {
            LogCommand::Export { dir, csv, out } => {
                if !csv {
                    eprintln!("hob: refused: log export: give --csv (the only format)");
                    return Err(Failure::Exit(2));
                }
                let text = log::export_csv(&dir).map_err(Failure::Other)?;
                match out {
                    Some(f) => {
                        std::fs::write(&f, text).map_err(|e| Failure::Other(format!("{}: {e}", f.display())))
                    }
                    None => emit(&text),
                }
            }
            LogCommand::Report { dir } => {
                let r = log::report(&dir).map_err(Failure::Other)?;
                emit(&log::report_text(&dir, &r))
            }
        },
        Command::Plan {
            program,
            machine,
            json,
        } => {
            let machine = load_machine(machine.as_deref())?;
            let plan = plan_file(&program, &machine).map_err(Failure::Refused)?;
            if json {
                let text = serde_json::to_string_pretty(&plan).map_err(|e| Failure::Other(e.to_string()))?;
                emit(&format!("{text}\n"))
            } else {
                emit(&render::plan_text(&program, &plan))
            }
        }
        Command::Simulate {
            program,
            machine,
            plant,
            no_ccc,
            no_predictor,
            single,
            no_windows,
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
        Command::BusLoad { machine } => {
            let machine = load_machine(machine.as_deref())?;
            match can::bus_load(&machine) {
                Ok(text) => emit(&text),
                Err(text) => {
                    eprintln!("hob: refused: {text}");
                    Err(Failure::Exit(2))
                }
            }
        }
        Command::Can {
            command,
            iface,
            machine,
            timeout_ms,
        } => {
            let machine = load_machine(machine.as_deref())?;
            let iface = iface.unwrap_or_else(|| machine.can.interface.clone());
            let timeout = std::time::Duration::from_millis(timeout_ms);
            let result = match command {
                CanCommand::Scan => can::scan(&iface, timeout).map_err(|e| (1, e)),
                CanCommand::Sdo { op } => sdo(&iface, op, timeout),
                CanCommand::Dump { file, count } => {
                    let live = file.is_none().then_some(iface.as_str());
                    can::dump(&machine, live, file.as_deref(), count).map_err(|e| (1, e))
                }
                CanCommand::CheckCapture { file, program } => {
                    can::check_capture(&machine, &file, program.as_deref()).map_err(|e| (1, e))
                }
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
                        Ok(jogs) => can::run(
                            &machine,
                            &can::RunArgs {
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
        Command::Check { program, machine } => {
            let machine_file = machine_path(machine.as_deref())?;
            let machine = MachineConfig::load(&machine_file).map_err(Failure::Refused)?;
            match program {
                None => emit(&format!(
                    "{}: ok ({})\n",
                    machine_file.display(),
                    machine.machine.name
                )),
                Some(program) => {
                    let plan = plan_file(&program, &machine).map_err(Failure::Refused)?;
                    let mut text = format!(
                        "{}: ok on {}: {} pass{}, {:.0} s\n",
                        program.display(),
                        machine_file.display(),
                        plan.passes.len(),
                        if plan.passes.len() == 1 { "" } else { "es" },
                        plan.total_time_s
                    );
                    for w in &plan.warnings {
                        text.push_str(&format!("  note: {w}\n"));
                    }
                    emit(&text)
                }
            }
        }
    }
}

fn sdo(iface: &str, op: SdoOp, timeout: std::time::Duration) -> Result<String, (u8, String)> {
    let bad = |e: String| (2, e);
    match op {
        SdoOp::Read { node, index, sub, ty } => {
            let (index, sub) = (
                can::parse_u16(&index).map_err(bad)?,
                can::parse_u16(&sub).map_err(bad)?,
            );
            can::sdo_read_cmd(iface, node, index, sub as u8, ty, timeout).map_err(|e| (1, e))
        }
        SdoOp::Write {
            node,
            index,
            sub,
            value,
            ty,
        } => {
            let (index, sub) = (
                can::parse_u16(&index).map_err(bad)?,
                can::parse_u16(&sub).map_err(bad)?,
            );
            can::sdo_write_cmd(iface, node, index, sub as u8, &value, ty, timeout).map_err(|e| (1, e))
        }
    }
}

fn parse_jog(s: &str) -> Result<(hob_control::fault::Axis, f64), String> {
    use hob_control::fault::Axis;
    let (axis, d) = s
        .split_once('=')
        .ok_or_else(|| format!("--jog {s}: expected AXIS=DISTANCE"))?;
    let axis = Axis::parse(axis).ok_or_else(|| format!("--jog {s}: axis {axis} is not x, y or b"))?;
    let d: f64 = d.parse().map_err(|e| format!("--jog {s}: {e}"))?;
    Ok((axis, d))
}

/// Writes to stdout; a reader that went away (`hob plan ... | head`) is not an error.
fn emit(text: &str) -> Result<(), Failure> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Failure::Other(format!("stdout: {e}"))),
        _ => Ok(()),
    }
}

fn machine_path(given: Option<&Path>) -> Result<PathBuf, Failure> {
    if let Some(p) = given {
        return Ok(p.to_path_buf());
    }
    MACHINE_DEFAULTS
        .iter()
        .map(PathBuf::from)
        .find(|p| p.exists())
        .ok_or_else(|| {
            Failure::Other(format!(
                "no machine configuration: give --machine FILE or install one at {}",
                MACHINE_DEFAULTS.join(" or ")
            ))
        })
}

fn load_machine(given: Option<&Path>) -> Result<MachineConfig, Failure> {
    MachineConfig::load(&machine_path(given)?).map_err(Failure::Refused)
}
