//! What can go wrong writing or reading a log, and I/O errors in words a
//! user acts on: a full or read-only file system told from a bad path.

use std::path::{Path, PathBuf};

use super::file;

/// What can go wrong writing or reading a log.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// The file system refused.
    #[error("{}: {}", path.display(), io_reason(source))]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The MCAP layer refused.
    #[error("{}: {source}", path.display())]
    Mcap {
        /// The file.
        path: PathBuf,
        /// Why.
        source: mcap::McapError,
    },
    /// The file is not a hardbody log, or lacks what was asked for.
    #[error("{}: {message}", path.display())]
    Content {
        /// The file.
        path: PathBuf,
        /// What is missing or wrong.
        message: String,
    },
    /// An output file could not be made (a link or a device where it
    /// would go, a full or read-only file system).
    #[error(transparent)]
    Output(#[from] file::OutputError),
    /// Another process is writing this log.
    #[error(
        "{}: another hardbody run is writing this log (it holds the file's lock); wait for it, or give this run another --out",
        path.display()
    )]
    Busy {
        /// The file that is locked.
        path: PathBuf,
    },
}

/// An error that may be the file system's (full, over quota, read-only)
/// rather than its input's: a run or command that meets one failed (exit
/// 1), one refused a path was given bad input (exit 2).
pub trait StorageFailure {
    /// Whether the file system, not the input, is at fault.
    fn is_storage_failure(&self) -> bool;
}

impl StorageFailure for std::io::ErrorKind {
    fn is_storage_failure(&self) -> bool {
        use std::io::ErrorKind::*;
        matches!(
            self,
            StorageFull | QuotaExceeded | ReadOnlyFilesystem | FileTooLarge
        )
    }
}

impl StorageFailure for LogError {
    fn is_storage_failure(&self) -> bool {
        match self {
            LogError::Io { source, .. } => source.kind().is_storage_failure(),
            LogError::Output(e) => e.is_storage_failure(),
            _ => false,
        }
    }
}

/// The I/O error at the root of `e`'s chain of causes, if any.
pub fn io_cause<'a>(e: &'a (dyn std::error::Error + 'static)) -> Option<&'a std::io::Error> {
    let mut cause = Some(e);
    while let Some(e) = cause {
        if let Some(io) = e.downcast_ref::<std::io::Error>() {
            return Some(io);
        }
        cause = e.source();
    }
    None
}

/// An I/O error in words a user acts on: a full disk is named as such.
pub(super) fn io_reason(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::StorageFull => "no space left on device".into(),
        std::io::ErrorKind::QuotaExceeded => "disk quota exceeded".into(),
        _ => e.to_string(),
    }
}

impl LogError {
    /// An MCAP writer's error on `path`, with the I/O cause kept where
    /// there is one.
    pub(super) fn from_mcap(path: &Path, source: mcap::McapError) -> Self {
        match source {
            mcap::McapError::Io(source) => LogError::Io {
                path: path.to_path_buf(),
                source,
            },
            source => LogError::Mcap {
                path: path.to_path_buf(),
                source,
            },
        }
    }

    /// Whether the file system ran out of room (or of quota).
    pub fn is_disk_full(&self) -> bool {
        matches!(self, LogError::Io { source, .. } if matches!(
            source.kind(),
            std::io::ErrorKind::StorageFull | std::io::ErrorKind::QuotaExceeded
        ))
    }

    /// The same error again (a writer that failed once reports its first
    /// error to every later call).
    pub(super) fn again(&self) -> Self {
        match self {
            LogError::Io { path, source } => LogError::Io {
                path: path.clone(),
                source: std::io::Error::new(source.kind(), io_reason(source)),
            },
            LogError::Mcap { path, source } => LogError::Content {
                path: path.clone(),
                message: source.to_string(),
            },
            LogError::Content { path, message } => LogError::Content {
                path: path.clone(),
                message: message.clone(),
            },
            LogError::Busy { path } => LogError::Busy { path: path.clone() },
            LogError::Output(e) => LogError::Output(e.clone()),
        }
    }
}

/// How a `/state` record contradicts itself (damage, never a pose).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InconsistentState {
    /// An array of another length than the particles.
    #[error("{len} {name} for {n} particles")]
    Count {
        /// The array.
        name: &'static str,
        /// Its length.
        len: usize,
        /// The particles.
        n: usize,
    },
    /// A species index past the species.
    #[error("species index {index} of {species} species")]
    Species {
        /// The index.
        index: u16,
        /// The species there are.
        species: usize,
    },
    /// Box edges that are not finite and positive.
    #[error("box edges {0:?}")]
    Box([f64; 3]),
    /// Tilt factors that are not finite.
    #[error("box tilts {0:?}")]
    Tilts([f64; 3]),
    /// A position that is not finite.
    #[error("particle {0}: position {1:?}")]
    Position(usize, [f64; 3]),
    /// An orientation that is not a unit quaternion.
    #[error("particle {0}: orientation {1:?} is not a unit quaternion")]
    Orientation(usize, [f64; 4]),
}
