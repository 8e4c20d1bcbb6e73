//! The program definition's form and the program file: a TOML program flattened into one
//! field per key path (`workpiece.teeth`, `strategy.rough_depths_mm[1]`,
//! `workpiece.contour[2][0]`) for the page, and the page's fields written back as TOML,
//! one key per line, so that every problem the Rust checks find (by key, or by line for a
//! syntax error) lands on its field. Nothing here checks a value: a field the operator
//! typed wrong goes into the TOML as text and the program's parser refuses it by key.

use crate::error::Error;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use toml::Value;

/// How a field's text goes into TOML.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// A number when it reads as one (with a decimal point or comma), else the text as a
    /// string (the parser then says "expected a number" for that key).
    Num,
    Str,
    Bool,
}

/// One field of the form.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Field {
    pub key: String,
    pub kind: Kind,
    pub text: String,
}

/// A key path's parts: `strategy.rough_depths_mm[1]` is `strategy`, `rough_depths_mm`, `[1]`.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Part {
    Name(String),
    Index(usize),
}

fn parts(key: &str) -> Result<Vec<Part>, Error> {
    let mut out = Vec::new();
    for seg in key.split('.') {
        let (name, rest) = seg.split_once('[').map_or((seg, ""), |(n, r)| (n, r));
        let name_ok = !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !name_ok {
            return Err(Error::KeyPath { key: key.to_string() });
        }
        out.push(Part::Name(name.to_string()));
        if !rest.is_empty() {
            for idx in format!("[{rest}").split('[').skip(1) {
                let i = idx
                    .strip_suffix(']')
                    .and_then(|n| n.parse::<usize>().ok())
                    .filter(|i| *i < 1000)
                    .ok_or_else(|| Error::KeyPath { key: key.to_string() })?;
                out.push(Part::Index(i));
            }
        }
    }
    Ok(out)
}

fn literal(f: &Field) -> Option<Value> {
    let t = f.text.trim();
    if t.is_empty() {
        return None;
    }
    Some(match f.kind {
        Kind::Str => Value::String(t.to_string()),
        Kind::Bool => match t {
            "true" => Value::Boolean(true),
            "false" => Value::Boolean(false),
            _ => Value::String(t.to_string()),
        },
        Kind::Num => match (t.parse::<i64>(), t.parse::<f64>(), hob_ipc::number::decimal(t)) {
            (Ok(i), _, _) => Value::Integer(i),
            (_, Ok(x), _) if x.is_finite() => Value::Float(x),
            // A decimal comma (`94,94`), read as the CLI and the commands read it.
            (_, _, Some(x)) => Value::Float(x),
            _ => Value::String(t.to_string()),
        },
    })
}

fn insert(slot: &mut Value, path: &[Part], v: Value) -> Result<(), Error> {
    let Some((first, rest)) = path.split_first() else {
        *slot = v;
        return Ok(());
    };
    match first {
        Part::Name(n) => {
            if !slot.is_table() {
                *slot = Value::Table(toml::Table::new());
            }
            let t = slot.as_table_mut().ok_or(Error::NotATable)?;
            let child = t.entry(n.clone()).or_insert(Value::Table(toml::Table::new()));
            insert(child, rest, v)
        }
        Part::Index(i) => {
            if !slot.is_array() {
                *slot = Value::Array(Vec::new());
            }
            let a = slot.as_array_mut().ok_or(Error::NotAnArray)?;
            while a.len() <= *i {
                a.push(Value::Table(toml::Table::new()));
            }
            insert(&mut a[*i], rest, v)
        }
    }
}

/// Drops array slots nobody filled (a row left empty), so `[6.0, , 4.75]` cannot happen.
fn prune(v: &mut Value) {
    match v {
        Value::Table(t) => {
            for (_, x) in t.iter_mut() {
                prune(x);
            }
            t.retain(|_, x| !matches!(x, Value::Table(t) if t.is_empty()));
        }
        Value::Array(a) => {
            for x in a.iter_mut() {
                prune(x);
            }
            a.retain(|x| !matches!(x, Value::Table(t) if t.is_empty()));
        }
        _ => {}
    }
}

