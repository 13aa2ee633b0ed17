//! `solver = "explicit"`: explicit MLS-MPM (`mpm-explicit`) on one grid or several coupled ones.
//! [`scene`] reads and resolves the tables and keys only this solver reads (with the multi-grid
//! tables of [`multigrid`]); [`build`] makes the solver from the resolved scene.

pub mod build;
pub mod multigrid;
pub mod scene;
