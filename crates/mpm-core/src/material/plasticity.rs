//! Plastic flow rules applied as return mappings on the trial elastic deformation gradient.
//!
//! Both rules work on the signed SVD `F = U Σ Vᵀ` of the trial elastic deformation gradient
//! (see [`crate::math::Svd`]).
//!
//! * Snow clamps the *signed* singular values, so an inverted trial F (σ_D < 0) is flipped back
//!   to a positive stretch and the sign goes into `J_P` (which becomes negative); the product
//!   `det F_E · J_P` is conserved exactly.
//! * Drucker–Prager works on the Hencky strain `ε = ln max(|σ|, 10⁻⁶)`, so inversion is discarded
//!   and a collapsed direction gets a large but finite compressive strain. Cohesion `c` moves the
//!   apex of the cone from `ε = 0` to `ε = c (1, …, 1)`: the return mapping of Klár et al. 2016 is
//!   applied to `ε − c` and `c` is added back, so the material sustains an isotropic tensile
//!   log-strain up to `c` per direction (`c = 0` is cohesionless sand).

use super::{ElasticModel, Lame};
use crate::math::{Dim, DimOps, Matrix, Real, Vector};
use serde::{Deserialize, Serialize};

/// Per-particle plastic state. The default is the virgin state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlasticState {
    /// Snow: plastic volume ratio J_P = det F_P (dimensionless, 1 when virgin).
    pub jp: Real,
    /// Sand: accumulated plastic strain q, the hardening variable of Klár et al. 2016.
    pub q: Real,
    /// Sand: volume-correction scalar v_c (log of volume gained by the tip projection,
    /// Tampubolon et al. 2017); 0 when virgin.
    pub vc: Real,
}

impl Default for PlasticState {
    fn default() -> Self {
        Self {
            jp: 1.0,
            q: 0.0,
            vc: 0.0,
        }
    }
}

/// Snow plasticity (Stomakhin et al. 2013).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Snow {
    /// Critical compression θ_c (dimensionless, e.g. 2.5e-2).
    pub theta_c: Real,
    /// Critical stretch θ_s (dimensionless, e.g. 7.5e-3).
    pub theta_s: Real,
    /// Hardening coefficient ξ (dimensionless, e.g. 10).
    pub hardening: Real,
}

/// Drucker–Prager sand plasticity (Klár et al. 2016) with volume correction.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DruckerPrager {
    /// Hardening parameters h₀..h₃ of the friction angle φ_F = h₀ + (h₁ q − h₃) e^{−h₂ q}
    /// (degrees for h₀, h₁, h₃; h₂ dimensionless). Klár et al. use (35, 9, 0.2, 10).
    pub h: [Real; 4],
    /// Cohesion c (dimensionless fraction of the tip shift, ≥ 0).
    pub cohesion: Real,
    /// Whether the volume correction of Tampubolon et al. 2017 is applied.
    pub volume_correction: bool,
}

/// Plastic flow rules.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case")]
pub enum Plasticity {
    /// Purely elastic.
    #[default]
    None,
    /// Snow: singular values clamped to [1 − θ_c, 1 + θ_s], hardening e^{ξ(1 − J_P)}.
    Snow(Snow),
    /// Drucker–Prager sand.
    DruckerPrager(DruckerPrager),
}

/// Largest magnitude of the snow hardening exponent ξ (1 − J_P): the Lamé scale stays within
/// [e⁻²⁰, e²⁰] ≈ [2·10⁻⁹, 5·10⁸], finite for any J_P (J_P far outside ~[0.5, 1.5] is
/// unphysical anyway; the time-step control sees the stiffened wave speed).
const MAX_HARDENING_EXPONENT: Real = 20.0;

/// Smallest |σ| fed to the logarithm of the sand return mapping (keeps ε finite).
const MIN_STRETCH: Real = 1e-6;

impl Plasticity {
    /// Multiplier applied to both Lamé parameters for the current state (1 when no hardening).
    /// Snow: `exp(ξ (1 − J_P))` with the exponent clamped to ±20 so the factor stays finite.
    #[inline]
    pub fn hardening_scale(&self, state: &PlasticState) -> Real {
        match self {
            Plasticity::Snow(s) => (s.hardening * (1.0 - state.jp))
                .clamp(-MAX_HARDENING_EXPONENT, MAX_HARDENING_EXPONENT)
                .exp(),
            Plasticity::None | Plasticity::DruckerPrager(_) => 1.0,
        }
    }

