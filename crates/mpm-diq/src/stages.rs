//! The stages of a DIQ step beyond the ones [`Stage`] names (the coupled solver also runs the
//! TLMPM stages of `mpm_tlmpm::stages`): a solver declares its own.

use mpm_core::Stage;

/// Volume-preserving particle position correction (Kugelstadt et al. 2019).
pub const POSITION_CORRECTION: Stage = Stage::new("position_correction");
/// The coupled solver's interface quadrature and coupled pressure system.
pub const COUPLING: Stage = Stage::new("coupling");
