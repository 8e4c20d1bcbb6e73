//! A file replaced whole or not at all.
//!
//! [`write_atomic`] writes a temporary file in the target's directory (hidden:
//! `.NAME.tmp.PID.N`), `sync_all`s it, renames it over the target and `fsync`s the
//! directory, so that after a crash or power loss at any point the target holds either
//! its old content or the new one. A crash before the rename leaves the temporary file
//! behind: readers ignore hidden files ([`is_temporary`]), and the next write uses a new
//! name. [`write_new`] is the same for a file that must not exist yet (a hard link in place
//! of the rename: it fails if the target exists).

use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Temporary files of this process get distinct names.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// Replaces `path` with `bytes`, atomically and durably.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let tmp = write_temporary(path, bytes)?;
    #[cfg(test)]
    tests::pause_before_rename(&tmp);
    if let Err(e) = std::fs::rename(&tmp, path) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    sync_dir(path)
}

/// Creates `path` with `bytes`, atomically and durably; fails with
/// [`io::ErrorKind::AlreadyExists`] if it exists (nothing is replaced).
pub fn write_new(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let tmp = write_temporary(path, bytes)?;
    let linked = std::fs::hard_link(&tmp, path);
    let _ = std::fs::remove_file(&tmp);
    linked?;
    sync_dir(path)
}

/// Renames `from` to `to` in the same directory; fails with
/// [`io::ErrorKind::AlreadyExists`] if `to` exists (nothing is replaced).
pub fn rename_new(from: &Path, to: &Path) -> io::Result<()> {
    std::fs::hard_link(from, to)?;
    std::fs::remove_file(from)?;
    sync_dir(to)
}

/// Removes `path` durably.
pub fn remove(path: &Path) -> io::Result<()> {
    std::fs::remove_file(path)?;
    sync_dir(path)
}

/// Whether a file name is one of [`write_atomic`]'s temporary files (or any hidden file):
/// readers skip them.
pub fn is_temporary(file_name: &str) -> bool {
    file_name.starts_with('.')
}

fn write_temporary(path: &Path, bytes: &[u8]) -> io::Result<PathBuf> {
    let name = path.file_name().and_then(|n| n.to_str()).ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{}: no file name", path.display()),
        )
    })?;
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp = path.with_file_name(format!(".{name}.tmp.{}.{n}", std::process::id()));
    let result = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .and_then(|mut f| {
            f.write_all(bytes)?;
            f.sync_all()
        });
    match result {
        Ok(()) => Ok(tmp),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// `fsync` of the directory holding `path`: the rename (or link, or removal) survives a
/// power loss.
fn sync_dir(path: &Path) -> io::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    File::open(dir)?.sync_all()
}

#[cfg(test)]
mod tests;
