//! The COMPENSATE screen's state and the parts of it that need no request: the `hob` CLI
//! it runs and the folder of the gear checker's files ([`Setup`]), what PREVIEW holds for
//! WRITE ([`Compensation`]), the folder's listing and the one check of a name the page sends
//! ([`checked_name`]), and a run of the CLI with its exit told apart ([`run_cli`]). The
//! routes are `crate::compensate`'s.

use crate::words::tr;
use serde::{Deserialize, Serialize};
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant, UNIX_EPOCH};

/// A run of `hob compensate` is killed after this long (a whole cut's log reads in seconds).
pub const RUN_LIMIT: Duration = Duration::from_secs(120);

/// What the screen was given at start-up.
#[derive(Debug, Clone)]
pub struct Setup {
    /// The `hob` CLI (`--hob`, or next to hob-hmi's own executable).
    pub hob: PathBuf,
    /// The folder of the checker's files (`--measurements-dir`); `None`: off.
    pub measurements_dir: Option<PathBuf>,
}

impl Setup {
    /// `hob` next to this process's executable (as installed, and in `target/release`).
    pub fn hob_beside_me() -> PathBuf {
        std::env::current_exe()
            .ok()
            .and_then(|e| e.parent().map(|p| p.join("hob")))
            .unwrap_or_else(|| PathBuf::from("hob"))
    }
}

/// What the page asks to compute: names only (a library program, the folder's files).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Request {
    /// The library program the gear was cut with.
    pub program: String,
    /// The checker's files, by name in the measurements folder, one per height.
    pub measurements: Vec<String>,
    /// The cut's cycles `[first, last]` in the log (`--cycles`); `None`: the newest run of
    /// hob-rt whole.
    #[serde(default)]
    pub cycles: Option<(u64, u64)>,
}

/// The screen's state on the server: the request PREVIEW held for WRITE, one run at a time.
#[derive(Debug)]
pub struct Compensation {
    pub setup: Setup,
    held: Mutex<Option<Request>>,
    /// A run under way (one at a time).
    pub(crate) busy: AtomicBool,
    /// Runs so far (each its own scratch folder).
    pub(crate) runs: AtomicU64,
}

impl Compensation {
    pub fn new(setup: Setup) -> Self {
        Self {
            setup,
            held: Mutex::new(None),
            busy: AtomicBool::new(false),
            runs: AtomicU64::new(0),
        }
    }

    /// What PREVIEW holds for WRITE.
    pub fn held(&self) -> std::sync::MutexGuard<'_, Option<Request>> {
        self.held
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

/// A checker's file in the folder, as the page lists it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FileEntry {
    pub name: String,
    /// Last modified, seconds since 1970 (the list is newest first).
    pub modified_unix_s: u64,
    pub bytes: u64,
}

/// The CSV files in `dir` (`.csv`, any case; no hidden file, no folder), newest first.
pub fn listing(dir: &Path) -> Result<Vec<FileEntry>, String> {
    let read = std::fs::read_dir(dir).map_err(|e| {
        tr(&format!(
            "the measurements folder {} cannot be read: {e}",
            dir.display()
        ))
    })?;
    let mut files: Vec<FileEntry> = read
        .filter_map(Result::ok)
        .filter_map(|e| {
            let name = e.file_name().to_str()?.to_string();
            let meta = e.metadata().ok()?;
            let csv = name.to_ascii_lowercase().ends_with(".csv");
            (csv && meta.is_file() && !name.starts_with('.')).then(|| FileEntry {
                modified_unix_s: meta
                    .modified()
                    .ok()
                    .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
                    .map_or(0, |d| d.as_secs()),
                bytes: meta.len(),
                name,
            })
        })
        .collect();
    files.sort_by(|a, b| {
        b.modified_unix_s
            .cmp(&a.modified_unix_s)
            .then_with(|| a.name.cmp(&b.name))
    });
    Ok(files)
}

/// The file `name` names in `dir`: only the bare name of a checker's file listed there (no
/// folder, no `..`, no absolute path), else refused in words.
pub fn checked_name(dir: &Path, name: &str) -> Result<PathBuf, String> {
    let plain = !name.is_empty()
        && !name.contains(['/', '\\', '\0'])
        && name != "."
        && name != ".."
        && !Path::new(name).is_absolute();
    if !plain {
        return Err(tr(&format!(
            "measurement {name:?}: only the name of a file in the measurements folder {} is taken (no folder, no .., no absolute path); nothing was read",
            dir.display()
        )));
    }
    if !listing(dir)?.iter().any(|f| f.name == name) {
        return Err(tr(&format!(
            "measurement {name:?}: no such checker's file (.csv) in the measurements folder {}; nothing was read",
            dir.display()
        )));
    }
    Ok(dir.join(name))
}

/// What a run of the CLI ended with.
#[derive(Debug, Clone, PartialEq)]
pub enum Ran {
    /// Exit 0: its standard output.
    Done(String),
    /// Exit 2: its refusal (standard error), word for word.
    Refused(String),
    /// Anything else, in words.
    Failed(String),
}

