use super::*;
use crate::test_dir;

fn sample() -> MachineState {
    MachineState {
        format_version: FORMAT_VERSION,
        x_offset_mm: 0.125,
        y_offset_mm: -3.5,
        set_at_utc: "2025-03-01T08:15:00Z".into(),
        gauge_diameter_mm: Some(40.0),
        gauge_height_mm: Some(100.0),
        note: Some("mandrel 40 h6".into()),
    }
}

#[test]
fn a_missing_file_is_no_calibration_yet() {
    let dir = test_dir("state-missing");
    assert_eq!(
        load(&dir.join("machine-state.toml")).expect("not an error"),
        Loaded::NotCalibrated
    );
}

#[test]
fn a_saved_state_loads_the_same() {
    let dir = test_dir("state-roundtrip");
    let path = dir.join("machine-state.toml");
    sample().save(&path).expect("saved");
    assert_eq!(load(&path).expect("loads"), Loaded::Calibrated(sample()));
    let mut second = sample();
    second.x_offset_mm = 0.25;
    second.note = None;
    second.save(&path).expect("replaced");
    assert_eq!(load(&path).expect("loads"), Loaded::Calibrated(second));
}

/// Seconds since the Unix epoch of the system clock, the clock `crate::utc::now` reads.
fn unix_now_s() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("the system clock is after 1970")
        .as_secs()
}

/// A `YYYY-MM-DDTHH:MM:SSZ` stamp back to Unix seconds, computed here on its own (days
/// from the civil date, H. Hinnant), not by the code under test.
fn stamp_unix_s(stamp: &str) -> u64 {
    let n = |r: std::ops::Range<usize>| -> i64 {
        stamp
            .get(r.clone())
            .and_then(|t| t.parse().ok())
            .unwrap_or_else(|| panic!("{stamp:?}: no number at {r:?}"))
    };
    let (y, m, d) = (n(0..4), n(5..7), n(8..10));
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    let days = era * 146_097 + doe - 719_468;
    let s = days * 86_400 + n(11..13) * 3600 + n(14..16) * 60 + n(17..19);
    u64::try_from(s).expect("after 1970")
}

#[test]
fn the_stamp_reader_here_agrees_with_known_instants() {
    // `date -u -d @...`: the checks below rest on this reading.
    for (stamp, s) in [
        ("1970-01-01T00:00:00Z", 0),
        ("2000-02-29T00:00:00Z", 951_782_400),
        ("2024-12-31T23:59:59Z", 1_735_689_599),
        ("2025-03-01T08:15:00Z", 1_740_816_900),
    ] {
        assert_eq!(stamp_unix_s(stamp), s, "{stamp}");
    }
}

#[test]
fn a_new_state_is_stamped_now_and_valid() {
    let before = unix_now_s();
    let s = MachineState::new(1.0, 2.0, Some(40.0), Some(100.0));
    let after = unix_now_s();
    // Now: within the second the call began and the one it ended (the stamp is whole
    // seconds of the system clock, UTC).
    assert!(crate::utc::is_timestamp(&s.set_at_utc), "{:?}", s.set_at_utc);
    let stamped = stamp_unix_s(&s.set_at_utc);
    assert!(
        (before..=after).contains(&stamped),
        "stamped {:?} ({stamped} s), not now: the call ran from {} to {} ({before} to {after} s)",
        s.set_at_utc,
        crate::utc::from_unix_s(before),
        crate::utc::from_unix_s(after)
    );
    // The values given, nothing else.
    assert_eq!(
        s,
        MachineState {
            format_version: FORMAT_VERSION,
            x_offset_mm: 1.0,
            y_offset_mm: 2.0,
            set_at_utc: s.set_at_utc.clone(),
            gauge_diameter_mm: Some(40.0),
            gauge_height_mm: Some(100.0),
            note: None,
        }
    );
    // Valid: no problem, and it saves and loads as it is.
    let mut p = Problems::new();
    s.validate(&mut p);
    assert!(p.is_empty(), "{:?}", p.as_slice());
    let path = test_dir("state-new").join("machine-state.toml");
    s.save(&path).expect("saved");
    assert_eq!(load(&path).expect("loads"), Loaded::Calibrated(s));
}

