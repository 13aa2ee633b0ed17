//! Axis-aligned manufactured solution (Wallstedt & Guilkey 2008) on the unit square / cube.
//!
//! Displacement `u_i(X, t) = A sin(2π X_i) sin(cπ t)` along every axis `i`, with
//! `c = √(E/ρ₀)`. The deformation gradient is diagonal,
//! `F_ii = 1 + 2πA cos(2π X_i) sin(cπ t)`, and for the compressible Neo-Hookean model
//! `P = μ (F − F⁻ᵀ) + λ ln J F⁻ᵀ` it stays diagonal:
//! `P_ii = μ (F_ii − 1/F_ii) + λ ln J / F_ii`. The only non-zero divergence term is
//! `∂P_ii/∂X_i = F_ii' [μ (1 + 1/F_ii²) + λ (1 − ln J)/F_ii²]` with
//! `F_ii' = ∂F_ii/∂X_i = −4π²A sin(2π X_i) sin(cπ t)` (the `ln J` factor depends on `X_i` only
//! through `F_ii`, `∂ ln J/∂X_i = F_ii'/F_ii`). The body force that makes `u` solve
//! `ρ₀ ü = ∇_X·P + ρ₀ b` is therefore `b_i = ü_i − (1/ρ₀) ∂P_ii/∂X_i` with
//! `ü_i = −A (cπ)² sin(2π X_i) sin(cπ t)`.

use super::{assemble, lattice, neo_hookean, sweep, RunError};
use crate::report::{
    decreases_under_refinement, nan_max, progress, timed_step, CaseResult, Mode, Run,
};
use mpm_core::boundary::{
    Boundaries, Collider, ColliderShape, Contact, ContactKind, DomainWalls, WallTreatment,
};
use mpm_core::material::Lame;
use mpm_core::{
    Dim, DimOps, GridSpec, Kernel, Matrix, ParticlesBuilder, Real, StepControl, TimeStepPolicy,
    Vector,
};
use mpm_explicit::{BodyForce, ExplicitParams, ExplicitSolver, Transfer};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::sync::Arc;
use std::time::Duration;

/// Case name in 2D.
pub const NAME_2D: &str = "mms_axis_aligned_2d";
/// Case name in 3D.
pub const NAME_3D: &str = "mms_axis_aligned_3d";

/// Parameters of the manufactured solution and its discretisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MmsConfig {
    /// Young's modulus E (Pa).
    pub youngs: Real,
    /// Poisson's ratio ν.
    pub poisson: Real,
    /// Reference density ρ₀ (kg/m^D).
    pub density: Real,
    /// Displacement amplitude A (m).
    pub amplitude: Real,
    /// CFL factor C of the fixed step `dt ≈ C Δx / (c_P,max + |v|_max)` (dimensionless).
    pub cfl: Real,
    /// Particles per cell per axis.
    pub per_axis: usize,
    /// Simulated time in periods `2/c` of the solution (dimensionless).
    pub periods: Real,
    /// Interpolation kernel.
    pub kernel: Kernel,
    /// Velocity transfer.
    pub transfer: Transfer,
    /// Where the error is measured: every particle (`None`) or those whose reference position
    /// lies at least this distance (m) from every face (the interior, away from the walls).
    pub interior: Option<Real>,
    /// Whether the faces are mirrored slip walls (`WallTreatment::Mirror`, the wall planes on
    /// the faces) instead of slip half-space colliders that hold the nodes on and beyond them.
    /// The solution is odd in the normal and even in the tangential components across every
    /// face, so with mirrored walls the discrete problem has no boundary closure at all.
    pub mirror_walls: bool,
}

impl Default for MmsConfig {
    fn default() -> Self {
        Self {
            youngs: 1e7,
            poisson: 0.3,
            density: 1000.0,
            amplitude: 0.01,
            cfl: 0.3,
            per_axis: 2,
            periods: 1.0,
            kernel: Kernel::Quadratic,
            transfer: Transfer::Apic,
            interior: None,
            mirror_walls: false,
        }
    }
}

