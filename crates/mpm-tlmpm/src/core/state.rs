//! The TLMPM state beyond the particle columns ([`TlmpmState`]), its checkpoint column names,
//! reading it back from a checkpoint ([`state_from`]), and checkpoint/restore of the [`Core`].

use super::Core;
use crate::parameters::restore::{
    BASE_DEF_GRAD, NODE_VELOCITIES, REFERENCE_POSITIONS, RELATIVE_DEF_GRAD,
};
use crate::params::Transfer;
use crate::reference::{Constraints, ReferenceConfig};
use mpm_core::solver::{RestoreError, SolverState};
use mpm_core::{
    columns, Column, ColumnData, Dim, DimOps, Matrix, Parameter, Particles, Real, SetupError,
    Vector,
};

/// The solver state beyond the particle columns: what a checkpoint must hold, besides the
/// particles, for a resumed run to continue bitwise identically.
#[derive(Clone, Debug, PartialEq)]
pub struct TlmpmState<const D: usize> {
    /// Simulation time (s).
    pub time: Real,
    /// Accepted steps.
    pub steps: u64,
    /// Reference positions X_p (m): the initial positions, or those of the last A-ULMPM
    /// reference update.
    pub reference_positions: Vec<Vector<D>>,
    /// A-ULMPM only: `G_p = F_p^{(r,n)}`, the deformation gradients since the reference
    /// configuration (dimensionless).
    pub relative_def_grad: Option<Vec<Matrix<D>>>,
    /// A-ULMPM only: `B_p = F_p^{(0,r)}`, the base deformation gradients (dimensionless);
    /// `None` while they are the identity.
    pub base_def_grad: Option<Vec<Matrix<D>>>,
    /// Number of A-ULMPM reference updates so far.
    pub reference_updates: u64,
    /// [`Transfer::Persistent`] only: the node velocities of the last accepted step (m/s), one
    /// per active node of the reference grid in its numbering; `None` when the next step starts
    /// with a P2G transfer (before the first step, after a reference update or a change of the
    /// particle velocities).
    pub node_velocities: Option<Vec<Vector<D>>>,
}

/// Checkpoint column of the reference positions.
const REFERENCE_X: &str = "tlmpm_reference_x";
/// Checkpoint column of the A-ULMPM deformation gradients since the reference configuration.
const RELATIVE_F: &str = "tlmpm_relative_F";
/// Checkpoint column of the A-ULMPM base deformation gradients.
const BASE_F: &str = "tlmpm_base_F";
/// Checkpoint column of the persistent node velocities (one row per active reference node).
const NODE_V: &str = "tlmpm_node_v";
/// Checkpoint attribute of the number of A-ULMPM reference updates.
const ATTR_REFERENCE_UPDATES: &str = "tlmpm_reference_updates";

/// A set-up error met while restoring, as a restore error.
pub(crate) fn misfit(e: SetupError) -> RestoreError {
    RestoreError(format!("does not fit this scene: {e}"))
}

/// The [`TlmpmState`] stored in `state` for `n` particles.
pub(crate) fn state_from<const D: usize>(
    state: &SolverState,
    n: usize,
) -> Result<TlmpmState<D>, RestoreError> {
    let cols = &state.columns;
    let reference_positions = columns::f64_values(cols, REFERENCE_X, &[n, D])?
        .ok_or_else(|| format!("checkpoint has no field `{REFERENCE_X}` (not a TLMPM run?)"))?;
    let mats = |name| -> Result<Option<Vec<Matrix<D>>>, String> {
        Ok(columns::f64_values(cols, name, &[n, D, D])?.map(columns::to_matrices::<D>))
    };
    let node_velocities = match columns::find(cols, NODE_V).map(|c| &c.data) {
        None => None,
        Some(ColumnData::F64 { values, shape }) if shape.len() == 2 && shape[1] == D => {
            Some(columns::to_vectors::<D>(values))
        }
        Some(_) => return Err(format!("column `{NODE_V}` is not an [N, {D}] f64 column").into()),
    };
    Ok(TlmpmState {
        time: state.time,
        steps: state.steps,
        reference_positions: columns::to_vectors::<D>(reference_positions),
        relative_def_grad: mats(RELATIVE_F)?,
        base_def_grad: mats(BASE_F)?,
        reference_updates: state.attr(ATTR_REFERENCE_UPDATES).map_or(0, |v| v as u64),
        node_velocities,
    })
}

