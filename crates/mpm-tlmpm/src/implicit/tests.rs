//! White-box checks of the incremental potential, its assembled tangent and the linear solvers.

use crate::assembly::{assemble, hessian_pattern};
use crate::params::FixedRegion;
use crate::potential::{deformation, tensor_len, Constitutive, Potential};
use crate::reference::{Constraints, ReferenceConfig};
use mpm_core::material::{ElasticModel, Lame};
use mpm_core::{Dim, DimOps, GridSpec, Kernel, Matrix, Real, Vector};
use mpm_linalg::{
    conjugate_gradient, CgParams, CgStop, CgWorkspace, Jacobi, SparseCholesky, SymmetricMatrix,
};

/// Deterministic numbers in [−1, 1).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> Real {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        2.0 * ((self.0 >> 11) as Real / (1u64 << 53) as Real) - 1.0
    }
    fn vector<const D: usize>(&mut self, a: Real) -> Vector<D> {
        Vector::<D>::from_fn(|_, _| a * self.next())
    }
}

/// A jittered block of particles with a clamped face and a roller face, pre-deformed, with a
/// random inertial target and gravity.
struct Fixture<const D: usize> {
    reference: ReferenceConfig<D>,
    constraints: Constraints<D>,
    models: Vec<ElasticModel>,
    material: Vec<u32>,
    volume0: Vec<Real>,
    def_grad: Vec<Matrix<D>>,
    /// A-ULMPM base `F^{(0,r)}` per particle, `None` for plain TLMPM.
    base: Option<Vec<Matrix<D>>>,
    target: Vec<Vector<D>>,
    external: Vec<Vector<D>>,
    dt: Real,
}

impl<const D: usize> Fixture<D>
where
    Dim<D>: DimOps<D>,
{
    fn new(model: ElasticModel, kernel: Kernel, rng: &mut Lcg) -> Self {
        let dx = 0.1;
        let h = 0.05;
        let spec = GridSpec::<D>::new(Vector::<D>::zeros(), dx, [12; D]);
        let per_axis: usize = 6;
        let mut x = Vec::new();
        for k in 0..per_axis.pow(D as u32) {
            let mut r = k;
            let p = Vector::<D>::from_fn(|_, _| {
                let i = r % per_axis;
                r /= per_axis;
                0.3 + (i as Real + 0.5) * h
            });
            x.push(p + rng.vector::<D>(0.2 * h));
        }
        let n = x.len();
        let mass = vec![1000.0 * h.powi(D as i32); n];
        let reference = ReferenceConfig::new(spec, kernel, &[], &x, &mass).unwrap();
        let mut lo = Vector::<D>::from_element(-1.0);
        let mut hi = Vector::<D>::from_element(10.0);
        hi[0] = 0.3;
        let clamp = FixedRegion::clamp(lo, hi);
        lo[0] = 0.6;
        hi[0] = 10.0;
        let mut axes = [false; D];
        axes[1] = true;
        let roller = FixedRegion {
            min: lo,
            max: hi,
            axes,
            velocity: rng.vector::<D>(1.0),
        };
        let constraints = Constraints::new(&reference, &[clamp, roller]);
        let def_grad = (0..n)
            .map(|_| Matrix::<D>::identity() + Matrix::<D>::from_fn(|_, _| 0.1 * rng.next()))
            .collect();
        let gravity = rng.vector::<D>(10.0);
        let nodes = reference.num_nodes();
        let external = reference
            .node_masses()
            .iter()
            .map(|&m| gravity * m)
            .collect();
        Self {
            constraints,
            models: vec![model],
            material: vec![0; n],
            volume0: vec![h.powi(D as i32); n],
            def_grad,
            base: None,
            target: (0..nodes).map(|_| rng.vector::<D>(0.01)).collect(),
            external,
            dt: 2e-3,
            reference,
        }
    }

    fn law(&self) -> Constitutive<'_, D> {
        Constitutive {
            models: &self.models,
            material: &self.material,
            volume0: &self.volume0,
            base: self.base.as_deref(),
            hardening: None,
        }
    }

    fn potential(&self) -> Potential<'_, D> {
        Potential {
            reference: &self.reference,
            constraints: &self.constraints,
            law: self.law(),
            def_grad: &self.def_grad,
            target: &self.target,
            external: &self.external,
            inertia: 1.0 / (self.dt * self.dt),
        }
    }

    fn energy(&self, u: &[Vector<D>]) -> Real {
        let n = self.material.len();
        let mut f = vec![Matrix::<D>::zeros(); n];
        deformation(&self.reference, &self.def_grad, u, &mut f);
        self.potential().energy(u, &f, &mut vec![0.0; n]).unwrap().0
    }

    fn gradient(&self, u: &[Vector<D>]) -> Vec<Vector<D>> {
        let n = self.material.len();
        let mut f = vec![Matrix::<D>::zeros(); n];
        deformation(&self.reference, &self.def_grad, u, &mut f);
        let mut s = vec![Matrix::<D>::zeros(); n];
        self.law().weighted_stresses(&f, &mut s);
        let mut g = vec![Vector::<D>::zeros(); u.len()];
        // The rounding scales only enter the magnitudes, which this gradient discards.
        let scales = vec![0.0; n];
        self.potential()
            .gradient(u, (&s, &scales), &mut g, &mut vec![[0.0; 4]; u.len()]);
        g
    }

    fn tensors(&self, u: &[Vector<D>], project: bool) -> Vec<Real> {
        let n = self.material.len();
        let mut f = vec![Matrix::<D>::zeros(); n];
        deformation(&self.reference, &self.def_grad, u, &mut f);
        let mut t = vec![0.0; n * tensor_len(D)];
        self.potential().tensors(&f, project, &mut t);
        t
    }

    /// A random state: free components random, prescribed components at their prescribed
    /// displacement.
    fn state(&self, rng: &mut Lcg, amplitude: Real) -> Vec<Vector<D>> {
        (0..self.reference.num_nodes())
            .map(|i| {
                self.constraints
                    .displacement(i, rng.vector::<D>(amplitude), self.dt)
            })
            .collect()
    }

    /// A random direction on the free components.
    fn direction(&self, rng: &mut Lcg) -> Vec<Vector<D>> {
        self.constraints
            .mask
            .iter()
            .map(|m| rng.vector::<D>(1.0).component_mul(m))
            .collect()
    }

    fn to_equations(&self, v: &[Vector<D>]) -> Vec<Real> {
        let mut out = vec![0.0; self.constraints.dofs.len() * D];
        for (e, &j) in self.constraints.dofs.nodes().iter().enumerate() {
            for a in 0..D {
                out[e * D + a] = v[j][a] * self.constraints.mask[j][a];
            }
        }
        out
    }
}

