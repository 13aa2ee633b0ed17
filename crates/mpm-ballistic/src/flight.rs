//! Exact free flight along one axis between two walls, with bounces.

use mpm_core::Real;

/// Most wall hits resolved along one axis in one step. A particle that would bounce more often
/// (the ever smaller hops on a wall with `e < 1`, whose count grows without bound in a finite
/// time) comes to rest on the wall of its last hit instead, its kinetic energy counted as
/// dissipated.
const MAX_HITS: usize = 1000;

/// Advances the coordinate `x` (m) and velocity `v` (m/s) of a particle of mass `m` (kg) along
/// one axis by `dt` (s) under the acceleration `g` (m/s²) between walls at `lo` < `hi` (m) with
/// restitution `e` (`walls = (g, lo, hi, e)`); returns the kinetic energy (J) the bounces
/// dissipated. Between hits the motion is the exact parabola; at a hit, `v ← −e v`. A particle
/// at rest on a wall that `g` presses it against stays there.
pub fn fly(x: &mut Real, v: &mut Real, walls: (Real, Real, Real, Real), m: Real, dt: Real) -> Real {
    let (g, lo, hi, e) = walls;
    let mut left = dt;
    let mut lost = 0.0;
    for _ in 0..MAX_HITS {
        let vn = if (*x <= lo && *v < 0.0) || (*x >= hi && *v > 0.0) {
            // On a wall and moving into it: the hit is now.
            *v
        } else if *v == 0.0 && ((*x <= lo && g <= 0.0) || (*x >= hi && g >= 0.0)) {
            return lost;
        } else if let Some((tau, wall)) = first_hit(*x, *v, g, lo, hi, left) {
            *x = wall;
            left -= tau;
            *v + g * tau
        } else {
            *x = (*x + *v * left + 0.5 * g * left * left).clamp(lo, hi);
            *v += g * left;
            return lost;
        };
        *v = -e * vn;
        lost += 0.5 * m * vn * vn * (1.0 - e * e);
    }
    lost += 0.5 * m * *v * *v;
    *v = 0.0;
    lost
}

/// The first time `τ ∈ (0, left]` (s) at which the parabola `x + v τ + ½ g τ²` reaches a wall,
/// with that wall's position. From a point between the walls the first positive root for a
/// wall is where the particle arrives at it; a particle on a wall has the root τ = 0 there,
/// which is not a hit (its velocity points away, or it rests).
fn first_hit(x: Real, v: Real, g: Real, lo: Real, hi: Real, left: Real) -> Option<(Real, Real)> {
    let hit = |wall: Real| {
        roots(0.5 * g, v, x - wall)
            .into_iter()
            .flatten()
            .filter(|&t| t > 0.0 && t <= left)
            .reduce(Real::min)
            .map(|t| (t, wall))
    };
    match (hit(lo), hit(hi)) {
        (Some(a), Some(b)) => Some(if a.0 <= b.0 { a } else { b }),
        (a, b) => a.or(b),
    }
}

/// The real roots of `a t² + b t + c = 0`, computed without cancellation.
fn roots(a: Real, b: Real, c: Real) -> [Option<Real>; 2] {
    if a == 0.0 {
        return [(b != 0.0).then(|| -c / b), None];
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return [None, None];
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    if q == 0.0 {
        return [Some(0.0), None];
    }
    [Some(q / a), Some(c / q)]
}
