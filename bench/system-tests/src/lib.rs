//! The harness of the multi-process service tests (`tests/service.rs`): the binaries as a
//! user runs them, nothing of the project's libraries.
//!
//! A [`Bench`] is one test's set of processes (`hob-rt`, `hob-sim`, `hob-logger`,
//! `hob-watchdog`, a `hob status --watch`, `candump`), started from `HOB_BIN` (default
//! `target/release` of the workspace) on a bus instance of its own (`HOB_INSTANCE`), each
//! with its log in the test's artifacts directory, `target/service-artifacts/<test>/`. It
//! waits for conditions with a deadline ([`Bench::wait_for`]: on timeout it names what it
//! awaited and the last value it saw), reads `hob status --json` and the logger's
//! `logger.json` with serde, kills (`-9`), stops (`-STOP`), continues and restarts
//! processes. When it is dropped every process it started is killed; when that happens
//! because the test failed, it first prints the tail of every process's log.
//!
//! Environment (the knobs of the former `ci/service/run`):
//! - `HOB_BIN`: the binaries (default `target/release`, relative to the workspace root).
//! - `HOB_IFACE`: the CAN bus (default `vcan0` where the kernel has it, else `shm`, the
//!   shared-memory virtual CAN bus).
//! - `HOB_CYCLE_US`: run on the shipped machine file with `control.cycle_period_us` and
//!   `control.drive_delay_us` (CSP: one period) set to this.
//! - `HOB_TOLERANCE_MS`: the bus timing relaxation of `hob demo --tolerance-ms` (default
//!   100 ms, the demo's), also applied to the sessions' machine file.
//! - `HOB_SESSION_PROGRAM`: the sessions' program (default the demo's short job).
//! - `HOB_MIN_PACE`: the least pace of the loop that counts as kept (default 0.9).
//! - `HOB_SIM_BESIDE_LOOP=1`: read by `hob-sim` itself (`--beside-loop`); inherited.

use serde::Deserialize;
use std::fmt::Write as _;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// The workspace root (the binaries' working directory: relative paths in the machine
/// file and `hob demo`'s defaults are relative to it).
pub fn root() -> PathBuf {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    p.canonicalize().unwrap_or(p)
}

fn env_var(name: &str) -> Option<String> {
    std::env::var(name).ok().filter(|v| !v.is_empty())
}

/// A number from the environment, or `default`; a value that is not a number fails loudly.
pub fn env_num<T: std::str::FromStr>(name: &str, default: Option<T>) -> Option<T> {
    match env_var(name) {
        None => default,
        Some(v) => Some(v.parse().unwrap_or_else(|_| panic!("{name}={v}: not a number"))),
    }
}

/// Whether a test that involves no CAN is to be left out here: `HOB_CAN_TESTS_ONLY=1` (the
/// emulated guest, where the test command runs only what involves vcan0; the same test ran
/// on this host's bus earlier in the same run). Says so on stderr.
pub fn host_only(test: &str) -> bool {
    let skip = env_var("HOB_CAN_TESTS_ONLY").as_deref() == Some("1");
    if skip {
        eprintln!("{test}: involves no CAN: run on the host's bus, not here (HOB_CAN_TESTS_ONLY=1)");
    }
    skip
}

/// The CAN bus the tests use: `HOB_IFACE`, else `vcan0` where the kernel has it, else
/// `shm` (the shared-memory virtual CAN).
pub fn bus_iface() -> String {
    env_var("HOB_IFACE").unwrap_or_else(|| {
        if Path::new("/sys/class/net/vcan0").exists() {
            "vcan0".into()
        } else {
            "shm".into()
        }
    })
}

/// `HOB_MIN_PACE`, default 0.9.
pub fn min_pace() -> f64 {
    env_num("HOB_MIN_PACE", Some(0.9)).unwrap_or(0.9)
}

/// `HOB_SYNC_BOUND_FACTOR`, default 1: the demo's true sync error may reach this many times
/// the controller's bound. The emulated guest sets 2: its CPUs stall for tens of ms (the
/// loop's p99.9 wake-up 48 ms there, 2026-11-26), which no real-time machine does, and its
/// demo reached 1.98 and 2.59 um of 1.77 in two undisturbed runs that day (1.30 and 1.40 in
/// runs with a shorter tail); the host's run holds the bound itself.
pub fn sync_bound_factor() -> f64 {
    env_num("HOB_SYNC_BOUND_FACTOR", Some(1.0)).unwrap_or(1.0)
}

/// `HOB_TOLERANCE_MS`, default 100 (`hob demo --tolerance-ms`'s default).
pub fn tolerance_ms() -> u32 {
    env_num("HOB_TOLERANCE_MS", Some(100)).unwrap_or(100)
}

