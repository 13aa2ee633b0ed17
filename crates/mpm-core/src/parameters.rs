//! The parameters `mpm-core` checks for every solver, by the names
//! [`SetupError::InvalidParameter`](crate::SetupError::InvalidParameter) reports: the time-step
//! policy ([`TimeStepPolicy::validate`](crate::TimeStepPolicy::validate)), the damping
//! ([`Damping::invalid`](crate::quasistatic::Damping::invalid)), the gravity ramp
//! ([`GravityRamp::invalid`](crate::quasistatic::GravityRamp::invalid)) and the gravity of a
//! [`StepControl`](crate::StepControl), which the solvers check.

/// Declares the parameter names a crate raises in
/// [`SetupError::InvalidParameter`](crate::SetupError::InvalidParameter): one
/// `pub const NAME: Parameter` per entry, with its doc comment, and `pub const ALL`, every
/// constant the invocation declares in order, so a list of them cannot miss one. Invoked once
/// in a crate's `parameters` module:
///
/// ```
/// mod parameters {
///     mpm_core::declare_parameters! {
///         /// Relative tolerance of the pressure solve (dimensionless).
///         REL_TOL = "pressure.rel_tol";
///     }
/// }
/// assert_eq!(parameters::REL_TOL.to_string(), "pressure.rel_tol");
/// assert_eq!(parameters::ALL, &[parameters::REL_TOL]);
/// ```
#[macro_export]
macro_rules! declare_parameters {
    ($($(#[$attr:meta])* $name:ident = $text:literal;)+) => {
        $(
            $(#[$attr])*
            pub const $name: $crate::Parameter = $crate::Parameter::new($text);
        )+
        /// Every parameter this module declares, in declaration order.
        pub const ALL: &[$crate::Parameter] = &[$($name),+];
    };
}

declare_parameters! {
    /// A fixed time step (s).
    DT = "dt";
    /// The CFL factor of an adaptive time step (dimensionless).
    CFL = "cfl";
    /// The upper bound of an adaptive time step (s).
    DT_MAX = "dt_max";
    /// Gravitational acceleration (m/s²), which must be finite.
    GRAVITY = "gravity";
    /// Duration of the gravity ramp (s).
    GRAVITY_RAMP = "gravity ramp";
    /// Local non-viscous damping factor α (dimensionless).
    LOCAL_DAMPING = "local damping";
    /// Global viscous damping rate c (1/s).
    VISCOUS_DAMPING = "viscous damping";
}
