//! DIQ-MPM part 2 (diq-mpm §4.2–4.7, §5): the incompressible fluid of [`DiqFluid`] coupled to
//! mixed total-Lagrangian solids through one sparse SPD pressure-only system. The derivation of
//! the system (the mixed solid's pressure rows, the interface rows, Eq. 35, A-ULMPM and plastic
//! solids) is in `docs/diq-coupling.md`.
//!
//! # The step (§5.1)
//!
//! 1. **Time step.** `dt (|v|max + |g| dt) = cfl Δx` over fluid *and* solid particles, capped by
//!    `dt_max` (Table 1's `Δt_step`).
//! 2. **Fluid predictor** (when there is fluid): sort, APIC P2G to B1 nodes, `v* = v + Δt g`.
//! 3. **Solid elastic solve:** the implicit Newton TLMPM of `mpm-tlmpm` (P2G on the reference
//!    grid, gravity, the penalty contact of Eq. 4 with other solid particles and with walls and
//!    colliders, Newton on the backward-Euler incremental potential of the elastic energy
//!    `Ψ^s`), driven through its coupling stages ([`ImplicitTlmpm::elastic_predictor`] and the
//!    phase tokens that follow it): node velocities `V*`.
//! 4. **Dual interface quadrature** (§4.6, §5.2, stage `coupling`; `interface`).
//! 5. **Coupled projection** (§4.7, stage `coupling`; `rows`, `step`): one SPD system for the
//!    solid pressures `P^s`, fluid pressures `p`, wall pressures `y` and interface pressures
//!    `h`, iterated with the elastic solve of step 3 until the solid's projected velocity is its
//!    elastic response ([`CouplingIteration`]; one pass is the paper's split).
//! 6. **G2P** for both (the solid's F update and guards in `mpm-tlmpm`), the fluid's position
//!    correction, then commit and (A-ULMPM) the reference update.

use crate::fluid::{no_ramp_or_damping, DiqFluid, DiqParams};
use crate::pressure::PressureSystem;
use mpm_core::boundary::Boundaries;
use mpm_core::material::Plasticity;
use mpm_core::timestep::choose_dt;
use mpm_core::{
    retry_halving, Dim, DimOps, Failure, GridSpec, Material, Matrix, Particles, Real, SetupError,
    Solver, Stage, StagePlan, StageTimes, StepError, StepInfo, StepStart,
};
use mpm_tlmpm::{ImplicitTlmpm, TlmpmState};

mod interface;
mod params;
mod rows;
mod seam;
mod step;

pub use interface::InterfacePoints;
pub use params::{
    CoupledError, CouplingIteration, InterfaceQuadrature, SolidParams, BASE_F, DIVERGENCE,
    PRESSURE, REFERENCE_X, RELATIVE_F,
};

/// DIQ-MPM: the incompressible fluid and mixed TLMPM solids in one step, coupled through one
/// SPD pressure-only system (derived in `docs/diq-coupling.md`). Either part may be empty: a solids-only
/// scene has no fluid stage, and a fluid-only scene should use [`DiqFluid`] itself.
#[derive(Debug)]
pub struct DiqCoupled<const D: usize> {
    fluid: DiqFluid<D>,
    solid: ImplicitTlmpm<D>,
    /// Particles of the scene in its order (solids carry F; fluids F = I).
    particles: Particles<D>,
    materials: Vec<Material>,
    /// Scene index of each fluid particle, then of each solid particle.
    fluid_index: Vec<usize>,
    solid_index: Vec<usize>,
    /// `λ^v = λ/2` of each solid particle (Pa).
    lambda_v: Vec<Real>,
    /// Whether each solid particle's material is plastic: its volume term is measured from the
    /// elastic volume ratio `J_E` (`docs/diq-coupling.md`, "Plastic solids").
    plastic: Vec<bool>,
    /// Mixed pressure `P^s` of each solid particle (Pa).
    solid_pressure: Vec<Real>,
    /// Reference cell of each solid particle and the particles of each cell, in order.
    solid_cells: Vec<(usize, Vec<usize>)>,
    projection: PressureSystem<D>,
    correction: PressureSystem<D>,
    boundaries: Boundaries<D>,
    params: DiqParams<D>,
    solid_params: SolidParams<D>,
    time: Real,
    steps: u64,
    plan: StagePlan,
    times: StageTimes,
}

/// The particles `index` of `ps` with material indices renumbered by `material`: for solids
/// (`solid`) with their deformation gradients and plastic states, for the fluid without.
fn subset<const D: usize>(
    ps: &Particles<D>,
    index: &[usize],
    material: &[u32],
    solid: bool,
) -> Particles<D> {
    let mut out = ps.select(index);
    for m in &mut out.material {
        *m = material[*m as usize];
    }
    out.jacobian = None;
    if solid {
        out.def_grad = Some(index.iter().map(|&p| ps.def_grad_of(p)).collect());
    } else {
        out.def_grad = None;
        out.plastic = None;
    }
    out
}