/// How near their home the simulated drives power up (`hob-sim --power-on-near-home`) in
/// the tests whose subject is not referencing: referencing over the whole way takes
/// about a minute, and the operator path still does it.
pub const SHORT_HOMING_MM: &str = "20";

/// The demo's short job, also the sessions' unless `HOB_SESSION_PROGRAM` names another.
pub const DEMO_PROGRAM: &str = "config/programs/demo-short-spur-z17-m5.toml";

/// `HOB_SESSION_PROGRAM` (relative to the workspace root), default the demo's job.
pub fn session_program() -> PathBuf {
    root().join(env_var("HOB_SESSION_PROGRAM").unwrap_or_else(|| DEMO_PROGRAM.into()))
}

/// A TOML file as typed values: keys are set only where they exist (a key that is not
/// there fails the test: it would no longer test what it says).
#[derive(Debug, Clone)]
pub struct TomlDoc {
    pub origin: PathBuf,
    pub table: toml::Table,
}

impl TomlDoc {
    pub fn load(path: &Path) -> TomlDoc {
        let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let table = text
            .parse::<toml::Table>()
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        TomlDoc {
            origin: path.to_path_buf(),
            table,
        }
    }

    fn slot(&mut self, dotted: &str) -> &mut toml::Value {
        let origin = self.origin.display().to_string();
        let mut keys = dotted.split('.');
        let last = keys.next_back().unwrap_or(dotted);
        let mut t = &mut self.table;
        for k in keys {
            t = t
                .get_mut(k)
                .and_then(toml::Value::as_table_mut)
                .unwrap_or_else(|| panic!("{origin}: no table [{k}] (looking for {dotted})"));
        }
        t.get_mut(last)
            .unwrap_or_else(|| panic!("{origin}: no key {dotted}"))
    }

    /// The value at `dotted` (`control.cycle_period_us`); fails if there is none.
    pub fn get(&self, dotted: &str) -> &toml::Value {
        let origin = self.origin.display();
        let mut keys = dotted.split('.');
        let last = keys.next_back().unwrap_or(dotted);
        let mut t = &self.table;
        for k in keys {
            t = t
                .get(k)
                .and_then(toml::Value::as_table)
                .unwrap_or_else(|| panic!("{origin}: no table [{k}] (looking for {dotted})"));
        }
        t.get(last).unwrap_or_else(|| panic!("{origin}: no key {dotted}"))
    }

    pub fn int(&self, dotted: &str) -> i64 {
        self.get(dotted)
            .as_integer()
            .unwrap_or_else(|| panic!("{}: {dotted} is not an integer", self.origin.display()))
    }

    /// Sets an existing key to `value`, of the same type as before.
    pub fn set(&mut self, dotted: &str, value: impl Into<toml::Value>) -> &mut Self {
        let value = value.into();
        let origin = self.origin.display().to_string();
        let slot = self.slot(dotted);
        assert_eq!(
            slot.type_str(),
            value.type_str(),
            "{origin}: {dotted} is a {}, not a {}",
            slot.type_str(),
            value.type_str()
        );
        *slot = value;
        self
    }

    /// Raises an existing integer key to at least `least`; returns the value set.
    pub fn raise(&mut self, dotted: &str, least: i64) -> i64 {
        let v = self.int(dotted).max(least);
        self.set(dotted, v);
        v
    }

    pub fn write(&self, to: &Path) -> PathBuf {
        let text = format!("# {} as set by a test\n{}", self.origin.display(), self.table);
        std::fs::write(to, text).unwrap_or_else(|e| panic!("{}: {e}", to.display()));
        to.to_path_buf()
    }
}

/// The fields of `hob status --json` the tests read.
#[derive(Debug, Clone, Deserialize)]
pub struct Status {
    pub cycle: u64,
    /// hob-rt's CLOCK_MONOTONIC at this cycle's SYNC.
    pub sync_time_ns: u64,
    pub state: String,
    /// Feed hold is on.
    pub hold: bool,
    pub program_loaded: bool,
    /// Empty when there is none.
    pub alarm: String,
    /// What the machine did on the alarm (its reaction, in the operator's words).
    #[serde(default)]
    pub alarm_reaction: String,
    /// What the drive the alarm names reported itself (its last EMCY).
    #[serde(default)]
    pub alarm_drive_reported: Option<String>,
    pub stats: Option<LoopStats>,
    /// The table's angle, deg.
    pub table_deg: f64,
    /// The spindle's speed as the loop measures it.
    pub spindle_rpm: f64,
    /// Work positions (machine position plus the work offset).
    pub x_mm: f64,
    pub y_mm: f64,
    pub pass: u32,
    pub x_referenced: bool,
    pub y_referenced: bool,
    /// The table kept its position since an interrupted part's tooth phase was recorded.
    pub table_position_whole: bool,
    pub x_offset_mm: f64,
    pub y_offset_mm: f64,
    pub feed_override_percent: f64,
    pub spindle_override_percent: f64,
    /// The pass `hob continue` would continue from.
    pub continue_pass: Option<u32>,
    /// Where `hob continue` would re-enter that pass's cut (none: at its start).
    #[serde(default)]
    pub continue_from_y_mm: Option<f64>,
    pub recorder: RecorderStatus,
}

