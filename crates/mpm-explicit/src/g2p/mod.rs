//! Grid-to-particle transfer (multigrid paper Eqs. 8–10): velocity, affine field, deformation
//! update with plasticity, fluid J, advection, and the particle guard checks.
//!
//! G2P writes each particle's new state straight into its columns (no per-particle result
//! buffer), so a failed guard check leaves the step's partial result behind. The solver keeps a
//! copy of the columns G2P rewrites ([`Moving`]) only when its instability policy retries steps,
//! and puts it back before the retry.
//!
//! With the quadratic and cubic kernels the gather walks the stencil by rows along the first
//! axis ([`AxisStencil`]), reading the node velocities of a row from consecutive entries of the
//! particle's block window ([`crate::blocks::Blocks::velocities`]), the nodes P2G scattered
//! that block into; the linear kernel, and a particle whose stencil leaves its window, take the
//! general path over [`Stencil`] and the sparse grid's [`NodeLayout`].

use crate::blocks::{Blocks, Window};
use crate::materials::MaterialView;
use crate::multigrid::{Dissolution, Mixing, Porous};
use crate::p2g::mls_gradient;
use crate::params::{SoftWalls, Transfer};
use mpm_core::material::PlasticState;
use mpm_core::solver::nan_max;
use mpm_core::{
    AxisStencil, Dim, DimOps, GridNodes, GridSpec, Kernel, Location, Material, Matrix, NodeLayout,
    Particles, Real, Stencil, StencilRange, Vector, Violation,
};
use rayon::prelude::*;

/// Particles per work item of the in-place update.
const CHUNK: usize = 1024;

/// The new state of one particle, checked before it is written.
#[derive(Clone, Copy, Debug)]
struct Update<const D: usize> {
    x: Vector<D>,
    v: Vector<D>,
    c: Matrix<D>,
    f: Matrix<D>,
    j: Real,
    plastic: PlasticState,
}

/// The state of one particle that G2P reads before it rewrites it.
#[derive(Clone, Copy, Debug)]
struct Old<const D: usize> {
    x: Vector<D>,
    v: Vector<D>,
    f: Matrix<D>,
    j: Real,
    plastic: Option<PlasticState>,
}

/// The particle columns G2P rewrites: positions, velocities, affine fields, and the deformation
/// gradients, volume ratios and plastic states where they exist. Also the solver's backup of
/// them for dt/2 retries.
#[derive(Clone, Debug, Default)]
pub(crate) struct Moving<const D: usize> {
    x: Vec<Vector<D>>,
    v: Vec<Vector<D>>,
    affine: Vec<Matrix<D>>,
    def_grad: Option<Vec<Matrix<D>>>,
    jacobian: Option<Vec<Real>>,
    plastic: Option<Vec<PlasticState>>,
}

impl<const D: usize> Moving<D> {
    /// Moves the columns out of `particles`, leaving them empty there.
    fn take(particles: &mut Particles<D>) -> Self {
        Self {
            x: std::mem::take(&mut particles.x),
            v: std::mem::take(&mut particles.v),
            affine: std::mem::take(&mut particles.affine),
            def_grad: particles.def_grad.as_mut().map(std::mem::take),
            jacobian: particles.jacobian.as_mut().map(std::mem::take),
            plastic: particles.plastic.as_mut().map(std::mem::take),
        }
    }

    /// Moves the columns back into `particles`.
    fn put_back(self, particles: &mut Particles<D>) {
        particles.x = self.x;
        particles.v = self.v;
        particles.affine = self.affine;
        particles.def_grad = self.def_grad;
        particles.jacobian = self.jacobian;
        particles.plastic = self.plastic;
    }

    /// Copies the columns of `particles` into `self`, reusing its allocations.
    pub fn save(&mut self, particles: &Particles<D>) {
        self.x.clone_from(&particles.x);
        self.v.clone_from(&particles.v);
        self.affine.clone_from(&particles.affine);
        copy(&mut self.def_grad, &particles.def_grad);
        copy(&mut self.jacobian, &particles.jacobian);
        copy(&mut self.plastic, &particles.plastic);
    }

