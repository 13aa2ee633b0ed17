//! B-spline interpolation kernels, their stencils and the MLS inertia factor.
//!
//! Positions are converted to grid units `x̂ = (x − origin)/Δx`; a kernel gives, per axis, the
//! first node of the stencil (`base`) and the 1D weights `N(x̂ − i)` and derivatives
//! `N'(x̂ − i)/Δx` for the `support` nodes that follow. Weights in `D` dimensions are tensor
//! products.

use crate::grid::GridSpec;
use crate::math::{Real, Vector};
use serde::{Deserialize, Serialize};

/// Largest stencil width of any kernel (cubic: 4 nodes per axis).
pub const MAX_SUPPORT: usize = 4;

/// Interpolation kernel (B-spline order).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kernel {
    /// Linear (tent) B-spline, 2 nodes per axis. Not C¹: gradients jump at nodes.
    Linear,
    /// Quadratic B-spline, 3 nodes per axis (the MLS-MPM default).
    #[default]
    Quadratic,
    /// Cubic B-spline, 4 nodes per axis.
    Cubic,
}

impl Kernel {
    /// Number of nodes per axis in the stencil.
    pub fn support(self) -> usize {
        match self {
            Kernel::Linear => 2,
            Kernel::Quadratic => 3,
            Kernel::Cubic => 4,
        }
    }

    /// The MLS/APIC inertia factor `M_p⁻¹ = D_p⁻¹` (1/m²) for grid spacing `dx` (m).
    ///
    /// For quadratic and cubic B-splines `D_p = Σ_i w_ip (x_i − x_p)(x_i − x_p)ᵀ` is the constant
    /// `Δx²/4 · I` and `Δx²/3 · I`. For the linear kernel `D_p` depends on the particle position and
    /// vanishes on nodes, so there is no constant factor: this returns `None` and transfers use
    /// the true kernel gradient `∇w_ip` in place of `w_ip M_p⁻¹ (x_i − x_p)`. With a linear kernel
    /// the APIC transfer therefore does not conserve angular momentum exactly.
    pub fn mls_inertia_inv(self, dx: Real) -> Option<Real> {
        match self {
            Kernel::Linear => None,
            Kernel::Quadratic => Some(4.0 / (dx * dx)),
            Kernel::Cubic => Some(3.0 / (dx * dx)),
        }
    }

    /// Lowest grid-unit coordinate `x̂` at which a particle's stencil starts at node 0.
    pub fn lower_margin(self) -> Real {
        match self {
            Kernel::Linear => 0.0,
            Kernel::Quadratic => 0.5,
            Kernel::Cubic => 1.0,
        }
    }

    /// First stencil node along one axis for grid-unit coordinate `xh`.
    #[inline]
    pub fn base_node(self, xh: Real) -> i64 {
        floor_parts(xh - self.lower_margin()).1
    }

    /// `base_node(xh).max(0)`, the first stencil node clamped to the grid's low side, given
    /// `margin =` [`Self::lower_margin`] (hoisted by callers that bin many particles). With
    /// `v = xh − margin`, the floor `⌊v⌋` and the truncation `v as i64` are equal for `v ≥ 0`
    /// (both saturate alike above `i64::MAX`), and below 0 the floor is at most −1 and the
    /// truncation at most 0, so both clamp to 0; NaN gives 0 in both. The truncation (a
    /// conversion and two fix-ups, for NaN and out of range) has no branch; the floor has one.
    #[inline]
    pub fn clamped_base_node(margin: Real, xh: Real) -> usize {
        ((xh - margin) as i64).max(0) as usize
    }

    /// The first node (as a real and as an integer), `fx = xh − base` and the `S` weights at
    /// grid-unit coordinate `xh`. The kernel is read from `S` (its support), a constant, so the
    /// hot transfers compile without a branch on the kernel.
    #[inline(always)]
    fn stencil_1d<const S: usize>(self, xh: Real) -> (Real, i64, Real, [Real; S]) {
        debug_assert_eq!(S, self.support());
        let (base, node) = base_1d::<S>(xh);
        let fx = xh - base;
        (base, node, fx, weights_at::<S>(fx))
    }

