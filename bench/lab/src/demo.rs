//! `hob demo [PROGRAM]`: the virtual machine, `hob-rt`, the logger and the watchdog as
//! separate processes on `vcan0` (or, where the kernel has no CAN, the shared-memory
//! virtual CAN bus); loads the program, cuts it with a progress bar, prints the summary.
//! The last line is `log: PATH`.

use hob_cli::service;
use hob_ipc::codec::{self, State};
use hob_ipc::{CommandRequest, Ports, StateSample, StatsSample};
use hob_setup::config::machine::MachineConfig;
use hob_store::library::{Kind, Library};
use hob_virtual_machine::procs::{Processes, relaxed_machine_text, sibling, write_machine};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

pub const DEMO_PROGRAM: &str = "config/programs/demo-short-spur-z17-m5.toml";

#[derive(Debug)]
pub struct DemoArgs<'a> {
    pub program: &'a Path,
    pub machine_file: &'a Path,
    pub plant: &'a Path,
    pub iface: Option<&'a str>,
    pub log_dir: Option<&'a Path>,
    pub quiet: bool,
    /// Use the machine configuration's bus and watchdog timing as they are.
    pub strict: bool,
    /// Otherwise: how long the bus may be silent before it is a fault, ms.
    pub tolerance_ms: u32,
    /// X and Y power up within this many mm of their home (`hob-sim --power-on-near-home`:
    /// a short referencing); `None`: anywhere in their travel.
    pub near_home_mm: Option<f64>,
}

/// Where the demo keeps its logs when no `--log-dir` is given: `$XDG_STATE_HOME/hob`, else
/// `~/.local/state/hob` (never the current directory, which may be a checkout).
pub fn state_dir() -> Option<PathBuf> {
    state_dir_in(|k| std::env::var_os(k))
}