fn dot<const D: usize>(a: &[Vector<D>], b: &[Vector<D>]) -> Real {
    a.iter().zip(b).map(|(x, y)| x.dot(y)).sum()
}

fn models() -> [ElasticModel; 5] {
    let l = Lame::from_young_poisson(1e5, 0.3);
    [
        ElasticModel::NeoHookean(l),
        ElasticModel::FixedCorotated(l),
        ElasticModel::StableNeoHookean(l),
        ElasticModel::Hencky(l),
        ElasticModel::LinearElastic(l),
    ]
}

/// Largest relative errors of (gradient, assembled tangent, matrix-free tangent) against
/// central finite differences of the potential and of its gradient.
/// With `base`, every particle gets a random A-ULMPM base `F^{(0,r)}` near the identity.
fn finite_difference_errors<const D: usize>(
    model: ElasticModel,
    kernel: Kernel,
    base: bool,
) -> [Real; 3]
where
    Dim<D>: DimOps<D>,
{
    let mut rng = Lcg(17);
    let mut fx = Fixture::<D>::new(model, kernel, &mut rng);
    if base {
        fx.base = Some(
            (0..fx.material.len())
                .map(|_| Matrix::<D>::identity() + Matrix::<D>::from_fn(|_, _| 0.2 * rng.next()))
                .collect(),
        );
    }
    let u = fx.state(&mut rng, 0.005);
    let pot = fx.potential();
    let g = fx.gradient(&u);
    let tensors = fx.tensors(&u, false);
    let pattern = hessian_pattern(&fx.reference, &fx.constraints).unwrap();
    let mut matrix = SymmetricMatrix::new(pattern);
    assemble(&pot, &tensors, &mut matrix);
    let mut errors = [0.0f64; 3];
    for _ in 0..3 {
        let d = fx.direction(&mut rng);
        let h = 1e-6;
        let shifted =
            |s: Real| -> Vec<Vector<D>> { u.iter().zip(&d).map(|(x, y)| x + y * s).collect() };
        // Energy → gradient.
        let fd = (fx.energy(&shifted(h)) - fx.energy(&shifted(-h))) / (2.0 * h);
        let exact = dot(&g, &d);
        errors[0] = errors[0].max((fd - exact).abs() / exact.abs());
        // Gradient → assembled tangent.
        let (gp, gm) = (fx.gradient(&shifted(h)), fx.gradient(&shifted(-h)));
        let fd: Vec<Vector<D>> = gp
            .iter()
            .zip(&gm)
            .map(|(a, b)| (a - b) / (2.0 * h))
            .collect();
        let fd_eq = fx.to_equations(&fd);
        let mut hd = vec![0.0; fd_eq.len()];
        matrix.mul_vec(&fx.to_equations(&d), &mut hd);
        let norm = fd_eq.iter().map(|x| x * x).sum::<Real>().sqrt();
        let err = hd
            .iter()
            .zip(&fd_eq)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<Real>()
            .sqrt();
        errors[1] = errors[1].max(err / norm);
        // Matrix-free product.
        let mut y = vec![Vector::<D>::zeros(); u.len()];
        let mut scratch = vec![Matrix::<D>::zeros(); fx.material.len()];
        pot.apply_hessian(&tensors, &d, &mut scratch, &mut y);
        let y_eq = fx.to_equations(&y);
        let err = y_eq
            .iter()
            .zip(&hd)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<Real>()
            .sqrt();
        errors[2] = errors[2].max(err / norm);
    }
    errors
}

