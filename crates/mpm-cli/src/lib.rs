//! The `mpm-cli` command-line tool as a library: scene format, building a solver from a scene,
//! the run loop with snapshots and checkpoints, `check`, `info`, `render` and `surface`. The binary
//! (`src/main.rs`) only parses arguments and maps errors to exit codes. No physics lives here.

pub mod build;
pub mod check;
pub mod error;
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

pub use error::{CliError, SceneError};
