//! Child processes of a multi-process run (`hob demo`, the benchmarks): start them with
//! their output in a log file, stop them in order, kill what is left when dropped; find the
//! sibling binaries; relax the bus timing of a machine configuration for a virtual machine.

use hob_setup::config::machine::MachineConfig;
use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The machine configuration for a run on a virtual machine: the hypervisor stalls a
/// virtual CPU for milliseconds now and then (measured here: loop wake-up p99.99 4 ms,
/// max 6 to 66 ms), longer than the 3 cycles of TPDOs the shipped configuration tolerates. The
/// copy raises `can.tpdo_misses_to_fault`, `service.watchdog_deadline_ms` and
/// `can.heartbeat_timeout_ms` to the tolerance; everything else is unchanged. Written to
/// `dir/machine.toml` (see [`relaxed_machine_text`]).
pub fn relaxed_machine(file: &Path, dir: &Path, tolerance_ms: u32) -> Result<(PathBuf, String), String> {
    let (text, note) = relaxed_machine_text(file, tolerance_ms)?;
    Ok((write_machine(dir, &text)?, note))
}

/// [`relaxed_machine`]'s file as text, validated before anything is written (a tolerance
/// the validation refuses is refused here, naming the key), and a note saying what changed.
pub fn relaxed_machine_text(file: &Path, tolerance_ms: u32) -> Result<(String, String), String> {
    let text = std::fs::read_to_string(file).map_err(|e| format!("{}: {e}", file.display()))?;
    let mut t: toml::Table = text.parse().map_err(|e| format!("{}: {e}", file.display()))?;
    let set = |t: &mut toml::Table, sec: &str, key: &str, v: i64| -> Option<i64> {
        let s = t.get_mut(sec)?.as_table_mut()?;
        let old = s.get(key)?.as_integer()?;
        let new = old.max(v);
        s.insert(key.into(), toml::Value::Integer(new));
        Some(new)
    };
    let n = i64::from(tolerance_ms);
    let misses = set(&mut t, "can", "tpdo_misses_to_fault", n);
    let hb = set(&mut t, "can", "heartbeat_timeout_ms", (10 * n).max(250));
    let wd = set(&mut t, "service", "watchdog_deadline_ms", 2 * n);
    let relaxed = format!(
        "# {} with bus timing relaxed for a virtual machine\n{t}",
        file.display()
    );
    let origin = format!("{} relaxed to a tolerance of {tolerance_ms} ms", file.display());
    MachineConfig::parse(Path::new(&origin), &relaxed).map_err(|e| e.to_string())?;
    Ok((
        relaxed,
        format!(
            "timing relaxed for a virtual machine (--strict: as configured): TPDOs may be missing {} cycles, heartbeat timeout {} ms, watchdog deadline {} ms",
            misses.unwrap_or(0),
            hb.unwrap_or(0),
            wd.unwrap_or(0)
        ),
    ))
}

/// Writes a machine file's `text` to `dir/machine.toml`.
pub fn write_machine(dir: &Path, text: &str) -> Result<PathBuf, String> {
    let out = dir.join("machine.toml");
    std::fs::write(&out, text).map_err(|e| format!("{}: {e}", out.display()))?;
    Ok(out)
}

/// The processes of the demo; killed when dropped (an error half-way leaves nothing behind).
#[derive(Debug, Default)]
pub struct Processes {
    children: Vec<(&'static str, Child)>,
}

impl Processes {
    pub fn spawn(&mut self, name: &'static str, mut cmd: Command, log: &Path) -> Result<(), String> {
        let err = std::fs::File::create(log).map_err(|e| format!("{}: {e}", log.display()))?;
        let out = err.try_clone().map_err(|e| e.to_string())?;
        let child = cmd
            .stdin(Stdio::null())
            .stdout(out)
            .stderr(err)
            .spawn()
            .map_err(|e| format!("{name}: {e}"))?;
        self.children.push((name, child));
        Ok(())
    }

    /// SIGTERM to `name` and wait up to `wait` for it to exit.
    pub fn stop(&mut self, name: &str, wait: Duration) {
        if let Some((_, c)) = self.children.iter_mut().find(|(n, _)| *n == name) {
            let _ = kill(Pid::from_raw(c.id() as i32), Signal::SIGTERM);
            let end = Instant::now() + wait;
            while Instant::now() < end {
                if let Ok(Some(_)) = c.try_wait() {
                    return;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            let _ = c.kill();
            let _ = c.wait();
        }
    }

    /// A child that exited already: its name and status.
    pub fn dead(&mut self) -> Option<String> {
        self.children
            .iter_mut()
            .find_map(|(n, c)| c.try_wait().ok().flatten().map(|s| format!("{n} exited ({s})")))
    }
}

impl Drop for Processes {
    fn drop(&mut self) {
        for (_, c) in &mut self.children {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// A binary next to this one (`target/release/hob` -> `target/release/hob-rt`).
pub fn sibling(name: &str) -> Result<PathBuf, String> {
    let me = std::env::current_exe().map_err(|e| e.to_string())?;
    let p = me.with_file_name(name);
    if p.exists() {
        Ok(p)
    } else {
        Err(format!(
            "{} not found next to {}: build all binaries (cargo build --release --workspace --bins)",
            name,
            me.display()
        ))
    }
}
