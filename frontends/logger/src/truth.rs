//! The simulated machine's truth beside a recording (`truth.csv`): what the virtual machine
//! (`hob-sim --truth FILE`) knows and the controller does not, one row per SYNC. The
//! report joins it with the loop's samples by their SYNC times (both `CLOCK_MONOTONIC`), so
//! that a cut over the bus is graded by the true error, the controller's own estimate
//! reported beside it.
//!
//! The file: a first line `# hob-sim truth: teeth Z face_width_mm B pitch_radius_mm R
//! normal_module_mm M starts S` (the gear of the simulator's program and its hob's starts),
//! the header
//! [`HEADER`], then the rows. The errors are against the gearbox law without its phase
//! (which only the controller knows): the report puts each pass's phase back
//! ([`crate::export`]).

use crate::error::{Error, TruthProblem};
use std::io::{BufRead, Write};
use std::path::Path;

/// The file's name in a recording's directory.
pub const FILE: &str = "truth.csv";

/// The columns, in order.
pub const HEADER: &str = "sync_ns,table_drive_deg,y_mm,drive_err_arcsec,blank_err_arcsec";

/// What the truth is of: the gear on the table (the simulator's `--program`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gear {
    pub teeth: u32,
    pub face_width_mm: f64,
    pub pitch_radius_mm: f64,
    pub normal_module_mm: f64,
    /// The hob's starts: where the gaps are cut (`crate::predicted::GapsAt::Hob`).
    pub starts: u32,
}

impl Gear {
    /// Whether a recording of a gear of this pitch radius and normal module is of this
    /// gear (the truth's gearbox law is its program's: of another gear it means nothing).
    pub fn is_of(&self, pitch_radius_mm: f64, normal_module_mm: f64) -> bool {
        (self.pitch_radius_mm - pitch_radius_mm).abs() < 1e-6
            && (self.normal_module_mm - normal_module_mm).abs() < 1e-9
    }
}

/// The machine's truth at one SYNC, as the virtual machine latched it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthRow {
    /// When the simulator read the SYNC (`CLOCK_MONOTONIC`, ns).
    pub sync_ns: u64,
    /// The table as its motor turned it through an ideal worm (deg, continuous).
    pub table_drive_deg: f64,
    pub y_mm: f64,
    /// The drive's motion against the gearbox law for the true spindle angle and Y, less
    /// the law's phase (arcsec): the controller's share plus a constant.
    pub drive_err_arcsec: f64,
    /// The blank's true angle (worm, play, compliance, the work's twist) against the same
    /// law, less the same phase (arcsec): what the gear gets plus the same constant.
    pub blank_err_arcsec: f64,
}

impl TruthRow {
    /// The row as CSV (no newline). Errors to 1e-4 arcsec: the law's phase makes them
    /// large numbers (the table's whole turns) whose differences must survive.
    pub fn csv(&self) -> String {
        format!(
            "{},{:.7},{:.5},{:.4},{:.4}",
            self.sync_ns, self.table_drive_deg, self.y_mm, self.drive_err_arcsec, self.blank_err_arcsec
        )
    }
}

/// Writes the file's first two lines.
pub fn write_head(w: &mut dyn Write, gear: Gear) -> std::io::Result<()> {
    writeln!(
        w,
        "# hob-sim truth: teeth {} face_width_mm {} pitch_radius_mm {} normal_module_mm {} starts {}",
        gear.teeth, gear.face_width_mm, gear.pitch_radius_mm, gear.normal_module_mm, gear.starts
    )?;
    writeln!(w, "{HEADER}")
}

/// Reads a truth file: the gear and the rows in the order written. A last line cut short
/// (the simulator stopped while writing) is left out; any other bad line is an error that
/// names it.
pub fn read(path: &Path) -> Result<(Gear, Vec<TruthRow>), Error> {
    let f = std::fs::File::open(path).map_err(|error| Error::Io {
        path: path.to_path_buf(),
        error,
    })?;
    let mut lines = std::io::BufReader::new(f).lines();
    let at = |line: usize, problem: TruthProblem| Error::Truth {
        path: path.to_path_buf(),
        line,
        problem,
    };
    let first = lines
        .next()
        .transpose()
        .map_err(|e| at(1, TruthProblem::Io(e)))?
        .unwrap_or_default();
    let gear = parse_gear(&first).ok_or_else(|| at(1, TruthProblem::NotATruthFile))?;
    let header = lines.next().transpose().map_err(|e| at(2, TruthProblem::Io(e)))?;
    if header.as_deref() != Some(HEADER) {
        return Err(at(2, TruthProblem::Header { expected: HEADER }));
    }
    let mut rows = Vec::new();
    let mut pending: Option<(usize, String)> = None;
    for (i, line) in lines.enumerate() {
        let line = line.map_err(|e| at(i + 3, TruthProblem::Io(e)))?;
        if let Some((n, bad)) = pending.take() {
            return Err(at(n, TruthProblem::NotARow(bad)));
        }
        match parse_row(&line) {
            Some(r) => rows.push(r),
            None => pending = Some((i + 3, line)),
        }
    }
    Ok((gear, rows))
}

