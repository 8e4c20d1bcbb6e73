//! `hob demo --hmi [PROGRAM]`: the simulated machine and the service as `hob demo` starts
//! them, and the touch HMI (`hob-hmi`) beside them on the loopback. It cuts nothing: it
//! prints the address to open, and the operator does the job on the page (POWER-UP, HOME
//! ALL, PROGRAMS: LOAD, AUTOMATIC: CYCLE START). It runs until Ctrl-C or SIGTERM, then
//! stops every process it started, each ending cleanly (no shared-memory files left).

use crate::demo::{self, DemoArgs, SIBLINGS, Started};
use hob_ipc::Ports;
use hob_ipc::codec::State;
use hob_setup::config::machine::MachineConfig;
use hob_virtual_machine::procs::{Processes, sibling};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How long `hob-hmi` may take to say where it serves.
const HMI_START: Duration = Duration::from_secs(20);

/// The line `hob-hmi` prints first (frontends/hmi/src/main.rs): `... at http://ADDR/ ...`.
const SERVING: &str = "serving the panel at ";

/// The HMI's two libraries (Preact and htm), which `hob-hmi` serves to the page: installed
/// beside the binaries (`BIN/../share/hob/hmi/vendor`, README "Deploying", step 5), else the
/// checkout's npm install (`frontends/hmi/node_modules`, relative to the current directory,
/// as the demo's other defaults). `None`: neither holds them.
fn vendor_dir(exe: &Path, cwd: &Path) -> Option<PathBuf> {
    let installed = exe.parent().map(|bin| bin.join("../share/hob/hmi/vendor"));
    let checkout = cwd.join("frontends/hmi/node_modules");
    installed
        .into_iter()
        .chain([checkout])
        .find(|d| d.join("preact").is_dir() && d.join("htm").is_dir())
}

/// The address in `hob-hmi`'s output, once it serves.
fn served_url(log: &str) -> Option<&str> {
    let rest = &log[log.find(SERVING)? + SERVING.len()..];
    rest.split_whitespace()
        .next()
        .filter(|u| u.starts_with("http://"))
}

/// The last line a process wrote to its log (why it exited, as it said it).
fn last_words(log: &Path) -> String {
    std::fs::read_to_string(log)
        .ok()
        .and_then(|t| t.lines().rev().find(|l| !l.trim().is_empty()).map(str::to_string))
        .unwrap_or_default()
}

/// A child that exited, with its last words and where its log is.
fn died(procs: &mut Processes, dir: &Path) -> Option<String> {
    let d = procs.dead()?;
    let name = d.split_whitespace().next().unwrap_or("");
    let log = dir.join(format!("{name}.log"));
    Some(format!("{d}: {} (its log: {})", last_words(&log), log.display()))
}

/// Stops every process in order: the HMI (no more commands), the watchdog (a stopping loop
/// is not a failure), the loop, the logger (it drains), the machine.
fn stop_all(procs: &mut Processes) {
    procs.stop("hob-hmi", Duration::from_secs(5));
    procs.stop("hob-watchdog", Duration::from_secs(2));
    procs.stop("hob-rt", Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(100));
    procs.stop("hob-logger", Duration::from_secs(5));
    procs.stop("hob-sim", Duration::from_secs(2));
}

/// What ended the run.
enum End {
    /// Ctrl-C or SIGTERM.
    Asked,
    /// A process exited by itself (what it said).
    Died(String),
}

