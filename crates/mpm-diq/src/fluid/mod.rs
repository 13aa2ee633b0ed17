//! The incompressible MPM fluid solver of DIQ-MPM (diq-mpm §4–5.1, fluid part).
//!
//! This module holds [`DiqFluid`], its parameters and its set-up checks; the stages live in
//! submodules by concern:
//! - `transfer`: binning particles by cell, APIC P2G to the linear B-spline nodes, and G2P with
//!   advection and clamping;
//! - `projection`: the rows of `J = [G^fᵀ; B]` and the pressure projection onto them;
//! - `correction`: the volume-preserving position correction and the fluid volume;
//! - `step`: the adaptive step bound, one attempt at a step and its commit;
//! - `seam`: the [`Solver`](mpm_core::Solver) implementation (checkpoint, restore, outputs).

mod correction;
mod projection;
mod seam;
mod step;
mod transfer;

pub(crate) use step::Attempt;
pub(crate) use transfer::{Bins, NodeFields, Points};

use crate::domain::{Domain, WallSample};
use crate::parameters::{GRID, MASS, PRESSURE_MAX_ITERATIONS, PRESSURE_REL_TOL};
use crate::pressure::{PressureParams, PressureSystem};
use crate::settings;
use mpm_core::boundary::{Boundaries, ContactKind};
use mpm_core::parameters::GRAVITY;
use mpm_core::solver::DtBound;
use mpm_core::{
    Dim, DimOps, GridSpec, Material, Parameter, Particles, Real, SetupError, Stage, StagePlan,
    StageTimes, StepControl, Vector,
};
use serde::{Deserialize, Serialize};

/// Parameters of the DIQ fluid solver.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiqParams<const D: usize> {
    /// Gravity, time step, damping and the reaction to instability. With
    /// [`TimeStepPolicy::Adaptive`](mpm_core::TimeStepPolicy::Adaptive), `cfl` is the fraction of Δx a particle may travel in one
    /// step (0.4 in the paper's Table 1): `dt (|v|max + |g| dt) = cfl Δx`. The reaction covers
    /// a failed guard check and a failed pressure solve. DIQ has neither a gravity ramp nor
    /// damping: set-up rejects a ramp and damping that is on. Serialised under the old keys
    /// `time_step`, `gravity` and `on_instability`.
    #[serde(flatten)]
    pub step: StepControl<D>,
    /// The pressure solve.
    pub pressure: PressureParams,
    /// The volume-preserving position correction after advection (on by default).
    pub position_correction: bool,
    /// Where `G^f` is integrated (see [`GradientQuadrature`]).
    #[serde(default)]
    pub gradient_quadrature: GradientQuadrature,
}

/// The quadrature of the fluid gradient operator `G^f_{cα,i} = −∫_cell i ∂_α w_c dx` (Eq. 30)
/// over the fluid in cell `i`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GradientQuadrature {
    /// One point per cell: the fluid volume of the cell (the sum of its particles' volumes)
    /// times `∇w_c` at the cell centre, which is the cell integral of `∇w_c` scaled by the
    /// cell's fluid fraction. The default: the operator depends on where particles are only
    /// through which cell holds them, so a fluid at rest stays at rest.
    #[default]
    CellCentre,
    /// One point per particle, `−Σ_p V_p ∇w_c(x_p)` (the paper's particle quadrature). The
    /// hydrostatic state is then unstable: the pressure turns sub-cell rearrangements of the
    /// particles into a negative stiffness, and round-off grows at a rate ≈ `√(p/ρ)/Δx`
    /// (measured 26 s⁻¹ at Δx = 1/16 m and 57 s⁻¹ at 1/32 m under 0.5 m of water).
    Particles,
}

