//! What every solver's parameters share about advancing in time: gravity and its ramp, the
//! damping of the grid's nodal forces, the time-step policy and the reaction to a failed guard
//! check. Each solver's parameter struct holds one [`StepControl`] as its field `step`; a solver
//! that has no gravity ramp or no damping rejects them at set-up.

use crate::error::SetupError;
use crate::math::Vector;
use crate::parameters::GRAVITY_RAMP;
use crate::quasistatic::{Damping, GravityRamp};
use crate::timestep::{OnInstability, TimeStepPolicy};
use serde::{Deserialize, Serialize};

/// Gravity, time step, damping and the reaction to instability.
///
/// Serialised, the fields keep their own names (`gravity`, `gravity_ramp`, `damping`,
/// `time_step`, `on_instability`); a ramp that is `None` and damping that is off are left out
/// and read back as those defaults, so a struct that flattens this one into its own keys reads
/// and writes the same text as before it had a ramp or damping.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepControl<const D: usize> {
    /// Gravitational acceleration (m/s²).
    pub gravity: Vector<D>,
    /// Gravity ramp from zero at t = 0 (full gravity from the start when `None`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity_ramp: Option<GravityRamp>,
    /// Damping of the unbalanced nodal forces in the grid update (off by default): local
    /// factor α (dimensionless) and viscous rate c (1/s).
    #[serde(default, skip_serializing_if = "Damping::is_off")]
    pub damping: Damping,
    /// Time-step policy: a fixed dt (s) or an adaptive one with a CFL factor (dimensionless)
    /// and bounds `dt_min ≤ dt ≤ dt_max` (s). Each solver words its own stable bound, which
    /// the CFL factor scales.
    pub time_step: TimeStepPolicy,
    /// Reaction to a failed guard check or a failed solve: abort, or retry at dt/2.
    pub on_instability: OnInstability,
}

impl<const D: usize> Default for StepControl<D> {
    /// No gravity, no ramp, no damping, the default adaptive time step, abort on instability.
    fn default() -> Self {
        Self {
            gravity: Vector::<D>::zeros(),
            gravity_ramp: None,
            damping: Damping::default(),
            time_step: TimeStepPolicy::default(),
            on_instability: OnInstability::Abort,
        }
    }
}

impl<const D: usize> StepControl<D> {
    /// For a solver with constant gravity and no damping term: a gravity ramp is rejected with
    /// `no_ramp` as the reason, and damping that is on with `no_damping`.
    pub fn refuse_ramp_and_damping(
        &self,
        no_ramp: &'static str,
        no_damping: &'static str,
    ) -> Result<(), SetupError> {
        let refuse = |(name, value), reason| {
            Err(SetupError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        match (self.gravity_ramp, self.damping.first_on()) {
            (Some(r), _) => refuse((GRAVITY_RAMP, r.duration), no_ramp),
            (None, Some(on)) => refuse(on, no_damping),
            (None, None) => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_weightless_undamped_adaptive_and_aborts() {
        let s = StepControl::<3>::default();
        assert_eq!(s.gravity, Vector::<3>::zeros());
        assert!(s.gravity_ramp.is_none() && s.damping.is_off());
        assert_eq!(s.time_step, TimeStepPolicy::default());
        assert_eq!(s.on_instability, OnInstability::Abort);
    }
}