fn check_tangent<const D: usize>()
where
    Dim<D>: DimOps<D>,
{
    let cases = [
        (Kernel::Quadratic, false),
        (Kernel::Linear, false),
        (Kernel::Cubic, false),
        (Kernel::Quadratic, true),
    ];
    for (kernel, base) in cases {
        for model in models() {
            let [grad, tangent, matrix_free] = finite_difference_errors::<D>(model, kernel, base);
            println!(
                "{D}D {kernel:?} {model:?} (A-ULMPM base: {base}): gradient {grad:.2e}, tangent {tangent:.2e}, \
                 matrix-free {matrix_free:.2e}"
            );
            assert!(grad < 1e-6, "gradient error {grad:e}");
            assert!(tangent < 1e-6, "tangent error {tangent:e}");
            assert!(matrix_free < 1e-12, "matrix-free error {matrix_free:e}");
        }
    }
}

#[test]
fn assembled_tangent_matches_finite_differences_2d() {
    check_tangent::<2>();
}

#[test]
fn assembled_tangent_matches_finite_differences_3d() {
    check_tangent::<3>();
}

fn check_projection<const D: usize>()
where
    Dim<D>: DimOps<D>,
{
    let mut rng = Lcg(5);
    let model = ElasticModel::FixedCorotated(Lame::from_young_poisson(1e5, 0.3));
    let fx = Fixture::<D>::new(model, Kernel::Quadratic, &mut rng);
    // Strong compression makes the corotated tensor indefinite somewhere.
    let u = fx.state(&mut rng, 0.04);
    let exact = fx.tensors(&u, false);
    let projected = fx.tensors(&u, true);
    let n2 = D * D;
    let min_eig = |t: &[Real]| -> Real {
        let m = nalgebra::DMatrix::from_row_slice(n2, n2, t);
        m.symmetric_eigenvalues().min()
    };
    let (mut worst_exact, mut worst_projected, mut changed) = (0.0f64, 0.0f64, 0);
    for p in 0..fx.material.len() {
        let r = p * tensor_len(D)..(p + 1) * tensor_len(D);
        let (e, q) = (min_eig(&exact[r.clone()]), min_eig(&projected[r.clone()]));
        let scale = exact[r.clone()]
            .iter()
            .fold(0.0, |a: Real, b| a.max(b.abs()));
        worst_exact = worst_exact.min(e / scale);
        worst_projected = worst_projected.min(q / scale);
        if e >= 0.0 {
            // Already PSD: projection leaves it unchanged.
            assert_eq!(&exact[r.clone()], &projected[r]);
        } else {
            changed += 1;
        }
    }
    println!("{D}D: min eigenvalue/scale exact {worst_exact:.3e}, projected {worst_projected:.3e}, {changed} projected");
    assert!(
        worst_exact < 0.0,
        "the test state should be indefinite somewhere"
    );
    assert!(worst_projected > -1e-12);
}

