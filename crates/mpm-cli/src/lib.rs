//! The `mpm-cli` command-line tool as a library: scene format, building a solver from a scene,
//! the run loop with snapshots and checkpoints, `check`, `info`, `render` and `surface`. The binary
//! (`src/main.rs`) only parses arguments and maps errors to exit codes. No physics lives here.

pub mod build;
pub mod check;
pub mod distributed;
pub mod error;
pub mod files;
pub mod font;
pub mod info;
pub mod input;
pub mod render;
pub mod run;
pub mod scene;
pub mod solvers;
pub mod span;
pub mod state;
pub mod surface;
pub mod sweep;

pub use error::{CliError, SceneError};

/// `println!` that never panics. The tool's messages (progress, warnings, `check`'s report) may
/// go to a pipe whose reader has gone (`mpm-cli run scene.toml | head`) or to a terminal that
/// hung up; a failed write is ignored, so a run still finishes and writes its files. On several
/// ranks only rank 0 prints ([`distributed::root`]).
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if $crate::distributed::root() {
            let _ = writeln!(std::io::stdout(), $($arg)*);
        }
    }};
}

/// `print!` that never panics (see [`outln!`]).
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if $crate::distributed::root() {
            let mut stdout = std::io::stdout();
            let _ = write!(stdout, $($arg)*).and_then(|_| stdout.flush());
        }
    }};
}

/// `eprintln!` that never panics (see [`outln!`]).
#[macro_export]
macro_rules! errln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if $crate::distributed::root() {
            let _ = writeln!(std::io::stderr(), $($arg)*);
        }
    }};
}

/// `eprint!` that never panics (see [`outln!`]).
#[macro_export]
macro_rules! err {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if $crate::distributed::root() {
            let _ = write!(std::io::stderr(), $($arg)*);
        }
    }};
}
