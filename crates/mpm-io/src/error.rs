//! Errors of the I/O layer.

use std::path::PathBuf;
use thiserror::Error;

/// An I/O failure, naming the file involved.
#[derive(Debug, Error)]
pub enum IoError {
    /// The HDF5 library reported an error.
    #[error("{path}: HDF5 error: {message}")]
    Hdf5 {
        /// File.
        path: PathBuf,
        /// Library message.
        message: String,
    },
    /// A file-system operation failed.
    #[error("{path}: {source}")]
    Fs {
        /// File.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The file does not match its checksums: it was damaged after it was written.
    #[error("{path}: the file is damaged: {message}")]
    Damaged {
        /// File.
        path: PathBuf,
        /// Which dataset or part of the file does not match.
        message: String,
    },
    /// An HDF5 file without the checksum block that mpm-io writes: refused unless read with
    /// [`crate::Verify::Unchecked`].
    #[error(
        "{path}: the file has no checksum block (another HDF5 tool wrote or rewrote it, or its \
         first bytes were cut), so it cannot be verified"
    )]
    Unverifiable {
        /// File.
        path: PathBuf,
    },
    /// The file is readable but not in the expected layout.
    #[error("{path}: {message}")]
    Format {
        /// File.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}