impl<const D: usize> Default for DiqParams<D> {
    /// Adaptive dt with cfl 0.4 and `dt_max = 1e-3 s`, gravity −9.81 m/s² on the last axis,
    /// abort on failure, default pressure solve, position correction on.
    fn default() -> Self {
        let mut gravity = Vector::<D>::zeros();
        gravity[D - 1] = -9.81;
        Self {
            step: StepControl {
                gravity,
                ..StepControl::default()
            },
            pressure: PressureParams::default(),
            position_correction: true,
            gradient_quadrature: GradientQuadrature::default(),
        }
    }
}

/// The adaptive step bound of the DIQ solvers, for `mpm-cli check`.
pub(crate) fn displacement_bound_doc() -> DtBound {
    DtBound {
        description: "no particle moves more than cfl·Δx: dt (|v|max + |g| dt) = cfl·Δx",
        limits_fixed_dt: true,
    }
}

/// Particles closer than this fraction of Δx to a wall or collider surface are moved out to that
/// distance.
pub(crate) const CLAMP_MARGIN: Real = 1e-3;

/// DIQ-MPM's incompressible fluid: APIC transfers to linear B-spline (B1) nodes, cell-constant
/// (B0) pressures, free-slip walls and colliders through boundary pressures, one SPD
/// pressure-only system per step, and a volume-preserving position correction.
#[derive(Debug)]
pub struct DiqFluid<const D: usize> {
    domain: Domain<D>,
    params: DiqParams<D>,
    materials: Vec<Material>,
    boundaries: Boundaries<D>,
    particles: Particles<D>,
    time: Real,
    steps: u64,
    /// Dynamic viscosity μ of each particle's material (Pa·s).
    viscosity: Vec<Real>,
    /// Solved pressure of each particle's cell at the last step (Pa).
    pressure: Vec<Real>,
    /// Discrete divergence of each particle's cell after the last projection (1/s).
    divergence: Vec<Real>,
    /// The static wall quadrature points, sorted by (node, face).
    wall_points: Vec<WallSample<D>>,
    /// CSR of `wall_points` by cell.
    wall_by_cell: (Vec<usize>, Vec<usize>),
    projection: PressureSystem<D>,
    correction: PressureSystem<D>,
    plan: StagePlan,
    times: StageTimes,
}

fn invalid(name: Parameter, value: Real, reason: &'static str) -> SetupError {
    SetupError::InvalidParameter {
        name,
        value,
        reason,
    }
}

/// Rejects a gravity ramp and damping that is on: DIQ loads gravity in full from the start and
/// has no damping term.
pub(crate) fn no_ramp_or_damping<const D: usize>(step: &StepControl<D>) -> Result<(), SetupError> {
    step.refuse_ramp_and_damping("DIQ has no gravity ramp", "DIQ has no damping")
}

