//! Files written whole or not at all: the bytes go to a temporary file in the target's directory
//! (so the rename stays on one file system), which is flushed to disk (`fsync`) and then renamed
//! over the target. Readers see the old file or the new one, never a part; on failure the
//! temporary file is removed and the target is left as it was.
//!
//! ```
//! let dir = std::env::temp_dir().join(format!("ddpkit-util-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir)?;
//! let path = dir.join("result.json");
//! ddpkit_util::fs::write_atomic(&path, b"{}")?;
//! assert_eq!(std::fs::read(&path)?, b"{}");
//! # std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), std::io::Error>(())
//! ```
//!
//! The parent directory must exist. Temporary files are hidden (`.name.tmp-<pid>-<n>.ext`, the
//! extension kept for writers that choose a format by it, e.g. PNG encoders) and unique within
//! the process, so concurrent writers of distinct targets never meet.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Writes `bytes` to `path` atomically (see the module docs).
pub fn write_atomic(path: impl AsRef<Path>, bytes: impl AsRef<[u8]>) -> io::Result<()> {
    write_atomic_with(path, |w| w.write_all(bytes.as_ref()))
}

/// Writes to `path` atomically through `write`, which streams the contents into a buffered
/// writer of the temporary file (for data in several pieces that should not be joined first).
pub fn write_atomic_with<F>(path: impl AsRef<Path>, write: F) -> io::Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> io::Result<()>,
{
    write_atomic_at(path, |tmp| {
        let mut w = BufWriter::new(File::create(tmp)?);
        write(&mut w)?;
        w.into_inner().map_err(io::IntoInnerError::into_error)?.sync_all()
    })
}

/// Writes to `path` atomically through `write`, which creates the temporary file at the path it
/// is given (for libraries that only write to a path, e.g. image encoders). The file is synced
/// to disk after `write` returns.
pub fn write_atomic_at<E, F>(path: impl AsRef<Path>, write: F) -> Result<(), E>
where
    E: From<io::Error>,
    F: FnOnce(&Path) -> Result<(), E>,
{
    let path = path.as_ref();
    let tmp = temp_path(path)?;
    let result = write(&tmp).and_then(|()| {
        File::open(&tmp)?.sync_all()?;
        std::fs::rename(&tmp, path)?;
        Ok(())
    });
    match result {
        Ok(()) => {
            sync_parent(path);
            Ok(())
        }
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// `.name.tmp-<pid>-<n>.ext` next to `path` (see the module docs).
fn temp_path(path: &Path) -> io::Result<PathBuf> {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{} does not name a file", path.display()),
        )
    })?;
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let tag = format!("tmp-{}-{n}", std::process::id());
    let name = Path::new(name);
    let mut tmp = std::ffi::OsString::from(".");
    match (name.file_stem(), name.extension()) {
        (Some(stem), Some(ext)) => {
            tmp.push(stem);
            tmp.push(format!(".{tag}."));
            tmp.push(ext);
        }
        _ => {
            tmp.push(name);
            tmp.push(format!(".{tag}"));
        }
    }
    Ok(path.with_file_name(tmp))
}

/// Makes the rename itself durable where the platform allows (best effort: an error here
/// cannot undo a rename that has happened).
fn sync_parent(path: &Path) {
    #[cfg(unix)]
    {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
    }
    #[cfg(not(unix))]
    let _ = path;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory under the system's temporary directory, removed on drop.
    struct TempDir(PathBuf);

    impl TempDir {
        fn new(name: &str) -> Self {
            let dir = std::env::temp_dir().join(format!("ddpkit-util-{name}-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
            Self(dir)
        }

        fn entries(&self) -> Vec<String> {
            let mut v: Vec<String> = std::fs::read_dir(&self.0)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            v.sort();
            v
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    #[test]
    fn writes_and_replaces_leaving_no_temporary_file() {
        let dir = TempDir::new("replace");
        let path = dir.0.join("out.json");
        write_atomic(&path, b"first").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"first");
        write_atomic(&path, "second, longer").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "second, longer");
        write_atomic_with(&path, |w| {
            w.write_all(b"a")?;
            w.write_all(b"b")
        })
        .unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"ab");
        assert_eq!(dir.entries(), ["out.json"]);
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_removes_the_temporary_one() {
        let dir = TempDir::new("fail");
        let path = dir.0.join("table.csv");
        write_atomic(&path, b"old").unwrap();
        let e = write_atomic_with(&path, |w| {
            w.write_all(b"half of the new")?;
            Err(io::Error::other("disk on fire"))
        })
        .unwrap_err();
        assert_eq!(e.to_string(), "disk on fire");
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(dir.entries(), ["table.csv"]);
    }

    #[test]
    fn a_failed_rename_removes_the_temporary_file() {
        let dir = TempDir::new("rename");
        // The target is a non-empty directory: the rename over it fails.
        let path = dir.0.join("busy");
        std::fs::create_dir_all(path.join("inside")).unwrap();
        assert!(write_atomic(&path, b"x").is_err());
        assert_eq!(dir.entries(), ["busy"]);
    }

    #[test]
    fn path_writers_get_a_hidden_sibling_with_the_extension() {
        let dir = TempDir::new("at");
        let path = dir.0.join("figure.png");
        let mut seen = PathBuf::new();
        write_atomic_at(&path, |tmp: &Path| {
            seen = tmp.to_path_buf();
            std::fs::write(tmp, b"png bytes")
        })
        .unwrap();
        assert_eq!(seen.parent(), Some(dir.0.as_path()));
        let name = seen.file_name().unwrap().to_str().unwrap();
        assert!(name.starts_with(".figure.tmp-") && name.ends_with(".png"), "{name}");
        assert_eq!(std::fs::read(&path).unwrap(), b"png bytes");
        // An error of the writer's own type comes back as it is.
        let e: Result<(), Box<dyn std::error::Error>> = write_atomic_at(&path, |tmp: &Path| {
            std::fs::write(tmp, b"partial")?;
            Err("encoder failed".into())
        });
        assert_eq!(e.unwrap_err().to_string(), "encoder failed");
        assert_eq!(std::fs::read(&path).unwrap(), b"png bytes");
        assert_eq!(dir.entries(), ["figure.png"]);
    }

    #[test]
    fn temporary_names_are_unique_and_need_a_file_name() {
        let a = temp_path(Path::new("dir/data")).unwrap();
        let b = temp_path(Path::new("dir/data")).unwrap();
        assert_ne!(a, b);
        assert!(a.starts_with("dir") && a.file_name().unwrap().to_str().unwrap().starts_with(".data.tmp-"));
        assert!(temp_path(Path::new("/")).is_err());
        assert!(write_atomic("/", b"x").is_err());
    }
}
