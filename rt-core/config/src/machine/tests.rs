use super::*;
use crate::parse_toml;
use std::path::PathBuf;

fn shipped_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/machine.toml")
}

/// The shipped file with `from` replaced by `to`; `from` must be there (else the test
/// would check the shipped file unchanged, and nothing).
fn shipped_with(edits: &[(&str, &str)]) -> String {
    let mut s = shipped_src();
    for (from, to) in edits {
        assert!(
            s.contains(from),
            "{from:?} is not in config/machine.toml: the file changed, the test would check nothing"
        );
        s = s.replace(from, to);
    }
    s
}

fn shipped_src() -> String {
    std::fs::read_to_string(shipped_path()).expect("shipped machine.toml")
}

/// Loads `src` with its validation, as `hob_store::files::load_machine` does.
fn load_src(src: &str) -> Result<MachineConfig, LoadError> {
    let file = Path::new("machine.toml");
    let config: MachineConfig = parse_toml(file, src)?;
    let mut p = Problems::new();
    config.validate(&mut p);
    p.into_result(file, src)?;
    Ok(config)
}

#[test]
fn the_shipped_configuration_is_the_thesis_machine() {
    let m = MachineConfig::parse(
        &shipped_path(),
        &std::fs::read_to_string(shipped_path()).expect("read"),
    )
    .map_err(|e| e.to_string())
    .expect("valid");
    assert_eq!(m.spindle.encoder_counts_per_rev, 10_000);
    assert!((m.y.counts_per_mm() - 3000.0).abs() < 1e-12);
    assert!((m.x.counts_per_mm() - 3000.0).abs() < 1e-12);
    // 2^20 counts per motor turn through the 75:1 worm: 78 643 200 per table revolution,
    // 0.0165 arcsec per count.
    assert!((m.table.counts_per_deg() * 360.0 - 78_643_200.0).abs() < 1e-6);
    assert!((3600.0 / m.table.counts_per_deg() - 0.016_479_5).abs() < 1e-6);
}

#[test]
fn thesis_servo_motor_speeds() {
    let m = MachineConfig::parse(
        &shipped_path(),
        &std::fs::read_to_string(shipped_path()).expect("read"),
    )
    .map_err(|e| e.to_string())
    .expect("valid");
    // Table at 14.1 rpm needs 1057.5 motor rpm (thesis eq. 4.16).
    assert!((m.table.max_table_rpm * m.table.worm_ratio - 1057.5).abs() < 1e-9);
    // X/Y rapid 3 m/min: screw 300 rpm, motor 900 rpm (thesis eq. 4.5).
    assert!((m.y.motor_rpm(m.y.rapid_mm_min) - 900.0).abs() < 1e-9);
    assert!((m.x.motor_rpm(m.x.rapid_mm_min) - 900.0).abs() < 1e-9);
}

#[test]
fn a_bad_value_is_named_with_its_position() {
    let src = shipped_with(&[("max_table_rpm = 14.1", "max_table_rpm = 80.0")]);
    let err = load_src(&src).unwrap_err();
    let p = &err.problems()[0];
    assert_eq!(p.key, "table.max_table_rpm");
    assert!(p.message.contains("6000.0 motor rpm"), "{}", p.message);
    let line = src.lines().position(|l| l.starts_with("max_table_rpm")).unwrap() + 1;
    assert_eq!(p.position.map(|p| p.line), Some(line));
    assert!(
        err.to_string()
            .contains(&format!("machine.toml:{line}:1: table.max_table_rpm")),
        "{err}"
    );
}

/// The table's 2^20 counts per motor turn at 4000 rpm is 69.9 M counts/s; 2^26 would be
/// 4.5 G, beyond the drive's 32-bit velocity: refused by the unit's key.
#[test]
fn a_position_unit_whose_velocity_overflows_the_pdo_is_refused() {
    let src = shipped_with(&[(
        "encoder_counts_per_motor_rev = 1048576",
        "encoder_counts_per_motor_rev = 67108864",
    )]);
    let err = load_src(&src).unwrap_err();
    let keys: Vec<&str> = err.problems().iter().map(|p| p.key.as_str()).collect();
    assert_eq!(keys, ["table.encoder_counts_per_motor_rev"], "{err}");
    assert!(err.to_string().contains("4473924267 counts/s"), "{err}");
}

