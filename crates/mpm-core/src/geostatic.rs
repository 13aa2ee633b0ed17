//! Geostatic initial stress: a body that starts in equilibrium under its own weight.
//!
//! At depth `d` below the body's top surface the vertical Cauchy stress is `σ_v = −ρ g d` and
//! the horizontal ones `σ_h = K₀ σ_v` (compression negative), with ρ the material's density and
//! g = |gravity|. The default `K₀ = ν/(1 − ν) = λ/(λ + 2μ)` is the ratio of a laterally
//! confined linear elastic column, the state gravity would load the body into.
//!
//! Particles carry no stress, only deformation: a solid's elastic deformation gradient F and a
//! fluid's volume ratio J. The stress is therefore realised as the deformation that carries it
//! in the material's own law: for a solid the diagonal F (principal axes along the coordinate
//! axes) whose Cauchy stress `τ(F)/det F` is the geostatic one, found by Newton's method; for a
//! Tait fluid (isotropic, K₀ = 1) the J with `p(J) = ρ g d`. The particle keeps its mass and
//! current volume: its reference volume becomes `V⁰ = V/det F`, so the density a scene gives is
//! the in-situ density of the stressed body (its unstressed density is `ρ det F`) and the
//! stress and the weight balance exactly.
//!
//! The depth is measured from the body's top surface, the highest particle's height plus half
//! its spacing `V^{1/D}` (for a lattice-filled box, the box top).

use crate::material::{FluidMaterial, PlasticState, SolidMaterial};
use crate::math::{Dim, DimOps, Matrix, Real, Vector};
use crate::{Material, Particles};
use std::fmt;
use std::ops::Range;

/// Why a geostatic state could not be set.
#[derive(Clone, Debug, PartialEq)]
pub enum GeostaticError {
    /// Gravity is zero or not parallel to a coordinate axis.
    Gravity,
    /// K₀ was given for a fluid (whose stress is isotropic, K₀ = 1).
    FluidK0(Real),
    /// A particle column the material needs (`F` or `J`) is missing.
    MissingColumn(&'static str),
    /// No deformation of the material's law carries the stress at particle `index` (depth in
    /// m): the stress is too large for the material's stiffness.
    NoState {
        /// The particle.
        index: usize,
        /// Its depth below the top surface (m).
        depth: Real,
    },
}

impl fmt::Display for GeostaticError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Gravity => {
                f.write_str("needs gravity along one coordinate axis (the vertical) and non-zero")
            }
            Self::FluidK0(k) => write!(
                f,
                "K0 = {k} was given for a fluid, whose stress is isotropic (K0 = 1)"
            ),
            Self::MissingColumn(c) => write!(f, "needs the particle column `{c}`"),
            Self::NoState { index, depth } => write!(
                f,
                "no elastic state of the material carries the geostatic stress at particle \
                 {index} ({depth:.4} m deep): the material is too soft for its weight"
            ),
        }
    }
}

impl std::error::Error for GeostaticError {}

/// The axis gravity `g` (m/s²) acts along, if it is non-zero and parallel to one axis.
pub fn vertical_axis<const D: usize>(g: &Vector<D>) -> Option<usize> {
    let axes: Vec<usize> = (0..D).filter(|&a| g[a] != 0.0).collect();
    match axes[..] {
        [a] if g[a].is_finite() => Some(a),
        _ => None,
    }
}

/// The default earth-pressure coefficient `K₀ = ν/(1 − ν) = λ/(λ + 2μ)` (dimensionless) of a
/// solid, from its Lamé parameters.
pub fn default_k0(solid: &SolidMaterial) -> Real {
    let l = solid.elastic.lame();
    l.lambda / (l.lambda + 2.0 * l.mu)
}

/// The volume ratio J (dimensionless) of a Tait fluid under pressure `p` (Pa):
/// `J = (1 + γ p/K)^{−1/γ}`, or `None` when `1 + γ p/K ≤ 0`.
pub fn fluid_jacobian(fluid: &FluidMaterial, p: Real) -> Option<Real> {
    let (k, g) = (fluid.eos.bulk_modulus, fluid.eos.gamma);
    let s = 1.0 + g * p / k;
    (s > 0.0).then(|| s.powf(-1.0 / g))
}