#[test]
fn one_axis_touched_off_is_a_whole_state_and_saves() {
    // The first touch-off of a set-up is one axis: the other has no gauge yet.
    let dir = test_dir("state-one-axis");
    let path = dir.join("machine-state.toml");
    let x_only = MachineState::new(0.4, 0.0, Some(100.0), None);
    x_only.save(&path).expect("saved");
    assert!(
        !std::fs::read_to_string(&path)
            .expect("read")
            .contains("gauge_height_mm")
    );
    assert_eq!(load(&path).expect("loads"), Loaded::Calibrated(x_only));
    // A gauge of height 0 is the table face itself.
    let face = MachineState::new(0.4, -1.0, Some(100.0), Some(0.0));
    face.save(&path).expect("saved");
    assert_eq!(load(&path).expect("loads"), Loaded::Calibrated(face));
    let mut below = MachineState::new(0.4, -1.0, Some(100.0), Some(-0.1));
    assert_eq!(problem_keys(&below), ["gauge_height_mm"]);
    below.gauge_height_mm = Some(f64::NAN);
    assert_eq!(problem_keys(&below), ["gauge_height_mm"]);
}

fn problem_keys(state: &MachineState) -> Vec<String> {
    let mut p = Problems::new();
    state.validate(&mut p);
    p.as_slice().iter().map(|x| x.key.clone()).collect()
}

#[test]
fn bad_values_are_named_by_key() {
    let mut s = sample();
    s.x_offset_mm = 50.5;
    s.y_offset_mm = f64::NAN;
    s.gauge_diameter_mm = Some(0.0);
    s.gauge_height_mm = Some(2000.0);
    s.set_at_utc = "yesterday".into();
    s.format_version = 2;
    assert_eq!(
        problem_keys(&s),
        [
            "format_version",
            "x_offset_mm",
            "y_offset_mm",
            "gauge_diameter_mm",
            "gauge_height_mm",
            "set_at_utc"
        ]
    );
    let mut edge = sample();
    edge.x_offset_mm = -MAX_OFFSET_MM;
    edge.y_offset_mm = MAX_OFFSET_MM;
    assert!(problem_keys(&edge).is_empty());
}

#[test]
fn an_invalid_state_is_not_saved_and_the_old_one_stays() {
    let dir = test_dir("state-invalid");
    let path = dir.join("machine-state.toml");
    sample().save(&path).expect("saved");
    let mut bad = sample();
    bad.y_offset_mm = f64::INFINITY;
    let e = bad.save(&path).expect_err("refused");
    assert!(e.to_string().contains("y_offset_mm"), "{e}");
    assert_eq!(load(&path).expect("loads"), Loaded::Calibrated(sample()));
}

#[test]
fn a_file_with_a_bad_value_is_refused_with_key_and_line() {
    let dir = test_dir("state-bad-file");
    let path = dir.join("machine-state.toml");
    let text = sample()
        .to_toml()
        .replace("x_offset_mm = 0.125", "x_offset_mm = 51.0");
    std::fs::write(&path, &text).expect("write");
    let line = text
        .lines()
        .position(|l| l.starts_with("x_offset_mm"))
        .expect("key")
        + 1;
    let e = load(&path).expect_err("refused").to_string();
    assert!(
        e.contains(&format!(
            "machine-state.toml:{line}:1: x_offset_mm: must be within -50 .. 50 mm (is 51)"
        )),
        "{e}"
    );
    std::fs::write(&path, text.replace("note", "notes")).expect("write");
    let e = load(&path).expect_err("refused").to_string();
    assert!(e.contains("unknown field `notes`"), "{e}");
}
