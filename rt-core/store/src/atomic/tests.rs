//! A crash between the write and the rename loses nothing: a child process (this test
//! binary, run again for the ignored test `crash_child`) writes new content and stops at
//! the pause point right before the rename; the parent kills it there with SIGKILL and
//! checks the old file. The same check run on a writer that writes in place (truncate,
//! write) reports the loss: the test can fail.
#![allow(clippy::unwrap_used)]

use super::*;
use crate::machine_state::{self, Loaded, MachineState};
use crate::test_dir;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Set in the child only: the file it creates when it reaches the pause point.
const PAUSE_MARKER: &str = "HOB_STORE_TEST_PAUSE_MARKER";
/// Set in the child only: the file to write, and `atomic` or `in-place`.
const CHILD_TARGET: &str = "HOB_STORE_TEST_TARGET";
const CHILD_WRITER: &str = "HOB_STORE_TEST_WRITER";

/// Called by `write_atomic` (test builds only) between the write and the rename: in the
/// child, says so and waits to be killed; elsewhere nothing.
pub(super) fn pause_before_rename(_tmp: &Path) {
    if let Some(marker) = std::env::var_os(PAUSE_MARKER) {
        std::fs::write(marker, b"paused\n").unwrap();
        loop {
            std::thread::sleep(Duration::from_secs(60));
        }
    }
}

/// The naive writer the test must catch: truncate the target, write half, (pause), write
/// the rest.
fn write_in_place(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut f = File::create(path)?;
    let half = bytes.len() / 2;
    f.write_all(&bytes[..half])?;
    f.sync_all()?;
    pause_before_rename(path);
    f.write_all(&bytes[half..])?;
    f.sync_all()
}

fn state(x_offset_mm: f64) -> MachineState {
    MachineState {
        format_version: machine_state::FORMAT_VERSION,
        x_offset_mm,
        y_offset_mm: 1.5,
        set_at_utc: "2025-03-01T08:15:00Z".into(),
        gauge_diameter_mm: Some(40.0),
        gauge_height_mm: Some(100.0),
        note: None,
    }
}

fn old_state() -> MachineState {
    state(0.125)
}

fn new_state() -> MachineState {
    let mut s = state(-7.75);
    s.note = Some("the new calibration, longer than the old one".into());
    s
}

#[test]
#[ignore = "the child process of crash_between_write_and_rename_loses_nothing"]
fn crash_child() {
    // Run by hand (no target given) it has nothing to do.
    let Some(target) = std::env::var_os(CHILD_TARGET) else {
        return;
    };
    let text = new_state().to_toml();
    let path = Path::new(&target);
    match std::env::var(CHILD_WRITER).as_deref() {
        Ok("in-place") => write_in_place(path, text.as_bytes()).unwrap(),
        _ => write_atomic(path, text.as_bytes()).unwrap(),
    }
    panic!("the write finished: the parent should have killed this process at the pause point");
}

/// Writes the old state, has a child process write the new one with `writer` and kills it
/// at the pause point; Err says what was lost.
fn crash_mid_write(dir: &Path, writer: &str) -> Result<(), String> {
    let target = dir.join("machine-state.toml");
    let marker = dir.join("child-paused");
    old_state().save(&target).unwrap();
    let old_text = std::fs::read_to_string(&target).unwrap();
    let mut child = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "atomic::tests::crash_child",
            "--ignored",
            "--nocapture",
        ])
        .env(PAUSE_MARKER, &marker)
        .env(CHILD_TARGET, &target)
        .env(CHILD_WRITER, writer)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    while !marker.exists() {
        if let Some(status) = child.try_wait().unwrap() {
            return Err(format!("the child ended ({status}) before the pause point"));
        }
        assert!(
            Instant::now() < deadline,
            "the child did not reach the pause point in 30 s"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL: no destructor, no flush, no clean-up runs
    child.wait().unwrap();
    let now = std::fs::read_to_string(&target).map_err(|e| format!("old file gone: {e}"))?;
    if now != old_text {
        return Err(format!("old content lost: the file holds {now:?}"));
    }
    match machine_state::load(&target) {
        Ok(Loaded::Calibrated(s)) if s == old_state() => Ok(()),
        other => Err(format!("the old state does not load: {other:?}")),
    }
}

fn hidden_files(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| is_temporary(&p.file_name().unwrap().to_string_lossy()))
        .collect()
}

#[test]
fn crash_between_write_and_rename_loses_nothing() {
    let dir = test_dir("crash-atomic");
    crash_mid_write(&dir, "atomic").unwrap();
    // The child had written the whole new content: it is in the temporary file it left.
    let left = hidden_files(&dir);
    assert_eq!(left.len(), 1, "{left:?}");
    assert_eq!(std::fs::read_to_string(&left[0]).unwrap(), new_state().to_toml());
    // The next write succeeds, and the state loads as written.
    let target = dir.join("machine-state.toml");
    new_state().save(&target).unwrap();
    assert_eq!(
        machine_state::load(&target).unwrap(),
        Loaded::Calibrated(new_state())
    );
}

#[test]
fn the_crash_test_catches_a_write_in_place() {
    let dir = test_dir("crash-in-place");
    let e = crash_mid_write(&dir, "in-place").unwrap_err();
    assert!(e.contains("old content lost"), "{e}");
}

#[test]
fn write_new_and_rename_new_replace_nothing() {
    let dir = test_dir("atomic-new");
    let (a, b) = (dir.join("a.toml"), dir.join("b.toml"));
    write_new(&a, b"a").unwrap();
    assert_eq!(
        write_new(&a, b"again").unwrap_err().kind(),
        io::ErrorKind::AlreadyExists
    );
    write_new(&b, b"b").unwrap();
    assert_eq!(
        rename_new(&a, &b).unwrap_err().kind(),
        io::ErrorKind::AlreadyExists
    );
    assert_eq!(std::fs::read(&a).unwrap(), b"a");
    assert_eq!(std::fs::read(&b).unwrap(), b"b");
    let c = dir.join("c.toml");
    rename_new(&a, &c).unwrap();
    assert!(!a.exists());
    assert_eq!(std::fs::read(&c).unwrap(), b"a");
    remove(&c).unwrap();
    assert!(!c.exists());
    assert!(hidden_files(&dir).is_empty(), "no temporary file left");
}