    /// Return mapping: projects the trial elastic deformation gradient onto the admissible set,
    /// updates `state`, and returns the new elastic deformation gradient.
    pub fn project<const D: usize>(
        &self,
        f_trial: &Matrix<D>,
        state: &mut PlasticState,
        elastic: &ElasticModel,
    ) -> Matrix<D>
    where
        Dim<D>: DimOps<D>,
    {
        match self {
            Plasticity::None => *f_trial,
            Plasticity::Snow(s) => s.project(f_trial, state),
            Plasticity::DruckerPrager(dp) => dp.project(f_trial, state, elastic.lame()),
        }
    }
}

impl Snow {
    /// Clamps the signed singular values to [1 − θ_c, 1 + θ_s] and moves the removed volume into
    /// J_P, so that `det F_E · J_P` is unchanged.
    fn project<const D: usize>(&self, f_trial: &Matrix<D>, state: &mut PlasticState) -> Matrix<D>
    where
        Dim<D>: DimOps<D>,
    {
        let svd = Dim::<D>::svd(f_trial);
        let clamped = svd
            .sigma
            .map(|s| clamp_keep_nan(s, 1.0 - self.theta_c, 1.0 + self.theta_s));
        state.jp *= svd.sigma.product() / clamped.product();
        svd.compose(&clamped)
    }
}

impl DruckerPrager {
    /// Friction angle φ_F(q) = h₀ + (h₁ q − h₃) e^{−h₂ q} (degrees) for accumulated plastic
    /// strain q (dimensionless).
    pub fn friction_angle(&self, q: Real) -> Real {
        let [h0, h1, h2, h3] = self.h;
        h0 + (h1 * q - h3) * (-h2 * q).exp()
    }

    /// Friction coefficient α(q) of the cone `‖dev τ‖ + α tr τ ≤ 0` in `D` dimensions
    /// (dimensionless), matched to Mohr–Coulomb with the friction angle φ_F(q):
    ///
    /// * 3D: `α = √(2/3) · 2 sin φ_F / (3 − sin φ_F)`, the cone through Mohr–Coulomb's
    ///   compression meridian (Klár et al. 2016).
    /// * 2D (plane strain): `α = sin φ_F / √2`. With the in-plane principal stresses τ₁, τ₂,
    ///   `‖dev τ‖ = |τ₁ − τ₂|/√2` and `tr τ = τ₁ + τ₂`, so the cone is exactly Mohr–Coulomb's
    ///   `(τ₁ − τ₂)/2 ≤ −sin φ_F (τ₁ + τ₂)/2` for the in-plane pair: the plane-strain criterion
    ///   when the out-of-plane stress is the intermediate one, as it is in plane-strain plastic
    ///   flow. (The 3D mapping used in 2D gives `sin φ_eff = √2 α₃D`, φ_eff = 17.1° for
    ///   φ_F = 19.8° and 27.5° for 30°: sand that is too weak.)
    pub fn friction_coefficient<const D: usize>(&self, q: Real) -> Real {
        let s = self.friction_angle(q).to_radians().sin();
        if D == 2 {
            s / (2.0 as Real).sqrt()
        } else {
            (2.0 / 3.0 as Real).sqrt() * 2.0 * s / (3.0 - s)
        }
    }

    /// Yield function of an elastic deformation gradient `f_e` at hardening state `q` with Lamé
    /// parameters `lame` (dimensionless): with `ε` the Hencky strain relative to the cone apex and
    /// `ε̂` its deviator, `y = ‖ε̂‖ + (Dλ + 2μ)/(2μ) α(q) tr ε`, which is `(‖dev τ‖ + α tr τ)/(2μ)`
    /// for the Hencky Kirchhoff stress τ. `y ≤ 0` inside the cone (apex included), `y > 0`
    /// outside, including any isotropic tension beyond the apex.
    pub fn yield_function<const D: usize>(&self, f_e: &Matrix<D>, q: Real, lame: Lame) -> Real
    where
        Dim<D>: DimOps<D>,
    {
        let eps = log_strain(&Dim::<D>::svd(f_e).sigma).add_scalar(-self.cohesion);
        let tr = eps.sum();
        let dev = eps.add_scalar(-tr / D as Real);
        dev.norm() + volumetric_ratio::<D>(lame) * self.friction_coefficient::<D>(q) * tr
    }

