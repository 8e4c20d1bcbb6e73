//! The machine file changed by a tool (`hob commission`), never silently: the builder's
//! text kept (its comments, order and layout), only the lines of the changed keys and the
//! tool's own record rewritten, the change shown as a diff before it is written, and
//! written whole or not at all with the old file kept beside it.
//!
//! The edit is made on the text, line by line, and then proven: the new text is parsed and
//! validated as `hob-rt` would at its start, and a key that did not come out with the
//! intended value (a file written in another TOML style, say a dotted key at the top or an
//! inline table) refuses the edit, naming the key, instead of guessing.

use crate::atomic;
use hob_setup::config::LoadError;
use hob_setup::config::machine::MachineConfig;
use std::fmt;
use std::path::{Path, PathBuf};

/// Why an edit of the machine file was not made (nothing was written).
#[derive(Debug)]
pub enum EditError {
    /// The key's line was not found where the edit looks for it (`[table]` then `key = `).
    KeyNotFound { table: String, key: String },
    /// The edited text does not parse or validate (the problems name the keys).
    Invalid(LoadError),
    /// The file changed on disk after it was read for this edit.
    ChangedMeanwhile { file: PathBuf },
    /// Reading, keeping the old file or writing the new one failed.
    Io { file: PathBuf, error: std::io::Error },
}

impl fmt::Display for EditError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EditError::KeyNotFound { table, key } => write!(
                f,
                "{table}.{key}: no line `{key} = ...` under [{table}] in the machine file \
                 (a file in another TOML style is edited by hand)"
            ),
            EditError::Invalid(e) => write!(f, "the edited machine file would be refused: {e}"),
            EditError::ChangedMeanwhile { file } => write!(
                f,
                "{}: changed since it was read for this edit; nothing written (run again)",
                file.display()
            ),
            EditError::Io { file, error } => write!(f, "{}: {error}", file.display()),
        }
    }
}

impl std::error::Error for EditError {}

/// `text` with the value of `key` under `[table]` replaced by `value` (a TOML literal),
/// the line's indentation and trailing comment kept.
pub fn set_value(text: &str, table: &str, key: &str, value: &str) -> Result<String, EditError> {
    let mut out = String::with_capacity(text.len() + 16);
    let mut in_table = false;
    let mut done = false;
    for line in text.split_inclusive('\n') {
        let trimmed = line.trim_start();
        if let Some(header) = table_header(trimmed) {
            in_table = header == table;
        } else if in_table
            && !done
            && let Some(rest) = trimmed.strip_prefix(key)
            && let Some(after_eq) = rest.trim_start().strip_prefix('=')
        {
            let indent = &line[..line.len() - trimmed.len()];
            let comment = comment_of(after_eq);
            let eol = if line.ends_with('\n') { "\n" } else { "" };
            let lhs = format!("{indent}{key} = {value}");
            out.push_str(&match comment {
                // The comment stays in its column where the new value leaves room.
                Some(c) => {
                    let column = line.len() - eol.len() - c.len();
                    let pad = column.saturating_sub(lhs.len()).max(1);
                    format!("{lhs}{}{c}{eol}", " ".repeat(pad))
                }
                None => format!("{lhs}{eol}"),
            });
            done = true;
            continue;
        }
        out.push_str(line);
    }
    if done {
        Ok(out)
    } else {
        Err(EditError::KeyNotFound {
            table: table.to_string(),
            key: key.to_string(),
        })
    }
}

/// `text` with the table `[header]` (its header line and every line up to the next header)
/// replaced by `block` (which starts with the header line), or `block` appended after a
/// blank line when the table is not there.
pub fn replace_table(text: &str, header: &str, block: &str) -> String {
    let mut out = String::with_capacity(text.len() + block.len() + 2);
    let mut skipping = false;
    let mut replaced = false;
    for line in text.split_inclusive('\n') {
        if let Some(h) = table_header(line.trim_start()) {
            skipping = h == header;
            if skipping && !replaced {
                out.push_str(block);
                replaced = true;
            }
        }
        if !skipping {
            out.push_str(line);
        }
    }
    if !replaced {
        if !out.is_empty() && !out.ends_with('\n') {
            out.push('\n');
        }
        if !out.is_empty() && !out.ends_with("\n\n") {
            out.push('\n');
        }
        out.push_str(block);
    }
    out
}