/// The form as a program file. Top-level tables in the program's order, then one
/// `key = value` line per field (dotted keys for nested tables, arrays whole).
pub fn to_toml(fields: &[Field]) -> Result<String, Error> {
    let mut root = Value::Table(toml::Table::new());
    for f in fields {
        let p = parts(&f.key)?;
        if p.len() < 2 {
            return Err(Error::OutsideTables { key: f.key.clone() });
        }
        if let Some(v) = literal(f) {
            insert(&mut root, &p, v)?;
        }
    }
    prune(&mut root);
    let Value::Table(top) = root else {
        return Err(Error::NotATable);
    };
    let mut out = String::new();
    let order = ["workpiece", "tool", "cycle", "strategy"];
    let mut names: Vec<&String> = top.keys().collect();
    names.sort_by_key(|n| order.iter().position(|o| o == n).unwrap_or(order.len()));
    for name in names {
        let _ = writeln!(out, "[{name}]");
        if let Some(Value::Table(t)) = top.get(name) {
            write_table(&mut out, "", t);
        }
        out.push('\n');
    }
    Ok(out)
}

fn write_table(out: &mut String, prefix: &str, t: &toml::Table) {
    for (k, v) in t {
        match v {
            Value::Table(inner) => write_table(out, &format!("{prefix}{k}."), inner),
            other => {
                let _ = writeln!(out, "{prefix}{k} = {other}");
            }
        }
    }
}

/// A program file as the form's fields (kinds from the values).
pub fn fields(src: &str) -> Result<Vec<Field>, Error> {
    let t: toml::Table = src.parse().map_err(Error::Toml)?;
    let mut out = Vec::new();
    for (k, v) in &t {
        flatten(&mut out, k, v);
    }
    Ok(out)
}

fn flatten(out: &mut Vec<Field>, key: &str, v: &Value) {
    let (kind, text) = match v {
        Value::Table(t) => {
            for (k, x) in t {
                flatten(out, &format!("{key}.{k}"), x);
            }
            return;
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                flatten(out, &format!("{key}[{i}]"), x);
            }
            return;
        }
        Value::String(s) => (Kind::Str, s.clone()),
        Value::Integer(i) => (Kind::Num, i.to_string()),
        Value::Float(x) => (Kind::Num, format!("{x:?}")),
        Value::Boolean(b) => (Kind::Bool, b.to_string()),
        Value::Datetime(d) => (Kind::Str, d.to_string()),
    };
    out.push(Field {
        key: key.to_string(),
        kind,
        text,
    });
}

/// The key a TOML line of [`to_toml`]'s output sets (for a syntax error's position).
pub fn key_of_line(toml_text: &str, line: usize) -> Option<String> {
    let mut table = String::new();
    for (i, l) in toml_text.lines().enumerate() {
        let l = l.trim();
        if let Some(name) = l.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
            table = name.to_string();
        } else if i == line
            && let Some((k, _)) = l.split_once('=')
        {
            return Some(format!("{table}.{}", k.trim()));
        }
    }
    None
}

