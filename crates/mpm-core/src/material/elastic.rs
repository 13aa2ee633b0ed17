//! Hyperelastic energy densities ψ(F), first Piola–Kirchhoff stresses P(F) and their
//! differentials dP(F)[δF].
//!
//! Every model is normalised so that ψ(I) = 0 and P(I) = 0, and every model's tangent at the rest
//! state is the linear-elastic one, `dP(I)[δF] = 2μ sym δF + λ tr δF I`, so (μ, λ) mean the same
//! small-strain Lamé parameters for every model.
//!
//! * Neo-Hookean and Hencky take logarithms of J (resp. of the singular values) and are
//!   non-finite (NaN or ±∞) for J ≤ 0.
//! * Fixed-corotated writes `J F⁻ᵀ` as the cofactor matrix `cof F`, so it stays finite at J = 0
//!   and for inverted F (except where the polar rotation is itself singular, σᵢ + σⱼ = 0).
//! * Stable Neo-Hookean (Smith, de Goes, Kim 2018) is used without the `log(I_C + 1)`
//!   regulariser, in the form
//!   `ψ = μ/2 (I_C − D) + λ_s/2 (J − α)² − μ²/(2λ_s)` with `λ_s = λ + μ`, `α = 1 + μ/λ_s`,
//!   i.e. `ψ = μ/2 (I_C − D) − μ (J − 1) + λ_s/2 (J − 1)²`. The shift α makes P(I) = 0 in any D,
//!   the constant makes ψ(I) = 0, and `λ_s = λ + μ` (with `μ_s = μ`) is the re-parameterisation
//!   for which the small-strain limit is linear elasticity with the given (μ, λ). It is a
//!   polynomial in F, hence finite for every F including J ≤ 0.

use crate::math::{polar, Dim, DimOps, Matrix, Real, Vector};
use serde::{Deserialize, Serialize};

/// Lamé parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Lame {
    /// Shear modulus μ (Pa).
    pub mu: Real,
    /// First Lamé parameter λ (Pa).
    pub lambda: Real,
}

impl Lame {
    /// From Young's modulus `e` (Pa) and Poisson's ratio `nu` (−1 < ν < 0.5).
    pub fn from_young_poisson(e: Real, nu: Real) -> Self {
        Self {
            mu: e / (2.0 * (1.0 + nu)),
            lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
        }
    }
}

/// The narrow interface every hyperelastic model offers on a deformation gradient F.
pub trait Hyperelastic<const D: usize> {
    /// Energy density ψ(F) (J/m^D, i.e. Pa).
    fn psi(&self, f: &Matrix<D>) -> Real;
    /// First Piola–Kirchhoff stress P = ∂ψ/∂F (Pa).
    fn pk1(&self, f: &Matrix<D>) -> Matrix<D>;
    /// Differential `dP(F)[δF]` (Pa per unit δF).
    fn dpk1(&self, f: &Matrix<D>, df: &Matrix<D>) -> Matrix<D>;
}

/// The hyperelastic models, picked by name.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum ElasticModel {
    /// Compressible Neo-Hookean: ψ = μ/2 (tr FᵀF − D) − μ ln J + λ/2 (ln J)². Undefined for J ≤ 0.
    NeoHookean(Lame),
    /// Fixed-corotated (Stomakhin et al. 2012): ψ = μ ‖F − R‖² + λ/2 (J − 1)².
    FixedCorotated(Lame),
    /// St. Venant–Kirchhoff on the Hencky (logarithmic) strain ε = ln Σ:
    /// ψ = μ tr(ε²) + λ/2 (tr ε)². Undefined for J ≤ 0.
    Hencky(Lame),
    /// Small-strain linear elasticity: ψ = μ ε:ε + λ/2 (tr ε)², ε = (F + Fᵀ)/2 − I.
    LinearElastic(Lame),
    /// Stable Neo-Hookean (Smith et al. 2018), finite for J ≤ 0.
    StableNeoHookean(Lame),
}

impl ElasticModel {
    /// The model's Lamé parameters (Pa).
    pub fn lame(&self) -> Lame {
        match *self {
            Self::NeoHookean(l)
            | Self::FixedCorotated(l)
            | Self::Hencky(l)
            | Self::LinearElastic(l)
            | Self::StableNeoHookean(l) => l,
        }
    }