#[test]
fn all_problems_are_reported_at_once() {
    let src = shipped_with(&[
        (
            "screw_lead_mm = 10.0\nmotor_max_rpm = 4000.0\nsoft_limit_min_mm = 25.0",
            "screw_lead_mm = -1.0\nmotor_max_rpm = 4000.0\nsoft_limit_min_mm = 25.0",
        ),
        ("interval_travel_m = 5.0", "interval_travel_m = 0.0"),
    ]);
    let err = load_src(&src).unwrap_err();
    let keys: Vec<&str> = err.problems().iter().map(|p| p.key.as_str()).collect();
    assert!(keys.contains(&"x.screw_lead_mm"), "{keys:?}");
    assert!(keys.contains(&"lube.interval_travel_m"), "{keys:?}");
}

#[test]
fn unknown_keys_are_refused_with_position() {
    let src = shipped_with(&[("worm_ratio = 75.0", "worm_ratio = 75.0\nworm_raito = 75.0")]);
    let err = load_src(&src).unwrap_err();
    let text = err.to_string();
    assert!(text.contains("unknown field `worm_raito`"), "{text}");
    let line = src.lines().position(|l| l.starts_with("worm_raito")).unwrap() + 1;
    assert!(text.contains(&format!("machine.toml:{line}:")), "{text}");
}

#[test]
fn a_missing_key_is_refused() {
    let src = shipped_with(&[("pressure_timeout_s = 10.0\n", "")]);
    let text = load_src(&src).unwrap_err().to_string();
    assert!(text.contains("missing field `pressure_timeout_s`"), "{text}");
}

#[test]
fn two_signals_on_one_bit_are_refused() {
    let src = shipped_with(&[("coolant_pump = { bit = 3,", "coolant_pump = { bit = 2,")]);
    let err = load_src(&src).unwrap_err();
    let p = &err.problems()[0];
    assert_eq!(p.key, "io.outputs.coolant_pump.bit");
    assert!(p.message.contains("io.outputs.lube_pump"), "{}", p.message);
}

#[test]
fn a_bit_beyond_the_coupler_is_refused() {
    let src = shipped_with(&[("feed_hold_button = { bit = 19,", "feed_hold_button = { bit = 24,")]);
    let err = load_src(&src).unwrap_err();
    assert_eq!(err.problems()[0].key, "io.inputs.feed_hold_button.bit");
}

#[test]
fn duplicate_node_ids_are_refused() {
    let src = shipped_with(&[("[io]\ncan_node_id = 5", "[io]\ncan_node_id = 3")]);
    let err = load_src(&src).unwrap_err();
    let p = &err.problems()[0];
    assert_eq!(p.key, "io.can_node_id");
    assert!(p.message.contains("x.can_node_id"), "{}", p.message);
}

#[test]
fn polarity_must_be_a_named_value() {
    let src = shipped_with(&[("encoder_polarity = \"normal\"", "encoder_polarity = \"+\"")]);
    let text = load_src(&src).unwrap_err().to_string();
    assert!(text.contains("normal") && text.contains("inverted"), "{text}");
}

#[test]
fn an_idle_latency_request_longer_than_a_quarter_cycle_is_refused() {
    let src = shipped_with(&[("cpu_dma_latency_us = 0", "cpu_dma_latency_us = 300")]);
    let err = load_src(&src).unwrap_err();
    let p = &err.problems()[0];
    assert_eq!(p.key, "service.cpu_dma_latency_us");
    assert!(p.message.contains("250"), "{}", p.message);
    let src = shipped_with(&[("cpu_dma_latency_us = 0", "cpu_dma_latency_us = 250")]);
    assert_eq!(load_src(&src).unwrap().service.cpu_dma_latency_us, 250);
}

#[test]
fn library_and_state_paths_must_be_absolute_and_not_empty() {
    let src = shipped_with(&[
        ("dir = \"/var/lib/hob/library\"", "dir = \"lib\""),
        ("file = \"/var/lib/hob/machine-state.toml\"", "file = \" \""),
    ]);
    let e = load_src(&src).expect_err("refused");
    let keys: Vec<&str> = e.problems().iter().map(|p| p.key.as_str()).collect();
    assert_eq!(keys, ["library.dir", "state.file"], "{e}");
    let text = e.to_string();
    assert!(text.contains("library.dir: must be an absolute path"), "{text}");
    assert!(text.contains("state.file: must not be empty"), "{text}");
}

