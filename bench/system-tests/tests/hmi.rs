//! The touch HMI in a real browser: `hob-sim` (with `--control`), `hob-rt`, `hob-logger` and
//! `hob-watchdog` on this host's bus as in the service tests, then the browser tests
//! (`frontends/hmi/tests/e2e/*.test.mjs`, node's test runner driving Debian's Chromium with
//! playwright-core), which start `hob-hmi` themselves (one test kills and restarts it).
//!
//! Ignored in the workspace pass (it needs the release binaries, Chromium and the npm
//! install of `ci/hmi-setup`); `ci/test` runs it:
//!
//! ```sh
//! bash ci/hmi-setup
//! cargo build --release --workspace --bins
//! HOB_BIN=target/release cargo test -p hob-system-tests --release --test hmi -- --ignored --nocapture
//! ```
//!
//! Screenshots of every screen go to `target/service-artifacts/hmi/screens/` (set
//! `HOB_HMI_SHOTS=docs/hmi` to refresh the README's).
#![allow(clippy::unwrap_used)]

use hob_system_tests::{Bench, SHORT_HOMING_MM, TomlDoc, session_program};
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

/// The whole browser suite may take this long (it takes about N minutes here).
const SUITE_TIMEOUT: Duration = Duration::from_secs(900);

fn path(p: &Path) -> String {
    p.display().to_string()
}

