//! The multi-process tests of the service: `hob-sim` (the virtual machine), `hob-rt`,
//! `hob-logger`, `hob-watchdog` and the CLI as separate processes, over vcan0 where the
//! kernel has it, else the shared-memory virtual CAN bus (the harness: `src/lib.rs`).
//!
//! They need the release binaries and a bus, so they are ignored in the workspace's test
//! pass; `ci/test` runs them (one at a time on vcan0, which they would share; two at a
//! time on the shared-memory bus, where each has its own instance, the load test alone):
//!
//! ```sh
//! cargo build --release --workspace --bins
//! cargo test -p hob-system-tests --release -- --ignored --test-threads=1 --nocapture
//! ```
//!
//! Artifacts (each process's log, the demo's log and exported CSV) in
//! `target/service-artifacts/<test>/`.
#![allow(clippy::unwrap_used)]

use hob_system_tests::{
    Bench, CSV_COLUMNS, DoubleSawReaction, LoggerStats, ProcId, Report, SHORT_HOMING_MM, TomlDoc,
    WatchdogTrip, parse_candump, session_program, tolerance_ms, watchdog_reaction,
};
use std::path::Path;
use std::time::Duration;

/// How long power-up and reaching the cut may take (minutes in the emulated guest).
const STATE_TIMEOUT: Duration = Duration::from_secs(300);

/// `hob-sim` and `hob-rt` on `machine`, the session's program loaded into the simulator;
/// their logs `sim{n}.txt`, `rt{n}.txt`.
fn start_service(b: &mut Bench, machine: &Path, n: u32, homing: Homing) -> (ProcId, ProcId) {
    let (iface, machine, program) = (b.iface.clone(), path(machine), program_arg());
    let mut args = vec![
        "--iface",
        &iface,
        "--machine",
        &machine,
        "--program",
        &program,
        "--rt-priority",
        "75",
    ];
    if homing == Homing::Short {
        args.extend(["--power-on-near-home", SHORT_HOMING_MM]);
    }
    let sim = b.spawn("hob-sim", "hob-sim", &args, &format!("sim{n}.txt"));
    std::thread::sleep(Duration::from_millis(300));
    // The work offsets of this session only (never the machine PC's /var/lib/hob).
    let state = path(&b.art.join(format!("machine-state{n}.toml")));
    let rt = b.spawn(
        "hob-rt",
        "hob-rt",
        &["--iface", &iface, "--machine", &machine, "--state-file", &state],
        &format!("rt{n}.txt"),
    );
    (sim, rt)
}

/// A commissioning step that was refused or stopped changed nothing: `machine` reads as
/// `original`, and no old file was kept beside it in the bench's artifacts.
fn unchanged(b: &Bench, machine: &Path, original: &str, what: &str) {
    assert_eq!(
        std::fs::read_to_string(machine).unwrap(),
        original,
        "{what}: the machine file changed"
    );
    let kept: Vec<_> = std::fs::read_dir(&b.art)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.to_string_lossy().ends_with(".bak"))
        .collect();
    assert!(kept.is_empty(), "{what}: a file was kept: {kept:?}");
}

/// `hob-rt` on `machine` and this bench's bus, its work offsets in `state`, its log `log`.
fn spawn_rt(b: &mut Bench, machine: &Path, state: &Path, log: &str) -> ProcId {
    let iface = b.iface.clone();
    let (machine, state) = (path(machine), path(state));
    b.spawn(
        "hob-rt",
        "hob-rt",
        &["--iface", &iface, "--machine", &machine, "--state-file", &state],
        log,
    )
}

/// hob-sim on `machine` with the hidden values of `plant`, X and Y near home, its fault
/// injection on standard input (`--control`).
fn sim_on_plant(b: &Bench, machine: &Path, plant: &Path) -> std::process::Command {
    let mut sim = b.command("hob-sim");
    sim.args([
        "--iface",
        &b.iface,
        "--machine",
        &path(machine),
        "--plant",
        &path(plant),
        "--program",
        &program_arg(),
        "--rt-priority",
        "75",
        "--power-on-near-home",
        SHORT_HOMING_MM,
        "--control",
    ])
    .stdin(std::process::Stdio::piped());
    sim
}

/// Where the simulated drives power up: wherever the plant file says (referencing over
/// the whole way, the operator path's subject), or within [`SHORT_HOMING_MM`] of home
/// (tests whose subject is not referencing: each saves about 50 s of homing).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Homing {
    Full,
    Short,
}

fn path(p: &Path) -> String {
    p.display().to_string()
}

fn program_arg() -> String {
    session_program().display().to_string()
}

/// The demo's cut end to end: sync error within the control core's bound, no sample
/// lost, no system heap allocation in a cycle; and its relaxed machine file is the one the
/// session tests run on.
#[test]
#[ignore = "needs the release binaries and a bus; ci/test runs it (--ignored)"]
fn demo_cuts_end_to_end() {
    let mut b = Bench::new("demo_cuts_end_to_end");
    let machine = b.base_machine_file();
    let demo_dir = b.art.join("demo");
    b.step(
        "demo: cut end to end, sync error within the bound, no sample lost, no heap allocation in a cycle",
        |b| {
            let mut args = vec![
                "demo".to_string(),
                "--quiet".into(),
                "--machine".into(),
                machine.display().to_string(),
                "--iface".into(),
                b.iface.clone(),
                "--log".into(),
                demo_dir.display().to_string(),
                // The cut is the subject, not the length of the referencing's way.
                "--near-home".into(),
                SHORT_HOMING_MM.into(),
            ];
            // HOB_TOLERANCE_MS: the demo's relaxed bus timing (the emulated guest needs more).
            if std::env::var("HOB_TOLERANCE_MS").is_ok_and(|v| !v.is_empty()) {
                args.extend(["--tolerance-ms".into(), tolerance_ms().to_string()]);
            }
            let demo = b.spawn("hob demo", "hob", &args, "demo.txt");
            for f in ["hob-sim.log", "hob-rt.log", "hob-logger.log", "hob-watchdog.log"] {
                b.add_log(demo_dir.join(f));
            }
            let st = b.wait_exit(demo, Duration::from_secs(3600));
            let out = std::fs::read_to_string(b.log_of(demo)).unwrap();
            assert!(st.success(), "hob demo: {st}");
            assert!(
                out.contains("system heap allocations in cycles: 0"),
                "hob demo: no 'system heap allocations in cycles: 0' in its summary"
            );
            let last = out.lines().last().unwrap_or("");
            assert!(
                last.starts_with("log: "),
                "hob demo: last line '{last}', not 'log: DIR'"
            );

            let csv = b.art.join("demo.csv");
            let dir = path(&demo_dir);
            b.hob_ok(&["log", "export", &dir, "--csv", "--out", &path(&csv)]);
            let report = b.hob_ok(&["log", "report", &dir]);
            std::fs::write(b.art.join("report.txt"), &report.stdout).unwrap();
            let r = Report::parse(&report.stdout).unwrap_or_else(|e| panic!("hob log report: {e}"));
            let worst = r.pass_max_um.iter().copied().fold(0.0, f64::max);
            let logger = LoggerStats::read(&demo_dir).unwrap();
            let header = std::fs::read_to_string(&csv).unwrap();
            let header: Vec<&str> = header.lines().next().unwrap_or("").split(',').collect();
            assert_eq!(
                header[..CSV_COLUMNS.len().min(header.len())],
                CSV_COLUMNS,
                "the CSV's columns"
            );
            assert!(
                header.contains(&"cycle"),
                "no cycle column in the CSV: {header:?}"
            );
            assert_eq!(r.pass_max_um.len(), 2, "passes in the report:\n{}", report.stdout);
            // Graded by the virtual machine's truth, not the controller's own estimate;
            // and the gear each pass left, predicted from it.
            assert!(
                r.graded_by_truth,
                "the report is not graded by hob-sim's truth:\n{}",
                report.stdout
            );
            assert_eq!(
                r.predicted_passes, 2,
                "predicted gear per pass:\n{}",
                report.stdout
            );
            let factor = hob_system_tests::sync_bound_factor();
            assert!(
                worst <= r.bound_um * factor,
                "worst sync error {worst} um over the bound {} um (times {factor}, HOB_SYNC_BOUND_FACTOR)",
                r.bound_um
            );
            assert_eq!(r.missing, 0, "cycles missing from the log");
            assert_eq!(logger.samples_lost, 0, "samples lost by the logger");
            // The table drive's delay identified from the recording is the one the
            // machine file assumes (the virtual machine's drives interpolate over a period
            // with full feed-forward).
            let machine = path(&demo_dir.join("machine.toml"));
            let delay = b.hob_ok(&["log", "delay", &dir, "--machine", &machine]);
            std::fs::write(b.art.join("delay.txt"), &delay.stdout).unwrap();
            let number_before = |text: &str, marker: &str| -> f64 {
                let head = &text[..text.find(marker).unwrap_or_else(|| panic!("no '{marker}' in: {text}"))];
                head.split_whitespace().last().and_then(|w| w.parse().ok()).unwrap_or_else(|| panic!("no number before '{marker}' in: {text}"))
            };
            let identified_us = number_before(&delay.stdout, "us after the SYNC");
            let assumed_us = number_before(&delay.stdout, "us assumed");
            assert!(
                (identified_us - assumed_us).abs() <= 100f64.max(0.1 * assumed_us),
                "hob log delay: {}",
                delay.stdout
            );
            format!(
                "worst {worst:.3} um of {:.2} um (the truth), {} samples, 0 lost; drive delay {identified_us:.0} us identified, {assumed_us:.0} us assumed",
                r.bound_um, logger.samples
            )
        },
    );
    b.step("the demo's relaxed machine file is the sessions'", |b| {
        let demo = TomlDoc::load(&demo_dir.join("machine.toml"));
        let session = b.session_machine();
        assert!(
            demo.table == session.table,
            "the sessions' machine differs from the demo's {}:\n{}\n---\n{}",
            demo.origin.display(),
            demo.table,
            session.table
        );
        format!(
            "watchdog deadline {} ms, heartbeat timeout {} ms",
            demo.int("service.watchdog_deadline_ms"),
            demo.int("can.heartbeat_timeout_ms")
        )
    });
}

/// `hob demo --hmi`, the README's one command for the HMI on the simulated machine: it
/// prints the address; the page, the library and the loop's state arrive through it; HOME
/// ALL sent as the page sends it references X and Y; SIGTERM (with the page's socket open)
/// stops every process it started, each by itself, and leaves none of its instance's
/// shared-memory files.
#[test]
#[ignore = "needs the release binaries, the HMI's npm install and a bus; ci/test runs it"]
fn demo_hmi_serves_the_panel_and_stops_clean() {
    if hob_system_tests::host_only("demo_hmi_serves_the_panel_and_stops_clean") {
        return;
    }
    let mut b = Bench::new("demo_hmi");
    assert!(
        b.bin.join("hob-hmi").is_file(),
        "{}: not built",
        b.bin.join("hob-hmi").display()
    );
    let machine = b.base_machine_file();
    let dir = b.art.join("demo");
    let mut args = vec![
        "demo".to_string(),
        "--hmi".into(),
        "--port".into(),
        "0".into(),
        "--near-home".into(),
        SHORT_HOMING_MM.into(),
        "--machine".into(),
        path(&machine),
        "--iface".into(),
        b.iface.clone(),
        "--log-dir".into(),
        path(&dir),
    ];
    if std::env::var("HOB_TOLERANCE_MS").is_ok_and(|v| !v.is_empty()) {
        args.extend(["--tolerance-ms".into(), tolerance_ms().to_string()]);
    }
    let demo = b.spawn("hob demo --hmi", "hob", &args, "demo.txt");
    for f in [
        "hob-sim.log",
        "hob-rt.log",
        "hob-logger.log",
        "hob-watchdog.log",
        "hob-hmi.log",
    ] {
        b.add_log(dir.join(f));
    }
    let demo_pid = b.pid(demo);
    let mut children = Vec::new();
    let mut addr = String::new();
    b.step("the address printed, five processes started", |b| {
        let url = b.wait_for("the line HMI: URL", Duration::from_secs(120), |b| {
            let out = std::fs::read_to_string(b.log_of(demo)).unwrap_or_default();
            out.lines()
                .find_map(|l| l.strip_prefix("HMI: http://"))
                .and_then(|r| r.split_once('/'))
                .map(|(a, _)| a.to_string())
                .ok_or_else(|| format!("not yet: {}", out.lines().last().unwrap_or("")))
        });
        addr = url;
        children = children_of(demo_pid);
        let names: Vec<String> = children.iter().map(|(_, n)| n.clone()).collect();
        for exe in ["hob-sim", "hob-rt", "hob-logger", "hob-watchdog", "hob-hmi"] {
            assert!(
                names.iter().any(|n| n == exe),
                "{exe} not among the demo's children {names:?}"
            );
        }
        format!("http://{addr}/, children {names:?}")
    });
    b.step("the page and the library through the HMI", |b| {
        let page = http_get(&addr, "/").unwrap();
        assert!(
            page.contains("<title>hob</title>"),
            "not the panel's page: {page}"
        );
        let list = http_get(&addr, "/api/programs").unwrap();
        let j: serde_json::Value = serde_json::from_str(&list).unwrap_or_else(|e| panic!("{e}: {list}"));
        let demo_program = j["entries"]
            .as_array()
            .and_then(|l| l.iter().find(|e| e["name"] == "demo-short-spur-z17-m5"));
        assert!(
            demo_program.is_some_and(|e| e["valid"] == true),
            "the demo's program not valid in the library: {list}"
        );
        b.check_alive();
        "the panel's page; the demo's program in the library, valid".into()
    });
    let mut ws = Ws::connect(&addr, "/ws/panel");
    b.step(
        "the loop's state on the page's socket; HOME ALL as the page sends it references X and Y",
        |b| {
            ws.send(r#"{"t":"hello","last_event":0}"#);
            let frame = |m: &serde_json::Value| m["t"] == "frame";
            let first = ws.until(Duration::from_secs(120), |m| {
                frame(m) && m["state"]["state"] == "idle"
            });
            b.check_alive();
            ws.send(r#"{"t":"cmd","id":1,"op":"home","axis":"all"}"#);
            let answer = ws.until(Duration::from_secs(20), |m| m["t"] == "answer" && m["id"] == 1);
            assert_eq!(answer["ok"], true, "HOME ALL refused: {answer}");
            let s = ws.until(Duration::from_secs(120), |m| {
                let s = &m["state"];
                frame(m)
                    && s["state"] == "idle"
                    && s["referenced"]["x"] == true
                    && s["referenced"]["y"] == true
            });
            b.check_alive();
            format!(
                "idle at cycle {}; HOME ALL accepted ({}); X and Y referenced at cycle {}",
                first["state"]["cycle"], answer["text"], s["state"]["cycle"]
            )
        },
    );
    b.step(
        "SIGTERM: every process stopped, no shared-memory file of the instance left",
        |b| {
            let st = b.terminate(demo, Duration::from_secs(60));
            drop(ws);
            let st = st.unwrap_or_else(|| panic!("hob demo --hmi did not end within 60 s of SIGTERM"));
            assert!(st.success(), "hob demo --hmi: {st}");
            let out = std::fs::read_to_string(b.log_of(demo)).unwrap();
            let last = out.lines().last().unwrap_or("");
            assert!(last.starts_with("log: "), "last line '{last}', not 'log: DIR'");
            let mut wrong = Vec::new();
            for (pid, name) in &children {
                if Path::new(&format!("/proc/{pid}")).exists() {
                    wrong.push(format!("{name} (pid {pid}) still there"));
                }
                // The machine and the loop ended by themselves (their last words), not killed.
                let log = std::fs::read_to_string(dir.join(format!("{name}.log"))).unwrap_or_default();
                let words = match name.as_str() {
                    "hob-sim" => "hob-sim: stopped after",
                    "hob-rt" => "hob-rt: stopped in state",
                    _ => "",
                };
                if !log.contains(words) {
                    wrong.push(format!("{name} did not say '{words}': it was killed"));
                }
            }
            let left = iceoryx2_files_of(&b.instance, children.iter().map(|c| c.0).chain([demo_pid]));
            if !left.is_empty() {
                wrong.push(format!("left behind: {left:?}"));
            }
            assert!(wrong.is_empty(), "{}", wrong.join("\n"));
            format!(
                "{} processes ended; no file of instance {} left",
                children.len(),
                b.instance
            )
        },
    );
}

/// The processes whose parent is `pid`: their pid and name (from `/proc`).
fn children_of(pid: u32) -> Vec<(u32, String)> {
    let mut out = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let Some(child) = e.file_name().to_str().and_then(|n| n.parse::<u32>().ok()) else {
            continue;
        };
        let stat = std::fs::read_to_string(e.path().join("stat")).unwrap_or_default();
        // `pid (comm) state ppid ...`: comm may hold spaces, so after the last ')'.
        let ppid = stat
            .rsplit_once(')')
            .and_then(|(_, r)| r.split_whitespace().nth(1))
            .and_then(|p| p.parse::<u32>().ok());
        if ppid == Some(pid) {
            let exe = std::fs::read_link(e.path().join("exe")).unwrap_or_default();
            let name = exe
                .file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into_owned());
            out.push((child, name));
        }
    }
    out
}