/// The diagonal elastic deformation gradient whose Cauchy stress `τ(F)/det F` is
/// `diag(sigma)` (Pa), by Newton's method on the stretches from the small-strain guess; `None`
/// when it does not converge to `10⁻¹⁰ (λ + 2μ)` in 50 iterations.
pub fn stretch_for_stress<const D: usize>(
    solid: &SolidMaterial,
    sigma: &Vector<D>,
) -> Option<Matrix<D>>
where
    Dim<D>: DimOps<D>,
{
    let state = PlasticState::default();
    let l = solid.elastic.lame();
    let stiff = l.lambda + 2.0 * l.mu;
    let residual = |s: &Vector<D>| -> Vector<D> {
        let f = Matrix::<D>::from_diagonal(s);
        let tau = solid.kirchhoff(&f, &state);
        let j = s.iter().product::<Real>();
        Vector::<D>::from_fn(|a, _| tau[(a, a)] / j - sigma[a])
    };
    // Small strain: σ = λ tr ε I + 2μ ε.
    let tr = sigma.sum() / (D as Real * l.lambda + 2.0 * l.mu);
    let mut s = Vector::<D>::from_fn(|a, _| 1.0 + (sigma[a] - l.lambda * tr) / (2.0 * l.mu));
    let h = 1e-7;
    for _ in 0..50 {
        let r = residual(&s);
        if !r.iter().all(|c| c.is_finite()) {
            return None;
        }
        if r.amax() <= 1e-10 * stiff {
            return Some(Matrix::<D>::from_diagonal(&s));
        }
        let mut jac = Matrix::<D>::zeros();
        for b in 0..D {
            let (mut up, mut down) = (s, s);
            up[b] += h;
            down[b] -= h;
            jac.set_column(b, &((residual(&up) - residual(&down)) / (2.0 * h)));
        }
        let step = Dim::<D>::inverse(&jac)? * r;
        s -= step;
        if s.iter().any(|&c| c <= 0.0) {
            return None;
        }
    }
    None
}

/// The height (m) along the unit vector `up` of the top surface of the particles in `range`:
/// the highest particle's height plus half its spacing `V⁰^{1/D}` (−∞ for an empty range).
pub fn top_height<const D: usize>(
    particles: &Particles<D>,
    range: Range<usize>,
    up: &Vector<D>,
) -> Real {
    range
        .map(|p| up.dot(&particles.x[p]) + 0.5 * particles.volume0[p].powf(1.0 / D as Real))
        .fold(Real::NEG_INFINITY, Real::max)
}