    /// 1D stencil at grid-unit coordinate `xh`: first node index, weights, and derivatives of
    /// the weights with respect to `xh` (multiply by `1/Δx` for spatial gradients).
    pub fn weights_1d(self, xh: Real) -> (i64, [Real; MAX_SUPPORT], [Real; MAX_SUPPORT]) {
        fn padded<const S: usize>(w: [Real; S]) -> [Real; MAX_SUPPORT] {
            std::array::from_fn(|k| if k < S { w[k] } else { 0.0 })
        }
        let (base, fx, w) = match self {
            Kernel::Linear => {
                let (_, b, fx, w) = self.stencil_1d::<2>(xh);
                (b, fx, padded(w))
            }
            Kernel::Quadratic => {
                let (_, b, fx, w) = self.stencil_1d::<3>(xh);
                (b, fx, padded(w))
            }
            Kernel::Cubic => {
                let (_, b, fx, w) = self.stencil_1d::<4>(xh);
                (b, fx, w)
            }
        };
        let mut dw = [0.0; MAX_SUPPORT];
        match self {
            Kernel::Linear => {
                dw[0] = -1.0;
                dw[1] = 1.0;
            }
            Kernel::Quadratic => {
                dw[0] = fx - 1.5;
                dw[1] = -2.0 * (fx - 1.0);
                dw[2] = fx - 0.5;
            }
            Kernel::Cubic => {
                for (k, dwk) in dw.iter_mut().enumerate() {
                    let d = fx - k as Real;
                    let a = d.abs();
                    *dwk = if a < 1.0 {
                        1.5 * d * a - 2.0 * d
                    } else {
                        let t = 2.0 - a;
                        -0.5 * t * t * d.signum()
                    };
                }
            }
        }
        (base, w, dw)
    }
}

/// `⌊v⌋`, the same value as [`Real::floor`] for every input (−0.0 included).
#[cfg(test)]
fn floor(v: Real) -> Real {
    floor_parts(v).0
}

/// `⌊v⌋` as a real, the same value as [`Real::floor`] for every input (−0.0 included), and as
/// an integer, the same as `⌊v⌋ as i64` (saturating), without the library call that the baseline
/// x86-64 target makes of `floor` and without a saturating float-to-integer conversion. Below
/// 2⁵¹ in magnitude, `s = v + 1.5 · 2⁵²` lies where the spacing of doubles is 1, so it holds `v`
/// rounded to the nearest integer `r = s − 1.5 · 2⁵²` exactly, and the difference of the bit
/// patterns of `s` and `1.5 · 2⁵²` is `r` as an integer; `⌊v⌋` is `r` or `r − 1`, and its sign
/// is `v`'s (`⌊v⌋` is negative exactly when `v` is).
#[inline]
fn floor_parts(v: Real) -> (Real, i64) {
    const ROUND: Real = 6755399441055744.0; // 1.5 · 2⁵²
    if v.abs() < 2251799813685248.0 {
        // |v| < 2⁵¹
        let s = v + ROUND;
        let r = s - ROUND;
        let below = r > v;
        let int = (s.to_bits() as i64 - ROUND.to_bits() as i64) - i64::from(below);
        ((r - if below { 1.0 } else { 0.0 }).copysign(v), int)
    } else {
        let f = v.floor();
        (f, f as i64)
    }
}

/// The first stencil node along one axis, as a real and as an integer, at grid-unit coordinate
/// `xh` for the kernel of `S` nodes per axis (2 linear, 3 quadratic, 4 cubic).
#[inline(always)]
fn base_1d<const S: usize>(xh: Real) -> (Real, i64) {
    match S {
        2 => floor_parts(xh),
        3 => floor_parts(xh - 0.5),
        _ => {
            let (f, i) = floor_parts(xh);
            let b = f - 1.0;
            // `i − 1` is `b as i64` wherever `b` is an exact integer below 2⁵³.
            (
                b,
                if b.abs() < 9007199254740992.0 {
                    i - 1
                } else {
                    b as i64
                },
            )
        }
    }
}