    /// Copies the saved columns back into `particles`.
    pub fn restore(&self, particles: &mut Particles<D>) {
        particles.x.clone_from(&self.x);
        particles.v.clone_from(&self.v);
        particles.affine.clone_from(&self.affine);
        copy(&mut particles.def_grad, &self.def_grad);
        copy(&mut particles.jacobian, &self.jacobian);
        copy(&mut particles.plastic, &self.plastic);
    }

    /// Bytes held (lengths, not capacities).
    pub fn bytes(&self) -> usize {
        fn len<T>(c: &Option<Vec<T>>) -> usize {
            c.as_ref().map_or(0, |c| c.len() * std::mem::size_of::<T>())
        }
        self.x.len() * std::mem::size_of::<Vector<D>>() * 2
            + self.affine.len() * std::mem::size_of::<Matrix<D>>()
            + len(&self.def_grad)
            + len(&self.jacobian)
            + len(&self.plastic)
    }

    /// Splits the columns of the first `active` particles into runs of at most `size`.
    fn chunks(&mut self, size: usize, active: usize) -> Vec<Chunk<'_, D>> {
        fn split<'a, T>(s: &mut Option<&'a mut [T]>, n: usize) -> Option<&'a mut [T]> {
            let (head, tail) = s.take()?.split_at_mut(n);
            *s = Some(tail);
            Some(head)
        }
        let n = active.min(self.x.len());
        let (mut x, mut v, mut c) = (
            self.x.as_mut_slice(),
            self.v.as_mut_slice(),
            self.affine.as_mut_slice(),
        );
        let mut f = self.def_grad.as_deref_mut();
        let mut j = self.jacobian.as_deref_mut();
        let mut s = self.plastic.as_deref_mut();
        let mut out = Vec::with_capacity(n.div_ceil(size));
        let mut start = 0;
        while start < n {
            let len = size.min(n - start);
            let (xh, xt) = std::mem::take(&mut x).split_at_mut(len);
            let (vh, vt) = std::mem::take(&mut v).split_at_mut(len);
            let (ch, ct) = std::mem::take(&mut c).split_at_mut(len);
            (x, v, c) = (xt, vt, ct);
            out.push(Chunk {
                start,
                x: xh,
                v: vh,
                c: ch,
                f: split(&mut f, len),
                j: split(&mut j, len),
                plastic: split(&mut s, len),
            });
            start += len;
        }
        out
    }
}

/// Copies an optional column, reusing `to`'s allocation when both exist.
fn copy<T: Clone>(to: &mut Option<Vec<T>>, from: &Option<Vec<T>>) {
    match (to.as_mut(), from) {
        (Some(t), Some(f)) => t.clone_from(f),
        _ => *to = from.clone(),
    }
}

/// A run of consecutive particles' [`Moving`] columns, starting at particle `start`.
struct Chunk<'a, const D: usize> {
    start: usize,
    x: &'a mut [Vector<D>],
    v: &'a mut [Vector<D>],
    c: &'a mut [Matrix<D>],
    f: Option<&'a mut [Matrix<D>]>,
    j: Option<&'a mut [Real]>,
    plastic: Option<&'a mut [PlasticState]>,
}

impl<const D: usize> Chunk<'_, D> {
    #[inline(always)]
    fn old(&self, i: usize) -> Old<D> {
        Old {
            x: self.x[i],
            v: self.v[i],
            f: self.f.as_ref().map_or(Matrix::<D>::identity(), |f| f[i]),
            j: self.j.as_ref().map_or(1.0, |j| j[i]),
            plastic: self.plastic.as_ref().map(|s| s[i]),
        }
    }

    #[inline(always)]
    fn write(&mut self, i: usize, u: &Update<D>) {
        self.x[i] = u.x;
        self.v[i] = u.v;
        self.c[i] = u.c;
        if let Some(f) = &mut self.f {
            f[i] = u.f;
        }
        if let Some(j) = &mut self.j {
            j[i] = u.j;
        }
        if let Some(s) = &mut self.plastic {
            s[i] = u.plastic;
        }
    }
}