impl Status {
    /// Cycles run per period elapsed on hob-rt's CLOCK_MONOTONIC from `earlier` to this
    /// (the test's clock means nothing in the emulated guest).
    pub fn pace_since(&self, earlier: &Status, cycle_us: f64) -> f64 {
        if self.sync_time_ns > earlier.sync_time_ns {
            (self.cycle - earlier.cycle) as f64 * cycle_us * 1e3
                / (self.sync_time_ns - earlier.sync_time_ns) as f64
        } else {
            0.0
        }
    }
}

/// `recorder` of `hob status --json`: the logger's health.
#[derive(Debug, Clone, Deserialize)]
pub struct RecorderStatus {
    pub alarm: bool,
    pub text: String,
    pub writing: Option<bool>,
    pub samples_unwritten: Option<u64>,
}

/// `stats` of `hob status --json`.
#[derive(Debug, Clone, Deserialize)]
pub struct LoopStats {
    pub overruns: u64,
    pub period_ns: u64,
    pub system_allocations_in_cycle: u64,
}

/// The logger's `logger.json`.
#[derive(Debug, Clone, Deserialize)]
pub struct LoggerStats {
    pub samples: u64,
    pub samples_lost: u64,
    pub samples_not_running: u64,
    pub samples_unwritten: u64,
    pub events_unwritten: u64,
    pub writing: bool,
}

impl LoggerStats {
    pub fn read(dir: &Path) -> Result<LoggerStats, String> {
        let p = dir.join("logger.json");
        let t = std::fs::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()))?;
        serde_json::from_str(&t).map_err(|e| format!("{}: {e}: {t}", p.display()))
    }
}

/// The watchdog's report of a trip: the JSON line it prints on stdout.
#[derive(Debug, Clone, Deserialize)]
pub struct WatchdogTrip {
    pub tripped: bool,
    /// What went silent or failed: `state` (the loop's stream), `sync` (its SYNC frames on
    /// the bus) or `loop` (the loop reported that it lost the machine).
    pub channel: String,
    /// For `state` and `sync`: the silence when the watchdog noticed it, on its own clock.
    pub silence_ms: Option<f64>,
    pub reason: String,
    pub frames_sent: u64,
    pub answers: u64,
    pub errors: u64,
}

impl WatchdogTrip {
    /// The first trip reported in the watchdog's log (its stdout and stderr).
    pub fn find(log: &str) -> Option<WatchdogTrip> {
        log.lines()
            .filter(|l| l.starts_with('{'))
            .find_map(|l| serde_json::from_str(l).ok())
    }
}

/// `hob-loop-double`'s report of the watchdog's reaction (one JSON line on stdout).
#[derive(Debug, Clone, Deserialize)]
pub struct DoubleSawReaction {
    pub pc_ok_dropped: bool,
    /// `sync` or `state`.
    pub muted: Option<String>,
    /// From the double's last sign of life on the muted channel to the watchdog's frame
    /// switching the coupler's outputs off, on the double's clock.
    pub ms_after_last_sign: Option<f64>,
}

impl DoubleSawReaction {
    pub fn find(log: &str) -> Option<DoubleSawReaction> {
        log.lines()
            .filter(|l| l.starts_with('{'))
            .find_map(|l| serde_json::from_str(l).ok())
    }
}

/// A finished `hob` call.
#[derive(Debug, Clone)]
pub struct Output {
    pub code: Option<i32>,
    pub stdout: String,
    /// stdout and stderr.
    pub text: String,
}

/// One process a [`Bench`] started.
#[derive(Debug)]
struct Proc {
    name: String,
    child: Child,
    log: PathBuf,
    /// Ended by the test (killed, terminated, waited for): not a failure when it is gone.
    ended: bool,
}

/// A process started by [`Bench::spawn`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProcId(usize);

