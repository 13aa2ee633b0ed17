//! The parameters the explicit solver checks beyond [`mpm_core::parameters`], by the names
//! [`SetupError::InvalidParameter`](mpm_core::SetupError::InvalidParameter) reports.

mpm_core::declare_parameters! {
    /// Grid spacing Δx (m), which must be positive and finite.
    GRID_DX = "grid.dx";
    /// Number of grid nodes along an axis (the offending count), too few for the kernel.
    GRID_SIZE = "grid.size";
    /// FLIP fraction α of [`Transfer::Flip`](crate::Transfer::Flip) (dimensionless, in [0, 1]).
    FLIP_BLEND = "flip blend";
    /// Look-ahead time τ of [`SoftWalls`](crate::SoftWalls) (s), reported also for a negative
    /// margin.
    SOFT_WALLS_LOOKAHEAD = "soft_walls.lookahead";
}