#[test]
fn a_signal_is_read_and_written_with_its_polarity() {
    let high = DigitalBinding {
        bit: 5,
        active: Active::High,
    };
    let low = DigitalBinding {
        bit: 5,
        active: Active::Low,
    };
    assert!(high.is_active(1 << 5) && !high.is_active(!(1 << 5)));
    assert!(!low.is_active(1 << 5) && low.is_active(0));
    for b in [high, low] {
        for on in [true, false] {
            let mut raw = 0xA5A5_A5A5u32;
            b.set(&mut raw, on);
            assert_eq!(b.is_active(raw), on);
            // Only its own bit changed.
            assert_eq!(raw & !(1 << 5), 0xA5A5_A5A5 & !(1 << 5));
        }
    }
    // A bit beyond the image is never active-high and never panics.
    let far = DigitalBinding {
        bit: 40,
        active: Active::High,
    };
    assert!(!far.is_active(u32::MAX));
}

#[test]
fn the_touch_off_confirmation_limit_is_named_when_out_of_range_or_missing() {
    assert_eq!(load_src(&shipped_src()).unwrap().setup.touch_off_confirm_mm, 0.3);
    for bad in ["0.0", "0.005", "7.5", "nan", "-0.3"] {
        let src = shipped_with(&[(
            "touch_off_confirm_mm = 0.3",
            &format!("touch_off_confirm_mm = {bad}"),
        )]);
        let e = load_src(&src).expect_err(bad);
        let p = &e.problems()[0];
        assert_eq!(p.key, "setup.touch_off_confirm_mm", "{e}");
        assert!(p.message.contains("0.01 .. 5 mm"), "{bad}: {}", p.message);
        let line = src
            .lines()
            .position(|l| l.starts_with("touch_off_confirm_mm"))
            .unwrap()
            + 1;
        assert_eq!(p.position.map(|p| p.line), Some(line), "{bad}");
    }
    // Every key is the machine builder's to state: none has a silent default.
    let src = shipped_with(&[("[setup]\ntouch_off_confirm_mm = 0.3\n", "")]);
    let e = load_src(&src).expect_err("no [setup]").to_string();
    assert!(e.contains("setup"), "{e}");
}

#[test]
fn a_table_gauge_is_optional_and_its_channel_is_checked() {
    let m = load_src(&shipped_src()).unwrap();
    assert_eq!(m.io.analog_inputs.table_gauge, None);
    let with = |channel: &str| {
        shipped_with(&[(
            "[io.analog_outputs]\nspindle_speed = { channel = 0 }\n",
            &format!(
                "[io.analog_outputs]\nspindle_speed = {{ channel = 0 }}\n\n[io.analog_inputs]\ntable_gauge = {{ channel = {channel} }}\n"
            ),
        )])
    };
    let m = load_src(&with("1")).unwrap();
    assert_eq!(m.io.analog_inputs.table_gauge, Some(AnalogBinding { channel: 1 }));
    let err = load_src(&with("8")).unwrap_err();
    assert_eq!(err.problems()[0].key, "io.analog_inputs.table_gauge.channel");
}

#[test]
fn a_backlash_record_out_of_its_ranges_is_refused_naming_the_key() {
    let record = |lost: &str, speed: &str| {
        format!(
            "{}\n[commissioning.table_backlash]\nutc = 2026-11-29T06:10:05Z\nlost_motion_arcsec = {lost}\n\
             uncertainty_arcsec = 0.1\nspeed_deg_min = {speed}\nsamples = 278\n",
            shipped_src()
        )
    };
    let m = load_src(&record("25.15", "3.0")).unwrap();
    let b = m.commissioning.and_then(|c| c.table_backlash).unwrap();
    assert_eq!(b.lost_motion_arcsec, 25.15);
    let err = load_src(&record("-1.0", "3.0")).unwrap_err();
    assert_eq!(
        err.problems()[0].key,
        "commissioning.table_backlash.lost_motion_arcsec"
    );
    let err = load_src(&record("25.0", "0.0")).unwrap_err();
    assert_eq!(
        err.problems()[0].key,
        "commissioning.table_backlash.speed_deg_min"
    );
}

