//! Atomic file replacement: a reader sees the old file or the new one, never half of one.
//!
//! The bytes go to a temporary file in the same folder (a rename is atomic only within one file
//! system), which is flushed to disk and then renamed over the target; finally the folder itself
//! is flushed so that the rename survives a power cut. Without the first flush a crash could
//! leave the *new name* pointing at an empty or partial file on some file systems (ext4
//! `data=writeback`, XFS).

use std::ffi::OsString;
use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{ErrorKind, FormatError};

/// Distinguishes temporary files of concurrent writes within one process.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `bytes` to `path` atomically.
///
/// Steps: create `.<name>.<pid>.<n>.tmp` next to `path`, write, fsync, rename over `path`,
/// fsync the folder (errors of that last step are ignored: some platforms cannot open a folder).
/// On error the temporary file is removed and `path` is untouched. The new file gets default
/// permissions, not those of the file it replaces.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FormatError> {
    write_atomic_with(path, &mut |file| {
        file.write_all(bytes).map_err(|e| {
            FormatError::new(
                ErrorKind::Io,
                format!("cannot write {}: {e}", path.display()),
            )
        })
    })
}

/// Like [`write_atomic`], with the bytes written by `fill` into the temporary file (which it
/// may seek in): for outputs too large to hold. An error of `fill` removes the temporary file,
/// leaves `path` untouched and comes back as it is.
pub fn write_atomic_with(
    path: &Path,
    fill: &mut dyn FnMut(&mut File) -> Result<(), FormatError>,
) -> Result<(), FormatError> {
    let io_error = |what: &str, e: io::Error| {
        FormatError::new(
            ErrorKind::Io,
            format!("cannot write {}: {what}: {e}", path.display()),
        )
    };
    let name = path
        .file_name()
        .ok_or_else(|| io_error("not a file name", io::ErrorKind::InvalidInput.into()))?;
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let (tmp, mut file) =
        create_temporary(folder, name).map_err(|e| io_error("creating a temporary file", e))?;
    if let Err(e) = fill(&mut file) {
        drop(file);
        let _ = fs::remove_file(&tmp);
        return Err(e);
    }
    if let Err(e) = sync_and_rename(file, &tmp, path) {
        let _ = fs::remove_file(&tmp);
        return Err(io_error(&format!("via {}", tmp.display()), e));
    }
    if let Ok(dir) = File::open(folder) {
        let _ = dir.sync_all();
    }
    Ok(())
}

/// Creates a fresh temporary file next to the target; retries if a stale one has the same name.
fn create_temporary(folder: &Path, name: &std::ffi::OsStr) -> io::Result<(PathBuf, File)> {
    let mut last = io::Error::other("no attempt");
    for _ in 0..16 {
        let mut tmp_name = OsString::from(".");
        tmp_name.push(name);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        tmp_name.push(format!(".{}.{n}.tmp", std::process::id()));
        let tmp = folder.join(tmp_name);
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(file) => return Ok((tmp, file)),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last = e,
            Err(e) => return Err(e),
        }
    }
    Err(last)
}

fn sync_and_rename(file: File, tmp: &Path, path: &Path) -> io::Result<()> {
    file.sync_all()?;
    drop(file); // close before renaming: Windows refuses to rename an open file
    fs::rename(tmp, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch_folder(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("lrr-formats-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn listing(dir: &Path) -> Vec<OsString> {
        let mut names: Vec<OsString> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn replaces_and_leaves_no_temporaries() {
        let dir = scratch_folder("atomic");
        let path = dir.join("scene.lrr");
        write_atomic(&path, b"first version, longer").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"first version, longer");
        write_atomic(&path, b"second").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        write_atomic(&path, b"").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"");
        assert_eq!(listing(&dir), [OsString::from("scene.lrr")]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn failure_names_the_path_and_cleans_up() {
        let dir = scratch_folder("atomic-fail");
        // The target is a non-empty folder: the rename fails after the temporary was written.
        let path = dir.join("occupied");
        fs::create_dir_all(path.join("inside")).unwrap();
        let err = write_atomic(&path, b"data").unwrap_err();
        assert_eq!(err.kind, ErrorKind::Io);
        assert!(err.message.contains("occupied"), "{err}");
        assert_eq!(listing(&dir), [OsString::from("occupied")]);
        // A missing folder fails before anything is written.
        let err = write_atomic(&dir.join("missing/scene.lrr"), b"data").unwrap_err();
        assert!(err.message.contains("missing"), "{err}");
        fs::remove_dir_all(&dir).unwrap();
    }
}
