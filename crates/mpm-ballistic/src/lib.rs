//! A toy fourth solver: particles that do not interact, each in free flight under constant
//! gravity, bouncing off the faces of the grid box with a coefficient of restitution `e`.
//!
//! It exists to show (and to test) the seams a new solver goes through: it implements
//! [`mpm_core::Solver`], declares its own stage ([`stages::FLIGHT`]), energy term
//! ([`DISSIPATED_ENERGY`]) and output field (`speed`), and the CLI registers it with one line
//! behind the cargo feature `ballistic`. No grid is used: the box only bounds the flight.
//!
//! The flight is exact. Along each axis the motion `x(t) = x + v t + ½ g t²` is independent of
//! the other axes (walls are axis-aligned planes), so each axis is advanced from wall hit to
//! wall hit by solving that quadratic; a hit reverses the normal velocity and scales it by `e`.
//! The kinetic energy lost, `½ m v_n² (1 − e²)` per hit, is kept as [`DISSIPATED_ENERGY`], so
//! kinetic + potential + dissipated energy is constant to round-off.
//!
//! ```
//! use mpm_ballistic::{Ballistic, BallisticParams};
//! use mpm_core::prelude::*;
//!
//! // A 1 m box and a block of 2 × 2 particles per cell, 0.2 m below the lid.
//! let spec = GridSpec::<2>::covering(Vector::<2>::zeros(), Vector::<2>::new(1.0, 1.0), 0.1);
//! let materials = vec![Material::fluid(1000.0, 2e5, 0.0)];
//! let block = Body::new(Shape::cuboid([0.4, 0.6], [0.6, 0.8]), 0).lattice(2);
//! let particles = ParticlesBuilder::new(&spec, &materials).with(&block)?.build();
//! let mut sim = Ballistic::new(spec, BallisticParams::default(), materials, particles)?;
//! let e0 = sim.diagnostics().total_energy();
//! sim.run_until(2.0)?; // about three bounces on the floor
//! assert!((sim.diagnostics().total_energy() - e0).abs() < 1e-12 * e0.abs());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod flight;
mod seam;
#[cfg(test)]
mod tests;

use mpm_core::{
    Dim, DimOps, GridSpec, Material, Particles, Real, SetupError, StagePlan, StageTimes,
    StepControl, Vector,
};

pub use flight::fly;

/// The stages of a ballistic step beyond the ones [`mpm_core::Stage`] names.
pub mod stages {
    use mpm_core::Stage;

    /// Exact free flight of every particle with its wall bounces.
    pub const FLIGHT: Stage = Stage::new("flight");
}

/// The parameters the ballistic solver checks beyond [`mpm_core::parameters`].
pub mod parameters {
    mpm_core::declare_parameters! {
        /// Coefficient of restitution of the walls (dimensionless, in [0, 1]).
        RESTITUTION = "restitution";
    }
}

/// The output fields the ballistic solver computes beyond the particle columns and `pressure`.
pub mod fields {
    /// Speed `|v|` per particle (m/s).
    pub const SPEED: &str = "speed";
    /// Every ballistic-only output field.
    pub const ALL: &[&str] = &[SPEED];
}

/// Name of the energy term (J) the bounces have dissipated, in [`mpm_core::Diagnostics`].
pub const DISSIPATED_ENERGY: &str = "dissipated";

/// Parameters of [`Ballistic`].
#[derive(Clone, Debug, PartialEq)]
pub struct BallisticParams<const D: usize> {
    /// Gravity (m/s²; −9.81 on the last axis by default), time step and the reaction to
    /// instability. There is no gravity ramp and no damping. The flight is exact for any step:
    /// the adaptive bound only keeps a particle from crossing more than `cfl` cells per step
    /// (for smooth output).
    pub step: StepControl<D>,
    /// Coefficient of restitution `e` of the walls (dimensionless, in [0, 1]; 1 by default).
    pub restitution: Real,
}

impl<const D: usize> Default for BallisticParams<D> {
    fn default() -> Self {
        let mut step = StepControl::default();
        step.gravity[D - 1] = -9.81;
        Self {
            step,
            restitution: 1.0,
        }
    }
}

/// The ballistic solver: its particles, the box that bounds them and the energy dissipated.
#[derive(Clone, Debug)]
pub struct Ballistic<const D: usize> {
    spec: GridSpec<D>,
    params: BallisticParams<D>,
    materials: Vec<Material>,
    particles: Particles<D>,
    time: Real,
    steps: u64,
    dissipated: Real,
    plan: StagePlan,
    times: StageTimes,
}

impl<const D: usize> Ballistic<D>
where
    Dim<D>: DimOps<D>,
{
    /// A solver for `particles` inside the box of `spec`, at time 0. Errors: a restitution
    /// outside [0, 1], non-finite gravity, a gravity ramp or damping, an invalid time-step
    /// policy, a particle outside the box or naming a material that does not exist.
    pub fn new(
        spec: GridSpec<D>,
        params: BallisticParams<D>,
        materials: Vec<Material>,
        particles: Particles<D>,
    ) -> Result<Self, SetupError> {
        let e = params.restitution;
        if !(0.0..=1.0).contains(&e) {
            return Err(SetupError::InvalidParameter {
                name: parameters::RESTITUTION,
                value: e,
                reason: "must lie in [0, 1]",
            });
        }
        if let Some(g) = params.step.gravity.iter().find(|g| !g.is_finite()) {
            return Err(SetupError::InvalidParameter {
                name: mpm_core::parameters::GRAVITY,
                value: *g,
                reason: "must be finite",
            });
        }
        params.step.refuse_ramp_and_damping(
            "the ballistic flight is exact only under constant gravity",
            "the ballistic solver has no damping",
        )?;
        params.step.time_step.validate()?;
        let (lo, hi) = bounds(&spec);
        for (index, x) in particles.x.iter().enumerate() {
            if (0..D).any(|a| !(x[a] >= lo[a] && x[a] <= hi[a])) {
                return Err(SetupError::outside(index, x, &(lo, hi), "the grid box"));
            }
        }
        if let Some((index, &m)) =
            (particles.material.iter().enumerate()).find(|(_, &m)| m as usize >= materials.len())
        {
            return Err(SetupError::UnknownMaterial {
                index,
                material: m,
                count: materials.len(),
            });
        }
        let mut plan = StagePlan::default();
        plan.push(mpm_core::Stage::TIME_STEP, "min(cfl·dx / max |v|, dt_max)");
        plan.push(stages::FLIGHT, format!("exact parabolas, restitution {e}"));
        Ok(Self {
            spec,
            params,
            materials,
            particles,
            time: 0.0,
            steps: 0,
            dissipated: 0.0,
            plan,
            times: StageTimes::default(),
        })
    }

    /// The energy (J) the wall bounces have dissipated since time 0.
    pub fn dissipated(&self) -> Real {
        self.dissipated
    }
}

/// The lower and upper corners (m) of the box of `spec`.
pub(crate) fn bounds<const D: usize>(spec: &GridSpec<D>) -> (Vector<D>, Vector<D>) {
    let hi = Vector::<D>::from_fn(|a, _| spec.origin[a] + spec.dx * (spec.size[a] - 1) as Real);
    (spec.origin, hi)
}
