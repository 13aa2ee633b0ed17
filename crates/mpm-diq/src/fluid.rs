//! The incompressible MPM fluid solver of DIQ-MPM (diq-mpm §4–5.1, fluid part).

use crate::domain::{corner_weights, Domain, WallSample};
use crate::pressure::{
    Constraints, PressureError, PressureInfo, PressureParams, PressureSystem, UnknownKind,
};
use crate::viscosity::Viscous;
use mpm_core::boundary::{Boundaries, ContactKind};
use mpm_core::columns::{self, Column};
use mpm_core::solver::{on_pool, DtBound, FieldInfo, RestoreError, StageTime};
use mpm_core::timestep::choose_dt;
use mpm_core::{
    retry_halving, Diagnostics, Dim, DimOps, Failure, GridSpec, Location, Material, Matrix,
    Monitor, OnInstability, Particles, Real, SetupError, SolveInfo, Solver, SolverState, Stage,
    StagePlan, StageTimes, StepError, StepInfo, StepStart, TimeStepPolicy, Vector, Violation,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Parameters of the DIQ fluid solver.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiqParams<const D: usize> {
    /// Time step. With [`TimeStepPolicy::Adaptive`], `cfl` is the fraction of Δx a particle may
    /// travel in one step (0.4 in the paper's Table 1): `dt (|v|max + |g| dt) = cfl Δx`.
    pub time_step: TimeStepPolicy,
    /// Gravity (m/s²).
    pub gravity: Vector<D>,
    /// Abort, or retry at dt/2, when a guard check or the pressure solve fails.
    pub on_instability: OnInstability,
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
            time_step: TimeStepPolicy::default(),
            gravity,
            on_instability: OnInstability::Abort,
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

/// Particles binned by cell: `order[start[c]..start[c+1]]` are the particles of cell `c`, in
/// index order.
#[derive(Clone, Debug, Default)]
pub(crate) struct Bins {
    start: Vec<usize>,
    order: Vec<usize>,
    /// Cell of each particle.
    pub(crate) cell: Vec<usize>,
}

impl Bins {
    pub(crate) fn of(&self, c: usize) -> &[usize] {
        &self.order[self.start[c]..self.start[c + 1]]
    }
}

/// Node fields of one transfer.
#[derive(Clone, Debug, Default)]
pub(crate) struct NodeFields<const D: usize> {
    pub(crate) mass: Vec<Real>,
    /// Momentum, then velocity (m/s).
    pub(crate) velocity: Vec<Vector<D>>,
    /// Particle volume transferred to the node (m^D).
    pub(crate) volume: Vec<Real>,
    pub(crate) inv_mass: Vec<Real>,
    /// What the implicit viscosity's solve did, when a particle is viscous.
    pub(crate) viscous: Option<SolveInfo>,
}

/// The points a fluid transfer integrates over: the fluid particles, or (coupled solver) the
/// particles with part of their mass moved onto nearby interface points.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Points<'a, const D: usize> {
    /// Positions (m).
    pub(crate) x: &'a [Vector<D>],
    /// Velocities (m/s).
    pub(crate) v: &'a [Vector<D>],
    /// APIC affine matrices (1/s).
    pub(crate) affine: &'a [Matrix<D>],
    /// Masses (kg).
    pub(crate) mass: &'a [Real],
    /// Volumes (m^D).
    pub(crate) volume: &'a [Real],
}

impl<'a, const D: usize> Points<'a, D> {
    /// The particles themselves.
    pub(crate) fn of(ps: &'a Particles<D>) -> Self {
        Self {
            x: &ps.x,
            v: &ps.v,
            affine: &ps.affine,
            mass: &ps.mass,
            volume: &ps.volume0,
        }
    }
}

/// The outcome of one attempt, committed when accepted.
pub(crate) struct Attempt<const D: usize> {
    pub(crate) x: Vec<Vector<D>>,
    pub(crate) v: Vec<Vector<D>>,
    pub(crate) affine: Vec<Matrix<D>>,
    pub(crate) pressure: Vec<Real>,
    pub(crate) divergence: Vec<Real>,
    pub(crate) solves: Vec<SolveInfo>,
    pub(crate) events: Vec<(&'static str, u64)>,
}

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

fn invalid(name: &'static str, value: Real, reason: &'static str) -> SetupError {
    SetupError::InvalidParameter {
        name,
        value,
        reason,
    }
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
        params.time_step.validate()?;
        if !params.gravity.iter().all(|g| g.is_finite()) {
            return Err(invalid("gravity", Real::NAN, "must be finite"));
        }
        let p = &params.pressure;
        if !(p.rel_tol > 0.0 && p.rel_tol < 1.0) {
            return Err(invalid("pressure.rel_tol", p.rel_tol, "must lie in (0, 1)"));
        }
        if p.max_iterations == 0 {
            return Err(invalid(
                "pressure.max_iterations",
                0.0,
                "must be at least 1",
            ));
        }
        for (i, m) in materials.iter().enumerate() {
            match m {
                Material::Fluid(_) => {}
                Material::Solid(_) => {
                    return Err(SetupError::InvalidSetting {
                        setting: format!("material {i}"),
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
                        setting: "walls".into(),
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
                setting: "colliders".into(),
                reason: "DIQ colliders are free slip (v·n = v_b·n, Eq. 25): use kind = \"slip\" \
                         without friction"
                    .into(),
            });
        }
        if !domain.is_valid() {
            return Err(invalid(
                "grid",
                spec.size.iter().copied().min().unwrap_or(0) as Real,
                "the box inside the walls must hold at least 2 cells per axis",
            ));
        }
        for i in 0..particles.len() {
            if domain.locate(&particles.x[i]).is_none() {
                return Err(SetupError::ParticleOutsideGrid {
                    index: i,
                    position: format!("{:?}", particles.x[i].as_slice()),
                });
            }
            if let Some(k) = domain.colliders.iter().position(|c| {
                c.shape
                    .signed_distance(&(particles.x[i] - c.velocity * time))
                    .0
                    < 0.0
            }) {
                return Err(SetupError::InvalidSetting {
                    setting: "colliders".into(),
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
                    "mass",
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
            Stage::TimeStep,
            self.params.time_step.describe("Δx / max(|v| + |g| dt)"),
        );
        plan.push(Stage::Sort, "bin particles by cell");
        plan.push(
            Stage::P2G,
            "APIC to linear B-spline (B1) nodes: lumped mass M^f, momentum",
        );
        plan.push(Stage::GridUpdate, self.predictor_plan());
        let walls = match (self.domain.walls, self.domain.colliders.len()) {
            (true, 0) => "slip walls".to_string(),
            (true, k) => format!("slip walls and {k} collider(s)"),
            (false, 0) => "no walls".to_string(),
            (false, k) => format!("{k} collider(s)"),
        };
        plan.push(
            Stage::Solve,
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
                Stage::PositionCorrection,
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

    /// The pressure system a step of `dt` (s) would solve from the current state, for
    /// benchmarks: the rows of `J`, the inverse lumped node masses (1/kg, 0 without mass) and
    /// the right-hand side `J v* − b` (m³/s in 3D). Assemble it with
    /// [`PressureSystem::assemble`] (scale `dt`) and [`Self::solid_cells`].
    pub fn projection_problem(&self, dt: Real) -> (Constraints<D>, Vec<Real>, Vec<Real>) {
        let ps = &self.particles;
        let bins = self.bin(&ps.x);
        let mut nodes = self.transfer(Points::of(ps), &bins, true);
        // A non-finite state would have failed the last step's guards.
        let _ = self.predict(&mut nodes, dt);
        let (rows, _) = self.constraints((&ps.x, &ps.volume0), &bins, &nodes.mass, self.time);
        let rhs = rows.residual(&nodes.velocity);
        (rows, nodes.inv_mass, rhs)
    }

    /// Which cells are walls, for the multigrid preconditioner of [`PressureSystem::assemble`].
    pub fn solid_cells(&self) -> impl Fn(usize) -> bool + '_ {
        self.solid_cell()
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

    /// The fluid volume (m^D) at the grid's resolution: `Σ_p V_p / max(θ_p, 1)`, where `θ_p` is
    /// the volume fraction of the particle's cell, the mean over its corners of the particle
    /// volume transferred to each node divided by the node's support volume inside the walls
    /// (the quantity the position correction drives to 1). Compressed cells (`θ > 1`) count for
    /// less, so the volume drops below `Σ V_p` when particles cluster; the half-empty cells of a
    /// free surface do not count as lost volume.
    pub fn fluid_volume(&self) -> Real {
        let ps = &self.particles;
        let bins = self.bin(&ps.x);
        let nodes = self.transfer(Points::of(ps), &bins, false);
        let theta = self.node_fraction(&nodes);
        (0..ps.len())
            .map(|p| ps.volume0[p] / self.cell_fraction(&theta, bins.cell[p]).max(1.0))
            .sum()
    }

    /// Volume fraction of cell `c`: the mean of its corners' node fractions.
    fn cell_fraction(&self, theta: &[Real], c: usize) -> Real {
        let m = self.domain.cell_multi(c);
        (0..Domain::<D>::CORNERS)
            .map(|j| theta[self.domain.corner_node(&m, j)])
            .sum::<Real>()
            / Domain::<D>::CORNERS as Real
    }

    /// The stable step (s) for the adaptive policy's displacement bound.
    fn displacement_dt(&self, fraction: Real) -> Real {
        let vmax = self
            .particles
            .v
            .iter()
            .fold(0.0, |m: Real, v| mpm_core::solver::nan_max(m, v.norm()));
        self.bound_for(vmax, fraction)
    }

    /// The adaptive step bound (s) for particles of largest speed `vmax` (m/s): the `dt` with
    /// `dt (vmax + |g| dt) = cfl Δx`.
    pub(crate) fn displacement_bound(&self, vmax: Real) -> Real {
        self.bound_for(vmax, self.cfl())
    }

    fn bound_for(&self, vmax: Real, fraction: Real) -> Real {
        let g = self.params.gravity.norm();
        let c = fraction * self.domain.spec.dx;
        if vmax.is_nan() {
            return Real::NAN;
        }
        let denom = vmax + (vmax * vmax + 4.0 * g * c).sqrt();
        if denom > 0.0 {
            2.0 * c / denom
        } else {
            Real::INFINITY
        }
    }

    fn cfl(&self) -> Real {
        match self.params.time_step {
            TimeStepPolicy::Adaptive { cfl, .. } => cfl,
            TimeStepPolicy::Fixed { .. } => 0.4,
        }
    }

    /// Bins positions by cell (stable counting sort).
    pub(crate) fn bin(&self, x: &[Vector<D>]) -> Bins {
        let cell: Vec<usize> = x
            .par_iter()
            .map(|x| {
                let (m, _) = self.domain.locate(x).expect("particles are clamped inside");
                self.domain.cell_index(&m)
            })
            .collect();
        let nc = self.domain.num_cells();
        let mut start = vec![0usize; nc + 1];
        for &c in &cell {
            start[c + 1] += 1;
        }
        for c in 0..nc {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut order = vec![0usize; x.len()];
        for (p, &c) in cell.iter().enumerate() {
            order[fill[c]] = p;
            fill[c] += 1;
        }
        Bins { start, order, cell }
    }

    /// APIC P2G by node gather: each node sums, in a fixed order, over the particles of the
    /// `2^D` cells around it. With `momentum` false only mass and volume are transferred.
    pub(crate) fn transfer(
        &self,
        Points {
            x,
            v,
            affine,
            mass,
            volume,
        }: Points<'_, D>,
        bins: &Bins,
        momentum: bool,
    ) -> NodeFields<D> {
        let spec = &self.domain.spec;
        let nn = spec.num_nodes();
        let corners = Domain::<D>::CORNERS;
        let rows: Vec<(Real, Vector<D>, Real)> = (0..nn)
            .into_par_iter()
            .map(|n| {
                let node = spec.multi_index(n);
                let xn = spec.node_position(&node);
                let (mut m, mut mv, mut vol) = (0.0, Vector::<D>::zeros(), 0.0);
                for j in 0..corners {
                    let mut cm = [0usize; D];
                    let mut ok = true;
                    for a in 0..D {
                        let k = node[a] - ((j >> a) & 1) as i64;
                        if k < 0 || k >= self.domain.cell_dims[a] as i64 {
                            ok = false;
                            break;
                        }
                        cm[a] = k as usize;
                    }
                    if !ok {
                        continue;
                    }
                    for &p in bins.of(self.domain.cell_index(&cm)) {
                        let (_, f) = self.domain.locate(&x[p]).expect("inside");
                        let mut w = 1.0;
                        for a in 0..D {
                            w *= if (j >> a) & 1 == 1 { f[a] } else { 1.0 - f[a] };
                        }
                        let pm = mass[p];
                        m += w * pm;
                        vol += w * volume[p];
                        if momentum {
                            mv += (v[p] + affine[p] * (xn - x[p])) * (w * pm);
                        }
                    }
                }
                (m, mv, vol)
            })
            .collect();
        let mut out = NodeFields::default();
        out.mass = rows.iter().map(|r| r.0).collect();
        out.velocity = rows.iter().map(|r| r.1).collect();
        out.volume = rows.iter().map(|r| r.2).collect();
        out.inv_mass = out
            .mass
            .iter()
            .map(|&m| if m > 0.0 { 1.0 / m } else { 0.0 })
            .collect();
        out
    }

    /// Node volume fraction `θ_n` (dimensionless).
    fn node_fraction(&self, nodes: &NodeFields<D>) -> Vec<Real> {
        let cell = self.domain.spec.cell_volume();
        nodes
            .volume
            .iter()
            .enumerate()
            .map(|(n, &v)| v / (cell * self.domain.support_fraction(n)))
            .collect()
    }

    /// The rows of `J = [G^fᵀ; B]` at positions `x`: a fluid row per cell holding particles
    /// (in cell order), then a boundary row per node with mass whose piece of wall or collider
    /// surface (its node-centred B0 box) holds quadrature points in fluid cells, per wall face
    /// or collider. The points have positions `x` and volumes `volume`. Returns the rows and,
    /// per fluid row, the fluid volume in its cell (m^D).
    pub(crate) fn constraints(
        &self,
        (x, volume): (&[Vector<D>], &[Real]),
        bins: &Bins,
        mass: &[Real],
        t: Real,
    ) -> (Constraints<D>, Vec<Real>) {
        let corners = Domain::<D>::CORNERS;
        let dx = self.domain.spec.dx;
        let fluid_cells: Vec<usize> = (0..self.domain.num_cells())
            .filter(|&c| bins.start[c + 1] > bins.start[c])
            .collect();
        let fluid_rows: Vec<(Vec<Vector<D>>, Real)> = fluid_cells
            .par_iter()
            .map(|&c| {
                let mut r = vec![Vector::<D>::zeros(); corners];
                let mut vol = 0.0;
                let mut w = [0.0; 8];
                let mut g = [Vector::<D>::zeros(); 8];
                let particles = self.params.gradient_quadrature == GradientQuadrature::Particles;
                for &p in bins.of(c) {
                    let vp = volume[p];
                    vol += vp;
                    if particles {
                        let (_, f) = self.domain.locate(&x[p]).expect("inside");
                        corner_weights(&f, dx, &mut w, &mut g);
                        for j in 0..corners {
                            r[j] -= g[j] * vp;
                        }
                    }
                }
                if !particles {
                    corner_weights(&[0.5; D], dx, &mut w, &mut g);
                    for j in 0..corners {
                        r[j] = -g[j] * vol;
                    }
                }
                (r, vol)
            })
            .collect();
        let mut rows = Constraints::new(self.domain.cell_dims);
        let mut volumes = Vec::with_capacity(fluid_cells.len());
        for (&c, (r, vol)) in fluid_cells.iter().zip(fluid_rows) {
            let m = self.domain.cell_multi(c);
            rows.push_row(
                UnknownKind::Fluid,
                c,
                r.into_iter()
                    .enumerate()
                    .map(|(j, v)| (self.domain.corner_node(&m, j), v)),
                0.0,
            );
            volumes.push(vol);
        }
        // Boundary samples in fluid cells: the static wall points and the collider points.
        let per_cell: Vec<Vec<WallSample<D>>> = fluid_cells
            .par_iter()
            .map(|&c| {
                let (start, list) = &self.wall_by_cell;
                let mut out: Vec<WallSample<D>> = list[start[c]..start[c + 1]]
                    .iter()
                    .map(|&i| self.wall_points[i])
                    .collect();
                self.domain
                    .collider_points(&self.domain.cell_multi(c), t, &mut out);
                out
            })
            .collect();
        let mut samples: Vec<WallSample<D>> = per_cell.into_iter().flatten().collect();
        samples.sort_by_key(|s| (s.node, s.face));
        let mut w = [0.0; 8];
        let mut g = [Vector::<D>::zeros(); 8];
        for group in samples.chunk_by(|a, b| (a.node, a.face) == (b.node, b.face)) {
            let anchor = group[0].node;
            if mass[anchor] <= 0.0 {
                continue;
            }
            let mut entries = Vec::with_capacity(group.len() * corners);
            let mut b = 0.0;
            for s in group {
                let q = &s.point;
                let f: [Real; D] = std::array::from_fn(|a| {
                    ((q.x[a] - self.domain.spec.origin[a]) / dx - s.cell[a] as Real).clamp(0.0, 1.0)
                });
                corner_weights(&f, dx, &mut w, &mut g);
                for j in 0..corners {
                    entries.push((
                        self.domain.corner_node(&s.cell, j),
                        q.normal * (q.area * w[j]),
                    ));
                }
                b += q.area * q.normal_velocity;
            }
            rows.push_row(UnknownKind::Wall, anchor, entries, b);
        }
        rows.pin_gauge = !self.has_free_surface(&fluid_cells, bins);
        (rows, volumes)
    }

    /// Whether some fluid cell shares a node with an empty cell inside the walls (where
    /// `p = 0`), so that the pressure is unique.
    fn has_free_surface(&self, fluid_cells: &[usize], bins: &Bins) -> bool {
        fluid_cells.iter().any(|&c| {
            self.domain
                .neighbour_cells(self.domain.cell_multi(c))
                .any(|nm| {
                    let nc = self.domain.cell_index(&nm);
                    (self.domain.cell_inside(&nm) || !self.domain.walls) && bins.of(nc).is_empty()
                })
        })
    }

    pub(crate) fn solid_cell(&self) -> impl Fn(usize) -> bool + '_ {
        move |c| self.domain.walls && !self.domain.cell_inside(&self.domain.cell_multi(c))
    }

    /// One attempt at a step of `dt` (s), leaving the solver state untouched.
    fn attempt(
        &self,
        dt: Real,
        projection: &mut PressureSystem<D>,
        correction: &mut PressureSystem<D>,
        times: &mut StageTimes,
    ) -> Result<Attempt<D>, Failure<PressureError>> {
        let (bins, mut nodes) = self.predictor(dt, times)?;
        let (fields, info) = times.time(Stage::Solve, || {
            self.project(&mut nodes, &bins, dt, projection)
        })?;
        self.finish(&nodes, &bins, fields, &info, dt, correction, times)
    }

    /// The stages of an attempt before the projection: sort, P2G and the predictor `v*`.
    pub(crate) fn predictor(
        &self,
        dt: Real,
        times: &mut StageTimes,
    ) -> Result<(Bins, NodeFields<D>), Failure<PressureError>> {
        self.predictor_for(Points::of(&self.particles), dt, times)
    }

    /// [`Self::predictor`] over `points` instead of the particles.
    pub(crate) fn predictor_for(
        &self,
        points: Points<'_, D>,
        dt: Real,
        times: &mut StageTimes,
    ) -> Result<(Bins, NodeFields<D>), Failure<PressureError>> {
        let bins = times.time(Stage::Sort, || self.bin(points.x));
        let mut nodes = times.time(Stage::P2G, || self.transfer(points, &bins, true));
        times.time(Stage::GridUpdate, || self.predict(&mut nodes, dt))?;
        nodes.viscous = times.time(Stage::GridUpdate, || self.viscous(&bins, &mut nodes, dt))?;
        Ok((bins, nodes))
    }

    /// The implicit viscous solve on the predictor `nodes.velocity`, over the particles' own
    /// positions and volumes (the first entries of what `bins` sorted); `None` for an inviscid
    /// fluid.
    fn viscous(
        &self,
        bins: &Bins,
        nodes: &mut NodeFields<D>,
        dt: Real,
    ) -> Result<Option<SolveInfo>, Failure<PressureError>> {
        let ps = &self.particles;
        let Some(system) = Viscous::new(
            &self.domain,
            bins,
            (&ps.x, &ps.volume0, &self.viscosity),
            &nodes.mass,
            dt,
        ) else {
            return Ok(None);
        };
        let p = &self.params.pressure;
        system
            .solve(&mut nodes.velocity, (p.rel_tol, p.max_iterations))
            .map(Some)
            .map_err(|e| Failure::Solve(Stage::GridUpdate, e))
    }

    /// The stages of an attempt after the projection: G2P and the position correction, with
    /// the per-cell pressure and divergence `fields` of the projection mapped to particles.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn finish(
        &self,
        nodes: &NodeFields<D>,
        bins: &Bins,
        (pressure_of_cell, divergence_of_cell): (Vec<Real>, Vec<Real>),
        info: &PressureInfo,
        dt: Real,
        correction: &mut PressureSystem<D>,
        times: &mut StageTimes,
    ) -> Result<Attempt<D>, Failure<PressureError>> {
        let (mut x, v, affine) =
            times.time(Stage::G2P, || self.g2p(&self.particles.x, nodes, dt))?;
        let mut solves = vec![SolveInfo {
            name: "pressure",
            iterations: info.iterations,
            residual: info.relative_residual,
        }];
        solves.extend(nodes.viscous);
        let mut events = vec![("pressure_unknowns", info.unknowns as u64)];
        if info.pattern_reused {
            events.push(("pressure_pattern_reused", 1));
        }
        if self.params.position_correction {
            if let Some(c) = times.time(Stage::PositionCorrection, || {
                self.correct_positions(&mut x, dt, correction, &[])
            })? {
                solves.push(SolveInfo {
                    name: "position_correction",
                    iterations: c.iterations,
                    residual: c.relative_residual,
                });
            }
        }
        let pressure = bins.cell.iter().map(|&c| pressure_of_cell[c]).collect();
        let divergence = bins.cell.iter().map(|&c| divergence_of_cell[c]).collect();
        Ok(Attempt {
            x,
            v,
            affine,
            pressure,
            divergence,
            solves,
            events,
        })
    }

    /// Writes an accepted attempt of `dt` (s) into the state.
    pub(crate) fn accept(
        &mut self,
        a: Attempt<D>,
        dt: Real,
    ) -> (Vec<SolveInfo>, Vec<(&'static str, u64)>) {
        self.particles.x = a.x;
        self.particles.v = a.v;
        self.particles.affine = a.affine;
        self.pressure = a.pressure;
        self.divergence = a.divergence;
        self.time += dt;
        self.steps += 1;
        (a.solves, a.events)
    }

    /// `v* = v + dt g` on nodes with mass; guards non-finite node velocities.
    fn predict(&self, nodes: &mut NodeFields<D>, dt: Real) -> Result<(), Failure<PressureError>> {
        let g = self.params.gravity;
        for (n, (v, &im)) in nodes.velocity.iter_mut().zip(&nodes.inv_mass).enumerate() {
            if im > 0.0 {
                *v = *v * im + g * dt;
                if !v.iter().all(|c| c.is_finite()) {
                    return Err(Failure::Guard(
                        Stage::GridUpdate,
                        (
                            Location::Node(n),
                            Violation::NonFinite("node velocity"),
                            v.norm(),
                        ),
                    ));
                }
            } else {
                *v = Vector::<D>::zeros();
            }
        }
        Ok(())
    }

    /// The pressure projection: assemble and solve `A λ = J v* − b`, then `v = v* − dt M⁻¹ Jᵀ λ`.
    /// Returns the pressure and the discrete divergence per cell and the solve's summary.
    #[allow(clippy::type_complexity)]
    fn project(
        &self,
        nodes: &mut NodeFields<D>,
        bins: &Bins,
        dt: Real,
        system: &mut PressureSystem<D>,
    ) -> Result<((Vec<Real>, Vec<Real>), PressureInfo), Failure<PressureError>> {
        let ps = &self.particles;
        let (rows, volumes) = self.constraints((&ps.x, &ps.volume0), bins, &nodes.mass, self.time);
        let (lambda, info) = self.solve_onto(
            &rows,
            &nodes.inv_mass,
            dt,
            &mut nodes.velocity,
            system,
            Stage::Solve,
        )?;
        Ok((
            self.cell_fields(&rows, &lambda, &nodes.velocity, &volumes),
            info,
        ))
    }

    /// The solved pressure (Pa) and the discrete divergence `−G^fᵀ v / V` (1/s) of every cell
    /// (0 in cells without fluid), from the fluid rows of `rows`, the solution `lambda` and the
    /// projected node velocities `v` (m/s).
    pub(crate) fn cell_fields(
        &self,
        rows: &Constraints<D>,
        lambda: &[Real],
        v: &[Vector<D>],
        volumes: &[Real],
    ) -> (Vec<Real>, Vec<Real>) {
        let after = rows.residual(v);
        let mut pressure = vec![0.0; self.domain.num_cells()];
        let mut divergence = vec![0.0; self.domain.num_cells()];
        for k in 0..rows.num_fluid() {
            pressure[rows.anchors[k]] = lambda[k];
            divergence[rows.anchors[k]] = -after[k] / volumes[k];
        }
        (pressure, divergence)
    }

    /// Moves the node field `v` (velocities in m/s; for the position correction, displacements
    /// over dt) onto the constraints `J v = b` of `rows`: assembles `A = dt J M⁻¹ Jᵀ`, solves
    /// `A λ = J v − b` and sets `v ← v − dt M⁻¹ Jᵀ λ`. Returns λ (Pa) and the solve's summary;
    /// a failure is reported in `stage`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn solve_onto(
        &self,
        rows: &Constraints<D>,
        inv_mass: &[Real],
        dt: Real,
        v: &mut [Vector<D>],
        system: &mut PressureSystem<D>,
        stage: Stage,
    ) -> Result<(Vec<Real>, PressureInfo), Failure<PressureError>> {
        self.assemble_onto(rows, inv_mass, dt, system, stage)?;
        self.project_assembled(rows, inv_mass, dt, v, system, stage)
    }

    /// Assembles `Δt J M⁻¹ Jᵀ + C` of `rows` and `inv_mass` (1/kg) into `system` and sets up
    /// its preconditioner, for any number of [`Self::project_assembled`] solves.
    pub(crate) fn assemble_onto(
        &self,
        rows: &Constraints<D>,
        inv_mass: &[Real],
        dt: Real,
        system: &mut PressureSystem<D>,
        stage: Stage,
    ) -> Result<(), Failure<PressureError>> {
        let params = &self.params.pressure;
        system
            .assemble(rows, inv_mass, dt, params, &self.solid_cell())
            .map_err(|e| Failure::Solve(stage, e))
    }

    /// Projects the velocities `v` (m/s) with the system [`Self::assemble_onto`] left in
    /// `system`: solves for the pressures and applies `v ← v − Δt M⁻¹ Jᵀ λ`.
    pub(crate) fn project_assembled(
        &self,
        rows: &Constraints<D>,
        inv_mass: &[Real],
        dt: Real,
        v: &mut [Vector<D>],
        system: &mut PressureSystem<D>,
        stage: Stage,
    ) -> Result<(Vec<Real>, PressureInfo), Failure<PressureError>> {
        let rhs = rows.residual(v);
        let mut lambda = Vec::new();
        let info = system
            .solve(&rhs, &mut lambda, &self.params.pressure)
            .map_err(|e| Failure::Solve(stage, e))?;
        rows.apply_transpose(&lambda, inv_mass, dt, v);
        Ok((lambda, info))
    }

    /// APIC G2P at positions `x`, advection and clamping. Guards non-finite values and a
    /// displacement above Δx.
    #[allow(clippy::type_complexity)]
    pub(crate) fn g2p(
        &self,
        x: &[Vector<D>],
        nodes: &NodeFields<D>,
        dt: Real,
    ) -> Result<(Vec<Vector<D>>, Vec<Vector<D>>, Vec<Matrix<D>>), Failure<PressureError>> {
        let dx = self.domain.spec.dx;
        let t_end = self.time + dt;
        let out: Vec<(Vector<D>, Vector<D>, Matrix<D>)> = x
            .par_iter()
            .map(|x| {
                let (m, f) = self.domain.locate(x).expect("inside");
                let mut w = [0.0; 8];
                let mut g = [Vector::<D>::zeros(); 8];
                corner_weights(&f, dx, &mut w, &mut g);
                let mut v = Vector::<D>::zeros();
                let mut c = Matrix::<D>::zeros();
                for j in 0..Domain::<D>::CORNERS {
                    let vn = nodes.velocity[self.domain.corner_node(&m, j)];
                    v += vn * w[j];
                    c += vn * g[j].transpose();
                }
                let mut xn = x + v * dt;
                if xn.iter().all(|c| c.is_finite()) {
                    self.domain.clamp(&mut xn, t_end, CLAMP_MARGIN * dx);
                }
                (xn, v, c)
            })
            .collect();
        for (p, (_, v, _)) in out.iter().enumerate() {
            let speed = v.norm();
            if !speed.is_finite() {
                return Err(Failure::Guard(
                    Stage::G2P,
                    (
                        Location::Particle(p),
                        Violation::NonFinite("velocity"),
                        speed,
                    ),
                ));
            }
            if speed * dt > dx {
                return Err(Failure::Guard(
                    Stage::G2P,
                    (
                        Location::Particle(p),
                        Violation::CflExceeded,
                        speed * dt / dx,
                    ),
                ));
            }
        }
        let mut x = Vec::with_capacity(out.len());
        let mut v = Vec::with_capacity(out.len());
        let mut c = Vec::with_capacity(out.len());
        for (a, b, m) in out {
            x.push(a);
            v.push(b);
            c.push(m);
        }
        Ok((x, v, c))
    }

    /// The position correction: where the grid volume fraction `θ` of a fluid cell exceeds 1,
    /// find the node displacement `d` of least mass-weighted norm with `∫_cell ∇·d = θ − 1`
    /// (times the cell's fluid volume) and no flux through walls, by the same SPD system with
    /// the right-hand side of the density error (Kugelstadt et al. 2019's implicit density
    /// projection, on the MPM grid), and move particles by `d` interpolated.
    ///
    /// `occupied` (m^D per node, or empty) is volume that other material (the coupled solids)
    /// holds at each node: it counts in `θ`, so fluid is pushed out of cells a solid fills.
    pub(crate) fn correct_positions(
        &self,
        x: &mut [Vector<D>],
        dt: Real,
        system: &mut PressureSystem<D>,
        occupied: &[Real],
    ) -> Result<Option<PressureInfo>, Failure<PressureError>> {
        let bins = self.bin(x);
        let zero_v = vec![Vector::<D>::zeros(); x.len()];
        let zero_c = vec![Matrix::<D>::zeros(); x.len()];
        let points = Points {
            x,
            v: &zero_v,
            affine: &zero_c,
            mass: &self.particles.mass,
            volume: &self.particles.volume0,
        };
        let mut nodes = self.transfer(points, &bins, false);
        for (v, o) in nodes.volume.iter_mut().zip(occupied) {
            *v += o;
        }
        let theta = self.node_fraction(&nodes);
        let t_end = self.time + dt;
        let (mut rows, volumes) =
            self.constraints((x, &self.particles.volume0), &bins, &nodes.mass, t_end);
        let nf = rows.num_fluid();
        let mut any = false;
        for k in 0..nf {
            let th = self.cell_fraction(&theta, rows.anchors[k]);
            let excess = (th - 1.0).max(0.0);
            any |= excess > 0.0;
            rows.offsets[k] = -volumes[k] * excess;
        }
        for o in rows.offsets[nf..].iter_mut() {
            *o = 0.0;
        }
        if !any {
            return Ok(None);
        }
        let mut d = vec![Vector::<D>::zeros(); nodes.mass.len()];
        let (_, info) = self.solve_onto(
            &rows,
            &nodes.inv_mass,
            dt,
            &mut d,
            system,
            Stage::PositionCorrection,
        )?;
        let dx = self.domain.spec.dx;
        x.par_iter_mut().for_each(|xp| {
            let (m, f) = self.domain.locate(xp).expect("inside");
            let mut w = [0.0; 8];
            let mut g = [Vector::<D>::zeros(); 8];
            corner_weights(&f, dx, &mut w, &mut g);
            let mut shift = Vector::<D>::zeros();
            for j in 0..Domain::<D>::CORNERS {
                shift += d[self.domain.corner_node(&m, j)] * w[j];
            }
            if shift.iter().all(|s| s.is_finite()) {
                *xp += shift;
                self.domain.clamp(xp, t_end, CLAMP_MARGIN * dx);
            }
        });
        Ok(Some(info))
    }

    /// [`Solver::step`] on the calling thread, with the pressure-solve error typed.
    fn advance_step(&mut self) -> Result<StepInfo, StepError<PressureError>> {
        let start = StepStart {
            step: self.steps,
            time: self.time,
        };
        let t0 = std::time::Instant::now();
        let stable = self.displacement_dt(self.cfl());
        self.times.add(Stage::TimeStep, t0.elapsed());
        let dt0 = choose_dt(&self.params.time_step, stable).map_err(|e| {
            start.error(Failure::<PressureError>::Guard(Stage::TimeStep, e), 0.0, 0)
        })?;
        let mut projection = std::mem::take(&mut self.projection);
        let mut correction = std::mem::take(&mut self.correction);
        let mut times = std::mem::take(&mut self.times);
        let result = retry_halving(self.params.on_instability, start, dt0, |dt| {
            self.attempt(dt, &mut projection, &mut correction, &mut times)
        });
        self.projection = projection;
        self.correction = correction;
        self.times = times;
        let (a, dt, retries) = result?;
        let (solves, events) = self.accept(a, dt);
        Ok(StepInfo {
            dt,
            retries,
            time: self.time,
            solves,
            events,
            residual_histories: Vec::new(),
        })
    }
}

impl<const D: usize> Solver<D> for DiqFluid<D>
where
    Dim<D>: DimOps<D>,
{
    fn name(&self) -> &'static str {
        "DIQ-MPM incompressible fluid"
    }

    fn spec(&self) -> &GridSpec<D> {
        &self.domain.spec
    }

    fn particles(&self) -> &Particles<D> {
        &self.particles
    }

    fn materials(&self) -> &[Material] {
        &self.materials
    }

    fn time(&self) -> Real {
        self.time
    }

    fn steps(&self) -> u64 {
        self.steps
    }

    fn stable_dt(&self) -> Real {
        self.displacement_dt(self.cfl())
    }

    fn dt_bound(&self) -> DtBound {
        crate::fluid::displacement_bound_doc()
    }

    fn diagnostics(&self) -> Diagnostics<D> {
        Diagnostics::compute(&self.particles, &self.materials, None, &self.params.gravity)
    }

    fn plan(&self) -> StagePlan {
        self.plan.clone()
    }

    /// Advances one step; a failed pressure solve is a [`StepError::Solve`] with the
    /// [`PressureError`]'s message. The step runs on a thread of the rayon pool ([`on_pool`]).
    fn step(&mut self) -> Result<StepInfo, StepError> {
        on_pool(|| self.advance_step()).map_err(|e| e.erase("pressure"))
    }

    fn stage_times(&self) -> Vec<StageTime> {
        self.times.rows(&self.plan)
    }

    fn checkpoint(&self) -> SolverState {
        let mut state = SolverState::of_particles(&self.particles, self.time, self.steps);
        state
            .columns
            .push(Column::scalars("diq_pressure", "Pa", &self.pressure));
        state
            .columns
            .push(Column::scalars("diq_divergence", "1/s", &self.divergence));
        state
    }

    fn restore(&mut self, state: &SolverState) -> Result<(), RestoreError> {
        let particles =
            columns::particles_from_columns(&state.columns, &self.particles, self.materials.len())?;
        let n = particles.len();
        let scalar = |name: &str| -> Result<Vec<Real>, RestoreError> {
            columns::f64_values(&state.columns, name, &[n])?
                .map(<[Real]>::to_vec)
                .ok_or_else(|| RestoreError(format!("checkpoint has no field `{name}`")))
        };
        let (pressure, divergence) = (scalar("diq_pressure")?, scalar("diq_divergence")?);
        let mut s = Self::at_time(
            self.domain.spec,
            self.params.clone(),
            self.materials.clone(),
            self.boundaries.clone(),
            particles,
            state.time,
        )
        .map_err(|e| RestoreError(format!("does not fit this scene: {e}")))?;
        s.time = state.time;
        s.steps = state.steps;
        s.pressure = pressure;
        s.divergence = divergence;
        *self = s;
        Ok(())
    }

    fn monitors(&self) -> Vec<Monitor> {
        vec![Monitor {
            name: "fluid_volume",
            unit: if D == 2 { "m^2" } else { "m^3" },
            value: self.fluid_volume(),
        }]
    }

    fn output_fields(&self) -> Vec<FieldInfo> {
        let mut fields =
            mpm_core::solver::particle_field_infos::<D>(&self.particles.columns().names());
        fields.push(FieldInfo {
            name: "pressure",
            unit: "Pa",
            components: 1,
            derived: true,
        });
        fields.push(FieldInfo {
            name: "divergence",
            unit: "1/s",
            components: 1,
            derived: true,
        });
        fields
    }

    fn pressure(&self) -> Vec<Real> {
        self.pressure.clone()
    }

    fn output(&self, name: &str) -> Vec<Column> {
        match name {
            "pressure" => vec![Column::scalars("pressure", "Pa", &self.pressure)],
            "divergence" => vec![Column::scalars("divergence", "1/s", &self.divergence)],
            _ => columns::particle_column(&self.particles, name),
        }
    }
}
