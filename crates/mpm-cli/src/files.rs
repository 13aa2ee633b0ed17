//! Reading snapshots and checkpoints: verified against their checksum blocks, or, with
//! `--unchecked`, also HDF5 files without one (rewritten by h5py, written by another tool, cut
//! at the front).
//!
//! The HDF5 library is not hardened against damaged files: on one it may crash (SIGSEGV),
//! abort on an absurd allocation or loop, and a file it once read without complaint can crash
//! it on a second reading in the same process. A checksummed file is verified before the
//! library sees it. An unchecked file never reaches the library in this process: a child
//! process (the hidden `mpm-cli probe FILE COPY`) reads it once (mpm-io checks every dataset's
//! type, shape and size against its storage and the file before reading values) and writes
//! what it read as a checksummed copy, which this process then reads the verified way. A crash
//! or hang of the child is an error naming the file (exit 2), never a signal of this process.

use mpm_io::{FieldSpec, Header, IoError, Snapshot, Storage, Verify};
use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// The hidden subcommand that reads an unchecked file in a child process.
const PROBE_COMMAND: &str = "probe";

/// Environment variable that sets how long the child may take, in seconds (default
/// 10 s plus 1 s per 20 MB of file).
pub const TIMEOUT_VAR: &str = "MPM_UNCHECKED_TIMEOUT";

/// What the child prints when it has written the copy, so that the parent knows the child was
/// `mpm-cli` itself and finished.
const PROBE_DONE: &str = "mpm-cli probe: done";

/// Time the child may take: 10 s plus one second per 20 MB of file, or [`TIMEOUT_VAR`]
/// seconds.
fn probe_timeout(bytes: u64) -> Duration {
    std::env::var(TIMEOUT_VAR)
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s > 0.0)
        .map_or(Duration::from_secs(10 + bytes / 20_000_000), |s| {
            Duration::from_secs_f64(s.min(1e6))
        })
}

/// A snapshot or checkpoint to read with mpm-io's verified readers: the file itself, or, for
/// a file without a checksum block read with [`Verify::Unchecked`], the checksummed copy a
/// child process wrote (removed when this is dropped). Errors name the original file.
pub struct Checked {
    /// The file as named by the user.
    original: PathBuf,
    /// The checksummed copy, if any.
    copy: Option<PathBuf>,
}

impl Checked {
    /// Prepares `path` for reading: with [`Verify::Unchecked`] a file without a checksum
    /// block is read by a child process (this executable, which must be `mpm-cli`) into a
    /// checksummed copy first.
    pub fn open(path: &Path, trust: Verify) -> Result<Self, IoError> {
        let exe = std::env::current_exe().map_err(|source| IoError::Fs {
            path: path.to_path_buf(),
            source,
        })?;
        Self::open_with(path, trust, &exe, None)
    }

    /// [`Checked::open`] with `mpm_cli` as the program run as the child (for a process that is
    /// not `mpm-cli` itself: a library user, a test) and the time it may take (default
    /// [`TIMEOUT_VAR`] or 10 s plus 1 s per 20 MB).
    pub fn open_with(
        path: &Path,
        trust: Verify,
        mpm_cli: &Path,
        timeout: Option<Duration>,
    ) -> Result<Self, IoError> {
        // Only the first 8 bytes decide: the read of the file (or of its copy) verifies it once.
        let copy = if trust == Verify::Unchecked && mpm_io::is_unsealed(path) {
            Some(copy_in_child(path, mpm_cli, timeout)?)
        } else {
            None
        };
        Ok(Checked {
            original: path.to_path_buf(),
            copy,
        })
    }

    /// Reads the whole file ([`mpm_io::read_file`]).
    pub fn read_file(&self) -> Result<Snapshot, IoError> {
        self.read(mpm_io::read_file)
    }

    /// Reads the root attributes ([`mpm_io::read_header`]).
    pub fn read_header(&self) -> Result<Header, IoError> {
        self.read(mpm_io::read_header)
    }

    /// Reads the header and the fields' layout ([`mpm_io::read_layout`]).
    pub fn read_layout(&self) -> Result<(Header, Vec<FieldSpec>), IoError> {
        self.read(mpm_io::read_layout)
    }

    /// `reader` on the file or its copy, with the original's name in errors.
    fn read<T>(&self, reader: impl Fn(&Path) -> Result<T, IoError>) -> Result<T, IoError> {
        let Some(copy) = &self.copy else {
            return reader(&self.original);
        };
        reader(copy).map_err(|e| {
            let message = e.to_string();
            let message = message
                .strip_prefix(&format!("{}: ", copy.display()))
                .unwrap_or(&message);
            IoError::Format {
                path: self.original.clone(),
                message: message.to_string(),
            }
        })
    }
}

