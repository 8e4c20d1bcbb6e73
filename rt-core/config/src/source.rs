//! Positions in TOML sources: every refusal of a configuration or program names the key
//! and where it stands in the file.

use std::fmt;
use toml::de::{DeTable, DeValue};

/// A 1-based line and column in a source file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Position {
    pub line: usize,
    pub column: usize,
}

impl fmt::Display for Position {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.line, self.column)
    }
}

/// The line and column of byte offset `byte` in `src`.
pub fn position_of(src: &str, byte: usize) -> Position {
    let byte = byte.min(src.len());
    let before = &src[..byte];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    Position {
        line,
        column: before[line_start..].chars().count() + 1,
    }
}

/// One step of a key path: a table key or an array index.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Step<'a> {
    Key(&'a str),
    Index(usize),
}

/// Splits `workpiece.contour[1][0]` into `Key(workpiece) Key(contour) Index(1) Index(0)`.
fn steps(path: &str) -> Option<Vec<Step<'_>>> {
    let mut out = Vec::new();
    for part in path.split('.') {
        let (key, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        if !key.is_empty() {
            out.push(Step::Key(key));
        }
        while let Some(stripped) = rest.strip_prefix('[') {
            let end = stripped.find(']')?;
            out.push(Step::Index(stripped[..end].parse().ok()?));
            rest = &stripped[end + 1..];
        }
    }
    Some(out)
}

/// Where the key `path` (dotted, with `[i]` for array elements) is written in `src`.
///
/// Points at the key itself for table entries and at the element for array entries. When
/// the full path is absent (a missing key), the deepest existing parent is returned, so the
/// operator is sent to the table the key belongs in.
pub fn locate_key(src: &str, path: &str) -> Option<Position> {
    let root = DeTable::parse(src).ok()?;
    let steps = steps(path)?;
    let mut best: Option<usize> = None;
    let mut table: Option<&DeTable<'_>> = Some(root.get_ref());
    let mut array: Option<&[toml::Spanned<DeValue<'_>>]> = None;
    for step in steps {
        let value = match (step, table, array) {
            (Step::Key(k), Some(t), _) => match t.iter().find(|(key, _)| key.get_ref().as_ref() == k) {
                Some((key, value)) => {
                    best = Some(key.span().start);
                    value
                }
                None => break,
            },
            (Step::Index(i), _, Some(a)) => match a.get(i) {
                Some(value) => {
                    best = Some(value.span().start);
                    value
                }
                None => break,
            },
            _ => break,
        };
        table = None;
        array = None;
        match value.get_ref() {
            DeValue::Table(t) => table = Some(t),
            DeValue::Array(a) => array = Some(a),
            _ => {}
        }
    }
    best.map(|b| position_of(src, b))
}

/// The key path (as [`locate_key`] takes it: dotted, `[i]` for array elements) of the
/// deepest key or element whose text contains byte offset `byte` of `src`: where a parser's
/// error points, named as the operator's form names the field.
pub fn key_at(src: &str, byte: usize) -> Option<String> {
    fn within(span: std::ops::Range<usize>, byte: usize) -> bool {
        span.start <= byte && byte < span.end.max(span.start + 1)
    }
    // Depth first: a table's own span may cover only its header, so every child is looked
    // at, and the deepest entry containing the byte wins.
    fn find(v: &DeValue<'_>, path: &str, byte: usize) -> Option<String> {
        match v {
            DeValue::Table(t) => t.iter().find_map(|(k, x)| {
                let p = if path.is_empty() {
                    k.get_ref().to_string()
                } else {
                    format!("{path}.{}", k.get_ref())
                };
                find(x.get_ref(), &p, byte)
                    .or_else(|| (within(k.span(), byte) || within(x.span(), byte)).then_some(p))
            }),
            DeValue::Array(a) => a.iter().enumerate().find_map(|(i, x)| {
                let p = format!("{path}[{i}]");
                find(x.get_ref(), &p, byte).or_else(|| within(x.span(), byte).then_some(p))
            }),
            _ => None,
        }
    }
    let root = DeTable::parse(src).ok()?;
    find(&DeValue::Table(root.get_ref().clone()), "", byte)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_key_at_a_byte_is_the_deepest_one_written_there() {
        let at = |needle: &str| key_at(SRC, SRC.find(needle).expect("in SRC"));
        assert_eq!(at("17").as_deref(), Some("workpiece.teeth"));
        assert_eq!(at("-0.01").as_deref(), Some("workpiece.contour[1][1]"));
        assert_eq!(at("\"hob\"").as_deref(), Some("tool.kind"));
        assert_eq!(key_at(SRC, SRC.len() + 5), None);
    }

    const SRC: &str =
        "[workpiece]\nteeth = 17\ncontour = [[0.0, 0.0], [20.0, -0.01]]\n\n[tool]\nkind = \"hob\"\n";

    #[test]
    fn finds_keys_and_elements() {
        assert_eq!(
            locate_key(SRC, "workpiece.teeth"),
            Some(Position { line: 2, column: 1 })
        );
        assert_eq!(
            locate_key(SRC, "tool.kind"),
            Some(Position { line: 6, column: 1 })
        );
        assert_eq!(
            locate_key(SRC, "workpiece.contour[1]"),
            Some(Position { line: 3, column: 24 })
        );
    }

    #[test]
    fn missing_key_points_at_its_table() {
        assert_eq!(
            locate_key(SRC, "tool.starts"),
            Some(Position { line: 5, column: 2 })
        );
    }

    #[test]
    fn position_counts_lines_and_columns_from_one() {
        assert_eq!(position_of("ab\ncd", 4), Position { line: 2, column: 2 });
        assert_eq!(position_of("", 0), Position { line: 1, column: 1 });
    }
}