/// One test's processes, bus instance and artifacts.
#[derive(Debug)]
pub struct Bench {
    pub root: PathBuf,
    pub bin: PathBuf,
    /// `target/service-artifacts/<test>/`.
    pub art: PathBuf,
    pub iface: String,
    pub instance: String,
    procs: Vec<Proc>,
    /// Log files of calls that are not processes of the bench (`hob demo`'s own logs).
    extra_logs: Vec<PathBuf>,
    started: Instant,
}

impl Bench {
    /// A fresh artifacts directory for `test` and a bus instance of its own.
    pub fn new(test: &str) -> Bench {
        let root = root();
        let bin = root.join(env_var("HOB_BIN").unwrap_or_else(|| "target/release".into()));
        for exe in [
            "hob",
            "hob-rt",
            "hob-sim",
            "hob-logger",
            "hob-watchdog",
            "hob-loop-double",
        ] {
            assert!(
                bin.join(exe).is_file(),
                "{}: not there; build the binaries first: cargo build --release --workspace --bins (or set HOB_BIN)",
                bin.join(exe).display()
            );
        }
        let art = root.join("target/service-artifacts").join(test);
        let _ = std::fs::remove_dir_all(&art);
        std::fs::create_dir_all(&art).unwrap_or_else(|e| panic!("{}: {e}", art.display()));
        let iface = bus_iface();
        let instance = format!("st-{}-{test}", std::process::id());
        eprintln!(
            "{test}: bus {iface}, instance {instance}, binaries {}, artifacts {}{}",
            bin.display(),
            art.display(),
            if env_var("HOB_SIM_BESIDE_LOOP").as_deref() == Some("1") {
                ", hob-sim beside the loop (HOB_SIM_BESIDE_LOOP=1)"
            } else {
                ""
            }
        );
        Bench {
            root,
            bin,
            art,
            iface,
            instance,
            procs: Vec::new(),
            extra_logs: Vec::new(),
            started: Instant::now(),
        }
    }

    /// The shipped machine file, on `HOB_CYCLE_US`'s cycle if it is set.
    pub fn base_machine(&self) -> TomlDoc {
        let mut m = TomlDoc::load(&self.root.join("config/machine.toml"));
        if let Some(us) = env_num::<i64>("HOB_CYCLE_US", None) {
            m.set("control.cycle_period_us", us);
            m.set("control.drive_delay_us", us);
            // The simulated drives' delay is the file's: its commissioning record moves with it.
            m.set("commissioning.drive_delay.found_us", us as f64);
        }
        m
    }

    /// `base_machine()` written to the artifacts (the shipped file itself when unchanged).
    pub fn base_machine_file(&self) -> PathBuf {
        match env_num::<i64>("HOB_CYCLE_US", None) {
            None => self.root.join("config/machine.toml"),
            Some(us) => {
                let f = self
                    .base_machine()
                    .write(&self.art.join(format!("machine-{us}us.toml")));
                eprintln!("control cycle: {us} us ({})", f.display());
                f
            }
        }
    }

    /// The sessions' machine: `base_machine()` with the bus timing relaxed as
    /// `hob demo --tolerance-ms HOB_TOLERANCE_MS` relaxes it (the former script ran its
    /// sessions on the demo's machine file; the demo test checks the two are the same).
    pub fn session_machine(&self) -> TomlDoc {
        let mut m = self.base_machine();
        let n = i64::from(tolerance_ms());
        m.raise("can.tpdo_misses_to_fault", n);
        m.raise("can.heartbeat_timeout_ms", (10 * n).max(250));
        m.raise("service.watchdog_deadline_ms", 2 * n);
        m
    }

    /// A command for one of the binaries: in the workspace root, on this bench's instance.
    pub fn command(&self, exe: &str) -> Command {
        let mut c = Command::new(self.bin.join(exe));
        c.current_dir(&self.root)
            .env("HOB_INSTANCE", &self.instance)
            .stdin(Stdio::null());
        c
    }

    /// A command for a program of the system (`candump`), in the workspace root.
    pub fn command_any(&self, exe: &str, args: &[&str]) -> Command {
        let mut c = Command::new(exe);
        c.args(args).current_dir(&self.root).stdin(Stdio::null());
        c
    }

    /// Starts `cmd` as `name`, stdout and stderr to `log` in the artifacts directory.
    pub fn spawn_cmd(&mut self, name: &str, mut cmd: Command, log: &str) -> ProcId {
        let log = self.art.join(log);
        let out = File::create(&log).unwrap_or_else(|e| panic!("{}: {e}", log.display()));
        let err = out
            .try_clone()
            .unwrap_or_else(|e| panic!("{}: {e}", log.display()));
        let child = cmd
            .stdout(out)
            .stderr(err)
            .spawn()
            .unwrap_or_else(|e| panic!("{name}: cannot start {:?}: {e}", cmd.get_program()));
        self.procs.push(Proc {
            name: name.to_string(),
            child,
            log,
            ended: false,
        });
        ProcId(self.procs.len() - 1)
    }

