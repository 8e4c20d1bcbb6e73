use super::*;
use crate::config::parse_toml;
use crate::job::Program;
use proptest::prelude::*;
use std::path::PathBuf;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn machine() -> MachineConfig {
    crate::config::machine::shipped_for_tests()
}

fn program_src(name: &str) -> String {
    std::fs::read_to_string(root().join("config/programs").join(name)).expect("example program")
}

/// Plans `src` on the shipped machine; on refusal returns the located problems.
fn plan_src_on(src: &str, m: &MachineConfig) -> Result<Plan, LoadError> {
    let file = Path::new("program.toml");
    let program: Program = parse_toml(file, src)?;
    let mut p = Problems::new();
    match plan(&program, m, &mut p) {
        Some(plan) => {
            assert!(p.is_empty());
            Ok(plan)
        }
        None => Err(p.into_result(file, src).expect_err("a refusal records problems")),
    }
}

fn plan_src(src: &str) -> Result<Plan, LoadError> {
    plan_src_on(src, &machine())
}

fn refused_keys(src: &str) -> Vec<String> {
    match plan_src(src) {
        Ok(_) => panic!("accepted, expected a refusal"),
        Err(e) => {
            assert!(!e.problems().is_empty(), "{e}");
            e.problems().iter().map(|p| p.key.clone()).collect()
        }
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn thesis_worst_case_spur() {
    let p = plan_src(&program_src("spur-z17-m5.toml")).expect("plan");
    assert!(close(p.egb_ratio, 1.0 / 17.0, 1e-15));
    assert_eq!(p.differential_deg_per_mm, 0.0);
    assert!(close(p.hob_swivel_deg, 3.3, 1e-12), "spur: eta = gamma");
    assert!(close(p.pitch_diameter_mm, 85.0, 1e-12));
    let kinds: Vec<PassKind> = p.passes.iter().map(|x| x.kind).collect();
    assert_eq!(kinds, [PassKind::Rough, PassKind::Rough, PassKind::Finish]);
    let depths: Vec<f64> = p.passes.iter().map(|x| x.depth_mm).collect();
    assert_eq!(depths, [6.0, 10.75, 11.25]);
    let rough = &p.passes[0];
    assert!(close(rough.spindle_rpm, 119.366, 5e-4));
    assert!(close(rough.table_rpm, 119.366 / 17.0, 1e-4));
    assert!(close(rough.axial_feed_mm_min, 14.04, 0.005));
    assert!(close(rough.spindle_motor_rpm, 716.2, 0.05));
    assert!(close(rough.vfd_hz, 38.197, 1e-3));
    assert!(close(rough.analog_out_v, 4.775, 1e-3));
    assert!(close(rough.table_motor_rpm, 119.366 / 17.0 * 75.0, 0.01));
    // x = outside radius + hob tip radius - depth.
    assert!(close(p.passes[2].x_mm, 47.5 + 40.0 - 11.25, 1e-12));
    assert!(close(p.x_safe_mm, 47.5 + 40.0 + 5.0, 1e-12));
    // Start at the top: hob above the top face by the approach and allowance, ends with
    // its centre past the bottom face plus allowance.
    let fin = &p.passes[2];
    let approach = (11.25f64 * 68.75).sqrt() * 3.3f64.to_radians().cos() + 50.0 * 3.3f64.to_radians().sin();
    assert!(close(fin.approach_mm, approach, 1e-9));
    assert!(close(fin.y_start_mm, 50.0 + 40.0 + approach + 2.0, 1e-9));
    assert!(close(fin.y_end_mm, 48.0, 1e-12));
    assert!(close(
        fin.cut_time_s,
        (fin.y_start_mm - fin.y_end_mm) / fin.axial_feed_mm_min * 60.0,
        1e-9
    ));
    let cut: f64 = p.passes.iter().map(|x| x.cut_time_s).sum();
    let passes: f64 = p.passes.iter().map(|x| x.pass_time_s).sum();
    assert!(
        passes > cut && p.total_time_s > passes,
        "rapids and ramps come on top of the cut"
    );
    assert!(close(p.single_pitch_tolerance_grade5_um, 7.085, 1e-9));
    assert!(p.warnings.is_empty(), "{:?}", p.warnings);
}

#[test]
fn total_time_counts_the_rapids_with_acceleration() {
    let p = plan_src(&program_src("spur-z17-m5.toml")).expect("plan");
    let m = machine();
    let x_in = |d: f64| move_time_s(p.x_safe_mm - (47.5 + 40.0 - d), 50.0, 50.0);
    let pass0 = &p.passes[0];
    assert!(close(pass0.pass_time_s, pass0.cut_time_s + 2.0 * x_in(6.0), 1e-9));
    let drive = m.spindle.drive();
    let ramp = |a: f64, b: f64| (drive.vfd_hz(a) - drive.vfd_hz(b)).abs() / 80.0 * 3.0;
    let y = |d: f64| move_time_s(d, 50.0, 50.0);
    let expected = ramp(0.0, 119.366_197_723_675_8)
        + p.passes.iter().map(|x| x.pass_time_s).sum::<f64>()
        + y(p.passes[1].y_start_mm - p.passes[0].y_end_mm)
        + y(p.passes[2].y_start_mm - p.passes[1].y_end_mm)
        + ramp(p.passes[1].spindle_rpm, p.passes[2].spindle_rpm)
        + y(p.passes[0].y_start_mm - p.passes[2].y_end_mm)
        + ramp(p.passes[2].spindle_rpm, 0.0);
    assert!(
        close(p.total_time_s, expected, 1e-6),
        "{} vs {expected}",
        p.total_time_s
    );
}

#[test]
fn helical_gear_differential_and_swivel() {
    let p = plan_src(&program_src("helical-z31-m3.toml")).expect("plan");
    let d = 360.0 * 20f64.to_radians().sin() / (std::f64::consts::PI * 3.0 * 31.0);
    assert!(close(p.differential_deg_per_mm, d, 1e-12));
    assert!(close(p.helix_lead_mm.expect("helical"), 360.0 / d, 1e-9));
    // Same hands: eta = beta - gamma, in the gear's sense.
    assert!(close(p.hob_swivel_deg, 20.0 - 2.8, 1e-12));
    assert_eq!(p.hob_swivel_sense, Some(Hand::Right));
    assert_eq!(p.signs.feed, hob_gearing::signs::Vertical::Up);
    // Table speed: base rotation and differential add in the frame.
    let pass = &p.passes[0];
    let base = pass.spindle_rpm / 31.0 * 360.0;
    let diff = d * pass.axial_feed_mm_min;
    let s = &p.signs;
    let expected = (s.s_i() * s.spindle.sign() * base + s.s_d() * s.s_f() * diff).abs() / 360.0;
    assert!(close(pass.table_rpm, expected, 1e-12));
    assert!(
        !close(pass.table_rpm, base / 360.0, 1e-3),
        "the differential changes the table speed"
    );
}

#[test]
fn opposite_hands_add_the_lead_angle() {
    let src = program_src("helical-z31-m3.toml").replace("hand = \"right\"\nouts", "hand = \"left\"\nouts");
    let p = plan_src(&src).expect("plan");
    assert!(close(p.hob_swivel_deg, 22.8, 1e-12));
    assert_eq!(p.hob_swivel_sense, Some(Hand::Right));
}

#[test]
fn single_mode_is_one_pass_at_the_entered_depth() {
    let src = program_src("spur-z17-m5.toml").replace("mode = \"automatic\"", "mode = \"single\"");
    let p = plan_src(&src).expect("plan");
    assert_eq!(p.passes.len(), 1);
    assert_eq!(p.passes[0].kind, PassKind::Single);
    assert_eq!(p.passes[0].depth_mm, 5.0);
    assert!(
        close(p.passes[0].cutting_speed_m_min, 30.0, 0.0),
        "rough data by default"
    );
    let src = src.replace(
        "single_depth_mm = 5.0",
        "single_depth_mm = 5.0\nsingle_speeds = \"finish\"",
    );
    let p = plan_src(&src).expect("plan");
    assert!(close(p.passes[0].cutting_speed_m_min, 35.0, 0.0));
}

#[test]
fn equal_rough_depths_without_a_list() {
    let src = program_src("spur-z17-m5.toml")
        .replace("rough_depths_mm = [6.0, 4.75]\n", "")
        .replace("rough_passes = 2", "rough_passes = 3");
    let p = plan_src(&src).expect("plan");
    let depths: Vec<f64> = p.passes.iter().map(|x| x.depth_mm).collect();
    assert!(close(depths[0], 10.75 / 3.0, 1e-12));
    assert!(close(depths[1], 2.0 * 10.75 / 3.0, 1e-12));
    assert_eq!(depths[2], 10.75);
    assert_eq!(depths[3], 11.25);
}

#[test]
fn plunge_cycle_has_no_approach_and_turns_the_table_once_at_depth() {
    let src = program_src("spline-z12-m2-plunge.toml");
    let p = plan_src(&src).expect("plan");
    let pass = &p.passes[0];
    assert_eq!(pass.approach_mm, 0.0);
    assert!(close(pass.y_start_mm, 150.0 - 1.0, 1e-12));
    assert!(close(pass.y_end_mm, 150.0 + 35.0 + 1.0, 1e-12));
    let x_rapid = move_time_s(4.0 - 1.0, 50.0, 50.0);
    let x_out = move_time_s(p.x_safe_mm - pass.x_mm, 50.0, 50.0);
    let plunge = (1.0 + pass.depth_mm) / 20.0 * 60.0;
    let turn = 60.0 / (pass.spindle_rpm / 12.0);
    assert!(close(
        pass.pass_time_s,
        x_rapid + plunge + turn + pass.cut_time_s + x_out,
        1e-9
    ));
}

#[test]
fn tooth_by_tooth_indexes_and_strokes_every_tooth() {
    let p = plan_src(&program_src("tooth-by-tooth-z24-m8.toml")).expect("plan");
    assert_eq!(p.egb_ratio, 0.0);
    assert_eq!(p.index_deg, Some(15.0));
    let pass = &p.passes[0];
    assert_eq!(pass.table_rpm, 0.0, "spur: the table stands still in the stroke");
    assert!(close(pass.axial_feed_mm_min, 1.0 * pass.spindle_rpm, 1e-12));
    let stroke_s = (pass.y_start_mm - pass.y_end_mm) / pass.axial_feed_mm_min * 60.0;
    assert!(close(pass.cut_time_s, 24.0 * stroke_s, 1e-9));
}

#[test]
fn the_issue_sample_program_is_accepted() {
    // The shape the issue promises to accept, literally (crowning and contour superimpose).
    let src = r#"
[workpiece]
teeth = 17
module_mm = 5.0              # normal module
helix_deg = 0.0              # 0 = spur
helix_hand = "right"         # "right" | "left"; ignored for spur
face_width_mm = 40.0
outside_diameter_mm = 95.0
height_above_table_mm = 50.0 # bottom face of the toothed part above the table
allowance_mm = 2.0           # approach and exit allowance on Y
crowning = { height_mm = 0.02 }          # optional; or { radius_mm = ... }
contour = [[0.0, 0.0], [20.0, -0.01], [40.0, 0.0]]  # optional [y_mm, x_offset_mm] points

[tool]
kind = "hob"                 # "hob" | "disk" (disk = profiled cutter for tooth-by-tooth)
module_mm = 5.0
pressure_angle_deg = 20.0
starts = 1
lead_angle_deg = 3.3
hand = "right"
outside_diameter_mm = 80.0
length_mm = 100.0
gashes = 10

[cycle]
kind = "radial-axial"        # "radial-axial" | "radial-plunge" | "tooth-by-tooth"
start = "top"                # "top" | "bottom"
method = "climb"             # "climb" | "conventional"
mode = "automatic"           # "automatic" | "single"
single_depth_mm = 5.0        # used in single mode

[strategy]
total_depth_mm = 11.25
rough_passes = 2
finish_allowance_mm = 0.5
rough_depths_mm = [6.0, 4.75]   # optional: depth of cut of each rough pass, must sum to total - allowance
retract_mm = 5.0
plunge_feed_mm_min = 20.0       # radial-plunge cycle
rough = { cutting_speed_m_min = 30.0, feed_mm_per_rev = 2.0 }
finish = { cutting_speed_m_min = 35.0, feed_mm_per_rev = 1.0 }
"#;
    let p = plan_src(src).expect("plan");
    assert_eq!(p.passes.len(), 3);
    assert!(p.x_shape.x_moves_in_cut);
    assert_eq!(p.x_shape.contour.as_ref().map(Vec::len), Some(3));
}

#[test]
fn refuses_a_spindle_speed_above_the_machine() {
    let mut m = machine();
    m.spindle.max_spindle_rpm = 100.0;
    let err = plan_src_on(&program_src("spur-z17-m5.toml"), &m).unwrap_err();
    let p = &err.problems()[0];
    assert_eq!(p.key, "strategy.rough.cutting_speed_m_min");
    assert!(
        p.message.contains("119.4 spindle rpm") && p.message.contains("spindle.max_spindle_rpm = 100"),
        "{}",
        p.message
    );
}

#[test]
fn refuses_a_table_speed_above_the_machine() {
    let src = program_src("spur-z17-m5.toml").replace("teeth = 17", "teeth = 5");
    let err = plan_src(&src).unwrap_err();
    let p = err
        .problems()
        .iter()
        .find(|p| p.message.contains("table.max_table_rpm"))
        .expect("table refusal");
    assert_eq!(p.key, "strategy.rough.cutting_speed_m_min");
    assert!(p.message.contains("23.87 rpm"), "{}", p.message);
}

#[test]
fn refuses_a_cutting_speed_above_the_machine() {
    let src =
        program_src("spur-z17-m5.toml").replace("cutting_speed_m_min = 35.0", "cutting_speed_m_min = 45.0");
    let keys = refused_keys(&src);
    assert!(
        keys.iter().all(|k| k == "strategy.finish.cutting_speed_m_min"),
        "{keys:?}"
    );
}

#[test]
fn refuses_a_hob_of_another_module() {
    let src = program_src("spur-z17-m5.toml").replace(
        "[tool]\nkind = \"hob\"\nmodule_mm = 5.0",
        "[tool]\nkind = \"hob\"\nmodule_mm = 4.0",
    );
    let err = plan_src(&src).unwrap_err();
    assert_eq!(err.problems()[0].key, "tool.module_mm");
    assert!(
        err.problems()[0].message.contains("workpiece.module_mm = 5"),
        "{err}"
    );
}

#[test]
fn refuses_an_allowance_not_smaller_than_the_depth() {
    let src = program_src("spur-z17-m5.toml")
        .replace("finish_allowance_mm = 0.5", "finish_allowance_mm = 11.25")
        .replace("rough_depths_mm = [6.0, 4.75]\n", "");
    assert_eq!(refused_keys(&src), ["strategy.finish_allowance_mm"]);
}

#[test]
fn refuses_rough_depths_that_do_not_add_up() {
    let src = program_src("spur-z17-m5.toml").replace("[6.0, 4.75]", "[6.0, 4.0]");
    let err = plan_src(&src).unwrap_err();
    assert_eq!(err.problems()[0].key, "strategy.rough_depths_mm");
    assert!(
        err.problems()[0].message.contains("10 mm") && err.problems()[0].message.contains("10.75"),
        "{err}"
    );
    let src = program_src("spur-z17-m5.toml").replace("[6.0, 4.75]", "[6.0, 4.0, 0.75]");
    assert_eq!(refused_keys(&src), ["strategy.rough_depths_mm"]);
}

#[test]
fn refuses_zero_or_negative_teeth() {
    for teeth in ["0", "-3"] {
        let src = program_src("spur-z17-m5.toml").replace("teeth = 17", &format!("teeth = {teeth}"));
        let err = plan_src(&src).unwrap_err();
        let p = &err.problems()[0];
        assert_eq!(p.key, "workpiece.teeth");
        let line = src.lines().position(|l| l.starts_with("teeth =")).expect("teeth") + 1;
        assert_eq!(p.position.map(|p| p.line), Some(line), "{err}");
    }
}

#[test]
fn refuses_unknown_keys() {
    let src = program_src("spur-z17-m5.toml").replace("teeth = 17", "teeth = 17\nteth = 17");
    let text = plan_src(&src).unwrap_err().to_string();
    let line = src.lines().position(|l| l.starts_with("teth")).expect("teth") + 1;
    assert!(
        text.contains("unknown field `teth`") && text.contains(&format!("program.toml:{line}:")),
        "{text}"
    );
}

#[test]
fn refuses_a_tool_outside_the_machine_range() {
    let src =
        program_src("spur-z17-m5.toml").replace("outside_diameter_mm = 80.0", "outside_diameter_mm = 100.0");
    assert_eq!(refused_keys(&src), ["tool.outside_diameter_mm"]);
}

#[test]
fn refuses_a_stroke_beyond_the_y_travel() {
    let src = program_src("spur-z17-m5.toml")
        .replace("height_above_table_mm = 50.0", "height_above_table_mm = 400.0");
    let keys = refused_keys(&src);
    assert!(
        keys.iter().all(|k| k == "workpiece.height_above_table_mm") && !keys.is_empty(),
        "{keys:?}"
    );
}

#[test]
fn refuses_mismatched_tool_and_cycle() {
    let src = program_src("spur-z17-m5.toml").replace("kind = \"radial-axial\"", "kind = \"tooth-by-tooth\"");
    assert_eq!(refused_keys(&src), ["cycle.kind"]);
    let src = program_src("tooth-by-tooth-z24-m8.toml")
        .replace("kind = \"tooth-by-tooth\"", "kind = \"radial-axial\"");
    assert_eq!(refused_keys(&src), ["tool.kind"]);
}

#[test]
fn refuses_a_plunge_cycle_without_a_plunge_feed() {
    let src = program_src("spline-z12-m2-plunge.toml").replace("plunge_feed_mm_min = 20.0\n", "");
    assert_eq!(refused_keys(&src), ["strategy.plunge_feed_mm_min"]);
}

#[test]
fn refuses_a_single_depth_beyond_the_total() {
    let src = program_src("spur-z17-m5.toml")
        .replace("mode = \"automatic\"", "mode = \"single\"")
        .replace("single_depth_mm = 5.0", "single_depth_mm = 12.0");
    assert_eq!(refused_keys(&src), ["cycle.single_depth_mm"]);
}

#[test]
fn refuses_a_bad_contour_point_by_index() {
    let src = program_src("spur-z17-m5.toml").replace(
        "crowning = { height_mm = 0.02 }",
        "contour = [[0.0, 0.0], [20.0, -0.01], [15.0, 0.0]]",
    );
    let err = plan_src(&src).unwrap_err();
    assert_eq!(err.problems()[0].key, "workpiece.contour[2]");
    assert!(err.problems()[0].position.is_some());
}

#[test]
fn refuses_crowning_given_twice() {
    let src = program_src("spur-z17-m5.toml").replace(
        "{ height_mm = 0.02 }",
        "{ height_mm = 0.02, radius_mm = 10000.0 }",
    );
    assert_eq!(refused_keys(&src), ["workpiece.crowning"]);
}

#[test]
fn every_example_program_plans() {
    let m = machine();
    for entry in std::fs::read_dir(root().join("config/programs")).expect("programs") {
        let path = entry.expect("entry").path();
        let plan = plan_source(&path, &std::fs::read_to_string(&path).expect("read"), &m)
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(
            !plan.passes.is_empty() && plan.total_time_s > 0.0,
            "{}",
            path.display()
        );
    }
}

proptest! {
    #[test]
    fn pass_depths_increase_and_end_at_the_total(
        total in 0.5f64..20.0, allowance_share in 0.0f64..0.5, n in 1i64..6,
        weights in proptest::collection::vec(0.1f64..1.0, 6), listed in any::<bool>(),
    ) {
        let allowance = total * allowance_share;
        let rough_total = total - allowance;
        let list = if listed {
            let w = &weights[..n as usize];
            let sum: f64 = w.iter().sum();
            format!("rough_depths_mm = [{}]\n", w.iter().map(|x| format!("{:?}", x / sum * rough_total)).collect::<Vec<_>>().join(", "))
        } else {
            String::new()
        };
        let src = program_src("spur-z17-m5.toml")
            .replace("total_depth_mm = 11.25", &format!("total_depth_mm = {total:?}"))
            .replace("finish_allowance_mm = 0.5", &format!("finish_allowance_mm = {allowance:?}"))
            .replace("rough_passes = 2", &format!("rough_passes = {n}"))
            .replace("rough_depths_mm = [6.0, 4.75]\n", &list)
            .replace("single_depth_mm = 5.0\n", "");
        let p = plan_src(&src).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let depths: Vec<f64> = p.passes.iter().map(|x| x.depth_mm).collect();
        prop_assert!(depths.windows(2).all(|w| w[1] > w[0]), "{depths:?}");
        prop_assert_eq!(*depths.last().unwrap(), total);
        let rough = p.passes.iter().filter(|x| x.kind == PassKind::Rough).count();
        prop_assert_eq!(rough, n as usize);
        for pass in &p.passes {
            prop_assert!((pass.x_mm - (87.5 - pass.depth_mm)).abs() < 1e-12);
        }
    }

    #[test]
    fn y_stroke_covers_the_face_from_the_chosen_side(
        height in 35.0f64..300.0, face in 5.0f64..100.0, top in any::<bool>(),
    ) {
        let src = program_src("spur-z17-m5.toml")
            .replace("height_above_table_mm = 50.0", &format!("height_above_table_mm = {height:?}"))
            .replace("face_width_mm = 40.0", &format!("face_width_mm = {face:?}"))
            .replace("start = \"top\"", if top { "start = \"top\"" } else { "start = \"bottom\"" });
        let p = plan_src(&src).map_err(|e| TestCaseError::fail(e.to_string()))?;
        for pass in &p.passes {
            let (lo, hi) = if top { (pass.y_end_mm, pass.y_start_mm) } else { (pass.y_start_mm, pass.y_end_mm) };
            prop_assert!(lo <= height - 2.0 + 1e-9 && hi >= height + face + 2.0 - 1e-9);
            prop_assert_eq!(pass.y_start_mm > pass.y_end_mm, top);
        }
    }
}

/// The example tooth-by-tooth program's cutter (`[tool.disk]`, designed by `hob cutter
/// design`): its profile 10.79 um from the involute, 57 % of grade 7's f_falpha; refused at
/// grade 4 (6.65 um) with the figure; a cutter for another gear refused; without a mass no
/// dynamics; near resonance a warning.
#[test]
fn a_disk_cutters_profile_is_judged_against_the_gear_and_the_grade() {
    let src = program_src("tooth-by-tooth-z24-m8.toml");
    let p = plan_src(&src).expect("plan");
    let c = p.cutter.as_ref().expect("a disk cutter with a profile");
    assert!(close(c.profile_deviation_um, 10.79, 0.05), "{c:?}");
    assert_eq!(c.grade, Some(7));
    assert!(close(c.profile_form_tolerance_um.unwrap(), 18.8, 1e-9));
    // Seed 003's link for 24 mm, 80 mm, 10 kg: C = 3 x 2.1e5 x 24^3 / 40^2 = 5.443e6 N/mm,
    // f = 1 / (2 pi sqrt(10 / 5.443e9)) = 3713 Hz; the teeth pass at 12 x rpm / 60.
    assert!(close(c.natural_frequency_hz.unwrap(), 3713.2, 0.1), "{c:?}");
    assert_eq!(c.tooth_passing_hz.len(), p.passes.len());
    assert!(close(
        c.tooth_passing_hz[0],
        12.0 * p.passes[0].spindle_rpm / 60.0,
        1e-9
    ));
    assert!(!p.warnings.iter().any(|w| w.contains("resonance")));

    let err = plan_src(&src.replace("grade = 7 ", "grade = 4 "))
        .expect_err("grade 4")
        .to_string();
    assert!(
        err.contains("tool.disk.profile")
            && err.contains("10.8 um")
            && err.contains("f_falpha 6.65 um of grade 4"),
        "{err}"
    );
    // The same cutter on a z 40 gear of the same module.
    let keys = refused_keys(
        &src.replace("teeth = 24", "teeth = 40")
            .replace("outside_diameter_mm = 208.0", "outside_diameter_mm = 336.0"),
    );
    assert_eq!(keys, ["tool.disk.profile"]);
    // No mass: no dynamics.
    let p = plan_src(&src.replace("mass_kg = 10.0 ", "# mass_kg ")).expect("plan");
    assert_eq!(p.cutter.as_ref().unwrap().natural_frequency_hz, None);
    // A soft, heavy cutter (E 1e4 MPa, 10 t: C = 259 200 N/mm, 25.6 Hz): the finishing
    // pass's 23.9 Hz is near it (0.93), the roughing passes' 19.9 Hz not (0.78).
    let soft = src.replace("mass_kg = 10.0 ", "mass_kg = 10000.0\nyoungs_modulus_mpa = 1e4 ");
    let p = plan_src(&soft).expect("plan");
    let near: Vec<&String> = p
        .warnings
        .iter()
        .filter(|w| w.contains("near resonance"))
        .collect();
    assert_eq!(near.len(), 1, "{:?}", p.warnings);
    assert!(near[0].starts_with("pass 3:"), "{near:?}");
    // A profile wider than the cutter: refused with both widths.
    let err = plan_src(&src.replace("length_mm = 24.0", "length_mm = 20.0"))
        .expect_err("narrow")
        .to_string();
    assert!(
        err.contains("spans 21.464 mm across the cutter, wider than tool.length_mm = 20"),
        "{err}"
    );
}

/// The cutter's body under its peak side load (seed 003's beam, `2 b^2 [sigma]`): the
/// example's 24 mm cutter takes 2 x 24^2 x 400 = 460 800 N, far above its passes; at 10 MPa
/// (11 520 N) a rough feed of 4 mm/rev overloads it in the full-depth pass only (chip 0.333
/// mm x 18.62 mm: 2600 x 18.62 x 0.333^0.74 = 21.5 kN) and is refused by the feed's key,
/// with the load and the limit; at the example's 1 mm/rev (7.7 kN) it is not.
#[test]
fn a_pass_that_overloads_the_disk_cutter_is_refused_with_the_limit() {
    let src = program_src("tooth-by-tooth-z24-m8.toml");
    let p = plan_src(&src).expect("plan");
    let c = p.cutter.as_ref().expect("cutter");
    assert_eq!(c.passes.len(), 3);
    for cp in &c.passes {
        assert!(close(cp.load_limit_n.unwrap(), 460_800.0, 1e-6), "{cp:?}");
        assert!(cp.peak_load_n > 3000.0 && cp.peak_load_n < 8000.0, "{cp:?}");
    }
    let weak = src.replace("mass_kg = 10.0 ", "mass_kg = 10.0\nallowable_bending_mpa = 10.0 ");
    let p = plan_src(&weak).expect("the example's feed is within 11 520 N");
    assert!(close(
        p.cutter.unwrap().passes[0].load_limit_n.unwrap(),
        11_520.0,
        1e-6
    ));
    let fast = weak.replace("feed_mm_per_rev = 1.0 }", "feed_mm_per_rev = 4.0 }");
    assert_ne!(fast, weak);
    assert_eq!(refused_keys(&fast), ["strategy.rough.feed_mm_per_rev"]);
    let err = plan_src(&fast).expect_err("overload").to_string();
    assert!(
        err.contains("pass 2: the disk cutter's predicted peak side load 21")
            && err.contains("its body takes 11520 N at tool.disk.allowable_bending_mpa = 10 MPa"),
        "{err}"
    );
    assert_eq!(
        refused_keys(&weak.replace("allowable_bending_mpa = 10.0", "allowable_bending_mpa = 0.0")),
        ["tool.disk.allowable_bending_mpa"]
    );
    // A single pass at the finishing speeds is refused by the feed it runs at.
    let single = weak
        .replace(
            "mode = \"automatic\"",
            "mode = \"single\"\nsingle_speeds = \"finish\"\nsingle_depth_mm = 18.0",
        )
        .replace("feed_mm_per_rev = 0.5 }", "feed_mm_per_rev = 4.0 }");
    assert_ne!(single, weak);
    assert_eq!(refused_keys(&single), ["strategy.finish.feed_mm_per_rev"]);
}