    /// Return mapping of Klár et al. 2016 (Sec. 7.3) with the volume correction of Tampubolon et
    /// al. 2017: `ε = ln|σ| (+ v_c/D)` relative to the apex; tension beyond the apex projects to
    /// the apex, otherwise the deviator is shrunk onto the cone of α(q_old). `q` grows by the
    /// plastic multiplier δγ; with volume correction `v_c ← v_c + ln|det F_trial| − ln det F_E`.
    fn project<const D: usize>(
        &self,
        f_trial: &Matrix<D>,
        state: &mut PlasticState,
        lame: Lame,
    ) -> Matrix<D>
    where
        Dim<D>: DimOps<D>,
    {
        let svd = Dim::<D>::svd(f_trial);
        let mut eps = log_strain(&svd.sigma).add_scalar(-self.cohesion);
        if self.volume_correction {
            eps.add_scalar_mut(state.vc / D as Real);
        }
        let tr = eps.sum();
        let dev = eps.add_scalar(-tr / D as Real);
        let dev_norm = dev.norm();
        let tip = tr > 0.0;
        let (projected, delta_gamma) = if tip {
            (Vector::<D>::zeros(), eps.norm())
        } else {
            let dg = dev_norm
                + volumetric_ratio::<D>(lame) * self.friction_coefficient::<D>(state.q) * tr;
            if dg <= 0.0 || dev_norm == 0.0 {
                (eps, 0.0)
            } else {
                (eps - dev * (dg / dev_norm), dg)
            }
        };
        state.q += delta_gamma;
        if self.volume_correction {
            // v_c + ln|det F_trial| − ln det F_E = tr ε − tr ε_new: the elastic and cone cases
            // keep tr ε (so v_c is used up), the apex projection stores the removed volume.
            state.vc = if tip { tr } else { 0.0 };
        }
        svd.compose(&projected.add_scalar(self.cohesion).map(Real::exp))
    }
}

/// `(Dλ + 2μ)/(2μ)`: ratio of the volumetric to the deviatoric Hencky stiffness.
fn volumetric_ratio<const D: usize>(lame: Lame) -> Real {
    (D as Real * lame.lambda + 2.0 * lame.mu) / (2.0 * lame.mu)
}

/// Hencky strain `ln max(|σ|, MIN_STRETCH)` of signed singular values (NaN stays NaN).
fn log_strain<const D: usize>(sigma: &Vector<D>) -> Vector<D> {
    sigma.map(|s| clamp_keep_nan(s.abs(), MIN_STRETCH, Real::INFINITY).ln())
}

