//! Newton's method with a capped backtracking line search on an incremental potential.

use crate::error::NewtonError;
use crate::params::{LineSearch, NewtonParams, SpdProjection};
use mpm_core::{Real, Vector};
use serde::Serialize;

/// Relative size of an energy change below which energies are compared at round-off level; the
/// line search then accepts a step on a decrease of the residual instead.
const ENERGY_ROUNDOFF: Real = 1e-10;

/// Most line-search halvings of a chord iteration: a chord direction that needs more is a poor
/// one, and a fresh tangent is cheaper than further energy evaluations.
const CHORD_HALVINGS: u32 = 2;

/// What one Newton solve did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct NewtonInfo {
    /// Newton iterations (linear solves accepted).
    pub iterations: u32,
    /// Residual norms `‖∇E‖₂` (N): the initial guess first, then one per iteration.
    pub residuals: Vec<Real>,
    /// Tolerance the last residual met (N): `max(abs_tol + rel_tol · f, roundoff · s)` with the
    /// force scale `f` and the rounding scale `s` of the last iterate ([`NewtonParams`]).
    pub tolerance: Real,
    /// Line-search step halvings over all iterations.
    pub halvings: u32,
    /// CG iterations over all Newton iterations (0 with the Cholesky solver).
    pub linear_iterations: u32,
    /// Iterations that used the SPD-projected tangent.
    pub projected_iterations: u32,
    /// Chord iterations: iterations whose direction reused the last factorised tangent
    /// ([`NewtonParams::chord`]); included in `iterations`.
    pub chord_iterations: u32,
}

