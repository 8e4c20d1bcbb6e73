//! `hob lib programs|tools`, `hob load --lib`, and `hob check|plan` of a program that names a
//! library tool: the real `hob` binary on a library in a fresh temporary directory.
#![allow(clippy::unwrap_used)]

mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use support::{edited, root, text};

const HOB: &str = env!("CARGO_BIN_EXE_hob");
const SPUR: &str = "config/programs/spur-z17-m5.toml";

/// A fresh library directory for one test (not created: `hob lib` creates it).
fn library_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hob-test-lib-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// `hob ARGS --library DIR`, in the workspace's root, without `HOB_LIBRARY` from outside.
fn hob_lib(dir: &Path, args: &[&str]) -> Output {
    Command::new(HOB)
        .args(args)
        .arg("--library")
        .arg(dir)
        .current_dir(root())
        .env_remove("HOB_LIBRARY")
        .output()
        .unwrap()
}

fn ok(dir: &Path, args: &[&str]) -> String {
    let out = hob_lib(dir, args);
    assert!(out.status.success(), "{args:?}: {}", text(&out.stderr));
    text(&out.stdout)
}

/// Refused: exit 2, every needle on stderr, nothing on stdout.
fn refused(dir: &Path, args: &[&str], needles: &[&str]) {
    let out = hob_lib(dir, args);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{args:?}: {} {}",
        text(&out.stdout),
        text(&out.stderr)
    );
    let err = text(&out.stderr);
    for n in needles {
        assert!(err.contains(n), "{args:?}: missing {n:?} in: {err}");
    }
    assert!(out.stdout.is_empty(), "{}", text(&out.stdout));
}

fn spur_src() -> String {
    std::fs::read_to_string(root().join(SPUR)).unwrap()
}

fn section(src: &str, from: &str, to: &str) -> (usize, usize) {
    (src.find(from).unwrap(), src.find(to).unwrap())
}

/// The spur example's hob as a tool file.
fn tool_file(name: &str) -> PathBuf {
    let src = spur_src();
    let (a, b) = section(&src, "[tool]\n", "[cycle]\n");
    support::temp_file(name, &format!("format_version = 1\n\n{}", &src[a..b]))
}

/// The spur example naming the library tool `tool` instead of its own.
fn program_naming(tool: &str, name: &str) -> PathBuf {
    let src = spur_src();
    let (a, b) = section(&src, "[tool]\n", "[cycle]\n");
    let text = format!("{}[tool]\nlibrary = \"{tool}\"\n\n{}", &src[..a], &src[b..]);
    support::temp_file(name, &text)
}

fn entries(dir: &Path, kind: &str) -> Vec<String> {
    match std::fs::read_dir(dir.join(kind)) {
        Ok(rd) => rd
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect(),
        Err(_) => Vec::new(),
    }
}

#[test]
fn programs_create_list_show_copy_rename_delete() {
    let dir = library_dir("programs");
    let s = ok(&dir, &["lib", "programs", "create", "spur", SPUR]);
    assert!(
        s.starts_with("program spur created in ") && s.contains("3 passes"),
        "{s}"
    );
    assert_eq!(ok(&dir, &["lib", "programs", "show", "spur"]), spur_src());
    ok(&dir, &["lib", "programs", "copy", "spur", "spur-2"]);
    ok(&dir, &["lib", "programs", "rename", "spur-2", "spur.v3"]);
    let list = ok(&dir, &["lib", "programs", "list"]);
    assert_eq!(list, "spur     ok\nspur.v3  ok\n");
    assert_eq!(
        ok(&dir, &["lib", "programs", "delete", "spur.v3"]),
        "program spur.v3 deleted\n"
    );
    assert_eq!(entries(&dir, "programs"), ["spur.toml"]);
}