/// What iceoryx2 keeps of a bus instance and its processes under `/tmp/iceoryx2`: the
/// services named `hob/<instance>/...` and the nodes of `pids`. (Its files in `/dev/shm`
/// are named by hashes; they go with the services.)
fn iceoryx2_files_of(instance: &str, pids: impl Iterator<Item = u32>) -> Vec<String> {
    let pids: Vec<String> = pids.map(|p| format!("process = {p}\n")).collect();
    let service = format!("\"hob/{instance}/");
    let mut left = Vec::new();
    let mut dirs = vec![std::path::PathBuf::from("/tmp/iceoryx2")];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                dirs.push(p);
                continue;
            }
            let text = String::from_utf8_lossy(&std::fs::read(&p).unwrap_or_default()).into_owned();
            if text.contains(&service) || pids.iter().any(|x| text.contains(x.as_str())) {
                left.push(p.display().to_string());
            }
        }
    }
    left
}

/// A WebSocket client, as much as the panel's socket needs: text messages, each in one
/// frame (the server's are; the client's are masked, as they must be).
struct Ws {
    s: std::net::TcpStream,
}

impl Ws {
    fn connect(addr: &str, path: &str) -> Ws {
        use std::io::{Read, Write};
        let mut s = std::net::TcpStream::connect(addr).unwrap_or_else(|e| panic!("{addr}: {e}"));
        // The panel accepts a socket only from a page of its own address.
        write!(
            s,
            "GET {path} HTTP/1.1\r\nHost: {addr}\r\nOrigin: http://{addr}\r\nUpgrade: websocket\r\n\
             Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
        )
        .unwrap();
        s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        let mut head = Vec::new();
        let mut byte = [0u8; 1];
        while !head.ends_with(b"\r\n\r\n") {
            s.read_exact(&mut byte)
                .unwrap_or_else(|e| panic!("{addr}{path}: {e}"));
            head.push(byte[0]);
        }
        let head = String::from_utf8_lossy(&head);
        assert!(head.starts_with("HTTP/1.1 101"), "{addr}{path}: {head}");
        Ws { s }
    }

    fn send(&mut self, text: &str) {
        use std::io::Write;
        let n = text.len();
        assert!(n < 126, "a short message only");
        // FIN, text; masked with the key 0 (the payload as it is).
        let mut frame = vec![0x81, 0x80 | n as u8, 0, 0, 0, 0];
        frame.extend_from_slice(text.as_bytes());
        self.s.write_all(&frame).unwrap();
    }

    /// The next message (a JSON value; `Null` for what is not JSON text).
    fn next(&mut self) -> std::io::Result<serde_json::Value> {
        use std::io::Read;
        let mut h = [0u8; 2];
        self.s.read_exact(&mut h)?;
        let len = match h[1] & 0x7F {
            126 => {
                let mut l = [0u8; 2];
                self.s.read_exact(&mut l)?;
                u64::from(u16::from_be_bytes(l))
            }
            127 => {
                let mut l = [0u8; 8];
                self.s.read_exact(&mut l)?;
                u64::from_be_bytes(l)
            }
            n => u64::from(n),
        };
        let mut payload = vec![0u8; len as usize];
        self.s.read_exact(&mut payload)?;
        Ok(if h[0] & 0x0F == 1 {
            serde_json::from_slice(&payload).unwrap_or(serde_json::Value::Null)
        } else {
            serde_json::Value::Null
        })
    }

    /// The first message within `timeout` that `ok` accepts; fails with the last one seen.
    fn until(&mut self, timeout: Duration, ok: impl Fn(&serde_json::Value) -> bool) -> serde_json::Value {
        let end = std::time::Instant::now() + timeout;
        let mut last = serde_json::Value::Null;
        while std::time::Instant::now() < end {
            let m = self
                .next()
                .unwrap_or_else(|e| panic!("the panel's socket: {e}; last message {last}"));
            if ok(&m) {
                return m;
            }
            if m["t"] == "frame" {
                last = m;
            }
        }
        panic!("not within {} s; the last frame: {last}", timeout.as_secs());
    }
}

/// A service session: refusals change nothing; kill -9 of the logger and of a CLI leave
/// the loop on time; a restarted logger resumes; `hob status` shows the loop's histograms;
/// kill -9 of hob-rt mid-cut makes the watchdog drop PC-OK and quick-stop the drives.
/// One set of processes, the steps in order.
#[test]
#[ignore = "needs the release binaries and a bus; ci/test runs it (--ignored)"]
fn service_session() {
    let mut b = Bench::new("service_session");
    let m = b.session_machine();
    let machine = m.write(&b.art.join("machine.toml"));
    let cycle_us = m.int("control.cycle_period_us") as f64;
    let deadline_ms = m.int("service.watchdog_deadline_ms") as f64;
    let session = b.art.join("session");
    let (_sim, rt) = start_service(&mut b, &machine, 1, Homing::Short);
    let logger = b.spawn("hob-logger", "hob-logger", &[&session], "logger1.txt");
    let iface = b.iface.clone();
    let wd = b.spawn(
        "hob-watchdog",
        "hob-watchdog",
        &["--iface", &iface, "--machine", &path(&machine)],
        "watchdog.txt",
    );

    b.step("power-up to idle", |b| {
        b.wait_state("idle", STATE_TIMEOUT);
        String::new()
    });
    b.step("refused: start without a program", |b| {
        let o = b.hob(&["start"]);
        assert_eq!(o.code, Some(2), "hob start: {}", o.text);
        assert!(o.text.contains("no program loaded"), "hob start: {}", o.text);
        assert_eq!(b.status().state, "idle", "the state after the refusal");
        o.text
    });
    b.step("refused: a program that fails hob check", |b| {
        let mut p = TomlDoc::load(&session_program());
        p.set("workpiece.teeth", 2);
        let bad = p.write(&b.art.join("bad.toml"));
        let o = b.hob(&["load", &path(&bad)]);
        assert_eq!(o.code, Some(2), "hob load {}: {}", bad.display(), o.text);
        assert!(o.text.contains("teeth"), "hob load: {}", o.text);
        assert!(
            !b.status().program_loaded,
            "a program is loaded after the refusal"
        );
        String::new()
    });
    b.step("refused: start before X and Y are referenced", |b| {
        b.hob_ok(&["load", &program_arg()]);
        let o = b.hob(&["start"]);
        assert_eq!(o.code, Some(2), "hob start: {}", o.text);
        assert!(o.text.contains("not referenced"), "hob start: {}", o.text);
        let s = b.status();
        assert_eq!(s.state, "idle", "the state after the refusal");
        assert!(!s.x_referenced && !s.y_referenced, "{s:?}");
        o.text
    });
    b.step("referencing X and Y: hob home all", |b| {
        let s = b.reference(STATE_TIMEOUT);
        format!("X {:.3} mm, Y {:.3} mm", s.x_mm, s.y_mm)
    });
    b.step("load and start: cutting", |b| {
        b.hob_ok(&["load", &program_arg()]);
        b.hob_ok(&["start"]);
        b.wait_state("cut", STATE_TIMEOUT);
        String::new()
    });
    b.step("refused: jog while cutting", |b| {
        let o = b.hob(&["jog", "x", "5"]);
        assert_eq!(o.code, Some(2), "hob jog x 5: {}", o.text);
        assert!(o.text.contains("cycle is running"), "hob jog x 5: {}", o.text);
        assert_eq!(b.status().state, "cut", "the state after the refusal");
        o.text
    });
    b.step(
        "refused: commissioning while cutting, the machine file unchanged",
        |b| {
            let before = std::fs::read_to_string(&machine).unwrap();
            let o = b.hob(&["commission", "delay", "--machine", &path(&machine), "--yes"]);
            assert_eq!(o.code, Some(2), "hob commission delay: {}", o.text);
            assert!(
                o.text.contains("cycle is running"),
                "hob commission delay: {}",
                o.text
            );
            assert_eq!(b.status().state, "cut", "the state after the refusal");
            assert_eq!(std::fs::read_to_string(&machine).unwrap(), before);
            o.text
        },
    );
    b.step("feed hold and resume through the service", |b| {
        b.hob_ok(&["hold"]);
        let s = b.status();
        assert!(
            s.hold && s.state == "cut",
            "after hob hold: state {}, hold {}",
            s.state,
            s.hold
        );
        let again = b.hob(&["hold"]);
        assert_eq!(again.code, Some(2), "a second hob hold: {}", again.text);
        assert!(
            again.text.contains("nothing to do"),
            "a second hob hold: {}",
            again.text
        );
        b.hob_ok(&["resume"]);
        let s = b.status();
        assert!(
            !s.hold && s.state == "cut",
            "after hob resume: state {}, hold {}",
            s.state,
            s.hold
        );
        let again = b.hob(&["resume"]);
        assert_eq!(again.code, Some(2), "a second hob resume: {}", again.text);
        String::new()
    });
    b.step(
        "cycle stop through the service: out of the cut to idle, then cutting again",
        |b| {
            b.hob_ok(&["stop"]);
            let s = b.wait_state("idle", STATE_TIMEOUT);
            assert!(s.alarm.is_empty(), "alarm after the stop: {}", s.alarm);
            let again = b.hob(&["reset"]);
            assert_eq!(again.code, Some(2), "hob reset without a fault: {}", again.text);
            assert!(
                again.text.contains("nothing to do"),
                "hob reset without a fault: {}",
                again.text
            );
            b.hob_ok(&["start"]);
            b.wait_state("cut", STATE_TIMEOUT);
            String::new()
        },
    );
    b.step("kill -9 logger and CLI: the loop keeps its pace, no alarm", |b| {
        let cli = b.spawn(
            "hob status --watch",
            "hob",
            &["status", "--watch"],
            "cli-watch.txt",
        );
        std::thread::sleep(Duration::from_secs(1));
        // One snapshot each side: the cycle counter and hob-rt's own clock at that
        // cycle's SYNC (the test's clock means nothing in the emulated guest).
        let s0 = b.status();
        b.kill9(logger);
        b.kill9(cli);
        std::thread::sleep(Duration::from_secs(3));
        let s1 = b.status();
        let pace = s1.pace_since(&s0, cycle_us);
        let overruns = |s: &hob_system_tests::Status| s.stats.as_ref().map_or(0, |x| x.overruns);
        // HOB_MIN_PACE: the least pace that counts as kept (the emulated guest, where the
        // loop overruns a few per cent of its cycles anyway, takes less).
        let min = hob_system_tests::min_pace();
        assert!(s1.alarm.is_empty(), "alarm after the kills: {}", s1.alarm);
        assert!(
            pace >= min,
            "pace {pace:.3} cycles per period (least {min}): cycles {} -> {}, sync time {} -> {} ns",
            s0.cycle,
            s1.cycle,
            s0.sync_time_ns,
            s1.sync_time_ns
        );
        format!(
            "{pace:.3} cycles per period, overruns {} -> {}",
            overruns(&s0),
            overruns(&s1)
        )
    });
    b.step(
        "restarted logger resumes recording (the gap marked not-running, none lost)",
        |b| {
            let logger = b.spawn("hob-logger (restarted)", "hob-logger", &[&session], "logger2.txt");
            // Until the new logger (its logger.json counts the gap as not running) has 1000.
            let dir = session.clone();
            b.wait_for(
                "the restarted logger's logger.json: samples_not_running > 0, samples > 1000",
                Duration::from_secs(60),
                |_| {
                    let s = LoggerStats::read(&dir)?;
                    if s.samples_not_running > 0 && s.samples > 1000 {
                        Ok(())
                    } else {
                        Err(format!("{s:?}"))
                    }
                },
            );
            b.terminate(logger, Duration::from_secs(10));
            let s = LoggerStats::read(&session).unwrap();
            let gaps = std::fs::read_to_string(session.join("gaps.log")).unwrap_or_default();
            assert!(
                gaps.contains("not-running"),
                "no not-running gap in gaps.log:\n{gaps}"
            );
            assert!(s.samples > 1000, "{s:?}");
            assert_eq!(s.samples_lost, 0, "{s:?}");
            format!(
                "{} samples, {} not running, 0 lost",
                s.samples, s.samples_not_running
            )
        },
    );
    b.step(
        "hob status shows the loop's histograms; no heap allocation in a cycle",
        |b| {
            let text = b.hob_ok(&["status"]).stdout;
            assert!(
                text.contains("wake us"),
                "no 'wake us' histogram in hob status:\n{text}"
            );
            let stats = b.status().stats.expect("no loop stats in hob status --json");
            assert_eq!(
                stats.system_allocations_in_cycle, 0,
                "system heap allocations in a cycle"
            );
            assert!(stats.period_ns > 0);
            let lines: Vec<&str> = text
                .lines()
                .filter(|l| {
                    ["loop", "wake", "compute", "overruns"]
                        .iter()
                        .any(|k| l.contains(k))
                })
                .collect();
            format!("\n    {}", lines.join("\n    "))
        },
    );
    // kill -9 of hob-rt mid-cut: the watchdog acts. On SocketCAN a candump capture
    // measures the reaction on the wire: hob-rt's last SYNC to the watchdog's frames.
    let capture = (b.iface != "shm" && which("candump")).then(|| {
        let c = b.command_any("candump", &["-L", "-r", "33554432", &iface]);
        let p = b.spawn_cmd("candump", c, "kill-rt.candump");
        // The loop's SYNCs in the capture before hob-rt is killed: in the emulated guest
        // candump once took longer than the half second this waited to start capturing
        // ("no SYNC before the reaction in the capture", 2026-11-26).
        let log = b.log_of(p);
        b.wait_for(
            "candump capturing the loop's SYNCs",
            Duration::from_secs(30),
            |_| {
                let frames = parse_candump(&std::fs::read_to_string(&log).unwrap_or_default());
                if frames.iter().any(|f| f.id == 0x80) {
                    Ok(())
                } else {
                    Err(format!("{} frames, no SYNC", frames.len()))
                }
            },
        );
        p
    });
    b.step(
        "kill -9 hob-rt: the watchdog drops PC-OK and quick-stops the drives",
        |b| {
            b.kill9(rt);
            let log = b.log_of(wd);
            let trip = b.wait_for(
                "the watchdog's trip report in watchdog.txt",
                Duration::from_secs(10),
                |_| {
                    let text = std::fs::read_to_string(&log).map_err(|e| e.to_string())?;
                    WatchdogTrip::find(&text)
                        .ok_or_else(|| format!("no trip: {}", text.lines().last().unwrap_or("(empty)")))
                },
            );
            // Give the capture time.
            std::thread::sleep(Duration::from_secs(1));
            let text = std::fs::read_to_string(&log).unwrap();
            // Both signs of life stop together: either may be noticed first.
            assert!(
                trip.tripped && ["state", "sync"].contains(&trip.channel.as_str()),
                "{trip:?}"
            );
            let silence_ms = trip.silence_ms.unwrap_or(f64::NAN);
            assert!(
                silence_ms > deadline_ms && silence_ms <= 1.2 * deadline_ms,
                "the watchdog noticed after {silence_ms} ms of silence, deadline {deadline_ms} ms: {trip:?}"
            );
            assert_eq!(trip.errors, 0, "{trip:?}");
            let line = text.lines().find(|l| l.contains("TRIPPED")).unwrap_or("");
            format!(
                "{} (deadline {deadline_ms:.0} ms); {} frames sent, {} answered ({})",
                trip.reason,
                trip.frames_sent,
                trip.answers,
                line.rsplit_once("quick stop to the drives: ").map_or("", |x| x.1)
            )
        },
    );
    if let Some(candump) = capture {
        b.step(
            "kill -9 hob-rt, from the capture: the watchdog's frames on the wire",
            |b| {
                // Until candump has written the reaction: in the emulated guest it writes
                // to the host over 9p (about 1 300 frames a second), behind the bus; ended
                // a second after the trip it lost what it had not yet written ("no
                // reaction frame in the capture (2540 frames)", 2026-11-27).
                let log = b.log_of(candump);
                let reaction = b.wait_for(
                    "the watchdog's reaction in the capture",
                    Duration::from_secs(30),
                    |_| {
                        let text = std::fs::read_to_string(&log).map_err(|e| e.to_string())?;
                        watchdog_reaction(&parse_candump(&text), deadline_ms)
                    },
                );
                b.terminate(candump, Duration::from_secs(5));
                reaction
            },
        );
    } else {
        eprintln!("(no candump capture: bus {}, or candump not installed)", b.iface);
    }
}