    /// The standard input of a process started with `Stdio::piped()` (for `hob-sim
    /// --control`: one fault per line).
    pub fn stdin_of(&mut self, p: ProcId) -> std::process::ChildStdin {
        let pr = &mut self.procs[p.0];
        pr.child
            .stdin
            .take()
            .unwrap_or_else(|| panic!("{}: no piped standard input", pr.name))
    }

    /// `hob home all`, then waits until X and Y are referenced and the loop is idle.
    pub fn reference(&mut self, timeout: Duration) -> Status {
        self.hob_ok(&["home", "all"]);
        self.wait_for("X and Y referenced, idle", timeout, |b| {
            let s = b.try_status()?;
            if s.state == "idle" && s.x_referenced && s.y_referenced {
                Ok(s)
            } else {
                Err(format!(
                    "state {}, referenced x {} y {} (alarm '{}')",
                    s.state, s.x_referenced, s.y_referenced, s.alarm
                ))
            }
        })
    }

    /// Starts the binary `exe` with `args` as `name`, its output in `log`.
    pub fn spawn<S: AsRef<std::ffi::OsStr>>(
        &mut self,
        name: &str,
        exe: &str,
        args: &[S],
        log: &str,
    ) -> ProcId {
        let mut c = self.command(exe);
        c.args(args);
        self.spawn_cmd(name, c, log)
    }

    pub fn pid(&self, p: ProcId) -> u32 {
        self.procs[p.0].child.id()
    }

    pub fn log_of(&self, p: ProcId) -> PathBuf {
        self.procs[p.0].log.clone()
    }

    /// Also print the tail of `log` when the test fails.
    pub fn add_log(&mut self, log: PathBuf) {
        self.extra_logs.push(log);
    }

    /// `kill -9`, and reap it.
    pub fn kill9(&mut self, p: ProcId) {
        let pr = &mut self.procs[p.0];
        pr.ended = true;
        let _ = pr.child.kill();
        let _ = pr.child.wait();
    }

    /// Sends `signal` (`STOP`, `CONT`, `TERM`) with kill(1): std has no signals but KILL.
    pub fn signal(&self, p: ProcId, signal: &str) {
        let pid = self.pid(p).to_string();
        let st = Command::new("kill")
            .args([format!("-{signal}"), pid])
            .status()
            .unwrap_or_else(|e| panic!("kill -{signal}: {e}"));
        assert!(st.success(), "kill -{signal} {}: {st}", self.procs[p.0].name);
    }