/// Groups fields by their table (the sub-menus).
pub fn by_section(fields: &[Field]) -> BTreeMap<String, Vec<Field>> {
    let mut m: BTreeMap<String, Vec<Field>> = BTreeMap::new();
    for f in fields {
        let section = f.key.split(['.', '[']).next().unwrap_or("").to_string();
        m.entry(section).or_default().push(f.clone());
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(key: &str, kind: Kind, text: &str) -> Field {
        Field {
            key: key.into(),
            kind,
            text: text.into(),
        }
    }

    /// A disk cutter's profile (`[tool.disk]`, an array of tables) goes through the form's
    /// fields and back unchanged: the editor loses nothing it has no place for.
    #[test]
    fn a_disk_cutters_profile_survives_the_form() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/programs/tooth-by-tooth-z24-m8.toml"
        );
        let src = std::fs::read_to_string(path).expect("example");
        let fs = fields(&src).expect("fields");
        assert!(fs.iter().any(|f| f.key == "tool.disk.profile[8].end_mm[1]"));
        let back = to_toml(&fs).expect("toml");
        let before: hob_setup::job::Program = toml::from_str(&src).expect("example parses");
        let after: hob_setup::job::Program = toml::from_str(&back).expect("round trip parses");
        assert_eq!(after, before);
    }

    #[test]
    fn typed_text_becomes_toml_and_a_typo_stays_text_for_the_parser() {
        let t = to_toml(&[
            f("workpiece.teeth", Kind::Num, "17"),
            f("workpiece.module_mm", Kind::Num, "5.0"),
            f("workpiece.name", Kind::Str, "17"),
            f("workpiece.face_width_mm", Kind::Num, "1O"),
            f("workpiece.helix_deg", Kind::Num, ""),
            f("workpiece.crowning.height_mm", Kind::Num, "0.02"),
            f("strategy.rough_depths_mm[1]", Kind::Num, "4.75"),
            f("strategy.rough_depths_mm[0]", Kind::Num, "6"),
            f("workpiece.contour[0][0]", Kind::Num, "0"),
            f("workpiece.contour[0][1]", Kind::Num, "0.01"),
            f("workpiece.outside_diameter_mm", Kind::Num, "94,94"),
            f("workpiece.bore_mm", Kind::Num, "1.094,94"),
        ])
        .expect("toml");
        let v: toml::Table = t.parse().expect("valid TOML");
        let w = &v["workpiece"];
        assert_eq!(w["teeth"].as_integer(), Some(17));
        assert_eq!(w["name"].as_str(), Some("17"));
        assert_eq!(
            w["face_width_mm"].as_str(),
            Some("1O"),
            "the typo goes to the parser as text"
        );
        assert!(w.get("helix_deg").is_none(), "an empty field is absent");
        assert_eq!(
            w["outside_diameter_mm"].as_float(),
            Some(94.94),
            "a decimal comma"
        );
        assert_eq!(
            w["bore_mm"].as_str(),
            Some("1.094,94"),
            "a thousands separator is a typo"
        );
        assert_eq!(w["crowning"]["height_mm"].as_float(), Some(0.02));
        assert_eq!(v["strategy"]["rough_depths_mm"][1].as_float(), Some(4.75));
        assert_eq!(w["contour"][0][1].as_float(), Some(0.01));
        assert!(t.starts_with("[workpiece]"), "{t}");
        let line = t
            .lines()
            .position(|l| l.starts_with("face_width_mm"))
            .expect("line");
        assert_eq!(key_of_line(&t, line).as_deref(), Some("workpiece.face_width_mm"));
    }

    #[test]
    fn every_shipped_program_survives_the_form_unchanged() {
        let dir = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/programs"));
        for e in std::fs::read_dir(dir).expect("programs") {
            let p = e.expect("entry").path();
            let src = std::fs::read_to_string(&p).expect("read");
            let back = to_toml(&fields(&src).expect("fields")).expect("toml");
            let a: toml::Table = src.parse().expect("parse");
            let b: toml::Table = back.parse().expect("parse back");
            assert_eq!(a, b, "{}:\n{back}", p.display());
        }
    }

    #[test]
    fn a_key_that_is_not_a_path_is_refused() {
        for bad in [
            "",
            "teeth",
            "workpiece.",
            "workpiece.te eth",
            "strategy.x[a]",
            "a.b[5000]",
        ] {
            assert!(to_toml(&[f(bad, Kind::Num, "1")]).is_err(), "{bad:?}");
        }
    }
}
