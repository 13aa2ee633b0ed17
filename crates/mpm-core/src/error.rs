//! Typed errors shared by the solvers.

use crate::math::{Real, Vector};
use std::fmt;
use thiserror::Error;

/// A stage of a step: the id under which its wall time is recorded, the id of the entry in a
/// solver's [`crate::solver::StagePlan`], and the stage named when a guard check or a solve
/// fails in it; [`Stage::name`] is the text used in timing tables, `summary.json` and error
/// messages. Each solver declares the stages it runs: the ones most MPM steps share are the
/// associated constants here, and a solver declares its own as constants of its crate
/// (`pub const CONTACT: Stage = Stage::new("contact");`), so a new solver edits nothing here.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Stage(&'static str);

impl Stage {
    /// The stage called `name` (lower-case words joined by `_`, e.g. `position_correction`).
    pub const fn new(name: &'static str) -> Self {
        Self(name)
    }

    /// Time-step selection.
    pub const TIME_STEP: Stage = Stage("time_step");
    /// Binning particles into grid blocks or cells.
    pub const SORT: Stage = Stage("sort");
    /// Particle-to-grid transfer.
    pub const P2G: Stage = Stage("p2g");
    /// Grid velocity update (and, on a single grid, boundary conditions).
    pub const GRID_UPDATE: Stage = Stage("grid_update");
    /// A grid solve: Newton's method (implicit), the explicit node update, or the pressure
    /// projection.
    pub const SOLVE: Stage = Stage("solve");
    /// Grid-to-particle transfer, deformation update and advection.
    pub const G2P: Stage = Stage("g2p");
    /// Writing accepted particle updates.
    pub const COMMIT: Stage = Stage("commit");

    /// The stage's id in timing tables, `summary.json` and messages.
    pub fn name(self) -> &'static str {
        self.0
    }
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The name of a solver parameter, as [`SetupError::InvalidParameter`] reports it (e.g.
/// `flip blend`, `pressure.rel_tol`). Every crate that checks parameters declares the names it
/// raises as constants of its `parameters` module (with [`crate::declare_parameters!`], which
/// also lists them in `parameters::ALL`), and raises only those, so a program that maps the
/// names to its own keys (the CLI maps them to scene keys) refers to the constants and a
/// renamed or removed parameter is a compile error there. The ones `mpm-core` raises are in
/// [`crate::parameters`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Parameter(&'static str);

impl Parameter {
    /// The parameter called `name` in error messages; for `parameters` modules.
    pub const fn new(name: &'static str) -> Self {
        Self(name)
    }

    /// The name in error messages.
    pub const fn name(self) -> &'static str {
        self.0
    }
}

impl fmt::Display for Parameter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0)
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
        /// Parameter name: a constant of the raising crate's `parameters` module.
        name: Parameter,
        /// Its value.
        value: Real,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// A particle lies outside the box where the solver takes particles.
    #[error("particle {index} at {position} lies outside {interior}")]
    ParticleOutsideGrid {
        /// Particle index.
        index: usize,
        /// Position (m), formatted.
        position: String,
        /// The box particles must lie in (m), named and formatted (see [`SetupError::outside`]).
        interior: String,
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
    /// A setting (e.g. the phases, couplings, porous interaction, mixing or dissolution of the
    /// explicit solver, the walls of the DIQ fluid, a TLMPM load) is inconsistent with the
    /// materials, particles or grid.
    #[error("invalid {setting}: {reason}")]
    InvalidSetting {
        /// The setting, e.g. `coupling 0` or `mixing`: a constant or function of the raising
        /// crate's `settings` module.
        setting: String,
        /// Why it is rejected.
        reason: String,
    },
}

impl SetupError {
    /// Particle `index` at `x` (m) lies outside the box `lo .. hi` (m) where the solver takes
    /// particles; `what` names that box (e.g. "the grid's interior").
    pub fn outside<const D: usize>(
        index: usize,
        x: &Vector<D>,
        (lo, hi): &(Vector<D>, Vector<D>),
        what: &str,
    ) -> Self {
        use crate::sampling::vector_text;
        SetupError::ParticleOutsideGrid {
            index,
            position: vector_text(x.as_slice()),
            interior: format!(
                "{what} {} .. {} m",
                vector_text(lo.as_slice()),
                vector_text(hi.as_slice())
            ),
        }
    }
}
