use super::*;
use crate::test_dir;

fn sample() -> StoredCompensation {
    StoredCompensation {
        format_version: FORMAT_VERSION,
        worm_set: "B-2019-07".into(),
        gear: "Helical z41 m2 beta 15 LH".into(),
        teeth: 4,
        measured_at: "2026-11-29T12:00:00Z".into(),
        computed_at_utc: "2026-11-29T13:05:00Z".into(),
        measurements: vec!["low.csv".into(), "high.csv".into()],
        log_dir: "/var/log/hob/2026-11-29".into(),
        first_table_deg: 0.0,
        table_offsets_arcsec: vec![1.25, -0.5, 0.1 + 0.2, -1e-17],
        hob_cos_arcsec: 0.3,
        hob_sin_arcsec: -0.125,
        hob_identified: HobIdentified::Full,
        tooth_phase_deg: 12.345678901234567,
        removable_single_pitch_um: 3.5,
        removable_cumulative_pitch_um: 6.25,
        residual_single_pitch_um: 0.5,
        residual_cumulative_pitch_um: 0.75,
    }
}

fn problem_keys(s: &StoredCompensation) -> Vec<String> {
    let mut p = Problems::new();
    s.validate(&mut p);
    p.as_slice().iter().map(|x| x.key.clone()).collect()
}

#[test]
fn a_saved_compensation_loads_the_same_to_the_bit() {
    let dir = test_dir("comp-round-trip");
    let state = dir.join("machine-state.toml");
    assert_eq!(
        load_for(&state, "B-2019-07").unwrap(),
        None,
        "none before the first save"
    );
    let s = sample();
    assert_eq!(s.save(&state).unwrap(), None, "nothing to keep the first time");
    assert_eq!(
        s.path(&state),
        dir.join("pitch-compensation").join("B-2019-07.toml")
    );
    let back = load_for(&state, "B-2019-07").unwrap().unwrap();
    assert_eq!(back, s);
    for (a, b) in back.table_offsets_arcsec.iter().zip(&s.table_offsets_arcsec) {
        assert_eq!(a.to_bits(), b.to_bits());
    }
    let text = std::fs::read_to_string(s.path(&state)).unwrap();
    assert!(text.contains("hob_identified = \"full\""), "{text}");
}

/// A change that breaks one rule.
type Breaker = fn(&mut StoredCompensation);

#[test]
fn each_bad_value_is_named_by_key() {
    let cases: [(&str, Breaker); 14] = [
        ("format_version", |s| s.format_version = 2),
        ("worm_set", |s| s.worm_set = String::new()),
        ("gear", |s| s.gear = " ".into()),
        ("measured_at", |s| s.measured_at = String::new()),
        ("log_dir", |s| s.log_dir = String::new()),
        ("measurements", |s| s.measurements.clear()),
        ("computed_at_utc", |s| s.computed_at_utc = "today".into()),
        ("teeth", |s| {
            s.teeth = 2;
            s.table_offsets_arcsec.truncate(2);
        }),
        ("table_offsets_arcsec", |s| s.table_offsets_arcsec.push(0.0)),
        ("table_offsets_arcsec", |s| s.table_offsets_arcsec[2] = 72.5),
        ("table_offsets_arcsec", |s| s.table_offsets_arcsec[1] = f64::NAN),
        ("hob_cos_arcsec", |s| s.hob_cos_arcsec = 80.0),
        ("hob_identified", |s| s.hob_identified = HobIdentified::None),
        ("tooth_phase_deg", |s| s.tooth_phase_deg = 90.5),
    ];
    for (key, break_it) in cases {
        let mut s = sample();
        break_it(&mut s);
        assert_eq!(problem_keys(&s), [key], "{key}");
    }
    let mut many = sample();
    many.teeth = 513;
    many.table_offsets_arcsec = vec![0.0; 513];
    many.tooth_phase_deg = 0.5;
    assert_eq!(problem_keys(&many), ["teeth"]);
    many.teeth = 512;
    many.table_offsets_arcsec.pop();
    many.table_offsets_arcsec[7] = -72.0;
    assert!(problem_keys(&many).is_empty());
    let mut other = sample();
    other.removable_cumulative_pitch_um = -1.0;
    other.hob_sin_arcsec = f64::INFINITY;
    assert_eq!(
        problem_keys(&other),
        ["hob_sin_arcsec", "removable_cumulative_pitch_um"]
    );
}