/// The safety channel does not depend on the process it guards: the watchdog follows the
/// loop's state stream and, on a CAN socket of its own, the loop's SYNC frames, and trips
/// when either goes silent past its deadline. A stand-in for the loop (`hob-loop-double`)
/// goes silent on one channel while the other stays live; the watchdog's reaction is
/// timed on its own clock and, from the frame that switches the coupler's outputs off
/// (PC-OK), on the stand-in's. The loop's ports are its alone: while the stand-in holds
/// them, a second publisher (another stand-in, a hob-rt) or command server is refused, and
/// hob-rt is refused before it touches the bus.
#[test]
#[ignore = "needs the release binaries and a bus; ci/test runs it (--ignored)"]
fn watchdog_watches_the_sync_and_the_state_and_only_the_loop_publishes() {
    let mut b = Bench::new("watchdog_channels");
    let m = b.session_machine();
    let machine = m.write(&b.art.join("machine.toml"));
    let cycle_us = m.int("control.cycle_period_us").to_string();
    let deadline_ms = m.int("service.watchdog_deadline_ms") as f64;
    let iface = b.iface.clone();
    for (mute, other) in [
        ("sync", "the state stream still live"),
        ("state", "its SYNC still on"),
    ] {
        let wd = b.spawn(
            "hob-watchdog",
            "hob-watchdog",
            &["--iface", &iface, "--machine", &path(&machine)],
            &format!("watchdog-{mute}.txt"),
        );
        std::thread::sleep(Duration::from_millis(500));
        let double = b.spawn(
            "hob-loop-double",
            "hob-loop-double",
            &[
                "--iface",
                &iface,
                "--machine",
                &path(&machine),
                "--period-us",
                &cycle_us,
                "--mute",
                mute,
                "--after-ms",
                "4000",
                "--serve-commands",
            ],
            &format!("double-{mute}.txt"),
        );
        if mute == "sync" {
            b.step(
                "a second publisher of the state or server of commands is refused",
                |b| {
                    std::thread::sleep(Duration::from_millis(1000));
                    let second = b.spawn(
                        "second hob-loop-double",
                        "hob-loop-double",
                        &[
                            "--iface",
                            &iface,
                            "--machine",
                            &path(&machine),
                            "--run-ms",
                            "2000",
                        ],
                        "double-second.txt",
                    );
                    let code = b.wait_exit(second, Duration::from_secs(60)).code();
                    let text = std::fs::read_to_string(b.log_of(second)).unwrap();
                    assert_eq!(code, Some(2), "a second publisher of state: {text}");
                    assert!(
                        text.contains("state publisher: ExceedsMaxSupportedPublishers"),
                        "{text}"
                    );
                    let server = b.spawn(
                        "hob-loop-double --commands-only",
                        "hob-loop-double",
                        &["--iface", &iface, "--machine", &path(&machine), "--commands-only"],
                        "double-server.txt",
                    );
                    let code = b.wait_exit(server, Duration::from_secs(60)).code();
                    let text2 = std::fs::read_to_string(b.log_of(server)).unwrap();
                    assert_eq!(code, Some(2), "a second command server: {text2}");
                    assert!(
                        text2.contains("command server: ExceedsMaxSupportedServers"),
                        "{text2}"
                    );
                    let state = path(&b.art.join("machine-state.toml"));
                    let rt = b.spawn(
                        "second hob-rt",
                        "hob-rt",
                        &[
                            "--iface",
                            &iface,
                            "--machine",
                            &path(&machine),
                            "--state-file",
                            &state,
                        ],
                        "rt-second.txt",
                    );
                    let code = b.wait_exit(rt, Duration::from_secs(120)).code();
                    let text3 = std::fs::read_to_string(b.log_of(rt)).unwrap();
                    assert_eq!(code, Some(1), "a second hob-rt: {text3}");
                    assert!(
                        text3.contains(
                            "state publisher: ExceedsMaxSupportedPublishers (is another hob-rt running"
                        ),
                        "{text3}"
                    );
                    // Refused before the bus: no boot attempted.
                    assert!(
                        !text3.contains("bus boot") && !text3.contains("operational"),
                        "{text3}"
                    );
                    // A process of another user cannot join the bus at all: neither read
                    // the state nor publish (iceoryx2's files are the bus user's alone).
                    let foreign = |b: &Bench, exe: &str, args: &[&str]| {
                        let mut c =
                            b.command_any("setpriv", &["--reuid=65534", "--regid=65534", "--clear-groups"]);
                        c.arg(b.bin.join(exe)).args(args).env("HOB_INSTANCE", &b.instance);
                        c.output().unwrap()
                    };
                    let o = foreign(
                        b,
                        "hob-loop-double",
                        &["--iface", &iface, "--machine", &path(&machine), "--run-ms", "500"],
                    );
                    let text4 = String::from_utf8_lossy(&o.stderr).to_string();
                    assert_eq!(o.status.code(), Some(2), "another user's publisher: {text4}");
                    assert!(
                        text4.contains("node:") && text4.contains("runs as the user"),
                        "{text4}"
                    );
                    let o = foreign(b, "hob", &["status"]);
                    assert_ne!(o.status.code(), Some(0), "another user read the state");
                    format!(
                        "{}; {}; {}",
                        text.lines().last().unwrap_or(""),
                        text2.lines().last().unwrap_or(""),
                        text3.lines().last().unwrap_or("")
                    )
                },
            );
        }
        b.step(
            &format!("the loop's {mute} goes silent, the other channel live: the watchdog trips"),
            |b| {
                let log = b.log_of(wd);
                let trip = b.wait_for("the watchdog's trip report", Duration::from_secs(120), |_| {
                    let text = std::fs::read_to_string(&log).map_err(|e| e.to_string())?;
                    WatchdogTrip::find(&text).ok_or_else(|| "no trip reported yet".to_string())
                });
                let dlog = b.log_of(double);
                let seen = b.wait_for("the stand-in hears PC-OK dropped", Duration::from_secs(30), |_| {
                    let text = std::fs::read_to_string(&dlog).map_err(|e| e.to_string())?;
                    DoubleSawReaction::find(&text).ok_or_else(|| "no reaction heard yet".to_string())
                });
                assert!(trip.tripped && trip.errors == 0, "{trip:?}");
                assert_eq!(trip.channel, mute, "{trip:?}");
                assert!(trip.reason.contains(other), "{trip:?}");
                let silence_ms = trip.silence_ms.unwrap_or(f64::NAN);
                assert!(
                    silence_ms > deadline_ms && silence_ms <= 1.2 * deadline_ms,
                    "noticed after {silence_ms} ms, deadline {deadline_ms} ms"
                );
                assert!(seen.pc_ok_dropped && seen.muted.as_deref() == Some(mute), "{seen:?}");
                let after = seen.ms_after_last_sign.unwrap_or(f64::NAN);
                assert!(
                    after > deadline_ms && after <= 1.2 * deadline_ms,
                    "PC-OK dropped {after} ms after the stand-in's last {mute}, deadline {deadline_ms} ms"
                );
                format!(
                    "{}; on the watchdog's clock {silence_ms:.1} ms of silence, on the stand-in's PC-OK off {after:.1} ms after its last {mute} (deadline {deadline_ms:.0} ms)",
                    trip.reason
                )
            },
        );
        b.terminate(double, Duration::from_secs(10));
        b.terminate(wd, Duration::from_secs(10));
    }
}

/// The shared-memory files of iceoryx2 on this machine (`/dev/shm/iox2*` and everything
/// under `/tmp/iceoryx2`): what a process killed with `kill -9` could leave behind.
fn shm_files() -> usize {
    fn count(dir: &Path, filter: &dyn Fn(&str) -> bool) -> usize {
        std::fs::read_dir(dir).map_or(0, |rd| {
            rd.flatten()
                .map(|e| {
                    let p = e.path();
                    if p.is_dir() {
                        count(&p, &|_| true)
                    } else {
                        usize::from(filter(&e.file_name().to_string_lossy()))
                    }
                })
                .sum()
        })
    }
    count(Path::new("/dev/shm"), &|n| n.starts_with("iox2")) + count(Path::new("/tmp/iceoryx2"), &|_| true)
}

/// Load: a command flood from four processes at once (half the requests to the loop, half
/// refused before it) leaves the loop at its pace and every request answered; frontends
/// stopped with SIGSTOP (the logger, a `hob status --watch`) cost the loop nothing; the
/// logger, the watchdog and a `hob status --watch` killed with `kill -9` and started again,
/// over and over, leave no shared-memory files behind.
#[test]
#[ignore = "needs the release binaries and a bus; ci/test runs it (--ignored)"]
fn load_a_command_flood_stopped_subscribers_and_restarted_frontends() {
    if hob_system_tests::host_only("load_a_command_flood_stopped_subscribers_and_restarted_frontends") {
        return;
    }
    let mut b = Bench::new("load");
    let m = b.session_machine();
    let machine = m.write(&b.art.join("machine.toml"));
    let cycle_us = m.int("control.cycle_period_us") as f64;
    let iface = b.iface.clone();
    let (_sim, _rt) = start_service(&mut b, &machine, 1, Homing::Full);
    b.step("power-up to idle", |b| {
        b.wait_state("idle", STATE_TIMEOUT);
        String::new()
    });
    let pace_kept = |b: &Bench, s0: &hob_system_tests::Status, what: &str| {
        let s1 = b.status();
        let pace = s1.pace_since(s0, cycle_us);
        let min = hob_system_tests::min_pace();
        assert!(pace >= min, "{what}: pace {pace:.3} (least {min})");
        assert!(s1.alarm.is_empty(), "{what}: the loop's alarm {}", s1.alarm);
        let overruns = |s: &hob_system_tests::Status| s.stats.as_ref().map_or(0, |x| x.overruns);
        format!("pace {pace:.3}, overruns {} -> {}", overruns(s0), overruns(&s1))
    };
    b.step(
        "a command flood from four processes: every request answered, the loop at pace",
        |b| {
            let s0 = b.status();
            // Started here, not as the bench's processes: they end by themselves.
            let floods: Vec<(std::process::Child, std::path::PathBuf)> = (0..4)
                .map(|i| {
                    let log = b.art.join(format!("flood{i}.txt"));
                    let mut c = b.command("hob-bench");
                    c.args(["flood", "--requests", "1000"])
                        .stdout(std::fs::File::create(&log).unwrap())
                        .stderr(std::process::Stdio::inherit());
                    (c.spawn().unwrap(), log)
                })
                .collect();
            let mut total = (0u64, 0u64, 0.0f64);
            for (mut child, log) in floods {
                let status = child.wait().unwrap();
                let text = std::fs::read_to_string(&log).unwrap();
                assert!(
                    status.success(),
                    "a flood left requests unanswered ({status}): {text}"
                );
                let j: serde_json::Value = serde_json::from_str(text.lines().last().unwrap_or("")).unwrap();
                assert_eq!(j["sent"], 1000, "{text}");
                assert_eq!(j["answered"], 1000, "{text}");
                assert_eq!(j["accepted"], 500, "the loop's answers: {text}");
                total.0 += j["answered"].as_u64().unwrap();
                total.1 += j["accepted"].as_u64().unwrap();
                total.2 = total.2.max(j["seconds"].as_f64().unwrap());
            }
            let pace = pace_kept(b, &s0, "the flood");
            format!(
                "{} requests answered ({} by the loop) in {:.1} s, {:.0} requests/s; {pace}",
                total.0,
                total.1,
                total.2,
                total.0 as f64 / total.2
            )
        },
    );
    b.step(
        "a logger and a hob status --watch stopped with SIGSTOP cost the loop nothing",
        |b| {
            let log_dir = b.art.join("log");
            let logger = b.spawn("hob-logger", "hob-logger", &[&log_dir], "logger-stopped.txt");
            let watch = b.spawn(
                "hob status --watch",
                "hob",
                &["status", "--watch"],
                "watch-stopped.txt",
            );
            std::thread::sleep(Duration::from_secs(2));
            let s0 = b.status();
            b.signal(logger, "STOP");
            b.signal(watch, "STOP");
            std::thread::sleep(Duration::from_secs(5));
            let pace = pace_kept(b, &s0, "two subscribers stopped");
            b.signal(logger, "CONT");
            b.signal(watch, "CONT");
            std::thread::sleep(Duration::from_secs(1));
            b.terminate(logger, Duration::from_secs(10));
            b.kill9(watch);
            // The logger lost what overflowed its buffer while stopped, and says how much.
            let st = LoggerStats::read(&log_dir).unwrap();
            format!(
                "{pace}; the stopped logger counted {} samples lost of {}",
                st.samples_lost, st.samples
            )
        },
    );
    b.step("frontends killed and restarted over and over leave no shared-memory files", |b| {
        let s0 = b.status();
        let rounds = hob_system_tests::env_num("HOB_RESTART_ROUNDS", Some(40)).unwrap_or(40);
        let log_dir = b.art.join("log-restarts");
        // The first round's processes make the services they use (the recorder's, the
        // CAN endpoints'): what stays from the second round on is what leaks.
        let mut before = 0;
        for r in 0..=rounds {
            if r == 1 {
                before = shm_files();
            }
            let logger = b.spawn("hob-logger", "hob-logger", &[&log_dir], "logger-restarts.txt");
            let watch = b.spawn("hob status --watch", "hob", &["status", "--watch"], "watch-restarts.txt");
            let wd = b.spawn(
                "hob-watchdog",
                "hob-watchdog",
                &["--iface", &iface, "--machine", &path(&machine)],
                "watchdog-restarts.txt",
            );
            std::thread::sleep(Duration::from_millis(400));
            for p in [logger, watch, wd] {
                b.kill9(p);
            }
        }
        // One more frontend starts (it removes what dead nodes left, as every one does)
        // and ends cleanly.
        let o = b.hob(&["status"]);
        assert_eq!(o.code, Some(0), "hob status after the restarts: {}", o.text);
        let after = shm_files();
        let pace = pace_kept(b, &s0, "the restarts");
        // A leak of even one file per round would show: fewer than one more per round.
        assert!(
            after < before + rounds,
            "{rounds} rounds of kill -9 and restart: {before} shared-memory files before, {after} after"
        );
        format!("{rounds} rounds of three frontends killed and restarted: {before} shared-memory files before, {after} after; {pace}")
    });
}

/// A tmpfs of this size under the test's artifacts, unmounted when dropped (root: the
/// CI machine and the guest run as root).
struct SmallDisk(std::path::PathBuf);

impl SmallDisk {
    fn mount(dir: &Path, size: &str) -> SmallDisk {
        std::fs::create_dir_all(dir).unwrap();
        let o = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "hob-test-disk"])
            .arg(dir)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "mount a {size} tmpfs on {} (the test needs root): {}",
            dir.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        SmallDisk(dir.to_path_buf())
    }

    fn resize(&self, size: &str) {
        let o = std::process::Command::new("mount")
            .args(["-o", &format!("remount,size={size}")])
            .arg(&self.0)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "remount: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount")
            .arg("-l")
            .arg(&self.0)
            .status();
    }
}