impl MmsConfig {
    /// Lamé parameters (Pa).
    pub fn lame(&self) -> Lame {
        Lame::from_young_poisson(self.youngs, self.poisson)
    }

    /// The solution's speed `c = √(E/ρ₀)` (m/s).
    pub fn speed(&self) -> Real {
        (self.youngs / self.density).sqrt()
    }

    /// Period `2/c` of the solution (s).
    pub fn period(&self) -> Real {
        2.0 / self.speed()
    }

    /// Displacement `u_i` (m) of the axis coordinate `x` (m) at time `t` (s).
    pub fn displacement(&self, x: Real, t: Real) -> Real {
        self.amplitude * (2.0 * PI * x).sin() * (self.speed() * PI * t).sin()
    }

    /// Velocity `u̇_i` (m/s) of the axis coordinate `x` (m) at time `t` (s).
    pub fn velocity(&self, x: Real, t: Real) -> Real {
        let cp = self.speed() * PI;
        self.amplitude * (2.0 * PI * x).sin() * cp * (cp * t).cos()
    }

    /// Stretch `F_ii = 1 + 2πA cos(2π x) sin(cπ t)` (dimensionless).
    pub fn stretch(&self, x: Real, t: Real) -> Real {
        1.0 + 2.0 * PI * self.amplitude * (2.0 * PI * x).cos() * (self.speed() * PI * t).sin()
    }

    /// Diagonal of the Neo-Hookean `P = μ(F − F⁻ᵀ) + λ ln J F⁻ᵀ` (Pa) for the diagonal
    /// deformation gradient `diag(f)`.
    pub fn pk1_diagonal<const D: usize>(&self, f: &Vector<D>) -> Vector<D> {
        let Lame { mu, lambda } = self.lame();
        let ln_j = f.iter().map(|v| v.ln()).sum::<Real>();
        f.map(|fi| mu * (fi - 1.0 / fi) + lambda * ln_j / fi)
    }

    /// Body force `b(X, t)` (m/s²) at reference position `x_ref` (m) and time `t` (s).
    pub fn body_force<const D: usize>(&self, x_ref: &Vector<D>, t: Real) -> Vector<D> {
        let Lame { mu, lambda } = self.lame();
        let a = self.amplitude;
        let s = (self.speed() * PI * t).sin();
        let cp2 = (self.speed() * PI).powi(2);
        let f = x_ref.map(|x| self.stretch(x, t));
        let ln_j = f.iter().map(|v| v.ln()).sum::<Real>();
        Vector::<D>::from_fn(|i, _| {
            let sin_x = (2.0 * PI * x_ref[i]).sin();
            let fi = f[i];
            let dfi = -4.0 * PI * PI * a * sin_x * s;
            let dp = dfi * (mu * (1.0 + 1.0 / (fi * fi)) + lambda * (1.0 - ln_j) / (fi * fi));
            let acc = -a * cp2 * sin_x * s;
            acc - dp / self.density
        })
    }

    /// Fixed step (s) and step count covering the run: `dt = t_end/steps` with `steps` the
    /// least count keeping `dt ≤ C Δx/(c_P √J_max + |v|_max)`.
    pub fn time_steps<const D: usize>(&self, dx: Real) -> (Real, u64) {
        let Lame { mu, lambda } = self.lame();
        let j_max = (1.0 + 2.0 * PI * self.amplitude).powi(D as i32);
        let c_p = ((lambda + 2.0 * mu) * j_max / self.density).sqrt();
        let v_max = self.amplitude * self.speed() * PI * (D as Real).sqrt();
        let t_end = self.periods * self.period();
        let steps = (t_end / (self.cfl * dx / (c_p + v_max))).ceil() as u64;
        (t_end / steps as Real, steps)
    }
}

