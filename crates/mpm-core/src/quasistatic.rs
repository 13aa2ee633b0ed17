//! What a run needs to reach a rest state: damping of the grid's nodal forces and a gravity
//! ramp (the geostatic initial stress is in [`crate::geostatic`]). Solvers apply them at their
//! grid update; a solver whose parameters leave them off runs no extra arithmetic.

use crate::error::Parameter;
use crate::math::{Real, Vector};
use crate::parameters::{GRAVITY_RAMP, LOCAL_DAMPING, VISCOUS_DAMPING};
use serde::{Deserialize, Serialize};

/// Damping of the unbalanced nodal force `f_i` (N) of a node of mass `m_i` (kg) whose velocity
/// before the update is `v_i` (m/s), for quasi-static runs:
///
/// * local non-viscous damping (Cundall; CB-Geo's `damping_factor`, Karamelo's local damping):
///   `f_i ← f_i − α |f_i| sign(v_i)`, with `sign` taken per component (0 for a zero
///   component) and `|f_i|` the Euclidean norm, so the damping force opposes the motion with a
///   fraction α of the force that drives it and vanishes where the node is in equilibrium;
/// * global viscous damping: a force `−c m_i v_i^{n+1}` on the new velocity, i.e.
///   `v^{n+1} = (v^n + Δt f_i/m_i)/(1 + c Δt)`, unconditionally stable and never reversing a
///   velocity.
///
/// Both default to 0 (off).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Damping {
    /// Local damping factor α (dimensionless, in [0, 1); CB-Geo and Karamelo use about 0.05).
    pub local: Real,
    /// Global viscous damping rate c (1/s, ≥ 0).
    pub viscous: Real,
}

impl Damping {
    /// Whether neither damping is on.
    pub fn is_off(&self) -> bool {
        self.local == 0.0 && self.viscous == 0.0
    }

    /// The parameter name and value of the first damping that is on (local before viscous),
    /// for a solver that has no damping to name what it rejects; `None` when both are off.
    pub fn first_on(&self) -> Option<(Parameter, Real)> {
        if self.local != 0.0 {
            Some((LOCAL_DAMPING, self.local))
        } else if self.viscous != 0.0 {
            Some((VISCOUS_DAMPING, self.viscous))
        } else {
            None
        }
    }

    /// The damped velocity (m/s) after a step of `dt` (s) of a node of mass `m` (kg) with
    /// velocity `v` (m/s) before the update and unbalanced force `f` (N).
    pub fn velocity<const D: usize>(
        &self,
        v: &Vector<D>,
        f: &Vector<D>,
        m: Real,
        dt: Real,
    ) -> Vector<D> {
        let mut force = *f;
        if self.local > 0.0 {
            let size = self.local * f.norm();
            force -= v.map(|c| {
                if c > 0.0 {
                    size
                } else if c < 0.0 {
                    -size
                } else {
                    0.0
                }
            });
        }
        (v + force * (dt / m)) / (1.0 + self.viscous * dt)
    }

    /// `None` when the damping is off, else the reason a value is out of range: the parameter
    /// name and the reason.
    pub fn invalid(&self) -> Option<(Parameter, Real, &'static str)> {
        if !(self.local.is_finite() && (0.0..1.0).contains(&self.local)) {
            Some((LOCAL_DAMPING, self.local, "must lie in [0, 1)"))
        } else if !(self.viscous.is_finite() && self.viscous >= 0.0) {
            Some((VISCOUS_DAMPING, self.viscous, "must be a finite rate >= 0"))
        } else {
            None
        }
    }
}

/// Gravity scaled linearly from zero at t = 0 to its full value at `t ≥ duration`, so a body
/// is loaded gradually instead of being dropped into its own weight.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GravityRamp {
    /// Ramp time T (s, > 0).
    pub duration: Real,
}

impl GravityRamp {
    /// `None` when the duration is a positive finite time, else the parameter, its value and
    /// the reason.
    pub fn invalid(&self) -> Option<(Parameter, Real, &'static str)> {
        (!(self.duration > 0.0 && self.duration.is_finite())).then_some((
            GRAVITY_RAMP,
            self.duration,
            "must be a positive finite time",
        ))
    }

