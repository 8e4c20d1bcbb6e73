#![allow(clippy::unwrap_used)]

use super::*;
use crate::test_dir;
use hob_setup::config::machine::shipped_for_tests;
use hob_setup::job::Program;

fn spur_src() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/programs/spur-z17-m5.toml");
    std::fs::read_to_string(path).unwrap()
}

/// The spur example's `[tool]` section replaced by `tool`.
fn spur_with_tool(tool: &str) -> String {
    let src = spur_src();
    let start = src.find("[tool]\n").unwrap();
    let end = src.find("[cycle]\n").unwrap();
    format!("{}{tool}\n{}", &src[..start], &src[end..])
}

/// The spur example's hob as a tool record.
fn hob_m5_record() -> String {
    let src = spur_src();
    let start = src.find("[tool]\n").unwrap();
    let end = src.find("[cycle]\n").unwrap();
    format!("format_version = 1\n\n{}", &src[start..end])
}

fn library(name: &str) -> Library {
    Library::open(&test_dir(name).join("library")).unwrap()
}

#[test]
fn open_creates_programs_and_tools() {
    let lib = library("lib-open");
    assert!(lib.dir().join("programs").is_dir());
    assert!(lib.dir().join("tools").is_dir());
    assert!(lib.names(Kind::Program).unwrap().is_empty());
}

#[test]
fn a_program_naming_a_library_tool_resolves_to_the_same_program() {
    let lib = library("lib-resolve");
    lib.create_tool("hob-m5-a", &hob_m5_record()).unwrap();
    let text = spur_with_tool("[tool]\nlibrary = \"hob-m5-a\"\n");
    let resolved = lib.resolve(Path::new("p.toml"), &text).unwrap();
    let a = Program::parse(Path::new("r.toml"), &resolved).unwrap();
    let b = Program::parse(Path::new("s.toml"), &spur_src()).unwrap();
    assert_eq!(a, b);
    // A self-contained program comes back as it was.
    assert_eq!(lib.resolve(Path::new("s.toml"), &spur_src()).unwrap(), spur_src());
}

#[test]
fn a_program_naming_a_missing_tool_is_refused_with_the_tool_name() {
    let lib = library("lib-missing-tool");
    let text = spur_with_tool("[tool]\nlibrary = \"hob-m5-b\"\n");
    let e = lib.resolve(Path::new("p.toml"), &text).unwrap_err();
    assert!(
        matches!(&e, Refusal::MissingTool { tool, .. } if tool == "hob-m5-b"),
        "{e}"
    );
    assert!(
        e.to_string()
            .contains("tool.library: names the library tool \"hob-m5-b\", which is not in the library")
    );
    let e = lib
        .create_program("spur", &text, &shipped_for_tests())
        .unwrap_err();
    assert!(e.to_string().contains("\"hob-m5-b\""), "{e}");
    assert!(lib.names(Kind::Program).unwrap().is_empty(), "nothing written");
}

#[test]
fn a_reference_with_tool_fields_or_a_bad_tool_name_is_refused() {
    let lib = library("lib-both");
    lib.create_tool("hob-m5-a", &hob_m5_record()).unwrap();
    let both = spur_with_tool("[tool]\nlibrary = \"hob-m5-a\"\ngashes = 10\n");
    let e = lib.resolve(Path::new("p.toml"), &both).unwrap_err().to_string();
    assert!(
        e.contains("tool.library") && e.contains("gives tool fields too (gashes)"),
        "{e}"
    );
    let escape = spur_with_tool("[tool]\nlibrary = \"../tools/hob-m5-a\"\n");
    let e = lib.resolve(Path::new("p.toml"), &escape).unwrap_err().to_string();
    assert!(
        e.contains("tool.library") && e.contains("a name is not a path"),
        "{e}"
    );
}

#[test]
fn programs_are_created_only_when_they_check_on_the_machine() {
    let lib = library("lib-create");
    let machine = shipped_for_tests();
    lib.create_program("spur", &spur_src(), &machine).unwrap();
    assert_eq!(lib.text(Kind::Program, "spur").unwrap(), spur_src());
    let e = lib.create_program("spur", &spur_src(), &machine).unwrap_err();
    assert!(matches!(e, Refusal::Exists { .. }), "{e}");
    // The same check as hob check: the table too fast for this machine.
    let fast = spur_src().replace("teeth = 17", "teeth = 5");
    let e = lib
        .create_program("fast", &fast, &machine)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("program \"fast\" not created") && e.contains("strategy.rough.cutting_speed_m_min"),
        "{e}"
    );
    let e = lib
        .create_program("typo", &spur_src().replace("retract_mm", "retrakt_mm"), &machine)
        .unwrap_err();
    assert!(e.to_string().contains("unknown field `retrakt_mm`"), "{e}");
    assert_eq!(lib.names(Kind::Program).unwrap(), ["spur"]);
}