/// [`base_1d`] along all `D` axes at once. When every coordinate is below 2⁵¹ in magnitude (any
/// particle in a grid), the axes take [`floor_parts`]' rounding path without its branches, so
/// the compiler can run them side by side in vector registers: the same operations on each
/// axis, hence the same values; otherwise each axis goes through [`base_1d`]. The rounding
/// path is written out again here rather than shared with `floor_parts`: both shared forms
/// tried made G2P 2–10 % slower (benches/README.md, `ab6a78d`).
#[inline(always)]
fn bases<const D: usize, const S: usize>(xh: &[Real; D]) -> ([Real; D], [i64; D]) {
    const ROUND: Real = 6755399441055744.0; // 1.5 · 2⁵², as in `floor_parts`
    let v: [Real; D] = std::array::from_fn(|a| if S == 3 { xh[a] - 0.5 } else { xh[a] });
    if !v
        .iter()
        .fold(true, |ok, v| ok & (v.abs() < 2251799813685248.0))
    {
        let both: [(Real, i64); D] = std::array::from_fn(|a| base_1d::<S>(xh[a]));
        return (both.map(|b| b.0), both.map(|b| b.1));
    }
    let s = v.map(|v| v + ROUND);
    let below: [bool; D] = std::array::from_fn(|a| s[a] - ROUND > v[a]);
    let f: [Real; D] =
        std::array::from_fn(|a| (s[a] - ROUND - if below[a] { 1.0 } else { 0.0 }).copysign(v[a]));
    let i: [i64; D] = std::array::from_fn(|a| {
        (s[a].to_bits() as i64 - ROUND.to_bits() as i64) - i64::from(below[a])
    });
    if S == 4 {
        // The cubic stencil starts one node lower; below 2⁵¹ `i − 1` is exact.
        (f.map(|f| f - 1.0), i.map(|i| i - 1))
    } else {
        (f, i)
    }
}

/// The `S` weights `N(fx − o)` of the 1D stencil whose first node lies `fx` grid units below
/// the particle (2 linear, 3 quadratic, 4 cubic B-spline).
#[inline(always)]
fn weights_at<const S: usize>(fx: Real) -> [Real; S] {
    let mut w = [0.0; S];
    match S {
        2 => {
            w[0] = 1.0 - fx;
            w[1] = fx;
        }
        3 => {
            w[0] = 0.5 * (1.5 - fx) * (1.5 - fx);
            w[1] = 0.75 - (fx - 1.0) * (fx - 1.0);
            w[2] = 0.5 * (fx - 0.5) * (fx - 0.5);
        }
        _ => {
            for (k, wk) in w.iter_mut().enumerate() {
                let a = (fx - k as Real).abs();
                *wk = if a < 1.0 {
                    0.5 * a * a * a - a * a + 2.0 / 3.0
                } else {
                    let t = 2.0 - a;
                    t * t * t / 6.0
                };
            }
        }
    }
    w
}

/// The weights and gradients of one particle's stencil in `D` dimensions.
#[derive(Clone, Copy, Debug)]
pub struct Stencil<const D: usize> {
    /// Multi-index of the first node of the stencil.
    pub base: [i64; D],
    w: [[Real; MAX_SUPPORT]; D],
    dw: [[Real; MAX_SUPPORT]; D],
    support: usize,
    inv_dx: Real,
}

