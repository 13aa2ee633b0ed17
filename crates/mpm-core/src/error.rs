//! Typed errors shared by the solvers.

use crate::math::Real;
use std::fmt;
use thiserror::Error;

/// A stage of a step: the id under which its wall time is recorded, the id of the entry in a
/// solver's [`crate::solver::StagePlan`], and the stage named when a guard check or a solve
/// fails in it. Each solver runs a subset; [`Stage::name`] is the text used in timing tables,
/// `summary.json` and error messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Stage {
    /// Caching the reference configuration (TLMPM: weights, gradients, connectivity, sparsity
    /// pattern and symbolic factorisation), at set-up.
    Reference,
    /// Time-step selection.
    TimeStep,
    /// Binning particles into grid blocks for the deterministic scatter.
    Sort,
    /// Volume re-estimation from the grid density.
    Volume,
    /// Concentration diffusion (miscible mixing).
    Diffusion,
    /// Particle-to-grid transfer.
    P2G,
    /// Grid velocity update (and, on a single grid, boundary conditions).
    GridUpdate,
    /// External nodal forces (gravity, applied loads).
    ExternalForces,
    /// Particle contact forces.
    Contact,
    /// Coupling between phase grids, then boundary conditions on every phase grid.
    Coupling,
    /// A grid solve: Newton's method (implicit), the explicit node update, or the pressure
    /// projection (DIQ).
    Solve,
    /// Grid-to-particle transfer, deformation update and advection.
    G2P,
    /// Volume-preserving particle position correction (DIQ fluid, Kugelstadt et al. 2019).
    PositionCorrection,
    /// Writing accepted particle updates.
    Commit,
    /// A-ULMPM reference configuration update.
    ReferenceUpdate,
}

impl Stage {
    /// Every stage, in the order a step would run them.
    pub const ALL: [Stage; 15] = [
        Stage::Reference,
        Stage::TimeStep,
        Stage::Sort,
        Stage::Volume,
        Stage::Diffusion,
        Stage::P2G,
        Stage::GridUpdate,
        Stage::ExternalForces,
        Stage::Contact,
        Stage::Coupling,
        Stage::Solve,
        Stage::G2P,
        Stage::PositionCorrection,
        Stage::Commit,
        Stage::ReferenceUpdate,
    ];

    /// The stage's id in timing tables, `summary.json` and messages.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Reference => "reference",
            Stage::TimeStep => "time_step",
            Stage::Sort => "sort",
            Stage::Volume => "volume",
            Stage::Diffusion => "diffusion",
            Stage::P2G => "p2g",
            Stage::GridUpdate => "grid_update",
            Stage::ExternalForces => "external_forces",
            Stage::Contact => "contact",
            Stage::Coupling => "coupling",
            Stage::Solve => "solve",
            Stage::G2P => "g2p",
            Stage::PositionCorrection => "position_correction",
            Stage::Commit => "commit",
            Stage::ReferenceUpdate => "reference_update",
        }
    }

    /// Position in [`Stage::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What a guard check found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Violation {
    /// A non-finite value in the named quantity.
    NonFinite(&'static str),
    /// J ≤ 0 for a model undefined there.
    InvertedElement,
    /// A particle left the region where its stencil fits in the grid.
    LeftDomain,
    /// A particle moves more than one cell per step (|v| dt > Δx).
    CflExceeded,
    /// The time step fell below its minimum (m/s of the fastest particle given as value).
    TimeStepTooSmall,
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Violation::NonFinite(q) => write!(f, "non-finite {q}"),
            Violation::InvertedElement => f.write_str("J <= 0 for a model undefined there"),
            Violation::LeftDomain => f.write_str("particle left the grid"),
            Violation::CflExceeded => f.write_str("velocity beyond the CFL bound (|v| dt > dx)"),
            Violation::TimeStepTooSmall => f.write_str("time step below its minimum"),
        }
    }
}

/// Where the failing value sits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Location {
    /// A particle index.
    Particle(usize),
    /// A grid node (linear index).
    Node(usize),
    /// Not tied to one particle or node.
    Global,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Particle(p) => write!(f, "particle {p}"),
            Location::Node(n) => write!(f, "node {n}"),
            Location::Global => f.write_str("whole system"),
        }
    }
}

/// A failed guard check: the run became numerically unstable.
#[derive(Clone, Copy, Debug, PartialEq, Error)]
#[error("instability at step {step} (t = {time:.6e} s, dt = {dt:.3e} s), stage {stage}, {location}: {violation} (value {value:.6e}){retries}", retries = RetryNote(*.retries))]
pub struct Instability {
    /// Step number (0-based) that failed.
    pub step: u64,
    /// Simulation time at the start of the step (s).
    pub time: Real,
    /// Time step of the failing attempt (s).
    pub dt: Real,
    /// Stage whose guard check failed.
    pub stage: Stage,
    /// Particle or node.
    pub location: Location,
    /// What was wrong.
    pub violation: Violation,
    /// The offending value.
    pub value: Real,
    /// How many dt/2 retries were made before giving up.
    pub retries: u32,
}

struct RetryNote(u32);

impl fmt::Display for RetryNote {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0 > 0 {
            write!(f, " after {} dt/2 retries", self.0)
        } else {
            Ok(())
        }
    }
}

/// Errors raised when building a simulation from invalid parameters.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum SetupError {
    /// A parameter is out of its valid range.
    #[error("invalid parameter `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Its value.
        value: Real,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// A particle's stencil does not fit in the grid.
    #[error("particle {index} at {position} lies outside the grid's interior")]
    ParticleOutsideGrid {
        /// Particle index.
        index: usize,
        /// Position, formatted.
        position: String,
    },
    /// A particle names a material that does not exist.
    #[error("particle {index} refers to material {material}, but only {count} exist")]
    UnknownMaterial {
        /// Particle index.
        index: usize,
        /// Material index.
        material: u32,
        /// Number of materials.
        count: usize,
    },
    /// A particle column required by a material is missing.
    #[error("material {material} needs particle column `{column}`, which does not exist")]
    MissingColumn {
        /// Material index.
        material: usize,
        /// Column name.
        column: &'static str,
    },
    /// A multi-grid setting (phases, couplings, porous interaction, mixing, dissolution) is
    /// inconsistent with the materials or particles.
    #[error("invalid {setting}: {reason}")]
    InvalidSetting {
        /// The setting, e.g. `coupling 0` or `mixing`.
        setting: String,
        /// Why it is rejected.
        reason: String,
    },
}
