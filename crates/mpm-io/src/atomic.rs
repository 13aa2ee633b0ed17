//! Atomic replacement of a file: write to a hidden temporary name in the same directory, flush
//! it to disk, rename it over the final name, then flush the directory entry.

use crate::IoError;
use std::ffi::OsString;
use std::fs;
use std::path::{Path, PathBuf};

/// The temporary name used while `path` is being written: `<dir>/.<name>.tmp-<pid>`.
///
/// The leading dot keeps it out of globs such as `snap_*.h5`, and the process id keeps two
/// processes writing into the same directory apart.
pub(crate) fn temp_path(path: &Path) -> Result<PathBuf, IoError> {
    let name = path.file_name().ok_or_else(|| IoError::Format {
        path: path.to_path_buf(),
        message: "the path has no file name".to_owned(),
    })?;
    let mut tmp = OsString::from(".");
    tmp.push(name);
    tmp.push(format!(".tmp-{}", std::process::id()));
    Ok(parent_dir(path).join(tmp))
}

/// The directory holding `path` (`.` for a bare file name).
pub(crate) fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Writes `path` atomically: `write` fills the temporary file (and closes it), which is then
/// fsynced, renamed to `path`, and the directory fsynced. On any failure the temporary file is
/// removed (best effort) and the final file is left as it was.
pub(crate) fn replace_atomically<F>(path: &Path, write: F) -> Result<(), IoError>
where
    F: FnOnce(&Path) -> Result<(), IoError>,
{
    let tmp = temp_path(path)?;
    let staged = write(&tmp).and_then(|()| sync_file(&tmp));
    if let Err(e) = staged {
        let _ = fs::remove_file(&tmp);
        return Err(e);
    }
    if let Err(source) = fs::rename(&tmp, path) {
        let _ = fs::remove_file(&tmp);
        return Err(IoError::Fs {
            path: path.to_path_buf(),
            source,
        });
    }
    sync_dir(parent_dir(path))
}

/// Writes `bytes` to `path` atomically (temporary file, fsync, rename): a reader, or a process killed
/// while writing, sees either the old file or the complete new one, never a truncated file.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    replace_atomically(path, |tmp| {
        fs::write(tmp, bytes).map_err(|source| IoError::Fs {
            path: tmp.to_path_buf(),
            source,
        })
    })
}

/// Flushes a closed file's data and metadata to the storage device.
fn sync_file(path: &Path) -> Result<(), IoError> {
    let fs_err = |source| IoError::Fs {
        path: path.to_path_buf(),
        source,
    };
    fs::File::open(path)
        .map_err(fs_err)?
        .sync_all()
        .map_err(fs_err)
}

/// Flushes a directory so that a rename into it survives a crash (Unix only; elsewhere a
/// directory cannot be opened as a file and this does nothing).
fn sync_dir(dir: &Path) -> Result<(), IoError> {
    #[cfg(unix)]
    {
        let fs_err = |source| IoError::Fs {
            path: dir.to_path_buf(),
            source,
        };
        fs::File::open(dir)
            .map_err(fs_err)?
            .sync_all()
            .map_err(fs_err)?;
    }
    #[cfg(not(unix))]
    let _ = dir;
    Ok(())
}