/// Waits until `hob-hmi` says where it serves; `Err`: how the wait ended instead.
fn wait_for_url(procs: &mut Processes, dir: &Path, stop: &AtomicBool) -> Result<String, End> {
    let log = dir.join("hob-hmi.log");
    let end = Instant::now() + HMI_START;
    loop {
        if let Some(url) = served_url(&std::fs::read_to_string(&log).unwrap_or_default()) {
            return Ok(url.to_string());
        }
        if stop.load(Ordering::Relaxed) {
            return Err(End::Asked);
        }
        if let Some(d) = died(procs, dir) {
            return Err(End::Died(d));
        }
        if Instant::now() > end {
            return Err(End::Died(format!(
                "hob-hmi did not say where it serves within {} s (its log: {})",
                HMI_START.as_secs(),
                log.display()
            )));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

pub fn run(machine: &MachineConfig, a: &DemoArgs<'_>, port: u16) -> Result<String, (u8, String)> {
    let fail = |e: String| (1, e);
    let say = |s: &str| {
        if !a.quiet {
            eprintln!("{s}");
        }
    };
    // From here a Ctrl-C or SIGTERM is a request to stop everything in order.
    let stop = hob_rt_os::termination_flag();
    let exe = std::env::current_exe().map_err(|e| fail(e.to_string()))?;
    let cwd = std::env::current_dir().map_err(|e| fail(e.to_string()))?;
    // Refused before anything is written or started.
    let vendor = vendor_dir(&exe, &cwd).ok_or_else(|| {
        let installed = exe.parent().and_then(Path::parent).unwrap_or(Path::new("/"));
        (
            2,
            format!(
                "the HMI's web libraries (Preact and htm) are not installed: neither {} nor {} holds them; \
                 in the checkout run `npm ci --omit=dev --prefix frontends/hmi` (README, \"Deploying\", step 4)",
                installed.join("share/hob/hmi/vendor").display(),
                cwd.join("frontends/hmi/node_modules").display()
            ),
        )
    })?;
    let mut binaries = SIBLINGS.to_vec();
    binaries.push("hob-hmi");
    let Started {
        mut procs,
        dir,
        instance,
        machine_file,
        ..
    } = demo::start(machine, a, "hob demo --hmi", &binaries)?;
    // The program on the simulated machine's table, in the HMI's library.
    let library = dir.join("library");
    let (name, _) = demo::into_library(machine, a.program, &library)?;
    let mut hmi = Command::new(sibling("hob-hmi").map_err(fail)?);
    hmi.env("HOB_INSTANCE", &instance)
        .arg("--machine")
        .arg(&machine_file)
        .arg("--library")
        .arg(&library)
        .arg("--log-dir")
        .arg(&dir)
        .arg("--bind")
        .arg(format!("127.0.0.1:{port}"))
        .arg("--vendor")
        .arg(&vendor);
    procs
        .spawn("hob-hmi", hmi, &dir.join("hob-hmi.log"))
        .map_err(fail)?;
    let ports =
        Ports::subscribe(&format!("hob-demo-{}", std::process::id())).map_err(|e| fail(e.to_string()))?;

    let mut end = match wait_for_url(&mut procs, &dir, stop) {
        Ok(url) => {
            // The one line a newcomer needs, on stdout whatever --quiet says.
            println!("HMI: {url} (Ctrl-C stops everything)");
            let _ = std::io::stdout().flush();
            say(&format!(
                "on the page: POWER-UP (the simulated machine powers up by itself), HOME ALL; \
                 PROGRAMS: LOAD {name}; AUTOMATIC: CYCLE START (or SINGLE: START SINGLE); REPORT. \
                 Touch-off (JOG) is optional here: the blank sits where the program expects it."
            ));
            None
        }
        Err(e) => Some(e),
    };
    let mut powered_up = false;
    while end.is_none() {
        // Drains the state stream (also the wait between checks).
        if let Some(s) = ports.wait_state(Duration::from_millis(200))
            && !powered_up
            && State::from_code(s.state) == Some(State::Idle)
        {
            powered_up = true;
            say("the machine is powered up (idle): HOME ALL on the page references X and Y");
        }
        if stop.load(Ordering::Relaxed) {
            end = Some(End::Asked);
        } else if let Some(d) = died(&mut procs, &dir) {
            end = Some(End::Died(d));
        }
    }
    say("stopping the HMI, the watchdog, the loop, the recorder and the machine...");
    drop(ports);
    stop_all(&mut procs);
    let log = format!(
        "log: {} (hob log report {} reads the cuts)\n",
        dir.display(),
        dir.display()
    );
    match end {
        Some(End::Died(d)) => {
            let hint = if d.starts_with("hob-hmi") && d.contains("in use") {
                format!("; another program serves port {port}: give --port N (0: any free port)")
            } else {
                String::new()
            };
            Err((1, format!("{d}{hint}; everything stopped\n{log}")))
        }
        _ => Ok(log),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_address_is_read_from_the_hmis_first_line() {
        let out = "hob-hmi: serving the panel at http://127.0.0.1:40123/ (instance demo-7)\n";
        assert_eq!(served_url(out), Some("http://127.0.0.1:40123/"));
        assert_eq!(
            served_url("hob-hmi: --bind 127.0.0.1:8080: Address in use\n"),
            None
        );
        assert_eq!(served_url(""), None);
    }

    #[test]
    fn the_web_libraries_are_looked_for_installed_then_in_the_checkout() {
        let root = std::env::temp_dir().join(format!("hob-lab-vendor-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let exe = root.join("prefix/bin/hob-lab");
        let cwd = root.join("checkout");
        assert_eq!(vendor_dir(&exe, &cwd), None, "nothing installed");
        let checkout = cwd.join("frontends/hmi/node_modules");
        std::fs::create_dir_all(checkout.join("preact")).unwrap_or_default();
        assert_eq!(vendor_dir(&exe, &cwd), None, "htm missing");
        std::fs::create_dir_all(checkout.join("htm")).unwrap_or_default();
        assert_eq!(vendor_dir(&exe, &cwd), Some(checkout));
        let installed = root.join("prefix/bin/../share/hob/hmi/vendor");
        for lib in ["preact", "htm"] {
            std::fs::create_dir_all(installed.join(lib)).unwrap_or_default();
        }
        assert_eq!(vendor_dir(&exe, &cwd), Some(installed));
        let _ = std::fs::remove_dir_all(&root);
    }
}