/// The gear of a truth file's first line.
fn parse_gear(first: &str) -> Option<Gear> {
    let words: Vec<&str> = first.split_whitespace().collect();
    match words.as_slice() {
        [
            "#",
            "hob-sim",
            "truth:",
            "teeth",
            z,
            "face_width_mm",
            b,
            "pitch_radius_mm",
            r,
            "normal_module_mm",
            m,
            "starts",
            n,
        ] => match (z.parse(), b.parse(), r.parse(), m.parse(), n.parse()) {
            (Ok(teeth), Ok(face_width_mm), Ok(pitch_radius_mm), Ok(normal_module_mm), Ok(starts))
                if starts > 0 =>
            {
                Some(Gear {
                    teeth,
                    face_width_mm,
                    pitch_radius_mm,
                    normal_module_mm,
                    starts,
                })
            }
            _ => None,
        },
        _ => None,
    }
}

fn parse_row(line: &str) -> Option<TruthRow> {
    let mut f = line.split(',');
    let sync_ns = f.next()?.parse().ok()?;
    let mut num = || {
        f.next()
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite())
    };
    let row = TruthRow {
        sync_ns,
        table_drive_deg: num()?,
        y_mm: num()?,
        drive_err_arcsec: num()?,
        blank_err_arcsec: num()?,
    };
    f.next().is_none().then_some(row)
}

/// The truth row of the SYNC sent at `sync_ns`, in rows ordered by time: the first read at
/// or after it and before `next_sync_ns` (the next sample's SYNC; none: any later row).
/// `from` is where to start looking (the index after the last match), so that a whole
/// recording joins in one pass.
pub fn row_for(
    rows: &[TruthRow],
    from: &mut usize,
    sync_ns: u64,
    next_sync_ns: Option<u64>,
) -> Option<TruthRow> {
    while *from < rows.len() && rows[*from].sync_ns < sync_ns {
        *from += 1;
    }
    let r = rows.get(*from)?;
    next_sync_ns.is_none_or(|n| r.sync_ns < n).then_some(*r)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gear() -> Gear {
        Gear {
            teeth: 17,
            face_width_mm: 40.0,
            pitch_radius_mm: 42.5,
            normal_module_mm: 5.0,
            starts: 1,
        }
    }

    fn row(sync_ns: u64, e: f64) -> TruthRow {
        TruthRow {
            sync_ns,
            table_drive_deg: -1234.5678901,
            y_mm: 101.25,
            drive_err_arcsec: 7_200_000.123_4 + e,
            blank_err_arcsec: 7_200_003.5 + e,
        }
    }

    #[test]
    fn a_written_file_reads_back_and_a_cut_last_line_is_left_out() {
        let path = std::env::temp_dir().join(format!("hob-truth-{}.csv", std::process::id()));
        let mut text = Vec::new();
        write_head(&mut text, gear()).unwrap();
        let rows = [row(1000, 0.0), row(2000, 0.5)];
        for r in &rows {
            writeln!(text, "{}", r.csv()).unwrap();
        }
        text.extend_from_slice(b"3000,-12");
        std::fs::write(&path, &text).unwrap();
        let (gear, back) = read(&path).unwrap();
        assert_eq!(gear, self::gear());
        assert!(gear.is_of(42.5, 5.0) && !gear.is_of(42.5, 4.0) && !gear.is_of(49.5, 5.0));
        assert_eq!(back.len(), 2);
        for (a, b) in rows.iter().zip(&back) {
            assert_eq!(a.sync_ns, b.sync_ns);
            assert!((a.drive_err_arcsec - b.drive_err_arcsec).abs() < 1e-4);
            assert!((a.table_drive_deg - b.table_drive_deg).abs() < 1e-7);
        }
        // A bad line in the middle is an error naming its line.
        let mut bad = text.clone();
        bad.extend_from_slice(b"\n4000,1,2,3,4\n");
        std::fs::write(&path, &bad).unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(e.contains(":5: not a truth row"), "{e}");
        std::fs::write(&path, "t_s,state\n1,2\n").unwrap();
        assert!(
            read(&path)
                .unwrap_err()
                .to_string()
                .contains(":1: not a hob-sim truth file")
        );
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn each_sample_takes_the_row_read_after_its_sync_and_before_the_next() {
        let rows = [row(950, 0.0), row(1020, 1.0), row(2900, 2.0), row(3010, 3.0)];
        let mut from = 0;
        // SYNC at 1000: the row read at 1020.
        assert_eq!(
            row_for(&rows, &mut from, 1000, Some(2000)).map(|r| r.sync_ns),
            Some(1020)
        );
        // SYNC at 2000: the next row (2900) is read after the SYNC at 2500: none.
        assert_eq!(row_for(&rows, &mut from, 2000, Some(2500)), None);
        assert_eq!(
            row_for(&rows, &mut from, 2500, Some(3000)).map(|r| r.sync_ns),
            Some(2900)
        );
        assert_eq!(
            row_for(&rows, &mut from, 3000, None).map(|r| r.sync_ns),
            Some(3010)
        );
        assert_eq!(row_for(&rows, &mut from, 4000, None), None);
    }
}