/// What G2P needs besides particles and grid.
pub(crate) struct G2pContext<'a, const D: usize> {
    pub spec: &'a GridSpec<D>,
    /// The sparse grid's stored nodes.
    pub layout: &'a NodeLayout<D>,
    pub kernel: Kernel,
    pub transfer: Transfer,
    pub materials: MaterialView<'a>,
    pub soft_walls: Option<SoftWalls>,
    /// Whether to return the largest signal speed `max_p(|v_p| + c_p)` of the new state, for
    /// the next step's adaptive dt.
    pub signal_speed: bool,
}

/// The multi-grid state of one particle after the step, before commit.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Extra {
    phi_eff: Real,
    concentration: Real,
    dissolve: bool,
}

/// What the multi-grid particle update needs: porous interaction, dissolution, and the
/// concentrations of the diffusion stage.
pub(crate) struct ExtraContext<'a> {
    pub porous: Option<&'a Porous>,
    pub dissolution: Option<&'a Dissolution>,
    /// Node concentration of the mixing phase (empty without mixing).
    pub node_concentration: &'a [Real],
    /// Particle concentrations after diffusion, if the diffusion stage ran.
    pub alpha: Option<&'a [Real]>,
}

/// What a particle gathers from its grid: the PIC velocity, the FLIP velocity increment and
/// the affine field C.
type Gathered<const D: usize> = (Vector<D>, Vector<D>, Matrix<D>);

/// What G2P derives from the grid once rather than per particle: the bounds a particle's
/// stencil must stay within, `1/Δx` (1/m) and the MLS factor `M⁻¹` (1/m², `None` for the linear
/// kernel; [`Kernel::mls_inertia_inv`]).
struct Scale<const D: usize> {
    range: StencilRange<D>,
    inv_dx: Real,
    minv: Option<Real>,
}

/// Where a particle gathers from: its block's window, its phase's grid, with FLIP the grid's
/// velocities before the update (m/s), and its stencil for the row gather (`S` nodes per
/// axis; `None` for the linear kernel).
type Source<'a, const D: usize, const S: usize> = (
    Option<Window<'a, D>>,
    &'a GridNodes<D>,
    Option<&'a [Vector<D>]>,
    Option<&'a AxisStencil<D, S>>,
);

/// What every G2P chunk reads: the particles' fixed columns, and per phase the binning with
/// its velocity windows, the grid and, with FLIP, the velocities before the update (m/s).
type Inputs<'a, const D: usize> = (
    &'a Particles<D>,
    &'a [Blocks<D>],
    &'a [GridNodes<D>],
    Option<&'a [Vec<Vector<D>>]>,
);