/// Sets the geostatic state of `material` on the particles in `range` under gravity `g`
/// (m/s²): F (solid, with `k0`, default [`default_k0`]) or J (fluid, `k0` must be `None`), and
/// `V⁰ ← V⁰/det F` (see the module docs).
pub fn set_geostatic<const D: usize>(
    particles: &mut Particles<D>,
    range: Range<usize>,
    material: &Material,
    g: &Vector<D>,
    k0: Option<Real>,
) -> Result<(), GeostaticError>
where
    Dim<D>: DimOps<D>,
{
    let axis = vertical_axis(g).ok_or(GeostaticError::Gravity)?;
    let up = -g[axis].signum();
    let gravity = g[axis].abs();
    let height = |p: usize| up * particles.x[p][axis];
    let top = top_height(particles, range.clone(), &(-g / gravity));
    let rho = material.density();
    for p in range {
        let depth = (top - height(p)).max(0.0);
        let sigma_v = rho * gravity * depth;
        let det = match material {
            Material::Solid(s) => {
                let k0 = k0.unwrap_or_else(|| default_k0(s));
                let sigma =
                    Vector::<D>::from_fn(|a, _| if a == axis { -sigma_v } else { -k0 * sigma_v });
                let f = stretch_for_stress(s, &sigma)
                    .ok_or(GeostaticError::NoState { index: p, depth })?;
                let column = particles
                    .def_grad
                    .as_mut()
                    .ok_or(GeostaticError::MissingColumn("F"))?;
                column[p] = f;
                Dim::<D>::det(&f)
            }
            Material::Fluid(fl) => {
                if let Some(k) = k0 {
                    return Err(GeostaticError::FluidK0(k));
                }
                let j = fluid_jacobian(fl, sigma_v)
                    .ok_or(GeostaticError::NoState { index: p, depth })?;
                let column = particles
                    .jacobian
                    .as_mut()
                    .ok_or(GeostaticError::MissingColumn("J"))?;
                column[p] = j;
                j
            }
        };
        particles.volume0[p] /= det;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{ElasticModel, Lame, Tait};
    use crate::{Columns, ParticleInit};

    fn solid(elastic: fn(Lame) -> ElasticModel) -> SolidMaterial {
        SolidMaterial {
            density: 1800.0,
            elastic: elastic(Lame::from_young_poisson(1e6, 0.3)),
            plasticity: Default::default(),
        }
    }

    #[test]
    fn stretches_carry_the_requested_stress_for_every_model() {
        let models: [fn(Lame) -> ElasticModel; 5] = [
            ElasticModel::NeoHookean,
            ElasticModel::FixedCorotated,
            ElasticModel::Hencky,
            ElasticModel::LinearElastic,
            ElasticModel::StableNeoHookean,
        ];
        for m in models {
            let s = solid(m);
            let sigma = Vector::<3>::new(-2e4, -5e4, -2e4);
            let f = stretch_for_stress(&s, &sigma).expect("a state");
            let j = Dim::<3>::det(&f);
            let cauchy = s.kirchhoff(&f, &PlasticState::default()) / j;
            for a in 0..3 {
                assert!(
                    (cauchy[(a, a)] - sigma[a]).abs() < 1e-9 * 1e6,
                    "{m:?}: {cauchy}"
                );
            }
            assert!(cauchy[(0, 1)].abs() < 1e-6 && f[(0, 1)] == 0.0);
            // Compressed in volume, most along the vertical.
            assert!(f[(1, 1)] < f[(0, 0)] && j < 1.0, "{m:?}: {f}");
        }
    }

    #[test]
    fn k0_default_is_the_confined_elastic_ratio() {
        // ν = 0.3: ν/(1 − ν) = 3/7.
        assert!((default_k0(&solid(ElasticModel::LinearElastic)) - 3.0 / 7.0).abs() < 1e-12);
    }

    fn water() -> FluidMaterial {
        FluidMaterial {
            density: 1000.0,
            eos: Tait {
                bulk_modulus: 1e6,
                gamma: 7.0,
            },
            viscosity: 0.0,
        }
    }

    #[test]
    fn fluid_jacobian_inverts_the_tait_law() {
        let fl = water();
        for p in [0.0, 1e3, 5e5] {
            let j = fluid_jacobian(&fl, p).expect("a state");
            assert!((fl.pressure(j) - p).abs() < 1e-9 * 1e6, "{p}");
        }
        assert_eq!(fluid_jacobian(&fl, -2e6), None);
    }

    #[test]
    fn gravity_must_be_along_one_axis() {
        assert_eq!(vertical_axis(&Vector::<2>::new(0.0, -9.81)), Some(1));
        assert_eq!(vertical_axis(&Vector::<3>::new(0.0, 0.0, 9.81)), Some(2));
        assert_eq!(vertical_axis(&Vector::<2>::new(1.0, -9.81)), None);
        assert_eq!(vertical_axis(&Vector::<2>::zeros()), None);
    }

    /// A column of 4 particles of spacing 0.1 m, top surface at y = 0.4 m.
    fn column(material: &Material) -> Particles<2> {
        let mut ps = Particles::<2>::new(Columns::for_materials(std::slice::from_ref(material)));
        for k in 0..4 {
            ps.push(ParticleInit {
                x: Vector::<2>::new(0.05, 0.05 + 0.1 * k as Real),
                v: Vector::<2>::zeros(),
                mass: material.density() * 0.01,
                volume0: 0.01,
                material: 0,
                affine: Matrix::<2>::zeros(),
            });
        }
        ps
    }

    #[test]
    fn a_solid_column_gets_rho_g_depth_and_keeps_its_mass_and_volume() {
        let s = solid(ElasticModel::Hencky);
        let m = Material::Solid(s.clone());
        let mut ps = column(&m);
        let g = Vector::<2>::new(0.0, -10.0);
        set_geostatic(&mut ps, 0..4, &m, &g, Some(0.5)).expect("set");
        let fs = ps.def_grad.as_ref().expect("F");
        for p in 0..4 {
            let depth = 0.4 - ps.x[p].y;
            let j = Dim::<2>::det(&fs[p]);
            let sigma = s.kirchhoff(&fs[p], &PlasticState::default()) / j;
            let sv = 1800.0 * 10.0 * depth;
            assert!((sigma[(1, 1)] + sv).abs() < 1e-3, "{p}: {sigma}");
            assert!((sigma[(0, 0)] + 0.5 * sv).abs() < 1e-3, "{p}: {sigma}");
            // Current volume V⁰ det F is the sampled 0.01 m²; the mass is unchanged.
            assert!((ps.volume0[p] * j - 0.01).abs() < 1e-15);
            assert_eq!(ps.mass[p], 18.0);
        }
    }

    #[test]
    fn a_fluid_column_gets_its_hydrostatic_j_and_rejects_k0() {
        let fl = water();
        let m = Material::Fluid(fl);
        let g = Vector::<2>::new(0.0, -10.0);
        let mut ps = column(&m);
        assert_eq!(
            set_geostatic(&mut ps, 0..4, &m, &g, Some(0.5)),
            Err(GeostaticError::FluidK0(0.5))
        );
        let mut ps = column(&m);
        set_geostatic(&mut ps, 0..4, &m, &g, None).expect("set");
        for p in 0..4 {
            let j = ps.jacobian.as_ref().expect("J")[p];
            let depth = 0.4 - ps.x[p].y;
            assert!((fl.pressure(j) - 1e4 * depth).abs() < 1e-6, "{p}");
        }
        assert_eq!(
            set_geostatic(&mut ps, 0..4, &m, &Vector::<2>::new(1.0, 1.0), None),
            Err(GeostaticError::Gravity)
        );
    }
}
