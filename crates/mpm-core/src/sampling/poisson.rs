//! Bridson's Poisson-disk sampling of a shape in `D` dimensions, deterministic for a seed.

use super::{Rng, Shape};
use crate::math::{for_each_index, Real, Vector};

/// Bridson's Poisson-disk sampling of `shape` with minimum distance `radius`; `None` for
/// invalid parameters.
pub(super) fn sample_poisson<const D: usize>(
    shape: &Shape<D>,
    radius: Real,
    seed: u64,
) -> Option<(Vec<Vector<D>>, Vec<Real>)> {
    const CANDIDATES: usize = 30;
    if !(radius.is_finite() && radius > 0.0) {
        return None;
    }
    let (bmin, bmax) = shape.bounds();
    let cell = radius / (D as Real).sqrt();
    let mut dims = [0usize; D];
    let mut n_cells = 1usize;
    for a in 0..D {
        let n = ((bmax[a] - bmin[a]) / cell).floor() + 1.0;
        if !(1.0..1e15).contains(&n) {
            return None;
        }
        dims[a] = n as usize;
        n_cells = n_cells.checked_mul(dims[a])?;
    }
    // Refuse background grids that could not be allocated.
    if n_cells > (isize::MAX as usize) / std::mem::size_of::<u32>() {
        return None;
    }
    let cell_of = |x: &Vector<D>| -> Option<[i64; D]> {
        let mut c = [0i64; D];
        for a in 0..D {
            let f = ((x[a] - bmin[a]) / cell).floor();
            if !(f >= 0.0 && f < dims[a] as Real) {
                return None;
            }
            c[a] = f as i64;
        }
        Some(c)
    };
    let linear = |c: &[i64; D]| -> usize {
        let mut idx = 0usize;
        let mut stride = 1usize;
        for a in 0..D {
            idx += c[a] as usize * stride;
            stride *= dims[a];
        }
        idx
    };
    // Two samples ≥ radius apart can be up to ⌈√D⌉ cells away from each other per axis.
    let reach = (D as Real).sqrt().ceil() as i64;
    const EMPTY: u32 = u32::MAX;
    let mut grid = vec![EMPTY; n_cells];
    let mut points: Vec<Vector<D>> = Vec::new();
    let mut active: Vec<usize> = Vec::new();
    let mut rng = Rng::new(seed);

    let r2 = radius * radius;
    let fits = |x: &Vector<D>, grid: &[u32], points: &[Vector<D>]| -> Option<usize> {
        if !shape.contains(x) {
            return None;
        }
        let c = cell_of(x)?;
        let idx = linear(&c);
        if grid[idx] != EMPTY {
            return None;
        }
        let mut lo = [0i64; D];
        let mut count = [0usize; D];
        for a in 0..D {
            lo[a] = (c[a] - reach).max(0);
            let hi = (c[a] + reach).min(dims[a] as i64 - 1);
            count[a] = (hi - lo[a] + 1) as usize;
        }
        let mut ok = true;
        for_each_index(&lo, &count, |n| {
            if ok {
                let j = grid[linear(n)];
                if j != EMPTY && (points[j as usize] - x).norm_squared() < r2 {
                    ok = false;
                }
            }
        });
        ok.then_some(idx)
    };

    // First sample: a random point of the bounding box inside the shape, or a known interior
    // point if none is found quickly.
    let mut first = None;
    for _ in 0..64 {
        let x = Vector::<D>::from_fn(|a, _| bmin[a] + rng.uniform() * (bmax[a] - bmin[a]));
        if shape.contains(&x) {
            first = Some(x);
            break;
        }
    }
    let first = first.unwrap_or_else(|| shape.interior_point());
    let idx = fits(&first, &grid, &points)?;
    grid[idx] = 0;
    points.push(first);
    active.push(0);

    let inner = radius.powi(D as i32);
    let outer = (2.0 * radius).powi(D as i32);
    while !active.is_empty() {
        let slot = rng.index(active.len());
        let centre = points[active[slot]];
        let mut placed = false;
        for _ in 0..CANDIDATES {
            // Uniform direction (rejection in the unit ball) and a distance uniform in the
            // volume of the annulus [r, 2r].
            let dir = loop {
                let v = Vector::<D>::from_fn(|_, _| 2.0 * rng.uniform() - 1.0);
                let n2 = v.norm_squared();
                if n2 > 1e-12 && n2 <= 1.0 {
                    break v / n2.sqrt();
                }
            };
            let dist = (inner + rng.uniform() * (outer - inner)).powf(1.0 / D as Real);
            let x = centre + dir * dist.max(radius);
            if let Some(idx) = fits(&x, &grid, &points) {
                if points.len() >= EMPTY as usize {
                    return None;
                }
                grid[idx] = points.len() as u32;
                active.push(points.len());
                points.push(x);
                placed = true;
                break;
            }
        }
        if !placed {
            active.swap_remove(slot);
        }
    }
    let vol = shape.volume() / points.len() as Real;
    let vols = vec![vol; points.len()];
    Some((points, vols))
}