    /// `kill -TERM` and wait up to `wait` for it to exit (then `kill -9`).
    pub fn terminate(&mut self, p: ProcId, wait: Duration) -> Option<ExitStatus> {
        self.procs[p.0].ended = true;
        if let Ok(Some(st)) = self.procs[p.0].child.try_wait() {
            return Some(st);
        }
        self.signal(p, "TERM");
        let end = Instant::now() + wait;
        while Instant::now() < end {
            if let Ok(Some(st)) = self.procs[p.0].child.try_wait() {
                return Some(st);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        self.kill9(p);
        None
    }

    /// Waits for `p` to exit by itself within `timeout` (killed and failed otherwise).
    pub fn wait_exit(&mut self, p: ProcId, timeout: Duration) -> ExitStatus {
        let name = self.procs[p.0].name.clone();
        // Its exit is awaited, not a failure of the bench (a timeout kills it on drop).
        self.procs[p.0].ended = true;
        self.wait_for(&format!("{name} to finish"), timeout, |b| {
            match b.procs[p.0].child.try_wait() {
                Ok(Some(st)) => Ok(st),
                Ok(None) => Err("still running".into()),
                Err(e) => Err(e.to_string()),
            }
        })
    }

    /// Fails the test if a process it did not end itself has exited.
    pub fn check_alive(&mut self) {
        for pr in &mut self.procs {
            if !pr.ended
                && let Ok(Some(st)) = pr.child.try_wait()
            {
                pr.ended = true;
                panic!("{} exited ({st}); see {}", pr.name, pr.log.display());
            }
        }
    }

    /// Runs `hob ARGS` to the end.
    pub fn hob<S: AsRef<std::ffi::OsStr>>(&self, args: &[S]) -> Output {
        let out = self
            .command("hob")
            .args(args)
            .output()
            .unwrap_or_else(|e| panic!("cannot run hob: {e}"));
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        let text = format!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
        Output {
            code: out.status.code(),
            stdout,
            text: text.trim_end().to_string(),
        }
    }

    /// Runs `hob ARGS`; fails the test unless it succeeds.
    pub fn hob_ok<S: AsRef<std::ffi::OsStr>>(&self, args: &[S]) -> Output {
        let o = self.hob(args);
        let line: Vec<String> = args
            .iter()
            .map(|a| a.as_ref().to_string_lossy().into_owned())
            .collect();
        assert_eq!(o.code, Some(0), "hob {}: {}", line.join(" "), o.text);
        o
    }

    /// `hob status --json`, parsed.
    pub fn try_status(&self) -> Result<Status, String> {
        let o = self.hob(&["status", "--json"]);
        if o.code != Some(0) {
            return Err(format!("hob status --json: exit {:?}: {}", o.code, o.text));
        }
        serde_json::from_str(&o.stdout).map_err(|e| format!("hob status --json: {e}: {}", o.stdout))
    }

    pub fn status(&self) -> Status {
        self.try_status().unwrap_or_else(|e| panic!("{e}"))
    }

    /// Polls `f` until it gives a value, failing after `timeout` with what was awaited
    /// and the last thing `f` saw; fails at once if a process the test did not end exits.
    pub fn wait_for<T>(
        &mut self,
        what: &str,
        timeout: Duration,
        mut f: impl FnMut(&mut Bench) -> Result<T, String>,
    ) -> T {
        let t0 = Instant::now();
        loop {
            self.check_alive();
            let last = match f(self) {
                Ok(v) => return v,
                Err(seen) => seen,
            };
            if t0.elapsed() > timeout {
                panic!(
                    "timed out after {:.0} s waiting for {what}; last seen: {last}",
                    t0.elapsed().as_secs_f64()
                );
            }
            std::thread::sleep(Duration::from_millis(300));
        }
    }

    /// Waits until `hob status` shows `state`.
    pub fn wait_state(&mut self, state: &str, timeout: Duration) -> Status {
        self.wait_for(&format!("state {state}"), timeout, |b| {
            let s = b.try_status()?;
            if s.state == state {
                Ok(s)
            } else {
                Err(format!("state {} (alarm '{}')", s.state, s.alarm))
            }
        })
    }

    /// Runs a named step of the test: `PASS [elapsed] name: detail` when `f` returns,
    /// `FAIL [elapsed] name` when it panics.
    pub fn step(&mut self, name: &str, f: impl FnOnce(&mut Bench) -> String) {
        struct Guard<'a>(&'a str, Instant);
        impl Drop for Guard<'_> {
            fn drop(&mut self) {
                if std::thread::panicking() {
                    eprintln!("FAIL [{:.0} s] {}", self.1.elapsed().as_secs_f64(), self.0);
                }
            }
        }
        let g = Guard(name, self.started);
        eprintln!("--- {name}");
        let detail = f(self);
        eprintln!(
            "PASS [{:.0} s] {name}{}{detail}",
            g.1.elapsed().as_secs_f64(),
            if detail.is_empty() { "" } else { ": " }
        );
    }

    fn tails(&self) -> String {
        let mut o = String::new();
        let logs = self
            .procs
            .iter()
            .map(|p| (p.name.as_str(), &p.log))
            .chain(self.extra_logs.iter().map(|l| ("", l)));
        for (name, log) in logs {
            let text = std::fs::read_to_string(log).unwrap_or_else(|e| format!("({e})"));
            let lines: Vec<&str> = text.lines().collect();
            let from = lines.len().saturating_sub(20);
            let _ = writeln!(
                o,
                "==> {} {name} (last {} lines)",
                log.display(),
                lines.len() - from
            );
            for l in &lines[from..] {
                let _ = writeln!(o, "    {l}");
            }
        }
        o
    }
}

impl Drop for Bench {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("the test failed; the processes' logs:\n{}", self.tails());
        }
        // The last started first: the watchdog and the logger before the loop, the loop
        // before the machine (a watchdog outliving the loop would trip on the way out).
        for p in self.procs.iter_mut().rev() {
            let _ = p.child.kill();
            let _ = p.child.wait();
        }
    }
}

/// What the tests read of `hob log report`.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// The bound: a quarter of the grade 5 single pitch tolerance, um.
    pub bound_um: f64,
    /// Cycles missing from the log.
    pub missing: u64,
    /// Each pass's largest sync error at the pitch circle, um: the truth's where the
    /// simulated machine wrote one beside the log, else the controller's estimate.
    pub pass_max_um: Vec<f64>,
    /// Whether the report is graded by the simulated machine's truth (`truth.csv`).
    pub graded_by_truth: bool,
    /// The passes with a predicted gear (from the truth).
    pub predicted_passes: usize,
}

