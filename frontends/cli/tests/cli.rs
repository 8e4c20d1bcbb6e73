//! Runs the real `hob` binary on good and bad programs: exit status and message.
#![allow(clippy::unwrap_used)]

mod support;

use std::path::Path;
use std::process::{Command, Output};
use support::{edited, root, text};

fn hob(args: &[&str]) -> Output {
    support::run(env!("CARGO_BIN_EXE_hob"), args)
}

fn assert_refused(args: &[&str], needles: &[&str]) {
    support::assert_refused(env!("CARGO_BIN_EXE_hob"), args, needles);
}

fn temp_program(name: &str, src: &str) -> std::path::PathBuf {
    support::temp_file(name, src)
}

/// The thesis gear, the example most tests start from.
const SPUR: &str = "config/programs/spur-z17-m5.toml";

fn spur_src() -> String {
    std::fs::read_to_string(root().join(SPUR)).expect("example")
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
        "helical-z41-m2-2start",
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

#[test]
fn refuses_a_table_speed_above_the_machine_naming_field_and_limit() {
    let p = edited(SPUR, "fast-table.toml", &[("workpiece.teeth", 5.into())]);
    let p = p.to_str().unwrap();
    assert_refused(
        &["plan", p],
        &["strategy.rough.cutting_speed_m_min", "table.max_table_rpm = 14.1"],
    );
    assert_refused(&["check", p], &["strategy.rough.cutting_speed_m_min"]);
}

#[test]
fn refuses_a_hob_of_another_module() {
    let p = edited(SPUR, "module.toml", &[("tool.module_mm", 4.0.into())]);
    assert_refused(
        &["plan", p.to_str().unwrap(), "--json"],
        &["tool.module_mm", "workpiece.module_mm = 5"],
    );
}

#[test]
fn refuses_an_allowance_not_smaller_than_the_depth() {
    let p = edited(
        SPUR,
        "allowance.toml",
        &[("strategy.finish_allowance_mm", 12.0.into())],
    );
    assert_refused(
        &["check", p.to_str().unwrap()],
        &["strategy.finish_allowance_mm", "total_depth_mm = 11.25"],
    );
}

#[test]
fn refuses_rough_depths_that_do_not_add_up() {
    let depths = toml::Value::Array(vec![6.0.into(), 5.0.into()]);
    let p = edited(SPUR, "depths.toml", &[("strategy.rough_depths_mm", depths)]);
    assert_refused(
        &["check", p.to_str().unwrap()],
        &["strategy.rough_depths_mm", "11 mm", "10.75 mm"],
    );
}

#[test]
fn refuses_zero_teeth_with_the_position() {
    let p = edited(SPUR, "teeth.toml", &[("workpiece.teeth", 0.into())]);
    let src = std::fs::read_to_string(&p).unwrap();
    let line = src.lines().position(|l| l.starts_with("teeth")).unwrap() + 1;
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
    let m = edited(
        "config/machine.toml",
        "machine.toml",
        &[("table.max_table_rpm", 60.0.into())],
    );
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
fn the_simulator_commands_are_handed_to_hob_lab_with_their_arguments_unchanged() {
    // HOB_LAB names the binary `hob` runs in its place: here `echo`, which prints what it got.
    for args in [
        &["demo", "--quiet", "--log-dir", "/tmp/x"][..],
        &["simulate", "p.toml", "--no-ccc"],
        &["can", "--iface", "vcan0", "run", "p.toml", "--jog", "x=5"],
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_hob"))
            .args(args)
            .env("HOB_LAB", "/bin/echo")
            .output()
            .expect("run hob");
        assert!(o.status.success(), "{}", text(&o.stderr));
        assert_eq!(text(&o.stdout).trim_end(), args.join(" "));
    }
    // Without hob-lab beside it, `hob demo` says what is missing and how to get it.
    let o = Command::new(env!("CARGO_BIN_EXE_hob"))
        .args(["demo"])
        .env("HOB_LAB", "/nonexistent/hob-lab")
        .output()
        .expect("run hob");
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o.stderr).contains("cargo build --release -p hob-lab"),
        "{}",
        text(&o.stderr)
    );
    // A product command is not handed over.
    let o = Command::new(env!("CARGO_BIN_EXE_hob"))
        .args(["check"])
        .current_dir(root())
        .env("HOB_LAB", "/bin/false")
        .output()
        .expect("run hob");
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stdout).starts_with("config/machine.toml: ok"),
        "hob checked the machine itself: {}",
        text(&o.stdout)
    );
}