impl Drop for Checked {
    fn drop(&mut self) {
        if let Some(copy) = &self.copy {
            let _ = std::fs::remove_file(copy);
        }
    }
}

/// Reads a whole file ([`Checked`]).
pub fn read_file(path: &Path, trust: Verify) -> Result<Snapshot, IoError> {
    Checked::open(path, trust)?.read_file()
}

/// The child's side: reads `path` unchecked, once, and writes what it read to `copy` with
/// checksums (fields stored as in the file, uncompressed). Exit code 2 with the error on
/// stderr if the file cannot be read.
pub fn probe(path: &Path, copy: &Path) -> Result<(), crate::CliError> {
    let bad = |e: IoError| crate::CliError::BadInput(e.to_string());
    let (snapshot, specs) = mpm_io::read_stored(path, Verify::Unchecked).map_err(bad)?;
    let storage = Storage {
        single: specs.iter().any(|s| s.single),
        compression: 0,
    };
    mpm_io::write_file_with(copy, &snapshot.header, &snapshot.fields, storage).map_err(|e| {
        // What the writer refuses is the file's content: named after the file.
        let text = e.to_string();
        let text = text
            .strip_prefix(&format!("{}: ", copy.display()))
            .unwrap_or(&text);
        crate::CliError::BadInput(format!("{}: {text}", path.display()))
    })?;
    crate::outln!("{PROBE_DONE}");
    Ok(())
}

/// Copies made by this process so far (for unique names).
static COPIES: AtomicUsize = AtomicUsize::new(0);

/// Runs `mpm-cli probe FILE COPY` and waits for it, at most `timeout`; returns the
/// copy. A child killed by a signal or still running at the timeout (it is killed) makes the
/// file [`IoError::Damaged`]; a child that could not read it gives its message.
fn copy_in_child(
    path: &Path,
    mpm_cli: &Path,
    timeout: Option<Duration>,
) -> Result<PathBuf, IoError> {
    let damaged = |message: String| IoError::Damaged {
        path: path.to_path_buf(),
        message,
    };
    let fs_err = |source| IoError::Fs {
        path: path.to_path_buf(),
        source,
    };
    let bytes = std::fs::metadata(path).map_err(fs_err)?.len();
    let copy = std::env::temp_dir().join(format!(
        ".mpm-cli-unchecked-{}-{}.h5",
        std::process::id(),
        COPIES.fetch_add(1, Ordering::Relaxed)
    ));
    let mut child = Command::new(mpm_cli)
        .arg(PROBE_COMMAND)
        .arg(path)
        .arg(&copy)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(fs_err)?;
    let limit = timeout.unwrap_or_else(|| probe_timeout(bytes));
    let start = Instant::now();
    // Polled from 0.1 ms up to every 1 ms: reading a small file takes about 10 ms.
    let mut pause = Duration::from_micros(100);
    let status = loop {
        if let Some(status) = child.try_wait().map_err(fs_err)? {
            break status;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            let _ = std::fs::remove_file(&copy);
            return Err(damaged(format!(
                "the HDF5 library did not finish reading it within {:.1} s (in a child \
                 process, killed; {TIMEOUT_VAR} sets the limit in seconds)",
                limit.as_secs_f64()
            )));
        }
        std::thread::sleep(pause);
        pause = (pause * 2).min(Duration::from_millis(1));
    };
    let (mut said, mut complaint) = (String::new(), String::new());
    if let Some(mut out) = child.stdout.take() {
        let _ = out.read_to_string(&mut said);
    }
    if let Some(mut err) = child.stderr.take() {
        let _ = err.read_to_string(&mut complaint);
    }
    use std::os::unix::process::ExitStatusExt as _;
    let outcome = match (status.signal(), status.code()) {
        (None, Some(0)) if said.contains(PROBE_DONE) => return Ok(copy),
        (Some(signal), _) => damaged(format!(
            "reading it crashed the HDF5 library (signal {signal}, in a child process)"
        )),
        (None, Some(2)) => {
            let text = complaint.trim().trim_start_matches("error: ");
            let text = text
                .strip_prefix(&format!("{}: ", path.display()))
                .unwrap_or(text);
            IoError::Format {
                path: path.to_path_buf(),
                message: text.to_string(),
            }
        }
        (_, code) => damaged(format!(
            "a child process reading it failed (exit code {})",
            code.map_or("none".into(), |c| c.to_string())
        )),
    };
    let _ = std::fs::remove_file(&copy);
    Err(outcome)
}

/// The hint appended to an error about a file without a checksum block.
pub fn hint(e: &IoError) -> &'static str {
    if matches!(e, IoError::Unverifiable { .. }) {
        "; read it anyway with --unchecked (unsafe: damage to its values goes unnoticed)"
    } else {
        ""
    }
}
