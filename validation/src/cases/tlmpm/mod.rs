//! Validation cases of the total-Lagrangian solvers (`mpm-tlmpm`, diq-mpm §3, §5.3–5.4):
//! Newton convergence on large-deformation steps ([`newton_convergence`]), colliding disks with
//! penalty contact ([`two_disks_contact`]) and their energy per transfer
//! ([`two_disks_energy`]), a block hanging under extreme gravity
//! ([`hanging_block_extreme`]), the 1D manufactured solution of the TLMPM literature
//! ([`mms_1d_tlmpm`]), the work–precision cantilever of implicit against explicit
//! ([`cantilever_tip_load`]), backward Euler against Newmark on it
//! ([`implicit_second_order`]) and Newton's stopping test on Cook's membrane
//! ([`cooks_membrane`]).
//!
//! Run records follow the crate's conventions; `wall_s` is the time spent inside the solvers'
//! `step` (set-up and error sampling excluded). Units are SI; in 2D volumes are areas (m²) and
//! densities kg/m².

pub mod cantilever_tip_load;
pub mod cooks_membrane;
pub mod hanging_block_extreme;
pub mod implicit_second_order;
pub mod mms_1d_tlmpm;
pub mod newton_convergence;
pub mod two_disks_contact;
pub mod two_disks_energy;

use crate::report::{progress, CaseResult, Run, Status};
use mpm_core::{
    Body, Columns, Dim, DimOps, GridSpec, Material, Particles, ParticlesBuilder, Real, StepError,
    StepInfo, Vector,
};
use mpm_tlmpm::{ImplicitParams, TlmpmParams, TotalLagrangian};
use std::time::{Duration, Instant};

/// Name of the implicit TLMPM configuration.
pub const SOLVER_IMPLICIT: &str =
    "mpm-tlmpm implicit (backward Euler, Newton, sparse Cholesky; quadratic B-spline, APIC)";

/// Either TLMPM solver behind the solver seam ([`TotalLagrangian`]), with a label for reports;
/// it dereferences to the solver.
pub struct Tlmpm<const D: usize> {
    solver: Box<dyn TotalLagrangian<D>>,
    label: &'static str,
}

impl<const D: usize> Tlmpm<D>
where
    Dim<D>: DimOps<D>,
{
    /// Builds the explicit solver, or the implicit one when `implicit` is `Some`.
    pub fn new(
        spec: GridSpec<D>,
        params: TlmpmParams<D>,
        implicit: Option<ImplicitParams>,
        materials: Vec<Material>,
        particles: Particles<D>,
    ) -> Result<Self, String> {
        let label = if implicit.is_some() {
            "implicit"
        } else {
            "explicit"
        };
        let solver = mpm_tlmpm::build(spec, params, implicit, materials, particles)
            .map_err(|e| format!("set-up error: {e}"))?;
        Ok(Self { solver, label })
    }

    /// One step; the time spent in it is added to `wall`.
    pub fn step(&mut self, wall: &mut Duration) -> Result<StepInfo, StepError> {
        let t = Instant::now();
        let r = self.solver.step();
        *wall += t.elapsed();
        r
    }

    /// `"explicit"` or `"implicit"`.
    pub fn label(&self) -> &'static str {
        self.label
    }
}

impl<const D: usize> std::ops::Deref for Tlmpm<D> {
    type Target = dyn TotalLagrangian<D>;

    fn deref(&self) -> &Self::Target {
        self.solver.as_ref()
    }
}

impl<const D: usize> std::ops::DerefMut for Tlmpm<D> {
    fn deref_mut(&mut self) -> &mut Self::Target {
        self.solver.as_mut()
    }
}

/// The count of event `name` in a step's events (e.g. `contact_pairs`).
pub fn event_count(info: &StepInfo, name: &str) -> u64 {
    info.events
        .iter()
        .filter(|(n, _)| *n == name)
        .map(|(_, c)| c)
        .sum()
}

/// The optional columns TLMPM needs: the deformation gradient.
pub fn tl_columns() -> Columns {
    Columns {
        deformation_gradient: true,
        ..Columns::default()
    }
}

/// The particles of `bodies` (see [`crate::cases::lattice`]) on `spec` with `materials`, with
/// the deformation-gradient column TLMPM needs.
pub fn tl_particles<const D: usize>(
    spec: &GridSpec<D>,
    materials: &[Material],
    bodies: &[Body<D>],
) -> Result<Particles<D>, String> {
    let mut builder = ParticlesBuilder::with_columns(spec, materials, tl_columns());
    for body in bodies {
        builder.add(body).map_err(|e| e.to_string())?;
    }
    Ok(builder.build())
}

/// A grid of spacing `dx` (m) whose nodes include `lo` and cover `[lo, hi]` (m) with `margin`
/// extra cells on every side.
pub fn grid_around<const D: usize>(
    (lo, hi): (Vector<D>, Vector<D>),
    dx: Real,
    margin: usize,
) -> GridSpec<D> {
    let m = Vector::<D>::from_element(margin as Real * dx);
    GridSpec::covering(lo - m, hi + m, dx)
}

