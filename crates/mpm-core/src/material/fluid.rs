//! Weakly compressible Newtonian fluid.

use crate::math::{Matrix, Real};
use serde::{Deserialize, Serialize};

/// Tait equation of state `p = (K/γ) (J^{−γ} − 1)`, i.e. `p = B((ρ/ρ₀)^γ − 1)` with `B = K/γ`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tait {
    /// Bulk modulus K at rest (Pa).
    pub bulk_modulus: Real,
    /// Exponent γ (dimensionless, 7 for water).
    pub gamma: Real,
}

/// A weakly compressible fluid with Newtonian viscosity.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FluidMaterial {
    /// Rest density ρ₀ (kg/m^D).
    pub density: Real,
    /// Equation of state.
    pub eos: Tait,
    /// Dynamic viscosity μ (Pa·s).
    #[serde(default)]
    pub viscosity: Real,
}

impl FluidMaterial {
    /// Pressure p(J) = (K/γ)(J^{−γ} − 1) (Pa). Returns +∞ for J ≤ 0 (a collapsed or inverted
    /// fluid element has no meaningful pressure; the solver's guard rejects it) and NaN for NaN.
    /// Inline: P2G evaluates it once per fluid particle, a call from another crate otherwise.
    #[inline]
    pub fn pressure(&self, j: Real) -> Real {
        if j <= 0.0 {
            return Real::INFINITY;
        }
        let (k, g) = (self.eos.bulk_modulus, self.eos.gamma);
        (k / g) * (power(j, -g) - 1.0)
    }

    /// Stored energy per reference volume ψ(J) = −∫₁ᴶ p dJ' (J/m^D), so that p = −dψ/dJ.
    pub fn energy_density(&self, j: Real) -> Real {
        let (k, g) = (self.eos.bulk_modulus, self.eos.gamma);
        (k / g) * ((power(j, 1.0 - g) - 1.0) / (g - 1.0) + j - 1.0)
    }

    /// Sound speed `c = √(dp/dρ)` (m/s) at volume ratio `j`. With `ρ = ρ₀/J`,
    /// `p = (K/γ)((ρ/ρ₀)^γ − 1)` gives `dp/dρ = (K/ρ₀)(ρ/ρ₀)^{γ−1} = K J^{1−γ}/ρ₀ = K J^{−γ}/ρ`.
    /// Returns +∞ for J ≤ 0 (see [`Self::pressure`]).
    ///
    /// Inline: a per-particle loop that needs each particle's signal speed calls it once per
    /// fluid particle, and as a call across crates it makes that loop save and reload its live
    /// floating-point registers around it (measured on the explicit G2P).
    #[inline]
    pub fn sound_speed(&self, j: Real) -> Real {
        if j <= 0.0 {
            return Real::INFINITY;
        }
        let (k, g) = (self.eos.bulk_modulus, self.eos.gamma);
        (k * power(j, 1.0 - g) / self.density).sqrt()
    }

    /// Kirchhoff stress `τ = J σ` with `σ = −p I + μ (∇v + ∇vᵀ)` (Pa), given J and the velocity
    /// gradient ∇v (1/s). Non-finite for J ≤ 0 (the pressure is +∞ there).
    pub fn kirchhoff<const D: usize>(&self, j: Real, grad_v: &Matrix<D>) -> Matrix<D> {
        let viscous = (grad_v + grad_v.transpose()) * self.viscosity;
        (viscous - Matrix::<D>::identity() * self.pressure(j)) * j
    }
}

