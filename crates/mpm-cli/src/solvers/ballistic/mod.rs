//! `solver = "ballistic"` (cargo feature `ballistic`): the toy solver of `mpm-ballistic`,
//! particles in free flight bouncing off the grid box. [`scene`] reads its table `[ballistic]`;
//! [`build`] makes the solver from the resolved scene.

pub mod build;
pub mod scene;
