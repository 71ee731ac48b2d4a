//! Whole files: bounded reads, atomic writes (model files, checkpoints),
//! and whether a write may replace an existing file.

use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{invalid, Error, Result};

/// Whether a writer may replace an existing file (model files, trajectory
/// CSV). Default [`CreateNew`](Self::CreateNew): nothing the user has is
/// replaced without asking.
///
/// ```
/// use metriplectic_runtime::WriteMode;
/// assert_eq!(WriteMode::default(), WriteMode::CreateNew);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WriteMode {
    /// Fail with [`Error::FileExists`] if the file exists.
    #[default]
    CreateNew,
    /// Replace an existing file.
    Overwrite,
}

/// Reads `path` as UTF-8 text, refusing files larger than `limit` bytes.
///
/// The limit is enforced while reading, not only from the metadata, so a
/// special file (a pipe, `/dev/zero`) or a file growing under us cannot
/// exhaust memory either.
pub(crate) fn read_capped(path: &Path, limit: u64, what: &str) -> Result<String> {
    let io = |source| Error::Io {
        path: path.to_owned(),
        source,
    };
    let too_large = |size| Error::FileTooLarge {
        path: path.to_owned(),
        what: what.to_owned(),
        size,
        limit,
    };
    let file = File::open(path).map_err(io)?;
    let size = file.metadata().map_err(io)?.len();
    if size > limit {
        return Err(too_large(size));
    }
    let mut bytes = Vec::with_capacity(usize::try_from(size).unwrap_or(0));
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64));
    }
    String::from_utf8(bytes).map_err(|e| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("{what} is not UTF-8 text: {e}"),
        ))
    })
}