impl Report {
    /// Parses the report: the header line (`..., N missing; ... (bound: a quarter, B um)`)
    /// and one line per pass (`pass cut_s pass_s stood_s samples rms max | rms_um max_um
    /// pct % | ...`: the max um the second field after the first `|`).
    pub fn parse(text: &str) -> Result<Report, String> {
        let head = text.lines().next().ok_or("empty report")?;
        let after = |key: &str| -> Result<&str, String> {
            head.split_once(key)
                .map(|(_, r)| r)
                .ok_or_else(|| format!("no '{key}' in the report's first line: {head}"))
        };
        let bound_um = after("(bound: a quarter, ")?
            .split_whitespace()
            .next()
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| format!("no bound in: {head}"))?;
        let missing = head
            .split_once(" missing")
            .and_then(|(l, _)| l.rsplit(' ').next())
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| format!("no 'N missing' in: {head}"))?;
        let mut pass_max_um = Vec::new();
        let graded_by_truth = text
            .lines()
            .nth(1)
            .is_some_and(|l| l.starts_with("graded by the simulated machine's truth"));
        let predicted_passes = text
            .lines()
            .filter(|l| l.starts_with("  pass ") && l.contains(": predicted gear ("))
            .count();
        for l in text.lines().skip(1) {
            let f: Vec<&str> = l.split_whitespace().collect();
            if l.starts_with(' ') && f.first().is_some_and(|p| p.parse::<u32>().is_ok()) {
                let v = f
                    .iter()
                    .position(|f| *f == "|")
                    .and_then(|bar| f.get(bar + 2))
                    .and_then(|v| v.parse().ok())
                    .ok_or_else(|| format!("a pass line without its max um: {l}"))?;
                pass_max_um.push(v);
            }
        }
        Ok(Report {
            bound_um,
            missing,
            pass_max_um,
            graded_by_truth,
            predicted_passes,
        })
    }
}

/// The first columns of `hob log export --csv`.
pub const CSV_COLUMNS: [&str; 11] = [
    "t_s",
    "state",
    "pass",
    "spindle_deg",
    "table_deg",
    "table_cmd_deg",
    "x_mm",
    "x_cmd_mm",
    "y_mm",
    "y_cmd_mm",
    "sync_err_arcsec",
];

/// One frame of a `candump -L` capture: `(SECONDS) IFACE ID#DATA`.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    pub t_s: f64,
    pub id: u32,
    pub data: Vec<u8>,
}

pub fn parse_candump(text: &str) -> Vec<Frame> {
    text.lines()
        .filter_map(|l| {
            let (t, rest) = l.strip_prefix('(')?.split_once(')')?;
            let frame = rest.split_whitespace().nth(1)?;
            let (id, data) = frame.split_once('#')?;
            let data = (0..data.len())
                .step_by(2)
                .map(|i| u8::from_str_radix(data.get(i..i + 2)?, 16).ok())
                .collect::<Option<Vec<u8>>>()?;
            Some(Frame {
                t_s: t.parse().ok()?,
                id: u32::from_str_radix(id, 16).ok()?,
                data,
            })
        })
        .collect()
}

/// A frame of the watchdog's reaction (frontends/watchdog: `reaction()`): an SDO download
/// to the coupler (node 5: the digital outputs 0x6200, the spindle reference 0x6411), or
/// quick stop (controlword 0x6040 = 0x0002) to drives 2, 3, 4.
fn watchdog_frame(f: &Frame) -> bool {
    let d = &f.data;
    if d.len() != 8 || d[0] & 0xE0 != 0x20 {
        return false;
    }
    let index = u16::from(d[1]) | u16::from(d[2]) << 8;
    (f.id == 0x605 && (index == 0x6200 || index == 0x6411))
        || ([0x602, 0x603, 0x604].contains(&f.id) && index == 0x6040 && d[4] == 0x02)
}

