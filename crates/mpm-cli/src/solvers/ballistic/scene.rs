//! The scene module of `solver = "ballistic"`: its table `[ballistic]` and the checks of the
//! common tables it needs (no boundaries: the particles bounce off the grid box).

use crate::scene::{BodyDef, Checker, Common, SolverTables};
use mpm_core::Columns;
use serde::{Deserialize, Serialize};

/// The ballistic solver's tables as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBallisticTables {
    ballistic: Option<RawBallistic>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBallistic {
    restitution: Option<f64>,
}

/// `[ballistic]`, every default filled in.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BallisticDef {
    /// Coefficient of restitution of the grid box's faces (dimensionless, in [0, 1]; 1 by
    /// default).
    pub restitution: f64,
}

/// The ballistic solver's own tables of a scene, resolved.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BallisticScene {
    /// `[ballistic]`, every default filled in.
    pub ballistic: BallisticDef,
}

impl SolverTables for BallisticScene {
    const TABLES: &'static [&'static str] = &["ballistic"];
    const KEYS: &'static [&'static str] = &[];
    const PRINTED_LAST: bool = false;
    const FIELDS: &'static [&'static str] = mpm_ballistic::fields::ALL;
    type Raw = RawBallisticTables;

    fn resolve(c: &mut Checker<'_>, raw: RawBallisticTables, common: Common<'_>) -> Self {
        c.not_applicable(
            "boundaries",
            !common.boundaries.is_empty(),
            "with solver \"ballistic\": its particles bounce off the faces of the grid box",
        );
        let restitution = raw.ballistic.and_then(|b| b.restitution).unwrap_or(1.0);
        c.num(
            "ballistic.restitution",
            restitution,
            |e| (0.0..=1.0).contains(&e),
            "must lie in [0, 1]",
        );
        BallisticScene {
            ballistic: BallisticDef { restitution },
        }
    }

    /// Positions, velocities, masses and volumes only: the flight needs no other column.
    fn columns(&self, _materials: Columns, _bodies: &[BodyDef]) -> Columns {
        Columns::default()
    }
}
