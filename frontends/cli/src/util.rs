//! What every `hob` command shares: exit statuses, output, the machine file, arguments.

use hob_setup::config::LoadError;
use hob_setup::config::machine::MachineConfig;
use std::path::{Path, PathBuf};

/// Default machine configuration, looked up in this order when `--machine` is not given.
pub const MACHINE_DEFAULTS: [&str; 2] = ["config/machine.toml", "/etc/hob/machine.toml"];

/// Why a command failed, and with which exit status.
#[derive(Debug)]
pub enum Failure {
    Refused(LoadError),
    Other(String),
    /// Already reported.
    Exit(u8),
}

impl Failure {
    /// Any other failure (exit 1), in its words.
    pub fn other(e: impl std::fmt::Display) -> Self {
        Failure::Other(e.to_string())
    }

    /// The exit status, after printing the reason as every `hob` command does.
    pub fn report(self) -> std::process::ExitCode {
        match self {
            Failure::Refused(e) => {
                eprintln!("hob: refused: {e}");
                std::process::ExitCode::from(2)
            }
            Failure::Other(e) => {
                eprintln!("hob: error: {e}");
                std::process::ExitCode::FAILURE
            }
            Failure::Exit(code) => std::process::ExitCode::from(code),
        }
    }
}

pub fn service_result(r: Result<String, crate::service::ServiceError>) -> Result<(), Failure> {
    match r {
        Ok(text) => emit(&format!("{}\n", text.trim_end())),
        Err(e) if e.exit_code() == 2 => {
            eprintln!("hob: refused: {e}");
            Err(Failure::Exit(2))
        }
        Err(e) => {
            eprintln!("hob: {e}");
            Err(Failure::Exit(e.exit_code()))
        }
    }
}

/// `--jog AXIS=DISTANCE` of `hob-lab can run` (bench/lab, whose errors are text).
pub fn parse_jog(s: &str) -> Result<(hob_control::fault::Axis, f64), String> {
    use hob_control::fault::Axis;
    let (axis, d) = s
        .split_once('=')
        .ok_or_else(|| format!("--jog {s}: expected AXIS=DISTANCE"))?;
    let axis = Axis::parse(axis).ok_or_else(|| format!("--jog {s}: axis {axis} is not x, y or b"))?;
    let d: f64 = d.parse().map_err(|e| format!("--jog {s}: {e}"))?;
    Ok((axis, d))
}

/// Writes to stdout; a reader that went away (`hob plan ... | head`) is not an error.
pub fn emit(text: &str) -> Result<(), Failure> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Failure::Other(format!("stdout: {e}"))),
        _ => Ok(()),
    }
}

pub fn machine_path(given: Option<&Path>) -> Result<PathBuf, Failure> {
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

pub fn load_machine(given: Option<&Path>) -> Result<MachineConfig, Failure> {
    hob_store::files::load_machine(&machine_path(given)?).map_err(Failure::Refused)
}
