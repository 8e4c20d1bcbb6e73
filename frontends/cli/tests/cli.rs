//! Runs the real `hob` binary on good and bad programs: exit status and message.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn hob(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hob"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("run hob")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Writes `src` to a fresh temporary program file.
fn temp_program(name: &str, src: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hob-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(name);
    std::fs::write(&path, src).expect("write program");
    path
}

fn spur_src() -> String {
    std::fs::read_to_string(root().join("config/programs/spur-z17-m5.toml")).expect("example")
}

#[test]
fn plan_json_has_the_promised_fields() {
    let out = hob(&["plan", "config/programs/spur-z17-m5.toml", "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert!((v["egb_ratio"].as_f64().unwrap() - 1.0 / 17.0).abs() < 1e-12);
    assert_eq!(v["differential_deg_per_mm"].as_f64(), Some(0.0));
    assert!((v["hob_swivel_deg"].as_f64().unwrap() - 3.3).abs() < 1e-12);
    let passes = v["passes"].as_array().expect("passes");
    assert_eq!(passes.len(), 3);
    for key in [
        "kind",
        "depth_mm",
        "x_mm",
        "spindle_rpm",
        "table_rpm",
        "axial_feed_mm_min",
        "vfd_hz",
        "analog_out_v",
        "y_start_mm",
        "y_end_mm",
        "cut_time_s",
    ] {
        assert!(passes.iter().all(|p| !p[key].is_null()), "missing {key}");
    }
    assert_eq!(passes[0]["kind"], "rough");
    assert_eq!(passes[2]["kind"], "finish");
    assert!((passes[0]["spindle_rpm"].as_f64().unwrap() - 119.366).abs() < 1e-3);
    assert!(v["total_time_s"].as_f64().unwrap() > 0.0);
}

#[test]
fn plan_text_is_readable() {
    let out = hob(&["plan", "config/programs/helical-z31-m3.toml"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let s = text(&out.stdout);
    assert!(s.contains("helical right hand, beta 20 deg"), "{s}");
    assert!(s.contains("hob swivel 17.200 deg"), "{s}");
    assert!(s.contains("total cycle time"), "{s}");
}

#[test]
fn check_accepts_every_example() {
    for name in [
        "spur-z17-m5",
        "helical-z31-m3",
        "spline-z12-m2-plunge",
        "tooth-by-tooth-z24-m8",
    ] {
        let out = hob(&["check", &format!("config/programs/{name}.toml")]);
        assert!(out.status.success(), "{name}: {}", text(&out.stderr));
        assert!(text(&out.stdout).contains(": ok on"), "{name}");
    }
}

#[test]
fn check_without_a_program_checks_the_machine() {
    let out = hob(&["check", "--machine", "config/machine.toml"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("config/machine.toml: ok"));
}

fn assert_refused(args: &[&str], needles: &[&str]) {
    let out = hob(args);
    assert_eq!(
        out.status.code(),
        Some(2),
        "stdout {} stderr {}",
        text(&out.stdout),
        text(&out.stderr)
    );
    let err = text(&out.stderr);
    for n in needles {
        assert!(err.contains(n), "missing {n:?} in: {err}");
    }
    assert!(out.stdout.is_empty(), "nothing planned on a refusal");
}

#[test]
fn refuses_a_table_speed_above_the_machine_naming_field_and_limit() {
    let p = temp_program("fast-table.toml", &spur_src().replace("teeth = 17", "teeth = 5"));
    let p = p.to_str().unwrap();
    assert_refused(
        &["plan", p],
        &["strategy.rough.cutting_speed_m_min", "table.max_table_rpm = 14.1"],
    );
    assert_refused(&["check", p], &["strategy.rough.cutting_speed_m_min"]);
}

#[test]
fn refuses_a_hob_of_another_module() {
    let src = spur_src().replace(
        "[tool]\nkind = \"hob\"\nmodule_mm = 5.0",
        "[tool]\nkind = \"hob\"\nmodule_mm = 4.0",
    );
    let p = temp_program("module.toml", &src);
    assert_refused(
        &["plan", p.to_str().unwrap(), "--json"],
        &["tool.module_mm", "workpiece.module_mm = 5"],
    );
}

#[test]
fn refuses_an_allowance_not_smaller_than_the_depth() {
    let src = spur_src().replace("finish_allowance_mm = 0.5", "finish_allowance_mm = 12.0");
    let p = temp_program("allowance.toml", &src);
    assert_refused(
        &["check", p.to_str().unwrap()],
        &["strategy.finish_allowance_mm", "total_depth_mm = 11.25"],
    );
}

#[test]
fn refuses_rough_depths_that_do_not_add_up() {
    let p = temp_program("depths.toml", &spur_src().replace("[6.0, 4.75]", "[6.0, 5.0]"));
    assert_refused(
        &["check", p.to_str().unwrap()],
        &["strategy.rough_depths_mm", "11 mm", "10.75 mm"],
    );
}

#[test]
fn refuses_zero_teeth_with_the_position() {
    let src = spur_src().replace("teeth = 17", "teeth = 0");
    let line = src.lines().position(|l| l.starts_with("teeth")).unwrap() + 1;
    let p = temp_program("teeth.toml", &src);
    assert_refused(
        &["check", p.to_str().unwrap()],
        &[&format!("teeth.toml:{line}:1: workpiece.teeth"), "(is 0)"],
    );
}

#[test]
fn refuses_a_typo() {
    let p = temp_program("typo.toml", &spur_src().replace("retract_mm", "retrakt_mm"));
    assert_refused(
        &["plan", p.to_str().unwrap()],
        &["unknown field `retrakt_mm`", "typo.toml:"],
    );
}

#[test]
fn refuses_a_broken_machine_file() {
    let machine = std::fs::read_to_string(root().join("config/machine.toml"))
        .unwrap()
        .replace("max_table_rpm = 14.1", "max_table_rpm = 60.0");
    let m = temp_program("machine.toml", &machine);
    assert_refused(
        &[
            "plan",
            "config/programs/spur-z17-m5.toml",
            "--machine",
            m.to_str().unwrap(),
        ],
        &["machine.toml:", "table.max_table_rpm", "4500.0 motor rpm"],
    );
}

#[test]
fn a_missing_file_is_refused() {
    assert_refused(
        &["check", "config/programs/does-not-exist.toml"],
        &["does-not-exist.toml: cannot read"],
    );
}

/// The thesis gear made shallow and narrow so that the whole cycle simulates in a second.
fn short_spur_src() -> String {
    spur_src()
        .replace("face_width_mm = 40.0", "face_width_mm = 4.0")
        .replace("total_depth_mm = 11.25", "total_depth_mm = 2.0")
        .replace("finish_allowance_mm = 0.5", "finish_allowance_mm = 0.2")
        .replace("rough_depths_mm = [6.0, 4.75]\n", "")
        .replace("rough_passes = 2", "rough_passes = 1")
        .replace("feed_mm_per_rev = 2.0", "feed_mm_per_rev = 8.0")
        .replace("feed_mm_per_rev = 1.0", "feed_mm_per_rev = 6.0")
        .replace("single_depth_mm = 5.0", "single_depth_mm = 1.0")
}

#[test]
fn simulate_writes_the_trace_and_the_summary() {
    let p = temp_program("short.toml", &short_spur_src());
    let out = std::env::temp_dir().join(format!("hob-cli-sim-{}", std::process::id()));
    let o = hob(&["simulate", p.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let line = text(&o.stdout);
    assert_eq!(line.lines().count(), 1, "{line}");
    assert!(line.contains(": done in") && line.contains("bound"), "{line}");
    let trace = std::fs::read_to_string(out.join("trace.csv")).unwrap();
    let mut lines = trace.lines();
    let header = lines.next().unwrap();
    assert!(header.starts_with(
        "t_s,state,pass,spindle_deg,table_deg,table_cmd_deg,x_mm,x_cmd_mm,y_mm,y_cmd_mm,sync_err_arcsec"
    ));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let cut: Vec<&Vec<&str>> = rows.iter().filter(|r| r[1] == "cut").collect();
    assert!(cut.len() > 1000);
    assert!(
        cut.iter().all(|r| !r[10].is_empty()),
        "sync error in every cut row"
    );
    // One row per 1 ms cycle.
    let t: Vec<f64> = rows.iter().map(|r| r[0].parse().unwrap()).collect();
    assert!(t.windows(2).all(|w| (w[1] - w[0] - 0.001).abs() < 1e-6));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["completed"], true);
    let passes = summary["passes"].as_array().unwrap();
    assert_eq!(passes.len(), 2);
    for p in passes {
        for key in [
            "sync_err_rms_arcsec",
            "sync_err_max_arcsec",
            "sync_err_rms_um",
            "sync_err_max_um",
            "time_s",
        ] {
            assert!(p[key].as_f64().is_some(), "{key}");
        }
    }
}

#[test]
fn simulate_refuses_a_bad_plant_file() {
    let plant = std::fs::read_to_string(root().join("config/plant.toml"))
        .unwrap()
        .replace("inner_step_us = 100", "inner_step_us = 5000");
    let f = temp_program("plant.toml", &plant);
    let o = hob(&[
        "simulate",
        "config/programs/spur-z17-m5.toml",
        "--plant",
        f.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("simulation.inner_step_us"),
        "{}",
        text(&o.stderr)
    );
}

#[test]
fn doctor_reports_every_check_with_a_fix_and_fails_on_a_missing_can_interface() {
    let out = hob(&["doctor", "--cyclictest-seconds", "0", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    let findings = v.as_array().expect("array");
    let checks: Vec<&str> = findings.iter().filter_map(|f| f["check"].as_str()).collect();
    for c in [
        "PREEMPT_RT kernel",
        "isolated loop core",
        "nohz_full",
        "interrupt affinity",
        "CPU frequency governor",
        "CPU idle states",
        "SCHED_FIFO allowed",
        "memory lock allowed",
        "idle-state request",
        "CAN interface",
        "iceoryx2 shared memory",
        "clock source",
        "cyclictest",
    ] {
        assert!(checks.contains(&c), "{c} missing: {checks:?}");
    }
    for f in findings {
        let level = f["level"].as_str().unwrap();
        if level == "warn" || level == "fail" {
            assert!(!f["fix"].as_str().unwrap().is_empty(), "no fix: {f}");
        }
    }
    let any_fail = findings.iter().any(|f| f["level"] == "fail");
    assert_eq!(out.status.code(), Some(if any_fail { 1 } else { 0 }));
    // The shipped configuration names can0, which a test machine does not have.
    if !Path::new("/sys/class/net/can0").exists() {
        let can = findings.iter().find(|f| f["check"] == "CAN interface").unwrap();
        assert_eq!(can["level"], "fail");
        assert!(can["fix"].as_str().unwrap().contains("restart-ms 100"));
    }
}

#[test]
fn demo_refuses_a_tolerance_the_machine_file_cannot_take_before_creating_anything() {
    let log = std::env::temp_dir().join(format!("hob-cli-test-demo-refused-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&log);
    let log_arg = log.to_str().unwrap();
    // 600 ms: 600 TPDO misses (limit 100) and a 1200 ms watchdog deadline (limit 1000).
    assert_refused(
        &[
            "demo",
            "--tolerance-ms",
            "600",
            "--iface",
            "shm",
            "--log",
            log_arg,
        ],
        &[
            "can.tpdo_misses_to_fault",
            "service.watchdog_deadline_ms",
            "600 ms",
        ],
    );
    assert!(!log.exists(), "no log directory for a refused demo");
}
