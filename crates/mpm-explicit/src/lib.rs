//! Explicit MLS-MPM (Hu et al. 2018) as used by the multi-grid coupling paper §3.1: P2G with the
//! fused MLS stress term, grid update with gravity and boundaries, G2P with APIC (default), PIC or
//! FLIP blending, plasticity return mapping and fluid J update, then advection.
//!
//! A step is a short list of named stages (see [`ExplicitSolver::step`]): sort → (volume
//! re-estimation) → P2G → grid update → G2P with guard checks → commit. P2G is parallel and
//! deterministic: results are bitwise identical for any number of rayon threads.

mod blocks;
mod g2p;
mod grid_update;
mod p2g;
mod params;
mod solver;

pub use p2g::kirchhoff;
pub use params::{BodyForce, ExplicitParams, SoftWalls, Transfer, VolumeUpdate};
pub use solver::{ExplicitSolver, ScratchBytes, StageTimes, StepInfo};
