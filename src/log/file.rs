//! The files a run writes and reads: which output paths are refused, and
//! the advisory locks that keep two processes from writing one log.
//!
//! A log is written to `<path>.partial` under an exclusive lock (`flock`)
//! held until the writer closes; a second writer finds it locked and is
//! refused. A resumed run holds a shared lock on the log it reads, so that
//! a log still being written is not resumed from.

use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};

use super::{LogError, StorageFailure, partial_path};

/// Why an output path is refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum OutputError {
    /// The path names a directory, or ends in a separator.
    #[error("{}: names a directory, not a file", .0.display())]
    Directory(PathBuf),
    /// The directory to write in does not exist.
    #[error("{}: the directory {} does not exist", .0.display(), .1.display())]
    NoDirectory(PathBuf, PathBuf),
    /// The directory to write in is read-only.
    #[error("{}: the directory {} is read-only", .0.display(), .1.display())]
    ReadOnly(PathBuf, PathBuf),
    /// Something other than a regular file is there (a device, a FIFO, a
    /// socket): it is never replaced.
    #[error("{}: exists and is not a regular file (a device, FIFO or socket); refusing to replace it", .0.display())]
    NotRegular(PathBuf),
    /// A symbolic link is where a file of the run's own would be written
    /// (a `.partial` file): it is never written through, since its target
    /// may be anyone's file.
    #[error("{}: is a symbolic link; refusing to write through it (remove the link or choose another output path)", .0.display())]
    Link(PathBuf),
    /// Writing there would overwrite an input of the same command.
    #[error("{}: is the input {}; refusing to overwrite it (choose another output path)", .0.display(), .1.display())]
    IsInput(PathBuf, PathBuf),
    /// The file could not be created or written (the reason given).
    #[error("{}: {}", .0.display(), .1)]
    Create(PathBuf, String),
    /// The file system could not take the file: full, over quota or
    /// read-only (the reason given).
    #[error("{}: {}", .0.display(), .1)]
    Storage(PathBuf, String),
}

impl OutputError {
    /// The failure `e` of creating or writing `path`, a full or read-only
    /// file system told from a refusal of the path.
    pub fn io(path: &Path, e: &std::io::Error) -> Self {
        let reason = super::io_reason(e);
        if e.kind().is_storage_failure() {
            OutputError::Storage(path.to_path_buf(), reason)
        } else {
            OutputError::Create(path.to_path_buf(), reason)
        }
    }
}

impl StorageFailure for OutputError {
    fn is_storage_failure(&self) -> bool {
        matches!(self, OutputError::Storage(..))
    }
}

/// Whether `path` may be written as a command's output (directly or
/// through `<path>.partial`, which is checked too when `partial` is set)
/// without damaging any of `inputs`.
pub fn check_output(path: &Path, partial: bool, inputs: &[&Path]) -> Result<(), OutputError> {
    let text = path.as_os_str().to_string_lossy();
    if text.is_empty() || text.ends_with('/') || path.is_dir() {
        return Err(OutputError::Directory(path.to_path_buf()));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(OutputError::NoDirectory(path.to_path_buf(), dir));
    }
    if std::fs::metadata(&dir).is_ok_and(|m| m.permissions().readonly()) {
        return Err(OutputError::ReadOnly(path.to_path_buf(), dir));
    }
    let mut written = vec![path.to_path_buf()];
    if partial {
        written.push(partial_path(path));
    }
    if partial && is_link(&written[1]) {
        return Err(OutputError::Link(written[1].clone()));
    }
    for target in &written {
        if let Ok(meta) = std::fs::metadata(target) {
            if !meta.is_file() {
                return Err(OutputError::NotRegular(target.clone()));
            }
            if let Some(input) = inputs.iter().find(|i| same_file(target, i)) {
                return Err(OutputError::IsInput(target.clone(), input.to_path_buf()));
            }
        }
    }
    Ok(())
}

/// Whether `path` may be read as an input (a log or a scene): a regular
/// file, or a link to one. A FIFO would block the read and a device such
/// as /dev/zero never end it; the refusal says which.
pub fn check_input(path: &Path) -> Result<(), InputError> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(InputError::Directory),
        Ok(m) if !m.is_file() => Err(InputError::NotRegular),
        _ => Ok(()),
    }
}

/// Why an input path is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum InputError {
    /// A directory.
    #[error("is a directory, not a file")]
    Directory,
    /// A device, FIFO or socket.
    #[error(
        "is not a regular file (a device, FIFO or socket); hardbody reads logs and scenes only from regular files"
    )]
    NotRegular,
}

/// Whether `path` is a symbolic link (to anything, or dangling).
pub fn is_link(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink())
}

/// Creates `path` as a new, empty regular file of this process, for a
/// temporary file a result is written to before it is renamed into
/// place: a stale regular file there is removed first, and anything else
/// (a symbolic link above all, whose target may be anyone's file) is
/// refused. The file is created exclusively, so a link planted there
/// meanwhile makes the creation fail rather than be followed.
pub fn create_fresh(path: &Path) -> Result<File, OutputError> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => return Err(OutputError::Link(path.to_path_buf())),
        Ok(m) if !m.is_file() => return Err(OutputError::NotRegular(path.to_path_buf())),
        Ok(_) => {
            let _ = std::fs::remove_file(path);
        }
        Err(_) => {}
    }
    OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
        .map_err(|e| OutputError::io(path, &e))
}