/// The machine side on this bench's bus, and the environment the node scripts read.
fn stack(b: &mut Bench) -> Vec<(&'static str, String)> {
    let hmi_exe = b.bin.join("hob-hmi");
    assert!(hmi_exe.is_file(), "{}: not built", hmi_exe.display());
    let vendor = b.root.join("frontends/hmi/node_modules");
    assert!(
        vendor.join("playwright-core").is_dir() && Path::new("/usr/bin/chromium").is_file(),
        "Chromium or the npm install is missing: run bash ci/hmi-setup"
    );
    let mut m = b.session_machine();
    // The gauge on the table's rim that hob-sim's plant has on the coupler's analog input 0
    // (config/plant.toml's peripherals.table_gauge), named so that TABLE BACKLASH measures.
    m.table
        .get_mut("io")
        .and_then(toml::Value::as_table_mut)
        .unwrap()
        .insert(
            "analog_inputs".into(),
            toml::Value::Table(toml::toml! { table_gauge = { channel = 0 } }),
        );
    // The machine's state file is hob-rt's (--state-file below): `hob compensate`, run by the
    // HMI's COMPENSATE screen, writes the worm set's compensation beside it.
    let state_file = b.art.join("machine-state.toml");
    m.table
        .get_mut("state")
        .and_then(toml::Value::as_table_mut)
        .unwrap()
        .insert("file".into(), toml::Value::String(path(&state_file)));
    let machine = m.write(&b.art.join("machine.toml"));
    let (iface, program) = (b.iface.clone(), session_program());
    // The logger's directory, where the simulator writes its truth beside the record (the
    // cut report grades by it).
    let log_dir = b.art.join("log");
    std::fs::create_dir_all(&log_dir).unwrap();
    let mut sim = b.command("hob-sim");
    sim.args([
        "--iface",
        &iface,
        "--machine",
        &path(&machine),
        "--program",
        &path(&program),
        "--rt-priority",
        "75",
        "--control",
        "--truth",
        &path(&log_dir.join("truth.csv")),
        // HOME ALL is tested, not the length of its way.
        "--power-on-near-home",
        SHORT_HOMING_MM,
    ])
    .stdin(std::process::Stdio::piped());
    let sim = b.spawn_cmd("hob-sim", sim, "sim.txt");
    // hob-sim --control reads faults on its standard input (and ends with it): the browser
    // tests append theirs to a file (HOB_SIM_CONTROL), which this thread forwards line by
    // line for as long as the bench runs.
    let control = b.art.join("sim-control.txt");
    std::fs::write(&control, "").unwrap();
    forward_lines(control.clone(), b.stdin_of(sim));
    std::thread::sleep(Duration::from_millis(300));
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
        "rt.txt",
    );
    b.spawn("hob-logger", "hob-logger", &[&log_dir], "logger.txt");
    b.spawn(
        "hob-watchdog",
        "hob-watchdog",
        &["--iface", &iface, "--machine", &path(&machine)],
        "watchdog.txt",
    );
    // The operator's library: the session's gear, as a machine builder would install it.
    let library = b.art.join("library");
    b.hob_ok(&[
        "lib",
        "--library",
        &path(&library),
        "programs",
        "create",
        "session-gear",
        &path(&program),
    ]);
    // As deployed (README, "Who may speak on the bus"): the HMI is not a process of the bus
    // but runs as another user (here nobody, in the group users) and reaches the loop
    // through hob-gateway, which makes that group setters (the operators' job with the
    // setter's tool and span correction; an operator's panel refusing those is
    // frontends/hmi/tests/server.rs's). Its library is its to write.
    for entry in walk(&library) {
        let mode = if entry.is_dir() { 0o777 } else { 0o666 };
        std::fs::set_permissions(&entry, std::os::unix::fs::PermissionsExt::from_mode(mode)).unwrap();
    }
    let socket = b.art.join("gateway.sock");
    let _ = std::fs::remove_file(&socket);
    b.spawn(
        "hob-gateway",
        "hob-gateway",
        &[
            "--socket",
            &path(&socket),
            "--operators",
            "operator",
            "--setters",
            "users",
            "--viewers",
            "staff",
        ],
        "gateway.txt",
    );
    // The gear checker's folder (a USB stick's mount on the machine PC): the browser tests
    // put their files in it, the HMI's user reads them.
    let measurements = b.art.join("measurements");
    std::fs::create_dir_all(&measurements).unwrap();
    std::fs::set_permissions(&measurements, std::os::unix::fs::PermissionsExt::from_mode(0o777)).unwrap();
    // Where `hob compensate` keeps the worm set's compensation (beside the state file): the
    // HMI's user writes it (COMPENSATE's WRITE), as a deployment grants the setters.
    let kept = b.art.join("pitch-compensation");
    std::fs::create_dir_all(&kept).unwrap();
    std::fs::set_permissions(&kept, std::os::unix::fs::PermissionsExt::from_mode(0o777)).unwrap();
    let job = TomlDoc::load(&program);
    let tip_mm = job.get("tool.outside_diameter_mm").as_float().unwrap();
    let blank_mm = job.get("workpiece.outside_diameter_mm").as_float().unwrap();
    b.wait_state("idle", Duration::from_secs(300));
    vec![
        ("HOB_INSTANCE", b.instance.clone()),
        ("HOB_BIN", path(&b.bin)),
        ("HOB_MACHINE", path(&machine)),
        ("HOB_LIBRARY", path(&library)),
        ("HOB_LOG_DIR", path(&log_dir)),
        ("HOB_MEASUREMENTS_DIR", path(&measurements)),
        ("HOB_STATE_FILE", path(&state_file)),
        ("HOB_SESSION_PROGRAM_FILE", path(&program)),
        ("HOB_VENDOR", path(&vendor)),
        ("HOB_TOOL_TIP_MM", tip_mm.to_string()),
        // The touch-off test touches the blank of this diameter.
        ("HOB_BLANK_OD_MM", blank_mm.to_string()),
        // lib/hmi.mjs starts hob-hmi as this user through the gateway (the CLI that reads
        // the truth stays on the bus).
        ("HOB_HMI_USER", "65534:100".to_string()),
        ("HOB_HMI_GATEWAY", path(&socket)),
        ("HOB_SIM_CONTROL", path(&control)),
    ]
}