impl<const D: usize> DiqFluid<D>
where
    Dim<D>: DimOps<D>,
{
    /// Builds the solver. Every material must be a fluid (its density and its viscosity are
    /// used, the equation of state is not: this fluid is incompressible; a viscosity above zero
    /// adds the implicit viscous solve of [`crate::viscosity`]); walls and colliders
    /// must be free slip without friction (Eq. 25); every particle must lie inside the wall box.
    pub fn new(
        spec: GridSpec<D>,
        params: DiqParams<D>,
        materials: Vec<Material>,
        boundaries: Boundaries<D>,
        particles: Particles<D>,
    ) -> Result<Self, SetupError> {
        Self::at_time(spec, params, materials, boundaries, particles, 0.0)
    }

    /// [`Self::new`] for a state at time `time` (s): colliders, which move at constant
    /// velocity, are checked where they are then.
    pub(crate) fn at_time(
        spec: GridSpec<D>,
        params: DiqParams<D>,
        materials: Vec<Material>,
        boundaries: Boundaries<D>,
        mut particles: Particles<D>,
        time: Real,
    ) -> Result<Self, SetupError> {
        params.step.time_step.validate()?;
        if !params.step.gravity.iter().all(|g| g.is_finite()) {
            return Err(invalid(GRAVITY, Real::NAN, "must be finite"));
        }
        no_ramp_or_damping(&params.step)?;
        let p = &params.pressure;
        if !(p.rel_tol > 0.0 && p.rel_tol < 1.0) {
            return Err(invalid(PRESSURE_REL_TOL, p.rel_tol, "must lie in (0, 1)"));
        }
        if p.max_iterations == 0 {
            return Err(invalid(PRESSURE_MAX_ITERATIONS, 0.0, "must be at least 1"));
        }
        for (i, m) in materials.iter().enumerate() {
            match m {
                Material::Fluid(_) => {}
                Material::Solid(_) => {
                    return Err(SetupError::InvalidSetting {
                        setting: settings::material(i),
                        reason: "the DIQ solver takes fluid materials only (solids come with \
                                 the DIQ coupling)"
                            .into(),
                    })
                }
            }
        }
        let thickness = match &boundaries.walls {
            Some(w) => {
                if w.contact.kind != ContactKind::Slip || w.contact.friction != 0.0 {
                    return Err(SetupError::InvalidSetting {
                        setting: settings::WALLS.into(),
                        reason: "DIQ walls are free slip (v·n = 0, Eq. 25): use kind = \"slip\" \
                                 without friction"
                            .into(),
                    });
                }
                w.thickness.max(1)
            }
            None => 1,
        };
        let domain = Domain::new(
            spec,
            thickness,
            boundaries.walls.is_some(),
            boundaries.colliders.clone(),
        );
        if !domain.colliders_are_slip() {
            return Err(SetupError::InvalidSetting {
                setting: settings::COLLIDERS.into(),
                reason: "DIQ colliders are free slip (v·n = v_b·n, Eq. 25): use kind = \"slip\" \
                         without friction"
                    .into(),
            });
        }
        if !domain.is_valid() {
            return Err(invalid(
                GRID,
                spec.size.iter().copied().min().unwrap_or(0) as Real,
                "the box inside the walls must hold at least 2 cells per axis",
            ));
        }
        for i in 0..particles.len() {
            if domain.locate(&particles.x[i]).is_none() {
                return Err(SetupError::outside(
                    i,
                    &particles.x[i],
                    &(domain.lo(), domain.hi()),
                    domain.interior_name(),
                ));
            }
            if let Some(k) = domain.colliders.iter().position(|c| {
                c.shape
                    .signed_distance(&(particles.x[i] - c.velocity * time))
                    .0
                    < 0.0
            }) {
                return Err(SetupError::InvalidSetting {
                    setting: settings::COLLIDERS.into(),
                    reason: format!(
                        "particle {i} at {:?} lies inside collider {k} at t = {time} s: fluid \
                         cannot overlap a collider; move the body or the collider",
                        particles.x[i].as_slice()
                    ),
                });
            }
            let m = particles.material[i] as usize;
            if m >= materials.len() {
                return Err(SetupError::UnknownMaterial {
                    index: i,
                    material: m as u32,
                    count: materials.len(),
                });
            }
            if !(particles.mass[i] > 0.0 && particles.volume0[i] > 0.0) {
                return Err(invalid(
                    MASS,
                    particles.mass[i],
                    "particle mass and volume must be positive",
                ));
            }
        }
        // An incompressible particle has no deformation state.
        particles.jacobian = None;
        particles.def_grad = None;
        particles.plastic = None;
        let wall_points = domain.wall_points();
        let mut start = vec![0usize; domain.num_cells() + 1];
        for w in &wall_points {
            start[domain.cell_index(&w.cell) + 1] += 1;
        }
        for c in 0..domain.num_cells() {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut list = vec![0usize; wall_points.len()];
        for (i, w) in wall_points.iter().enumerate() {
            let c = domain.cell_index(&w.cell);
            list[fill[c]] = i;
            fill[c] += 1;
        }
        let wall_by_cell = (start, list);
        let n = particles.len();
        let viscosity = particles
            .material
            .iter()
            .map(|&m| match &materials[m as usize] {
                Material::Fluid(f) => f.viscosity,
                Material::Solid(_) => 0.0,
            })
            .collect();
        let mut solver = Self {
            domain,
            params,
            viscosity,
            materials,
            boundaries,
            particles,
            time: 0.0,
            steps: 0,
            pressure: vec![0.0; n],
            divergence: vec![0.0; n],
            wall_points,
            wall_by_cell,
            projection: PressureSystem::new(),
            correction: PressureSystem::new(),
            plan: StagePlan::default(),
            times: StageTimes::default(),
        };
        solver.plan = solver.make_plan();
        Ok(solver)
    }

    fn make_plan(&self) -> StagePlan {
        let mut plan = StagePlan::default();
        plan.push(
            Stage::TIME_STEP,
            self.params
                .step
                .time_step
                .describe("Δx / max(|v| + |g| dt)"),
        );
        plan.push(Stage::SORT, "bin particles by cell");
        plan.push(
            Stage::P2G,
            "APIC to linear B-spline (B1) nodes: lumped mass M^f, momentum",
        );
        plan.push(Stage::GRID_UPDATE, self.predictor_plan());
        let walls = match (self.domain.walls, self.domain.colliders.len()) {
            (true, 0) => "slip walls".to_string(),
            (true, k) => format!("slip walls and {k} collider(s)"),
            (false, 0) => "no walls".to_string(),
            (false, k) => format!("{k} collider(s)"),
        };
        plan.push(
            Stage::SOLVE,
            format!(
                "pressure-only SPD system (B0 fluid pressures, boundary pressures on {walls}): {}, rel. tol {:e}",
                self.params.pressure.method.describe(),
                self.params.pressure.rel_tol
            ),
        );
        plan.push(
            Stage::G2P,
            "APIC velocity and affine field, advection, clamping into walls and out of colliders",
        );
        if self.params.position_correction {
            plan.push(
                crate::stages::POSITION_CORRECTION,
                "volume-preserving position correction (Kugelstadt et al. 2019)",
            );
        }
        plan
    }

    /// The grid update's line of the plan: the predictor, and the implicit viscosity when a
    /// particle is viscous.
    pub(crate) fn predictor_plan(&self) -> String {
        let mu = self.viscosity.iter().copied().fold(0.0, Real::max);
        if mu > 0.0 {
            format!(
                "predictor v* = v + dt g, then implicit viscosity (μ up to {mu:e} Pa·s): \
                 (M + dt K) v = M v*, Jacobi CG"
            )
        } else {
            "predictor v* = v + dt g".into()
        }
    }

    /// The fluid domain (walls, colliders, cells).
    pub fn domain(&self) -> &Domain<D> {
        &self.domain
    }

    /// The parameters.
    pub fn params(&self) -> &DiqParams<D> {
        &self.params
    }

    /// Pressure of each particle's cell at the last step (Pa).
    pub fn particle_pressure(&self) -> &[Real] {
        &self.pressure
    }

    /// Discrete divergence `−(G^fᵀ v)_cell / V_cell` of each particle's cell after the last
    /// projection (1/s).
    pub fn particle_divergence(&self) -> &[Real] {
        &self.divergence
    }

    /// Sets the time (s), step count and per-particle pressure (Pa) and divergence (1/s) of a
    /// resumed run.
    pub(crate) fn set_state(
        &mut self,
        time: Real,
        steps: u64,
        pressure: Vec<Real>,
        divergence: Vec<Real>,
    ) {
        self.time = time;
        self.steps = steps;
        self.pressure = pressure;
        self.divergence = divergence;
    }

    /// Positions (m), for the coupled solver's push-out of fluid particles from solids.
    pub(crate) fn positions_mut(&mut self) -> &mut [Vector<D>] {
        &mut self.particles.x
    }

    /// Velocities, for tests and set-ups (m/s).
    pub fn velocities_mut(&mut self) -> &mut [Vector<D>] {
        &mut self.particles.v
    }
}