/// The recorder on a full disk: the logger writes its log onto a 1 MB tmpfs while the loop
/// runs; when it fills, the recorder alarm shows in `hob status`, the logger keeps counting
/// what it cannot write and the loop keeps its pace; when space returns (the tmpfs grown)
/// the alarm goes, the recording resumes, and every sample received is either in the log
/// or counted as not written, its run of cycles in `gaps.log`.
#[test]
#[ignore = "needs the release binaries, a bus and root (a tmpfs); ci/test runs it (--ignored)"]
fn logger_on_a_full_disk_raises_the_recorder_alarm_and_resumes() {
    if hob_system_tests::host_only("logger_on_a_full_disk_raises_the_recorder_alarm_and_resumes") {
        return;
    }
    let mut b = Bench::new("logger_full_disk");
    let m = b.session_machine();
    let machine = m.write(&b.art.join("machine.toml"));
    let cycle_us = m.int("control.cycle_period_us") as f64;
    let disk = SmallDisk::mount(&b.art.join("disk"), "1m");
    let log = disk.0.join("log");
    let (_sim, _rt) = start_service(&mut b, &machine, 1, Homing::Full);
    b.step("power-up to idle", |b| {
        b.wait_state("idle", STATE_TIMEOUT);
        String::new()
    });
    let logger = b.spawn("hob-logger", "hob-logger", &[&log], "logger.txt");
    let mut full_at = None;
    b.step("the disk fills: the recorder alarm in hob status", |b| {
        let s = b.wait_for("the recorder alarm", STATE_TIMEOUT, |b| {
            let s = b.try_status()?;
            if s.recorder.alarm {
                Ok(s)
            } else {
                Err(s.recorder.text)
            }
        });
        assert!(
            s.recorder.text.contains("No space left on device"),
            "{}",
            s.recorder.text
        );
        assert_eq!(s.recorder.writing, Some(false));
        full_at = Some(s.clone());
        s.recorder.text
    });
    b.step("the loop keeps its pace while the logger cannot write", |b| {
        std::thread::sleep(Duration::from_secs(3));
        let s1 = b.status();
        let s0 = full_at.as_ref().unwrap();
        let pace = s1.pace_since(s0, cycle_us);
        let min = hob_system_tests::min_pace();
        assert!(pace >= min, "pace {pace:.3} (least {min})");
        assert!(s1.alarm.is_empty(), "the loop's alarm: {}", s1.alarm);
        let more = s1.recorder.samples_unwritten.unwrap_or(0);
        assert!(
            more > s0.recorder.samples_unwritten.unwrap_or(0),
            "the samples not written are counted: {} then {more}",
            s0.recorder.samples_unwritten.unwrap_or(0)
        );
        format!("{pace:.3} cycles per period; {}", s1.recorder.text)
    });
    b.step("space returns: the alarm goes and the recording resumes", |b| {
        disk.resize("64m");
        let s = b.wait_for("the recorder writing again", STATE_TIMEOUT, |b| {
            let s = b.try_status()?;
            if !s.recorder.alarm && s.recorder.writing == Some(true) {
                Ok(s)
            } else {
                Err(s.recorder.text)
            }
        });
        s.recorder.text
    });
    b.step(
        "every sample received is in the log or counted, its gap in gaps.log",
        |b| {
            std::thread::sleep(Duration::from_secs(1));
            b.terminate(logger, Duration::from_secs(10));
            let stats = LoggerStats::read(&log).unwrap();
            assert!(stats.writing, "{stats:?}");
            assert_eq!(stats.samples_lost, 0, "samples missed on the bus: {stats:?}");
            assert!(stats.samples_unwritten > 0, "{stats:?}");
            let gaps = std::fs::read_to_string(log.join("gaps.log")).unwrap();
            let counted: u64 = gaps
                .lines()
                .filter_map(|l| l.strip_prefix("unwritten "))
                .map(|l| l.rsplit(' ').next().unwrap().parse::<u64>().unwrap())
                .sum();
            assert_eq!(counted, stats.samples_unwritten, "gaps.log:\n{gaps}\n{stats:?}");
            // The log as the operator reads it: hob log export counts the records written.
            let csv = b.art.join("export.csv");
            let o = b.hob(&["log", "export", &path(&log), "--csv", "--out", &path(&csv)]);
            assert_eq!(o.code, Some(0), "hob log export: {}", o.text);
            let rows = std::fs::read_to_string(&csv).unwrap().lines().count() as u64 - 1;
            assert_eq!(
                rows + stats.samples_unwritten,
                stats.samples,
                "rows exported {rows} + not written {} = received {}",
                stats.samples_unwritten,
                stats.samples
            );
            format!(
                "{} samples received, {} not written ({} in gaps.log), {rows} exported; {}",
                stats.samples,
                stats.samples_unwritten,
                counted,
                gaps.lines()
                    .filter(|l| l.starts_with("unwritten"))
                    .collect::<Vec<_>>()
                    .join("; ")
            )
        },
    );
}

/// The virtual machine going silent mid-cut (`kill -STOP hob-sim`) makes hob-rt fault and
/// retract.
#[test]
#[ignore = "needs the release binaries and a bus; ci/test runs it (--ignored)"]
fn silent_machine_mid_cut() {
    let mut b = Bench::new("silent_machine_mid_cut");
    let machine = b.session_machine().write(&b.art.join("machine.toml"));
    let (sim, _rt) = start_service(&mut b, &machine, 2, Homing::Short);
    let iface = b.iface.clone();
    let wd = b.spawn(
        "hob-watchdog",
        "hob-watchdog",
        &["--iface", &iface, "--machine", &path(&machine)],
        "watchdog2.txt",
    );
    b.step(
        "second session: power-up, referencing, load, start, cutting",
        |b| {
            b.wait_state("idle", STATE_TIMEOUT);
            b.reference(STATE_TIMEOUT);
            b.hob_ok(&["load", &program_arg()]);
            b.hob_ok(&["start"]);
            b.wait_state("cut", STATE_TIMEOUT);
            String::new()
        },
    );
    b.step(
        "virtual machine silent mid-cut: hob-rt faults and retracts",
        |b| {
            b.signal(sim, "STOP");
            std::thread::sleep(Duration::from_secs(2));
            let o = b.hob(&["status", "--json"]);
            b.signal(sim, "CONT");
            std::fs::write(b.art.join("silent-status.json"), &o.stdout).unwrap();
            assert_eq!(o.code, Some(0), "hob status --json: {}", o.text);
            let s: hob_system_tests::Status = serde_json::from_str(&o.stdout).unwrap();
            assert!(
                s.alarm.starts_with("feedback of drive ") && s.alarm.contains(" lost"),
                "alarm '{}', not the feedback of a drive lost",
                s.alarm
            );
            assert!(
                ["f_retract", "f_stop", "fault"].contains(&s.state.as_str()),
                "state {}, not retracting, stopping or faulted",
                s.state
            );
            format!("{}, alarm {}", s.state, s.alarm)
        },
    );
    b.step("the loop reports it lost the machine: the watchdog trips", |b| {
        let s = b.wait_state("fault", STATE_TIMEOUT);
        let log = b.log_of(wd);
        let trip = b.wait_for("the watchdog's trip report", Duration::from_secs(30), |_| {
            let text = std::fs::read_to_string(&log).map_err(|e| e.to_string())?;
            WatchdogTrip::find(&text).ok_or_else(|| "no trip reported yet".to_string())
        });
        assert!(trip.tripped, "{trip:?}");
        assert!(
            trip.reason
                .starts_with("loop reports it lost the machine: feedback of drive "),
            "the watchdog's reason: {} (the loop's alarm: {})",
            trip.reason,
            s.alarm
        );
        trip.reason
    });
    b.step(
        "the fault's flight record replays bit for bit (hob replay)",
        |b| {
            let dir = b.art.join("flight");
            let file = b.wait_for("the fault's flight record", STATE_TIMEOUT, |_| {
                std::fs::read_dir(&dir)
                    .map_err(|e| format!("{}: {e}", dir.display()))?
                    .flatten()
                    .map(|e| e.path())
                    .find(|p| p.to_string_lossy().ends_with("-fault.hobfr"))
                    .ok_or_else(|| format!("no *-fault.hobfr in {} yet", dir.display()))
            });
            let o = b.hob(&["replay", &path(&file)]);
            assert_eq!(o.code, Some(0), "hob replay: {}", o.text);
            assert!(o.text.contains("fault: feedback of drive "), "{}", o.text);
            assert!(
                o.text
                    .contains("every output identical to the recorded one, bit for bit"),
                "{}",
                o.text
            );
            let what_if = b.hob(&["replay", &path(&file), "--observer-bandwidth-hz", "5"]);
            assert_eq!(
                what_if.code,
                Some(0),
                "hob replay --observer-bandwidth-hz 5: {}",
                what_if.text
            );
            assert!(
                what_if
                    .text
                    .contains("what if the spindle observer's bandwidth were 5 Hz instead of 10 Hz, the machine answering"),
                "{}",
                what_if.text
            );
            format!(
                "{}\n    {}",
                o.stdout.trim_end().replace('\n', "\n    "),
                what_if.stdout.lines().skip(2).collect::<Vec<_>>().join("\n    ")
            )
        },
    );
    b.step("reset through the service clears the fault", |b| {
        b.hob_ok(&["reset"]);
        let s = b.wait_for("the state after the reset", STATE_TIMEOUT, |b| {
            let s = b.try_status()?;
            if s.state == "fault" {
                Err(format!("state {}", s.state))
            } else {
                Ok(s)
            }
        });
        assert!(s.alarm.is_empty(), "alarm after the reset: {}", s.alarm);
        s.state
    });
}

/// The operator's path from power-on to a continued cut, through the CLI as an operator
/// (or the touch HMI, which sends the same commands) goes: power-on with X and Y
/// unreferenced, referencing by the drives' homing, touch-off (the loop computes the
/// offsets, hob-rt saves them atomically), a program from the library, feed and spindle
/// overrides in the cut, a drive fault in the cut (X retracts, the loop stops), the fault
/// repaired and reset, and the program continued from the interrupted pass on the same part.
#[test]
#[ignore = "needs the release binaries and a bus; ci/test runs it (--ignored)"]
fn operator_path_from_power_on_to_a_continued_cut() {
    use std::io::Write as _;
    let mut b = Bench::new("operator_path");
    let m = b.session_machine();
    let machine = m.write(&b.art.join("machine.toml"));
    let (iface, program) = (b.iface.clone(), program_arg());
    let mut sim = b.command("hob-sim");
    sim.args([
        "--iface",
        &iface,
        "--machine",
        &path(&machine),
        "--program",
        &program,
        "--rt-priority",
        "75",
        "--control",
    ])
    .stdin(std::process::Stdio::piped());
    let sim = b.spawn_cmd("hob-sim", sim, "sim3.txt");
    let mut faults = b.stdin_of(sim);
    std::thread::sleep(Duration::from_millis(300));
    let state_file = b.art.join("machine-state3.toml");
    b.spawn(
        "hob-rt",
        "hob-rt",
        &[
            "--iface",
            &iface,
            "--machine",
            &path(&machine),
            "--state-file",
            &path(&state_file),
        ],
        "rt3.txt",
    );
    // The logger records every event (a `hob status` started later sees only new ones).
    let session = b.art.join("session");
    b.spawn("hob-logger", "hob-logger", &[&session], "logger3.txt");
    let library = path(&b.art.join("library"));
    let float = |v: &toml::Value| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)).unwrap();
    let home_mm = [
        float(m.get("x.homing.home_position_mm")),
        float(m.get("y.homing.home_position_mm")),
    ];
    let tip_diameter_mm = float(TomlDoc::load(&session_program()).get("tool.outside_diameter_mm"));

    b.step("power-on: idle, X and Y not referenced, no work offsets", |b| {
        let s = b.wait_state("idle", STATE_TIMEOUT);
        assert!(!s.x_referenced && !s.y_referenced, "{s:?}");
        assert_eq!((s.x_offset_mm, s.y_offset_mm), (0.0, 0.0));
        assert!(!state_file.exists(), "a machine state file before any touch-off");
        String::new()
    });
    b.step("referencing X and Y from wherever the drives powered up", |b| {
        let s = b.reference(STATE_TIMEOUT);
        // The drives end their homing standing on the home position (offsets still 0).
        assert!(
            (s.x_mm - home_mm[0]).abs() < 0.05 && (s.y_mm - home_mm[1]).abs() < 0.05,
            "X {} Y {} mm after homing, home positions {home_mm:?}",
            s.x_mm,
            s.y_mm
        );
        format!("X {:.3} mm, Y {:.3} mm", s.x_mm, s.y_mm)
    });
    b.step(
        "continuous jog by hob jog-hold; kill -9 of it stops X by the dead-man",
        |b| {
            let jog = b.spawn(
                "hob jog-hold",
                "hob",
                &["jog-hold", "x", "-", "--speed", "300", "--seconds", "60"],
                "jog-hold.txt",
            );
            let s0 = b.wait_for("X moving under hob jog-hold", STATE_TIMEOUT, |b| {
                let s = b.try_status()?;
                if s.state == "jog" && home_mm[0] - s.x_mm > 0.5 {
                    Ok(s)
                } else {
                    Err(format!("state {}, X {} mm", s.state, s.x_mm))
                }
            });
            b.kill9(jog);
            let s1 = b.wait_state("idle", STATE_TIMEOUT);
            std::thread::sleep(Duration::from_secs(1));
            let s2 = b.status();
            let events = session.join("events.log");
            let line = b.wait_for(
                "the dead-man stop in the logger's events.log",
                STATE_TIMEOUT,
                |_| {
                    let text = std::fs::read_to_string(&events).map_err(|e| e.to_string())?;
                    text.lines()
                        .find(|l| l.contains("dead-man"))
                        .map(str::to_string)
                        .ok_or_else(|| format!("{} lines, none with dead-man", text.lines().count()))
                },
            );
            assert!(line.contains("jog X stopped"), "{line}");
            assert!(
                (s2.x_mm - s1.x_mm).abs() < 0.01,
                "X still moving after the stop: {} -> {} mm",
                s1.x_mm,
                s2.x_mm
            );
            let soft_min_mm = float(m.get("x.soft_limit_min_mm"));
            assert!(
                s2.x_mm > soft_min_mm + 10.0,
                "X {} mm: it ran on towards the soft limit {soft_min_mm} mm",
                s2.x_mm
            );
            // After the kill X ran on for the dead-man time (machine file's [jog]) and braking
            // at 300 mm/min: a fraction of a millimetre, plus how late the kill came.
            format!("X {:.3} mm when killed, stopped at {:.3} mm", s0.x_mm, s2.x_mm)
        },
    );
    b.step("the program into the library and loaded from it", |b| {
        b.hob_ok(&[
            "lib",
            "--library",
            &library,
            "programs",
            "create",
            "session-gear",
            &program,
        ]);
        let list = b
            .hob_ok(&["lib", "--library", &library, "programs", "list"])
            .stdout;
        assert!(list.contains("session-gear"), "hob lib programs list:\n{list}");
        let o = b.hob(&["load", "--lib", "no-such-gear", "--library", &library]);
        assert_eq!(o.code, Some(2), "hob load --lib no-such-gear: {}", o.text);
        assert!(!b.status().program_loaded, "a program loaded after the refusal");
        b.hob_ok(&["load", "--lib", "session-gear", "--library", &library]);
        assert!(b.status().program_loaded);
        list.trim().to_string()
    });
    b.step(
        "touch-off: the loop computes the offsets, hob-rt saves them, hob status shows them",
        |b| {
            let s = b.status();
            // Gauges chosen so that the offsets come out +0.1 mm (X) and -0.2 mm (Y):
            // X = gauge radius + tip radius at the touch, Y = gauge height + tip radius.
            let gauge_diameter_mm = 2.0 * (s.x_mm + 0.1) - tip_diameter_mm;
            let gauge_height_mm = s.y_mm - 0.2 - 0.5 * tip_diameter_mm;
            let absurd = b.hob(&["touch-off", "x", "--diameter", "10"]);
            assert_eq!(absurd.code, Some(2), "a 10 mm gauge here: {}", absurd.text);
            assert_eq!(b.status().x_offset_mm, 0.0, "the offset after the refusal");
            // The hob stands beside the blank, on a ring gauge of another size than the
            // blank's: the loop asks first, naming the offset; --confirm sets it.
            let gauge = format!("{gauge_diameter_mm:.6}");
            let asked = b.hob(&["touch-off", "x", "--diameter", &gauge]);
            assert_eq!(asked.code, Some(2), "hob touch-off x unconfirmed: {}", asked.text);
            for needle in [
                "does not fit what the machine knows",
                // +0.1 mm within a count or two (the figures have 4 decimals).
                "X offset +0.0000 mm -> +0.",
                "than the loaded blank's outside diameter",
                "--confirm",
            ] {
                assert!(asked.text.contains(needle), "{needle:?} not in {}", asked.text);
            }
            assert_eq!(b.status().x_offset_mm, 0.0, "the offset after the question");
            let x = b.hob_ok(&["touch-off", "x", "--diameter", &gauge, "--confirm"]);
            assert!(x.text.contains("saved in"), "hob touch-off x: {}", x.text);
            assert!(
                x.text.contains("X offset +0.0000 mm -> +0."),
                "hob touch-off x: {}",
                x.text
            );
            let y = b.hob_ok(&["touch-off", "y", "--height", &format!("{gauge_height_mm:.6}")]);
            assert!(y.text.contains("saved in"), "hob touch-off y: {}", y.text);
            let t = b.status();
            // Within 1 um: X and Y at rest may move by a count (0.33 um) between the status
            // read above and the touch-off (the servo holding against the ways' static
            // friction, config/plant.toml), and the loop computes from its own reading.
            assert!(
                (t.x_offset_mm - 0.1).abs() < 1e-3 && (t.y_offset_mm + 0.2).abs() < 1e-3,
                "offsets {} {}",
                t.x_offset_mm,
                t.y_offset_mm
            );
            // Nothing moved: the work position is the machine position plus the offset.
            assert!((t.x_mm - s.x_mm - 0.1).abs() < 0.01, "X {} -> {}", s.x_mm, t.x_mm);
            let saved = TomlDoc::load(&state_file);
            assert!(
                (float(saved.get("x_offset_mm")) - t.x_offset_mm).abs() < 1e-9
                    && (float(saved.get("y_offset_mm")) - t.y_offset_mm).abs() < 1e-9,
                "{}: {}",
                state_file.display(),
                saved.table
            );
            format!(
                "offsets X {:+.4} Y {:+.4} mm, saved",
                t.x_offset_mm, t.y_offset_mm
            )
        },
    );
    b.step(
        "start; feed and spindle overrides in the cut, one out of range refused",
        |b| {
            b.hob_ok(&["start"]);
            b.wait_state("cut", STATE_TIMEOUT);
            b.hob_ok(&["override", "feed", "80"]);
            b.hob_ok(&["override", "spindle", "110"]);
            let o = b.hob(&["override", "feed", "150"]);
            assert_eq!(o.code, Some(2), "hob override feed 150: {}", o.text);
            let s = b.status();
            assert_eq!(
                (
                    s.state.as_str(),
                    s.feed_override_percent,
                    s.spindle_override_percent
                ),
                ("cut", 80.0, 110.0),
                "alarm '{}'",
                s.alarm
            );
            o.text
        },
    );
    let mut pass_at_fault = 0;
    b.step(
        "a drive fault in the cut: X retracts, the loop stops, the pass is kept",
        |b| {
            let before = b.status();
            pass_at_fault = before.pass;
            writeln!(faults, "drive-fault y").unwrap();
            let s = b.wait_state("fault", STATE_TIMEOUT);
            assert!(s.alarm.contains('Y'), "alarm '{}'", s.alarm);
            // The alarm says what the drive reported and what happened in the cut, only.
            assert!(
                s.alarm_drive_reported
                    .as_deref()
                    .is_some_and(|r| r.starts_with("drive Y reported EMCY 0x")),
                "{s:?}"
            );
            assert!(
                s.alarm_reaction.starts_with("X retracted to its safe position"),
                "{s:?}"
            );
            assert!(!s.alarm_reaction.contains("outside a cycle"), "{s:?}");
            assert!(
                s.x_mm > before.x_mm,
                "X {} -> {} mm: not retracted",
                before.x_mm,
                s.x_mm
            );
            assert_eq!(s.continue_pass, Some(pass_at_fault), "{s:?}");
            assert!(s.table_position_whole, "{s:?}");
            let o = b.hob(&["continue"]);
            assert_eq!(o.code, Some(2), "hob continue while faulted: {}", o.text);
            format!("{} in pass {pass_at_fault}", s.alarm)
        },
    );
    b.step(
        "the drive repaired, reset, continue: the interrupted pass is cut again",
        |b| {
            // The safety chain has dropped out by now (the loop opened it at the fault).
            std::thread::sleep(Duration::from_secs(1));
            writeln!(faults, "clear").unwrap();
            b.hob_ok(&["reset"]);
            let s = b.wait_state("idle", STATE_TIMEOUT);
            assert!(s.alarm.is_empty(), "alarm after the reset: {}", s.alarm);
            b.hob_ok(&["continue"]);
            let s = b.wait_state("cut", STATE_TIMEOUT);
            assert_eq!(s.pass, pass_at_fault, "{s:?}");
            b.hob_ok(&["stop"]);
            let s = b.wait_state("idle", STATE_TIMEOUT);
            assert!(s.alarm.is_empty(), "alarm after the stop: {}", s.alarm);
            format!("pass {pass_at_fault} continued")
        },
    );
}

