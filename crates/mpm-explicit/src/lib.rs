//! Explicit MLS-MPM (Hu et al. 2018) as used by the multi-grid coupling paper §3.1: P2G with the
//! fused MLS stress term, grid update with gravity and boundaries, G2P with APIC (default), PIC or
//! FLIP blending, plasticity return mapping and fluid J update, then advection.
//!
//! A step is a short list of named stages (see [`ExplicitSolver::step`]): sort → (volume
//! re-estimation) → P2G → grid update → G2P with guard checks → commit. P2G is parallel and
//! deterministic: results are bitwise identical for any number of rayon threads.
//!
//! With several phases (multigrid paper §4, see [`multigrid`]) every phase scatters to its own
//! grid and a coupling stage (drag, contact, buoyancy penalty) runs between the grid update and
//! the boundaries; optional stages diffuse concentrations (miscible mixing) and update φ_eff and
//! dissolution progress. A single-phase scene runs none of them.

mod advice;
mod blocks;
mod coupling;
mod g2p;
mod grid_update;
mod materials;
mod mixing;
pub mod multigrid;
mod p2g;
mod params;
mod plan;
mod solver;
mod validate;

pub use advice::{too_compressible, TooCompressible};
pub use multigrid::{
    Activation, BuoyancyPenalty, ContactCoupling, Coupling, CouplingKind, DiffusionScheme,
    Dissolution, Drag, EffectiveFraction, Friction, Mixing, Phases, Porous, PressureBuoyancy,
};
pub use p2g::kirchhoff;
pub use params::{BodyForce, ExplicitParams, SoftWalls, Transfer, VolumeUpdate};
pub use solver::{ExplicitSolver, PreparedG2p, ScratchBytes};