/// Builds the solver for `n` cells per unit length; returns it with the particles' reference
/// positions.
pub fn build<const D: usize>(
    cfg: &MmsConfig,
    n: usize,
) -> Result<(ExplicitSolver<D>, Vec<Vector<D>>), RunError>
where
    Dim<D>: DimOps<D>,
{
    let dx = 1.0 / n as Real;
    // Nodes at exactly 0 and 1 on every axis; three cells of grid beyond each face.
    let spec = GridSpec::new(Vector::<D>::from_element(-3.0 * dx), dx, [n + 7; D]);
    let materials = vec![neo_hookean(cfg.youngs, cfg.poisson, cfg.density)];
    let h = dx / cfg.per_axis as Real;
    let model = *cfg;
    // x = X, v = u̇(X, 0), C = ∇v(X, 0) (diagonal), F = I.
    let cube = lattice(&Vector::<D>::zeros(), &Vector::<D>::from_element(1.0), h, 0)
        .velocity_field(move |x| {
            let v = x.map(|xi| model.velocity(xi, 0.0));
            let grad =
                x.map(|xi| model.amplitude * 2.0 * PI * (2.0 * PI * xi).cos() * model.speed() * PI);
            (v, Matrix::<D>::from_diagonal(&grad))
        });
    let particles = ParticlesBuilder::new(&spec, &materials)
        .kernel(cfg.kernel)
        .with(&cube)?
        .build();
    let xs = particles.x.clone();
    // The planes sit 1e-9 Δx inside the faces so that nodes on the faces are inside the
    // colliders despite round-off in the node positions.
    let eps = 1e-9 * dx;
    let mut colliders = Vec::new();
    for a in 0..D {
        let e = Vector::<D>::from_fn(|i, _| if i == a { 1.0 } else { 0.0 });
        for (point, normal) in [(e * eps, e), (e * (1.0 - eps), -e)] {
            colliders.push(Collider {
                shape: ColliderShape::HalfSpace { point, normal },
                contact: Contact {
                    kind: ContactKind::Slip,
                    friction: 0.0,
                },
                velocity: Vector::<D>::zeros(),
            });
        }
    }
    let boundaries = if cfg.mirror_walls {
        // Four layers: the innermost, node 3, lies on the face.
        Boundaries {
            walls: Some(DomainWalls {
                contact: Contact {
                    kind: ContactKind::Slip,
                    friction: 0.0,
                },
                thickness: 4,
                treatment: WallTreatment::Mirror,
            }),
            colliders: Vec::new(),
        }
    } else {
        Boundaries {
            walls: None,
            colliders,
        }
    };
    let (dt, _) = cfg.time_steps::<D>(dx);
    let reference = xs.clone();
    let force = BodyForce(Arc::new(move |p: usize, _x: &Vector<D>, t: Real| {
        model.body_force(&reference[p], t)
    }));
    let params = ExplicitParams {
        kernel: cfg.kernel,
        transfer: cfg.transfer,
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt },
            ..StepControl::default()
        },
        body_force: Some(force),
        ..ExplicitParams::default()
    };
    let solver = ExplicitSolver::new(spec, params, materials, boundaries, particles)?;
    Ok((solver, xs))
}

/// Volume-weighted RMS (m) over particles (those of the interior with
/// [`MmsConfig::interior`]) of `|x_p − X_p − u(X_p, t)|`.
pub fn rms_error<const D: usize>(
    cfg: &MmsConfig,
    solver: &ExplicitSolver<D>,
    reference: &[Vector<D>],
) -> Real
where
    Dim<D>: DimOps<D>,
{
    let t = solver.time();
    let s = (cfg.speed() * PI * t).sin();
    let ps = solver.particles();
    let (mut num, mut den) = (0.0, 0.0);
    let margin = cfg.interior.unwrap_or(0.0);
    for (p, x_ref) in reference.iter().enumerate() {
        if x_ref.iter().any(|&x| x < margin || x > 1.0 - margin) {
            continue;
        }
        let u = x_ref.map(|x| cfg.amplitude * (2.0 * PI * x).sin() * s);
        let e = ps.x[p] - x_ref - u;
        num += ps.volume0[p] * e.norm_squared();
        den += ps.volume0[p];
    }
    (num / den).sqrt()
}

