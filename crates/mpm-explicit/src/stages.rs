//! The stages of an explicit step beyond the ones [`Stage`] names: a solver declares its own.

use mpm_core::Stage;

/// Volume re-estimation from the grid density.
pub const VOLUME: Stage = Stage::new("volume");
/// Concentration diffusion (miscible mixing).
pub const DIFFUSION: Stage = Stage::new("diffusion");
/// Coupling between phase grids, then boundary conditions on every phase grid.
pub const COUPLING: Stage = Stage::new("coupling");