/// `x` clamped to `[lo, hi]`; unlike `f64::clamp` it never panics on inconsistent bounds and,
/// unlike `max`/`min`, it lets NaN through so that the solver's guard sees it.
fn clamp_keep_nan(x: Real, lo: Real, hi: Real) -> Real {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::det;
    use crate::test_util::Lcg;

    fn elastic() -> ElasticModel {
        ElasticModel::Hencky(Lame::from_young_poisson(1e6, 0.3))
    }

    const SNOW: Snow = Snow {
        theta_c: 2.5e-2,
        theta_s: 7.5e-3,
        hardening: 10.0,
    };

    fn snow<const D: usize>()
    where
        Dim<D>: DimOps<D>,
    {
        let mut rng = Lcg(11);
        let (lo, hi) = (1.0 - SNOW.theta_c, 1.0 + SNOW.theta_s);
        for k in 0..40 {
            let mut f = Matrix::<D>::identity() + rng.matrix::<D>(0.1);
            if k % 10 == 0 {
                f.set_column(0, &(-f.column(0))); // inverted trial
            }
            let jp_old = 0.9 + 0.2 * rng.next();
            let mut state = PlasticState {
                jp: jp_old,
                ..PlasticState::default()
            };
            let fe = Plasticity::Snow(SNOW).project(&f, &mut state, &elastic());
            for s in Dim::<D>::svd(&fe).sigma.iter() {
                assert!((lo - 1e-12..=hi + 1e-12).contains(s), "σ = {s}");
            }
            let (before, after) = (det(&f) * jp_old, det(&fe) * state.jp);
            assert!(
                (after - before).abs() <= 1e-12 * before.abs(),
                "{before} vs {after}"
            );
        }
        // In-bounds F is left unchanged.
        let sigma = Vector::<D>::from_fn(|i, _| [1.005, 0.99, 0.98][i]);
        let f = rng.rotation::<D>() * Matrix::<D>::from_diagonal(&sigma) * rng.rotation::<D>();
        let mut state = PlasticState::default();
        let fe = Plasticity::Snow(SNOW).project(&f, &mut state, &elastic());
        assert!((fe - f).norm() <= 1e-12);
        assert!((state.jp - 1.0).abs() <= 1e-12);
    }

    #[test]
    fn snow_clamps_singular_values_and_conserves_volume() {
        snow::<2>();
        snow::<3>();
    }

    #[test]
    fn hardening_scale() {
        let state = |jp| PlasticState {
            jp,
            ..PlasticState::default()
        };
        let snow = Plasticity::Snow(SNOW);
        assert_eq!(snow.hardening_scale(&state(1.0)), 1.0);
        let e = snow.hardening_scale(&state(0.9));
        assert!((e - 1.0_f64.exp()).abs() < 1e-12);
        assert!(snow.hardening_scale(&state(-1e12)).is_finite());
        assert!(snow.hardening_scale(&state(1e12)) > 0.0);
        assert_eq!(Plasticity::None.hardening_scale(&state(0.5)), 1.0);
        let dp = Plasticity::DruckerPrager(sand(0.0, true));
        assert_eq!(dp.hardening_scale(&state(0.5)), 1.0);
    }

    fn sand(cohesion: Real, volume_correction: bool) -> DruckerPrager {
        DruckerPrager {
            h: [35.0, 9.0, 0.2, 10.0],
            cohesion,
            volume_correction,
        }
    }

    /// Trial F: pure tension, pure compression, compression with shear, random.
    fn sand_trials<const D: usize>(rng: &mut Lcg) -> Vec<Matrix<D>>
    where
        Dim<D>: DimOps<D>,
    {
        let i = Matrix::<D>::identity();
        let mut out = vec![i * 1.1, i * 0.9, i * 1.0001];
        for _ in 0..10 {
            let shear = rng.matrix::<D>(0.2);
            out.push(i * 0.95 + (shear - shear.transpose()) * 0.5 + shear * 0.3);
            out.push(i + rng.matrix::<D>(0.3));
        }
        out
    }

    fn drucker_prager<const D: usize>()
    where
        Dim<D>: DimOps<D>,
    {
        let mut rng = Lcg(12);
        let lame = elastic().lame();
        for dp in [sand(0.0, false), sand(0.0, true), sand(0.01, true)] {
            let mut state = PlasticState::default();
            for f in sand_trials::<D>(&mut rng) {
                let old = state;
                let fe = Plasticity::DruckerPrager(dp).project(&f, &mut state, &elastic());
                let y = dp.yield_function(&fe, old.q, lame);
                assert!(y <= 1e-10, "outside the cone: y = {y}");
                assert!(state.q >= old.q);
                if dp.volume_correction {
                    let expected = old.vc + det(&f).abs().ln() - det(&fe).ln();
                    assert!((state.vc - expected).abs() <= 1e-10);
                    assert!(state.vc >= -1e-12);
                } else {
                    assert_eq!(state.vc, 0.0);
                }
            }
            // Pure tension beyond the apex lands on the apex.
            let mut state = PlasticState::default();
            let fe = Plasticity::DruckerPrager(dp).project(
                &(Matrix::<D>::identity() * 1.1),
                &mut state,
                &elastic(),
            );
            let apex = Matrix::<D>::identity() * dp.cohesion.exp();
            assert!((fe - apex).norm() <= 1e-12);
            let eps = 1.1_f64.ln() - dp.cohesion;
            assert!((state.q - eps * (D as Real).sqrt()).abs() <= 1e-12);
        }
    }

    #[test]
    fn drucker_prager_returns_inside_the_cone() {
        drucker_prager::<2>();
        drucker_prager::<3>();
    }

    fn sand_elastic_region<const D: usize>()
    where
        Dim<D>: DimOps<D>,
    {
        let mut rng = Lcg(13);
        let lame = elastic().lame();
        for dp in [sand(0.0, false), sand(0.0, true), sand(0.01, true)] {
            // Compression with a small deviatoric part.
            let eps = Vector::<D>::from_fn(|i, _| [-0.01, -0.02, -0.015][i]);
            let sigma = eps.map(Real::exp);
            let f = rng.rotation::<D>() * Matrix::<D>::from_diagonal(&sigma) * rng.rotation::<D>();
            assert!(dp.yield_function(&f, 0.0, lame) < 0.0);
            let mut state = PlasticState::default();
            let fe = Plasticity::DruckerPrager(dp).project(&f, &mut state, &elastic());
            assert!((fe - f).norm() <= 1e-12);
            assert_eq!(state, PlasticState::default());
        }
    }

    #[test]
    fn drucker_prager_keeps_admissible_states() {
        sand_elastic_region::<2>();
        sand_elastic_region::<3>();
    }

    #[test]
    fn friction_coefficient_matches_klar() {
        let dp = sand(0.0, false);
        assert!((dp.friction_angle(0.0) - 25.0).abs() < 1e-12);
        let s = 25.0_f64.to_radians().sin();
        let alpha = (2.0_f64 / 3.0).sqrt() * 2.0 * s / (3.0 - s);
        assert!((dp.friction_coefficient::<3>(0.0) - alpha).abs() < 1e-14);
        assert!((dp.friction_angle(1e3) - 35.0).abs() < 1e-12);
    }

    /// Plane strain: a trial state far outside the 2D cone returns to a state whose Mohr circle
    /// of the in-plane Hencky Kirchhoff stresses touches the Mohr–Coulomb envelope
    /// `|τ| = −σ tan φ`, i.e. radius `R = −sin φ · centre`, for the friction angle the state's
    /// q gives.
    #[test]
    fn plane_strain_return_lies_on_mohr_coulomb() {
        let lame = elastic().lame();
        let dp = sand(0.0, false);
        let mut rng = Lcg(7);
        let mut checked = 0;
        for _ in 0..200 {
            // A compressive trial (tr ε < 0) with a large shear: one stretch above 1, one well
            // below, so ‖dev ε‖ ≥ 0.15 exceeds the cone's reach at |tr ε| ≤ 0.17.
            let a = 1.05 + 0.05 * rng.next();
            let b = 0.80 + 0.05 * rng.next();
            let theta = 3.0 * rng.next();
            let rot = Matrix::<2>::new(theta.cos(), -theta.sin(), theta.sin(), theta.cos());
            let f = rot * Matrix::<2>::new(a, 0.0, 0.0, b) * rot.transpose();
            let mut state = PlasticState::default();
            let fe = Plasticity::DruckerPrager(dp).project(&f, &mut state, &elastic());
            if state.q == 0.0 {
                continue;
            }
            let eps = log_strain(&Dim::<2>::svd(&fe).sigma);
            let tr = eps.sum();
            let tau = eps.map(|e| 2.0 * lame.mu * e + lame.lambda * tr);
            let centre = 0.5 * (tau[0] + tau[1]);
            let radius = 0.5 * (tau[0] - tau[1]).abs();
            // The cone was taken at the friction angle of the old q (0 here).
            let sin_phi = dp.friction_angle(0.0).to_radians().sin();
            assert!(centre < 0.0, "compressive state expected, centre {centre}");
            assert!(
                (radius + sin_phi * centre).abs() <= 1e-9 * centre.abs(),
                "R = {radius}, −sin φ · centre = {}",
                -sin_phi * centre
            );
            checked += 1;
        }
        assert_eq!(checked, 200, "every trial lies outside the cone");
    }

    #[test]
    fn non_finite_trial_is_not_hidden() {
        let mut f = Matrix::<3>::identity();
        f[(0, 1)] = Real::NAN;
        for rule in [
            Plasticity::Snow(SNOW),
            Plasticity::DruckerPrager(sand(0.0, true)),
        ] {
            let mut state = PlasticState::default();
            let fe = rule.project(&f, &mut state, &elastic());
            let finite = fe.iter().all(|x| x.is_finite())
                && [state.jp, state.q, state.vc].iter().all(|x| x.is_finite());
            assert!(!finite, "{rule:?}");
        }
    }

    #[test]
    fn no_plasticity_is_identity() {
        let f = Matrix::<3>::identity() + Lcg(14).matrix::<3>(0.3);
        let mut state = PlasticState::default();
        assert_eq!(Plasticity::None.project(&f, &mut state, &elastic()), f);
        assert_eq!(state, PlasticState::default());
    }
}
