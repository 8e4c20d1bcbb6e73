//! What the command-line tests of `hob` (frontends/cli/tests) and `hob-lab` (bench/lab/tests)
//! share: running a binary in the workspace's root, temporary files, typed edits of the
//! shipped TOML files (a key that is not there fails the test: the file changed), and the
//! check of a refusal. bench/lab/tests includes this file by path.
#![allow(dead_code, clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The workspace's root (both test crates sit two levels below it).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Runs `bin ARGS` in the workspace's root.
pub fn run(bin: &str, args: &[&str]) -> Output {
    Command::new(bin)
        .args(args)
        .current_dir(root())
        .output()
        .unwrap_or_else(|e| panic!("run {bin}: {e}"))
}

pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Writes `src` to a fresh file in this test process's temporary directory.
pub fn temp_file(name: &str, src: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hob-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join(name);
    std::fs::write(&path, src).expect("write file");
    path
}

/// A shipped file (path from the workspace's root), parsed.
pub fn toml_file(rel: &str) -> toml::Table {
    std::fs::read_to_string(root().join(rel))
        .unwrap()
        .parse()
        .unwrap()
}

/// The table holding the last part of a dotted key, and that part; panics if a part is missing.
fn parent<'a>(t: &'a mut toml::Table, key: &'a str) -> (&'a mut toml::Table, &'a str) {
    let mut parts: Vec<&str> = key.split('.').collect();
    let last = parts.pop().unwrap();
    let mut cur = t;
    for p in parts {
        cur = cur
            .get_mut(p)
            .and_then(toml::Value::as_table_mut)
            .unwrap_or_else(|| panic!("{key}: no table {p}"));
    }
    (cur, last)
}

/// Sets an existing dotted key.
pub fn set(t: &mut toml::Table, key: &str, v: toml::Value) {
    let (table, last) = parent(t, key);
    *table
        .get_mut(last)
        .unwrap_or_else(|| panic!("{key}: no such key")) = v;
}

/// Removes an existing dotted key.
pub fn remove(t: &mut toml::Table, key: &str) {
    let (table, last) = parent(t, key);
    table.remove(last).unwrap_or_else(|| panic!("{key}: no such key"));
}

/// A shipped file with typed edits, written to a temporary file.
pub fn edited(rel: &str, name: &str, edits: &[(&str, toml::Value)]) -> PathBuf {
    let mut t = toml_file(rel);
    for (key, v) in edits {
        set(&mut t, key, v.clone());
    }
    temp_file(name, &toml::to_string(&t).unwrap())
}

/// `bin ARGS` is refused: exit status 2, every needle on stderr, nothing on stdout.
pub fn assert_refused(bin: &str, args: &[&str], needles: &[&str]) {
    let out = run(bin, args);
    assert_eq!(
        out.status.code(),
        Some(2),
        "stdout {} stderr {}",
        text(&out.stdout),
        text(&out.stderr)
    );
    let err = text(&out.stderr);
    for n in needles {
        assert!(err.contains(n), "missing {n:?} in: {err}");
    }
    assert!(
        out.stdout.is_empty(),
        "nothing on stdout on a refusal: {}",
        text(&out.stdout)
    );
}