#[test]
fn a_changed_program_replaces_the_old_only_when_it_checks() {
    let lib = library("lib-replace");
    let machine = shipped_for_tests();
    let e = lib.replace_program("spur", &spur_src(), &machine).unwrap_err();
    assert!(
        matches!(e, Refusal::Missing { .. }),
        "a replace creates nothing: {e}"
    );
    assert!(lib.names(Kind::Program).unwrap().is_empty());
    lib.create_program("spur", &spur_src(), &machine).unwrap();
    let path = lib.path(Kind::Program, "spur").unwrap();
    let before = std::fs::metadata(&path).unwrap().modified().unwrap();
    let bad = spur_src().replace("teeth = 17", "teeth = \"1O\"");
    let e = lib
        .replace_program("spur", &bad, &machine)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("program \"spur\" not changed") && e.contains("\"1O\""),
        "{e}"
    );
    assert_eq!(
        lib.text(Kind::Program, "spur").unwrap(),
        spur_src(),
        "a refused replace changed the file"
    );
    assert_eq!(std::fs::metadata(&path).unwrap().modified().unwrap(), before);
    let deeper = spur_src().replace("retract_mm = 5.0", "retract_mm = 6.0");
    assert_ne!(deeper, spur_src());
    let plan = lib.replace_program("spur", &deeper, &machine).unwrap();
    assert_eq!(lib.text(Kind::Program, "spur").unwrap(), deeper);
    assert!(!plan.passes.is_empty());
    // No temporary file is left beside it.
    let left: Vec<_> = std::fs::read_dir(path.parent().unwrap())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left.len(), 1, "{left:?}");
}

/// The bytes and the modification time of a file.
fn contents_and_mtime(path: &Path) -> (Vec<u8>, std::time::SystemTime) {
    (
        std::fs::read(path).unwrap(),
        std::fs::metadata(path).unwrap().modified().unwrap(),
    )
}

#[test]
fn a_changed_tool_replaces_the_old_only_when_it_is_valid_and_keeps_its_usage() {
    let lib = library("lib-replace-tool");
    let longer = hob_m5_record().replace("length_mm = 100.0", "length_mm = 120.0");
    assert_ne!(longer, hob_m5_record());
    let e = lib.replace_tool("hob-m5-a", &longer).unwrap_err();
    assert!(
        matches!(e, Refusal::Missing { .. }),
        "a replace creates nothing: {e}"
    );
    assert!(lib.names(Kind::Tool).unwrap().is_empty());
    lib.create_tool("hob-m5-a", &hob_m5_record()).unwrap();
    let used = lib
        .record_usage("hob-m5-a", 4, 0.5, "2025-03-01T08:15:00Z")
        .unwrap();
    let path = lib.path(Kind::Tool, "hob-m5-a").unwrap();
    let before = contents_and_mtime(&path);
    // Refused, nothing written: an invalid field, a usage other than the recorded one.
    let zero = used.to_toml().replace("gashes = 10", "gashes = 0");
    let e = lib.replace_tool("hob-m5-a", &zero).unwrap_err().to_string();
    assert!(
        e.contains("tool \"hob-m5-a\" not changed") && e.contains("tool.gashes"),
        "{e}"
    );
    let typed = used.to_toml().replace("passes_cut = 4", "passes_cut = 0");
    assert_ne!(typed, used.to_toml());
    let e = lib.replace_tool("hob-m5-a", &typed).unwrap_err().to_string();
    assert!(
        e.contains("usage") && e.contains("recorded after each cut"),
        "{e}"
    );
    assert_eq!(
        contents_and_mtime(&path),
        before,
        "a refused replace changed the file"
    );
    // The tool's fields alone: the recorded usage stays.
    let r = lib.replace_tool("hob-m5-a", &longer).unwrap();
    assert!((r.tool.length_mm - 120.0).abs() < 1e-12);
    assert_eq!(r.usage, used.usage);
    assert_eq!(lib.tool("hob-m5-a").unwrap(), r);
    assert!(lib.text(Kind::Tool, "hob-m5-a").unwrap().starts_with(&longer));
    // With the usage as stored: written as given.
    let as_stored = r.to_toml().replace("gashes = 10", "gashes = 12");
    let r = lib.replace_tool("hob-m5-a", &as_stored).unwrap();
    assert_eq!(r.tool.gashes, 12);
    assert_eq!(lib.text(Kind::Tool, "hob-m5-a").unwrap(), as_stored);
    // A program resolving the tool still checks, and no temporary file is left beside it.
    let text = spur_with_tool("[tool]\nlibrary = \"hob-m5-a\"\n");
    lib.check_program(Path::new("p.toml"), &text, &shipped_for_tests())
        .unwrap();
    assert_eq!(lib.names(Kind::Tool).unwrap(), ["hob-m5-a"]);
    assert_eq!(std::fs::read_dir(path.parent().unwrap()).unwrap().count(), 1);
}