/// Forwards what is appended to `file` into `to`, whole lines only, until the process ends.
fn forward_lines(file: std::path::PathBuf, mut to: std::process::ChildStdin) {
    use std::io::Write;
    std::thread::spawn(move || {
        let mut sent = 0;
        loop {
            std::thread::sleep(Duration::from_millis(100));
            let Ok(text) = std::fs::read_to_string(&file) else {
                continue;
            };
            let Some(end) = text.rfind('\n').map(|i| i + 1) else {
                continue;
            };
            if end > sent {
                if to
                    .write_all(&text.as_bytes()[sent..end])
                    .and_then(|()| to.flush())
                    .is_err()
                {
                    return;
                }
                sent = end;
            }
        }
    });
}

/// `dir` and everything under it.
fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut all = vec![dir.to_path_buf()];
    let mut i = 0;
    while i < all.len() {
        if all[i].is_dir() {
            let children: Vec<_> = std::fs::read_dir(&all[i])
                .unwrap()
                .map(|e| e.unwrap().path())
                .collect();
            all.extend(children);
        }
        i += 1;
    }
    all
}

/// Runs node with `args` in the workspace root and `env`, its output in `log`; fails the
/// test with that output when node fails or takes longer than `limit`.
fn node(b: &mut Bench, args: &[&str], env: &[(&'static str, String)], log: &str, limit: Duration) {
    let started = Instant::now();
    let mut node = Command::new("node");
    node.current_dir(&b.root).args(args);
    for (k, v) in env {
        node.env(k, v);
    }
    let log = b.art.join(log);
    let out = std::fs::File::create(&log).unwrap();
    let mut child = node
        .stdout(out.try_clone().unwrap())
        .stderr(out)
        .spawn()
        .expect("node");
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if started.elapsed() > limit {
            let _ = child.kill();
            panic!("node {args:?} took over {} s: {}", limit.as_secs(), log.display());
        }
        std::thread::sleep(Duration::from_millis(200));
    };
    let text = std::fs::read_to_string(&log).unwrap();
    eprintln!("{text}");
    eprintln!("node {args:?}: {:.0} s", started.elapsed().as_secs_f64());
    assert!(
        status.success(),
        "node {args:?} failed ({}); the log above",
        log.display()
    );
    b.check_alive();
}

#[test]
#[ignore = "needs the release binaries, Chromium and frontends/hmi/node_modules: run by ci/test"]
fn the_touch_hmi_in_chromium() {
    let mut b = Bench::new("hmi");
    let mut env = stack(&mut b);
    let shots = std::env::var("HOB_HMI_SHOTS").unwrap_or_else(|_| path(&b.art.join("screens")));
    env.push(("HOB_HMI_SHOTS", shots));
    node(
        &mut b,
        &[
            "--test",
            "--test-concurrency=1",
            "--test-timeout=600000",
            "frontends/hmi/tests/e2e/",
        ],
        &env,
        "node-tests.txt",
        SUITE_TIMEOUT,
    );
}

/// The HMI's figures (docs/performance.md, "The touch HMI"): not part of ci/test.
/// `HOB_HMI_BENCH_S` seconds of frames (default 60), then 200 command round trips; the
/// JSON in `target/service-artifacts/hmi-figures/figures.json`.
#[test]
#[ignore = "a benchmark: HOB_BIN=target/release cargo test -p hob-system-tests --release --test hmi hmi_figures -- --ignored --nocapture"]
fn hmi_figures() {
    let mut b = Bench::new("hmi-figures");
    let mut env = stack(&mut b);
    env.push(("HOB_HMI_FIGURES", path(&b.art.join("figures.json"))));
    if let Ok(s) = std::env::var("HOB_HMI_BENCH_S") {
        env.push(("HOB_HMI_BENCH_S", s));
    }
    node(
        &mut b,
        &["frontends/hmi/tests/bench/figures.mjs"],
        &env,
        "figures.txt",
        Duration::from_secs(3600),
    );
}
