//! The settings the explicit solver checks, by the names
//! [`SetupError::InvalidSetting`](mpm_core::SetupError::InvalidSetting) reports.

/// The phases: their count, the `phase` column and each particle's phase.
pub const PHASES: &str = "phases";
/// The porous interaction ([`Porous`](crate::Porous)).
pub const POROUS: &str = "porous";
/// The miscible mixing ([`Mixing`](crate::Mixing)).
pub const MIXING: &str = "mixing";
/// The dissolution of a solid ([`Dissolution`](crate::Dissolution)).
pub const DISSOLUTION: &str = "dissolution";
/// The domain walls: mirrored walls
/// ([`WallTreatment::Mirror`](mpm_core::mirror::WallTreatment::Mirror)) need a contact with a
/// reflection, at least one layer, and a grid large enough for the ghosts' mirrors.
pub const WALLS: &str = "walls";

/// The coupling at index `index` of [`Phases::couplings`](crate::Phases::couplings).
pub fn coupling(index: usize) -> String {
    format!("coupling {index}")
}