    /// The same model with both Lamé parameters multiplied by `s` (dimensionless).
    pub fn scaled(&self, s: Real) -> Self {
        let l = self.lame();
        let l = Lame {
            mu: s * l.mu,
            lambda: s * l.lambda,
        };
        match self {
            Self::NeoHookean(_) => Self::NeoHookean(l),
            Self::FixedCorotated(_) => Self::FixedCorotated(l),
            Self::Hencky(_) => Self::Hencky(l),
            Self::LinearElastic(_) => Self::LinearElastic(l),
            Self::StableNeoHookean(_) => Self::StableNeoHookean(l),
        }
    }

    /// Kirchhoff stress `τ = P(F) Fᵀ` (Pa). For the Neo-Hookean model this is
    /// `μ (F Fᵀ − I) + λ ln J I`, which needs no inverse of F (`F⁻ᵀ Fᵀ = I`); the other models
    /// form `P Fᵀ`.
    #[inline]
    pub fn kirchhoff<const D: usize>(&self, f: &Matrix<D>) -> Matrix<D>
    where
        Dim<D>: DimOps<D>,
    {
        match self {
            Self::NeoHookean(Lame { mu, lambda }) => {
                let log_j = Dim::<D>::det(f).ln();
                let mut tau = f * f.transpose() * *mu;
                for a in 0..D {
                    tau[(a, a)] += lambda * log_j - mu;
                }
                tau
            }
            _ => self.pk1(f) * f.transpose(),
        }
    }

    /// Whether ψ, P and dP are finite for J ≤ 0.
    pub fn defined_for_inverted(&self) -> bool {
        matches!(
            self,
            Self::FixedCorotated(_) | Self::LinearElastic(_) | Self::StableNeoHookean(_)
        )
    }
}

impl<const D: usize> Hyperelastic<D> for ElasticModel
where
    Dim<D>: DimOps<D>,
{
    fn psi(&self, f: &Matrix<D>) -> Real {
        let Lame { mu, lambda } = self.lame();
        let d = D as Real;
        match self {
            Self::NeoHookean(_) => {
                let log_j = Dim::<D>::det(f).ln();
                0.5 * mu * (f.norm_squared() - d) - mu * log_j + 0.5 * lambda * log_j * log_j
            }
            Self::FixedCorotated(_) => {
                let (r, _) = polar(f);
                let j = Dim::<D>::det(f);
                mu * (f - r).norm_squared() + 0.5 * lambda * (j - 1.0).powi(2)
            }
            Self::Hencky(_) => {
                let eps = Dim::<D>::svd(f).sigma.map(Real::ln);
                mu * eps.norm_squared() + 0.5 * lambda * eps.sum().powi(2)
            }
            Self::LinearElastic(_) => {
                let eps = small_strain(f);
                mu * eps.norm_squared() + 0.5 * lambda * eps.trace().powi(2)
            }
            Self::StableNeoHookean(_) => {
                let jm1 = Dim::<D>::det(f) - 1.0;
                0.5 * mu * (f.norm_squared() - d) - mu * jm1 + 0.5 * (lambda + mu) * jm1 * jm1
            }
        }
    }

    fn pk1(&self, f: &Matrix<D>) -> Matrix<D> {
        let Lame { mu, lambda } = self.lame();
        match self {
            Self::NeoHookean(_) => {
                let f_inv_t = inverse_transpose(f);
                let log_j = Dim::<D>::det(f).ln();
                (f - f_inv_t) * mu + f_inv_t * (lambda * log_j)
            }
            Self::FixedCorotated(_) => {
                let (r, _) = polar(f);
                let j = Dim::<D>::det(f);
                (f - r) * (2.0 * mu) + cofactor(f) * (lambda * (j - 1.0))
            }
            Self::Hencky(_) => {
                let svd = Dim::<D>::svd(f);
                let h = HenckyPrincipal::new(mu, lambda, &svd.sigma);
                svd.compose(&h.dpsi)
            }
            Self::LinearElastic(_) => {
                let eps = small_strain(f);
                eps * (2.0 * mu) + Matrix::<D>::identity() * (lambda * eps.trace())
            }
            Self::StableNeoHookean(_) => {
                let jm1 = Dim::<D>::det(f) - 1.0;
                f * mu + cofactor(f) * ((lambda + mu) * jm1 - mu)
            }
        }
    }

    fn dpk1(&self, f: &Matrix<D>, df: &Matrix<D>) -> Matrix<D> {
        let Lame { mu, lambda } = self.lame();
        match self {
            Self::NeoHookean(_) => {
                // d(F⁻ᵀ) = −F⁻ᵀ δFᵀ F⁻ᵀ, d(ln J) = F⁻ᵀ : δF.
                let f_inv_t = inverse_transpose(f);
                let log_j = Dim::<D>::det(f).ln();
                let d_log_j = f_inv_t.dot(df);
                df * mu
                    + f_inv_t * df.transpose() * f_inv_t * (mu - lambda * log_j)
                    + f_inv_t * (lambda * d_log_j)
            }
            Self::FixedCorotated(_) => {
                let (r, s) = polar(f);
                let dr = Dim::<D>::polar_rotation_differential(&r, &s, df);
                let (j, cof) = (Dim::<D>::det(f), cofactor(f));
                (df - dr) * (2.0 * mu)
                    + cof * (lambda * cof.dot(df))
                    + cofactor_differential(f, df) * (lambda * (j - 1.0))
            }
            Self::Hencky(_) => hencky_dpk1(mu, lambda, f, df),
            Self::LinearElastic(_) => {
                (df + df.transpose()) * mu + Matrix::<D>::identity() * (lambda * df.trace())
            }
            Self::StableNeoHookean(_) => {
                let lambda_s = lambda + mu;
                let (j, cof) = (Dim::<D>::det(f), cofactor(f));
                df * mu
                    + cof * (lambda_s * cof.dot(df))
                    + cofactor_differential(f, df) * (lambda_s * (j - 1.0) - mu)
            }
        }
    }
}