/// `hob-rt --require-rt` refuses to run without the real-time set-up (exit status 3),
/// after the bus is booted and before the loop starts: here without the capabilities and
/// limits for SCHED_FIFO and the memory lock (`prlimit`, `setpriv`, from util-linux).
/// `hob commission delay` over the bus against `hob-sim` whose drives are 250 us slower than
/// the machine file says (the plant's hidden `drives.delay_us`): interrupted by a drive
/// fault and by `kill -9` of the CLI it stops with the table at rest and the machine file
/// unchanged; whole, it finds the hidden delay within 20 us and writes it with its record,
/// the old file kept; the written file is the one hob-rt then starts on.
#[test]
#[ignore = "needs the release binaries and a bus; ci/test runs it (--ignored)"]
fn commissioning_finds_the_hidden_drive_delay_over_the_bus() {
    use std::io::Write as _;
    let mut b = Bench::new("commission");
    let mut m = b.session_machine();
    // A file commissioned on another drive: a copy from another machine, or a drive replaced.
    m.set("commissioning.drive_delay.table_drive_serial", 0x0000_9999);
    let machine = m.write(&b.art.join("machine.toml"));
    let original = std::fs::read_to_string(&machine).unwrap();
    let told_us = m.int("control.drive_delay_us");
    let cycle_us = m.int("control.cycle_period_us") as u64;
    let hidden_us = told_us + 250;
    let plant_text = std::fs::read_to_string(b.root.join("config/plant.toml")).unwrap();
    assert!(
        plant_text.contains("\n# delay_us = 1000\n"),
        "config/plant.toml's [drives] delay line moved"
    );
    // The spindle encoder's error with its harmonics, hidden too (none the shipped; a true
    // swing beside it is bench/plant/tests/spindle_encoder.rs's, in-process).
    let hidden_error_arcsec = 15.0;
    for line in [
        "\nencoder_error_arcsec = 26.0\n",
        "\n# encoder_error_2_arcsec = 6.0\n",
        "\n# encoder_error_3_arcsec = 3.0\n",
    ] {
        assert!(plant_text.contains(line), "config/plant.toml's {line:?} moved");
    }
    let plant = b.art.join("plant.toml");
    std::fs::write(
        &plant,
        plant_text
            .replace("\n# delay_us = 1000\n", &format!("\ndelay_us = {hidden_us}\n"))
            .replace(
                "\nencoder_error_arcsec = 26.0\n",
                &format!("\nencoder_error_arcsec = {hidden_error_arcsec}\n"),
            )
            .replace(
                "\n# encoder_error_2_arcsec = 6.0\n",
                "\nencoder_error_2_arcsec = 4.0\n",
            )
            .replace(
                "\n# encoder_error_3_arcsec = 3.0\n",
                "\nencoder_error_3_arcsec = 2.0\n",
            ),
    )
    .unwrap();
    let sim = b.spawn_cmd("hob-sim", sim_on_plant(&b, &machine, &plant), "sim.txt");
    let mut control = b.stdin_of(sim);
    std::thread::sleep(Duration::from_millis(300));
    let state = b.art.join("machine-state.toml");
    let rt = spawn_rt(&mut b, &machine, &state, "rt.txt");
    let commission = |yes: bool| {
        let mut a = vec![
            "commission".to_string(),
            "delay".into(),
            "--machine".into(),
            path(&machine),
        ];
        if yes {
            a.push("--yes".into());
        }
        a
    };
    let unchanged = |b: &Bench, what: &str| unchanged(b, &machine, &original, what);
    let at_rest = |b: &Bench| {
        let a = b.status();
        std::thread::sleep(Duration::from_millis(400));
        let z = b.status();
        assert!(z.cycle > a.cycle, "the loop stands");
        assert!(
            (z.table_deg - a.table_deg).abs() < 1e-3,
            "the table moves: {} then {} deg",
            a.table_deg,
            z.table_deg
        );
        format!("table at rest at {:.3} deg", z.table_deg)
    };

    b.step("power-up to idle", |b| {
        b.wait_state("idle", STATE_TIMEOUT);
        String::new()
    });
    b.step("before commissioning: START refused, the drive named", |b| {
        let log = std::fs::read_to_string(b.log_of(rt)).unwrap();
        assert!(log.contains("measured on another drive"), "{log}");
        b.hob_ok(&["load", &program_arg()]);
        let o = b.hob(&["start"]);
        assert_eq!(o.code, Some(2), "hob start: {}", o.text);
        assert!(o.text.contains("hob commission delay"), "hob start: {}", o.text);
        assert_eq!(b.status().state, "idle");
        o.text
    });
    b.step(
        "refused: a jog speed beyond the command's limits, nothing moves",
        |b| {
            let mut a = commission(true);
            a.extend(["--speed".into(), "5000".into()]);
            let o = b.hob(&a);
            assert_eq!(o.code, Some(2), "{}", o.text);
            assert!(o.text.contains("--speed"), "{}", o.text);
            unchanged(b, "a refused speed");
            String::new()
        },
    );
    b.step("a drive fault mid-measurement stops it: nothing written", |b| {
        let p = b.spawn("hob commission", "hob", &commission(true), "commission-fault.txt");
        std::thread::sleep(Duration::from_millis(1500));
        writeln!(control, "drive-fault b").unwrap();
        let st = b.wait_exit(p, Duration::from_secs(60));
        let out = std::fs::read_to_string(b.log_of(p)).unwrap();
        assert!(!st.success(), "hob commission went on after the fault: {out}");
        assert!(
            out.contains("nothing written") || out.contains("unchanged"),
            "{out}"
        );
        let s = b.wait_state("fault", STATE_TIMEOUT);
        unchanged(b, "the drive fault");
        writeln!(control, "clear").unwrap();
        std::thread::sleep(Duration::from_millis(300));
        b.hob_ok(&["reset"]);
        b.wait_state("idle", STATE_TIMEOUT);
        let detail = at_rest(b);
        format!("{}; {detail}", s.alarm)
    });
    b.step(
        "kill -9 of the CLI mid-jog: the dead-man stops the table, nothing written",
        |b| {
            let p = b.spawn("hob commission", "hob", &commission(true), "commission-kill.txt");
            std::thread::sleep(Duration::from_millis(1500));
            let moving = b.status();
            b.kill9(p);
            std::thread::sleep(Duration::from_millis(800));
            let detail = at_rest(b);
            assert_eq!(b.status().state, "idle");
            unchanged(b, "kill -9");
            format!("jogging at {:.3} deg when killed; {detail}", moving.table_deg)
        },
    );
    let mut found_us = 0.0;
    b.step("whole: the hidden delay found and written with its record", |b| {
        let dry = b.hob(&commission(false));
        assert_eq!(dry.code, Some(0), "{}", dry.text);
        assert!(dry.text.contains("not written"), "{}", dry.text);
        unchanged(b, "without --yes or a typed yes");
        let o = b.hob_ok(&commission(true));
        let line = o
            .text
            .lines()
            .find(|l| l.starts_with("found "))
            .unwrap_or_else(|| panic!("{}", o.text));
        found_us = line["found ".len()..].split(' ').next().unwrap().parse().unwrap();
        assert!(
            (found_us - hidden_us as f64).abs() <= 20.0,
            "{hidden_us} us hidden, {found_us} us found:\n{}",
            o.text
        );
        let written = TomlDoc::load(&machine);
        assert_eq!(written.int("control.drive_delay_us"), found_us.round() as i64);
        assert_eq!(
            written.int("commissioning.drive_delay.table_drive_serial"),
            0x1002
        );
        assert!(
            written
                .get("commissioning.drive_delay.found_us")
                .as_float()
                .is_some()
        );
        let kept: Vec<_> = std::fs::read_dir(&b.art)
            .unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.path())
            .filter(|p| p.to_string_lossy().ends_with(".bak"))
            .collect();
        assert_eq!(kept.len(), 1, "{kept:?}");
        assert_eq!(std::fs::read_to_string(&kept[0]).unwrap(), original);
        assert!(o.text.contains("restart hob-rt"), "{}", o.text);
        format!(
            "{hidden_us} us hidden, {found_us:.1} us found ({} told before)",
            told_us
        )
    });
    let mut rt2 = None;
    b.step("hob-rt restarted on the commissioned file", |b| {
        assert!(
            b.terminate(rt, Duration::from_secs(20)).is_some(),
            "hob-rt did not stop"
        );
        rt2 = Some(spawn_rt(b, &machine, &state, "rt2.txt"));
        b.wait_state("idle", STATE_TIMEOUT);
        let log = std::fs::read_to_string(b.art.join("rt2.txt")).unwrap();
        assert!(log.contains("was measured on this drive"), "{log}");
        String::new()
    });
    b.step("commissioned: the cut starts and engages without a fault", |b| {
        b.reference(STATE_TIMEOUT);
        b.hob_ok(&["load", &program_arg()]);
        b.hob_ok(&["start"]);
        let cut = b.wait_state("cut", STATE_TIMEOUT);
        // Two seconds of the loop's cycles into the cut: past the gearbox's engagement.
        let s = b.wait_for("two seconds of cut", STATE_TIMEOUT, |b| {
            let s = b.try_status()?;
            if !s.alarm.is_empty() || s.state != "cut" {
                return Ok(s);
            }
            if s.cycle > cut.cycle + 2_000_000 / cycle_us {
                Ok(s)
            } else {
                Err(format!("cycle {}", s.cycle))
            }
        });
        assert!(
            s.alarm.is_empty() && s.state == "cut",
            "state {}, alarm '{}'",
            s.state,
            s.alarm
        );
        b.hob_ok(&["stop"]);
        b.wait_state("idle", STATE_TIMEOUT);
        format!("pass {} at cycle {}, no alarm", s.pass, s.cycle)
    });
    // The spindle encoder (issue 33, step 4).
    let encoder = |extra: &[&str]| {
        let mut a: Vec<String> = ["commission", "encoder", "--machine", &path(&machine)]
            .iter()
            .map(|s| s.to_string())
            .collect();
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let commissioned = std::fs::read_to_string(&machine).unwrap();
    let kept = |b: &Bench| {
        std::fs::read_dir(&b.art)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".bak"))
            .count()
    };
    let kept_before = kept(&b);
    let same_files = |b: &Bench, what: &str| {
        assert_eq!(
            std::fs::read_to_string(&machine).unwrap(),
            commissioned,
            "{what}: the machine file changed"
        );
        assert_eq!(kept(b), kept_before, "{what}: a file was kept");
    };
    b.step(
        "encoder: too few speeds, and a speed above the spindle's largest, refused",
        |b| {
            let o = b.hob(&encoder(&["--speeds", "60,130", "--yes"]));
            assert_eq!(o.code, Some(2), "{}", o.text);
            assert!(o.text.contains("at least 3"), "{}", o.text);
            let o = b.hob(&encoder(&["--speeds", "60,130,400", "--yes"]));
            assert_eq!(o.code, Some(2), "{}", o.text);
            assert!(o.text.contains("max_spindle_rpm"), "{}", o.text);
            same_files(b, "refused speeds");
            String::new()
        },
    );
    b.step("encoder: refused while cutting, the cut goes on", |b| {
        b.hob_ok(&["start"]);
        b.wait_state("cut", STATE_TIMEOUT);
        let o = b.hob(&encoder(&["--yes"]));
        assert_eq!(o.code, Some(2), "{}", o.text);
        let s = b.status();
        assert!(s.alarm.is_empty() && s.state == "cut", "{} {}", s.state, s.alarm);
        b.hob_ok(&["stop"]);
        b.wait_state("idle", STATE_TIMEOUT);
        same_files(b, "while cutting");
        o.text.lines().last().unwrap_or_default().to_string()
    });
    b.step(
        "encoder: kill -9 of the CLI mid-run: the spindle stops, nothing written",
        |b| {
            let p = b.spawn("hob commission", "hob", &encoder(&["--yes"]), "encoder-kill.txt");
            let turning = b.wait_for("the spindle turning", STATE_TIMEOUT, |b| {
                let s = b.try_status()?;
                if s.spindle_rpm.abs() > 30.0 {
                    Ok(s)
                } else {
                    Err(format!("{:.1} rpm", s.spindle_rpm))
                }
            });
            b.kill9(p);
            let stopped = b.wait_for("the spindle stopped", STATE_TIMEOUT, |b| {
                let s = b.try_status()?;
                if s.spindle_rpm.abs() < 1.0 {
                    Ok(s)
                } else {
                    Err(format!("{:.1} rpm", s.spindle_rpm))
                }
            });
            assert_eq!(stopped.state, "idle");
            same_files(b, "kill -9");
            format!("{:.0} rpm when killed, at rest since", turning.spindle_rpm)
        },
    );
    // The error is written within the issue's 10 %: over the bus it came out 13.6-21.4 for
    // 15 (refused or written) while the loop trimmed the held spindle through the coupler's
    // 50 ms analog updates; with the trim kept once at speed, 15.20, 15.48, 15.68 and 14.85
    // on the host's bus (docs/commands.md). In the emulated guest, whose CPUs stall for tens
    // of ms (HOB_SYNC_BOUND_FACTOR 2), 16.20: there the share is 10 % times that factor.
    let share = 0.1 * hob_system_tests::sync_bound_factor();
    let mut written_record = false;
    b.step(
        "encoder: whole, the error written within 10 % (x HOB_SYNC_BOUND_FACTOR)",
        |b| {
            // Three speeds, 12 s each: about a minute and a half (the default, six speeds 30 s
            // each, takes five).
            let o = b.hob(&encoder(&["--speeds", "64,110,212", "--seconds", "12", "--yes"]));
            assert_eq!(o.code, Some(0), "{}", o.text);
            let written = TomlDoc::load(&machine);
            let get = |key: &str| {
                written
                    .get(&format!("commissioning.spindle_encoder.{key}"))
                    .as_float()
                    .unwrap_or_else(|| panic!("{key}: {}", o.text))
            };
            let (found, second, swing) = (get("error_arcsec"), get("error_2_arcsec"), get("swing_arcsec"));
            assert!(
                (found - hidden_error_arcsec).abs() <= share * hidden_error_arcsec,
                "{hidden_error_arcsec} arcsec hidden, {found:.2} found ({:.0} % allowed):\n{}",
                share * 100.0,
                o.text
            );
            assert!((second - 4.0).abs() <= 2.0, "2nd: 4 hidden, {second:.2} found");
            assert!(swing < 1.0, "a swing of {swing:.1} arcsec claimed:\n{}", o.text);
            assert!(o.text.contains("restart hob-rt"), "{}", o.text);
            written_record = true;
            format!(
                "written: {hidden_error_arcsec} arcsec hidden, {found:.2} found (2nd: 4 hidden, \
             {second:.2} found), no swing claimed"
            )
        },
    );
    b.step(
        "hob-rt restarted: the record read (or its absence said), idle",
        |b| {
            let rt2 = rt2.expect("hob-rt restarted");
            assert!(
                b.terminate(rt2, Duration::from_secs(20)).is_some(),
                "hob-rt did not stop"
            );
            spawn_rt(b, &machine, &state, "rt3.txt");
            b.wait_state("idle", STATE_TIMEOUT);
            let log = std::fs::read_to_string(b.art.join("rt3.txt")).unwrap();
            let said = if written_record {
                "told apart"
            } else {
                "spindle encoder is not commissioned"
            };
            assert!(log.contains(said), "{log}");
            String::new()
        },
    );
}