/// The watchdog's reaction in a capture of `kill -9 hob-rt`: Ok(text) when the coupler
/// and all three drives got their frames (the coupler at least three) within 1.2 times the
/// deadline of hob-rt's last SYNC; Err(text) otherwise.
pub fn watchdog_reaction(frames: &[Frame], deadline_ms: f64) -> Result<String, String> {
    let first = frames
        .iter()
        .position(watchdog_frame)
        .ok_or_else(|| format!("no reaction frame in the capture ({} frames)", frames.len()))?;
    let last_sync = frames[..first]
        .iter()
        .rfind(|f| f.id == 0x080)
        .ok_or("no SYNC before the reaction in the capture")?;
    let reaction: Vec<u32> = frames[first..]
        .iter()
        .filter(|f| watchdog_frame(f))
        .map(|f| f.id)
        .collect();
    let ms = (frames[first].t_s - last_sync.t_s) * 1e3;
    let mut nodes = reaction.clone();
    nodes.sort_unstable();
    nodes.dedup();
    let ok = nodes == [0x602, 0x603, 0x604, 0x605]
        && reaction.iter().filter(|&&c| c == 0x605).count() >= 3
        && ms <= 1.2 * deadline_ms;
    let ids: Vec<String> = reaction.iter().map(|c| format!("{c:03X}")).collect();
    let text = format!(
        "{ms:.1} ms from hob-rt's last SYNC to the watchdog's first frame (deadline {deadline_ms:.0} ms), frames {}",
        ids.join(" ")
    );
    if ok { Ok(text) } else { Err(text) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_report_is_read() {
        let text = "target/x: 36520 samples, cycles 5 .. 36525, 0 missing; pitch radius 42.500 mm, ISO 1328-1 grade 5 single pitch tolerance 7.10 um (bound: a quarter, 1.77 um)\n\
                    pass  cut s  samples  sync error arcsec: rms    max   |  um at pitch circle: rms    max   of grade 5\n   \
                    1   20.1    20100                    0.100  0.400 |                    0.010  1.030      15 %\n   \
                    2   10.0    10000                    0.100  0.300 |                    0.010  0.800      11 %\n";
        let r = Report::parse(text).unwrap();
        assert_eq!(
            r,
            Report {
                bound_um: 1.77,
                missing: 0,
                pass_max_um: vec![1.03, 0.8],
                graded_by_truth: false,
                predicted_passes: 0,
            }
        );
        // Graded by the truth: its pass lines, the estimate's and the predicted gear's
        // lines are not passes.
        let truth = text.replacen(
            "\n",
            "\ngraded by the simulated machine's truth (truth.csv: 30100 of 36520 samples joined): the error is ...\n",
            1,
        ) + "  the controller's estimate, pass 1: rms 0.186 max 0.758 um\n  \
               pass 1: predicted gear (2 face sections): f_pt 2.43 um ...\n  \
               pass 2: predicted gear (3 face sections): f_pt 2.60 um ...\n";
        let r = Report::parse(&truth).unwrap();
        assert!(r.graded_by_truth);
        assert_eq!(r.predicted_passes, 2);
        assert_eq!(r.pass_max_um, vec![1.03, 0.8]);
        assert_eq!(
            Report::parse(&text.replace(" 0 missing", " 10 missing"))
                .unwrap()
                .missing,
            10
        );
    }

    fn sdo(id: u32, index: u16, v: u8, t_s: f64) -> String {
        let [lo, hi] = index.to_le_bytes();
        format!("({t_s:.6}) vcan0 {id:03X}#2B{lo:02X}{hi:02X}00{v:02X}000000")
    }

    #[test]
    fn the_watchdogs_reaction_is_found_in_a_capture() {
        let mut lines = vec![
            "(100.000000) vcan0 080#".to_string(),
            "(100.000200) vcan0 182#0102".to_string(),
            "(100.001000) vcan0 080#".to_string(),
        ];
        lines.push(sdo(0x605, 0x6200, 0, 100.201));
        lines.push(sdo(0x605, 0x6200, 0, 100.2011));
        lines.push(sdo(0x605, 0x6411, 0, 100.2012));
        for (i, id) in [0x602, 0x603, 0x604].into_iter().enumerate() {
            lines.push(sdo(id, 0x6040, 2, 100.2013 + i as f64 * 1e-4));
        }
        let frames = parse_candump(&lines.join("\n"));
        assert_eq!(frames.len(), 9);
        let ok = watchdog_reaction(&frames, 200.0).unwrap();
        assert!(ok.starts_with("200.0 ms"), "{ok}");
        // Too late for a 100 ms deadline; a drive missing.
        assert!(watchdog_reaction(&frames, 100.0).is_err());
        let frames = parse_candump(&lines[..8].join("\n"));
        assert!(watchdog_reaction(&frames, 200.0).is_err());
        assert!(watchdog_reaction(&[], 200.0).is_err());
    }

    #[test]
    fn a_missing_key_fails_loudly() {
        let mut d = TomlDoc {
            origin: "m.toml".into(),
            table: "[control]\ncycle_period_us = 1000\n".parse().unwrap(),
        };
        d.set("control.cycle_period_us", 2000);
        assert_eq!(d.int("control.cycle_period_us"), 2000);
        let missing = std::panic::catch_unwind(move || {
            d.set("control.drive_delay_us", 2000);
        });
        assert!(missing.is_err());
    }
}
