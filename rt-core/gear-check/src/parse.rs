//! Reading a measurement file: every refusal names the line and the field.

use crate::error::MeasurementError;
use crate::{
    COLUMNS, Counting, FORMAT_LINE, FlankPitch, Header, MAX_DEVIATION_UM, PitchMeasurement, TEETH_RANGE,
};

/// The header's keys, each required once.
const KEYS: [&str; 8] = [
    "gear",
    "teeth",
    "normal_module_mm",
    "face_position_mm",
    "tooth_1_table_deg",
    "counting",
    "checker",
    "measured_at",
];

/// A number of the file and its resolution (one unit of its last decimal).
#[derive(Debug, Clone, Copy)]
struct Value {
    um: f64,
    resolution_um: f64,
}

/// One tooth's row: its line and its four numbers in the columns' order.
#[derive(Debug, Clone, Copy)]
struct Row {
    line: usize,
    values: [Value; 4],
}

/// Reads a measurement file. Refused, with the line and the field, on: a missing or other
/// format line; an unknown, repeated or missing header key, or a value out of its range; a
/// column header other than [`COLUMNS`] (mm or nm instead of um among them); a row with
/// another number of fields, a tooth number out of 1..=teeth or repeated, a deviation that
/// is not a finite number or is larger than [`MAX_DEVIATION_UM`]; a tooth missing; and a
/// flank whose consecutive `Fp` do not differ by the tooth's `fp`.
pub fn parse(text: &str) -> Result<PitchMeasurement, MeasurementError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')));
    match lines.next() {
        Some((_, l)) if l.trim() == FORMAT_LINE => {}
        Some((n, l)) => {
            return Err(MeasurementError::at(
                n,
                "format",
                format!("the first line is {l:?}, not {FORMAT_LINE:?}"),
            ));
        }
        None => return Err(MeasurementError::whole("format", "the file is empty")),
    }
    let mut values: [Option<(usize, String)>; KEYS.len()] = Default::default();
    let mut columns_line = None;
    let mut rows = Vec::new();
    let mut last_line = 1;
    for (n, raw) in lines {
        last_line = n;
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(comment) = line.strip_prefix('#') {
            if columns_line.is_some() {
                continue;
            }
            let Some((key, value)) = comment.split_once(':') else {
                continue;
            };
            let key = key.trim();
            let Some(i) = KEYS.iter().position(|k| *k == key) else {
                return Err(MeasurementError::at(
                    n,
                    key,
                    format!("not a key of the header (known: {})", KEYS.join(", ")),
                ));
            };
            if let Some((first, _)) = &values[i] {
                return Err(MeasurementError::at(
                    n,
                    key,
                    format!("given again (first on line {first})"),
                ));
            }
            values[i] = Some((n, value.trim().to_string()));
            continue;
        }
        if columns_line.is_none() {
            check_columns(n, line)?;
            columns_line = Some(n);
            continue;
        }
        rows.push((n, line.to_string()));
    }
    let header = header(&values)?;
    let Some(columns_line) = columns_line else {
        return Err(MeasurementError::whole(
            "columns",
            format!("no column header {COLUMNS:?}"),
        ));
    };
    let z = header.teeth as usize;
    let mut teeth: Vec<Option<Row>> = vec![None; z];
    for (n, line) in rows {
        let row = row(n, &line, header.teeth)?;
        let (tooth, row) = row;
        if let Some(first) = teeth[tooth - 1] {
            return Err(MeasurementError::at(
                n,
                "tooth",
                format!("tooth {tooth} given again (first on line {})", first.line),
            ));
        }
        teeth[tooth - 1] = Some(row);
    }
    let teeth: Vec<Row> = teeth
        .into_iter()
        .enumerate()
        .map(|(k, r)| {
            r.ok_or_else(|| {
                MeasurementError::at(
                    last_line.max(columns_line),
                    "tooth",
                    format!("tooth {} of {z} is missing", k + 1),
                )
            })
        })
        .collect::<Result<_, _>>()?;
    let left = flank(&teeth, 0, 2, "left_Fp_um")?;
    let right = flank(&teeth, 1, 3, "right_Fp_um")?;
    Ok(PitchMeasurement { header, left, right })
}

fn check_columns(n: usize, line: &str) -> Result<(), MeasurementError> {
    let wanted: Vec<&str> = COLUMNS.split(',').collect();
    let given: Vec<&str> = line.split(',').map(str::trim).collect();
    for (i, w) in wanted.iter().enumerate() {
        match given.get(i) {
            Some(g) if g == w => {}
            Some(g) if g.ends_with("_mm") || g.ends_with("_nm") => {
                return Err(MeasurementError::at(
                    n,
                    g,
                    format!("deviations are in um: the column is {w:?}"),
                ));
            }
            Some(g) => {
                return Err(MeasurementError::at(n, g, format!("column {} is {w:?}", i + 1)));
            }
            None => return Err(MeasurementError::at(n, w, "column missing")),
        }
    }
    if given.len() > wanted.len() {
        return Err(MeasurementError::at(
            n,
            given[wanted.len()],
            format!("{} columns, not {}", given.len(), wanted.len()),
        ));
    }
    Ok(())
}

