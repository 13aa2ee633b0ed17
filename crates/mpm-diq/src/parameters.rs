//! The parameters the DIQ solvers check beyond [`mpm_core::parameters`], by the names
//! [`SetupError::InvalidParameter`](mpm_core::SetupError::InvalidParameter) reports.

mpm_core::declare_parameters! {
    /// The grid (the value is its smallest node count): the box inside the walls must hold at
    /// least 2 cells per axis.
    GRID = "grid";
    /// Relative tolerance of the pressure solve
    /// ([`PressureParams::rel_tol`](crate::PressureParams::rel_tol); dimensionless, in (0, 1)).
    PRESSURE_REL_TOL = "pressure.rel_tol";
    /// Iteration cap of the pressure solve
    /// ([`PressureParams::max_iterations`](crate::PressureParams::max_iterations); at least 1).
    PRESSURE_MAX_ITERATIONS = "pressure.max_iterations";
    /// A fluid particle's mass (kg; its volume, m^D, is checked with it), which must be
    /// positive.
    MASS = "mass";
    /// The first Lamé parameter λ (Pa) of a solid of the coupled solver, which must be positive
    /// and finite: `λ^v = λ/2` is the solid's pressure stiffness.
    LAMBDA = "lambda";
}