/// Writes `bytes` to `path` through `<path>.partial` (made by
/// [`create_fresh`]) renamed into place: `path` is never left half
/// written, and neither it nor the temporary file is written through a
/// symbolic link (a link at `path` itself is replaced, its target left
/// alone).
pub fn write_replacing(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    use std::io::Write;
    let partial = partial_path(path);
    let fail = |e: std::io::Error| {
        let _ = std::fs::remove_file(&partial);
        OutputError::io(path, &e)
    };
    let mut file = create_fresh(&partial)?;
    file.write_all(bytes).map_err(fail)?;
    file.sync_all().map_err(fail)?;
    drop(file);
    std::fs::rename(&partial, path).map_err(fail)
}

/// Whether two paths name one existing file.
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (std::fs::metadata(a), std::fs::metadata(b)) {
            (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
            (Ok(x), Ok(y)) => x == y,
            _ => false,
        }
    }
}

/// Opens `path` for writing under an exclusive lock, emptied; refused
/// with [`LogError::Busy`] while another process holds the lock. The
/// lock is checked to be on the file the path names when it is taken (a
/// writer that finished may have renamed the file it locked).
pub(crate) fn create_locked(path: &Path) -> Result<File, LogError> {
    let io = |source| LogError::Io {
        path: path.to_path_buf(),
        source,
    };
    let refused = |e: OutputError| LogError::Content {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    if is_link(path) {
        return Err(refused(OutputError::Link(path.to_path_buf())));
    }
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
        return Err(refused(OutputError::NotRegular(path.to_path_buf())));
    }
    for _ in 0..16 {
        let mut options = OpenOptions::new();
        options.write(true).create(true).truncate(false);
        // A link planted after the check above is not followed either.
        #[cfg(unix)]
        std::os::unix::fs::OpenOptionsExt::custom_flags(&mut options, libc::O_NOFOLLOW);
        let file = options.open(path).map_err(|e| {
            if is_link(path) {
                refused(OutputError::Link(path.to_path_buf()))
            } else {
                io(e)
            }
        })?;
        match file.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                return Err(LogError::Busy {
                    path: path.to_path_buf(),
                });
            }
            Err(std::fs::TryLockError::Error(e)) => return Err(io(e)),
        }
        if is_named_by(&file, path) {
            file.set_len(0).map_err(io)?;
            return Ok(file);
        }
    }
    Err(LogError::Busy {
        path: path.to_path_buf(),
    })
}

/// Takes a shared lock on the log at `path` for as long as the returned
/// file is open: refused with [`LogError::Busy`] while a writer holds it.
pub(crate) fn lock_for_reading(path: &Path) -> Result<File, LogError> {
    let file = File::open(path).map_err(|source| LogError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    match file.try_lock_shared() {
        Ok(()) => Ok(file),
        Err(std::fs::TryLockError::WouldBlock) => Err(LogError::Busy {
            path: path.to_path_buf(),
        }),
        Err(std::fs::TryLockError::Error(source)) => Err(LogError::Io {
            path: path.to_path_buf(),
            source,
        }),
    }
}

/// Whether the open `file` is the one `path` names now.
fn is_named_by(file: &File, path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (file.metadata(), std::fs::metadata(path)) {
            (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = (file, path);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("hardbody-file-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn a_second_writer_is_refused_while_the_first_holds_the_lock() {
        let dir = scratch("lock");
        let path = dir.join("a.mcap.partial");
        let first = create_locked(&path).unwrap();
        assert!(matches!(create_locked(&path), Err(LogError::Busy { .. })));
        assert!(matches!(
            lock_for_reading(&path),
            Err(LogError::Busy { .. })
        ));
        drop(first);
        let again = create_locked(&path).unwrap();
        drop(again);
        assert!(lock_for_reading(&path).is_ok());
    }

    #[test]
    fn outputs_that_are_inputs_directories_or_not_regular_are_refused() {
        let dir = scratch("outputs");
        let input = dir.join("s.ron");
        std::fs::write(&input, "x").unwrap();
        assert!(matches!(
            check_output(&input, true, &[&input]),
            Err(OutputError::IsInput(..))
        ));
        let other = dir.join("t.mcap");
        assert_eq!(check_output(&other, true, &[&input]), Ok(()));
        let with_slash = PathBuf::from(format!("{}/", other.display()));
        assert!(matches!(
            check_output(&with_slash, true, &[]),
            Err(OutputError::Directory(_))
        ));
        assert!(matches!(
            check_output(&dir.join("no/such/dir.mcap"), true, &[]),
            Err(OutputError::NoDirectory(..))
        ));
        assert!(matches!(
            check_output(Path::new("/dev/null"), true, &[]),
            Err(OutputError::NotRegular(_))
        ));
        // The partial of an output that is an input is refused too.
        let log = dir.join("l.mcap");
        std::fs::write(partial_path(&log), "x").unwrap();
        let partial = partial_path(&log);
        assert!(matches!(
            check_output(&log, true, &[&partial]),
            Err(OutputError::IsInput(..))
        ));
        assert_eq!(check_output(&log, false, &[&partial]), Ok(()));
    }
}
