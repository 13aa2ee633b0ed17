//! Time-step control (DESIGN §6): `dt = min(C·Δx / max_p(|v_p| + c_p), viscous limit, dt_max)`.

use crate::error::{Location, SetupError, Violation};
use crate::math::Real;
use crate::parameters::{CFL, DT, DT_MAX};
use serde::{Deserialize, Serialize};

/// How the time step is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "mode", rename_all = "snake_case")]
pub enum TimeStepPolicy {
    /// Adaptive CFL-limited step, recomputed every step.
    Adaptive {
        /// CFL factor C (dimensionless, typically 0.2–0.5).
        cfl: Real,
        /// Upper bound on dt (s).
        dt_max: Real,
        /// Lower bound on dt (s): a smaller stable step is reported as an instability.
        dt_min: Real,
    },
    /// A fixed step (s). If it exceeds the stable bound at start, callers should warn.
    Fixed {
        /// The step (s).
        dt: Real,
    },
}

impl TimeStepPolicy {
    /// The policy in words, with `bound` naming the stable step bound the CFL factor scales
    /// (e.g. `dx / max(|v| + c)`).
    pub fn describe(&self, bound: &str) -> String {
        match *self {
            TimeStepPolicy::Fixed { dt } => format!("fixed dt = {dt:e} s"),
            TimeStepPolicy::Adaptive {
                cfl,
                dt_max,
                dt_min,
            } => format!("adaptive: dt = min({cfl}·{bound}, {dt_max:e} s), at least {dt_min:e} s"),
        }
    }

    /// Checks that a fixed dt is positive and finite, and that an adaptive policy has a positive
    /// finite CFL factor and `dt_max > 0` with `dt_max ≥ dt_min`.
    pub fn validate(&self) -> Result<(), SetupError> {
        let invalid = |name, value, reason| {
            Err(SetupError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        match *self {
            TimeStepPolicy::Fixed { dt } if !(dt > 0.0 && dt.is_finite()) => {
                invalid(DT, dt, "must be positive and finite")
            }
            TimeStepPolicy::Adaptive { cfl, .. } if !(cfl > 0.0 && cfl.is_finite()) => {
                invalid(CFL, cfl, "must be positive and finite")
            }
            TimeStepPolicy::Adaptive { dt_max, dt_min, .. }
                if !(dt_max > 0.0 && dt_max >= dt_min) =>
            {
                invalid(DT_MAX, dt_max, "must be positive and at least dt_min")
            }
            _ => Ok(()),
        }
    }
}

impl Default for TimeStepPolicy {
    fn default() -> Self {
        TimeStepPolicy::Adaptive {
            cfl: 0.4,
            dt_max: 1e-3,
            dt_min: 1e-12,
        }
    }
}

/// What to do when a guard check fails.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "action", rename_all = "snake_case")]
pub enum OnInstability {
    /// Stop with an [`crate::Instability`] error (the default).
    #[default]
    Abort,
    /// Retry the step with dt/2, at most `max_retries` times, then stop.
    Retry {
        /// Maximum number of halvings per step.
        max_retries: u32,
    },
}

/// The stable explicit step for spacing `dx` (m), fastest signal speed `max_signal` =
/// max_p(|v_p| + c_p) (m/s) and largest kinematic viscosity `max_nu` (m²/s) in `dim`
/// dimensions: `min(cfl·Δx/max_signal, Δx²/(2·dim·ν))`. Infinite when nothing limits it.
pub fn stable_dt(cfl: Real, dx: Real, max_signal: Real, max_nu: Real, dim: usize) -> Real {
    let wave = if max_signal > 0.0 {
        cfl * dx / max_signal
    } else {
        Real::INFINITY
    };
    let viscous = if max_nu > 0.0 {
        dx * dx / (2.0 * dim as Real * max_nu)
    } else {
        Real::INFINITY
    };
    wave.min(viscous)
}

/// Chooses dt under `policy` given the stable bound. Returns the step or the violation (a step
/// below `dt_min`, or a non-finite signal speed).
pub fn choose_dt(
    policy: &TimeStepPolicy,
    stable: Real,
) -> Result<Real, (Location, Violation, Real)> {
    if stable.is_nan() {
        return Err((
            Location::Global,
            Violation::NonFinite("signal speed"),
            stable,
        ));
    }
    match *policy {
        TimeStepPolicy::Fixed { dt } => Ok(dt),
        TimeStepPolicy::Adaptive { dt_max, dt_min, .. } => {
            let dt = stable.min(dt_max);
            if dt < dt_min {
                Err((Location::Global, Violation::TimeStepTooSmall, dt))
            } else {
                Ok(dt)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stable_dt_takes_the_tighter_limit() {
        // Wave limit 0.5·0.01/100 = 5e-5; viscous 1e-4/(2·2·1e-3) = 2.5e-2.
        assert!((stable_dt(0.5, 0.01, 100.0, 1e-3, 2) - 5e-5).abs() < 1e-18);
        // Viscous limit dominates: 1e-4/(2·3·1) = 1.6667e-5.
        assert!((stable_dt(0.5, 0.01, 1.0, 1.0, 3) - 1e-4 / 6.0).abs() < 1e-18);
        assert_eq!(stable_dt(0.5, 0.01, 0.0, 0.0, 2), Real::INFINITY);
        let policy = TimeStepPolicy::Adaptive {
            cfl: 0.5,
            dt_max: 1e-3,
            dt_min: 1e-9,
        };
        assert_eq!(choose_dt(&policy, Real::INFINITY), Ok(1e-3));
        assert_eq!(choose_dt(&policy, 2e-4), Ok(2e-4));
        assert!(matches!(
            choose_dt(&policy, 1e-10),
            Err((_, Violation::TimeStepTooSmall, _))
        ));
    }
}
