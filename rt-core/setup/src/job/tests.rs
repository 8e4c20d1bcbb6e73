use super::*;
use crate::config::parse_toml;
use std::path::PathBuf;

fn example(name: &str) -> String {
    let path: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/programs")
        .join(name);
    std::fs::read_to_string(path).expect("example program")
}

fn check_keys(src: &str) -> Vec<String> {
    let program: Program = parse_toml(Path::new("p.toml"), src).expect("parses");
    let mut p = Problems::new();
    let checked = program.check(&mut p);
    assert_eq!(checked.is_none(), !p.is_empty());
    p.as_slice().iter().map(|x| x.key.clone()).collect()
}

#[test]
fn examples_pass_the_machine_independent_checks() {
    for name in [
        "spur-z17-m5.toml",
        "helical-z31-m3.toml",
        "spline-z12-m2-plunge.toml",
        "tooth-by-tooth-z24-m8.toml",
        "helical-z41-m2-2start.toml",
    ] {
        assert!(check_keys(&example(name)).is_empty(), "{name}");
    }
}

#[test]
fn a_hob_needs_starts_lead_angle_and_hand() {
    let src = example("spur-z17-m5.toml").replace("starts = 1\nlead_angle_deg = 3.3\nhand = \"right\"\n", "");
    assert_eq!(
        check_keys(&src),
        ["tool.starts", "tool.lead_angle_deg", "tool.hand"]
    );
}

#[test]
fn a_disk_has_no_starts_or_hand() {
    let src = example("tooth-by-tooth-z24-m8.toml")
        .replace("gashes = 12", "gashes = 12\nstarts = 2\nhand = \"left\"");
    assert_eq!(check_keys(&src), ["tool.starts", "tool.hand"]);
}

#[test]
fn crowning_radius_below_half_the_face_is_refused() {
    let src = example("spur-z17-m5.toml").replace("{ height_mm = 0.02 }", "{ radius_mm = 19.0 }");
    assert_eq!(check_keys(&src), ["workpiece.crowning.radius_mm"]);
}

#[test]
fn crowning_by_radius_gives_the_same_arc_as_by_height() {
    let by_height = example("spur-z17-m5.toml");
    let by_radius = by_height.replace("{ height_mm = 0.02 }", "{ radius_mm = 10000.01 }");
    let shape = |src: &str| {
        let program: Program = parse_toml(Path::new("p.toml"), src).expect("parses");
        program.check(&mut Problems::new()).expect("valid").x_shape
    };
    let (a, b) = (shape(&by_height), shape(&by_radius));
    for face in [0.0, 7.0, 20.0, 33.0, 40.0] {
        assert!((a.x_offset_mm(face) - b.x_offset_mm(face)).abs() < 1e-12);
    }
}

#[test]
fn a_contour_point_outside_the_face_is_refused() {
    let src = example("spur-z17-m5.toml").replace(
        "crowning = { height_mm = 0.02 }",
        "contour = [[0.0, 0.0], [45.0, -0.01]]",
    );
    assert_eq!(check_keys(&src), ["workpiece.contour[1]"]);
}

#[test]
fn a_shape_deeper_than_the_retract_is_refused() {
    let src = example("spur-z17-m5.toml").replace("{ height_mm = 0.02 }", "{ height_mm = 6.0 }");
    assert_eq!(check_keys(&src), ["strategy.retract_mm"]);
}

const REFERENCE_TOOL: &str = "[tool]\nlibrary = \"hob-m5-a\"\n";

fn with_tool_section(tool: &str) -> String {
    let src = example("spur-z17-m5.toml");
    let start = src.find("[tool]\n").expect("[tool]");
    let end = src.find("[cycle]\n").expect("[cycle]");
    format!("{}{tool}\n{}", &src[..start], &src[end..])
}

#[test]
fn a_program_naming_a_library_tool_is_not_planned_unresolved() {
    let src = with_tool_section(REFERENCE_TOOL);
    let r = ToolReference::find(Path::new("p.toml"), &src)
        .expect("toml")
        .expect("a reference");
    assert_eq!(r.library, "hob-m5-a");
    assert!(r.tool_keys.is_empty());
    let e = Program::parse(Path::new("p.toml"), &src).expect_err("unresolved");
    let text = e.to_string();
    assert_eq!(e.problems()[0].key, "tool.library", "{text}");
    assert!(
        text.contains("names the library tool \"hob-m5-a\": resolve it"),
        "{text}"
    );
}

#[test]
fn a_library_tool_and_tool_fields_together_are_refused() {
    let src = with_tool_section(&format!("{REFERENCE_TOOL}kind = \"hob\"\ngashes = 10\n"));
    let e = Program::parse(Path::new("p.toml"), &src).expect_err("both");
    let text = e.to_string();
    assert!(text.contains("tool.library"), "{text}");
    assert!(text.contains("gives tool fields too (gashes, kind)"), "{text}");
}

#[test]
fn a_self_contained_program_has_no_reference_and_parses() {
    let src = example("spur-z17-m5.toml");
    assert_eq!(
        ToolReference::find(Path::new("p.toml"), &src).expect("toml"),
        None
    );
    assert!(Program::parse(Path::new("p.toml"), &src).is_ok());
}

#[test]
fn a_tool_alone_is_checked_by_its_own_keys() {
    let program: Program = parse_toml(Path::new("p.toml"), &example("spur-z17-m5.toml")).expect("parses");
    assert!(program.tool.check(&mut Problems::new()));
    let mut tool = program.tool.clone();
    tool.gashes = 0;
    tool.hand = None;
    let mut p = Problems::new();
    assert!(!tool.check(&mut p));
    let keys: Vec<&str> = p.as_slice().iter().map(|x| x.key.as_str()).collect();
    assert_eq!(keys, ["tool.gashes", "tool.hand"]);
}