fn header(values: &[Option<(usize, String)>; KEYS.len()]) -> Result<Header, MeasurementError> {
    let get = |key: &str| -> Result<(usize, &str), MeasurementError> {
        let i = KEYS.iter().position(|k| *k == key).unwrap_or(0);
        values[i]
            .as_ref()
            .map(|(n, v)| (*n, v.as_str()))
            .ok_or_else(|| MeasurementError::whole(key, "missing from the header"))
    };
    let text = |key: &str| -> Result<String, MeasurementError> {
        let (n, v) = get(key)?;
        if v.is_empty() {
            return Err(MeasurementError::at(n, key, "empty"));
        }
        Ok(v.to_string())
    };
    let number = |key: &str, lo: f64, hi: f64| -> Result<f64, MeasurementError> {
        let (n, v) = get(key)?;
        match v.parse::<f64>() {
            Ok(x) if x.is_finite() && (lo..=hi).contains(&x) => Ok(x),
            Ok(x) if x.is_finite() => Err(MeasurementError::at(
                n,
                key,
                format!("{x} is outside {lo}..={hi}"),
            )),
            _ => Err(MeasurementError::at(n, key, format!("{v:?} is not a number"))),
        }
    };
    let teeth = {
        let (n, v) = get("teeth")?;
        match v.parse::<u32>() {
            Ok(t) if (TEETH_RANGE.0..=TEETH_RANGE.1).contains(&t) => t,
            _ => {
                return Err(MeasurementError::at(
                    n,
                    "teeth",
                    format!(
                        "{v:?} is not a whole number in {}..={}",
                        TEETH_RANGE.0, TEETH_RANGE.1
                    ),
                ));
            }
        }
    };
    let counting = {
        let (n, v) = get("counting")?;
        match v {
            "table_positive" => Counting::TablePositive,
            "table_negative" => Counting::TableNegative,
            _ => {
                return Err(MeasurementError::at(
                    n,
                    "counting",
                    format!("{v:?} is neither table_positive nor table_negative"),
                ));
            }
        }
    };
    Ok(Header {
        gear: text("gear")?,
        teeth,
        normal_module_mm: number("normal_module_mm", 0.1, 100.0)?,
        face_position_mm: number("face_position_mm", 0.0, 2000.0)?,
        tooth_1_table_deg: number("tooth_1_table_deg", -360.0, 360.0)?,
        counting,
        checker: text("checker")?,
        measured_at: text("measured_at")?,
    })
}

/// A tooth's row: its number (1-based) and its values.
fn row(n: usize, line: &str, teeth: u32) -> Result<(usize, Row), MeasurementError> {
    let names: Vec<&str> = COLUMNS.split(',').collect();
    let fields: Vec<&str> = line.split(',').map(str::trim).collect();
    if fields.len() != names.len() {
        return Err(MeasurementError::at(
            n,
            "row",
            format!("{} fields, not {} ({COLUMNS})", fields.len(), names.len()),
        ));
    }
    let tooth = match fields[0].parse::<u32>() {
        Ok(t) if (1..=teeth).contains(&t) => t as usize,
        _ => {
            return Err(MeasurementError::at(
                n,
                "tooth",
                format!("{:?} is not a tooth number in 1..={teeth}", fields[0]),
            ));
        }
    };
    let mut values = [Value {
        um: 0.0,
        resolution_um: 0.0,
    }; 4];
    for (i, v) in values.iter_mut().enumerate() {
        *v = value(n, names[i + 1], fields[i + 1])?;
    }
    Ok((tooth, Row { line: n, values }))
}

fn value(n: usize, column: &str, field: &str) -> Result<Value, MeasurementError> {
    let um = match field.parse::<f64>() {
        Ok(x) if x.is_finite() => x,
        _ => {
            return Err(MeasurementError::at(
                n,
                column,
                format!("{field:?} is not a finite number"),
            ));
        }
    };
    if um.abs() > MAX_DEVIATION_UM {
        return Err(MeasurementError::at(
            n,
            column,
            format!("{um} um is more than {MAX_DEVIATION_UM} um: not in um?"),
        ));
    }
    let mantissa = field.split(['e', 'E']).next().unwrap_or(field);
    let exponent: i32 = field
        .split_once(['e', 'E'])
        .and_then(|(_, e)| e.parse().ok())
        .unwrap_or(0);
    let decimals = mantissa.split_once('.').map_or(0, |(_, d)| d.len() as i32);
    Ok(Value {
        um,
        resolution_um: 10f64.powi(exponent - decimals),
    })
}

/// A flank from the rows' columns `single` and `cumulative`, checked: consecutive `Fp`
/// (cyclically) differ by the tooth's `fp` to within the three numbers' rounding.
fn flank(
    rows: &[Row],
    single: usize,
    cumulative: usize,
    field: &str,
) -> Result<FlankPitch, MeasurementError> {
    let z = rows.len();
    for k in 0..z {
        let prev = rows[(k + z - 1) % z].values[cumulative];
        let this = rows[k].values[cumulative];
        let fp = rows[k].values[single];
        let step = this.um - prev.um;
        let tolerance = 0.5 * (prev.resolution_um + this.resolution_um + fp.resolution_um) + 1e-9;
        if (step - fp.um).abs() > tolerance {
            return Err(MeasurementError::at(
                rows[k].line,
                field,
                format!(
                    "tooth {}'s Fp is {:.4} um from tooth {}'s, but its fp is {} um",
                    k + 1,
                    step,
                    (k + z - 1) % z + 1,
                    fp.um
                ),
            ));
        }
    }
    Ok(FlankPitch {
        single_um: rows.iter().map(|r| r.values[single].um).collect(),
        cumulative_um: rows.iter().map(|r| r.values[cumulative].um).collect(),
    })
}