impl<const D: usize> DiqCoupled<D>
where
    Dim<D>: DimOps<D>,
{
    /// Builds the solver from the scene's particles and materials: fluid materials go to the
    /// incompressible fluid, elastic solid materials to the mixed TLMPM (λ > 0 required, i.e.
    /// Poisson's ratio above 0). Walls and colliders must be free slip for the fluid; solids
    /// meet them through the penalty contact of `solid.tlmpm.contact`.
    pub fn new(
        spec: GridSpec<D>,
        params: DiqParams<D>,
        solid: SolidParams<D>,
        materials: Vec<Material>,
        boundaries: Boundaries<D>,
        particles: Particles<D>,
    ) -> Result<Self, SetupError> {
        Self::build(
            spec, params, solid, materials, boundaries, particles, None, 0.0,
        )
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn build(
        spec: GridSpec<D>,
        params: DiqParams<D>,
        solid_params: SolidParams<D>,
        materials: Vec<Material>,
        boundaries: Boundaries<D>,
        mut particles: Particles<D>,
        restart: Option<TlmpmState<D>>,
        time: Real,
    ) -> Result<Self, SetupError> {
        let is_fluid: Vec<bool> = materials
            .iter()
            .map(|m| matches!(m, Material::Fluid(_)))
            .collect();
        let (mut fluid_mats, mut solid_mats) = (Vec::new(), Vec::new());
        let renumber: Vec<u32> = materials
            .iter()
            .map(|m| {
                let list = if matches!(m, Material::Fluid(_)) {
                    &mut fluid_mats
                } else {
                    &mut solid_mats
                };
                list.push(m.clone());
                (list.len() - 1) as u32
            })
            .collect();
        for (i, &m) in particles.material.iter().enumerate() {
            if m as usize >= materials.len() {
                return Err(SetupError::UnknownMaterial {
                    index: i,
                    material: m,
                    count: materials.len(),
                });
            }
        }
        let (fluid_index, solid_index): (Vec<usize>, Vec<usize>) =
            (0..particles.len()).partition(|&p| is_fluid[particles.material[p] as usize]);
        if solid_index.is_empty() {
            return Err(SetupError::InvalidSetting {
                setting: crate::settings::MATERIALS.into(),
                reason: "the coupled DIQ solver needs a solid; a fluid alone runs on the DIQ \
                         fluid solver"
                    .into(),
            });
        }
        let mut lambda_v = Vec::with_capacity(solid_index.len());
        let mut plastic = Vec::with_capacity(solid_index.len());
        for &p in &solid_index {
            let lambda = match &materials[particles.material[p] as usize] {
                Material::Solid(s) => {
                    plastic.push(!matches!(s.plasticity, Plasticity::None));
                    s.elastic.lame().lambda
                }
                Material::Fluid(_) => unreachable!("partitioned above"),
            };
            if !(lambda > 0.0 && lambda.is_finite()) {
                return Err(SetupError::InvalidParameter {
                    name: crate::parameters::LAMBDA,
                    value: lambda,
                    reason: "the mixed solid needs a positive first Lamé parameter (Poisson's \
                             ratio above 0): λ^v = λ/2 is its pressure stiffness",
                });
            }
            lambda_v.push(0.5 * lambda);
        }
        let fluid_ps = subset(&particles, &fluid_index, &renumber, false);
        let solid_ps = subset(&particles, &solid_index, &renumber, true);
        let fluid = DiqFluid::at_time(
            spec,
            params.clone(),
            fluid_mats,
            boundaries.clone(),
            fluid_ps,
            time,
        )?;
        // The solids take the fluid's step control; a ramp or damping of their own would be
        // dropped, so it is rejected as the fluid's is.
        no_ramp_or_damping(&solid_params.tlmpm.step)?;
        let mut tl = solid_params.tlmpm.clone();
        tl.step = params.step;
        let mut solid = ImplicitTlmpm::new(spec, tl, solid_params.implicit, solid_mats, solid_ps)?;
        let mut steps = 0;
        if let Some(state) = restart {
            // The reference configuration of a resumed run is the saved one, not the current
            // positions (and, with A-ULMPM, the saved F^(r,n) and F^(0,r)).
            steps = state.steps;
            solid.restore(state)?;
        }
        if particles.def_grad.is_none() {
            particles.def_grad = Some(vec![Matrix::<D>::identity(); particles.len()]);
        }
        particles.jacobian = None;
        let n_solid = solid_index.len();
        let mut s = Self {
            fluid,
            solid,
            particles,
            materials,
            fluid_index,
            solid_index,
            lambda_v,
            plastic,
            solid_pressure: vec![0.0; n_solid],
            solid_cells: Vec::new(),
            projection: PressureSystem::new(),
            correction: PressureSystem::new(),
            boundaries,
            params,
            solid_params,
            time,
            steps,
            plan: StagePlan::default(),
            times: StageTimes::default(),
        };
        s.bin_solid_cells();
        s.plan = s.make_plan();
        Ok(s)
    }

    /// Groups the solid particles by the reference-grid cell of their reference position.
    pub(super) fn bin_solid_cells(&mut self) {
        let spec = *Solver::spec(&self.fluid);
        let cells: [usize; D] = std::array::from_fn(|a| spec.size[a].saturating_sub(1).max(1));
        let x = self.solid.reference().positions();
        let mut keyed: Vec<(usize, usize)> = x
            .iter()
            .enumerate()
            .map(|(p, x)| {
                let mut c = 0;
                for a in (0..D).rev() {
                    let k = ((x[a] - spec.origin[a]) / spec.dx).floor();
                    let k = (k.max(0.0) as usize).min(cells[a] - 1);
                    c = c * cells[a] + k;
                }
                (c, p)
            })
            .collect();
        keyed.sort_unstable();
        self.solid_cells = keyed
            .chunk_by(|a, b| a.0 == b.0)
            .map(|g| (g[0].0, g.iter().map(|&(_, p)| p).collect()))
            .collect();
    }

    pub(super) fn has_fluid(&self) -> bool {
        !self.fluid_index.is_empty()
    }

    pub(super) fn make_plan(&self) -> StagePlan {
        let mut plan = StagePlan::default();
        let fluid = self.has_fluid();
        plan.push(
            mpm_tlmpm::stages::REFERENCE,
            "at set-up: the solids' reference weights, gradients and node masses",
        );
        plan.push(
            Stage::TIME_STEP,
            self.params
                .step
                .time_step
                .describe("Δx / max(|v| + |g| dt) over fluid and solid particles"),
        );
        if fluid {
            plan.push(Stage::SORT, "bin fluid particles by cell");
        }
        plan.push(
            Stage::P2G,
            if fluid {
                "fluid: APIC to linear B-spline (B1) nodes; solid: momentum to the reference grid"
            } else {
                "solid: momentum to the reference grid"
            },
        );
        if fluid {
            plan.push(
                Stage::GRID_UPDATE,
                format!("fluid {}", self.fluid.predictor_plan()),
            );
        }
        plan.push(mpm_tlmpm::stages::EXTERNAL_FORCES, "solid: gravity");
        if let Some(c) = &self.solid_params.tlmpm.contact {
            plan.push(
                mpm_tlmpm::stages::CONTACT,
                format!(
                    "solid: Eq. 4 particle pairs, radius {:?}; {} wall/collider obstacle(s)",
                    c.radius,
                    c.obstacles.len()
                ),
            );
        }
        plan.push(
            Stage::SOLVE,
            "solid: Newton elastic solve on the backward-Euler potential of Ψ^s (V*)",
        );
        plan.push(
            crate::stages::COUPLING,
            format!(
                "{}coupled pressure-only system (Eq. 35) by {}",
                match (fluid, self.solid_params.interface) {
                    (false, _) => "solid pressures: ",
                    (true, InterfaceQuadrature::SolidParticles) => {
                        "interface quadrature points and normals (Eq. 36), "
                    }
                    (true, InterfaceQuadrature::FluidNodes) => {
                        "interface rows at the fluid's boundary nodes (not in the paper), "
                    }
                },
                self.params.pressure.method.describe()
            ),
        );
        plan.push(
            Stage::G2P,
            if fluid {
                "solid: F update and guards; fluid: APIC G2P, advection, clamping"
            } else {
                "solid: F update and guards"
            },
        );
        if fluid && self.params.position_correction {
            plan.push(
                crate::stages::POSITION_CORRECTION,
                "fluid: volume-preserving position correction",
            );
        }
        plan.push(
            Stage::COMMIT,
            if self.plastic.contains(&true) {
                "write checked updates; P^s to particles, J^s remapped, plastic P^s scaled with \
                 the return mapping's det F_E / det F_E^trial"
            } else {
                "write checked updates; P^s to particles, J^s remapped"
            },
        );
        if let Some(r) = &self.solid_params.tlmpm.reference_update {
            plan.push(
                mpm_tlmpm::stages::REFERENCE_UPDATE,
                format!("A-ULMPM trigger: epsilon = {}, eta = {}", r.epsilon, r.eta),
            );
        }
        plan
    }

    /// The remapped volume ratio `J_p = 1 − P_p/λ^v_p` of each solid particle.
    pub fn solid_jacobian(&self) -> Vec<Real> {
        self.solid_pressure
            .iter()
            .zip(&self.lambda_v)
            .map(|(p, l)| 1.0 - p / l)
            .collect()
    }

    /// The mixed pressure `P^s` of each solid particle (Pa), in solid order.
    pub fn solid_pressure(&self) -> &[Real] {
        &self.solid_pressure
    }

    /// Scene indices of the solid particles, in solid order.
    pub fn solid_indices(&self) -> &[usize] {
        &self.solid_index
    }

    /// Scene indices of the fluid particles, in fluid order.
    pub fn fluid_indices(&self) -> &[usize] {
        &self.fluid_index
    }

    /// The fluid part.
    pub fn fluid(&self) -> &DiqFluid<D> {
        &self.fluid
    }

    /// The solid part.
    pub fn solid(&self) -> &ImplicitTlmpm<D> {
        &self.solid
    }

    /// The last assembled coupled system, for tests and benchmarks.
    pub fn system(&self) -> &PressureSystem<D> {
        &self.projection
    }

    /// Copies the parts' particles into the scene-ordered set.
    pub(super) fn gather_particles(&mut self) {
        let fp = Solver::particles(&self.fluid);
        let sp = self.solid.particles();
        let ps = &mut self.particles;
        for (k, &p) in self.fluid_index.iter().enumerate() {
            ps.x[p] = fp.x[k];
            ps.v[p] = fp.v[k];
            ps.affine[p] = fp.affine[k];
        }
        let f = ps.def_grad.as_mut().expect("set at build");
        for (k, &p) in self.solid_index.iter().enumerate() {
            ps.x[p] = sp.x[k];
            ps.v[p] = sp.v[k];
            ps.affine[p] = sp.affine[k];
            f[p] = sp.def_grad_of(k);
            if let (Some(dst), Some(src)) = (&mut ps.plastic, &sp.plastic) {
                dst[p] = src[k];
            }
        }
    }

    /// The step bound (s): no particle, fluid or solid, moves more than `cfl Δx`.
    pub(super) fn bound(&self) -> Real {
        let vmax = self
            .particles
            .v
            .iter()
            .fold(0.0, |m: Real, v| mpm_core::solver::nan_max(m, v.norm()));
        self.fluid.displacement_bound(vmax)
    }

    /// [`Solver::step`] on the calling thread, with the solve errors typed.
    pub(super) fn advance_step(&mut self) -> Result<StepInfo, StepError<CoupledError>> {
        let start = StepStart {
            step: self.steps,
            time: self.time,
        };
        let t0 = std::time::Instant::now();
        let stable = self.bound();
        self.times.add(Stage::TIME_STEP, t0.elapsed());
        let dt0 = choose_dt(&self.params.step.time_step, stable)
            .map_err(|e| start.error(Failure::Guard(Stage::TIME_STEP, e), 0.0, 0))?;
        let (pending, dt, retries) =
            retry_halving(self.params.step.on_instability, start, dt0, |dt| {
                self.attempt(dt)
            })?;
        let (solves, iq) = (pending.solves.clone(), pending.interface_points);
        let pairs = pending.contact_pairs;
        let updated = self
            .commit(pending, dt)
            .map_err(|f| start.error(f, dt, retries))?;
        let mut events = vec![("interface_points", iq as u64)];
        if let Some(n) = pairs {
            events.push(("contact_pairs", n as u64));
        }
        if updated {
            events.push(("reference_updates", 1));
        }
        Ok(StepInfo {
            dt,
            retries,
            time: self.time,
            solves,
            events,
            residual_histories: Vec::new(),
        })
    }

    /// Per-particle pressure in scene order (Pa).
    pub(super) fn scene_pressure(&self) -> Vec<Real> {
        let mut out = vec![0.0; self.particles.len()];
        for (k, &p) in self.fluid_index.iter().enumerate() {
            out[p] = self.fluid.particle_pressure()[k];
        }
        for (k, &p) in self.solid_index.iter().enumerate() {
            out[p] = self.solid_pressure[k];
        }
        out
    }

    /// Per-particle fluid divergence in scene order (1/s; 0 on solids).
    pub(super) fn scene_divergence(&self) -> Vec<Real> {
        let mut out = vec![0.0; self.particles.len()];
        for (k, &p) in self.fluid_index.iter().enumerate() {
            out[p] = self.fluid.particle_divergence()[k];
        }
        out
    }
}