impl<const D: usize> G2pContext<'_, D>
where
    Dim<D>: DimOps<D>,
{
    /// Gathers from the grid and writes every particle's new state in place, with the guard
    /// checks. Returns the largest signal speed `max_p(|v_p| + c_p)` (m/s) of the new state
    /// when [`Self::signal_speed`] is set (0 otherwise), or the first (lowest-index) failing
    /// particle; the particles then hold the step's partial result. `blocks`, `grids` and, with
    /// FLIP, `velocity_old` have one entry per phase; each phase's block windows must hold its
    /// grid's velocities ([`Blocks::load_velocities`]). Only the first `active` particles are
    /// advanced and checked; the others keep their state.
    pub fn advance(
        &self,
        particles: &mut Particles<D>,
        blocks: &[Blocks<D>],
        grids: &[GridNodes<D>],
        velocity_old: Option<&[Vec<Vector<D>>]>,
        dt: Real,
        active: usize,
    ) -> Result<Real, (Location, Violation, Real)> {
        type Fault = Option<(usize, Violation, Real)>;
        fn first(a: Fault, b: Fault) -> Fault {
            match (a, b) {
                (Some(a), Some(b)) => Some(if a.0 <= b.0 { a } else { b }),
                (a, b) => a.or(b),
            }
        }
        let mut moving = Moving::take(particles);
        let fixed: &Particles<D> = particles;
        let scale = Scale {
            range: self.spec.stencil_range(self.kernel),
            inv_dx: 1.0 / self.spec.dx,
            minv: self.kernel.mls_inertia_inv(self.spec.dx),
        };
        let (fault, signal) = moving
            .chunks(CHUNK, active)
            .into_par_iter()
            .map(|mut chunk| {
                let run = (fixed, blocks, grids, velocity_old);
                match (self.kernel, scale.minv) {
                    (Kernel::Quadratic, Some(_)) => self.run::<3>(run, &mut chunk, dt, &scale),
                    (Kernel::Cubic, Some(_)) => self.run::<4>(run, &mut chunk, dt, &scale),
                    _ => self.run::<0>(run, &mut chunk, dt, &scale),
                }
            })
            .reduce(|| (None, 0.0), |a, b| (first(a.0, b.0), nan_max(a.1, b.1)));
        moving.put_back(particles);
        match fault {
            Some((p, violation, value)) => Err((Location::Particle(p), violation, value)),
            None => Ok(signal),
        }
    }

    /// Advances the particles of `chunk` in order (see [`Self::advance`]); returns the first
    /// fault and the largest signal speed. With `S > 0` (quadratic, cubic) each particle's
    /// stencil of `S` nodes per axis is built while the particle before it is advanced, so
    /// the stencil's latency chain (floor, weights) overlaps that particle's gather and
    /// update instead of delaying its own gather; with `S = 0` (linear) there is none.
    fn run<const S: usize>(
        &self,
        (fixed, blocks, grids, velocity_old): Inputs<'_, D>,
        chunk: &mut Chunk<'_, D>,
        dt: Real,
        scale: &Scale<D>,
    ) -> (Option<(usize, Violation, Real)>, Real) {
        let (mut fault, mut signal) = (None, 0.0);
        let n = chunk.x.len();
        let stencil =
            |x: &Vector<D>| AxisStencil::<D, S>::new(self.kernel, self.spec, scale.inv_dx, x);
        let mut ahead = [AxisStencil::<D, S>::ZERO; 2];
        if S > 0 && n > 0 {
            ahead[0] = stencil(&chunk.x[0]);
        }
        for i in 0..n {
            if S > 0 && i + 1 < n {
                ahead[(i + 1) % 2] = stencil(&chunk.x[i + 1]);
            }
            let st = (S > 0).then_some(&ahead[i % 2]);
            let p = chunk.start + i;
            let k = fixed.phase_of(p) as usize;
            let v0 = velocity_old.map(|v| v[k].as_slice());
            let window = blocks[k].velocities(p);
            let source = (window, &grids[k], v0, st);
            let (check, c) = self.particle(fixed, source, p, dt, scale, (chunk, i));
            signal = nan_max(signal, c);
            if fault.is_none() {
                fault = check.map(|(violation, value)| (p, violation, value));
            }
        }
        (fault, signal)
    }

    /// The PIC velocity, FLIP increment and C of a particle at `xp` over the general stencil
    /// (any kernel; nodes outside the grid or not stored are skipped).
    fn gather_nodes(
        &self,
        grid: &GridNodes<D>,
        velocity_old: Option<&[Vector<D>]>,
        minv: Option<Real>,
        xp: &Vector<D>,
    ) -> Gathered<D> {
        let spec = self.spec;
        let (mut v_pic, mut dv, mut c) = (
            Vector::<D>::zeros(),
            Vector::<D>::zeros(),
            Matrix::<D>::zeros(),
        );
        Stencil::new(self.kernel, spec, xp).for_each(|node, w, grad| {
            let Some(i) = self.layout.index(&node) else {
                return;
            };
            let vi = grid.velocity[i];
            let d = spec.node_position(&node) - xp;
            v_pic += vi * w;
            c += vi * mls_gradient(minv, w, &grad, &d).transpose();
            if let Some(v0) = velocity_old {
                dv += (vi - v0[i]) * w;
            }
        });
        (v_pic, dv, c)
    }

    fn gather<const S: usize>(
        &self,
        (window, grid, velocity_old, st): Source<'_, D, S>,
        scale: &Scale<D>,
        xp: &Vector<D>,
    ) -> Gathered<D> {
        let rows = match (window, scale.minv, st) {
            (Some(win), Some(minv), Some(st)) => match velocity_old {
                None => gather_rows::<D, S, false>(&win, minv, st),
                Some(_) => gather_rows::<D, S, true>(&win, minv, st),
            },
            _ => None,
        };
        rows.unwrap_or_else(|| self.gather_nodes(grid, velocity_old, scale.minv, xp))
    }

    /// Advances particle `p`, entry `i` of `chunk`, in place: its new state is written to the
    /// chunk here rather than returned, so it goes from registers to its columns without a
    /// copy through the stack (a 192-byte `memcpy` per particle in 3D). Returns its guard
    /// check and its signal speed.
    fn particle<const S: usize>(
        &self,
        particles: &Particles<D>,
        source: Source<'_, D, S>,
        p: usize,
        dt: Real,
        scale: &Scale<D>,
        (chunk, i): (&mut Chunk<'_, D>, usize),
    ) -> (Option<(Violation, Real)>, Real) {
        let old = chunk.old(i);
        let spec = self.spec;
        let xp = old.x;
        let (v_pic, dv, c) = self.gather(source, scale, &xp);
        let mut v = match self.transfer {
            Transfer::Flip { blend } => (old.v + dv) * blend + v_pic * (1.0 - blend),
            Transfer::Apic | Transfer::Pic => v_pic,
        };
        if let Some(sw) = self.soft_walls {
            soften(spec, &sw, &xp, &mut v);
        }
        let mut u = Update {
            x: xp + v * dt,
            v,
            c,
            f: old.f,
            j: old.j,
            plastic: old.plastic.unwrap_or_default(),
        };
        let material = self.materials.get(particles, p);
        let grad_step = Matrix::<D>::identity() + c * dt;
        match material.as_ref() {
            Material::Solid(s) => {
                let f_trial = grad_step * old.f;
                u.f = match old.plastic {
                    Some(state) => {
                        let (f, state) = s.return_mapping(f_trial, state);
                        u.plastic = state;
                        f
                    }
                    None => f_trial,
                };
                u.j = Dim::<D>::det(&u.f);
            }
            Material::Fluid(_) => {
                u.j = (1.0 + dt * c.trace()) * old.j;
            }
        }
        let fault = check(spec, &scale.range, &material, &u, dt);
        // The same expression as `ExplicitSolver::stable_dt` evaluates on the committed state.
        let signal = match (self.signal_speed, material.as_ref()) {
            (false, _) => 0.0,
            (true, Material::Solid(s)) => u.v.norm() + s.wave_speed(u.j, &u.plastic),
            (true, Material::Fluid(f)) => u.v.norm() + f.sound_speed(u.j),
        };
        chunk.write(i, &u);
        (fault, signal)
    }

    /// The multi-grid particle state after the step: volume fraction φ_p (Eqs. 19–20) and the
    /// effective fraction φ_eff, the diffused concentration, and the dissolution progress.
    pub fn gather_extra(
        &self,
        particles: &Particles<D>,
        grids: &[GridNodes<D>],
        ctx: &ExtraContext<'_>,
        extras: &mut Vec<Extra>,
        dt: Real,
    ) {
        (0..particles.len())
            .into_par_iter()
            .map(|p| self.extra(particles, grids, ctx, p, dt))
            .collect_into_vec(extras);
    }

    fn extra(
        &self,
        particles: &Particles<D>,
        grids: &[GridNodes<D>],
        ctx: &ExtraContext<'_>,
        p: usize,
        dt: Real,
    ) -> Extra {
        let spec = self.spec;
        let k = particles.phase_of(p) as usize;
        let dissolving = ctx.dissolution.filter(|d| d.solid == particles.material[p]);
        let (mut phi, mut wet, mut c_bar) = (0.0, 0.0, 0.0);
        Stencil::new(self.kernel, spec, &particles.x[p]).for_each(|node, w, _| {
            let Some(i) = self.layout.index(&node) else {
                return;
            };
            if ctx.porous.is_some()
                && grids[k].mass[i] > 0.0
                && grids
                    .iter()
                    .enumerate()
                    .any(|(j, g)| j != k && g.mass[i] > 0.0)
            {
                phi += w;
            }
            if let Some(d) = dissolving {
                if grids[d.fluid_phase as usize].mass[i] > 0.0 {
                    wet += w;
                }
                c_bar += w * ctx.node_concentration.get(i).copied().unwrap_or(0.0);
            }
        });
        let mut e = Extra {
            phi_eff: particles.volume_fraction_of(p),
            concentration: ctx
                .alpha
                .map_or_else(|| particles.concentration_of(p), |a| a[p]),
            dissolve: false,
        };
        // Σ w = 1 holds to round-off only: keep fractions in [0, 1].
        if let Some(porous) = ctx.porous {
            e.phi_eff = porous.update.update(e.phi_eff, phi.min(1.0), dt);
        }
        if let Some(d) = dissolving {
            let fresh = (1.0 - c_bar).clamp(0.0, 1.0);
            e.concentration = (e.concentration + dt * d.rate * wet.min(1.0) * fresh).min(1.0);
            e.dissolve = e.concentration >= 1.0;
        }
        e
    }
}

/// The PIC velocity, FLIP increment and C of the particle with stencil `st`, by rows of the
/// stencil read from its block's window (`FLIP`: with the FLIP increment, zero otherwise).
/// `None` when the stencil leaves the window.
fn gather_rows<const D: usize, const S: usize, const FLIP: bool>(
    win: &Window<'_, D>,
    minv: Real,
    st: &AxisStencil<D, S>,
) -> Option<Gathered<D>> {
    let (origin, width) = (win.window.origin(), win.window.width());
    let outside = |a: usize| {
        let b = st.base[a] - origin[a];
        b < 0 || b as usize + S > width
    };
    if (0..D).any(outside) {
        return None;
    }
    let (first, stride) = (win.window.local(&st.base), win.window.strides());
    let (mut v, mut dv, mut b) = (
        Vector::<D>::zeros(),
        Vector::<D>::zeros(),
        Matrix::<D>::zeros(),
    );
    st.for_each_row(first, &stride, |i0, wr, dr| {
        let row = &win.velocity[i0..i0 + S];
        // The row sums start from the first node's terms rather than from +0, which cost 2·D
        // additions per row: `+0 + t` is `t` for every t but −0, and a row sum's sign of zero
        // cannot reach the result, because `v` and `b` start at +0 and a sum is −0 only when
        // both terms are, so they never hold −0 (test: row_gather_never_returns_negative_zero).
        // (`dv` adds each node's term directly, as before.)
        let (mut sum, mut col0) = (Vector::<D>::zeros(), Vector::<D>::zeros());
        for i in 0..S {
            let w = st.w[0][i] * wr;
            let wv = row[i] * w;
            if i == 0 {
                (sum, col0) = (wv, wv * st.d[0][0]);
            } else {
                sum += wv;
                col0 += wv * st.d[0][i];
            }
            if FLIP {
                dv += (row[i] - win.old[i0 + i]) * w;
            }
        }
        v += sum;
        let mut c0 = b.column_mut(0);
        c0 += col0;
        for a in 1..D {
            let mut ca = b.column_mut(a);
            ca += sum * dr[a];
        }
    });
    Some((v, dv, b * minv))
}

/// Predictive softened walls: pushes the velocity back when `x + τ v` is within `margin` of the
/// grid box.
fn soften<const D: usize>(spec: &GridSpec<D>, sw: &SoftWalls, x: &Vector<D>, v: &mut Vector<D>) {
    let (lo, hi) = (spec.origin, spec.max_corner());
    for a in 0..D {
        let predicted = x[a] + sw.lookahead * v[a];
        let (wall_lo, wall_hi) = (lo[a] + sw.margin, hi[a] - sw.margin);
        if predicted < wall_lo {
            v[a] += (wall_lo - predicted) / sw.lookahead;
        } else if predicted > wall_hi {
            v[a] += (wall_hi - predicted) / sw.lookahead;
        }
    }
}

/// Guard checks on one particle's new state (DESIGN §6).
#[inline(always)]
fn check<const D: usize>(
    spec: &GridSpec<D>,
    range: &StencilRange<D>,
    material: &Material,
    u: &Update<D>,
    dt: Real,
) -> Option<(Violation, Real)> {
    // `c · 0` is ±0 for finite `c` and NaN otherwise, so the sum is zero exactly when every
    // value is finite: one test in the common case, the itemised tests only when it fails.
    // Summed by vectors, component-wise, so the additions are independent and packed.
    let probe =
        u.f.column_iter()
            .fold(u.v * 0.0 + u.x * 0.0, |sum, c| sum + c * 0.0);
    if probe.sum() + u.j * 0.0 != 0.0 {
        let finite = |m: &[Real]| m.iter().all(|c| c.is_finite());
        if !finite(u.v.as_slice()) {
            return Some((Violation::NonFinite("velocity"), u.v.norm()));
        }
        if !finite(u.x.as_slice()) {
            return Some((Violation::NonFinite("position"), u.x.norm()));
        }
        return Some((Violation::NonFinite("deformation"), u.j));
    }
    if u.j <= 0.0 && !material.defined_for_inverted() {
        return Some((Violation::InvertedElement, u.j));
    }
    if !range.contains(spec, &u.x) {
        return Some((Violation::LeftDomain, u.x.norm()));
    }
    let speed = u.v.norm();
    if speed * dt > spec.dx {
        return Some((Violation::CflExceeded, speed));
    }
    None
}

/// Writes the accepted multi-grid state: φ_eff, concentration and the mass of mixing particles
/// (`m = V⁰ ρ₀(α)`), and turns fully dissolved particles into fluid particles (see
/// [`Dissolution`]).
pub(crate) fn commit_extra<const D: usize>(
    particles: &mut Particles<D>,
    extras: &[Extra],
    materials: &[Material],
    mixing: Option<&Mixing>,
    dissolution: Option<&Dissolution>,
) {
    if let Some(f) = &mut particles.volume_fraction {
        f.par_iter_mut()
            .zip(extras)
            .for_each(|(f, e)| *f = e.phi_eff);
    }
    if let Some(c) = &mut particles.concentration {
        c.par_iter_mut()
            .zip(extras)
            .for_each(|(c, e)| *c = e.concentration);
    }
    if let Some(mix) = mixing {
        let view = MaterialView::new(materials, None, Some(mix));
        let masses: Vec<Option<Real>> = (0..particles.len())
            .into_par_iter()
            .map(|p| {
                mix.fluids
                    .contains(&particles.material[p])
                    .then(|| particles.volume0[p] * view.rest_density(particles, p))
            })
            .collect();
        for (m, new) in particles.mass.iter_mut().zip(masses) {
            if let Some(new) = new {
                *m = new;
            }
        }
    }
    if let Some(d) = dissolution {
        let rho = materials[d.into as usize].density();
        for p in (0..particles.len()).filter(|&p| extras[p].dissolve) {
            particles.material[p] = d.into;
            if let Some(k) = &mut particles.phase {
                k[p] = d.fluid_phase;
            }
            if let Some(c) = &mut particles.concentration {
                c[p] = 1.0;
            }
            if let Some(j) = &mut particles.jacobian {
                j[p] = 1.0;
            }
            if let Some(f) = &mut particles.def_grad {
                f[p] = Matrix::<D>::identity();
            }
            if let Some(s) = &mut particles.plastic {
                s[p] = PlasticState::default();
            }
            particles.volume0[p] = particles.mass[p] / rho;
        }
    }
}

#[cfg(test)]
mod tests;
