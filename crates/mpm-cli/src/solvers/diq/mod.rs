//! `solver = "diq"`: DIQ-MPM's incompressible fluid (`mpm-diq`), coupled to mixed TLMPM solids
//! when the scene has solid materials. [`scene`] reads and resolves the tables and keys only
//! this solver reads; [`build`] makes the solver from the resolved scene.

pub mod build;
pub mod scene;
