//! The settings the TLMPM solvers check, by the names
//! [`SetupError::InvalidSetting`](mpm_core::SetupError::InvalidSetting) reports.

/// A-ULMPM reference updates: a restored state and the solver must agree on them.
pub const REFERENCE_UPDATE: &str = "reference_update";
/// The transfer: a restored state with persistent node velocities needs
/// [`Transfer::Persistent`](crate::Transfer::Persistent).
pub const TRANSFER: &str = "transfer";

/// The nodal load at index `index` of [`TlmpmParams::nodal_loads`](crate::TlmpmParams::nodal_loads).
pub fn nodal_load(index: usize) -> String {
    format!("nodal load {index}")
}

/// The surface traction at index `index` of [`TlmpmParams::tractions`](crate::TlmpmParams::tractions).
pub fn traction(index: usize) -> String {
    format!("traction {index}")
}

/// The clamp plane normal to `axis` at `position` (m) ([`ClampPlane`](crate::ClampPlane)).
pub fn clamp_plane(axis: usize, position: mpm_core::Real) -> String {
    format!("clamp plane on axis {axis} at {position} m")
}
