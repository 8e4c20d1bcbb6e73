//! `hob demo`, `hob simulate` and `hob can run` need the simulated machine: they are the
//! sibling binary `hob-lab`, which `hob` runs in its own place with the same arguments
//! (as `git` runs `git-<command>`). The product binary never links the simulators.

use std::ffi::OsString;
use std::os::unix::process::CommandExt as _;
use std::path::PathBuf;

/// The commands that `hob-lab` answers.
pub const LAB_COMMANDS: [&str; 3] = ["demo", "simulate", "can run"];

/// Options of `hob can` that take a value (skipped when looking for its subcommand).
const CAN_VALUE_OPTIONS: [&str; 3] = ["--iface", "--machine", "--timeout-ms"];

/// Whether these arguments (without the program name) are a `hob-lab` command.
pub fn is_lab_command(args: &[OsString]) -> bool {
    let words: Vec<&str> = args.iter().map(|a| a.to_str().unwrap_or("")).collect();
    match words.first() {
        Some(&"demo") | Some(&"simulate") => true,
        Some(&"can") => {
            let mut rest = words[1..].iter();
            while let Some(w) = rest.next() {
                if CAN_VALUE_OPTIONS.contains(w) {
                    rest.next();
                } else if !w.starts_with('-') {
                    return *w == "run";
                }
            }
            false
        }
        _ => false,
    }
}

/// Where `hob-lab` is: `$HOB_LAB`, else beside this executable.
pub fn lab_path() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("HOB_LAB").filter(|p| !p.is_empty()) {
        return Some(PathBuf::from(p));
    }
    let me = std::env::current_exe().ok()?;
    Some(me.parent()?.join("hob-lab"))
}

/// Replaces this process with `hob-lab ARGS`; returns only when that could not be done,
/// with the reason.
pub fn exec_lab(args: &[OsString]) -> String {
    let Some(path) = lab_path() else {
        return "cannot tell where hob-lab is (no executable path)".into();
    };
    if !path.exists() {
        return format!(
            "{}: not found. `hob {}` runs the simulated machine, which is in the binary hob-lab \
             (build it with `cargo build --release -p hob-lab`, and for `hob demo` every binary beside it: \
             `cargo build --release --workspace --bins`; a machine PC does not need them)",
            path.display(),
            args.first().and_then(|a| a.to_str()).unwrap_or("")
        );
    }
    let e = std::process::Command::new(&path).args(args).exec();
    format!("{}: {e}", path.display())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Vec<OsString> {
        s.split_whitespace().map(OsString::from).collect()
    }

    #[test]
    fn the_lab_commands_are_recognised_and_nothing_else() {
        assert!(is_lab_command(&args("demo --quiet")));
        assert!(is_lab_command(&args("simulate p.toml --out x")));
        assert!(is_lab_command(&args("can run p.toml --iface vcan0")));
        assert!(is_lab_command(&args("can --iface vcan0 run p.toml")));
        assert!(is_lab_command(&args("can --timeout-ms 50 --machine m.toml run")));
        assert!(!is_lab_command(&args("can scan --iface run")));
        assert!(!is_lab_command(&args("can --iface run scan")));
        assert!(!is_lab_command(&args("status")));
        assert!(!is_lab_command(&args("plan demo")));
        assert!(!is_lab_command(&[]));
    }
}