/// `j^e` for a volume ratio `j` (dimensionless). An integer exponent of magnitude at most 64
/// (γ = 7 gives −7 and −6) is formed by squaring and multiplying in a fixed order, a negative
/// one as the reciprocal of the positive power: relative difference from `powf` below
/// 8ε = 1.8e-15, the same bits on every machine, and cheaper than the library's `pow`, which
/// was about 6 % of a 2D explicit step with fluid. Any other exponent takes `powf`.
///
/// The exponent is an integer of magnitude at most 64 exactly when it is in that range and
/// converting it to an integer and back gives it again (NaN and ±∞ fail the range test, −0
/// passes as 0). `e.fract()` says the same but calls the library's `trunc` on the default
/// x86-64 target, which has no rounding instruction.
#[inline]
fn power(j: Real, e: Real) -> Real {
    if !(e.abs() <= 64.0 && (e as i32) as Real == e) {
        return j.powf(e);
    }
    let (mut n, mut base, mut acc) = (e.abs() as u32, j, 1.0);
    while n > 0 {
        if n & 1 == 1 {
            acc *= base;
        }
        n >>= 1;
        if n > 0 {
            base *= base;
        }
    }
    if e < 0.0 {
        1.0 / acc
    } else {
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn water(viscosity: Real) -> FluidMaterial {
        FluidMaterial {
            density: 1000.0,
            eos: Tait {
                bulk_modulus: 2.2e9,
                gamma: 7.0,
            },
            viscosity,
        }
    }

    #[test]
    fn pressure_vanishes_at_rest_and_grows_under_compression() {
        let w = water(0.0);
        assert_eq!(w.pressure(1.0), 0.0);
        assert!(w.pressure(0.99) > 0.0 && w.pressure(0.98) > w.pressure(0.99));
        assert!(w.pressure(1.01) < 0.0);
        // Bulk modulus at rest: −J dp/dJ = K.
        let h = 1e-6;
        let k = -(w.pressure(1.0 + h) - w.pressure(1.0 - h)) / (2.0 * h);
        assert!((k / w.eos.bulk_modulus - 1.0).abs() < 1e-8);
        // p = −dψ/dJ for the stored energy.
        for j in [0.9, 1.0, 1.1] {
            let dpsi = (w.energy_density(j + h) - w.energy_density(j - h)) / (2.0 * h);
            assert!((dpsi + w.pressure(j)).abs() <= 1e-6 * w.eos.bulk_modulus);
        }
        assert!(!w.pressure(0.0).is_finite() && !w.pressure(-0.5).is_finite());
    }

    /// Integer powers by multiplication agree with `powf` to 8ε relative over volume ratios from
    /// strong compression to strong expansion; zero and fractional exponents are exact or
    /// `powf` itself.
    #[test]
    fn integer_powers_match_powf() {
        let mut worst: Real = 0.0;
        for k in 0..=2000 {
            let j = 0.05 + 3.0 * k as Real / 2000.0;
            for e in [-7.0, -6.0, -1.0, 1.0, 2.0, 3.0, 6.0, 7.0, 15.0, -15.0] {
                let exact = j.powf(e);
                worst = worst.max(((power(j, e) - exact) / exact).abs());
            }
            assert_eq!(power(j, 0.0), 1.0);
            assert_eq!(power(j, -1.4).to_bits(), j.powf(-1.4).to_bits());
            assert_eq!(power(j, 70.0).to_bits(), j.powf(70.0).to_bits());
        }
        assert!(worst > 0.0 && worst < 8.0 * Real::EPSILON, "{worst:e}");
        // The edges of the integer range: ±64 by multiplication, anything beyond, fractional
        // or not a number by `powf` itself; a −0 exponent is the integer 0.
        for j in [0.5 as Real, 0.97, 1.03, 2.0] {
            for e in [64.0, -64.0] {
                let exact = j.powf(e);
                assert!(((power(j, e) - exact) / exact).abs() < 16.0 * Real::EPSILON);
            }
            for e in [64.5, -64.5, 65.0, -65.0, 0.5, -0.5, 1e300, Real::INFINITY] {
                assert_eq!(power(j, e).to_bits(), j.powf(e).to_bits(), "{j}^{e}");
            }
            assert!(power(j, Real::NAN).is_nan());
            assert_eq!(power(j, -0.0), 1.0);
        }
        // A collapsed and a NaN volume ratio give what `powf` gives.
        assert_eq!(power(0.0, -7.0), Real::INFINITY);
        assert!(power(Real::NAN, -7.0).is_nan());
    }

    #[test]
    fn sound_speed_is_sqrt_dp_drho() {
        let w = water(0.0);
        let rho0 = w.density;
        let p_of_rho = |rho: Real| w.pressure(rho0 / rho);
        for j in [0.95, 1.0, 1.05] {
            let (rho, h) = (rho0 / j, 1e-3);
            let dp_drho = (p_of_rho(rho + h) - p_of_rho(rho - h)) / (2.0 * h);
            let c = w.sound_speed(j);
            assert!(
                (c * c / dp_drho - 1.0).abs() < 1e-7,
                "{c} vs {}",
                dp_drho.sqrt()
            );
        }
        assert!((w.sound_speed(1.0) - (2.2e6 as Real).sqrt()).abs() < 1e-9);
        assert!(!w.sound_speed(0.0).is_finite());
    }

    fn kirchhoff_checks<const D: usize>() {
        let grad_v = Matrix::<D>::from_fn(|i, j| (i as Real + 1.0) * 0.3 - j as Real * 0.7);
        // At rest: zero stress whatever the viscosity.
        let rest = water(1e-3).kirchhoff::<D>(1.0, &Matrix::<D>::zeros());
        assert_eq!(rest, Matrix::<D>::zeros());
        // Without viscosity the stress is isotropic, τ = −J p I, whatever ∇v.
        let j = 0.98;
        let w = water(0.0);
        let tau = w.kirchhoff::<D>(j, &grad_v);
        let expected = Matrix::<D>::identity() * (-j * w.pressure(j));
        assert!((tau - expected).norm() <= 1e-12 * expected.norm());
        // With viscosity, τ = J (−p I + μ (∇v + ∇vᵀ)) (a soft, viscous fluid so that both parts
        // are of the same size).
        let mut syrup = water(2.0);
        syrup.eos.bulk_modulus = 10.0;
        let tau = syrup.kirchhoff::<D>(j, &grad_v);
        let sym = grad_v + grad_v.transpose();
        let expected = (sym * 2.0 - Matrix::<D>::identity() * syrup.pressure(j)) * j;
        assert!((tau - expected).norm() <= 1e-12 * expected.norm());
        assert_eq!(tau, tau.transpose());
    }

    #[test]
    fn kirchhoff_stress() {
        kirchhoff_checks::<2>();
        kirchhoff_checks::<3>();
    }
}
