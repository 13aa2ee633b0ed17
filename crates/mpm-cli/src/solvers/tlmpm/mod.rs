//! `solver = "tlmpm"`: total-Lagrangian MPM (`mpm-tlmpm`), implicit or explicit. [`scene`]
//! reads and resolves the tables and keys only this solver reads; [`build`] makes the solver
//! from the resolved scene.

pub mod build;
pub mod scene;