/// `hob commission response` over the bus against `hob-sim`, whose table is hidden: 12 kg m2
/// on a mesh of 3.0e6 Nm/rad without play (the shipped plant file says 20 kg m2, 2.0e6 and
/// 10 arcsec), the mesh's anti-resonance sqrt(k / J_t) / 2 pi = 79.6 Hz: a machine file
/// without `[table.drive_model]` and a frequency beyond a quarter of the loop's rate are
/// refused before anything moves; kill -9 of the CLI mid-sweep fades the swing by the
/// dead-man, nothing written; whole, the anti-resonance is found within 5 %, the gains the
/// drive reported are kept as the previous ones and the proposed gains written as
/// `[commissioning.table_drive_gains]` with the Bode plot beside; restarted on the file,
/// hob-rt's boot writes the gains to the drive and reads them back, and `hob commission
/// report` says them.
#[test]
#[ignore = "needs the release binaries and a bus; ci/test runs it (--ignored)"]
fn commissioning_measures_the_table_response_and_writes_the_gains_over_the_bus() {
    let mut b = Bench::new("commission-response");
    let mut m = b.session_machine();
    let machine = m.write(&b.art.join("machine.toml"));
    let original = std::fs::read_to_string(&machine).unwrap();
    m.table
        .get_mut("table")
        .and_then(toml::Value::as_table_mut)
        .unwrap()
        .remove("drive_model");
    let bare = m.write(&b.art.join("no-drive-model.toml"));
    let (j_t, k) = (12.0f64, 3.0e6f64);
    let hidden_hz = (k / j_t).sqrt() / std::f64::consts::TAU;
    let plant_text = std::fs::read_to_string(b.root.join("config/plant.toml")).unwrap();
    let edits = [
        (
            "\ntable_inertia_kg_m2 = 20.0 ",
            format!("\ntable_inertia_kg_m2 = {j_t} "),
        ),
        (
            "\nstiffness_nm_rad = 2.0e6\n",
            format!("\nstiffness_nm_rad = {k:e}\n"),
        ),
        (
            "\nbacklash_arcsec = 10.0\n",
            "\nbacklash_arcsec = 0.0\n".to_string(),
        ),
    ];
    let mut hidden = plant_text.clone();
    for (from, to) in &edits {
        assert!(hidden.contains(from), "config/plant.toml's line {from:?} moved");
        hidden = hidden.replace(from, to);
    }
    let plant = b.art.join("plant.toml");
    std::fs::write(&plant, hidden).unwrap();
    b.spawn_cmd("hob-sim", sim_on_plant(&b, &machine, &plant), "sim.txt");
    std::thread::sleep(Duration::from_millis(300));
    let state = b.art.join("machine-state.toml");
    let rt = spawn_rt(&mut b, &machine, &state, "rt.txt");
    let cycle_us = std::env::var("HOB_CYCLE_US")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(1000.0);
    let to_hz = format!("{:.0}", (0.25e6 / cycle_us).min(250.0));
    // The guest's slower loop (HOB_CYCLE_US): fewer points, the same procedure.
    let points = if cycle_us > 1000.0 { "10" } else { "16" };
    let svg = b.art.join("bode.svg");
    let response = |file: &Path, extra: &[&str]| {
        let mut a: Vec<String> = [
            "commission",
            "response",
            "--machine",
            &path(file),
            "--to",
            &to_hz,
            "--points",
            points,
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let unchanged = |b: &Bench, what: &str| unchanged(b, &machine, &original, what);
    b.step("power-up to idle", |b| {
        b.wait_state("idle", STATE_TIMEOUT);
        String::new()
    });
    b.step("refused: no [table.drive_model], a frequency too high", |b| {
        let before = b.status();
        let o = b.hob(&response(&bare, &["--yes"]));
        assert_eq!(o.code, Some(2), "{}", o.text);
        assert!(o.text.contains("[table.drive_model]"), "{}", o.text);
        let o = b.hob(&response(&machine, &["--to", "900", "--yes"]));
        assert_eq!(o.code, Some(2), "{}", o.text);
        assert!(o.text.contains("--to"), "{}", o.text);
        assert!(
            (b.status().table_deg - before.table_deg).abs() < 1e-3,
            "the table moved"
        );
        unchanged(b, "refused");
        String::new()
    });
    b.step(
        "kill -9 of the CLI mid-sweep: the swing fades, nothing written",
        |b| {
            let args = response(&machine, &["--yes"]);
            let p = b.spawn("hob commission", "hob", &args, "commission-kill.txt");
            b.wait_state("jog", STATE_TIMEOUT);
            std::thread::sleep(Duration::from_millis(1500));
            b.kill9(p);
            b.wait_state("idle", Duration::from_secs(5));
            unchanged(b, "kill -9");
            String::new()
        },
    );
    b.step(
        "whole: the anti-resonance found, the gains proposed and written",
        |b| {
            let o = b.hob_ok(&response(&machine, &["--yes", "--svg", &path(&svg)]));
            let written = TomlDoc::load(&machine);
            let key = |k: &str| {
                written
                    .get(&format!("commissioning.table_drive_gains.{k}"))
                    .as_float()
                    .unwrap_or_else(|| panic!("{k}:\n{}", o.text))
            };
            let found_hz = key("mesh_antiresonance_hz");
            assert!(
                (found_hz / hidden_hz - 1.0).abs() < 0.05,
                "{hidden_hz:.1} Hz hidden, {found_hz:.1} Hz found:\n{}",
                o.text
            );
            assert!(key("velocity_phase_margin_deg") >= 44.9 && key("position_gain_margin_db") >= 6.0);
            assert!(key("previous_velocity_kp_nm_s_per_rad") > 0.0);
            let plot = std::fs::read_to_string(&svg).unwrap();
            assert!(
                plot.starts_with("<svg") && plot.contains("anti-resonance"),
                "{plot}"
            );
            let line = o
                .text
                .lines()
                .find(|l| l.starts_with("mesh anti-resonance"))
                .unwrap_or_default();
            format!("{hidden_hz:.1} Hz hidden: {line}")
        },
    );
    b.step("hob-rt restarted: the boot writes the gains to the drive", |b| {
        assert!(
            b.terminate(rt, Duration::from_secs(20)).is_some(),
            "hob-rt did not stop"
        );
        spawn_rt(b, &machine, &state, "rt2.txt");
        b.wait_state("idle", STATE_TIMEOUT);
        let log = std::fs::read_to_string(b.art.join("rt2.txt")).unwrap();
        let line = log
            .lines()
            .find(|l| l.contains("runs on the gains commissioned"))
            .unwrap_or_else(|| panic!("{log}"))
            .to_string();
        let report = b.hob_ok(&["commission", "report", "--machine", &path(&machine)]);
        assert!(
            report
                .text
                .contains("Table drive's gains (hob commission response"),
            "{}",
            report.text
        );
        line
    });
}

/// `hob commission backlash` over the bus against `hob-sim`, whose worm has a hidden
/// backlash of 25 arcsec (the shipped plant file says 10) and a gauge on the table's rim
/// (the plant's `peripherals.table_gauge`, on the coupler's analog input 0): a machine file
/// that names no gauge, and settings beyond their limits, are refused before anything
/// moves; whole, the lost motion is found within 10 % from the gauge the coupler sends
/// every 50th SYNC and written as `[commissioning.table_backlash]`, the old file kept, and
/// `hob commission report` says it.
#[test]
#[ignore = "needs the release binaries and a bus; ci/test runs it (--ignored)"]
fn commissioning_finds_the_hidden_backlash_over_the_bus() {
    let mut b = Bench::new("commission-backlash");
    let m = b.session_machine();
    let bare = m.write(&b.art.join("no-gauge.toml"));
    let mut m = m;
    let mut gauge = toml::Table::new();
    gauge.insert(
        "table_gauge".into(),
        toml::Value::Table(toml::toml! { channel = 0 }),
    );
    m.table
        .get_mut("io")
        .and_then(toml::Value::as_table_mut)
        .unwrap()
        .insert("analog_inputs".into(), toml::Value::Table(gauge));
    let machine = m.write(&b.art.join("machine.toml"));
    let original = std::fs::read_to_string(&machine).unwrap();
    let hidden_arcsec = 25.0;
    let plant_text = std::fs::read_to_string(b.root.join("config/plant.toml")).unwrap();
    let shipped_line = "\nbacklash_arcsec = 10.0\n";
    assert!(
        plant_text.contains(shipped_line),
        "config/plant.toml's backlash line moved"
    );
    assert!(
        plant_text.contains("[peripherals.table_gauge]"),
        "config/plant.toml has no gauge"
    );
    let plant = b.art.join("plant.toml");
    std::fs::write(
        &plant,
        plant_text.replace(shipped_line, &format!("\nbacklash_arcsec = {hidden_arcsec}\n")),
    )
    .unwrap();
    b.spawn_cmd("hob-sim", sim_on_plant(&b, &machine, &plant), "sim.txt");
    std::thread::sleep(Duration::from_millis(300));
    let state = b.art.join("machine-state.toml");
    spawn_rt(&mut b, &machine, &state, "rt.txt");
    let backlash = |file: &Path, extra: &[&str]| {
        let mut a: Vec<String> = ["commission", "backlash", "--machine", &path(file)]
            .iter()
            .map(|s| s.to_string())
            .collect();
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let unchanged = |b: &Bench, what: &str| unchanged(b, &machine, &original, what);
    b.step("power-up to idle", |b| {
        b.wait_state("idle", STATE_TIMEOUT);
        String::new()
    });
    b.step(
        "refused: a machine file that names no gauge, nothing moves",
        |b| {
            let before = b.status();
            let o = b.hob(&backlash(&bare, &["--yes"]));
            assert_eq!(o.code, Some(2), "{}", o.text);
            assert!(o.text.contains("io.analog_inputs.table_gauge"), "{}", o.text);
            let after = b.status();
            assert!(
                (after.table_deg - before.table_deg).abs() < 1e-3,
                "the table moved"
            );
            unchanged(b, "no gauge");
            o.text.lines().last().unwrap_or_default().to_string()
        },
    );
    b.step(
        "refused: a travel beyond a gauge's stroke, a speed beyond the limits",
        |b| {
            let o = b.hob(&backlash(
                &machine,
                &["--speed", "30", "--seconds", "10", "--yes"],
            ));
            assert_eq!(o.code, Some(2), "{}", o.text);
            assert!(o.text.contains("stroke"), "{}", o.text);
            let o = b.hob(&backlash(&machine, &["--speed", "100", "--yes"]));
            assert_eq!(o.code, Some(2), "{}", o.text);
            assert!(o.text.contains("--speed"), "{}", o.text);
            unchanged(b, "refused settings");
            String::new()
        },
    );
    b.step("whole: the hidden backlash found within 10 % and written", |b| {
        let o = b.hob_ok(&backlash(&machine, &["--yes"]));
        let written = TomlDoc::load(&machine);
        let found = written
            .get("commissioning.table_backlash.lost_motion_arcsec")
            .as_float()
            .unwrap_or_else(|| panic!("{}", o.text));
        assert!(
            (found - hidden_arcsec).abs() <= 0.1 * hidden_arcsec,
            "{hidden_arcsec} arcsec hidden, {found} found:\n{}",
            o.text
        );
        let kept: Vec<_> = std::fs::read_dir(&b.art)
            .unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.path())
            .filter(|p| p.to_string_lossy().ends_with(".bak"))
            .collect();
        assert_eq!(kept.len(), 1, "{kept:?}");
        assert_eq!(std::fs::read_to_string(&kept[0]).unwrap(), original);
        let report = b.hob_ok(&["commission", "report", "--machine", &path(&machine)]);
        assert!(
            report
                .text
                .contains("Table drive's lost motion (hob commission backlash"),
            "{}",
            report.text
        );
        let line = o
            .text
            .lines()
            .find(|l| l.starts_with("lost motion"))
            .unwrap_or_default();
        format!("{hidden_arcsec} arcsec hidden: {line}")
    });
}

#[test]
#[ignore = "needs the release binaries and a bus; ci/test runs it (--ignored)"]
fn require_rt_refuses_to_run_degraded() {
    assert!(
        which("prlimit") && which("setpriv"),
        "prlimit and setpriv (util-linux) are needed"
    );
    let mut b = Bench::new("require_rt_refuses_to_run_degraded");
    let machine = path(&b.session_machine().write(&b.art.join("machine.toml")));
    let (iface, program) = (b.iface.clone(), program_arg());
    b.spawn(
        "hob-sim",
        "hob-sim",
        &["--iface", &iface, "--machine", &machine, "--program", &program],
        "sim.txt",
    );
    std::thread::sleep(Duration::from_millis(300));
    let rt = b.bin.join("hob-rt").display().to_string();
    let mut cmd = b.command_any(
        "prlimit",
        &[
            "--rtprio=0:0",
            "--memlock=65536:65536",
            "--",
            "setpriv",
            "--bounding-set=-sys_nice,-ipc_lock",
            "--",
            &rt,
            "--iface",
            &iface,
            "--machine",
            &machine,
            "--require-rt",
        ],
    );
    cmd.env("HOB_INSTANCE", &b.instance);
    let p = b.spawn_cmd("hob-rt --require-rt", cmd, "rt.txt");
    b.step("exit status 3, saying why", |b| {
        let st = b.wait_exit(p, STATE_TIMEOUT);
        let log = std::fs::read_to_string(b.log_of(p)).unwrap();
        assert_eq!(st.code(), Some(3), "hob-rt --require-rt: {st}\n{log}");
        assert!(
            log.contains("operational"),
            "the bus was not booted first:\n{log}"
        );
        assert!(
            log.contains("DEGRADED") && log.contains("--require-rt: refusing to run degraded"),
            "{log}"
        );
        log.lines()
            .filter(|l| l.contains("  - "))
            .collect::<Vec<_>>()
            .join("; ")
    });
}

/// Frontends of another user (issue 18): the processes of the bus run as its user (here
/// root); an operator's shell and the HMI run as `nobody` and reach the loop through
/// `hob-gateway`, which asks the kernel who is on the other end. A member of the operators'
/// group watches and commands (the loop checks and answers every command as the CLI's), of
/// the viewers' group only watches, anyone else is refused; none of them can join the bus
/// (so none can publish the loop's state) or write the machine file.
#[test]
#[ignore = "needs the release binaries, a bus and root (setpriv); ci/test runs it (--ignored)"]
fn frontends_of_another_user_watch_and_command_through_the_gateway() {
    if hob_system_tests::host_only("frontends_of_another_user_watch_and_command_through_the_gateway") {
        return;
    }
    assert!(which("setpriv"), "setpriv (util-linux) is needed");
    let mut b = Bench::new("gateway");
    let m = b.session_machine();
    let machine = m.write(&b.art.join("machine.toml"));
    // As deployed (README): the machine file root's, readable by all, writable by root alone.
    std::fs::set_permissions(&machine, std::os::unix::fs::PermissionsExt::from_mode(0o644)).unwrap();
    let (_sim, _rt) = start_service(&mut b, &machine, 1, Homing::Full);
    let socket = b.art.join("gateway.sock");
    // Operators: the group `users` (100); viewers: `staff` (50): Debian's base groups.
    let (operators, viewers, nobody) = ("100", "50", "65534");
    let gateway = b.spawn(
        "hob-gateway",
        "hob-gateway",
        &[
            "--socket",
            &path(&socket),
            "--operators",
            "users",
            "--viewers",
            "staff",
        ],
        "gateway.txt",
    );
    b.step("power-up to idle; the gateway listening", |b| {
        b.wait_state("idle", STATE_TIMEOUT);
        let sock = socket.clone();
        b.wait_for("the gateway's socket", Duration::from_secs(30), |_| {
            sock.exists()
                .then_some(())
                .ok_or_else(|| "no socket yet".to_string())
        });
        String::new()
    });
    // `hob ARGS` as uid 65534 with `gid` as its only group, through the gateway (or not).
    let as_nobody = |b: &Bench, gid: &str, through_gateway: bool, args: &[&str]| {
        let mut c = b.command_any(
            "setpriv",
            &["--reuid", nobody, "--regid", gid, "--clear-groups", "--"],
        );
        c.arg(b.bin.join("hob"))
            .args(args)
            .env("HOB_INSTANCE", &b.instance);
        if through_gateway {
            c.env("HOB_GATEWAY", &socket);
        } else {
            c.env_remove("HOB_GATEWAY");
        }
        let o = c.output().unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stdout).to_string(),
            text,
        )
    };
    let program = program_arg();
    b.step(
        "a viewer watches; its command is refused by the gateway and changes nothing",
        |b| {
            let (code, json, text) = as_nobody(b, viewers, true, &["status", "--json"]);
            assert_eq!(code, Some(0), "a viewer's hob status: {text}");
            let st: hob_system_tests::Status =
                serde_json::from_str(&json).unwrap_or_else(|e| panic!("{e}: {json}"));
            assert_eq!(st.state, "idle", "what the viewer saw");
            let (code, _, text) = as_nobody(b, viewers, true, &["load", &program]);
            assert_eq!(code, Some(2), "a viewer's hob load: {text}");
            assert!(text.contains("may watch, not command"), "{text}");
            assert!(!b.status().program_loaded, "the viewer's program was loaded");
            text.trim().to_string()
        },
    );
    b.step(
        "an operator commands: the loop checks and answers through the gateway",
        |b| {
            let (code, _, text) = as_nobody(b, operators, true, &["start"]);
            assert_eq!(code, Some(2), "an operator's hob start without a program: {text}");
            assert!(text.contains("no program loaded"), "the loop's refusal: {text}");
            let (code, _, text) = as_nobody(b, operators, true, &["load", &program]);
            assert_eq!(code, Some(0), "an operator's hob load: {text}");
            assert!(b.status().program_loaded, "the operator's program is not loaded");
            let (code, json, text) = as_nobody(b, operators, true, &["status", "--json"]);
            assert_eq!(code, Some(0), "{text}");
            let st: hob_system_tests::Status =
                serde_json::from_str(&json).unwrap_or_else(|e| panic!("{e}: {json}"));
            assert!(st.program_loaded, "what the operator saw: {json}");
            let log = std::fs::read_to_string(b.log_of(gateway)).unwrap();
            let line = log
                .lines()
                .find(|l| l.contains(": load -> accepted"))
                .unwrap_or_else(|| panic!("the gateway did not record who loaded the program:\n{log}"));
            assert!(line.contains("uid 65534"), "{line}");
            line.to_string()
        },
    );
    b.step("anyone else is refused by the gateway, saying why", |b| {
        let (code, _, text) = as_nobody(b, nobody, true, &["status"]);
        assert_ne!(code, Some(0), "a stranger read the state: {text}");
        assert!(
            text.contains("in none of the groups users (operator), staff (viewer)"),
            "{text}"
        );
        text.trim().to_string()
    });
    b.step(
        "one user's connections are limited; another user's are still served",
        |b| {
            // 16 `hob status --watch` of root through the gateway hold 16 connections.
            let watchers: Vec<std::process::Child> = (0..16)
                .map(|_| {
                    let mut c = b.command("hob");
                    c.args(["status", "--watch"])
                        .env("HOB_GATEWAY", &socket)
                        .stdout(std::process::Stdio::null())
                        .stderr(std::process::Stdio::null());
                    c.spawn().unwrap()
                })
                .collect();
            let log = b.log_of(gateway);
            b.wait_for("16 connections of root", Duration::from_secs(30), |_| {
                let text = std::fs::read_to_string(&log).unwrap_or_default();
                let n = text
                    .lines()
                    .filter(|l| l.contains("root (uid 0,") && l.contains("connected"))
                    .count();
                if n >= 16 {
                    Ok(())
                } else {
                    Err(format!("{n} connected"))
                }
            });
            let mut c = b.command("hob");
            c.args(["status"]).env("HOB_GATEWAY", &socket);
            let o = c.output().unwrap();
            let text = String::from_utf8_lossy(&o.stderr).to_string();
            let (code, _, other) = as_nobody(b, operators, true, &["status", "--json"]);
            for mut w in watchers {
                let _ = w.kill();
                let _ = w.wait();
            }
            assert_ne!(o.status.code(), Some(0), "root's 17th connection was served");
            assert!(text.contains("16 connections open"), "{text}");
            assert_eq!(
                code,
                Some(0),
                "another user's status while root holds 16: {other}"
            );
            text.trim().to_string()
        },
    );
    b.step(
        "the frontends' user cannot join the bus (nor publish the loop's state) nor write the machine file",
        |b| {
            let (code, _, text) = as_nobody(b, operators, false, &["status"]);
            assert_ne!(code, Some(0), "the operator joined the bus: {text}");
            assert!(text.contains("runs as the user"), "{text}");
            let mut c = b.command_any(
                "setpriv",
                &["--reuid", nobody, "--regid", operators, "--clear-groups", "--"],
            );
            c.arg(b.bin.join("hob-loop-double"))
                .args([
                    "--iface",
                    &b.iface.clone(),
                    "--machine",
                    &path(&machine),
                    "--run-ms",
                    "300",
                ])
                .env("HOB_INSTANCE", &b.instance);
            let o = c.output().unwrap();
            assert_eq!(o.status.code(), Some(2), "a publisher of the operators' user");
            let mut c = b.command_any(
                "setpriv",
                &[
                    "--reuid",
                    nobody,
                    "--regid",
                    operators,
                    "--clear-groups",
                    "--",
                    "sh",
                    "-c",
                ],
            );
            c.arg(format!("echo '# changed' >> '{}'", machine.display()));
            let o = c.output().unwrap();
            assert!(!o.status.success(), "the operators' user wrote the machine file");
            assert!(!std::fs::read_to_string(&machine).unwrap().contains("# changed"));
            String::from_utf8_lossy(&o.stderr).trim().to_string()
        },
    );
    b.step(
        "the HMI as the frontends' user: the loop's events reach it through the gateway",
        |b| {
            let library = b.art.join("library");
            std::fs::create_dir_all(&library).unwrap();
            std::fs::set_permissions(&library, std::os::unix::fs::PermissionsExt::from_mode(0o777)).unwrap();
            let mut c = b.command_any(
                "setpriv",
                &["--reuid", nobody, "--regid", operators, "--clear-groups", "--"],
            );
            c.arg(b.bin.join("hob-hmi"))
                .args([
                    "--machine",
                    &path(&machine),
                    "--library",
                    &path(&library),
                    "--bind",
                    "127.0.0.1:0",
                ])
                .env("HOB_INSTANCE", &b.instance)
                .env("HOB_GATEWAY", &socket);
            let hmi = b.spawn_cmd("hob-hmi (nobody, through the gateway)", c, "hmi.txt");
            let log = b.log_of(hmi);
            let addr = b.wait_for("the HMI's address", Duration::from_secs(30), |_| {
                let text = std::fs::read_to_string(&log).unwrap_or_default();
                text.split("serving the panel at http://")
                    .nth(1)
                    .and_then(|r| r.split('/').next())
                    .map(str::to_string)
                    .ok_or_else(|| format!("not serving yet: {text}"))
            });
            let page = b.wait_for(
                "the loop's events on the HMI's alarm page",
                Duration::from_secs(30),
                |_| {
                    let body = http_get(&addr, "/api/alarms/page")?;
                    if body.contains("\"seq\"") {
                        Ok(body)
                    } else {
                        Err(body)
                    }
                },
            );
            let n = page.matches("\"seq\"").count();
            b.terminate(hmi, Duration::from_secs(10));
            format!("{n} events on the alarm page of an HMI running as nobody")
        },
    );
    b.terminate(gateway, Duration::from_secs(10));
}