#[test]
fn program_refusals_name_the_reason_and_write_nothing() {
    let dir = library_dir("program-refusals");
    ok(&dir, &["lib", "programs", "create", "spur", SPUR]);
    refused(
        &dir,
        &["lib", "programs", "create", "../evil", SPUR],
        &["program name \"../evil\" has '/': a name is not a path"],
    );
    refused(
        &dir,
        &["lib", "programs", "create", ".hidden", SPUR],
        &["hidden file"],
    );
    refused(
        &dir,
        &["lib", "programs", "show", "..\\x"],
        &["a name is not a path"],
    );
    refused(&dir, &["lib", "programs", "copy", "spur", "a..b"], &["\"..\""]);
    refused(
        &dir,
        &["lib", "programs", "create", "spur", SPUR],
        &["the library already has a program \"spur\""],
    );
    refused(
        &dir,
        &["lib", "programs", "show", "gone"],
        &["no program \"gone\" in the library"],
    );
    refused(
        &dir,
        &["lib", "programs", "copy", "gone", "x"],
        &["no program \"gone\""],
    );
    refused(
        &dir,
        &["lib", "programs", "rename", "gone", "x"],
        &["no program \"gone\""],
    );
    refused(
        &dir,
        &["lib", "programs", "delete", "gone"],
        &["no program \"gone\""],
    );
    ok(&dir, &["lib", "programs", "copy", "spur", "other"]);
    refused(
        &dir,
        &["lib", "programs", "rename", "other", "spur"],
        &["already has a program \"spur\""],
    );
    // A program this machine cannot cut: refused with the key, as hob check refuses it.
    let fast = edited(SPUR, "fast-table.toml", &[("workpiece.teeth", 5.into())]);
    refused(
        &dir,
        &["lib", "programs", "create", "fast", fast.to_str().unwrap()],
        &[
            "program \"fast\" not created",
            "strategy.rough.cutting_speed_m_min",
            "table.max_table_rpm = 14.1",
        ],
    );
    refused(
        &dir,
        &[
            "lib",
            "programs",
            "create",
            "none",
            "config/programs/does-not-exist.toml",
        ],
        &["does-not-exist.toml: cannot read"],
    );
    let mut names = entries(&dir, "programs");
    names.sort();
    assert_eq!(names, ["other.toml", "spur.toml"]);
    assert!(!dir.join("evil.toml").exists() && !dir.parent().unwrap().join("evil.toml").exists());
}

#[test]
fn tools_create_list_show_copy_rename_delete_and_refusals() {
    let dir = library_dir("tools");
    let file = tool_file("hob-m5.toml");
    let f = file.to_str().unwrap();
    assert!(ok(&dir, &["lib", "tools", "create", "hob-m5-a", f]).starts_with("tool hob-m5-a created"));
    assert_eq!(
        ok(&dir, &["lib", "tools", "show", "hob-m5-a"]),
        std::fs::read_to_string(&file).unwrap()
    );
    ok(&dir, &["lib", "tools", "copy", "hob-m5-a", "hob-m5-b"]);
    ok(&dir, &["lib", "tools", "rename", "hob-m5-b", "hob-m5-c"]);
    assert_eq!(
        ok(&dir, &["lib", "tools", "list"]),
        "hob-m5-a  ok\nhob-m5-c  ok\n"
    );
    ok(&dir, &["lib", "tools", "delete", "hob-m5-c"]);
    refused(
        &dir,
        &["lib", "tools", "create", "hob-m5-a", f],
        &["the library already has a tool \"hob-m5-a\""],
    );
    refused(
        &dir,
        &["lib", "tools", "create", "x/y", f],
        &["tool name \"x/y\" has '/'"],
    );
    refused(
        &dir,
        &["lib", "tools", "delete", "hob-m5-c"],
        &["no tool \"hob-m5-c\""],
    );
    let bad = support::temp_file(
        "bad-tool.toml",
        &std::fs::read_to_string(&file)
            .unwrap()
            .replace("gashes = 10", "gashes = 0"),
    );
    refused(
        &dir,
        &["lib", "tools", "create", "bad", bad.to_str().unwrap()],
        &["tool \"bad\" not created", "tool.gashes"],
    );
    assert_eq!(entries(&dir, "tools"), ["hob-m5-a.toml"]);
}

