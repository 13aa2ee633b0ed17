//! Set-up checks of the step control: DIQ has no gravity ramp and no damping, and its
//! parameters serialise under the keys they had before the step control was shared.

use super::*;
use mpm_core::parameters::{GRAVITY_RAMP, LOCAL_DAMPING, VISCOUS_DAMPING};
use mpm_core::quasistatic::{Damping, GravityRamp};
use mpm_core::{Parameter, SetupError};

/// Builds the 2D column of [`column`] with the step control changed by `edit`.
fn column_with(edit: impl FnOnce(&mut StepControl<2>)) -> Result<DiqFluid<2>, SetupError> {
    let n = 8;
    let dx = 1.0 / n as Real;
    let mut p = params::<2>(1e-2, true);
    edit(&mut p.step);
    let spec = grid([n, n], dx);
    DiqFluid::new(
        spec,
        p,
        vec![water()],
        walls(),
        block(&spec, [0.0, 0.0], [1.0, 0.5], |_| Vector::<2>::zeros()),
    )
}

/// The name, value and reason of an `InvalidParameter`; panics on anything else.
fn rejected(r: Result<DiqFluid<2>, SetupError>) -> (Parameter, Real, &'static str) {
    match r {
        Err(SetupError::InvalidParameter {
            name,
            value,
            reason,
        }) => (name, value, reason),
        Err(other) => panic!("expected an invalid parameter, got {other}"),
        Ok(_) => panic!("expected an invalid parameter, the set-up was accepted"),
    }
}

#[test]
fn a_gravity_ramp_or_damping_is_rejected() {
    assert!(column_with(|_| {}).is_ok());
    let ramp = column_with(|s| s.gravity_ramp = Some(GravityRamp { duration: 0.5 }));
    assert_eq!(
        rejected(ramp),
        (GRAVITY_RAMP, 0.5, "DIQ has no gravity ramp")
    );
    let local = column_with(|s| {
        s.damping = Damping {
            local: 0.05,
            viscous: 0.0,
        }
    });
    assert_eq!(rejected(local), (LOCAL_DAMPING, 0.05, "DIQ has no damping"));
    let viscous = column_with(|s| {
        s.damping = Damping {
            local: 0.0,
            viscous: 2.0,
        }
    });
    assert_eq!(
        rejected(viscous),
        (VISCOUS_DAMPING, 2.0, "DIQ has no damping")
    );
}

#[test]
fn params_serialise_under_their_old_keys() {
    let p = DiqParams::<2>::default();
    let json = serde_json::to_value(&p).expect("serialised");
    let mut keys: Vec<&str> = json
        .as_object()
        .expect("an object")
        .keys()
        .map(String::as_str)
        .collect();
    keys.sort_unstable();
    assert_eq!(
        keys,
        [
            "gradient_quadrature",
            "gravity",
            "on_instability",
            "position_correction",
            "pressure",
            "time_step"
        ]
    );
    assert_eq!(
        json["gravity"],
        serde_json::to_value(p.step.gravity).unwrap()
    );
    let back: DiqParams<2> = serde_json::from_value(json).expect("read back");
    assert_eq!(back, p);
}