/// Small strain `ε = (F + Fᵀ)/2 − I`.
fn small_strain<const D: usize>(f: &Matrix<D>) -> Matrix<D> {
    (f + f.transpose()) * 0.5 - Matrix::<D>::identity()
}

/// `F⁻ᵀ`, or a NaN matrix when F is singular (the models using it are undefined there).
fn inverse_transpose<const D: usize>(f: &Matrix<D>) -> Matrix<D>
where
    Dim<D>: DimOps<D>,
{
    Dim::<D>::inverse(f).map_or_else(|| Matrix::<D>::repeat(Real::NAN), |m| m.transpose())
}

/// The symmetric bilinear form `B` with `cof F = B(F, F)` in 3D:
/// `B(A, C)ᵢⱼ = ½ (A_{i+1,j+1} C_{i+2,j+2} + C_{i+1,j+1} A_{i+2,j+2} − A_{i+1,j+2} C_{i+2,j+1}
/// − C_{i+1,j+2} A_{i+2,j+1})` (indices mod 3). In 2D the cofactor is linear in F.
fn cofactor_bilinear<const D: usize>(a: &Matrix<D>, c: &Matrix<D>) -> Matrix<D> {
    Matrix::<D>::from_fn(|i, j| {
        let (i1, i2, j1, j2) = ((i + 1) % 3, (i + 2) % 3, (j + 1) % 3, (j + 2) % 3);
        0.5 * (a[(i1, j1)] * c[(i2, j2)] + c[(i1, j1)] * a[(i2, j2)]
            - a[(i1, j2)] * c[(i2, j1)]
            - c[(i1, j2)] * a[(i2, j1)])
    })
}

/// Cofactor matrix `cof F = J F⁻ᵀ`, defined (and smooth) for every F.
fn cofactor<const D: usize>(f: &Matrix<D>) -> Matrix<D> {
    if D == 2 {
        Matrix::<D>::from_fn(|i, j| {
            let sign = if i == j { 1.0 } else { -1.0 };
            sign * f[(1 - i, 1 - j)]
        })
    } else {
        cofactor_bilinear(f, f)
    }
}

/// Differential of the cofactor matrix, `d(cof F)[δF]`.
fn cofactor_differential<const D: usize>(f: &Matrix<D>, df: &Matrix<D>) -> Matrix<D> {
    if D == 2 {
        cofactor(df)
    } else {
        cofactor_bilinear(f, df) * 2.0
    }
}