#[test]
fn bus_load_of_the_shipped_machine_is_under_its_limit() {
    let out = hob(&["bus-load"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let s = text(&out.stdout);
    assert!(
        s.lines()
            .any(|l| l.starts_with("total 698.0 of 1000 bits per cycle: 69.8 % (limit 70 %)")),
        "{s}"
    );
}

#[test]
fn bus_load_above_the_limit_exits_2_naming_the_key() {
    // The shipped PDO set needs 69.8 % of the bus; a machine that allows 60 % refuses it.
    let f = edited(
        "config/machine.toml",
        "bus-load-machine.toml",
        &[("can.bus_load_limit", 0.6.into())],
    );
    assert_refused(
        &["bus-load", "--machine", f.to_str().unwrap()],
        &["bus load 69.8 % is above can.bus_load_limit = 60 %"],
    );
}

/// `hob cutter design`: the fewest arcs within the grade, the figures an operator checks,
/// the profile as the tool library's TOML (it reads back and validates), a plot; bad
/// arguments refused with what is wrong.
#[test]
fn cutter_design_reports_the_fit_and_writes_the_profile() {
    let dir = std::env::temp_dir().join(format!("hob-cutter-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (toml_path, svg_path) = (dir.join("c.toml"), dir.join("c.svg"));
    let out = hob(&[
        "cutter",
        "design",
        "--teeth",
        "24",
        "--module-mm",
        "8",
        "--outside-diameter-mm",
        "80",
        "--toml",
        toml_path.to_str().unwrap(),
        "--svg",
        svg_path.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let o = text(&out.stdout);
    // z24 m8 at grade 7 (f_falpha 18.8 um): one arc leaves 87 um, two 10.8 um.
    assert!(o.contains("flank: 2 arc(s)"), "{o}");
    assert!(
        o.contains("of ISO 1328-1 f_falpha 18.80 um at grade 7, within"),
        "{o}"
    );
    assert!(o.contains("radii (mm): tip 104.000, pitch 96.000"), "{o}");
    #[derive(serde::Deserialize)]
    struct File {
        profile: Vec<hob_cutters::profile::Primitive>,
    }
    let f: File = toml::from_str(&std::fs::read_to_string(&toml_path).unwrap()).unwrap();
    assert_eq!(f.profile.len(), 9);
    assert_eq!(hob_cutters::profile::validate(&f.profile, 40.0), Ok(()));
    let svg = std::fs::read_to_string(&svg_path).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("polyline"));
    // One arc asked for: reported beyond the grade, not refused (the operator sees why).
    let out = hob(&[
        "cutter",
        "design",
        "--teeth",
        "24",
        "--module-mm",
        "8",
        "--outside-diameter-mm",
        "80",
        "--arcs",
        "1",
    ]);
    assert!(text(&out.stdout).contains("BEYOND"), "{}", text(&out.stdout));
    assert_refused(
        &[
            "cutter",
            "design",
            "--teeth",
            "24",
            "--module-mm",
            "8",
            "--outside-diameter-mm",
            "30",
        ],
        &["18.00 mm deep", "outside radius 15.00 mm"],
    );
    assert_refused(
        &[
            "cutter",
            "design",
            "--teeth",
            "24",
            "--module-mm",
            "8",
            "--outside-diameter-mm",
            "80",
            "--grade",
            "12",
        ],
        &["--grade", "1 to 11"],
    );
    assert_refused(
        &[
            "cutter",
            "design",
            "--teeth",
            "3",
            "--module-mm",
            "8",
            "--outside-diameter-mm",
            "80",
        ],
        &["at least 5 teeth"],
    );
}

/// `hob cutter dynamics`: seed 003's first cutter by its own equations (984 N/mm, 49.9 Hz,
/// not the 3 kN/mm and 12.6 Hz it states), the warning near resonance, the speed ranges; a
/// bad value refused with its name.
#[test]
fn cutter_dynamics_reports_the_link_and_warns_near_resonance() {
    let base = [
        "cutter",
        "dynamics",
        "--width-mm",
        "2.5",
        "--outside-diameter-mm",
        "200",
        "--mass-kg",
        "10",
        "--teeth",
        "45",
        "--kc11-n-mm2",
        "2600",
        "--mc",
        "0.26",
        "--chip-thickness-mm",
        "0.01",
        "--chip-width-mm",
        "2",
    ];
    let run = |speed: &str, limit: &str| {
        let mut a = base.to_vec();
        a.extend(["--cutting-speed-m-min", speed, "--limit-um", limit]);
        let out = hob(&a);
        assert!(out.status.success(), "{}", text(&out.stderr));
        text(&out.stdout)
    };
    let o = run("40", "500");
    assert!(
        o.contains("stiffness 984 N/mm") && o.contains("natural frequency 49.9 Hz"),
        "{o}"
    );
    assert!(
        o.contains("0.96 of the natural frequency") && o.contains("WARNING: near resonance"),
        "{o}"
    );
    // Far from it: no warning, and the speeds within the limit exclude the resonance at 41.8.
    let o = run("10", "500");
    assert!(!o.contains("WARNING"), "{o}");
    let ranges = o.lines().last().unwrap().to_string();
    assert!(
        ranges.contains("speeds within it (5-200 m/min): 5.0-"),
        "{ranges}"
    );
    // 171 N: 174 um static; at resonance ten times that: the speeds around 41.8 m/min
    // (tooth-passing 0.89-1.1 of 49.9 Hz) are left out.
    assert!(
        ranges.contains(", ") && !ranges.contains("-200.0 m/min, "),
        "{ranges}"
    );
    // The body (b 2.5 mm) takes 2 x 2.5^2 x 400 = 5000 N: 172 N of side force near
    // resonance is within; ten times the chip width there (~1.7 kN, amplified ~8) is not.
    let o = run("40", "500");
    assert!(o.contains("it takes 5000 N at 400 MPa: within"), "{o}");
    let mut a = base.to_vec();
    a[17] = "20";
    a.extend(["--cutting-speed-m-min", "40"]);
    let out = hob(&a);
    assert!(
        text(&out.stdout).contains("it takes 5000 N at 400 MPa: OVERLOADED"),
        "{}",
        text(&out.stdout)
    );
    let mut a = base.to_vec();
    a.extend(["--cutting-speed-m-min", "40"]);
    a[7] = "0";
    assert_refused(&a, &["--mass-kg"]);
}

/// `hob cutter grind` on a profile `hob cutter design` wrote: a program of linear moves for
/// every tooth, indexed by the dividing head; a broken profile refused naming its primitive.
#[test]
fn cutter_grind_writes_a_program_of_linear_moves_per_tooth() {
    let dir = std::env::temp_dir().join(format!("hob-grind-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let profile = dir.join("z24.toml");
    let out = hob(&[
        "cutter",
        "design",
        "--teeth",
        "24",
        "--module-mm",
        "8",
        "--outside-diameter-mm",
        "80",
        "--toml",
        profile.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let nc = dir.join("z24.nc");
    let grind = |profile: &Path| {
        hob(&[
            "cutter",
            "grind",
            profile.to_str().unwrap(),
            "--outside-diameter-mm",
            "80",
            "--teeth",
            "12",
            "--rake-deg",
            "5",
            "--wheel-radius-mm",
            "50",
            "--wheel-edge-radius-mm",
            "1",
            "--out",
            nc.to_str().unwrap(),
        ])
    };
    let out = grind(&profile);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let o = text(&out.stdout);
    assert!(
        o.contains("12 teeth") && o.contains("lowered 4.181 mm for the 6 deg clearance"),
        "{o}"
    );
    let code = std::fs::read_to_string(&nc).unwrap();
    assert_eq!(code.matches("\nG0 A").count(), 12);
    assert!(code.contains("G0 A330.0000"));
    assert!(!code.lines().any(|l| l.starts_with("G2 ") || l.starts_with("G3 ")));
    // A gap in the profile: refused, the file and the primitive named, nothing written.
    let mut t: toml::Table = std::fs::read_to_string(&profile).unwrap().parse().unwrap();
    let start = &mut t["profile"].as_array_mut().unwrap()[1]["start_mm"]
        .as_array_mut()
        .unwrap()[0];
    *start = toml::Value::Float(start.as_float().unwrap() + 0.1);
    let broken = dir.join("broken.toml");
    let bad = toml::to_string(&t).unwrap();
    std::fs::write(&broken, bad).unwrap();
    std::fs::remove_file(&nc).unwrap();
    let out = grind(&broken);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stdout));
    let err = text(&out.stderr);
    assert!(
        err.contains("broken.toml") && err.contains("primitive 2: starts 0.1000 mm"),
        "{err}"
    );
    assert!(!nc.exists());
}

/// `hob touch-flank` takes `+` or `-` (the way the table was turned to the flank); anything
/// else is refused before anything is sent to the loop.
#[test]
fn a_flank_touch_needs_the_way_the_table_turned() {
    assert_refused(
        &["touch-flank", "up"],
        &["touch-flank: direction up is not + or -"],
    );
}

/// `hob touch-off` takes `--confirm` (for a touch-off the loop asks about); the gauge is
/// still needed, and refused before anything is sent to the loop when missing.
#[test]
fn a_touch_off_takes_a_confirmation_and_still_needs_its_gauge() {
    assert_refused(
        &["touch-off", "x", "--confirm"],
        &["touch-off: give x --diameter MM"],
    );
    let help = hob(&["touch-off", "--help"]);
    assert!(help.status.success());
    let text = support::text(&help.stdout);
    assert!(
        text.contains("--confirm") && text.contains("names the offset it would set"),
        "{text}"
    );
}

/// A gauge typed with a decimal comma is read as with a point (`hob_ipc::number`, as the
/// HMI reads it); a thousands separator is refused in words before anything is sent.
#[test]
fn a_typed_number_takes_a_decimal_comma_and_refuses_a_thousands_separator() {
    assert_refused(
        &["touch-off", "x", "--diameter", "1.094,94"],
        &["\"1.094,94\" is not a number", "94.94 or 94,94"],
    );
    assert_refused(&["override", "feed", "8O"], &["\"8O\" is not a number"]);
    let out = hob(&["touch-off", "x", "--diameter", "94,94"]);
    let err = text(&out.stderr);
    assert!(
        !err.contains("not a number") && !err.contains("invalid value"),
        "{err}"
    );
}

/// `hob commission report`: the shipped file's records in words; its plot refused without
/// an encoder record, written with one.
#[test]
fn the_commissioning_report_says_what_was_measured_and_plots_the_encoder() {
    let shipped = root().join("config/machine.toml");
    let o = hob(&["commission", "report", "--machine", shipped.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(out.contains("found 999.9 us"), "{out}");
    assert!(out.contains("Spindle encoder: not commissioned"), "{out}");
    let svg = std::env::temp_dir().join(format!("hob-report-{}.svg", std::process::id()));
    let svg_arg = svg.to_str().unwrap();
    assert_refused(
        &[
            "commission",
            "report",
            "--machine",
            shipped.to_str().unwrap(),
            "--svg",
            svg_arg,
        ],
        &["no [commissioning.spindle_encoder] to plot"],
    );
    assert!(!svg.exists());
    let record = "\n[commissioning.spindle_encoder]\nutc = 2026-11-29T02:10:05Z\n\
        error_arcsec = 15.2\nerror_2_arcsec = 4.1\nerror_3_arcsec = 1.6\nswing_arcsec = 12.0\n\
        swing_phase_deg = 131.0\nswing_tau_s = 0.003\nreference_rpm = 212.0\n\
        speeds_rpm = [64.0, 110.0, 212.0]\nmisfit_arcsec = 0.5\nerror_uncertainty_arcsec = 0.9\n";
    let file = temp_program(
        "machine-with-encoder.toml",
        &(std::fs::read_to_string(&shipped).unwrap() + record),
    );
    let o = hob(&[
        "commission",
        "report",
        "--machine",
        file.to_str().unwrap(),
        "--svg",
        svg_arg,
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("15.20 +- 0.90 arcsec once per turn"));
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert_eq!(plot.matches("<polyline").count(), 3);
    let _ = std::fs::remove_file(&svg);
}