/// One run at `n` cells per unit length: error is the RMS displacement error (m) maximised over
/// all steps of one period.
pub fn run<const D: usize>(cfg: &MmsConfig, n: usize) -> Result<Run, RunError>
where
    Dim<D>: DimOps<D>,
{
    let dx = 1.0 / n as Real;
    let (mut solver, reference) = build::<D>(cfg, n)?;
    let (dt, steps) = cfg.time_steps::<D>(dx);
    let mut wall = Duration::ZERO;
    let (mut max_err, mut t_max) = (0.0, 0.0);
    for _ in 0..steps {
        timed_step(&mut solver, &mut wall)?;
        let e = rms_error(cfg, &solver, &reference);
        if e > max_err || e.is_nan() {
            t_max = solver.time();
        }
        max_err = nan_max(max_err, e);
    }
    let final_err = rms_error(cfg, &solver, &reference);
    let mut extra = BTreeMap::new();
    extra.insert("amplitude_m".into(), cfg.amplitude);
    extra.insert("relative_error".into(), max_err / cfg.amplitude);
    extra.insert("error_at_end_m".into(), final_err);
    extra.insert("time_of_max_s".into(), t_max);
    Ok(Run {
        dx,
        dt,
        particles: solver.particles().len(),
        steps: solver.steps(),
        wall_s: wall.as_secs_f64(),
        error: max_err,
        extra,
    })
}

/// Resolutions (cells per unit length) for `mode` in `D` dimensions.
pub fn resolutions<const D: usize>(mode: Mode) -> Vec<usize> {
    match (D, mode) {
        (2, Mode::Quick) => vec![8, 16, 32, 64],
        (2, Mode::Full) => vec![8, 16, 32, 64, 128, 256],
        (_, Mode::Quick) => vec![4, 6, 8, 12, 16],
        (_, Mode::Full) => vec![4, 6, 8, 12, 16, 24, 32, 48],
    }
}