#[test]
fn spd_projection_clamps_negative_eigenvalues() {
    check_projection::<2>();
    check_projection::<3>();
}

fn check_symbolic_reuse<const D: usize>()
where
    Dim<D>: DimOps<D>,
{
    let mut rng = Lcg(9);
    let model = ElasticModel::NeoHookean(Lame::from_young_poisson(1e5, 0.3));
    let fx = Fixture::<D>::new(model, Kernel::Quadratic, &mut rng);
    let pot = fx.potential();
    let pattern = hessian_pattern(&fx.reference, &fx.constraints).unwrap();
    let n = fx.constraints.dofs.len() * D;
    // Analyse once and factorise an earlier state first, as Newton does.
    let mut reused = SparseCholesky::new(&pattern).unwrap();
    let mut matrix = SymmetricMatrix::new(pattern);
    let u0 = fx.state(&mut rng, 0.0);
    assemble(&pot, &fx.tensors(&u0, false), &mut matrix);
    reused.factorize(&matrix).unwrap();
    // The state of interest.
    let u1 = fx.state(&mut rng, 0.005);
    let tensors = fx.tensors(&u1, false);
    assemble(&pot, &tensors, &mut matrix);
    let b = fx.to_equations(&fx.gradient(&u1));
    reused.factorize(&matrix).unwrap();
    let mut x_reused = b.clone();
    reused.solve_in_place(&mut x_reused).unwrap();
    let mut fresh = SparseCholesky::new(matrix.pattern()).unwrap();
    fresh.factorize(&matrix).unwrap();
    let mut x_fresh = b.clone();
    fresh.solve_in_place(&mut x_fresh).unwrap();
    let norm = x_fresh.iter().map(|x| x * x).sum::<Real>().sqrt();
    let diff = x_reused
        .iter()
        .zip(&x_fresh)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<Real>()
        .sqrt();
    // Independent check: CG on the matrix-free operator.
    let mut scratch = vec![Matrix::<D>::zeros(); fx.material.len()];
    let mut inv_diag = vec![Vector::<D>::zeros(); u1.len()];
    pot.inverse_diagonal(&tensors, &mut inv_diag);
    let rhs = fx.gradient(&u1);
    let mut x_cg = vec![Vector::<D>::zeros(); u1.len()];
    let params = CgParams {
        max_iterations: 5000,
        rel_tol: 1e-13,
        ..CgParams::default()
    };
    let info = conjugate_gradient(
        &mut |x: &[Vector<D>], y: &mut [Vector<D>]| pot.apply_hessian(&tensors, x, &mut scratch, y),
        &mut Jacobi::from_inverse_diagonal(inv_diag),
        &rhs,
        &mut x_cg,
        &params,
        &mut CgWorkspace::new(),
    )
    .unwrap();
    let iterations = info.iterations;
    assert_eq!(info.stop, CgStop::Converged);
    let x_cg = fx.to_equations(&x_cg);
    let diff_cg = x_cg
        .iter()
        .zip(&x_fresh)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<Real>()
        .sqrt();
    let mut ax = vec![0.0; n];
    matrix.mul_vec(&x_reused, &mut ax);
    let residual = ax
        .iter()
        .zip(&b)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<Real>()
        .sqrt()
        / b.iter().map(|x| x * x).sum::<Real>().sqrt();
    println!(
        "{D}D: n = {n}, nnz(A) = {}, nnz(L) = {}, reused vs fresh {:.2e}, vs CG ({iterations} its) \
         {:.2e}, relative residual {residual:.2e}",
        reused.nnz(),
        reused.factor_nnz(),
        diff / norm,
        diff_cg / norm
    );
    assert_eq!(
        x_reused, x_fresh,
        "same pattern, same ordering: bitwise equal"
    );
    assert!(diff_cg / norm < 1e-8);
    assert!(residual < 1e-12);
}

#[test]
fn reused_symbolic_factorisation_matches_a_fresh_one() {
    check_symbolic_reuse::<2>();
    check_symbolic_reuse::<3>();
}
