//! The file read back as written; every malformed file refused with its line and field.
#![allow(clippy::unwrap_used)]

use super::*;
use proptest::prelude::*;

fn header(teeth: u32) -> Header {
    Header {
        gear: "spur-z17-m5".to_string(),
        teeth,
        normal_module_mm: 5.0,
        face_position_mm: 15.0,
        tooth_1_table_deg: 12.5,
        counting: Counting::TablePositive,
        checker: "test".to_string(),
        measured_at: "2026-11-29T12:00:00Z".to_string(),
    }
}

fn measurement(left: &[f64], right: &[f64]) -> PitchMeasurement {
    PitchMeasurement {
        header: header(left.len() as u32),
        left: FlankPitch::from_positions(left),
        right: FlankPitch::from_positions(right),
    }
}

fn sample() -> String {
    let left: Vec<f64> = (0..17).map(|k| (k as f64 * 0.7).sin() * 3.0).collect();
    let right: Vec<f64> = (0..17).map(|k| (k as f64 * 0.7).sin() * 3.0 + 0.2).collect();
    measurement(&left, &right).to_file()
}

/// The sample with line `n` (1-based) replaced.
fn with_line(n: usize, line: &str) -> String {
    let mut lines: Vec<String> = sample().lines().map(str::to_string).collect();
    lines[n - 1] = line.to_string();
    lines.join("\n")
}

fn refused(text: &str) -> MeasurementError {
    parse(text).expect_err("refused")
}

#[test]
fn the_positions_give_iso_1328_s_figures() {
    // A gap 2 um late on tooth 3: pitches 2 and 3 change by +2 and -2.
    let mut p = vec![0.0; 6];
    p[2] = 2.0;
    let f = FlankPitch::from_positions(&p);
    assert_eq!(f.single_um, vec![0.0, 0.0, 2.0, -2.0, 0.0, 0.0]);
    assert_eq!(f.cumulative_um, p);
    assert_eq!(f.single_pitch_um(), 2.0);
    assert_eq!(f.cumulative_pitch_um(), 2.0);
}

#[test]
fn a_written_file_reads_back() {
    let m = parse(&sample()).unwrap();
    assert_eq!(m.header, header(17));
    assert!((m.left.cumulative_um[0] - (0.0 - (16.0f64 * 0.7).sin() * 3.0)).abs() < 6e-4);
}

#[test]
fn a_checker_s_one_decimal_file_is_read() {
    // Rounded to 0.1 um as checkers print: Fp steps differ from fp by up to 0.15 um.
    let text = "# hob gear measurement 1\n# gear: g\n# teeth: 3\n# normal_module_mm: 2\n\
                # face_position_mm: 10\n# tooth_1_table_deg: 0\n# counting: table_negative\n\
                # checker: Klingelnberg P26\n# measured_at: 2026-11-29\n\
                tooth,left_fp_um,right_fp_um,left_Fp_um,right_Fp_um\n\
                1,0.1,0.0,0.1,0.0\n2,-0.2,0.0,-0.1,0.0\n3,0.1,0.0,0.0,0.0\n";
    let m = parse(text).unwrap();
    assert_eq!(m.header.counting, Counting::TableNegative);
    assert_eq!(m.figures_um(), (0.2, 0.2));
}

#[test]
fn every_malformed_file_is_refused_with_its_line_and_field() {
    let cases: Vec<(String, Option<usize>, &str)> = vec![
        (with_line(1, "# hob gear measurement 2"), Some(1), "format"),
        (String::new(), None, "format"),
        (with_line(3, "# teeth: 18"), Some(27), "tooth"),
        (with_line(3, "# teeth: 17.0"), Some(3), "teeth"),
        (with_line(3, "# teeth: 2"), Some(3), "teeth"),
        (with_line(3, "# teth: 17"), Some(3), "teth"),
        (with_line(4, "# gear: again"), Some(4), "gear"),
        (
            with_line(5, "# face_position_mm: NaN"),
            Some(5),
            "face_position_mm",
        ),
        (with_line(7, "# counting: clockwise"), Some(7), "counting"),
        (with_line(9, "# measured_at:"), Some(9), "measured_at"),
        (with_line(8, "# a comment"), None, "checker"),
        (
            with_line(10, "tooth,left_fp_mm,right_fp_mm,left_Fp_mm,right_Fp_mm"),
            Some(10),
            "left_fp_mm",
        ),
        (
            with_line(10, "tooth,left_fp_um,right_fp_um,left_Fp_um"),
            Some(10),
            "right_Fp_um",
        ),
        (with_line(11, "1,0.1,0.2,0.3"), Some(11), "row"),
        (with_line(11, "0,0,0,0,0"), Some(11), "tooth"),
        (with_line(11, "18,0,0,0,0"), Some(11), "tooth"),
        (with_line(12, "1,0,0,0,0"), Some(12), "tooth"),
        (with_line(11, "1,NaN,0,0,0"), Some(11), "left_fp_um"),
        (with_line(11, "1,0,inf,0,0"), Some(11), "right_fp_um"),
        (with_line(11, "1,0.000,0,0.0035,0"), Some(11), "left_Fp_um"),
        (with_line(11, "1,0,0,0,3500"), Some(11), "right_Fp_um"),
        (with_line(11, "# tooth 1 left out"), Some(27), "tooth"),
    ];
    for (text, line, field) in cases {
        let e = refused(&text);
        assert_eq!((e.line, e.field.as_str()), (line, field), "{e}");
        assert!(!e.to_string().is_empty());
    }
    // A flank whose Fp does not step by its fp: the tooth's line, the flank's Fp.
    let mut lines: Vec<String> = sample().lines().map(str::to_string).collect();
    let fields: Vec<String> = lines[14].split(',').map(str::to_string).collect();
    let bumped: f64 = fields[2].parse::<f64>().unwrap() + 0.5;
    lines[14] = format!(
        "{},{},{bumped:.3},{},{}",
        fields[0], fields[1], fields[3], fields[4]
    );
    let e = refused(&lines.join("\n"));
    assert_eq!((e.line, e.field.as_str()), (Some(15), "right_Fp_um"), "{e}");
}

proptest! {
    /// Any two flanks' positions are read back as written, to the nanometre the file keeps,
    /// whatever their offset.
    #[test]
    fn any_measurement_reads_back(
        left in proptest::collection::vec(-100.0f64..100.0, 3..60),
        offset in -50.0f64..50.0,
    ) {
        let right: Vec<f64> = left.iter().rev().map(|p| p + offset).collect();
        let m = measurement(&left, &right);
        let back = parse(&m.to_file()).unwrap();
        prop_assert_eq!(&back.header, &m.header);
        for f in Flank::BOTH {
            for (a, b) in back.flank(f).single_um.iter().zip(&m.flank(f).single_um) {
                prop_assert!((a - b).abs() <= 5e-4);
            }
            for (a, b) in back.flank(f).cumulative_um.iter().zip(&m.flank(f).cumulative_um) {
                prop_assert!((a - b).abs() <= 5e-4);
            }
        }
    }

    /// Whatever a line of the file is replaced by, the file is read or refused with a
    /// line number within the file; never a panic.
    #[test]
    fn any_damaged_line_is_read_or_refused(n in 1usize..28, junk in "[ -~]{0,40}") {
        let text = with_line(n, &junk);
        if let Err(e) = parse(&text) {
            prop_assert!(e.line.is_none_or(|l| (1..=27).contains(&l)), "{}", e);
        }
    }
}
