//! The settings the DIQ solvers check, by the names
//! [`SetupError::InvalidSetting`](mpm_core::SetupError::InvalidSetting) reports.

/// The materials: the coupled solver needs a solid.
pub const MATERIALS: &str = "materials";
/// The domain walls, which must be free slip without friction (Eq. 25).
pub const WALLS: &str = "walls";
/// The colliders, which must be free slip without friction (Eq. 25) and must not overlap the
/// fluid.
pub const COLLIDERS: &str = "colliders";

/// The material at index `index`: the DIQ fluid solver takes fluids only.
pub fn material(index: usize) -> String {
    format!("material {index}")
}
