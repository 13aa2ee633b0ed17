//! Material parameters that change with the particle state: porous material interactions
//! (multigrid paper §4.1) and the blending of miscible fluids by concentration (§4.4).
//!
//! A porous interaction scales one parameter of one material by a factor that depends on the
//! particle's effective volume fraction φ_eff: `factor = max(0, offset + slope · φ_eff^exponent)`.
//! The paper's examples are cohesion × √φ_eff (`offset = 0, slope = 1, exponent = 0.5`) and
//! E × (1 − 0.9 φ_eff) (`offset = 1, slope = −0.9, exponent = 1`); Eq. 18 of Tampubolon et al.
//! 2017, cohesion × (1 − φ), is `offset = 1, slope = −1, exponent = 1`.

use super::{FluidMaterial, Material, Plasticity};
use crate::math::Real;
use serde::{Deserialize, Serialize};

/// A material parameter that a porous interaction can scale.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Parameter {
    /// Young's modulus at fixed Poisson ratio (both Lamé parameters are scaled).
    YoungsModulus,
    /// Drucker–Prager cohesion.
    Cohesion,
    /// Drucker–Prager friction angle (h₀, h₁ and h₃ are scaled).
    FrictionAngle,
    /// Snow critical compression θ_c.
    CriticalCompression,
    /// Snow critical stretch θ_s.
    CriticalStretch,
    /// Snow hardening coefficient ξ.
    Hardening,
    /// Fluid dynamic viscosity μ.
    Viscosity,
    /// Fluid bulk modulus K.
    BulkModulus,
}

impl Parameter {
    /// Whether `material` has this parameter.
    pub fn applies_to(self, material: &Material) -> bool {
        match (self, material) {
            (Parameter::YoungsModulus, Material::Solid(_)) => true,
            (Parameter::Cohesion | Parameter::FrictionAngle, Material::Solid(s)) => {
                matches!(s.plasticity, Plasticity::DruckerPrager(_))
            }
            (
                Parameter::CriticalCompression | Parameter::CriticalStretch | Parameter::Hardening,
                Material::Solid(s),
            ) => matches!(s.plasticity, Plasticity::Snow(_)),
            (Parameter::Viscosity | Parameter::BulkModulus, Material::Fluid(_)) => true,
            _ => false,
        }
    }
}

/// `factor(φ) = max(0, offset + slope · φ^exponent)` (all dimensionless).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scaling {
    /// Factor at φ_eff = 0.
    pub offset: Real,
    /// Change of the factor between φ_eff = 0 and φ_eff = 1.
    pub slope: Real,
    /// Exponent applied to φ_eff (> 0).
    pub exponent: Real,
}

impl Scaling {
    /// The factor at effective volume fraction `phi` ∈ [0, 1].
    pub fn factor(&self, phi: Real) -> Real {
        (self.offset + self.slope * phi.max(0.0).powf(self.exponent)).max(0.0)
    }
}

/// Porous material interaction: `parameter` of material `material` is multiplied by
/// `scaling.factor(φ_eff)` for every particle of that material.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Interaction {
    /// Index into the material table.
    pub material: u32,
    /// Which parameter changes.
    pub parameter: Parameter,
    /// How it changes with φ_eff.
    pub scaling: Scaling,
}

impl Material {
    /// A copy with `parameter` multiplied by `factor`. Parameters the material does not have
    /// are left alone (a scene is checked with [`Parameter::applies_to`] before it runs).
    pub fn scaled(&self, parameter: Parameter, factor: Real) -> Material {
        let mut m = self.clone();
        match (&mut m, parameter) {
            (Material::Solid(s), Parameter::YoungsModulus) => s.elastic = s.elastic.scaled(factor),
            (Material::Solid(s), p) => match (&mut s.plasticity, p) {
                (Plasticity::DruckerPrager(dp), Parameter::Cohesion) => dp.cohesion *= factor,
                (Plasticity::DruckerPrager(dp), Parameter::FrictionAngle) => {
                    for k in [0, 1, 3] {
                        dp.h[k] *= factor;
                    }
                }
                (Plasticity::Snow(sn), Parameter::CriticalCompression) => sn.theta_c *= factor,
                (Plasticity::Snow(sn), Parameter::CriticalStretch) => sn.theta_s *= factor,
                (Plasticity::Snow(sn), Parameter::Hardening) => sn.hardening *= factor,
                _ => {}
            },
            (Material::Fluid(f), Parameter::Viscosity) => f.viscosity *= factor,
            (Material::Fluid(f), Parameter::BulkModulus) => f.eos.bulk_modulus *= factor,
            (Material::Fluid(_), _) => {}
        }
        m
    }
}