/// Principal quantities of the Hencky model for singular values σ (all positive):
/// ε = ln σ, ψᵢ = ∂ψ/∂σᵢ = (2μ εᵢ + λ tr ε)/σᵢ.
struct HenckyPrincipal<const D: usize> {
    mu: Real,
    lambda: Real,
    sigma: Vector<D>,
    eps: Vector<D>,
    dpsi: Vector<D>,
}

impl<const D: usize> HenckyPrincipal<D> {
    fn new(mu: Real, lambda: Real, sigma: &Vector<D>) -> Self {
        let eps = sigma.map(Real::ln);
        let tr = eps.sum();
        let dpsi = Vector::<D>::from_fn(|i, _| (2.0 * mu * eps[i] + lambda * tr) / sigma[i]);
        Self {
            mu,
            lambda,
            sigma: *sigma,
            eps,
            dpsi,
        }
    }

    /// ∂²ψ/∂σᵢ∂σⱼ.
    fn hessian(&self, i: usize, j: usize) -> Real {
        let (mu, lambda, s) = (self.mu, self.lambda, &self.sigma);
        let mut h = lambda / (s[i] * s[j]);
        if i == j {
            h += (2.0 * mu - self.dpsi[i] * s[i]) / (s[i] * s[i]);
        }
        h
    }

    /// Divided difference (ψᵢ − ψⱼ)/(σᵢ − σⱼ), evaluated without cancellation so that it is exact
    /// for σᵢ = σⱼ too. With ψᵢ = g(σᵢ), g(x) = (2μ ln x + c)/x and c = λ tr ε:
    /// (g(x) − g(y))/(x − y) = (2μ (ln(1 + r)/r − ln y) − c)/(x y) with r = (x − y)/y, and
    /// ln(1 + r)/r → 1 as r → 0 (the limit is g'(y)).
    fn divided_difference(&self, i: usize, j: usize) -> Real {
        let (x, y) = (self.sigma[i], self.sigma[j]);
        let r = (x - y) / y;
        let log_ratio = if r == 0.0 { 1.0 } else { r.ln_1p() / r };
        let c = self.lambda * self.eps.sum();
        (2.0 * self.mu * (log_ratio - self.eps[j]) - c) / (x * y)
    }
}