/// The whole case in `D` dimensions.
pub fn case<const D: usize>(mode: Mode) -> CaseResult
where
    Dim<D>: DimOps<D>,
{
    let cfg = MmsConfig::default();
    let name = if D == 2 { NAME_2D } else { NAME_3D };
    progress(name, "manufactured solution, Neo-Hookean, slip faces");
    let (runs, failures) = sweep(name, &resolutions::<D>(mode), |n| run::<D>(&cfg, n));
    let description = format!(
        "Axis-aligned manufactured solution of Wallstedt & Guilkey (2008) on the unit {}: \
         u_i = A sin(2πX_i) sin(cπt), c = √(E/ρ₀) = {:.1} m/s, A = {} m, Neo-Hookean E = {:.0e} Pa, \
         ν = {}, ρ₀ = {} kg/m^{D}, body force b_i = ü_i − (1/ρ₀)∂P_ii/∂X_i applied per particle at its \
         reference position. Initial x = X, v = u̇(X, 0), C = ∇v(X, 0), F = I. Slip half-space \
         colliders on every face (nodes on the faces lie exactly at 0 and 1), grid 3 cells beyond. \
         {} particles per cell per axis; fixed dt = t_end/steps ≤ {}·Δx/(c_P,max + |v|_max); one \
         period t_end = 2/c = {:.4e} s. error = max over steps of the volume-weighted RMS of \
         |x_p − X_p − u(X_p, t)| (m).",
        if D == 2 { "square" } else { "cube" },
        cfg.speed(),
        cfg.amplitude,
        cfg.youngs,
        cfg.poisson,
        cfg.density,
        cfg.per_axis,
        cfg.cfl,
        cfg.period()
    );
    assemble(name, description, runs, failures, true, |runs| {
        let ok = decreases_under_refinement(runs);
        (
            ok,
            format!(
                "Acceptance: the error decreases monotonically under refinement ({}).",
                if ok { "holds" } else { "does not hold" }
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `P_ii(X)` along the manufactured solution, as a function of the full reference position.
    fn pk1_at<const D: usize>(cfg: &MmsConfig, x: &Vector<D>, t: Real) -> Vector<D> {
        cfg.pk1_diagonal(&x.map(|xi| cfg.stretch(xi, t)))
    }

    fn check_body_force<const D: usize>() {
        let cfg = MmsConfig {
            amplitude: 0.03,
            ..MmsConfig::default()
        };
        let h = 1e-6;
        let ht = 1e-6 * cfg.period();
        for k in 0..7 {
            let x = Vector::<D>::from_fn(|a, _| 0.07 + 0.13 * k as Real + 0.29 * a as Real);
            let t = (0.11 + 0.09 * k as Real) * cfg.period();
            // Divergence of P by central differences; off-diagonal entries of P vanish.
            let div = Vector::<D>::from_fn(|i, _| {
                let mut xp = x;
                xp[i] += h;
                let mut xm = x;
                xm[i] -= h;
                (pk1_at(&cfg, &xp, t)[i] - pk1_at(&cfg, &xm, t)[i]) / (2.0 * h)
            });
            // Acceleration by central differences in time.
            let acc = x.map(|xi| {
                (cfg.displacement(xi, t + ht) - 2.0 * cfg.displacement(xi, t)
                    + cfg.displacement(xi, t - ht))
                    / (ht * ht)
            });
            let b = cfg.body_force(&x, t);
            let residual = acc * cfg.density - div - b * cfg.density;
            let scale = div.norm() + acc.norm() * cfg.density;
            assert!(
                residual.norm() < 1e-5 * scale,
                "{D}D point {k}: residual {residual:?} vs scale {scale:e}"
            );
        }
    }

    #[test]
    fn body_force_balances_finite_difference_momentum_equation() {
        check_body_force::<2>();
        check_body_force::<3>();
    }

    fn check_against_core_model<const D: usize>()
    where
        Dim<D>: DimOps<D>,
    {
        use mpm_core::material::{ElasticModel, Hyperelastic};
        let cfg = MmsConfig::default();
        let model = ElasticModel::NeoHookean(cfg.lame());
        let f = Vector::<D>::from_fn(|a, _| 1.0 + 0.05 * (a as Real + 1.0) - 0.08);
        let p_core = model.pk1(&Matrix::<D>::from_diagonal(&f));
        let p_here = Matrix::<D>::from_diagonal(&cfg.pk1_diagonal(&f));
        assert!(
            (p_core - p_here).norm() < 1e-9 * p_here.norm(),
            "{D}D: {p_core} vs {p_here}"
        );
    }

    #[test]
    fn diagonal_stress_matches_the_solver_neo_hookean_model() {
        check_against_core_model::<2>();
        check_against_core_model::<3>();
    }

    #[test]
    fn stretch_is_the_displacement_gradient() {
        let cfg = MmsConfig::default();
        let (x, t, h) = (0.37, 0.3 * cfg.period(), 1e-7);
        let fd = 1.0 + (cfg.displacement(x + h, t) - cfg.displacement(x - h, t)) / (2.0 * h);
        assert!((fd - cfg.stretch(x, t)).abs() < 1e-8);
        let fdv = (cfg.displacement(x, t + h * 1e-3) - cfg.displacement(x, t - h * 1e-3))
            / (2.0 * h * 1e-3);
        assert!((fdv - cfg.velocity(x, t)).abs() < 1e-6 * cfg.velocity(x, t).abs().max(1.0));
    }

    #[test]
    fn time_steps_cover_one_period() {
        let cfg = MmsConfig::default();
        let (dt, steps) = cfg.time_steps::<2>(1.0 / 16.0);
        assert!((dt * steps as Real - cfg.period()).abs() < 1e-15);
    }
}