/// The example record of the table drive's gains, with `edit` applied to its lines.
fn gains_record(edit: &[(&str, &str)]) -> String {
    let mut lines = vec![
        ("utc", "2026-11-29T09:10:05Z"),
        ("velocity_kp_nm_s_per_rad", "1.91"),
        ("velocity_integral_time_ms", "8.6"),
        ("position_kv_per_s", "100.5"),
        ("previous_velocity_kp_nm_s_per_rad", "7.5"),
        ("previous_velocity_integral_time_ms", "1.6"),
        ("previous_position_kv_per_s", "377.0"),
        ("velocity_gain_margin_db", "9.1"),
        ("velocity_phase_margin_deg", "45.0"),
        ("position_gain_margin_db", "8.9"),
        ("position_phase_margin_deg", "41.0"),
        ("mesh_antiresonance_hz", "50.3"),
        ("mesh_resonance_hz", "137.0"),
        ("table_drive_vendor_id", "0x00000B0B"),
        ("table_drive_product_code", "0x00020192"),
        ("table_drive_serial", "0x00001002"),
    ];
    for (key, value) in edit {
        if let Some(l) = lines.iter_mut().find(|l| l.0 == *key) {
            l.1 = value;
        }
    }
    let body: String = lines.iter().map(|(k, v)| format!("{k} = {v}\n")).collect();
    format!("{}\n[commissioning.table_drive_gains]\n{body}", shipped_src())
}

#[test]
fn a_gains_record_is_read_with_the_drive_it_names() {
    let m = load_src(&gains_record(&[])).unwrap();
    let g = m.commissioning.and_then(|c| c.table_drive_gains).unwrap();
    assert_eq!(g.velocity_kp_nm_s_per_rad, 1.91);
    assert_eq!(g.velocity_integral_time_ms, 8.6);
    assert_eq!(g.position_kv_per_s, 100.5);
    assert_eq!(g.previous_position_kv_per_s, 377.0);
    assert_eq!(g.mesh_resonance_hz, 137.0);
    assert!(g.is_of(0x0B0B, 0x0002_0192, 0x1002));
    assert!(!g.is_of(0x0B0B, 0x0002_0192, 0x1003));
    assert!(!g.is_of(0x0B0C, 0x0002_0192, 0x1002));
}

#[test]
fn a_gains_record_out_of_its_ranges_is_refused_naming_the_key() {
    let k = |key: &str| format!("commissioning.table_drive_gains.{key}");
    for (key, value) in [
        ("velocity_kp_nm_s_per_rad", "0.0"),
        ("velocity_kp_nm_s_per_rad", "nan"),
        ("velocity_integral_time_ms", "-8.6"),
        ("position_kv_per_s", "1e9"),
        ("previous_velocity_kp_nm_s_per_rad", "0.0"),
        ("previous_position_kv_per_s", "inf"),
        // A proposal with too little margin is never a record to write.
        ("velocity_gain_margin_db", "2.9"),
        ("position_gain_margin_db", "-1.0"),
        ("velocity_phase_margin_deg", "29.0"),
        ("position_phase_margin_deg", "12.0"),
        ("mesh_resonance_hz", "0.0"),
        ("mesh_antiresonance_hz", "140.0"),
        ("utc", "2026-11-29T09:10:05"),
    ] {
        let err = load_src(&gains_record(&[(key, value)])).unwrap_err();
        assert!(
            err.problems().iter().any(|p| p.key == k(key)),
            "{key} = {value}: {:?}",
            err.problems()
        );
    }
}

#[test]
fn the_worm_set_is_optional_and_named_when_invalid() {
    let shipped = load_src(&shipped_src()).unwrap();
    assert_eq!(shipped.table.worm_set.as_deref(), Some("B-2019-07"));
    let without = load_src(&shipped_with(&[("worm_set = \"B-2019-07\"\n", "")])).unwrap();
    assert_eq!(without.table.worm_set, None);
    let long = format!("worm_set = \"{}\"", "W".repeat(65));
    for bad in [
        "worm_set = \"\"",
        "worm_set = \"  \"",
        "worm_set = \"B\\u00e4\"",
        "worm_set = \"a\\tb\"",
        long.as_str(),
    ] {
        let src = shipped_with(&[("worm_set = \"B-2019-07\"", bad)]);
        let err = load_src(&src).unwrap_err();
        assert_eq!(err.problems()[0].key, "table.worm_set", "{bad}: {err}");
    }
    let max = format!("worm_set = \"{}\"", "W".repeat(64));
    assert!(load_src(&shipped_with(&[("worm_set = \"B-2019-07\"", max.as_str())])).is_ok());
}