/// The table a header line opens (`[a.b]` -> `a.b`), if `line` is one.
fn table_header(line: &str) -> Option<&str> {
    let line = line.trim_end();
    let line = match line.find('#') {
        Some(i) => line[..i].trim_end(),
        None => line,
    };
    let inner = line.strip_prefix('[')?.strip_suffix(']')?;
    // `[[array]]` tables are not the machine file's style: never matched.
    if inner.starts_with('[') {
        return None;
    }
    Some(inner.trim())
}

/// The trailing `# comment` of a value's text, outside of a quoted string.
fn comment_of(value_text: &str) -> Option<&str> {
    let mut quote: Option<char> = None;
    for (i, c) in value_text.char_indices() {
        match (quote, c) {
            (None, '"' | '\'') => quote = Some(c),
            (Some(q), _) if c == q => quote = None,
            (None, '#') => return Some(value_text[i..].trim_end_matches(['\n', '\r'])),
            _ => {}
        }
    }
    None
}

/// The lines that differ between `old` and `new`, as `-`/`+` lines with their line number
/// in the old and the new file (a longest-common-subsequence diff; the machine file has a
/// few hundred lines).
pub fn diff(old: &str, new: &str) -> String {
    let a: Vec<&str> = old.lines().collect();
    let b: Vec<&str> = new.lines().collect();
    // lcs[i][j]: common lines of a[i..] and b[j..].
    let mut lcs = vec![vec![0u32; b.len() + 1]; a.len() + 1];
    for i in (0..a.len()).rev() {
        for j in (0..b.len()).rev() {
            lcs[i][j] = if a[i] == b[j] {
                lcs[i + 1][j + 1] + 1
            } else {
                lcs[i + 1][j].max(lcs[i][j + 1])
            };
        }
    }
    let (mut i, mut j) = (0, 0);
    let mut out = String::new();
    while i < a.len() || j < b.len() {
        if i < a.len() && j < b.len() && a[i] == b[j] {
            i += 1;
            j += 1;
        } else if j < b.len() && (i == a.len() || lcs[i][j + 1] > lcs[i + 1][j]) {
            out.push_str(&format!("+{:>4}  {}\n", j + 1, b[j]));
            j += 1;
        } else {
            out.push_str(&format!("-{:>4}  {}\n", i + 1, a[i]));
            i += 1;
        }
    }
    out
}

/// Checks `new_text` as `hob-rt` would load it (`file` names it in the problems).
pub fn check(file: &Path, new_text: &str) -> Result<MachineConfig, EditError> {
    MachineConfig::parse(file, new_text).map_err(EditError::Invalid)
}

/// Writes `new_text` over `file`, which must still hold `read_text` (what the edit was made
/// from): the new text checked first, the old file kept as `FILE.STAMP.bak` (`stamp`: when,
/// as digits, e.g. `20261128T231005Z`), then the file replaced atomically, its permissions
/// kept. Returns the kept file's path. Nothing is changed on any refusal.
pub fn commit(file: &Path, read_text: &str, new_text: &str, stamp: &str) -> Result<PathBuf, EditError> {
    check(file, new_text)?;
    let io = |error| EditError::Io {
        file: file.to_path_buf(),
        error,
    };
    let on_disk = std::fs::read_to_string(file).map_err(io)?;
    if on_disk != read_text {
        return Err(EditError::ChangedMeanwhile {
            file: file.to_path_buf(),
        });
    }
    let permissions = std::fs::metadata(file).map_err(io)?.permissions();
    let name = file
        .file_name()
        .map_or_else(|| "machine.toml".into(), |n| n.to_string_lossy().into_owned());
    let kept = file.with_file_name(format!("{name}.{stamp}.bak"));
    atomic::write_new(&kept, read_text.as_bytes()).map_err(|error| EditError::Io {
        file: kept.clone(),
        error,
    })?;
    atomic::write_atomic(file, new_text.as_bytes()).map_err(io)?;
    std::fs::set_permissions(file, permissions).map_err(io)?;
    Ok(kept)
}

/// A UTC timestamp as [`crate::utc::now`] writes it, as a file name's digits.
pub fn file_stamp(utc: &str) -> String {
    utc.chars().filter(|c| *c != '-' && *c != ':').collect()
}

#[cfg(test)]
mod tests;
