//! `hob`: the command-line frontend of the hob controller.
//!
//! Exit status: 0 done; 2 refused (an invalid program or machine configuration, or bad
//! arguments: the message names the file, position, key and limit); 1 anything else.

mod render;
mod simulate;

use clap::{Parser, Subcommand};
use hob_rt_core::config::LoadError;
use hob_rt_core::config::machine::MachineConfig;
use hob_rt_core::planner::plan_file;
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
    /// Validate a program against the machine (and the machine configuration itself).
    Check {
        /// Program file (TOML); without it only the machine configuration is checked.
        program: Option<PathBuf>,
        /// Machine configuration [default: config/machine.toml, then /etc/hob/machine.toml].
        #[arg(long, value_name = "FILE")]
        machine: Option<PathBuf>,
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

fn run(command: Command) -> Result<(), Failure> {
    match command {
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
                    hob_rt_core::control::SpindleAngleSource::LastMeasured
                } else {
                    hob_rt_core::control::SpindleAngleSource::Predicted
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