/// Number of connected components of the particle graph in which two particles are linked
/// when their distance is below `link` (m). Uses a uniform bucket grid of cell size `link`.
pub fn components<const D: usize>(x: &[Vector<D>], link: Real) -> usize {
    use std::collections::HashMap;
    let key = |p: &Vector<D>| -> [i64; D] { std::array::from_fn(|a| (p[a] / link).floor() as i64) };
    let mut buckets: HashMap<[i64; D], Vec<usize>> = HashMap::new();
    for (i, p) in x.iter().enumerate() {
        buckets.entry(key(p)).or_default().push(i);
    }
    let mut parent: Vec<usize> = (0..x.len()).collect();
    fn find(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let offsets = 3usize.pow(D as u32);
    for (i, p) in x.iter().enumerate() {
        let k = key(p);
        for o in 0..offsets {
            let mut r = o;
            let nk: [i64; D] = std::array::from_fn(|a| {
                let d = (r % 3) as i64 - 1;
                r /= 3;
                k[a] + d
            });
            for &j in buckets.get(&nk).map_or(&[][..], Vec::as_slice) {
                if j > i && (x[j] - p).norm() < link {
                    let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                    parent[a] = b;
                }
            }
        }
    }
    (0..x.len()).filter(|&i| find(&mut parent, i) == i).count()
}

/// Runs `run(k)` for each entry `k` of `items` (labelled by `label(k)`), printing progress, and
/// collects the runs that succeeded; failures are returned as notes.
pub fn sweep_labelled<T: Copy>(
    name: &str,
    items: &[T],
    label: impl Fn(T) -> String,
    mut run: impl FnMut(T) -> Result<Run, String>,
) -> (Vec<Run>, Vec<String>) {
    let mut runs = Vec::new();
    let mut failures = Vec::new();
    for &k in items {
        let l = label(k);
        progress(name, &format!("{l} ..."));
        match run(k) {
            Ok(r) => {
                progress(
                    name,
                    &format!(
                        "{l}: error {:.4e}, {} particles, {} steps, {:.2} s",
                        r.error, r.particles, r.steps, r.wall_s
                    ),
                );
                runs.push(r);
            }
            Err(e) => {
                progress(name, &format!("{l}: FAILED: {e}"));
                failures.push(format!("{l} failed: {e}"));
            }
        }
    }
    (runs, failures)
}

/// Builds a [`CaseResult`] with solver `solver`: any failure makes the case fail; `ok` and
/// `notes` come from the case's verdict.
pub fn result(
    name: &str,
    solver: &str,
    description: String,
    runs: Vec<Run>,
    failures: Vec<String>,
    rate: Option<Real>,
    (ok, mut notes): (bool, String),
) -> CaseResult {
    for f in &failures {
        notes.push_str(&format!(" {f}."));
    }
    CaseResult {
        name: name.to_string(),
        solver: solver.to_string(),
        description,
        runs,
        rate,
        status: if ok && failures.is_empty() {
            Status::Pass
        } else {
            Status::Fail
        },
        notes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::Mode;

    #[test]
    fn components_of_two_separated_rows() {
        let mut x: Vec<Vector<2>> = (0..5).map(|i| Vector::<2>::new(i as Real, 0.0)).collect();
        assert_eq!(components(&x, 1.5), 1);
        x.extend((0..5).map(|i| Vector::<2>::new(i as Real + 10.0, 0.0)));
        assert_eq!(components(&x, 1.5), 2);
        assert_eq!(components(&x, 0.5), 10);
    }

    /// Runs the cases named in `TLMPM_CASES` (comma-separated; all when unset) in quick mode, or
    /// full mode when `TLMPM_FULL` is set, and prints their results:
    /// `cargo test --release -p mpm-validation tlmpm::tests::run_cases -- --ignored --nocapture`.
    #[test]
    #[ignore = "long-running; run on demand"]
    fn run_cases() {
        let mode = if std::env::var_os("TLMPM_FULL").is_some() {
            Mode::Full
        } else {
            Mode::Quick
        };
        let selected = std::env::var("TLMPM_CASES").unwrap_or_default();
        let tlmpm = crate::cases::names()
            .into_iter()
            .skip_while(|&n| n != newton_convergence::NAME);
        for name in tlmpm {
            if !selected.is_empty() && !selected.split(',').any(|s| s == name) {
                continue;
            }
            let t = Instant::now();
            let c = crate::cases::find(name).expect("known case").run(mode);
            println!(
                "{name}: {:?} in {:.1} s, rate {:?}\n  {}",
                c.status,
                t.elapsed().as_secs_f64(),
                c.rate,
                c.notes
            );
            for r in &c.runs {
                println!(
                    "  dx {:.4e} dt {:.3e} n {} steps {} wall {:.2} s error {:.4e} {:?}",
                    r.dx, r.dt, r.particles, r.steps, r.wall_s, r.error, r.extra
                );
            }
        }
    }
}