#[test]
fn a_tool_file_broken_by_hand_can_be_replaced() {
    let lib = library("lib-replace-broken-tool");
    lib.create_tool("t", &hob_m5_record()).unwrap();
    let path = lib.path(Kind::Tool, "t").unwrap();
    std::fs::write(&path, "format_version = 1\n[tool]\ngashes = \"ten\"\n").unwrap();
    assert!(matches!(lib.tool("t"), Err(Refusal::Invalid { .. })));
    let r = lib.replace_tool("t", &hob_m5_record()).unwrap();
    assert_eq!(r.usage, Usage::default());
    assert_eq!(lib.text(Kind::Tool, "t").unwrap(), hob_m5_record());
}

#[test]
fn the_listing_checks_each_program_and_skips_temporary_files() {
    let lib = library("lib-list");
    let machine = shipped_for_tests();
    lib.create_tool("hob-m5-a", &hob_m5_record()).unwrap();
    lib.create_program(
        "by-ref",
        &spur_with_tool("[tool]\nlibrary = \"hob-m5-a\"\n"),
        &machine,
    )
    .unwrap();
    lib.create_program("spur", &spur_src(), &machine).unwrap();
    // A program made invalid on disk (by hand), a tool deleted under a program, and what
    // a crash leaves.
    let dir = lib.dir().join("programs");
    std::fs::write(
        dir.join("hand.toml"),
        spur_src().replace("teeth = 17", "teeth = 0"),
    )
    .unwrap();
    std::fs::write(dir.join(".spur.toml.tmp.1.0"), "half").unwrap();
    std::fs::write(dir.join("notes.txt"), "not a program").unwrap();
    let list = lib.list_programs(&machine).unwrap();
    let names: Vec<&str> = list.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(names, ["by-ref", "hand", "spur"]);
    assert_eq!(list[0].problem, None);
    assert!(
        list[1].problem.as_deref().unwrap().contains("workpiece.teeth"),
        "{list:?}"
    );
    assert_eq!(list[2].problem, None);
    lib.delete(Kind::Tool, "hob-m5-a").unwrap();
    let list = lib.list_programs(&machine).unwrap();
    assert!(
        list[0]
            .problem
            .as_deref()
            .unwrap()
            .contains("\"hob-m5-a\", which is not in the library"),
        "{list:?}"
    );
}

#[test]
fn copy_rename_delete_refuse_missing_and_existing_entries() {
    let lib = library("lib-crd");
    lib.create_tool("a", &hob_m5_record()).unwrap();
    lib.copy(Kind::Tool, "a", "b").unwrap();
    assert_eq!(lib.tool("a").unwrap(), lib.tool("b").unwrap());
    assert!(matches!(
        lib.copy(Kind::Tool, "a", "b"),
        Err(Refusal::Exists { .. })
    ));
    assert!(matches!(
        lib.rename(Kind::Tool, "a", "b"),
        Err(Refusal::Exists { .. })
    ));
    assert!(matches!(
        lib.copy(Kind::Tool, "x", "y"),
        Err(Refusal::Missing { .. })
    ));
    assert!(matches!(
        lib.rename(Kind::Tool, "x", "y"),
        Err(Refusal::Missing { .. })
    ));
    assert!(matches!(
        lib.delete(Kind::Tool, "x"),
        Err(Refusal::Missing { .. })
    ));
    lib.rename(Kind::Tool, "a", "c").unwrap();
    assert_eq!(lib.names(Kind::Tool).unwrap(), ["b", "c"]);
    lib.delete(Kind::Tool, "b").unwrap();
    assert_eq!(lib.names(Kind::Tool).unwrap(), ["c"]);
    let e = lib.copy(Kind::Tool, "c", "../programs/c").unwrap_err();
    assert!(matches!(e, Refusal::BadName { .. }), "{e}");
    assert!(lib.names(Kind::Program).unwrap().is_empty());
}

