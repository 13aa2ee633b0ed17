//! The parameters the TLMPM solvers check beyond [`mpm_core::parameters`], by the names
//! [`SetupError::InvalidParameter`](mpm_core::SetupError::InvalidParameter) reports. Those a
//! restored state can violate are in [`restore`]; they are not part of a set-up.

mpm_core::declare_parameters! {
    /// Grid spacing Δx of the reference grid (m), which must be positive and finite.
    GRID_DX = "grid.dx";
    /// Number of active nodes of the reference grid (the offending count), beyond 32-bit
    /// indices.
    GRID_SIZE = "grid.size";
    /// Number of particles (the offending count), beyond 32-bit indices.
    PARTICLES = "particles";
    /// FLIP fraction α of [`Transfer::Flip`](crate::Transfer::Flip) (dimensionless, in [0, 1]).
    FLIP_BLEND = "flip blend";
    /// Fixed contact radius of [`ContactRadius::Fixed`](crate::ContactRadius::Fixed) (m).
    CONTACT_RADIUS = "contact.radius";
    /// A-ULMPM volume-change threshold ε of [`ReferenceUpdate`](crate::ReferenceUpdate)
    /// (dimensionless, ≥ 0).
    REFERENCE_UPDATE_EPSILON = "reference_update.epsilon";
    /// A-ULMPM marked fraction η of [`ReferenceUpdate`](crate::ReferenceUpdate)
    /// (dimensionless, in [0, 1]).
    REFERENCE_UPDATE_ETA = "reference_update.eta";
    /// A plastic material without A-ULMPM reference updates (the value is the material's
    /// index).
    MATERIAL_PLASTICITY = "material.plasticity";
    /// A fluid material, which TLMPM does not support (the value is the material's index).
    MATERIAL_KIND = "material.kind";
    /// A particle's mass (kg), which must be positive and finite.
    PARTICLE_MASS = "particle.mass";
    /// A particle's initial volume (m^D), which must be positive and finite.
    PARTICLE_VOLUME0 = "particle.volume0";
    /// The implicit solver's linear solver (no value): the symbolic Cholesky analysis of the
    /// sparsity pattern failed.
    LINEAR_SOLVER = "linear_solver";
}

/// The parameters of a state handed to `restore` (a checkpoint), whose lengths must match
/// the solver's particles or active nodes (the value is the offending length).
pub mod restore {
    mpm_core::declare_parameters! {
        /// The reference positions, one per particle (m).
        REFERENCE_POSITIONS = "reference_positions";
        /// The A-ULMPM relative deformation gradients `F^(r,n)`, one per particle.
        RELATIVE_DEF_GRAD = "relative_def_grad";
        /// The A-ULMPM base deformation gradients `F^(0,r)`, one per particle.
        BASE_DEF_GRAD = "base_def_grad";
        /// The persistent node velocities, one per active node of the reference grid (m/s).
        NODE_VELOCITIES = "node_velocities";
    }
}