/// dP of the Hencky model through the signed SVD `F = U Σ Vᵀ`: in the rotated frame
/// `δF̂ = Uᵀ δF V`, the diagonal of `dP̂` is `∂²ψ/∂σ∂σ · diag δF̂` and each off-diagonal pair
/// `(dP̂ᵢⱼ, dP̂ⱼᵢ)` is `[[a, b], [b, a]] (δF̂ᵢⱼ, δF̂ⱼᵢ)` with
/// `a, b = ½ ((ψᵢ − ψⱼ)/(σᵢ − σⱼ) ± (ψᵢ + ψⱼ)/(σᵢ + σⱼ))`.
fn hencky_dpk1<const D: usize>(mu: Real, lambda: Real, f: &Matrix<D>, df: &Matrix<D>) -> Matrix<D>
where
    Dim<D>: DimOps<D>,
{
    let svd = Dim::<D>::svd(f);
    let h = HenckyPrincipal::new(mu, lambda, &svd.sigma);
    let dfh = svd.u.transpose() * df * svd.v;
    let mut dph = Matrix::<D>::zeros();
    for i in 0..D {
        dph[(i, i)] = (0..D).map(|j| h.hessian(i, j) * dfh[(j, j)]).sum();
        for j in i + 1..D {
            let diff = h.divided_difference(i, j);
            let sum = (h.dpsi[i] + h.dpsi[j]) / (h.sigma[i] + h.sigma[j]);
            let (a, b) = (0.5 * (diff + sum), 0.5 * (diff - sum));
            dph[(i, j)] = a * dfh[(i, j)] + b * dfh[(j, i)];
            dph[(j, i)] = b * dfh[(i, j)] + a * dfh[(j, i)];
        }
    }
    svd.u * dph * svd.v.transpose()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::Lcg;

    fn lame() -> Lame {
        Lame::from_young_poisson(1e5, 0.3)
    }

    fn models() -> [ElasticModel; 5] {
        let l = lame();
        [
            ElasticModel::NeoHookean(l),
            ElasticModel::FixedCorotated(l),
            ElasticModel::Hencky(l),
            ElasticModel::LinearElastic(l),
            ElasticModel::StableNeoHookean(l),
        ]
    }

    fn diag<const D: usize>(mut f: impl FnMut(usize) -> Real) -> Matrix<D> {
        Matrix::<D>::from_diagonal(&Vector::<D>::from_fn(|i, _| f(i)))
    }

    /// F = I, uniform stretch, (nearly) repeated singular values, near-identity F and larger rotated
    /// stretches with singular values in [0.8, 1.25] (det within [0.5, 2]).
    fn samples<const D: usize>(rng: &mut Lcg) -> Vec<Matrix<D>>
    where
        Dim<D>: DimOps<D>,
    {
        let (q1, q2) = (rng.rotation::<D>(), rng.rotation::<D>());
        let repeated = diag::<D>(|i| if i + 1 < D || D == 2 { 1.2 } else { 0.8 });
        let mut out = vec![
            Matrix::<D>::identity(),
            Matrix::<D>::identity() * 1.1,
            repeated,
            q1 * repeated * q2,
            q1 * diag::<D>(|i| 1.2 + 1e-9 * i as Real) * q2,
            q1 * diag::<D>(|i| if i == 0 { 1.2 } else { 1.0 }) * q2,
        ];
        for _ in 0..5 {
            out.push(Matrix::<D>::identity() + rng.matrix::<D>(0.1));
        }
        for _ in 0..5 {
            let s = diag::<D>(|_| 0.8 + 0.45 * rng.next());
            out.push(rng.rotation::<D>() * s * rng.rotation::<D>());
        }
        out
    }

    /// Asserts ‖a − b‖ ≤ tol (‖b‖ + scale).
    fn assert_close<const D: usize>(a: &Matrix<D>, b: &Matrix<D>, tol: Real, scale: Real) {
        let err = (a - b).norm();
        assert!(err <= tol * (b.norm() + scale), "{a} vs {b}: error {err}");
    }

    fn check_derivatives<const D: usize>(model: &ElasticModel, f: &Matrix<D>, rng: &mut Lcg)
    where
        Dim<D>: DimOps<D>,
    {
        let (h, mu) = (1e-6, model.lame().mu);
        let grad = Matrix::<D>::from_fn(|i, j| {
            let mut e = Matrix::<D>::zeros();
            e[(i, j)] = h;
            (model.psi(&(f + e)) - model.psi(&(f - e))) / (2.0 * h)
        });
        assert_close(&model.pk1(f), &grad, 1e-6, mu);
        // The Kirchhoff stress is P Fᵀ (the Neo-Hookean closed form included).
        assert_close(
            &model.kirchhoff(f),
            &(model.pk1(f) * f.transpose()),
            1e-13,
            mu,
        );
        let df = rng.matrix::<D>(1.0);
        let fd = (model.pk1(&(f + df * h)) - model.pk1(&(f - df * h))) / (2.0 * h);
        assert_close(&model.dpk1(f, &df), &fd, 1e-6, mu * df.norm());
    }

    fn derivatives_match_finite_differences<const D: usize>()
    where
        Dim<D>: DimOps<D>,
    {
        let mut rng = Lcg(1);
        for model in models() {
            for f in samples::<D>(&mut rng) {
                check_derivatives(&model, &f, &mut rng);
            }
        }
    }

    #[test]
    fn pk1_and_dpk1_match_finite_differences_2d() {
        derivatives_match_finite_differences::<2>();
    }

    #[test]
    fn pk1_and_dpk1_match_finite_differences_3d() {
        derivatives_match_finite_differences::<3>();
    }

    fn rest_state<const D: usize>()
    where
        Dim<D>: DimOps<D>,
    {
        let mut rng = Lcg(2);
        let l = lame();
        let i = Matrix::<D>::identity();
        for model in models() {
            assert!(Hyperelastic::<D>::psi(&model, &i).abs() <= 1e-12 * l.mu);
            assert!(model.pk1(&i).norm() <= 1e-12 * l.mu);
            // The tangent at rest is the linear-elastic one for every model.
            let df = rng.matrix::<D>(1.0);
            let linear = (df + df.transpose()) * l.mu + i * (l.lambda * df.trace());
            assert_close(&model.dpk1(&i, &df), &linear, 1e-10, l.mu);
        }
    }

    #[test]
    fn zero_energy_and_stress_at_rest_with_linear_elastic_tangent() {
        rest_state::<2>();
        rest_state::<3>();
    }

    fn dpk1_linear<const D: usize>()
    where
        Dim<D>: DimOps<D>,
    {
        let mut rng = Lcg(3);
        for model in models() {
            for f in samples::<D>(&mut rng) {
                let (a, b) = (rng.matrix::<D>(1.0), rng.matrix::<D>(1.0));
                let lhs = model.dpk1(&f, &(a * 2.0 - b * 0.5));
                let rhs = model.dpk1(&f, &a) * 2.0 - model.dpk1(&f, &b) * 0.5;
                assert_close(&lhs, &rhs, 1e-12, model.lame().mu);
            }
        }
    }

    #[test]
    fn dpk1_is_linear_in_df() {
        dpk1_linear::<2>();
        dpk1_linear::<3>();
    }

    fn objectivity<const D: usize>()
    where
        Dim<D>: DimOps<D>,
    {
        let mut rng = Lcg(4);
        for model in models() {
            if matches!(model, ElasticModel::LinearElastic(_)) {
                continue;
            }
            for f in samples::<D>(&mut rng) {
                let q = rng.rotation::<D>();
                let (a, b) = (model.psi(&(q * f)), model.psi(&f));
                assert!(
                    (a - b).abs() <= 1e-10 * (b.abs() + model.lame().mu),
                    "{a} vs {b}"
                );
                // and the stress rotates with it: P(QF) = Q P(F).
                assert_close(
                    &model.pk1(&(q * f)),
                    &(q * model.pk1(&f)),
                    1e-10,
                    model.lame().mu,
                );
            }
        }
    }

    #[test]
    fn energy_is_objective() {
        objectivity::<2>();
        objectivity::<3>();
    }

    fn inverted<const D: usize>()
    where
        Dim<D>: DimOps<D>,
    {
        let mut rng = Lcg(5);
        let degenerate = diag::<D>(|i| if i + 1 < D { 1.0 } else { 0.0 });
        let flipped = diag::<D>(|i| if i + 1 < D { 1.2 } else { -0.5 });
        let q = rng.rotation::<D>();
        for model in models().into_iter().filter(|m| m.defined_for_inverted()) {
            for f in [degenerate, flipped, q * flipped] {
                let df = rng.matrix::<D>(1.0);
                assert!(model.psi(&f).is_finite(), "{model:?} at {f}");
                assert!(model.pk1(&f).iter().all(|x| x.is_finite()));
                assert!(model.dpk1(&f, &df).iter().all(|x| x.is_finite()));
                // Stress and tangent stay consistent with the energy through inversion.
                check_derivatives(&model, &f, &mut rng);
            }
        }
        for model in models().into_iter().filter(|m| !m.defined_for_inverted()) {
            assert!(!model.psi(&flipped).is_finite(), "{model:?}");
        }
    }

    #[test]
    fn inverted_elements_are_finite_where_defined() {
        inverted::<2>();
        inverted::<3>();
    }

    #[test]
    fn scaled_and_flags() {
        let l = lame();
        for model in models() {
            let s = model.scaled(2.0);
            assert_eq!(s.lame().mu, 2.0 * l.mu);
            assert_eq!(s.lame().lambda, 2.0 * l.lambda);
            assert_eq!(std::mem::discriminant(&s), std::mem::discriminant(&model));
            let f = Matrix::<3>::identity() + Lcg(6).matrix::<3>(0.1);
            assert_close(&s.pk1(&f), &(model.pk1(&f) * 2.0), 1e-14, 0.0);
        }
        let flags: Vec<bool> = models().iter().map(|m| m.defined_for_inverted()).collect();
        assert_eq!(flags, [false, true, false, true, true]);
    }

    #[test]
    fn stable_neo_hookean_finite_when_collapsed() {
        let m = ElasticModel::StableNeoHookean(lame());
        for f in [Matrix::<3>::zeros(), Matrix::<3>::identity() * -1.0] {
            assert!(m.psi(&f).is_finite() && m.psi(&f) > 0.0);
            assert!(m.pk1(&f).iter().all(|x| x.is_finite()));
        }
    }
}