/// `GET path` from `addr` (HTTP/1.0, the whole body).
fn http_get(addr: &str, path: &str) -> Result<String, String> {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(addr).map_err(|e| format!("{addr}: {e}"))?;
    s.set_read_timeout(Some(Duration::from_secs(10)))
        .map_err(|e| e.to_string())?;
    write!(s, "GET {path} HTTP/1.0\r\nHost: {addr}\r\n\r\n").map_err(|e| e.to_string())?;
    let mut text = String::new();
    s.read_to_string(&mut text).map_err(|e| e.to_string())?;
    Ok(text
        .split_once("\r\n\r\n")
        .map_or(text.as_str(), |x| x.1)
        .to_string())
}

fn which(exe: &str) -> bool {
    std::env::var_os("PATH").is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(exe).is_file()))
}

/// The short two-start helical gear of [`measure_the_first_gear_correct_the_second_over_the_bus`].
const SHORT_HELICAL: &str = "config/programs/demo-short-helical-z41-m2-2start.toml";

/// The gear a recording's last pass left, by hob-sim's truth, as `hob log report DIR`
/// prints it (`  pass N: predicted gear (...): f_pt A um (P % of grade 5 ...), F_p B um
/// (Q % of ...)`): (f_pt um, its share of grade 5, F_p um, its share).
fn truth_gear(b: &Bench, log: &Path) -> (f64, f64, f64, f64, String) {
    let report = b.hob_ok(&["log", "report", &path(log)]);
    let r = Report::parse(&report.stdout).unwrap_or_else(|e| panic!("hob log report: {e}"));
    assert!(r.graded_by_truth, "not graded by the truth:\n{}", report.stdout);
    let line = report
        .stdout
        .lines()
        .rfind(|l| l.starts_with("  pass ") && l.contains(": predicted gear ("))
        .unwrap_or_else(|| panic!("no predicted gear:\n{}", report.stdout))
        .to_string();
    let after = |key: &str| -> (f64, f64) {
        let rest = &line[line.find(key).unwrap_or_else(|| panic!("no {key:?} in {line}")) + key.len()..];
        let words: Vec<&str> = rest.split_whitespace().collect();
        let um = words[0].parse().unwrap_or_else(|_| panic!("{key} in {line}"));
        let pct: f64 = words[2]
            .trim_start_matches('(')
            .parse()
            .unwrap_or_else(|_| panic!("{key}'s share in {line}"));
        (um, pct / 100.0)
    };
    let (fpt, fpt_share) = after("f_pt ");
    let (fp, fp_share) = after("F_p ");
    std::fs::write(
        b.art.join(format!(
            "report-{}.txt",
            log.file_name().unwrap_or_default().to_string_lossy()
        )),
        &report.stdout,
    )
    .unwrap();
    (fpt, fpt_share, fp, fp_share, line)
}