impl<const D: usize> Stencil<D> {
    /// Builds the stencil of kernel `kernel` on grid `spec` at position `x` (m).
    pub fn new(kernel: Kernel, spec: &GridSpec<D>, x: &Vector<D>) -> Self {
        let mut base = [0i64; D];
        let mut w = [[0.0; MAX_SUPPORT]; D];
        let mut dw = [[0.0; MAX_SUPPORT]; D];
        let inv_dx = 1.0 / spec.dx;
        for a in 0..D {
            let xh = (x[a] - spec.origin[a]) * inv_dx;
            let (b, wa, dwa) = kernel.weights_1d(xh);
            base[a] = b;
            w[a] = wa;
            dw[a] = dwa;
        }
        Self {
            base,
            w,
            dw,
            support: kernel.support(),
            inv_dx,
        }
    }

    /// Number of nodes in the stencil (`support^D`).
    pub fn len(&self) -> usize {
        self.support.pow(D as u32)
    }

    /// Always false: a stencil has at least `2^D` nodes.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Offsets (per axis, within the stencil) of the `k`-th node, `k < len()`.
    #[inline]
    pub fn offset(&self, mut k: usize) -> [usize; D] {
        let mut o = [0usize; D];
        for oa in o.iter_mut() {
            *oa = k % self.support;
            k /= self.support;
        }
        o
    }

    /// Weight and spatial gradient (1/m) of the node at stencil offset `o`.
    #[inline]
    pub fn weight_gradient(&self, o: &[usize; D]) -> (Real, Vector<D>) {
        let mut weight = 1.0;
        for a in 0..D {
            weight *= self.w[a][o[a]];
        }
        let grad = Vector::<D>::from_fn(|a, _| {
            let mut g = self.dw[a][o[a]] * self.inv_dx;
            for b in 0..D {
                if b != a {
                    g *= self.w[b][o[b]];
                }
            }
            g
        });
        (weight, grad)
    }

    /// Makes the stencil's basis vanish on the plane `x_axis = plane` (grid units: `plane` is
    /// `(X − origin)/Δx`), the material lying `above` it or below: along `axis` each node `i` on
    /// the material side gets the factor `N(x − i) − N(x̄ − i)`, `x̄ = 2 plane − x` the particle's
    /// mirror image, and nodes on the plane (within 10⁻⁹) or beyond it get 0. The new factor is
    /// zero at `x = plane` for every node, whatever the plane's position relative to the nodes;
    /// on the material side it is positive wherever `N(x − i)` is (the image is farther from the
    /// node). Derivatives follow: `d/dx N(x̄ − i) = −N'(x̄ − i)`. Other axes are unchanged, so
    /// planes on different axes compose into products that vanish on each. `kernel` must be the
    /// stencil's kernel and `x` the particle's coordinate along `axis` in grid units.
    pub fn reflect_odd(&mut self, kernel: Kernel, axis: usize, plane: Real, above: bool, x: Real) {
        let (image_base, wi, dwi) = kernel.weights_1d(2.0 * plane - x);
        for k in 0..self.support {
            let node = self.base[axis] + k as i64;
            let side = if above {
                node as Real - plane
            } else {
                plane - node as Real
            };
            if side <= 1e-9 {
                self.w[axis][k] = 0.0;
                self.dw[axis][k] = 0.0;
                continue;
            }
            let j = node - image_base;
            if (0..self.support as i64).contains(&j) {
                self.w[axis][k] -= wi[j as usize];
                self.dw[axis][k] += dwi[j as usize];
            }
        }
    }

    /// Calls `f(node, weight, gradient)` for every node of the stencil, in a fixed order
    /// (first axis fastest). `node` is the grid multi-index.
    #[inline]
    pub fn for_each(&self, mut f: impl FnMut([i64; D], Real, Vector<D>)) {
        for k in 0..self.len() {
            let o = self.offset(k);
            let (w, g) = self.weight_gradient(&o);
            let node = std::array::from_fn(|a| self.base[a] + o[a] as i64);
            f(node, w, g);
        }
    }
}