    /// The gravity (m/s²) at time `t` (s): `g · min(t/T, 1)` (zero for t ≤ 0).
    pub fn gravity<const D: usize>(&self, full: &Vector<D>, t: Real) -> Vector<D> {
        if t >= self.duration {
            *full
        } else {
            full * (t.max(0.0) / self.duration)
        }
    }
}

/// The gravity (m/s²) at time `t` (s) under an optional ramp: `full` itself without one.
pub fn gravity_at<const D: usize>(
    full: &Vector<D>,
    ramp: Option<&GravityRamp>,
    t: Real,
) -> Vector<D> {
    ramp.map_or(*full, |r| r.gravity(full, t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_damping_opposes_the_motion_with_a_fraction_of_the_force() {
        let d = Damping {
            local: 0.1,
            viscous: 0.0,
        };
        let (m, dt) = (2.0, 0.5);
        let f = Vector::<2>::new(3.0, -4.0); // |f| = 5
        let v = Vector::<2>::new(1.0, 0.0);
        let out = d.velocity(&v, &f, m, dt);
        // x: 3 − 0.1·5·1 = 2.5 N; y: sign 0, no damping, −4 N.
        assert_eq!(out, Vector::<2>::new(1.0 + 2.5 * dt / m, -4.0 * dt / m));
        let v = Vector::<2>::new(-1.0, 2.0);
        let out = d.velocity(&v, &f, m, dt);
        assert_eq!(
            out,
            Vector::<2>::new(-1.0 + 3.5 * dt / m, 2.0 + (-4.0 - 0.5) * dt / m)
        );
        // No force, no damping force: a node in equilibrium keeps its velocity.
        assert_eq!(d.velocity(&v, &Vector::<2>::zeros(), m, dt), v);
    }

    #[test]
    fn viscous_damping_decays_a_free_velocity_without_reversing_it() {
        let d = Damping {
            local: 0.0,
            viscous: 4.0,
        };
        let v = Vector::<2>::new(1.0, -2.0);
        // c Δt = 4: the velocity is divided by 5.
        let out = d.velocity(&v, &Vector::<2>::zeros(), 1.0, 1.0);
        assert_eq!(out, v / 5.0);
        // Many small steps give e^{−c t}.
        let mut w = 1.0;
        for _ in 0..10_000 {
            w = d.velocity(&Vector::<1>::new(w), &Vector::<1>::zeros(), 1.0, 1e-4)[0];
        }
        assert!((w - (-4.0_f64).exp()).abs() < 1e-4 * (-4.0_f64).exp() * 10.0);
    }

    #[test]
    fn out_of_range_damping_is_named() {
        assert!(Damping::default().is_off() && Damping::default().invalid().is_none());
        for (d, name) in [
            ((1.0, 0.0), LOCAL_DAMPING),
            ((-0.1, 0.0), LOCAL_DAMPING),
            ((Real::NAN, 0.0), LOCAL_DAMPING),
            ((0.0, -1.0), VISCOUS_DAMPING),
            ((0.0, Real::INFINITY), VISCOUS_DAMPING),
        ] {
            let d = Damping {
                local: d.0,
                viscous: d.1,
            };
            assert_eq!(d.invalid().map(|e| e.0), Some(name));
        }
    }

    #[test]
    fn ramp_starts_at_zero_and_reaches_full_gravity_at_its_end() {
        let g = Vector::<2>::new(0.0, -9.81);
        let r = GravityRamp { duration: 0.5 };
        assert_eq!(r.gravity(&g, 0.0), Vector::<2>::zeros());
        assert_eq!(r.gravity(&g, 0.25), Vector::<2>::new(0.0, -4.905));
        assert_eq!(r.gravity(&g, 0.5), g);
        assert_eq!(r.gravity(&g, 7.0), g);
        assert_eq!(gravity_at(&g, None, 0.0), g);
        assert_eq!(gravity_at(&g, Some(&r), 0.1), r.gravity(&g, 0.1));
        assert!(r.invalid().is_none());
        for duration in [0.0, -1.0, Real::NAN, Real::INFINITY] {
            let bad = GravityRamp { duration }.invalid().map(|e| e.0);
            assert_eq!(bad, Some(GRAVITY_RAMP), "{duration}");
        }
    }
}