impl<const D: usize> Core<D>
where
    Dim<D>: DimOps<D>,
{
    /// The state beyond the particle columns (see [`TlmpmState`]).
    pub fn state(&self) -> TlmpmState<D> {
        let a = self.adaptive.as_ref();
        TlmpmState {
            time: self.time,
            steps: self.steps,
            reference_positions: self.reference.positions().to_vec(),
            relative_def_grad: a.map(|a| a.rel.clone()),
            base_def_grad: a.and_then(|a| a.base.clone()),
            reference_updates: a.map_or(0, |a| a.updates),
            node_velocities: (!self.node_velocity.is_empty()).then(|| self.node_velocity.clone()),
        }
    }

    /// The whole state as named columns: the particle columns, the reference positions, the
    /// A-ULMPM deformation gradients and the persistent node velocities where they exist, and
    /// the count of reference updates.
    pub fn checkpoint(&self) -> SolverState {
        let st = self.state();
        let mut out = SolverState::of_particles(&self.particles, self.time, self.steps);
        out.columns
            .push(Column::vectors(REFERENCE_X, "m", &st.reference_positions));
        if let Some(g) = &st.relative_def_grad {
            out.columns.push(Column::matrices(RELATIVE_F, "1", g));
        }
        if let Some(b) = &st.base_def_grad {
            out.columns.push(Column::matrices(BASE_F, "1", b));
        }
        if let Some(v) = &st.node_velocities {
            out.columns.push(Column::vectors(NODE_V, "m/s", v));
        }
        out.attrs.push((
            ATTR_REFERENCE_UPDATES.to_string(),
            st.reference_updates as f64,
        ));
        out
    }

    /// The particles stored in `state`, checked against this set-up's columns and materials.
    pub fn particles_from(&self, state: &SolverState) -> Result<Particles<D>, RestoreError> {
        Ok(columns::particles_from_columns(
            &state.columns,
            &self.particles,
            self.materials.len(),
        )?)
    }

    /// Restores a state saved by [`Core::state`] for the current particles: rebuilds the
    /// reference configuration at `state.reference_positions` and the Dirichlet numbering,
    /// and sets the A-ULMPM columns and the persistent node velocities (without them the next
    /// step starts with a P2G transfer).
    pub fn restore(&mut self, state: TlmpmState<D>) -> Result<(), SetupError> {
        let n = self.particles.len();
        let mismatch = |name: Parameter, len: usize| SetupError::InvalidParameter {
            name,
            value: len as Real,
            reason: "must have one entry per particle",
        };
        if state.reference_positions.len() != n {
            return Err(mismatch(
                REFERENCE_POSITIONS,
                state.reference_positions.len(),
            ));
        }
        match (&mut self.adaptive, state.relative_def_grad) {
            (Some(a), Some(rel)) => {
                if rel.len() != n {
                    return Err(mismatch(RELATIVE_DEF_GRAD, rel.len()));
                }
                if let Some(b) = state.base_def_grad.as_ref().filter(|b| b.len() != n) {
                    return Err(mismatch(BASE_DEF_GRAD, b.len()));
                }
                a.rel = rel;
                a.base = state.base_def_grad;
                a.updates = state.reference_updates;
                a.refresh_hardening(
                    &self.materials,
                    &self.particles.material,
                    self.particles.plastic.as_deref(),
                );
            }
            (None, None) => {}
            _ => {
                return Err(SetupError::InvalidSetting {
                    setting: crate::settings::REFERENCE_UPDATE.into(),
                    reason: "the saved state and the solver disagree on A-ULMPM".into(),
                })
            }
        }
        self.reference = ReferenceConfig::new(
            *self.reference.spec(),
            self.reference.kernel(),
            self.reference.clamp_planes(),
            &state.reference_positions,
            &self.particles.mass,
        )?;
        self.constraints = Constraints::new(&self.reference, &self.params.fixed);
        self.node_velocity.clear();
        if let Some(v) = state.node_velocities {
            if self.params.transfer != Transfer::Persistent {
                return Err(SetupError::InvalidSetting {
                    setting: crate::settings::TRANSFER.into(),
                    reason: "the saved state has persistent node velocities, the solver's \
                             transfer is not persistent"
                        .into(),
                });
            }
            if v.len() != self.reference.num_nodes() {
                return Err(SetupError::InvalidParameter {
                    name: NODE_VELOCITIES,
                    value: v.len() as Real,
                    reason: "must have one entry per active node of the reference grid",
                });
            }
            self.node_velocity = v;
        }
        self.time = state.time;
        self.steps = state.steps;
        Ok(())
    }
}
