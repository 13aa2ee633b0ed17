//! Validation cases of the total-Lagrangian solvers (`mpm-tlmpm`, diq-mpm §3, §5.3–5.4):
//! Newton convergence on large-deformation steps ([`newton_convergence`]), colliding disks with
//! penalty contact ([`two_disks_contact`]), a block hanging under extreme gravity
//! ([`hanging_block_extreme`]), the 1D manufactured solution of the TLMPM literature
//! ([`mms_1d_tlmpm`]), the work–precision cantilever of implicit against explicit
//! ([`cantilever_tip_load`]).
//!
//! Run records follow the crate's conventions; `wall_s` is the time spent inside the solvers'
//! `step` (set-up and error sampling excluded). Units are SI; in 2D volumes are areas (m²) and
//! densities kg/m².

pub mod cantilever_tip_load;
pub mod hanging_block_extreme;
pub mod mms_1d_tlmpm;
pub mod newton_convergence;
pub mod two_disks_contact;

use crate::report::{progress, CaseResult, Mode, Run, Status};
use mpm_core::{
    Columns, Diagnostics, Dim, DimOps, GridSpec, Material, Matrix, ParticleInit, Particles, Real,
    Vector,
};
use mpm_tlmpm::{
    ContactStats, ExplicitTlmpm, ImplicitParams, ImplicitTlmpm, NewtonInfo, StepError, TlmpmParams,
};
use std::time::{Duration, Instant};

/// Name of the implicit TLMPM configuration.
pub const SOLVER_IMPLICIT: &str =
    "mpm-tlmpm implicit (backward Euler, Newton, sparse Cholesky; quadratic B-spline, APIC)";

/// Names of the TLMPM cases, in the order they run.
pub const NAMES: [&str; 5] = [
    newton_convergence::NAME,
    two_disks_contact::NAME,
    hanging_block_extreme::NAME,
    mms_1d_tlmpm::NAME,
    cantilever_tip_load::NAME,
];

/// Runs the named TLMPM case in `mode`; `None` for a name not in [`NAMES`].
pub fn run(name: &str, mode: Mode) -> Option<CaseResult> {
    Some(match name {
        newton_convergence::NAME => newton_convergence::case(mode),
        two_disks_contact::NAME => two_disks_contact::case(mode),
        hanging_block_extreme::NAME => hanging_block_extreme::case(mode),
        mms_1d_tlmpm::NAME => mms_1d_tlmpm::case(mode),
        cantilever_tip_load::NAME => cantilever_tip_load::case(mode),
        _ => return None,
    })
}

/// Either TLMPM solver, stepped and inspected the same way.
pub enum Tlmpm<const D: usize> {
    /// Symplectic Euler on the reference grid.
    Explicit(Box<ExplicitTlmpm<D>>),
    /// Backward Euler solved by Newton's method.
    Implicit(Box<ImplicitTlmpm<D>>),
}

/// What one TLMPM step reported.
pub struct StepReport {
    /// Contact statistics of the step (`None` without contact).
    pub contact: Option<ContactStats>,
    /// The Newton solve (`None` for the explicit solver).
    pub newton: Option<NewtonInfo>,
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
        Ok(match implicit {
            Some(ip) => Self::Implicit(Box::new(
                ImplicitTlmpm::new(spec, params, ip, materials, particles)
                    .map_err(|e| format!("set-up error: {e}"))?,
            )),
            None => Self::Explicit(Box::new(
                ExplicitTlmpm::new(spec, params, materials, particles)
                    .map_err(|e| format!("set-up error: {e}"))?,
            )),
        })
    }

    /// One step; the time spent in it is added to `wall`.
    pub fn step(&mut self, wall: &mut Duration) -> Result<StepReport, StepError> {
        let t = Instant::now();
        let r = match self {
            Self::Explicit(s) => s.step().map(|i| StepReport {
                contact: i.contact,
                newton: None,
            }),
            Self::Implicit(s) => s.step().map(|i| StepReport {
                contact: i.contact,
                newton: Some(i.newton),
            }),
        };
        *wall += t.elapsed();
        r
    }

    /// Particle state.
    pub fn particles(&self) -> &Particles<D> {
        match self {
            Self::Explicit(s) => s.particles(),
            Self::Implicit(s) => s.particles(),
        }
    }

    /// Particle velocities (m/s), writable; the next step transfers them to the grid.
    pub fn velocities_mut(&mut self) -> &mut [Vector<D>] {
        match self {
            Self::Explicit(s) => s.velocities_mut(),
            Self::Implicit(s) => s.velocities_mut(),
        }
    }

    /// Reference positions of the particles (m).
    pub fn reference_positions(&self) -> &[Vector<D>] {
        match self {
            Self::Explicit(s) => s.reference().positions(),
            Self::Implicit(s) => s.reference().positions(),
        }
    }

    /// Mass, momenta and energies.
    pub fn diagnostics(&self) -> Diagnostics<D> {
        match self {
            Self::Explicit(s) => s.diagnostics(),
            Self::Implicit(s) => s.diagnostics(),
        }
    }

    /// Simulation time (s).
    pub fn time(&self) -> Real {
        match self {
            Self::Explicit(s) => s.time(),
            Self::Implicit(s) => s.time(),
        }
    }

    /// Accepted steps.
    pub fn steps(&self) -> u64 {
        match self {
            Self::Explicit(s) => s.steps(),
            Self::Implicit(s) => s.steps(),
        }
    }

    /// `"explicit"` or `"implicit"`.
    pub fn label(&self) -> &'static str {
        match self {
            Self::Explicit(_) => "explicit",
            Self::Implicit(_) => "implicit",
        }
    }
}

/// Empty particle set with the deformation-gradient column (needed by TLMPM).
pub fn tl_particles<const D: usize>() -> Particles<D> {
    Particles::new(Columns {
        deformation_gradient: true,
        ..Columns::default()
    })
}

/// Appends the cell-centred lattice points of spacing `h` (m) in the box `[lo, hi]` (m) for
/// which `keep(X)` holds: density `rho` (kg/m^D), material 0, velocity `vel(X)` (m/s) and
/// affine column `grad(X)` (1/s).
pub fn add_lattice<const D: usize>(
    particles: &mut Particles<D>,
    (lo, hi): (Vector<D>, Vector<D>),
    (h, rho): (Real, Real),
    keep: impl Fn(&Vector<D>) -> bool,
    vel: impl Fn(&Vector<D>) -> (Vector<D>, Matrix<D>),
) {
    let vol = h.powi(D as i32);
    for x in super::lattice(&lo, &hi, h) {
        if keep(&x) {
            let (v, c) = vel(&x);
            particles.push(ParticleInit {
                x,
                v,
                mass: rho * vol,
                volume0: vol,
                material: 0,
                affine: c,
            });
        }
    }
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
        for name in NAMES {
            if !selected.is_empty() && !selected.split(',').any(|s| s == name) {
                continue;
            }
            let t = Instant::now();
            let c = run(name, mode).expect("known case");
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
