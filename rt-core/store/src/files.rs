//! The set-up's files read from disk: the machine file, a program, a program planned on a
//! machine. `hob-setup` is pure (it parses, validates and plans texts); reading the files
//! is this edge's, with the same errors (`LoadError::Io` names the file).

use hob_setup::config::machine::MachineConfig;
use hob_setup::config::{LoadError, parse_toml};
use hob_setup::job::Program;
use hob_setup::planner::{Plan, plan_source};
use serde::de::DeserializeOwned;
use std::path::Path;

/// The text of `file`.
pub fn read_text(file: &Path) -> Result<String, LoadError> {
    std::fs::read_to_string(file).map_err(|error| LoadError::Io {
        file: file.to_path_buf(),
        error,
    })
}

/// Reads `file` and deserialises it; returns the value and the source text (kept to
/// locate later validation problems).
pub fn read_toml<T: DeserializeOwned>(file: &Path) -> Result<(T, String), LoadError> {
    let src = read_text(file)?;
    let value = parse_toml(file, &src)?;
    Ok((value, src))
}

/// Loads and validates the machine file `file`.
pub fn load_machine(file: &Path) -> Result<MachineConfig, LoadError> {
    MachineConfig::parse(file, &read_text(file)?)
}

/// Reads and deserialises the program `file` (unknown keys refused, a library tool not
/// resolved refused: `Program::parse`); returns the source text too.
pub fn read_program(file: &Path) -> Result<(Program, String), LoadError> {
    let src = read_text(file)?;
    let program = Program::parse(file, &src)?;
    Ok((program, src))
}

/// Reads, checks and plans the program in `file` on `machine`.
pub fn plan_file(file: &Path, machine: &MachineConfig) -> Result<Plan, LoadError> {
    plan_source(file, &read_text(file)?, machine)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn root() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
    }

    #[test]
    fn the_shipped_files_load_and_a_missing_one_is_named() {
        let m = load_machine(&root().join("config/machine.toml")).expect("machine");
        let plan = plan_file(&root().join("config/programs/spur-z17-m5.toml"), &m).expect("plan");
        assert!((plan.passes[0].spindle_rpm - 119.366).abs() < 1e-3);
        let (_, src) = read_program(&root().join("config/programs/spur-z17-m5.toml")).expect("program");
        assert!(!src.is_empty());
        let e = load_machine(&root().join("config/no-such-machine.toml")).unwrap_err();
        assert!(matches!(e, LoadError::Io { .. }), "{e}");
        assert!(e.to_string().contains("no-such-machine.toml"), "{e}");
    }
}
