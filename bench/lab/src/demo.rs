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

/// Waits for a state sample `ok` accepts; `dead` names a process of the demo that exited.
/// The loop faulted (and `ok` does not take it) is an error at once, with its alarm.
pub fn wait_for(
    ports: &Ports,
    dead: &mut dyn FnMut() -> Option<String>,
    timeout: Duration,
    what: &str,
    ok: impl Fn(State, &StateSample) -> bool,
) -> Result<StateSample, String> {
    let end = Instant::now() + timeout;
    loop {
        if let Some(s) = ports.wait_state(Duration::from_millis(200))
            && let Some(st) = State::from_code(s.state)
        {
            if ok(st, &s) {
                return Ok(s);
            }
            if st == State::Faulted {
                return Err(format!(
                    "{what}: the loop faulted: {}",
                    codec::alarm_text(&s.alarm)
                ));
            }
        }
        if let Some(d) = dead() {
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
/// keys) when its validation refuses it. With `own_state` (`hob demo --compensate`) always
/// a copy (the timing as `strict` says), its `[state] file` the demo's own
/// (`DIR/machine-state.toml`): `hob compensate` keeps the compensation beside it, never
/// beside the machine PC's.
fn machine_for_demo(
    strict: bool,
    machine_file: &Path,
    tolerance_ms: u32,
    own_state: Option<&Path>,
) -> Result<Option<(String, String)>, String> {
    let copy = if strict {
        match own_state {
            None => return Ok(None),
            Some(_) => {
                let text = std::fs::read_to_string(machine_file)
                    .map_err(|e| format!("{}: {e}", machine_file.display()))?;
                (
                    text,
                    format!(
                        "{}: the bus timing as configured (--strict)",
                        machine_file.display()
                    ),
                )
            }
        }
    } else {
        relaxed_machine_text(machine_file, tolerance_ms)?
    };
    let Some(state) = own_state else {
        return Ok(Some(copy));
    };
    let (text, note) = copy;
    let quoted = serde_json::to_string(&state.display().to_string()).map_err(|e| e.to_string())?;
    let text =
        hob_store::machine_edit::replace_table(&text, "state", &format!("[state]\nfile = {quoted}\n\n"));
    let origin = format!("{} with the demo's own state file", machine_file.display());
    MachineConfig::parse(Path::new(&origin), &text).map_err(|e| e.to_string())?;
    Ok(Some((
        text,
        format!(
            "{note}; the machine state in {} and the pitch compensation beside it (never the machine PC's)",
            state.display()
        ),
    )))
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

/// Where the demo runs, before any process is started: its directory, its bus and
/// instance, its machine file.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The demo's directory (its machine file, its library, its machine state).
    pub dir: PathBuf,
    pub iface: String,
    pub instance: String,
    pub machine_file: PathBuf,
}

impl Prepared {
    /// The demo's own machine state file (work offsets; the pitch compensation beside it).
    pub fn state_file(&self) -> PathBuf {
        self.dir.join("machine-state.toml")
    }

    fn command(&self, name: &str) -> Result<Command, (u8, String)> {
        let mut c = Command::new(sibling(name).map_err(|e| (1, e))?);
        c.env("HOB_INSTANCE", &self.instance);
        Ok(c)
    }
}

/// What `hob demo` and `hob demo --hmi` share: [`prepare`], then `hob-sim` (its truth beside
/// the recording), the logger, `hob-rt` and the watchdog on a bus instance of their own.
pub fn start(
    machine: &MachineConfig,
    a: &DemoArgs<'_>,
    title: &str,
    binaries: &[&str],
) -> Result<Started, (u8, String)> {
    let p = prepare(machine, a, title, binaries, false)?;
    let mut procs = Processes::default();
    spawn_sim(&p, a, &p.dir.join(hob_logger::truth::FILE), &mut procs)?;
    spawn_service(&p, &p.dir, &mut procs)?;
    Ok(Started {
        procs,
        dir: p.dir,
        iface: p.iface,
        instance: p.instance,
        machine_file: p.machine_file,
    })
}

/// Checks the program and the tolerance, has cargo build the binaries when run by it and
/// checks that `binaries` are all there (each a refusal, exit 2, before anything is
/// written), makes the demo's directory and writes its machine file (with `own_state`, its
/// `[state] file` the demo's own, [`Prepared::state_file`]). `title` opens the first line
/// it says.
pub fn prepare(
    machine: &MachineConfig,
    a: &DemoArgs<'_>,
    title: &str,
    binaries: &[&str],
    own_state: bool,
) -> Result<Prepared, (u8, String)> {
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
    let dir = demo_dir(a.log_dir).map_err(fail)?;
    // Refused before anything is created: a tolerance the machine file's validation refuses.
    let state = dir.join("machine-state.toml");
    let machine_text = machine_for_demo(
        a.strict,
        a.machine_file,
        a.tolerance_ms,
        own_state.then_some(state.as_path()),
    )
    .map_err(|e| (2, e))?;
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
    std::fs::create_dir_all(&dir).map_err(|e| fail(format!("{}: {e}", dir.display())))?;
    let machine_file = match &machine_text {
        None => a.machine_file.to_path_buf(),
        Some((text, note)) => {
            say(note);
            write_machine(&dir, text).map_err(fail)?
        }
    };
    Ok(Prepared {
        dir,
        iface,
        instance,
        machine_file,
    })
}

/// The demo's directory: `--log-dir`, else `demo-UNIXTIME` in the per-user state
/// directory; absolute (the machine file names its state file by it).
fn demo_dir(log_dir: Option<&Path>) -> Result<PathBuf, String> {
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let dir = match log_dir {
        Some(d) => d.to_path_buf(),
        None => state_dir()
            .ok_or("no per-user state directory (HOME and XDG_STATE_HOME unset): give --log-dir DIR")?
            .join(format!("demo-{stamp}")),
    };
    std::path::absolute(&dir).map_err(|e| format!("{}: {e}", dir.display()))
}

/// `hob-sim` on the demo's bus, the program's blank on its table, its truth written to
/// `truth` (the report grades a cut by it), its log `DIR/hob-sim.log`.
pub fn spawn_sim(
    p: &Prepared,
    a: &DemoArgs<'_>,
    truth: &Path,
    procs: &mut Processes,
) -> Result<(), (u8, String)> {
    let mut sim = p.command("hob-sim")?;
    sim.arg("--iface")
        .arg(&p.iface)
        .arg("--machine")
        .arg(&p.machine_file)
        .args(["--rt-priority", "75"])
        .arg("--plant")
        .arg(a.plant)
        .arg("--program")
        .arg(a.program)
        .arg("--truth")
        .arg(truth);
    if let Some(mm) = a.near_home_mm {
        sim.arg("--power-on-near-home").arg(mm.to_string());
    }
    procs
        .spawn("hob-sim", sim, &p.dir.join("hob-sim.log"))
        .map_err(|e| (1, e))?;
    std::thread::sleep(Duration::from_millis(300));
    Ok(())
}

/// The service: the logger recording into `recording`, `hob-rt` with the demo's own machine
/// state (never the machine PC's) and the watchdog; their logs in `recording`.
pub fn spawn_service(p: &Prepared, recording: &Path, procs: &mut Processes) -> Result<(), (u8, String)> {
    let fail = |e: String| (1, e);
    let mut logger = p.command("hob-logger")?;
    logger.arg(recording);
    procs
        .spawn("hob-logger", logger, &recording.join("hob-logger.log"))
        .map_err(fail)?;
    let mut rt = p.command("hob-rt")?;
    rt.arg("--iface")
        .arg(&p.iface)
        .arg("--machine")
        .arg(&p.machine_file)
        .arg("--state-file")
        .arg(p.state_file());
    procs
        .spawn("hob-rt", rt, &recording.join("hob-rt.log"))
        .map_err(fail)?;
    let mut wd = p.command("hob-watchdog")?;
    wd.arg("--iface")
        .arg(&p.iface)
        .arg("--machine")
        .arg(&p.machine_file);
    procs
        .spawn("hob-watchdog", wd, &recording.join("hob-watchdog.log"))
        .map_err(fail)
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

/// Prints `s` on standard error unless `quiet`.
pub fn say(quiet: bool, s: &str) {
    if !quiet {
        eprintln!("{s}");
    }
}

/// Waits for the loop's power-up (drives enabled, lubrication, safety chain), then
/// references X and Y by the drives' own homing.
pub fn power_up_and_reference(
    ports: &Ports,
    dead: &mut dyn FnMut() -> Option<String>,
    quiet: bool,
) -> Result<(), (u8, String)> {
    let fail = |e: String| (1, e);
    say(
        quiet,
        "waiting for power-up (drives enabled, lubrication, safety chain)...",
    );
    wait_for(ports, dead, Duration::from_secs(60), "power-up", |s, _| {
        s == State::Idle
    })
    .map_err(fail)?;
    // The drives count from wherever the machine stood at power-on: X and Y reference by
    // their own homing before anything but a slow jog is accepted.
    say(
        quiet,
        "referencing X and Y (the drives' homing: home switch, then index pulse)...",
    );
    let home = service::home("all").and_then(|r| service::request(&r));
    say(quiet, &home.map_err(|e| (e.exit_code(), format!("home: {e}")))?);
    let referenced = wait_for(ports, dead, Duration::from_secs(300), "referencing", |s, x| {
        s == State::Idle && x.referenced & 0b110 == 0b110
    })
    .map_err(fail)?;
    say(
        quiet,
        &format!(
            "referenced: X {:.3} mm, Y {:.3} mm",
            referenced.x_mm.actual, referenced.y_mm.actual
        ),
    );
    Ok(())
}

/// Loads `program` through the demo's own program library `dir/library`, as the shop's
/// would hold it.
pub fn load_from_library(
    machine: &MachineConfig,
    program: &Path,
    dir: &Path,
    quiet: bool,
) -> Result<(), (u8, String)> {
    let library = dir.join("library");
    let (name, text) = into_library(machine, program, &library)?;
    say(
        quiet,
        &format!("program from the library {}: {name}", library.display()),
    );
    let req = CommandRequest::load_program(&format!("library program {name}"), &text)
        .map_err(|e| (2, e.to_string()))?;
    say(
        quiet,
        &service::request(&req).map_err(|e| (e.exit_code(), format!("load: {e}")))?,
    );
    Ok(())
}

/// Starts the loaded program and follows it to idle with a progress bar (pass, Y, time
/// left, sync error) unless `quiet`: `Some(alarm)` when it faulted.
pub fn cut(
    ports: &Ports,
    dead: &mut dyn FnMut() -> Option<String>,
    plan: &hob_setup::planner::Plan,
    period_s: f64,
    quiet: bool,
) -> Result<Option<String>, (u8, String)> {
    let fail = |e: String| (1, e);
    say(
        quiet,
        &service::request(&service::start(false)).map_err(|e| (e.exit_code(), format!("start: {e}")))?,
    );
    let total_s = plan.total_time_s;
    let timeout = Duration::from_secs_f64(total_s * 4.0 + 120.0);
    let end = Instant::now() + timeout;
    let mut start_cycle = None;
    let mut left_idle = false;
    let mut last_draw = Instant::now();
    let fault = loop {
        let Some(s) = ports.wait_state(Duration::from_millis(500)) else {
            return Err(fail(dead().unwrap_or_else(|| "hob-rt stopped publishing".into())));
        };
        let state = State::from_code(s.state).unwrap_or(State::Init);
        let c0 = *start_cycle.get_or_insert(s.cycle);
        left_idle |= state != State::Idle;
        if state == State::Faulted {
            break Some(codec::alarm_text(&s.alarm));
        }
        if left_idle && state == State::Idle {
            break None;
        }
        if Instant::now() > end {
            return Err(fail(format!(
                "the cut did not finish within {} s",
                timeout.as_secs()
            )));
        }
        if !quiet && last_draw.elapsed() > Duration::from_millis(250) {
            last_draw = Instant::now();
            progress(&s, (s.cycle - c0) as f64 * period_s, total_s);
        }
    };
    if !quiet {
        eprintln!();
    }
    Ok(fault)
}

/// One line of the progress bar, over the line before.
fn progress(s: &StateSample, elapsed_s: f64, total_s: f64) {
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

pub fn run(machine: &MachineConfig, a: &DemoArgs<'_>) -> Result<String, (u8, String)> {
    let fail = |e: String| (1, e);
    let plan = hob_store::files::plan_file(a.program, machine).map_err(|e| (2, e.to_string()))?;
    let Started {
        mut procs,
        dir,
        iface,
        ..
    } = start(machine, a, "hob demo", &SIBLINGS)?;
    let ports =
        Ports::subscribe(&format!("hob-demo-{}", std::process::id())).map_err(|e| fail(e.to_string()))?;
    let mut dead = || procs.dead();
    power_up_and_reference(&ports, &mut dead, a.quiet)?;
    load_from_library(machine, a.program, &dir, a.quiet)?;
    let period_s = f64::from(machine.control.cycle_period_us) * 1e-6;
    let fault = cut(&ports, &mut dead, &plan, period_s, a.quiet)?;
    // The loop's timing as published, then everything stopped in order.
    std::thread::sleep(Duration::from_millis(600));
    let stats: Option<StatsSample> = ports.latest_stats();
    stop_in_order(&mut procs);
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
    o.push_str(&recorded_and_loop(&dir, stats.as_ref(), &iface));
    let _ = writeln!(o, "log: {}", dir.display());
    if fault.is_some() {
        return Err((3, o));
    }
    Ok(o)
}

/// Stops the processes in order: the watchdog first (a stopping loop is not a failure),
/// the loop, the logger (it drains), the machine; those not in `procs` are passed over.
pub fn stop_in_order(procs: &mut Processes) {
    procs.stop("hob-watchdog", Duration::from_secs(2));
    procs.stop("hob-rt", Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(100));
    procs.stop("hob-logger", Duration::from_secs(5));
    procs.stop("hob-sim", Duration::from_secs(2));
}

/// The recording's samples and events (recorded, lost) and the loop's timing as it last
/// published it, a line each.
pub fn recorded_and_loop(dir: &Path, stats: Option<&StatsSample>, iface: &str) -> String {
    let mut o = String::new();
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
                iface
            },
            x.system_allocations_in_cycle
        );
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strict_runs_on_the_configured_machine_file_as_it_is() {
        let m = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/machine.toml");
        // --strict: no relaxed copy, and the tolerance is not even looked at.
        assert_eq!(machine_for_demo(true, &m, 600, None), Ok(None));
        // Without it: a relaxed copy that differs from the file, and a tolerance its
        // validation refuses is refused with the keys.
        let (text, note) = machine_for_demo(false, &m, 100, None)
            .unwrap_or_default()
            .unwrap_or_default();
        assert_ne!(text, std::fs::read_to_string(&m).unwrap_or_default());
        assert!(note.contains("100"), "{note}");
        let refused = machine_for_demo(false, &m, 600, None).unwrap_err();
        assert!(refused.contains("can.tpdo_misses_to_fault"), "{refused}");
    }

    #[test]
    fn with_its_own_state_the_demo_always_writes_a_copy_naming_its_state_file() {
        let m = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/machine.toml");
        let state = Path::new("/tmp/demo \"x\"/machine-state.toml");
        for strict in [true, false] {
            let (text, note) = machine_for_demo(strict, &m, 100, Some(state))
                .unwrap_or_default()
                .unwrap_or_default();
            let parsed = MachineConfig::parse(&m, &text).map_err(|e| e.to_string());
            assert_eq!(
                parsed.map(|c| c.state.file),
                Ok(state.display().to_string()),
                "{text}"
            );
            assert!(note.contains("machine-state.toml"), "{note}");
            // --strict: the timing as configured; else relaxed.
            let original = MachineConfig::parse(&m, &std::fs::read_to_string(&m).unwrap_or_default())
                .map(|c| c.can.tpdo_misses_to_fault)
                .ok();
            let misses = MachineConfig::parse(&m, &text)
                .map(|c| c.can.tpdo_misses_to_fault)
                .ok();
            assert_eq!(misses == original, strict, "{text}");
        }
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