#[test]
fn an_invalid_compensation_is_not_saved_and_a_bad_file_is_refused_with_its_line() {
    let dir = test_dir("comp-invalid");
    let state = dir.join("machine-state.toml");
    sample().save(&state).unwrap();
    let mut bad = sample();
    bad.table_offsets_arcsec[0] = 100.0;
    let e = bad.save(&state).unwrap_err().to_string();
    assert!(e.contains("table_offsets_arcsec"), "{e}");
    assert_eq!(load_for(&state, "B-2019-07").unwrap(), Some(sample()));
    let path = sample().path(&state);
    let text = sample().to_toml().replace("teeth = 4", "teeth = 5");
    std::fs::write(&path, &text).unwrap();
    let e = load_for(&state, "B-2019-07").unwrap_err().to_string();
    assert!(e.contains("B-2019-07.toml"), "{e}");
    assert!(
        e.contains("table_offsets_arcsec: must have one offset per tooth, 5 (has 4)"),
        "{e}"
    );
    let text = sample().to_toml().replace("\"full\"", "\"half\"");
    std::fs::write(&path, &text).unwrap();
    let line = text
        .lines()
        .position(|l| l.starts_with("hob_identified"))
        .unwrap()
        + 1;
    let e = load_for(&state, "B-2019-07").unwrap_err().to_string();
    assert!(
        e.contains(&format!("B-2019-07.toml:{line}:")) && e.contains("`half`"),
        "{e}"
    );
}

#[test]
fn another_worm_set_s_file_is_refused_naming_both() {
    let dir = test_dir("comp-other-set");
    let state = dir.join("machine-state.toml");
    // "B 2019/07" and "B_2019_07" share a file name; the file says whose it is.
    let mut s = sample();
    s.worm_set = "B 2019/07".into();
    s.save(&state).unwrap();
    assert_eq!(s.path(&state), dir.join("pitch-compensation/B_2019_07.toml"));
    let e = load_for(&state, "B_2019_07").unwrap_err();
    assert!(matches!(e, LoadError::OtherWormSet { .. }), "{e}");
    let e = e.to_string();
    assert!(e.contains("\"B 2019/07\"") && e.contains("\"B_2019_07\""), "{e}");
    assert_eq!(load_for(&state, "B 2019/07").unwrap(), Some(s));
    assert_eq!(file_stem(".hidden"), "_hidden");
}

#[test]
fn a_new_compensation_keeps_the_old_one_beside_it() {
    let dir = test_dir("comp-kept");
    let state = dir.join("machine-state.toml");
    let old = sample();
    old.save(&state).unwrap();
    let old_text = std::fs::read_to_string(old.path(&state)).unwrap();
    let mut new = sample();
    new.table_offsets_arcsec[0] = -2.0;
    let kept = new.save(&state).unwrap().expect("the old one kept");
    let name = kept.file_name().unwrap().to_string_lossy().into_owned();
    assert!(
        name.starts_with("B-2019-07.2") && name.ends_with("Z.toml"),
        "{name}"
    );
    assert_eq!(std::fs::read_to_string(&kept).unwrap(), old_text);
    assert_eq!(load_for(&state, "B-2019-07").unwrap(), Some(new.clone()));
    // Within the same second the next keeps its own name.
    let again = new.save(&state).unwrap().unwrap();
    assert_ne!(again, kept);
    assert!(kept.exists() && again.exists());
}

#[test]
fn a_crash_while_saving_leaves_the_previous_compensation() {
    // A crash before write_atomic's rename leaves its hidden temporary file, half
    // written: the stored file is the previous one whole, and the next save goes through.
    let dir = test_dir("comp-crash");
    let state = dir.join("machine-state.toml");
    sample().save(&state).unwrap();
    let path = sample().path(&state);
    let tmp = path.with_file_name(".B-2019-07.toml.tmp.999999.0");
    let half = sample().to_toml();
    std::fs::write(&tmp, &half.as_bytes()[..half.len() / 2]).unwrap();
    assert!(crate::atomic::is_temporary(".B-2019-07.toml.tmp.999999.0"));
    assert_eq!(load_for(&state, "B-2019-07").unwrap(), Some(sample()));
    let mut new = sample();
    new.hob_cos_arcsec = 0.0;
    new.save(&state).unwrap();
    assert_eq!(load_for(&state, "B-2019-07").unwrap(), Some(new));
}