impl FluidMaterial {
    /// The mixture with volume fraction `alpha` ∈ [0, 1] of `other`: rest density, viscosity,
    /// bulk modulus and Tait exponent are blended linearly (Yan et al. 2018 blend mass and rest
    /// density this way; the multigrid paper §4.4 adds the viscosity blend).
    pub fn blend(&self, other: &FluidMaterial, alpha: Real) -> FluidMaterial {
        let a = alpha.clamp(0.0, 1.0);
        let lerp = |x: Real, y: Real| x + a * (y - x);
        let mut m = *self;
        m.density = lerp(self.density, other.density);
        m.viscosity = lerp(self.viscosity, other.viscosity);
        m.eos.bulk_modulus = lerp(self.eos.bulk_modulus, other.eos.bulk_modulus);
        m.eos.gamma = lerp(self.eos.gamma, other.eos.gamma);
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{DruckerPrager, ElasticModel, Lame, SolidMaterial, Tait};

    fn sand() -> Material {
        Material::Solid(SolidMaterial {
            density: 1600.0,
            elastic: ElasticModel::Hencky(Lame {
                mu: 1e6,
                lambda: 2e6,
            }),
            plasticity: Plasticity::DruckerPrager(DruckerPrager {
                h: [35.0, 9.0, 0.2, 10.0],
                cohesion: 0.02,
                volume_correction: true,
            }),
        })
    }

    #[test]
    fn paper_examples_of_scaling() {
        let sqrt = Scaling {
            offset: 0.0,
            slope: 1.0,
            exponent: 0.5,
        };
        assert_eq!(sqrt.factor(0.25), 0.5);
        assert_eq!(sqrt.factor(0.0), 0.0);
        let soften = Scaling {
            offset: 1.0,
            slope: -0.9,
            exponent: 1.0,
        };
        assert!((soften.factor(1.0) - 0.1).abs() < 1e-15);
        assert_eq!(soften.factor(0.0), 1.0);
        // Never negative.
        let cut = Scaling {
            offset: 1.0,
            slope: -2.0,
            exponent: 1.0,
        };
        assert_eq!(cut.factor(1.0), 0.0);
    }

    #[test]
    fn scaling_changes_only_the_named_parameter() {
        let s = sand();
        let Material::Solid(base) = &s else { panic!() };
        let Material::Solid(c) = s.scaled(Parameter::Cohesion, 0.5) else {
            panic!()
        };
        let (Plasticity::DruckerPrager(dp0), Plasticity::DruckerPrager(dp)) =
            (base.plasticity, c.plasticity)
        else {
            panic!()
        };
        assert_eq!(dp.cohesion, 0.01);
        assert_eq!(dp.h, dp0.h);
        assert_eq!(c.elastic, base.elastic);
        let Material::Solid(e) = s.scaled(Parameter::YoungsModulus, 0.1) else {
            panic!()
        };
        let (l0, l) = (base.elastic.lame(), e.elastic.lame());
        assert!((l.mu / l0.mu - 0.1).abs() < 1e-15 && (l.lambda / l0.lambda - 0.1).abs() < 1e-15);
        // A parameter the material lacks changes nothing.
        assert_eq!(s.scaled(Parameter::Viscosity, 3.0), s);
        assert!(!Parameter::Viscosity.applies_to(&s) && Parameter::Cohesion.applies_to(&s));
    }

    #[test]
    fn blend_is_linear_in_concentration() {
        let a = FluidMaterial {
            density: 1000.0,
            eos: Tait {
                bulk_modulus: 1e5,
                gamma: 7.0,
            },
            viscosity: 0.0,
        };
        let b = FluidMaterial {
            density: 400.0,
            viscosity: 2.0,
            ..a
        };
        assert_eq!(a.blend(&b, 0.0), a);
        assert_eq!(a.blend(&b, 1.0), b);
        let m = a.blend(&b, 0.25);
        assert_eq!(m.density, 850.0);
        assert_eq!(m.viscosity, 0.5);
    }
}
