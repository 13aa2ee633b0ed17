//! The stages of a TLMPM step beyond the ones [`Stage`] names: a solver declares its own.

use mpm_core::Stage;

/// Caching the reference configuration (weights, gradients, connectivity, sparsity pattern and
/// symbolic factorisation), at set-up and after a reference update.
pub const REFERENCE: Stage = Stage::new("reference");
/// External nodal forces (gravity, applied loads).
pub const EXTERNAL_FORCES: Stage = Stage::new("external_forces");
/// Particle–particle and particle–obstacle penalty contact forces.
pub const CONTACT: Stage = Stage::new("contact");
/// A-ULMPM reference configuration update.
pub const REFERENCE_UPDATE: Stage = Stage::new("reference_update");