/// Issue 34 over the bus, as an operator does it: on a simulated machine whose worm wheel is
/// ISO 1328-1 grade 6 and whose hob runs out axially by 3 um (hob-sim's plant file; hidden
/// from the controller), the short two-start helical gear is cut (hob-sim, hob-rt,
/// hob-logger as processes), measured by the simulated checker from the recording and
/// hob-sim's truth at three heights (`hob-lab check`), the compensation computed and stored
/// for the table's worm set (`hob compensate --yes`); hob-rt restarted loads it switched
/// off, `hob pitch-compensation on`, `hob new-blank`, the gear cut again. By the truth (the
/// report's predicted gear: the gear itself, every face section of the pass) the second
/// gear is at least three times better in f_pt (2.5 times in the emulated guest, whose
/// stalls add to it) and in F_p than the first, and within grade 5; switching the compensation in the cut is refused; the machine file is not touched.
/// The simulated machine needs no new blank: its blank keeps no memory of a cut.
#[test]
#[ignore = "needs the release binaries and a bus; ci/test runs it (--ignored)"]
fn measure_the_first_gear_correct_the_second_over_the_bus() {
    // On the shared-memory bus `demo_compensate_cuts_measures_compensates_and_cuts_again`
    // runs the same loop (the same program, plant and code, through `hob demo
    // --compensate`): two such tests of two cuts each cost the host's run 70 s. This one,
    // with the operator's commands one by one, runs on vcan0 (the guest, a machine with
    // vcan), where the demo's is left out.
    if hob_system_tests::bus_iface() == "shm" {
        eprintln!(
            "measure_the_first_gear_correct_the_second_over_the_bus: on vcan0 only; on the \
             shared-memory bus demo_compensate_cuts_measures_compensates_and_cuts_again runs the loop"
        );
        return;
    }
    let started = std::time::Instant::now();
    let mut b = Bench::new("compensation");
    let lab = b.bin.join("hob-lab");
    assert!(
        lab.is_file(),
        "{}: not there; cargo build --release --workspace --bins",
        lab.display()
    );
    let program = path(&b.root.join(SHORT_HELICAL));
    let state = b.art.join("machine-state.toml");
    let mut m = b.session_machine();
    assert_eq!(
        m.get("table.worm_set").as_str(),
        Some("B-2019-07"),
        "config/machine.toml's table.worm_set"
    );
    // The compensation is kept beside the state file: this test's, never /var/lib/hob.
    m.set("state.file", path(&state));
    let machine = m.write(&b.art.join("machine.toml"));
    let original = std::fs::read_to_string(&machine).unwrap();
    let mut hidden = std::fs::read_to_string(b.root.join("config/plant.toml")).unwrap();
    // The shipped plant's hob runs out by 3 um already: its line is checked, not changed.
    for (from, to) in [
        ("\nwheel_grade = 4\n", "\nwheel_grade = 6\n"),
        ("\nhob_axial_runout_um = 3.0\n", "\nhob_axial_runout_um = 3.0\n"),
    ] {
        assert!(hidden.contains(from), "config/plant.toml's line {from:?} moved");
        hidden = hidden.replace(from, to);
    }
    let plant = b.art.join("plant.toml");
    std::fs::write(&plant, hidden).unwrap();
    let (log1, log2) = (b.art.join("log1"), b.art.join("log2"));
    std::fs::create_dir_all(&log1).unwrap();
    std::fs::create_dir_all(&log2).unwrap();
    let truth = log1.join("truth.csv");
    let mut sim = b.command("hob-sim");
    sim.args([
        "--iface",
        &b.iface,
        "--machine",
        &path(&machine),
        "--plant",
        &path(&plant),
        "--program",
        &program,
        "--rt-priority",
        "75",
        "--power-on-near-home",
        SHORT_HOMING_MM,
        "--truth",
        &path(&truth),
    ]);
    b.spawn_cmd("hob-sim", sim, "sim.txt");
    std::thread::sleep(Duration::from_millis(300));
    let rt = spawn_rt(&mut b, &machine, &state, "rt1.txt");
    let logger = b.spawn("hob-logger", "hob-logger", &[&log1], "logger1.txt");
    // Cuts with the program loaded; `then` runs once the cut is under way.
    let cut = |b: &mut Bench, then: &dyn Fn(&mut Bench)| {
        b.hob_ok(&["start"]);
        b.wait_state("cut", STATE_TIMEOUT);
        then(b);
        let s = b.wait_state("idle", STATE_TIMEOUT);
        assert!(s.alarm.is_empty(), "alarm after the cut: {}", s.alarm);
    };
    b.step("power-up, referencing, no compensation stored", |b| {
        b.wait_state("idle", STATE_TIMEOUT);
        b.reference(STATE_TIMEOUT);
        let log = std::fs::read_to_string(b.art.join("rt1.txt")).unwrap();
        assert!(
            log.contains("no pitch compensation stored for worm set \"B-2019-07\""),
            "{log}"
        );
        String::new()
    });
    let t_cut = std::time::Instant::now();
    b.step("the first gear: cut", |b| {
        b.hob_ok(&["load", &program]);
        cut(b, &|_| {});
        format!("{:.0} s from start to idle", t_cut.elapsed().as_secs_f64())
    });
    let measured = b.art.join("measured");
    let files: Vec<String> = (1..=3)
        .map(|i| path(&measured.join(format!("measurement-{i}.csv"))))
        .collect();
    b.step(
        "hob-lab check: the checker's files at three heights from the log and the truth",
        |b| {
            assert!(
                b.terminate(logger, Duration::from_secs(10)).is_some(),
                "hob-logger did not stop"
            );
            let mut c = b.command("hob-lab");
            c.args([
                "check",
                "--log",
                &path(&log1),
                "--program",
                &program,
                "--machine",
                &path(&machine),
                "--out",
                &path(&measured),
                "--heights",
                "3",
                "--seed",
                "11",
            ]);
            let o = c.output().unwrap();
            let text = format!(
                "{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            );
            std::fs::write(b.art.join("check.txt"), &text).unwrap();
            assert!(o.status.success(), "hob-lab check: {text}");
            for f in &files {
                assert!(Path::new(f).is_file(), "{f}: not written\n{text}");
            }
            text.lines()
                .filter(|l| l.contains("height"))
                .map(|l| l.rsplit('/').next().unwrap_or(l))
                .collect::<Vec<_>>()
                .join("; ")
        },
    );
    b.step("hob compensate --yes: stored for the worm set", |b| {
        let mut args = vec![
            "compensate",
            "--machine",
            machine.to_str().unwrap(),
            "--program",
            &program,
            "--log",
            log1.to_str().unwrap(),
            "--yes",
        ];
        for f in &files {
            args.extend(["--measurement", f.as_str()]);
        }
        let o = b.hob_ok(&args);
        std::fs::write(b.art.join("compensate.txt"), &o.text).unwrap();
        let stored = b.art.join("pitch-compensation/B-2019-07.toml");
        assert!(stored.is_file(), "{}: not written\n{}", stored.display(), o.text);
        unchanged(b, &machine, &original, "hob compensate");
        o.text
            .lines()
            .find(|l| l.contains("hob") && l.contains("identified"))
            .unwrap_or_default()
            .to_string()
    });
    b.step(
        "hob-rt restarted (X and Y jogged near home first): the compensation loaded, switched off",
        |b| {
            // Referencing again from near the switches takes seconds, from the cut's end a minute.
            for (axis, to) in [("x", 238.0), ("y", 438.0)] {
                let s = b.status();
                let at = if axis == "x" { s.x_mm } else { s.y_mm };
                b.hob_ok(&["jog", axis, &format!("{:.3}", to - at)]);
                b.wait_for(&format!("{axis} at {to} mm, idle"), STATE_TIMEOUT, |b| {
                    let s = b.try_status()?;
                    let at = if axis == "x" { s.x_mm } else { s.y_mm };
                    if s.state == "idle" && (at - to).abs() < 0.1 {
                        Ok(())
                    } else {
                        Err(format!("state {}, {axis} {at:.3} mm", s.state))
                    }
                });
            }
            assert!(
                b.terminate(rt, Duration::from_secs(20)).is_some(),
                "hob-rt did not stop"
            );
            spawn_rt(b, &machine, &state, "rt2.txt");
            b.spawn("hob-logger", "hob-logger", &[&log2], "logger2.txt");
            b.wait_state("idle", STATE_TIMEOUT);
            let log = std::fs::read_to_string(b.art.join("rt2.txt")).unwrap();
            let line = log
                .lines()
                .find(|l| l.contains("pitch compensation for worm set \"B-2019-07\" loaded, switched off"))
                .unwrap_or_else(|| panic!("{log}"))
                .to_string();
            b.reference(STATE_TIMEOUT);
            line
        },
    );
    let t_cut = std::time::Instant::now();
    b.step(
        "the second gear: compensation on, new blank, cut; switching it in the cut refused",
        |b| {
            b.hob_ok(&["load", &program]);
            b.hob_ok(&["new-blank"]);
            b.hob_ok(&["pitch-compensation", "on"]);
            let status = b.hob_ok(&["status"]);
            assert!(status.text.contains("pitch compensation on"), "{}", status.text);
            cut(b, &|b| {
                for word in ["on", "off"] {
                    let o = b.hob(&["pitch-compensation", word]);
                    assert_eq!(
                        o.code,
                        Some(2),
                        "hob pitch-compensation {word} in the cut: {}",
                        o.text
                    );
                    assert!(o.text.contains("cycle is running"), "{}", o.text);
                }
                assert!(b.hob_ok(&["status"]).text.contains("pitch compensation on"));
            });
            format!("{:.0} s from start to idle", t_cut.elapsed().as_secs_f64())
        },
    );
    // Where the machine's CPUs stall (the emulated guest: HOB_SYNC_BOUND_FACTOR above 1)
    // the stalls add to the second gear's f_pt what they add to the controller's share:
    // there f_pt 2.5 times (measured in the guest: 3.6 and 3.0 times in two runs), F_p 3.
    let fpt_factor = if hob_system_tests::sync_bound_factor() > 1.0 {
        2.5
    } else {
        3.0
    };
    b.step(
        "by the truth: the second gear 3 times better in f_pt (2.5 where the CPUs stall) and F_p, within grade 5",
        |b| {
            // hob-sim writes its truth at least every 0.5 s; the second log gets a copy.
            std::thread::sleep(Duration::from_millis(600));
            std::fs::copy(&truth, log2.join("truth.csv")).unwrap();
            let (f1, s1, p1, q1, first) = truth_gear(b, &log1);
            let (f2, s2, p2, q2, second) = truth_gear(b, &log2);
            eprintln!("the first gear: {first}");
            eprintln!("the second gear: {second}");
            unchanged(b, &machine, &original, "the whole loop");
            assert!(
                f1 >= fpt_factor * f2 && p1 >= 3.0 * p2,
                "f_pt {f1:.2} -> {f2:.2} um (at least {fpt_factor} times), F_p {p1:.2} -> {p2:.2} um \
                 (3 times): not that much better"
            );
            assert!(s2 <= 1.0 && q2 <= 1.0, "the second gear is not within grade 5: {second}");
            format!(
                "f_pt {f1:.2} -> {f2:.2} um ({:.0} -> {:.0} % of grade 5), F_p {p1:.2} -> {p2:.2} um ({:.0} -> {:.0} %); the test {:.0} s",
                100.0 * s1,
                100.0 * s2,
                100.0 * q1,
                100.0 * q2,
                started.elapsed().as_secs_f64()
            )
        },
    );
}

/// config/plant.toml with its worm wheel made ISO 1328-1 grade 6 (the hob's 3 um of axial
/// runout kept), written into the bench's artifacts: the machine a compensation shows on.
fn grade_6_plant(b: &Bench) -> std::path::PathBuf {
    let shipped = std::fs::read_to_string(b.root.join("config/plant.toml")).unwrap();
    for line in ["\nwheel_grade = 4\n", "\nhob_axial_runout_um = 3.0\n"] {
        assert!(shipped.contains(line), "config/plant.toml's line {line:?} moved");
    }
    let plant = b.art.join("plant-grade-6.toml");
    std::fs::write(
        &plant,
        shipped.replace("\nwheel_grade = 4\n", "\nwheel_grade = 6\n"),
    )
    .unwrap();
    plant
}

/// The two numbers of a `hob demo --compensate` table row (`  f_pt, single pitch   9.02 um
/// 153 % (grade 7)   2.65 um ...`) under the heading that starts with `section`: the first
/// and the second gear's um.
fn demo_row(out: &str, section: &str, row: &str) -> (f64, f64) {
    let rest = &out[out
        .find(section)
        .unwrap_or_else(|| panic!("no {section:?} in:\n{out}"))..];
    let line = rest
        .lines()
        .find(|l| l.trim_start().starts_with(row))
        .unwrap_or_else(|| panic!("no row {row:?} under {section:?} in:\n{out}"));
    let um: Vec<f64> = line
        .split_whitespace()
        .zip(line.split_whitespace().skip(1))
        .filter(|(_, unit)| *unit == "um")
        .map(|(v, _)| v.parse().unwrap_or_else(|_| panic!("{line}")))
        .collect();
    assert_eq!(um.len(), 2, "two figures in {line:?}");
    (um[0], um[1])
}

/// `hob demo --compensate`, issue 34's loop as one command (the recipe of
/// [`measure_the_first_gear_correct_the_second_over_the_bus`] run by the demo): on the grade 6
/// plant it cuts the short two-start helical gear, measures it with the simulated checker,
/// stores the compensation in its own directory, restarts hob-rt, switches it on, cuts and
/// measures the second gear. By the truth (`hob log report` of each gear's log) the second
/// gear is at least three times better in f_pt and F_p and within grade 5, and the demo's
/// table prints those figures; the checker's files, the plot, `hob compensate`'s output and
/// the compensation are where it says; the machine file it was given is not touched.
#[test]
#[ignore = "needs the release binaries and a bus; ci/test runs it (--ignored)"]
fn demo_compensate_cuts_measures_compensates_and_cuts_again() {
    const TEST: &str = "demo_compensate_cuts_measures_compensates_and_cuts_again";
    // Two whole cuts: the emulated guest (2 ms cycle, stalls) would take many minutes.
    if std::env::var("HOB_CAN_TESTS_ONLY").as_deref() == Ok("1") {
        eprintln!("{TEST}: two whole cuts: run on the host's bus, not here (HOB_CAN_TESTS_ONLY=1)");
        return;
    }
    let started = std::time::Instant::now();
    let mut b = Bench::new("demo_compensate");
    let machine = b.base_machine_file();
    let original = std::fs::read_to_string(&machine).unwrap();
    let plant = grade_6_plant(&b);
    let dir = b.art.join("demo");
    let (first, second) = (dir.join("first-gear"), dir.join("second-gear"));
    let mut out = String::new();
    b.step(
        "hob demo --compensate: two cuts, the checker, hob compensate, hob-rt restarted",
        |b| {
            let mut args: Vec<String> = [
                "demo",
                "--compensate",
                "--quiet",
                "--machine",
                &path(&machine),
                "--plant",
                &path(&plant),
                "--iface",
                &b.iface,
                "--log-dir",
                &path(&dir),
                "--near-home",
                SHORT_HOMING_MM,
            ]
            .map(str::to_string)
            .to_vec();
            if std::env::var("HOB_TOLERANCE_MS").is_ok_and(|v| !v.is_empty()) {
                args.extend(["--tolerance-ms".into(), tolerance_ms().to_string()]);
            }
            let demo = b.spawn("hob demo --compensate", "hob", &args, "demo.txt");
            b.add_log(dir.join("hob-sim.log"));
            for g in [&first, &second] {
                b.add_log(g.join("hob-rt.log"));
            }
            let st = b.wait_exit(demo, Duration::from_secs(1800));
            out = std::fs::read_to_string(b.log_of(demo)).unwrap();
            assert!(st.success(), "hob demo --compensate: {st}\n{out}");
            let last = out.lines().last().unwrap_or("");
            assert_eq!(last, format!("log: {}", dir.display()), "the last line");
            out.lines()
                .find(|l| l.starts_with("the whole loop took"))
                .unwrap_or_default()
                .to_string()
        },
    );
    b.step(
        "the files: the checker's, the plot, the compensation in the demo's own directory",
        |_| {
            for g in [&first, &second] {
                for f in [
                    "measurement-1.csv",
                    "measurement-2.csv",
                    "measurement-3.csv",
                    "truth.csv",
                ] {
                    assert!(g.join(f).is_file(), "{}: not written", g.join(f).display());
                }
            }
            for f in ["compensate.txt", "compensation.svg"] {
                assert!(
                    first.join(f).is_file(),
                    "{}: not written",
                    first.join(f).display()
                );
            }
            let stored = dir.join("pitch-compensation/B-2019-07.toml");
            assert!(stored.is_file(), "{}: not written", stored.display());
            let compensate = std::fs::read_to_string(first.join("compensate.txt")).unwrap();
            assert!(
                compensate.contains(&format!("written: {}", stored.display())),
                "{compensate}"
            );
            let demo_machine = TomlDoc::load(&dir.join("machine.toml"));
            assert_eq!(
                demo_machine.get("state.file").as_str(),
                Some(path(&dir.join("machine-state.toml")).as_str()),
                "the demo's machine file's state.file"
            );
            assert_eq!(
                std::fs::read_to_string(&machine).unwrap(),
                original,
                "the machine file given changed"
            );
            let rt2 = std::fs::read_to_string(second.join("hob-rt.log")).unwrap();
            assert!(
                rt2.contains("pitch compensation for worm set \"B-2019-07\" loaded, switched off"),
                "{rt2}"
            );
            stored.display().to_string()
        },
    );
    b.step(
        "by the truth: the second gear 3 times better in f_pt and F_p, within grade 5, as printed",
        |b| {
            let (f1, s1, p1, q1, first_line) = truth_gear(b, &first);
            let (f2, s2, p2, q2, second_line) = truth_gear(b, &second);
            eprintln!("the first gear: {first_line}");
            eprintln!("the second gear: {second_line}");
            assert!(
                f1 >= 3.0 * f2 && p1 >= 3.0 * p2,
                "f_pt {f1:.2} -> {f2:.2} um, F_p {p1:.2} -> {p2:.2} um: not 3 times better"
            );
            assert!(s2 <= 1.0 && q2 <= 1.0, "the second gear is not within grade 5: {second_line}");
            let near = |a: f64, b: f64| (a - b).abs() <= 0.011;
            let (pf1, pf2) = demo_row(&out, "by the truth", "f_pt");
            let (pp1, pp2) = demo_row(&out, "by the truth", "F_p");
            assert!(
                near(pf1, f1) && near(pf2, f2) && near(pp1, p1) && near(pp2, p2),
                "the demo printed f_pt {pf1} -> {pf2}, F_p {pp1} -> {pp2}; the reports say \
                 {f1:.2} -> {f2:.2}, {p1:.2} -> {p2:.2}"
            );
            // The checker's reading (0.4 um of noise a flank, the worst of three heights).
            let (cf1, cf2) = demo_row(&out, "by the checker's files", "f_pt");
            let (cp1, cp2) = demo_row(&out, "by the checker's files", "F_p");
            assert!(
                cf1 >= 2.0 * cf2 && cp1 >= 3.0 * cp2,
                "by the checker f_pt {cf1} -> {cf2}, F_p {cp1} -> {cp2}"
            );
            format!(
                "f_pt {f1:.2} -> {f2:.2} um ({:.0} -> {:.0} % of grade 5), F_p {p1:.2} -> {p2:.2} um ({:.0} -> {:.0} %); by the checker f_pt {cf1:.2} -> {cf2:.2}, F_p {cp1:.2} -> {cp2:.2}; the test {:.0} s",
                100.0 * s1,
                100.0 * s2,
                100.0 * q1,
                100.0 * q2,
                started.elapsed().as_secs_f64()
            )
        },
    );
}