#[test]
fn a_program_naming_a_library_tool_is_checked_planned_and_stored_through_the_library() {
    let dir = library_dir("resolve");
    ok(
        &dir,
        &[
            "lib",
            "tools",
            "create",
            "hob-m5-a",
            tool_file("hob-m5.toml").to_str().unwrap(),
        ],
    );
    let p = program_naming("hob-m5-a", "by-ref.toml");
    let p = p.to_str().unwrap();
    assert!(ok(&dir, &["check", p]).contains(": ok on config/machine.toml: 3 passes"));
    let plan = ok(&dir, &["plan", p, "--json"]);
    let direct = support::run(HOB, &["plan", SPUR, "--json"]);
    assert_eq!(
        plan,
        text(&direct.stdout),
        "the same plan as the program with the tool written out"
    );
    ok(&dir, &["lib", "programs", "create", "by-ref", p]);
    assert_eq!(ok(&dir, &["lib", "programs", "list"]), "by-ref  ok\n");
    // HOB_LIBRARY names the library when --library is not given.
    let out = Command::new(HOB)
        .args(["check", p])
        .current_dir(root())
        .env("HOB_LIBRARY", &dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out.stderr));
    // Without the library it cannot be checked: the reference is named.
    let out = Command::new(HOB)
        .args(["check", p])
        .current_dir(root())
        .env("HOB_LIBRARY", library_dir("resolve-empty"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr)
            .contains("tool.library: names the library tool \"hob-m5-a\", which is not in the library"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn a_program_naming_a_missing_tool_is_refused_with_the_tool_name_everywhere() {
    let dir = library_dir("missing-tool");
    let p = program_naming("hob-m5-z", "missing-tool.toml");
    let p = p.to_str().unwrap();
    let needle = "tool.library: names the library tool \"hob-m5-z\", which is not in the library";
    refused(&dir, &["check", p], &[needle]);
    refused(&dir, &["plan", p], &[needle]);
    refused(&dir, &["load", p], &[needle]);
    refused(&dir, &["lib", "programs", "create", "x", p], &[needle]);
    assert!(entries(&dir, "programs").is_empty());
    // A library program whose tool was deleted: listed with the reason, not loaded.
    ok(
        &dir,
        &[
            "lib",
            "tools",
            "create",
            "hob-m5-z",
            tool_file("z.toml").to_str().unwrap(),
        ],
    );
    ok(&dir, &["lib", "programs", "create", "by-ref", p]);
    ok(&dir, &["lib", "tools", "delete", "hob-m5-z"]);
    assert!(ok(&dir, &["lib", "programs", "list"]).starts_with("by-ref  INVALID: "));
    refused(
        &dir,
        &["load", "--lib", "by-ref"],
        &["\"hob-m5-z\", which is not in the library"],
    );
    refused(
        &dir,
        &["load", "--lib", "gone"],
        &["no program \"gone\" in the library"],
    );
    refused(&dir, &["load", "--lib", "../by-ref"], &["a name is not a path"]);
    // Both a reference and tool fields.
    let both = support::temp_file(
        "both.toml",
        &std::fs::read_to_string(p).unwrap().replace(
            "library = \"hob-m5-z\"\n",
            "library = \"hob-m5-z\"\ngashes = 10\n",
        ),
    );
    refused(
        &dir,
        &["check", both.to_str().unwrap()],
        &["tool.library", "gives tool fields too (gashes)"],
    );
}

/// A recording of two passes: Y feeds 40 mm down in the cut of each, rapids back up.
fn two_passes_recorded(name: &str) -> PathBuf {
    use hob_ipc::StateSample;
    use hob_ipc::codec::State;
    let log = library_dir(name);
    std::fs::create_dir_all(&log).unwrap();
    let mut w = hob_logger::LogWriter::open(&log, "test").unwrap();
    let mut cycle = 0;
    for pass in 1..=2 {
        for (state, y0, y1) in [
            (State::ToStart, 0.0, 40.0),
            (State::Cut, 40.0, 0.0),
            (State::Retract, 0.0, 0.0),
        ] {
            for i in 0..=100 {
                cycle += 1;
                let y = y0 + (y1 - y0) * f64::from(i) / 100.0;
                let s = StateSample {
                    cycle,
                    sync_time_ns: cycle * 1_000_000,
                    state: state.code(),
                    pass,
                    passes_total: 2,
                    pitch_radius_mm: 42.5,
                    normal_module_mm: 5.0,
                    y_mm: hob_ipc::AxisSample {
                        actual: y,
                        command: y,
                    },
                    ..StateSample::default()
                };
                w.push_state(&s).unwrap();
            }
        }
    }
    w.flush().unwrap();
    log
}

/// `hob lib tools record-usage NAME --log LOG --when WHEN`.
fn record_usage<'a>(name: &'a str, log: &'a str, when: &'a str) -> [&'a str; 8] {
    ["lib", "tools", "record-usage", name, "--log", log, "--when", when]
}

#[test]
fn usage_of_a_recorded_cut_is_added_to_the_tool() {
    let dir = library_dir("usage");
    ok(
        &dir,
        &[
            "lib",
            "tools",
            "create",
            "hob-m5-a",
            tool_file("u.toml").to_str().unwrap(),
        ],
    );
    let log = two_passes_recorded("usage-log");
    let log = log.to_str().unwrap();
    let s = ok(&dir, &record_usage("hob-m5-a", log, "2025-03-01T08:15:00Z"));
    assert!(s.contains("+2 passes and 0.0800 m of Y in the cut"), "{s}");
    ok(&dir, &record_usage("hob-m5-a", log, "2025-03-02T08:15:00Z"));
    let shown = ok(&dir, &["lib", "tools", "show", "hob-m5-a"]);
    let t: toml::Table = shown.parse().unwrap();
    let usage = t["usage"].as_table().unwrap();
    assert_eq!(usage["passes_cut"].as_integer(), Some(4));
    assert!(
        (usage["y_travel_in_cut_m"].as_float().unwrap() - 0.16).abs() < 1e-9,
        "{shown}"
    );
    assert_eq!(usage["last_used_utc"].as_str(), Some("2025-03-02T08:15:00Z"));
    refused(
        &dir,
        &record_usage("hob-m5-a", log, "later"),
        &["usage.last_used_utc"],
    );
    refused(
        &dir,
        &["lib", "tools", "record-usage", "hob-m5-b", "--log", log],
        &["no tool \"hob-m5-b\""],
    );
}

/// The shipped library's disk cutter (`config/library/tools/module-cutter-m8-no5.toml`)
/// taken into a machine's library with `hob lib tools create`; the shipped tooth-by-tooth
/// program that names it planned through that library with the cutter judged; `hob lib
/// tools grind NAME` grinds it per gash; a hob (no `[tool.disk]`) refused.
#[test]
fn a_library_disk_cutter_is_planned_and_ground_from_its_profile() {
    let dir = library_dir("grind");
    let file = support::root().join("config/library/tools/module-cutter-m8-no5.toml");
    ok(
        &dir,
        &[
            "lib",
            "tools",
            "create",
            "module-cutter-m8-no5",
            file.to_str().unwrap(),
        ],
    );
    let plan = ok(
        &dir,
        &["plan", "config/library/programs/tooth-by-tooth-z24-m8.toml"],
    );
    assert!(
        plan.contains("disk cutter's profile: 10.79 um from the gear's involute")
            && plan.contains("peak load 7695 N of 460800 N the body takes"),
        "{plan}"
    );
    ok(
        &dir,
        &["lib", "tools", "rename", "module-cutter-m8-no5", "cutter-m8"],
    );
    refused(
        &dir,
        &["plan", "config/library/programs/tooth-by-tooth-z24-m8.toml"],
        &["module-cutter-m8-no5"],
    );
    let nc = dir.join("cutter-m8.nc");
    let args = [
        "lib",
        "tools",
        "grind",
        "cutter-m8",
        "--wheel-radius-mm",
        "50",
        "--wheel-edge-radius-mm",
        "1",
        "--out",
        nc.to_str().unwrap(),
    ];
    let o = ok(&dir, &args);
    assert!(o.starts_with("cutter-m8: ") && o.contains("12 teeth"), "{o}");
    let code = std::fs::read_to_string(&nc).unwrap();
    assert_eq!(code.matches("\nG0 A").count(), 12);
    let hob = tool_file("hob-for-grind.toml");
    ok(&dir, &["lib", "tools", "create", "hob-m5", hob.to_str().unwrap()]);
    let mut args = args;
    args[3] = "hob-m5";
    refused(&dir, &args, &["hob-m5", "no disk cutter's profile"]);
}