/// Runs `hob` with `args`, killed after `limit`; blocking (call it off the runtime).
pub fn run_cli(hob: &Path, args: &[OsString], limit: Duration) -> Ran {
    static RUNS: AtomicU64 = AtomicU64::new(0);
    let n = RUNS.fetch_add(1, Ordering::SeqCst);
    let dir = std::env::temp_dir().join(format!("hob-hmi-cli-{}-{n}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let (out, err) = (dir.join("stdout.txt"), dir.join("stderr.txt"));
    let files = std::fs::File::create(&out).and_then(|o| Ok((o, std::fs::File::create(&err)?)));
    let spawned = files.and_then(|(o, e)| {
        std::process::Command::new(hob)
            .args(args)
            .stdin(std::process::Stdio::null())
            .stdout(o)
            .stderr(e)
            .spawn()
    });
    let mut child = match spawned {
        Ok(c) => c,
        Err(e) => return Ran::Failed(format!("{} could not be run: {e}", hob.display())),
    };
    let started = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(s)) => break Ok(s),
            Ok(None) if started.elapsed() < limit => std::thread::sleep(Duration::from_millis(20)),
            Ok(None) => {
                let _ = child.kill();
                let _ = child.wait();
                break Err(format!(
                    "hob compensate took over {} s and was stopped",
                    limit.as_secs()
                ));
            }
            Err(e) => break Err(e.to_string()),
        }
    };
    let read = |f: &Path| std::fs::read_to_string(f).unwrap_or_default();
    let (stdout, stderr) = (read(&out), read(&err));
    let _ = std::fs::remove_dir_all(&dir);
    match status {
        Ok(s) if s.success() => Ran::Done(stdout),
        Ok(s) if s.code() == Some(2) => Ran::Refused(stderr.trim_end().to_string()),
        Ok(s) => Ran::Failed(format!("hob compensate failed ({s}): {}", stderr.trim_end())),
        Err(why) => Ran::Failed(why),
    }
}

/// Why the screen is off: no folder given.
pub fn no_folder() -> String {
    tr(
        "hob-hmi was started without --measurements-dir: no folder of the checker's files (a USB stick's mount or a share) to read",
    )
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
pub(crate) mod tests {
    use super::*;

    /// A fresh scratch folder of this test process (the compensation screen's tests).
    pub(crate) fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("hob-hmi-comp-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn only_the_bare_name_of_a_listed_csv_is_taken() {
        let d = scratch("names");
        std::fs::write(d.join("gear-1.csv"), "x").unwrap();
        std::fs::write(d.join("notes.txt"), "x").unwrap();
        std::fs::write(d.join(".hidden.csv"), "x").unwrap();
        std::fs::create_dir_all(d.join("sub.csv")).unwrap();
        assert_eq!(checked_name(&d, "gear-1.csv"), Ok(d.join("gear-1.csv")));
        for bad in [
            "",
            ".",
            "..",
            "../gear-1.csv",
            "/etc/passwd",
            "sub.csv/x.csv",
            "a\\b.csv",
        ] {
            let e = checked_name(&d, bad).unwrap_err();
            assert!(e.contains("only the name of a file"), "{bad:?}: {e}");
        }
        for absent in ["notes.txt", ".hidden.csv", "sub.csv", "gear-2.csv"] {
            let e = checked_name(&d, absent).unwrap_err();
            assert!(e.contains("no such checker's file"), "{absent:?}: {e}");
        }
        let names: Vec<String> = listing(&d).unwrap().into_iter().map(|f| f.name).collect();
        assert_eq!(names, ["gear-1.csv"]);
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn the_cli_s_exit_codes_are_told_apart() {
        let d = scratch("cli");
        let sh = |body: &str| vec![OsString::from("-c"), OsString::from(body)];
        let run = |body: &str| run_cli(Path::new("/bin/sh"), &sh(body), Duration::from_secs(10));
        assert_eq!(run("echo found; exit 0"), Ran::Done("found\n".into()));
        assert_eq!(
            run("echo 'hob: refused: x.csv: gear' >&2; exit 2"),
            Ran::Refused("hob: refused: x.csv: gear".into())
        );
        assert!(matches!(run("echo broke >&2; exit 1"), Ran::Failed(t) if t.contains("broke")));
        let slow = run_cli(Path::new("/bin/sh"), &sh("sleep 5"), Duration::from_millis(200));
        assert!(
            matches!(&slow, Ran::Failed(t) if t.contains("was stopped")),
            "{slow:?}"
        );
        let none = run_cli(&d.join("no-hob"), &[], Duration::from_secs(1));
        assert!(
            matches!(&none, Ran::Failed(t) if t.contains("could not be run")),
            "{none:?}"
        );
        let _ = std::fs::remove_dir_all(&d);
    }
}
