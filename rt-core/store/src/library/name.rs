//! The names of library entries: a name becomes the file `<name>.toml` in `programs/` or
//! `tools/`, so a name that is accepted can only ever be a plain, visible file in that
//! directory.

use std::fmt;

/// Longest accepted name, in characters.
pub const MAX_NAME_LEN: usize = 64;

/// Why a name is not accepted; its text follows the name (`name "a/b" has '/': ...`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NameError {
    Empty,
    /// A path separator: `/` or a backslash.
    Separator(char),
    /// Another character outside ASCII letters, digits, `-`, `_` and `.`.
    Character(char),
    /// Longer than [`MAX_NAME_LEN`]: its length in bytes (all ASCII: characters).
    TooLong(usize),
    /// Starts with `.`.
    Hidden,
    /// Has `..`.
    DotDot,
}

impl fmt::Display for NameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NameError::Empty => write!(f, "is empty"),
            NameError::Separator(c) => write!(f, "has {c:?}: a name is not a path"),
            NameError::Character(c) => write!(
                f,
                "has {c:?}: only ASCII letters, digits, '-', '_' and '.' are allowed"
            ),
            NameError::TooLong(n) => write!(f, "has {n} characters, at most {MAX_NAME_LEN} are allowed"),
            NameError::Hidden => write!(f, "starts with '.': that would be a hidden file"),
            NameError::DotDot => write!(f, "has \"..\": a name is not a path"),
        }
    }
}

impl std::error::Error for NameError {}

/// Accepts ASCII letters, digits, `-`, `_` and `.`, 1 ..= [`MAX_NAME_LEN`] characters, not
/// starting with `.` (no hidden file: `.` itself and the temporary files of
/// [`crate::atomic`] are hidden), without `..`; Err says why not.
pub fn check_name(name: &str) -> Result<(), NameError> {
    if name.is_empty() {
        return Err(NameError::Empty);
    }
    if let Some(c) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.')))
    {
        return Err(match c {
            '/' | '\\' => NameError::Separator(c),
            _ => NameError::Character(c),
        });
    }
    if name.len() > MAX_NAME_LEN {
        return Err(NameError::TooLong(name.len()));
    }
    if name.starts_with('.') {
        return Err(NameError::Hidden);
    }
    if name.contains("..") {
        return Err(NameError::DotDot);
    }
    Ok(())
}

/// The file name of an entry: `<name>.toml`.
pub fn file_name(name: &str) -> String {
    format!("{name}.toml")
}

/// The entry's name for a file name in the directory, if it is one (`<valid name>.toml`,
/// not hidden); temporary and foreign files are not entries.
pub fn entry_name(file_name: &str) -> Option<&str> {
    let name = file_name.strip_suffix(".toml")?;
    check_name(name).ok().map(|()| name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::path::{Component, Path, PathBuf};

    #[test]
    fn each_refusal_says_why() {
        for (name, why) in [
            ("", "is empty"),
            ("a/b", "'/': a name is not a path"),
            ("..\\x", "'\\\\': a name is not a path"),
            ("..", "hidden file"),
            (".", "hidden file"),
            (".hidden", "hidden file"),
            ("a..b", "\"..\""),
            ("hob m5", "' ': only ASCII letters"),
            ("hüb", "'ü'"),
        ] {
            let e = check_name(name).expect_err(name).to_string();
            assert!(e.contains(why), "{name:?}: {e}");
        }
        assert!(
            check_name(&"a".repeat(65))
                .expect_err("long")
                .to_string()
                .contains("65 characters")
        );
        for ok in ["hob-m5-a", "Spur_z17.v2", "a", &"a".repeat(64)] {
            assert_eq!(check_name(ok), Ok(()), "{ok}");
        }
    }

    #[test]
    fn each_refusal_reads_in_full() {
        for (name, text) in [
            ("", "is empty"),
            ("a/b", "has '/': a name is not a path"),
            ("a\\b", "has '\\\\': a name is not a path"),
            (
                "hob m5",
                "has ' ': only ASCII letters, digits, '-', '_' and '.' are allowed",
            ),
            (".x", "starts with '.': that would be a hidden file"),
            ("a..b", "has \"..\": a name is not a path"),
        ] {
            assert_eq!(check_name(name).expect_err(name).to_string(), text);
        }
        assert_eq!(
            check_name(&"a".repeat(65)),
            Err(NameError::TooLong(65)),
            "at most {MAX_NAME_LEN}"
        );
        assert_eq!(
            NameError::TooLong(65).to_string(),
            "has 65 characters, at most 64 are allowed"
        );
    }

    #[test]
    fn temporary_and_foreign_files_are_not_entries() {
        assert_eq!(entry_name("hob-m5-a.toml"), Some("hob-m5-a"));
        assert_eq!(entry_name(".hob-m5-a.toml.tmp.12.0"), None);
        assert_eq!(entry_name(".x.toml"), None);
        assert_eq!(entry_name("notes.txt"), None);
    }

    /// How a name's file left its directory or hid.
    #[derive(Debug, PartialEq)]
    enum Escape {
        /// The file's parent is not the directory.
        Parent(Option<PathBuf>),
        /// The file's path below the directory is not one visible file name.
        Components(Vec<String>),
    }

    /// Every way an accepted name's file could leave `dir` or be hidden.
    fn stays_inside(dir: &Path, name: &str) -> Result<(), Escape> {
        let path = dir.join(file_name(name));
        if path.parent() != Some(dir) {
            return Err(Escape::Parent(path.parent().map(Path::to_path_buf)));
        }
        let extra: Vec<Component> = path.components().skip(dir.components().count()).collect();
        match extra.as_slice() {
            [Component::Normal(f)] if !f.to_string_lossy().starts_with('.') => Ok(()),
            other => Err(Escape::Components(
                other.iter().map(|c| format!("{c:?}")).collect(),
            )),
        }
    }

    proptest! {
        #[test]
        fn no_accepted_name_escapes_or_hides(name in "[a-zA-Z0-9._/\\\\-]{0,70}|\\PC{0,70}") {
            if check_name(&name).is_ok() {
                let dir = Path::new("/var/lib/hob/library/programs");
                prop_assert_eq!(stays_inside(dir, &name), Ok(()));
                let file = file_name(&name);
                prop_assert_eq!(entry_name(&file), Some(name.as_str()));
            }
        }

        #[test]
        fn names_of_the_allowed_characters_are_accepted(name in "[a-zA-Z0-9_-][a-zA-Z0-9._-]{0,63}") {
            prop_assume!(!name.contains(".."));
            prop_assert_eq!(check_name(&name), Ok(()));
        }
    }

    #[test]
    fn the_containment_check_can_fail() {
        let dir = Path::new("/var/lib/hob/library/programs");
        for bad in ["../x", "a/b", ".hidden", "/etc/passwd"] {
            assert!(stays_inside(dir, bad).is_err(), "{bad}");
        }
    }
}