fn state_dir_in(env: impl Fn(&str) -> Option<std::ffi::OsString>) -> Option<PathBuf> {
    let nonempty = |k: &str| env(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    nonempty("XDG_STATE_HOME")
        .filter(|p| p.is_absolute())
        .or_else(|| nonempty("HOME").map(|h| h.join(".local/state")))
        .map(|d| d.join("hob"))
}

fn bar(done: f64, width: usize) -> String {
    let n = ((done.clamp(0.0, 1.0)) * width as f64).round() as usize;
    format!("[{}{}]", "#".repeat(n), ".".repeat(width - n))
}

fn wait_for(
    ports: &Ports,
    procs: &mut Processes,
    timeout: Duration,
    what: &str,
    ok: impl Fn(State, &StateSample) -> bool,
) -> Result<StateSample, String> {
    let end = Instant::now() + timeout;
    loop {
        if let Some(s) = ports.wait_state(Duration::from_millis(200))
            && State::from_code(s.state).is_some_and(|st| ok(st, &s))
        {
            return Ok(s);
        }
        if let Some(d) = procs.dead() {
            return Err(format!("{what}: {d}"));
        }
        if Instant::now() > end {
            return Err(format!("{what}: not reached within {} s", timeout.as_secs()));
        }
    }
}

/// The machine file the demo runs on: with `--strict` the configured one as it is (`None`:
/// nothing written, the tolerance not looked at); else a copy with the bus and watchdog
/// timing relaxed by `tolerance_ms` for a virtual machine's stalls, refused (`Err`, the
/// keys) when its validation refuses it.
fn machine_for_demo(
    strict: bool,
    machine_file: &Path,
    tolerance_ms: u32,
) -> Result<Option<(String, String)>, String> {
    if strict {
        return Ok(None);
    }
    relaxed_machine_text(machine_file, tolerance_ms).map(Some)
}

/// The binaries the demo starts beside itself.
pub const SIBLINGS: [&str; 4] = ["hob-rt", "hob-sim", "hob-logger", "hob-watchdog"];

/// Run by `cargo run` (which names itself in `CARGO`), the demo first has cargo build the
/// binaries it starts, in its own profile: `cargo run --release -p hob-lab -- demo` is the
/// whole quick start on a fresh clone. Run as an installed binary, it builds nothing.
fn build_siblings(binaries: &[&str], say: &dyn Fn(&str)) -> Result<(), String> {
    let Some(cargo) = std::env::var_os("CARGO") else {
        return Ok(());
    };
    let me = std::env::current_exe().map_err(|e| e.to_string())?;
    let profile_dir = me.parent().and_then(Path::file_name).and_then(|n| n.to_str());
    // The whole workspace's binaries: the same features (and so the same artifacts) as the
    // build of the test command and of the README's install.
    let mut c = Command::new(cargo);
    c.args(["build", "--workspace", "--bins"]);
    match profile_dir {
        Some("release") => {
            c.arg("--release");
        }
        Some("debug") => {}
        _ => return Ok(()), // not in a cargo target directory: nothing to build
    }
    say(&format!("building {} (cargo build, once)", binaries.join(", ")));
    let status = c.status().map_err(|e| format!("cargo build: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("cargo build of the demo's binaries failed ({status})"))
    }
}

/// The simulated machine and the service, running: the processes `hob demo` started and
/// where they write.
#[derive(Debug)]
pub struct Started {
    pub procs: Processes,
    /// The log directory (the recording, each process's log, the demo's machine file).
    pub dir: PathBuf,
    pub iface: String,
    pub instance: String,
    /// The machine file the processes run on (the relaxed copy unless `--strict`).
    pub machine_file: PathBuf,
}

/// What `hob demo` and `hob demo --hmi` share: checks the program and the tolerance, has
/// cargo build the binaries when run by it and checks that `binaries` are all there (each
/// a refusal, exit 2, before anything is written), makes the log directory, then starts
/// `hob-sim`, the logger, `hob-rt` and the watchdog on a bus instance of their own.
/// `title` opens the first line it says.
pub fn start(
    machine: &MachineConfig,
    a: &DemoArgs<'_>,
    title: &str,
    binaries: &[&str],
) -> Result<Started, (u8, String)> {
    let fail = |e: String| (1, e);
    hob_store::files::plan_file(a.program, machine).map_err(|e| (2, e.to_string()))?;
    if let Some(mm) = a.near_home_mm
        && !(mm.is_finite() && mm > 0.0)
    {
        return Err((2, format!("--near-home {mm}: must be a distance above 0 mm")));
    }
    let iface = a.iface.map_or_else(
        || hob_can_transport::shm::default_iface().to_string(),
        str::to_string,
    );
    // Refused before anything is created: a tolerance the machine file's validation refuses.
    let relaxed = machine_for_demo(a.strict, a.machine_file, a.tolerance_ms).map_err(|e| (2, e))?;
    let instance = std::env::var("HOB_INSTANCE").unwrap_or_else(|_| format!("demo-{}", std::process::id()));
    hob_ipc::use_instance(&instance);
    let say = |s: &str| {
        if !a.quiet {
            eprintln!("{s}");
        }
    };
    say(&format!(
        "{title}: {} on {} ({}), instance {instance}",
        a.program.display(),
        iface,
        if iface == "shm" {
            "shared-memory virtual CAN bus: this kernel has no vcan0"
        } else {
            "SocketCAN"
        }
    ));
    build_siblings(binaries, &say).map_err(fail)?;
    // Every binary there before anything is written or started: refused otherwise.
    for b in binaries {
        sibling(b).map_err(|e| (2, e))?;
    }
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let dir = match a.log_dir {
        Some(d) => d.to_path_buf(),
        None => state_dir()
            .ok_or_else(|| {
                fail("no per-user state directory (HOME and XDG_STATE_HOME unset): give --log-dir DIR".into())
            })?
            .join(format!("demo-{stamp}")),
    };
    std::fs::create_dir_all(&dir).map_err(|e| fail(format!("{}: {e}", dir.display())))?;
    let machine_path = match &relaxed {
        None => a.machine_file.to_path_buf(),
        Some((text, note)) => {
            say(note);
            write_machine(&dir, text).map_err(fail)?
        }
    };
    let mut procs = Processes::default();
    let machine_file = machine_path.to_str().unwrap_or("config/machine.toml");
    let cmd = |name: &str| -> Result<Command, (u8, String)> {
        let mut c = Command::new(sibling(name).map_err(fail)?);
        c.env("HOB_INSTANCE", &instance);
        Ok(c)
    };
    let mut sim = cmd("hob-sim")?;
    sim.args([
        "--iface",
        &iface,
        "--machine",
        machine_file,
        "--rt-priority",
        "75",
    ])
    .arg("--plant")
    .arg(a.plant)
    .arg("--program")
    .arg(a.program)
    // The machine's truth beside the recording: the report grades the cut by it.
    .arg("--truth")
    .arg(dir.join(hob_logger::truth::FILE));
    if let Some(mm) = a.near_home_mm {
        sim.arg("--power-on-near-home").arg(mm.to_string());
    }
    procs
        .spawn("hob-sim", sim, &dir.join("hob-sim.log"))
        .map_err(fail)?;
    std::thread::sleep(Duration::from_millis(300));
    let mut logger = cmd("hob-logger")?;
    logger.arg(&dir);
    procs
        .spawn("hob-logger", logger, &dir.join("hob-logger.log"))
        .map_err(fail)?;
    // The demo's own machine state (work offsets), never the machine PC's.
    let mut rt = cmd("hob-rt")?;
    rt.args(["--iface", &iface, "--machine", machine_file])
        .arg("--state-file")
        .arg(dir.join("machine-state.toml"));
    procs.spawn("hob-rt", rt, &dir.join("hob-rt.log")).map_err(fail)?;
    let mut wd = cmd("hob-watchdog")?;
    wd.args(["--iface", &iface, "--machine", machine_file]);
    procs
        .spawn("hob-watchdog", wd, &dir.join("hob-watchdog.log"))
        .map_err(fail)?;
    Ok(Started {
        procs,
        dir,
        iface,
        instance,
        machine_file: machine_path,
    })
}

/// The program `a.program` in the demo's own program library `DIR/library`, as the shop's
/// would hold it (replacing one of its name): its name there and its text, resolved.
pub fn into_library(
    machine: &MachineConfig,
    program: &Path,
    library: &Path,
) -> Result<(String, String), (u8, String)> {
    let fail = |e: String| (1, e);
    let name = program
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("program")
        .to_string();
    let text = std::fs::read_to_string(program).map_err(|e| (2, format!("{}: {e}", program.display())))?;
    let lib = Library::open(library).map_err(|e| fail(e.to_string()))?;
    if lib
        .names(Kind::Program)
        .map_err(|e| fail(e.to_string()))?
        .contains(&name)
    {
        lib.delete(Kind::Program, &name)
            .map_err(|e| fail(e.to_string()))?;
    }
    lib.create_program(&name, &text, machine)
        .map_err(|e| (2, format!("library: {e}")))?;
    let origin = lib.path(Kind::Program, &name).map_err(|e| fail(e.to_string()))?;
    let stored = lib.text(Kind::Program, &name).map_err(|e| fail(e.to_string()))?;
    let text = lib
        .resolve(&origin, &stored)
        .map_err(|e| (2, format!("library: {e}")))?;
    Ok((name, text))
}

pub fn run(machine: &MachineConfig, a: &DemoArgs<'_>) -> Result<String, (u8, String)> {
    let fail = |e: String| (1, e);
    let plan = hob_store::files::plan_file(a.program, machine).map_err(|e| (2, e.to_string()))?;
    let say = |s: &str| {
        if !a.quiet {
            eprintln!("{s}");
        }
    };
    let Started {
        mut procs,
        dir,
        iface,
        ..
    } = start(machine, a, "hob demo", &SIBLINGS)?;
    let ports =
        Ports::subscribe(&format!("hob-demo-{}", std::process::id())).map_err(|e| fail(e.to_string()))?;
    say("waiting for power-up (drives enabled, lubrication, safety chain)...");
    wait_for(&ports, &mut procs, Duration::from_secs(60), "power-up", |s, _| {
        s == State::Idle
    })
    .map_err(fail)?;
    // The drives count from wherever the machine stood at power-on: X and Y reference by
    // their own homing before anything but a slow jog is accepted.
    say("referencing X and Y (the drives' homing: home switch, then index pulse)...");
    let home = service::home("all").and_then(|r| service::request(&r));
    say(&home.map_err(|e| (e.exit_code(), format!("home: {e}")))?);
    let referenced = wait_for(
        &ports,
        &mut procs,
        Duration::from_secs(300),
        "referencing",
        |s, x| s == State::Idle && x.referenced & 0b110 == 0b110,
    )
    .map_err(fail)?;
    say(&format!(
        "referenced: X {:.3} mm, Y {:.3} mm",
        referenced.x_mm.actual, referenced.y_mm.actual
    ));
    // The program goes through the demo's own program library, as the shop's would.
    let library = dir.join("library");
    let (name, text) = into_library(machine, a.program, &library)?;
    say(&format!("program from the library {}: {name}", library.display()));
    let req = CommandRequest::load_program(&format!("library program {name}"), &text)
        .map_err(|e| (2, e.to_string()))?;
    say(&service::request(&req).map_err(|e| (e.exit_code(), format!("load: {e}")))?);
    say(&service::request(&service::start(false)).map_err(|e| (e.exit_code(), format!("start: {e}")))?);

    // Progress: pass, Y, time left, sync error.
    let total_s = plan.total_time_s;
    let period_s = f64::from(machine.control.cycle_period_us) * 1e-6;
    let timeout = Duration::from_secs_f64(total_s * 4.0 + 120.0);
    let end = Instant::now() + timeout;
    let mut start_cycle = None;
    let mut left_idle = false;
    let mut last_draw = Instant::now();
    let mut fault = None;
    loop {
        let Some(s) = ports.wait_state(Duration::from_millis(500)) else {
            return Err(fail(
                procs.dead().unwrap_or_else(|| "hob-rt stopped publishing".into()),
            ));
        };
        let state = State::from_code(s.state).unwrap_or(State::Init);
        let c0 = *start_cycle.get_or_insert(s.cycle);
        left_idle |= state != State::Idle;
        if state == State::Faulted {
            fault = Some(codec::alarm_text(&s.alarm));
            break;
        }
        if left_idle && state == State::Idle {
            break;
        }
        if Instant::now() > end {
            return Err(fail(format!(
                "the cut did not finish within {} s",
                timeout.as_secs()
            )));
        }
        if !a.quiet && last_draw.elapsed() > Duration::from_millis(250) {
            last_draw = Instant::now();
            let elapsed_s = (s.cycle - c0) as f64 * period_s;
            let left = (total_s - elapsed_s).max(0.0);
            eprint!(
                "\r{} pass {}/{}  {:<11} Y {:8.2} mm  left {:>3.0}:{:02.0}  sync {:+7.3} arcsec ",
                bar(elapsed_s / total_s, 24),
                s.pass,
                s.passes_total,
                codec::state_name(s.state),
                s.y_mm.actual,
                (left / 60.0).floor(),
                left % 60.0,
                s.sync_error_arcsec
            );
            let _ = std::io::stderr().flush();
        }
    }
    if !a.quiet {
        eprintln!();
    }
    // The loop's timing as published, then everything stopped in order: the watchdog
    // first (a stopping loop is not a failure), the loop, the logger (it drains), the
    // machine.
    std::thread::sleep(Duration::from_millis(600));
    let stats: Option<StatsSample> = ports.latest_stats();
    procs.stop("hob-watchdog", Duration::from_secs(2));
    procs.stop("hob-rt", Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(100));
    procs.stop("hob-logger", Duration::from_secs(5));
    procs.stop("hob-sim", Duration::from_secs(2));

    let mut o = String::new();
    if let Some(f) = &fault {
        let _ = writeln!(
            o,
            "FAULT: {f} (the machine retracted and stopped; see {}/events.log)",
            dir.display()
        );
    }
    match hob_logger::export::report(&dir) {
        Ok(r) => o.push_str(&hob_logger::export::report_text(&dir, &r)),
        Err(e) => {
            let _ = writeln!(o, "no per-pass report: {e}");
        }
    }
    if let Ok(t) = std::fs::read_to_string(dir.join("logger.json"))
        && let Ok(j) = serde_json::from_str::<serde_json::Value>(&t)
    {
        let _ = writeln!(
            o,
            "recorded: {} samples, {} lost; {} events, {} lost",
            j["samples"], j["samples_lost"], j["events"], j["events_lost"]
        );
    }
    if let Some(x) = stats {
        let us = |n: u64| n as f64 / 1e3;
        let w = &x.wake_latency;
        let c = &x.compute;
        let _ = writeln!(
            o,
            "loop: {} cycles, {} overruns; wake latency us p50 {:.1} p99 {:.1} p99.9 {:.1} max {:.1}; compute us p50 {:.1} p99.9 {:.1} max {:.1}; {}, {}; system heap allocations in cycles: {}",
            w.count,
            x.overruns,
            us(w.p50_ns),
            us(w.p99_ns),
            us(w.p999_ns),
            us(w.max_ns),
            us(c.p50_ns),
            us(c.p999_ns),
            us(c.max_ns),
            if x.fifo_priority > 0 {
                format!("SCHED_FIFO {}", x.fifo_priority)
            } else {
                "not SCHED_FIFO (degraded)".into()
            },
            if iface == "shm" {
                "shared-memory virtual CAN"
            } else {
                iface.as_str()
            },
            x.system_allocations_in_cycle
        );
    }
    let _ = writeln!(o, "log: {}", dir.display());
    if fault.is_some() {
        return Err((3, o));
    }
    Ok(o)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strict_runs_on_the_configured_machine_file_as_it_is() {
        let m = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/machine.toml");
        // --strict: no relaxed copy, and the tolerance is not even looked at.
        assert_eq!(machine_for_demo(true, &m, 600), Ok(None));
        // Without it: a relaxed copy that differs from the file, and a tolerance its
        // validation refuses is refused with the keys.
        let (text, note) = machine_for_demo(false, &m, 100)
            .unwrap_or_default()
            .unwrap_or_default();
        assert_ne!(text, std::fs::read_to_string(&m).unwrap_or_default());
        assert!(note.contains("100"), "{note}");
        let refused = machine_for_demo(false, &m, 600).unwrap_err();
        assert!(refused.contains("can.tpdo_misses_to_fault"), "{refused}");
    }

    #[test]
    fn the_log_goes_to_the_per_user_state_directory_never_the_current_one() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |k: &str| pairs.iter().find(|(n, _)| *n == k).map(|(_, v)| v.into())
        };
        assert_eq!(
            state_dir_in(env(&[("XDG_STATE_HOME", "/s"), ("HOME", "/h")])),
            Some(PathBuf::from("/s/hob"))
        );
        assert_eq!(
            state_dir_in(env(&[("HOME", "/h")])),
            Some(PathBuf::from("/h/.local/state/hob"))
        );
        // A relative XDG_STATE_HOME is invalid (XDG base directory spec): ignored.
        assert_eq!(
            state_dir_in(env(&[("XDG_STATE_HOME", "rel"), ("HOME", "/h")])),
            Some(PathBuf::from("/h/.local/state/hob"))
        );
        assert_eq!(state_dir_in(env(&[("XDG_STATE_HOME", "")])), None);
    }
}