/// Least-squares estimate of the convergence order `q` in `r_{k+1} ≈ C r_k^q` from consecutive
/// residuals (at least three, all positive); `None` otherwise.
pub fn fitted_order(residuals: &[Real]) -> Option<Real> {
    if residuals.len() < 3 || residuals.iter().any(|&r| r <= 0.0 || !r.is_finite()) {
        return None;
    }
    let pts: Vec<(Real, Real)> = residuals
        .windows(2)
        .map(|w| (w[0].ln(), w[1].ln()))
        .collect();
    let n = pts.len() as Real;
    let (mx, my) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let (sxy, sxx) = pts.iter().fold((0.0, 0.0), |(a, b), (x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The sizes (N) of the forces that make up a residual `∇E = f_inertial − f_int − f_ext`, as
/// 2-norms over the free components of the nodes, and the rounding scale of its evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Forces {
    /// `‖Σ |terms|‖₂` (N): the magnitude of every term before cancellation, which bounds the
    /// rounding error of the residual.
    pub rounding: Real,
    /// `‖f_inertial‖₂ = ‖M (u − û) c/Δt²‖₂` (N).
    pub inertial: Real,
    /// `‖f_int‖₂` (N).
    pub internal: Real,
    /// `‖f_ext‖₂` (N).
    pub external: Real,
}

impl Forces {
    /// The force scale the residual is measured against (N): the largest of the inertial,
    /// internal and external forces.
    pub fn scale(&self) -> Real {
        self.inertial.max(self.internal).max(self.external)
    }

    /// The residual norm (N) below which a solve counts as converged:
    /// `max(abs_tol + rel_tol · scale, roundoff · rounding)`.
    pub fn tolerance(&self, params: &NewtonParams) -> Real {
        (params.abs_tol + params.rel_tol * self.scale()).max(params.roundoff * self.rounding)
    }
}

/// The tangent was not positive definite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Indefinite;

/// A smooth potential over node vectors, with a Newton direction.
pub(crate) trait Objective<const D: usize> {
    /// `E(u)` (J) and the magnitude scale of its terms (J), `None` when not finite.
    fn energy(&mut self, u: &[Vector<D>]) -> Option<(Real, Real)>;
    /// `∇E(u)` (N) into `out`, zero on prescribed components; returns the sizes of its forces.
    fn gradient(&mut self, u: &[Vector<D>], out: &mut [Vector<D>]) -> Forces;
    /// Solves `H(u) d = −r`, zero on prescribed components, with the SPD-projected tangent when
    /// `project`; in full precision when `exact`, else possibly with a single-precision
    /// factorisation ([`NewtonParams::single_precision`]). Returns the linear iterations, or
    /// `Ok(Err(Indefinite))` when the tangent is not positive definite.
    fn direction(
        &mut self,
        u: &[Vector<D>],
        r: &[Vector<D>],
        d: &mut [Vector<D>],
        project: bool,
        exact: bool,
    ) -> Result<Result<u32, Indefinite>, String>;
    /// A chord direction: solves `H(u') d = −r` with the factor of the last tangent
    /// [`Self::direction`] factorised, at an earlier iterate `u'`. `None` when there is no such
    /// factor (the default: an objective without a reusable factorisation).
    fn chord_direction(&mut self, _r: &[Vector<D>], _d: &mut [Vector<D>]) -> Option<()> {
        None
    }
}

/// Scratch vectors of the Newton loop.
#[derive(Clone, Debug, Default)]
pub(crate) struct NewtonWork<const D: usize> {
    r: Vec<Vector<D>>,
    d: Vec<Vector<D>>,
    trial: Vec<Vector<D>>,
    r_trial: Vec<Vector<D>>,
}

fn dot<const D: usize>(a: &[Vector<D>], b: &[Vector<D>]) -> Real {
    a.iter().zip(b).map(|(x, y)| x.dot(y)).sum()
}

/// Minimises `obj` from `u` (overwritten with the solution).
pub(crate) fn minimize<const D: usize>(
    obj: &mut impl Objective<D>,
    params: &NewtonParams,
    u: &mut Vec<Vector<D>>,
    w: &mut NewtonWork<D>,
) -> Result<NewtonInfo, NewtonError> {
    let n = u.len();
    for v in [&mut w.r, &mut w.d, &mut w.trial, &mut w.r_trial] {
        v.clear();
        v.resize(n, Vector::<D>::zeros());
    }
    let mut info = NewtonInfo::default();
    let Some(mut energy) = obj.energy(u) else {
        return Err(NewtonError::NonFiniteStart);
    };
    let mut tolerance = obj.gradient(u, &mut w.r).tolerance(params);
    let mut residual = dot(&w.r, &w.r).sqrt();
    let initial = residual;
    info.tolerance = tolerance;
    info.residuals.push(residual);
    let ls = params.line_search;
    let mut iteration = 0;
    let mut chord = false;
    let mut exact = !params.single_precision;
    loop {
        if residual <= tolerance {
            return Ok(info);
        }
        if iteration == params.max_iterations {
            return Err(NewtonError::NotConverged {
                iterations: iteration,
                residual,
                initial,
                tolerance,
            });
        }
        // Newton direction, with the projected tangent when the exact one fails; a chord
        // direction when the last iteration contracted enough (`NewtonParams::chord`).
        let mut accepted = None;
        if chord {
            accepted = obj.chord_direction(&w.r, &mut w.d).and_then(|()| {
                let capped = LineSearch {
                    max_halvings: ls.max_halvings.min(CHORD_HALVINGS),
                    ..ls
                };
                line_search(obj, u, w, capped, energy, residual, &mut info)
            });
        }
        let chorded = accepted.is_some();
        let (e, trial_forces) = match accepted {
            Some(a) => a,
            None => {
                let mut project = params.projection == SpdProjection::Always;
                loop {
                    let outcome = obj
                        .direction(u, &w.r, &mut w.d, project, exact)
                        .map_err(|message| NewtonError::LinearSolver { iteration, message })?;
                    if let Ok(lin) = outcome {
                        info.linear_iterations += lin;
                        if dot(&w.r, &w.d) < 0.0 {
                            break;
                        }
                        if !exact {
                            // An f32 factor too coarse for a descent direction: f64 before
                            // the tangent counts as indefinite.
                            exact = true;
                            continue;
                        }
                    }
                    if project || params.projection == SpdProjection::Never {
                        return Err(NewtonError::IndefiniteTangent { iteration });
                    }
                    project = true;
                }
                if project {
                    info.projected_iterations += 1;
                }
                line_search(obj, u, w, ls, energy, residual, &mut info).ok_or(
                    NewtonError::LineSearchFailed {
                        iteration,
                        halvings: ls.max_halvings,
                        residual,
                    },
                )?
            }
        };
        std::mem::swap(u, &mut w.trial);
        energy = e;
        let forces = match trial_forces {
            Some(f) => {
                std::mem::swap(&mut w.r, &mut w.r_trial);
                f
            }
            None => obj.gradient(u, &mut w.r),
        };
        tolerance = forces.tolerance(params);
        info.tolerance = tolerance;
        let previous = residual;
        residual = dot(&w.r, &w.r).sqrt();
        iteration += 1;
        info.iterations = iteration;
        info.chord_iterations += u32::from(chorded);
        info.residuals.push(residual);
        let contracted = residual <= NewtonParams::CHORD_CONTRACTION * previous;
        chord = params.chord && contracted;
        exact |= !contracted;
    }
}

/// Capped backtracking (Armijo) line search along `w.d` from `u`, whose energy is `energy` and
/// residual norm `residual`; the accepted point goes to `w.trial`. Returns its energy and, when
/// `w.r_trial` holds its gradient, the sizes of that gradient's forces, or `None` when every
/// step length failed.
fn line_search<const D: usize>(
    obj: &mut impl Objective<D>,
    u: &[Vector<D>],
    w: &mut NewtonWork<D>,
    ls: LineSearch,
    energy: (Real, Real),
    residual: Real,
    info: &mut NewtonInfo,
) -> Option<((Real, Real), Option<Forces>)> {
    let slope = dot(&w.r, &w.d);
    if slope >= 0.0 {
        return None;
    }
    let mut alpha = 1.0;
    for _ in 0..=ls.max_halvings {
        for ((t, x), d) in w.trial.iter_mut().zip(u.iter()).zip(&w.d) {
            *t = x + d * alpha;
        }
        if let Some(e) = obj.energy(&w.trial) {
            if e.0 <= energy.0 + ls.armijo * alpha * slope {
                return Some((e, None));
            } else if (alpha * slope).abs() <= ENERGY_ROUNDOFF * e.1.max(energy.1) {
                let forces = obj.gradient(&w.trial, &mut w.r_trial);
                if dot(&w.r_trial, &w.r_trial).sqrt() < residual {
                    return Some((e, Some(forces)));
                }
            }
        }
        alpha *= 0.5;
        info.halvings += 1;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `E(u) = Σ (e^y − y)` with `y = u − c` per component: convex, minimum at `u = c`, and the
    /// full Newton step overshoots far from it.
    struct Convex {
        c: Vec<Vector<2>>,
    }

    impl Objective<2> for Convex {
        fn energy(&mut self, u: &[Vector<2>]) -> Option<(Real, Real)> {
            let e: Real = u
                .iter()
                .zip(&self.c)
                .map(|(x, c)| (x - c).map(|y| y.exp() - y).sum())
                .sum();
            e.is_finite().then_some((e, e))
        }
        fn gradient(&mut self, u: &[Vector<2>], out: &mut [Vector<2>]) -> Forces {
            for ((o, x), c) in out.iter_mut().zip(u).zip(&self.c) {
                *o = (x - c).map(|y| y.exp() - 1.0);
            }
            Forces {
                rounding: 1.0,
                ..Forces::default()
            }
        }
        fn direction(
            &mut self,
            u: &[Vector<2>],
            r: &[Vector<2>],
            d: &mut [Vector<2>],
            _project: bool,
            _exact: bool,
        ) -> Result<Result<u32, Indefinite>, String> {
            for (((d, x), c), r) in d.iter_mut().zip(u).zip(&self.c).zip(r) {
                *d = -r.component_div(&(x - c).map(Real::exp));
            }
            Ok(Ok(0))
        }
    }

    #[test]
    fn converges_quadratically_with_line_search() {
        let mut obj = Convex {
            c: (0..10).map(|i| Vector::<2>::new(i as Real, -3.0)).collect(),
        };
        let mut u = vec![Vector::<2>::zeros(); 10];
        let params = NewtonParams {
            abs_tol: 1e-13,
            rel_tol: 0.0,
            ..Default::default()
        };
        let info = minimize(&mut obj, &params, &mut u, &mut NewtonWork::default()).unwrap();
        assert!(info.halvings > 0, "far start needs damping");
        for (x, c) in u.iter().zip(&obj.c) {
            assert!((x - c).norm() < 1e-12);
        }
        let r = &info.residuals;
        let tail = &r[r.len() - 4..r.len() - 1];
        assert!(fitted_order(tail).unwrap() > 1.8, "{r:?}");
    }

    #[test]
    fn fitted_order_of_exact_sequences() {
        let quadratic: Vec<Real> = (0..5).map(|k| 10f64.powi(-(1 << k))).collect();
        assert!((fitted_order(&quadratic).unwrap() - 2.0).abs() < 1e-12);
        let linear: Vec<Real> = (0..5).map(|k| 0.5f64.powi(k)).collect();
        assert!((fitted_order(&linear).unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(fitted_order(&[1.0, 0.1]), None);
    }
}