/// One particle's stencil as per-axis factors, for kernels of `S` nodes per axis: the weights
/// and the offsets `x_i − x_p` of the nodes along each axis. The hot
/// transfers iterate it by rows along axis 0 ([`AxisStencil::for_each_row`]), so the factors
/// of the other axes are multiplied once per row rather than once per node.
#[derive(Clone, Copy, Debug)]
pub struct AxisStencil<const D: usize, const S: usize> {
    /// Multi-index of the first node of the stencil.
    pub base: [i64; D],
    /// `w[a][o]`: 1D weight of the node at offset `o` along axis `a` (dimensionless).
    pub w: [[Real; S]; D],
    /// `d[a][o]`: component `a` of `x_i − x_p` for the nodes at offset `o` along axis `a` (m).
    pub d: [[Real; S]; D],
}

impl<const D: usize, const S: usize> AxisStencil<D, S> {
    /// The stencil with every field zero: a placeholder for storage that [`Self::new`] fills.
    pub const ZERO: Self = Self {
        base: [0; D],
        w: [[0.0; S]; D],
        d: [[0.0; S]; D],
    };

    /// Builds the stencil of `kernel`, which must have `S` nodes per axis, on grid `spec` at
    /// position `x` (m), in 1 to 3 dimensions. `inv_dx` is `1 / spec.dx` (1/m), which the
    /// transfers compute once rather than once per particle.
    ///
    /// # Panics
    /// In debug builds, when `kernel.support() != S`, `D > 3` or `inv_dx != 1 / spec.dx`.
    #[inline(always)]
    pub fn new(kernel: Kernel, spec: &GridSpec<D>, inv_dx: Real, x: &Vector<D>) -> Self {
        debug_assert_eq!(kernel.support(), S);
        debug_assert!(D <= 3);
        debug_assert_eq!(inv_dx, 1.0 / spec.dx);
        let xh: [Real; D] = std::array::from_fn(|a| (x[a] - spec.origin[a]) * inv_dx);
        let (b, base) = bases::<D, S>(&xh);
        let fx: [Real; D] = std::array::from_fn(|a| xh[a] - b[a]);
        Self {
            base,
            w: fx.map(weights_at::<S>),
            // `b + o` is an integer below 2⁵³, exact in floating point: the node's index as a
            // real, without an integer-to-float conversion per node.
            d: std::array::from_fn(|a| {
                std::array::from_fn(|o| spec.origin[a] + (b[a] + o as Real) * spec.dx - x[a])
            }),
        }
    }