/// Writes `bytes` to `path` so that nothing is ever half-written: a reader
/// (or a crash, or a full disk) sees either the previous file or the
/// complete new one. [`WriteMode::CreateNew`] refuses an existing file with
/// [`Error::FileExists`]; [`WriteMode::Overwrite`] replaces it, keeping its
/// permissions, and replaces the file a symbolic link points to rather than
/// the link; a read-only file is refused ([`Error::Io`], permission denied). The
/// directory must exist; a `path` that is a directory is
/// [`Error::InvalidArgument`], any other failure [`Error::Io`].
///
/// The bytes go to a temporary file in the same directory (same file
/// system), are flushed to disk, and only then take the name: by an atomic
/// rename when overwriting, by a hard link (which fails if the name exists)
/// when creating. On file systems without hard links the new file is
/// created exclusively and filled, and removed again if writing fails.
///
/// ```
/// use metriplectic_runtime::{write_file, Error, WriteMode};
/// let path = std::env::temp_dir().join(format!("write-file-doc-{}.txt", std::process::id()));
/// write_file(&path, b"first", WriteMode::CreateNew)?;
/// assert!(matches!(
///     write_file(&path, b"again", WriteMode::CreateNew),
///     Err(Error::FileExists { .. })
/// ));
/// write_file(&path, b"second", WriteMode::Overwrite)?;
/// assert_eq!(std::fs::read_to_string(&path).unwrap(), "second");
/// # std::fs::remove_file(&path).unwrap();
/// # Ok::<(), Error>(())
/// ```
pub fn write_file(path: &Path, bytes: &[u8], mode: WriteMode) -> Result<()> {
    let io = |path: &Path| {
        let path = path.to_owned();
        move |source| Error::Io { path, source }
    };
    if path.is_dir() {
        return Err(invalid(
            "file path",
            format!(
                "{} is a directory; give the name of a file inside it",
                path.display()
            ),
        ));
    }
    // Overwriting a symbolic link replaces the file it points to, not the
    // link; a read-only file is not replaced, and a replaced file keeps its
    // permissions.
    let resolved;
    let (path, existing) = match (mode, std::fs::symlink_metadata(path)) {
        (WriteMode::Overwrite, Ok(meta)) => {
            let path = if meta.file_type().is_symlink() {
                resolved = link_target(path).map_err(io(path))?;
                resolved.as_path()
            } else {
                path
            };
            match std::fs::metadata(path) {
                // A dangling link: its target is created.
                Err(error) if error.kind() == std::io::ErrorKind::NotFound => (path, None),
                Err(error) => return Err(io(path)(error)),
                Ok(meta) if meta.permissions().readonly() => {
                    return Err(io(path)(std::io::Error::new(
                        std::io::ErrorKind::PermissionDenied,
                        "the file is read-only; refusing to replace it (make it writable to overwrite it)",
                    )))
                }
                Ok(meta) => (path, Some(meta.permissions())),
            }
        }
        _ => (path, None),
    };
    let temporary = temporary_beside(path)?;
    // A fresh file, never an existing one or a symbolic link's target: the
    // name is only unlikely to be taken, and what is there is not ours.
    let mut file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temporary)
        .map_err(io(path))?;
    let written = (|| {
        file.write_all(bytes)?;
        if let Some(permissions) = existing {
            file.set_permissions(permissions)?;
        }
        file.sync_all()
    })();
    if let Err(source) = written {
        let _ = std::fs::remove_file(&temporary);
        return Err(io(path)(source));
    }
    let placed = match mode {
        WriteMode::Overwrite => std::fs::rename(&temporary, path),
        WriteMode::CreateNew => match std::fs::hard_link(&temporary, path) {
            Err(error) if error.kind() != std::io::ErrorKind::AlreadyExists => {
                write_exclusively(path, bytes)
            }
            other => other,
        },
    };
    let _ = std::fs::remove_file(&temporary);
    match placed {
        Err(source) if source.kind() == std::io::ErrorKind::AlreadyExists => {
            return Err(Error::FileExists {
                path: path.to_owned(),
            })
        }
        Err(source) => return Err(io(path)(source)),
        Ok(()) => {}
    }
    // Persist the new name (the directory entry); best effort, since not
    // every platform can open a directory for syncing.
    if let Some(directory) = path.parent() {
        let directory = if directory.as_os_str().is_empty() {
            Path::new(".")
        } else {
            directory
        };
        if let Ok(directory) = File::open(directory) {
            let _ = directory.sync_all();
        }
    }
    Ok(())
}

/// The file the symbolic link `path` points to, through any chain of links,
/// whether or not it exists yet.
fn link_target(path: &Path) -> std::io::Result<PathBuf> {
    let mut current = path.to_path_buf();
    // Bounded like the kernel's own loop limit.
    for _ in 0..40 {
        if !std::fs::symlink_metadata(&current).is_ok_and(|m| m.file_type().is_symlink()) {
            return Ok(current);
        }
        let target = std::fs::read_link(&current)?;
        current = match current.parent() {
            Some(parent) if target.is_relative() => parent.join(target),
            _ => target,
        };
    }
    Err(std::io::Error::other("too many levels of symbolic links"))
}

/// Bytes of the target's name a temporary name keeps: with its dot and
/// suffix (at most 42 bytes) it stays within the 255 bytes most file
/// systems allow, so a name that is valid there gets a valid temporary
/// (a 250-byte name failed with "File name too long" before).
const TEMPORARY_NAME_PREFIX: usize = 200;