#[test]
fn an_invalid_tool_is_not_created() {
    let lib = library("lib-bad-tool");
    let e = lib
        .create_tool("t", &hob_m5_record().replace("gashes = 10", "gashes = 0"))
        .unwrap_err();
    assert!(e.to_string().contains("tool.gashes"), "{e}");
    let e = lib
        .create_tool(
            "t",
            &hob_m5_record().replace("format_version = 1", "format_version = 9"),
        )
        .unwrap_err();
    assert!(e.to_string().contains("format_version"), "{e}");
    assert!(lib.names(Kind::Tool).unwrap().is_empty());
}

#[test]
fn usage_adds_up_and_is_validated() {
    let lib = library("lib-usage");
    lib.create_tool("hob-m5-a", &hob_m5_record()).unwrap();
    assert_eq!(lib.tool("hob-m5-a").unwrap().usage, Usage::default());
    lib.record_usage("hob-m5-a", 3, 0.25, "2025-03-01T08:15:00Z")
        .unwrap();
    let r = lib
        .record_usage("hob-m5-a", 2, 0.5, "2025-03-02T09:00:00Z")
        .unwrap();
    assert_eq!(r.usage.passes_cut, 5);
    assert!((r.usage.y_travel_in_cut_m - 0.75).abs() < 1e-12);
    assert_eq!(lib.tool("hob-m5-a").unwrap(), r);
    for (y, when, key) in [
        (-1.0, "2025-03-03T00:00:00Z", "y_travel_m"),
        (f64::NAN, "2025-03-03T00:00:00Z", "y_travel_m"),
        (0.1, "today", "usage.last_used_utc"),
    ] {
        let e = lib.record_usage("hob-m5-a", 1, y, when).unwrap_err().to_string();
        assert!(e.contains(key), "{e}");
    }
    assert_eq!(
        lib.tool("hob-m5-a").unwrap(),
        r,
        "a refused record changes nothing"
    );
    // The tool's fields stay as they were: a program resolving it plans the same.
    let text = spur_with_tool("[tool]\nlibrary = \"hob-m5-a\"\n");
    lib.check_program(Path::new("p.toml"), &text, &shipped_for_tests())
        .unwrap();
}

/// The library shipped as an example (`config/library`, the layout of `[library] dir`):
/// every entry is valid, and its tooth-by-tooth program, which names the designed disk
/// cutter, resolves to the self-contained example and plans as it does.
#[test]
fn the_shipped_library_is_valid_and_its_program_plans_as_the_self_contained_example() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let lib = Library::open(&root.join("config/library")).unwrap();
    let m = shipped_for_tests();
    let programs = lib.list_programs(&m).unwrap();
    let tools = lib.list_tools().unwrap();
    assert!(!programs.is_empty() && !tools.is_empty());
    for e in programs.iter().chain(&tools) {
        assert_eq!(e.problem, None, "{}", e.name);
    }
    let cutter = lib.tool("module-cutter-m8-no5").unwrap();
    assert_eq!(cutter.usage, Usage::default(), "a new cutter has cut nothing");
    assert!(cutter.tool.disk.is_some(), "a profile disk cutter");
    let origin = lib.path(Kind::Program, "tooth-by-tooth-z24-m8").unwrap();
    let text = lib.text(Kind::Program, "tooth-by-tooth-z24-m8").unwrap();
    assert!(text.contains("library = \"module-cutter-m8-no5\""), "{text}");
    let resolved = lib.resolve(&origin, &text).unwrap();
    let inline_path = root.join("config/programs/tooth-by-tooth-z24-m8.toml");
    let inline = std::fs::read_to_string(&inline_path).unwrap();
    assert_eq!(
        Program::parse(&origin, &resolved).unwrap(),
        Program::parse(&inline_path, &inline).unwrap()
    );
    let a = plan_source(&origin, &resolved, &m).unwrap();
    let b = plan_source(&inline_path, &inline, &m).unwrap();
    assert_eq!(a, b);
    assert!(a.cutter.is_some(), "the plan judges the library cutter");
}
