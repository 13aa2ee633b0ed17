//! Signal handling of `mpm-cli run`: SIGINT, SIGTERM and SIGHUP (a closed terminal or SSH
//! session) stop the run after the current step with a checkpoint (see [`stop_on_signals`]).

use super::Runner;
use crate::error::CliError;
use mpm_core::{Dim, DimOps};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

/// Installs handlers so that the first SIGINT, SIGTERM or SIGHUP stores its signal number in the
/// returned flag (the run loop then finishes its step, writes a checkpoint, a snapshot and
/// `summary.json` with status "interrupted", and exits with 128 + the number), and a second
/// one ends the process at once with the signal's default action. Every output is written
/// under a temporary name and renamed into place, so that second signal, even during the
/// checkpoint write, leaves the files written before complete.
pub fn stop_on_signals() -> Result<Arc<AtomicUsize>, CliError> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    use signal_hook::flag;
    let which = Arc::new(AtomicUsize::new(0));
    let armed = Arc::new(AtomicBool::new(false));
    for sig in [SIGINT, SIGTERM, SIGHUP] {
        // The conditional default goes first: it fires only once `armed` is set, i.e. on the
        // second signal.
        flag::register_conditional_default(sig, Arc::clone(&armed))
            .and_then(|_| flag::register(sig, Arc::clone(&armed)))
            .and_then(|_| flag::register_usize(sig, Arc::clone(&which), sig as usize))
            .map_err(|e| {
                CliError::Other(format!(
                    "error: cannot install a handler for signal {sig}: {e}"
                ))
            })?;
    }
    Ok(which)
}

/// The conventional name of the termination signals `mpm-cli run` handles.
pub(super) fn signal_name(signal: i32) -> String {
    match signal {
        signal_hook::consts::SIGINT => "SIGINT".into(),
        signal_hook::consts::SIGTERM => "SIGTERM".into(),
        signal_hook::consts::SIGHUP => "SIGHUP".into(),
        s => format!("signal {s}"),
    }
}

impl<const D: usize> Runner<'_, D>
where
    Dim<D>: DimOps<D>,
{
    /// The signal that asked the run to stop, if one did.
    pub(super) fn stop_signal(&self) -> Option<i32> {
        let s = self.stop.as_ref().map_or(0, |s| s.load(Ordering::SeqCst));
        // On several ranks every rank stops after the same step: a signal any rank got.
        if crate::distributed::any(s != 0) {
            Some(if s != 0 { s as i32 } else { 15 })
        } else {
            None
        }
    }
}