/// A fresh temporary name next to `path`: hidden, with the process id and
/// a per-process counter so that concurrent writers never share one.
fn temporary_beside(path: &Path) -> Result<PathBuf> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path.file_name().ok_or_else(|| {
        invalid(
            "file path",
            format!("{} does not name a file", path.display()),
        )
    })?;
    // Only a hint of the target for whoever finds a leftover: lossy and
    // shortened on a character boundary.
    let mut prefix = String::new();
    for c in name.to_string_lossy().chars() {
        if prefix.len() + c.len_utf8() > TEMPORARY_NAME_PREFIX {
            break;
        }
        prefix.push(c);
    }
    let mut temporary_name = std::ffi::OsString::from(".");
    temporary_name.push(prefix);
    temporary_name.push(format!(
        ".tmp-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    Ok(path.with_file_name(temporary_name))
}

/// Creates `path` (failing if it exists) and fills it; removes it again if
/// filling fails, so no partial file is left under the name.
fn write_exclusively(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut file = OpenOptions::new().write(true).create_new(true).open(path)?;
    let filled = file.write_all(bytes).and_then(|()| file.sync_all());
    if filled.is_err() {
        let _ = std::fs::remove_file(path);
    }
    filled
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!(
            "metriplectic-file-io-{}-{name}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = scratch("atomic");
        let path = dir.join("state.json");
        write_file(&path, b"first", WriteMode::CreateNew).unwrap();
        assert!(matches!(
            write_file(&path, b"other", WriteMode::CreateNew),
            Err(Error::FileExists { .. })
        ));
        write_file(&path, b"second", WriteMode::Overwrite).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "second");
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("state.json")]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A name of 255 bytes, the longest most file systems allow, is written
    /// (its temporary name was longer than the limit; a probe).
    #[test]
    fn the_longest_file_names_are_written() {
        let dir = scratch("long-name");
        let path = dir.join(format!("{}.json", "é".repeat(125)));
        assert_eq!(path.file_name().unwrap().len(), 255);
        write_file(&path, b"first", WriteMode::CreateNew).unwrap();
        write_file(&path, b"second", WriteMode::Overwrite).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A probe's overwrite made a read-only file writable (0444 → 0644) and
    /// replaced a symbolic link by a file, leaving the link's target as it was.
    #[cfg(unix)]
    #[test]
    fn overwriting_keeps_permissions_follows_links_and_spares_read_only_files() {
        use std::os::unix::fs::{symlink, PermissionsExt};
        let dir = scratch("permissions");
        let path = dir.join("model.json");
        let _ = std::fs::remove_file(&path);
        write_file(&path, b"first", WriteMode::CreateNew).unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).unwrap();
        write_file(&path, b"second", WriteMode::Overwrite).unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600);

        let link = dir.join("link.json");
        let _ = std::fs::remove_file(&link);
        symlink(&path, &link).unwrap();
        write_file(&link, b"through the link", WriteMode::Overwrite).unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read(&path).unwrap(), b"through the link");

        // A dangling link: the file it names is created.
        let dangling = dir.join("dangling.json");
        let _ = std::fs::remove_file(&dangling);
        symlink(dir.join("new.json"), &dangling).unwrap();
        write_file(&dangling, b"new", WriteMode::Overwrite).unwrap();
        assert_eq!(std::fs::read(dir.join("new.json")).unwrap(), b"new");

        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o444)).unwrap();
        let error = write_file(&path, b"third", WriteMode::Overwrite).unwrap_err();
        assert!(error.to_string().contains("read-only"), "{error}");
        assert_eq!(std::fs::read(&path).unwrap(), b"through the link");
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn capped_read_refuses_large_and_endless_files() {
        let dir = scratch("capped");
        let path = dir.join("big.json");
        std::fs::write(&path, vec![b' '; 101]).unwrap();
        assert!(matches!(
            read_capped(&path, 100, "a test file"),
            Err(Error::FileTooLarge {
                size: 101,
                limit: 100,
                ..
            })
        ));
        assert_eq!(read_capped(&path, 101, "a test file").unwrap().len(), 101);
        std::fs::remove_dir_all(&dir).unwrap();
        // A character device reports size 0 and never ends.
        let zero = Path::new("/dev/zero");
        if zero.exists() {
            assert!(matches!(
                read_capped(zero, 1 << 20, "a test file"),
                Err(Error::FileTooLarge { limit, .. }) if limit == 1 << 20
            ));
        }
    }
}