    /// Calls `f(start, weight, d)` for each row of the stencil along axis 0, in the order of
    /// [`Stencil::for_each`], for a buffer that holds node `base + o` at index
    /// `first + Σ_a o_a stride[a]`: `start` is the index of the row's first node, `weight` the
    /// product of the weights of axes `1..D`, and `d` their components of `x_i − x_p` (m;
    /// component 0 is 0). The caller walks the `S` nodes of the row, at `start + i stride[0]`,
    /// with `w[0]` and `d[0]`. The indices are formed by additions as the walk goes.
    #[inline(always)]
    pub fn for_each_row(
        &self,
        first: usize,
        stride: &[usize; D],
        mut f: impl FnMut(usize, Real, &Vector<D>),
    ) {
        let mut d = Vector::<D>::zeros();
        match D {
            1 => f(first, 1.0, &d),
            2 => {
                let mut start = first;
                for j in 0..S {
                    d[1] = self.d[1][j];
                    f(start, self.w[1][j], &d);
                    start += stride[1];
                }
            }
            _ => {
                let mut plane = first;
                for k in 0..S {
                    d[D - 1] = self.d[D - 1][k];
                    let mut start = plane;
                    for j in 0..S {
                        d[1] = self.d[1][j];
                        f(start, self.w[1][j] * self.w[D - 1][k], &d);
                        start += stride[1];
                    }
                    plane += stride[D - 1];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    const KERNELS: [Kernel; 3] = [Kernel::Linear, Kernel::Quadratic, Kernel::Cubic];

    fn spec<const D: usize>() -> GridSpec<D> {
        GridSpec::new(Vector::<D>::from_element(-0.3), 0.1, [40; D])
    }

    fn positions<const D: usize>() -> Vec<Vector<D>> {
        (0..50)
            .map(|k| {
                Vector::<D>::from_fn(|a, _| 0.5 + 0.0173 * (k as Real) * (a as Real + 1.0).sqrt())
            })
            .collect()
    }

    fn partition_of_unity_and_consistency<const D: usize>() {
        let spec = spec::<D>();
        for kernel in KERNELS {
            for x in positions::<D>() {
                let st = Stencil::new(kernel, &spec, &x);
                let (mut sw, mut sg) = (0.0, Vector::<D>::zeros());
                let mut first = Vector::<D>::zeros();
                let mut grad_x = nalgebra::SMatrix::<Real, D, D>::zeros();
                let mut second = nalgebra::SMatrix::<Real, D, D>::zeros();
                st.for_each(|node, w, g| {
                    let xi = spec.node_position(&node);
                    sw += w;
                    sg += g;
                    first += (xi - x) * w;
                    grad_x += xi * g.transpose();
                    second += (xi - x) * (xi - x).transpose() * w;
                });
                // Partition of unity and its gradient.
                assert_relative_eq!(sw, 1.0, epsilon = 1e-13);
                assert_relative_eq!(sg.norm(), 0.0, epsilon = 1e-11);
                // Linear reproduction: Σ w x_i = x_p and Σ x_i ∇wᵀ = I.
                assert_relative_eq!(first.norm(), 0.0, epsilon = 1e-13);
                assert_relative_eq!(
                    grad_x,
                    nalgebra::SMatrix::<Real, D, D>::identity(),
                    epsilon = 1e-11
                );
                // MLS inertia: Σ w (x_i − x_p)(x_i − x_p)ᵀ = M_p for quadratic and cubic.
                if let Some(minv) = kernel.mls_inertia_inv(spec.dx) {
                    assert_relative_eq!(
                        second,
                        nalgebra::SMatrix::<Real, D, D>::identity() / minv,
                        epsilon = 1e-13
                    );
                }
            }
        }
    }

    #[test]
    fn partition_of_unity_gradient_consistency_and_inertia() {
        partition_of_unity_and_consistency::<2>();
        partition_of_unity_and_consistency::<3>();
    }

    /// The row walk of [`AxisStencil`] visits the nodes of [`Stencil::for_each`] in the same
    /// order with the same weights (to round-off: the products associate differently) and
    /// the offsets `x_i − x_p`.
    fn rows_match_the_stencil<const D: usize, const S: usize>(kernel: Kernel) {
        let spec = spec::<D>();
        for x in positions::<D>() {
            let mut nodes = Vec::new();
            Stencil::new(kernel, &spec, &x).for_each(|node, w, _| nodes.push((node, w)));
            let st = AxisStencil::<D, S>::new(kernel, &spec, 1.0 / spec.dx, &x);
            // Index the nodes as a buffer of (S + 1)^D nodes from `base − 1` would.
            let width = S + 1;
            let stride: [usize; D] = std::array::from_fn(|a| width.pow(a as u32));
            let first: usize = stride.iter().sum();
            let mut k = 0;
            st.for_each_row(first, &stride, |start, wr, dr| {
                for i in 0..S {
                    let (node, w) = nodes[k];
                    k += 1;
                    let index: usize = (0..D)
                        .map(|a| (node[a] - st.base[a] + 1) as usize * stride[a])
                        .sum();
                    assert_eq!(index, start + i);
                    assert_relative_eq!(st.w[0][i] * wr, w, max_relative = 1e-14);
                    let d = spec.node_position(&node) - x;
                    assert_eq!(d[0], st.d[0][i]);
                    for a in 1..D {
                        assert_eq!(d[a], dr[a]);
                    }
                }
            });
            assert_eq!(k, S.pow(D as u32));
        }
    }

    /// Values for the floor tests: signed zeros, ties of the rounding step, the ends of the
    /// fast path (2⁵¹), huge and non-finite values.
    const FLOOR_CASES: [Real; 29] = [
        0.0,
        -0.0,
        0.5,
        -0.5,
        1.0,
        -1.0,
        2.999999,
        -2.000001,
        1e15 + 0.5,
        -1e15 - 0.5,
        4.6e18,
        -4.6e18,
        1e300,
        Real::INFINITY,
        Real::NEG_INFINITY,
        Real::MIN_POSITIVE,
        -1e-300,
        // Ties of the rounding step, both parities, and the ends of the fast path (2⁵¹).
        2.5,
        3.5,
        -2.5,
        -3.5,
        0.49999999999999994,
        -0.49999999999999994,
        2251799813685247.5,
        -2251799813685247.5,
        2251799813685248.0,
        -2251799813685248.0,
        4503599627370495.5,
        -4503599627370495.5,
    ];

    #[test]
    fn floor_matches_the_library_floor() {
        for v in FLOOR_CASES {
            assert_eq!(floor(v).to_bits(), v.floor().to_bits(), "{v}");
            assert_eq!(floor_parts(v).1, v.floor() as i64, "{v}");
        }
        assert!(floor(Real::NAN).is_nan());
        assert_eq!(floor_parts(Real::NAN).1, 0);
        // A sweep over magnitudes from 1e-3 to 1e16, each value and its neighbours in ulps.
        let mut v: Real = 1e-3;
        while v < 1e16 {
            for x in [
                v,
                -v,
                v.next_up(),
                v.next_down(),
                -v.next_up(),
                -v.next_down(),
            ] {
                assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "{x}");
                assert_eq!(floor_parts(x).1, x.floor() as i64, "{x}");
            }
            v *= 1.0009765625;
        }
    }

    /// The truncating clamped first node is the floor's, clamped, for every kernel: on the
    /// floor's edge cases, a sweep of magnitudes with their neighbours in ulps, and NaN.
    #[test]
    fn clamped_base_node_is_the_clamped_floor() {
        let mut values = FLOOR_CASES.to_vec();
        let mut v: Real = 1e-3;
        while v < 1e20 {
            values.extend([
                v,
                -v,
                v.next_up(),
                v.next_down(),
                -v.next_up(),
                -v.next_down(),
            ]);
            v *= 1.0009765625;
        }
        values.extend([0.5, 1.0, 1.5, 0.5f64.next_down(), 1.0f64.next_down(), -0.0]);
        values.extend([Real::NAN, Real::INFINITY, Real::NEG_INFINITY, 1e300, -1e300]);
        let mut checked = 0;
        for k in KERNELS {
            let margin = k.lower_margin();
            for &xh in &values {
                let want = k.base_node(xh).max(0) as usize;
                assert_eq!(Kernel::clamped_base_node(margin, xh), want, "{k:?} {xh}");
                checked += 1;
            }
        }
        assert!(checked > 3 * 6 * 40_000, "{checked} values");
    }

    /// `bases` (all axes at once, branchless below 2⁵¹) gives bit for bit the first nodes of
    /// `base_1d` axis by axis, for every kernel, whether all, some or none of the axes take the
    /// fast path; NaN included.
    fn bases_match_base_1d<const S: usize>() {
        let mut values = FLOOR_CASES.to_vec();
        values.extend([Real::NAN, -Real::NAN, 0.25, -0.75, 63.5, 1e-17]);
        let mut v: Real = 1e-3;
        while v < 1e16 {
            values.extend([v, -v, v.next_up(), -v.next_down()]);
            v *= 1.0078125;
        }
        let check = |xh: &[Real]| match *xh {
            [a, b] => {
                let (f, i) = bases::<2, S>(&[a, b]);
                for (k, x) in [a, b].into_iter().enumerate() {
                    let (f1, i1) = base_1d::<S>(x);
                    assert_eq!((f[k].to_bits(), i[k]), (f1.to_bits(), i1), "{x} in {xh:?}");
                }
            }
            [a, b, c] => {
                let (f, i) = bases::<3, S>(&[a, b, c]);
                for (k, x) in [a, b, c].into_iter().enumerate() {
                    let (f1, i1) = base_1d::<S>(x);
                    assert_eq!((f[k].to_bits(), i[k]), (f1.to_bits(), i1), "{x} in {xh:?}");
                }
            }
            _ => unreachable!(),
        };
        for (k, &x) in values.iter().enumerate() {
            // Each value beside a neighbour from the list and beside a lattice value, in both
            // orders, in 2D and 3D.
            let y = values[(k * 7 + 3) % values.len()];
            check(&[x, y]);
            check(&[0.5, x]);
            check(&[x, 0.25, y]);
            check(&[y, x, 17.75]);
        }
    }

    #[test]
    fn all_axes_bases_match_the_axis_by_axis_base() {
        bases_match_base_1d::<2>();
        bases_match_base_1d::<3>();
        bases_match_base_1d::<4>();
    }

    #[test]
    fn axis_stencil_rows_match_the_stencil() {
        rows_match_the_stencil::<2, 3>(Kernel::Quadratic);
        rows_match_the_stencil::<3, 3>(Kernel::Quadratic);
        rows_match_the_stencil::<2, 4>(Kernel::Cubic);
        rows_match_the_stencil::<3, 4>(Kernel::Cubic);
        rows_match_the_stencil::<3, 2>(Kernel::Linear);
    }

    #[test]
    fn gradients_match_finite_differences_of_weights() {
        let spec = spec::<2>();
        let h = 1e-7;
        for kernel in KERNELS {
            for x in positions::<2>() {
                let st = Stencil::new(kernel, &spec, &x);
                for a in 0..2 {
                    let mut xp = x;
                    xp[a] += h;
                    let mut xm = x;
                    xm[a] -= h;
                    let (sp, sm) = (
                        Stencil::new(kernel, &spec, &xp),
                        Stencil::new(kernel, &spec, &xm),
                    );
                    if sp.base != st.base || sm.base != st.base {
                        continue; // a cell boundary lies within h
                    }
                    for k in 0..st.len() {
                        let o = st.offset(k);
                        let (_, g) = st.weight_gradient(&o);
                        let fd = (sp.weight_gradient(&o).0 - sm.weight_gradient(&o).0) / (2.0 * h);
                        assert_relative_eq!(g[a], fd, epsilon = 1e-6);
                    }
                }
            }
        }
    }

    /// `reflect_odd` makes every factor along the axis vanish on the plane, wherever the plane
    /// lies between the nodes, and leaves positive factors on the material side.
    #[test]
    fn odd_reflection_vanishes_on_the_plane_and_stays_positive_beside_it() {
        let spec = GridSpec::<2>::new(Vector::<2>::zeros(), 1.0, [12, 12]);
        for kernel in [Kernel::Quadratic, Kernel::Cubic] {
            for plane in [4.0, 4.5, 4.3, 4.9] {
                for (d, above) in [(1e-12, true), (0.37, true), (-1e-12, false), (-0.61, false)] {
                    let x = Vector::<2>::new(plane + d, 5.2);
                    let mut st = Stencil::new(kernel, &spec, &x);
                    st.reflect_odd(kernel, 0, plane, above, x.x);
                    let mut total: Real = 0.0;
                    st.for_each(|node, w, _| {
                        let beyond = if above {
                            node[0] as Real <= plane
                        } else {
                            node[0] as Real >= plane
                        };
                        assert!(w >= 0.0 && (!beyond || w == 0.0), "{kernel:?} {plane} {d}");
                        total += w;
                    });
                    if d.abs() < 1e-9 {
                        assert!(total < 1e-10, "{kernel:?} {plane}: {total}");
                    } else {
                        assert!(
                            total > 0.01 && total < 1.0,
                            "{kernel:?} {plane} {d}: {total}"
                        );
                    }
                }
            }
        }
    }
}
