//! The explicit MLS-MPM solver on several ranks.
//!
//! Each rank runs an [`ExplicitSolver`] on its own particles followed by *halo copies*: the
//! particles of other ranks whose stencils reach, within the step's chain of transfers, the
//! grid nodes its own particles read. A step then is, on every rank:
//!
//! 1. repartition when due (every `K` steps, and before the first);
//! 2. migration: particles whose block another rank owns move there;
//! 3. halo exchange: copies of the particles near each rank's blocks go to that rank;
//! 4. the serial step on own particles plus halo ([`ExplicitSolver::step_among`]): every
//!    transfer runs over both, G2P advances the own particles only; dt and the outcome of each
//!    attempt are agreed between ranks.
//!
//! Why the result is bitwise the one-process result: the scatter sums each node's
//! contributions block by block in ascending block id and, within a block, in particle order
//! (`mpm_core::scatter`). A rank's particles are ordered by global id (own first, then halo;
//! a block's particles all belong to one rank, so within each block the order is the global
//! one), and it holds every particle that contributes to a node its own particles read; the
//! blocks it does not hold contribute nothing to those nodes. So every node an own particle
//! reads receives the same terms in the same order as in one process, and G2P computes the
//! same new state. Chains of transfers within one step widen the halo: when volumes are
//! re-estimated from the grid density or the concentration diffuses with the kernel-gradient
//! scheme, the halo particles' own gathered values must be right too, so the halo reaches two
//! stencil widths; mirrored walls add the reflection across the wall. The time step is the
//! minimum over ranks of each rank's bound (each a decreasing function of its largest signal
//! speed), exactly the one-process bound, and failures are ordered as a serial step would
//! meet them.

use crate::comm::Comm;
use crate::partition::{block_nodes, for_each_in_box, morton, Locator, OwnerMap, Partition};
use crate::wire::{decode_particles, encode_particles, WireFailure};
use mpm_core::boundary::WallTreatment;
use mpm_core::{Dim, DimOps};
use mpm_core::{
    Failure, Location, Particles, Peers, Real, SetupError, Solver, Stage, StepError, StepInfo,
    Vector,
};
use mpm_explicit::{DiffusionScheme, ExplicitSolver, VolumeUpdate};
use std::collections::HashMap;
use std::convert::Infallible;
use std::time::{Duration, Instant};

/// What the ranks sent each other so far, on this rank.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Traffic {
    /// Bytes this rank sent (particles, their ids, and the agreements on dt and outcomes).
    pub bytes_sent: u64,
    /// Halo copies this rank received, summed over steps.
    pub halo_particles: u64,
    /// Particles that moved to this rank, summed over steps.
    pub arrived: u64,
    /// Wall time in exchanges (packing, communication, unpacking), including waits for
    /// slower ranks.
    pub time: Duration,
}

/// One rank's part of an explicit MLS-MPM run.
#[derive(Debug)]
pub struct DistributedExplicit<const D: usize, C: Comm> {
    comm: C,
    solver: ExplicitSolver<D>,
    /// Global ids of the solver's particles: own ones ascending, then the halo.
    ids: Vec<u64>,
    /// Number of own particles (the first ones).
    owned: usize,
    /// Halo copies the last step used.
    halo: usize,
    partition: Partition,
    /// Where particles sit on the grid.
    at: Locator<D>,
    /// Owners of the blocks around this rank's particles, rebuilt after a repartition and
    /// whenever a particle leaves the box it covers.
    owners: OwnerMap<D>,
    /// Halo reach in nodes around a block.
    reach: i64,
    /// Steps between repartitions (0: only before the first step).
    every: u64,
    traffic: Traffic,
}

impl<const D: usize, C: Comm> DistributedExplicit<D, C>
where
    Dim<D>: DimOps<D>,
{
    /// This rank's part of the run of `solver`, which every rank passes with the same set-up
    /// and particles (global ids are particle indices). The rank keeps a contiguous slice of
    /// the particles until the first step's repartition moves each to the owner of its block;
    /// later repartitions come every `every` steps (0: never).
    pub fn new(comm: C, solver: ExplicitSolver<D>, every: u64) -> Result<Self, SetupError> {
        let n = solver.particles().len();
        let (rank, size) = (comm.rank(), comm.size());
        let slice: Vec<usize> = (n * rank / size..n * (rank + 1) / size).collect();
        let mut solver = solver;
        solver.replace_particles(solver.particles().select(&slice))?;
        let params = solver.params();
        let support = params.kernel.support() as i64;
        let hops = if params.volume == VolumeUpdate::Reestimate
            || params
                .mixing
                .is_some_and(|m| m.scheme == DiffusionScheme::KernelGradient)
        {
            2
        } else {
            1
        };
        let mirror = match &solver.boundaries().walls {
            Some(w) if w.treatment != WallTreatment::Nodes => 2 * (w.thickness as i64 + support),
            _ => 0,
        };
        Ok(Self {
            partition: Partition::on_first(size),
            at: Locator::new(solver.spec(), params.kernel),
            ids: slice.iter().map(|&p| p as u64).collect(),
            owned: slice.len(),
            halo: 0,
            comm,
            solver,
            owners: OwnerMap::default(),
            reach: hops * (support - 1 + mirror),
            every,
            traffic: Traffic::default(),
        })
    }

    /// Advances the whole run by one step: repartition when due, migration, halo exchange,
    /// then the step ([`ExplicitSolver::step_among`]). Every rank must call it.
    pub fn step(&mut self) -> Result<StepInfo, StepError<Infallible>> {
        let steps = self.solver.steps();
        let mut ps = self.solver.take_particles();
        ps.truncate(self.owned);
        self.ids.truncate(self.owned);
        if steps == 0 || (self.every > 0 && steps % self.every == 0) {
            self.repartition(&ps);
        }
        let ps = self.migrate(ps);
        let ps = self.exchange_halo(ps);
        self.solver
            .replace_particles(ps)
            .expect("particles that passed a step's checks fit the same set-up");
        let mut peers = RankPeers {
            comm: &self.comm,
            ids: &self.ids,
            stages: stage_order(&self.solver),
            bytes: 0,
        };
        let r = self.solver.step_among(self.owned, &mut peers);
        self.traffic.bytes_sent += peers.bytes;
        self.halo = self.ids.len() - self.owned;
        self.solver.truncate_particles(self.owned);
        self.ids.truncate(self.owned);
        r
    }

    /// Simulation time (s).
    pub fn time(&self) -> Real {
        self.solver.time()
    }

    /// Accepted steps.
    pub fn steps(&self) -> u64 {
        self.solver.steps()
    }

    /// This rank's own particles and their global ids.
    pub fn own_particles(&self) -> (&Particles<D>, &[u64]) {
        (self.solver.particles(), &self.ids)
    }

    /// Halo copies the last step used.
    pub fn halo_len(&self) -> usize {
        self.halo
    }

    /// The transport.
    pub fn comm(&self) -> &C {
        &self.comm
    }

    /// What this rank sent and received so far.
    pub fn traffic(&self) -> Traffic {
        self.traffic
    }

    /// The local solver (between steps it holds the own particles only).
    pub fn solver(&self) -> &ExplicitSolver<D> {
        &self.solver
    }

    /// Block coordinates of the particle at `x`: the block of its first stencil node.
    #[inline]
    fn block_of(&self, x: &Vector<D>) -> [i64; D] {
        self.at.block_of_node(&self.at.base(x))
    }

    /// The owner rank of block `block`: from the map, else from the partition (and then the
    /// map is stale).
    fn owner(&self, block: &[i64; D], stale: &mut bool) -> usize {
        self.owners.get(block).unwrap_or_else(|| {
            *stale = true;
            self.partition.owner(morton(block))
        })
    }

    /// Rebuilds the owner map over the blocks of `x`, widened by two blocks (particles move
    /// less than a cell per step).
    fn map_owners(&mut self, x: &[Vector<D>]) {
        let b = block_nodes::<D>();
        let (mut lo, mut hi) = ([i64::MAX; D], [i64::MIN; D]);
        for xp in x {
            let block = self.block_of(xp);
            for a in 0..D {
                lo[a] = lo[a].min(block[a]);
                hi[a] = hi[a].max(block[a]);
            }
        }
        let blocks: [i64; D] =
            std::array::from_fn(|a| self.solver.spec().size[a].div_ceil(b as usize) as i64);
        self.owners = OwnerMap::new(
            &self.partition,
            (lo.map(|l| l - 2), hi.map(|h| h + 2)),
            blocks,
        );
    }

    /// Recomputes the partition from every rank's particle count per block (`ps`: the own
    /// particles).
    fn repartition(&mut self, ps: &Particles<D>) {
        let t = Instant::now();
        let mut counts: HashMap<u64, u64> = HashMap::new();
        for x in &ps.x {
            *counts.entry(morton(&self.block_of(x))).or_insert(0) += 1;
        }
        let mut mine: Vec<(u64, u64)> = counts.into_iter().collect();
        mine.sort_unstable();
        let bytes: Vec<u8> = mine
            .iter()
            .flat_map(|&(k, c)| k.to_le_bytes().into_iter().chain(c.to_le_bytes()))
            .collect();
        self.traffic.bytes_sent += (bytes.len() * (self.comm.size() - 1)) as u64;
        let mut all: Vec<(u64, u64)> = self
            .comm
            .all_gather(bytes)
            .iter()
            .flat_map(|b| {
                b.chunks_exact(16).map(|c| {
                    let word = |k: usize| u64::from_le_bytes(c[k..k + 8].try_into().expect("8"));
                    (word(0), word(8))
                })
            })
            .collect();
        all.sort_unstable();
        let mut weights: Vec<(u64, u64)> = Vec::with_capacity(all.len());
        for (k, c) in all {
            match weights.last_mut() {
                Some(last) if last.0 == k => last.1 += c,
                _ => weights.push((k, c)),
            }
        }
        self.partition = Partition::balance(&weights, self.comm.size());
        self.owners = OwnerMap::default();
        self.traffic.time += t.elapsed();
    }

    /// Sends every own particle of `ps` whose block another rank owns to that rank and takes
    /// the particles other ranks send; returns the own particles, ordered by global id.
    fn migrate(&mut self, mut ps: Particles<D>) -> Particles<D> {
        let t = Instant::now();
        let (me, size) = (self.comm.rank(), self.comm.size());
        let mut stale = false;
        let mut leave = vec![Vec::new(); size];
        let mut keep = vec![true; ps.len()];
        for (p, x) in ps.x.iter().enumerate().filter(|_| size > 1) {
            let r = self.owner(&self.block_of(x), &mut stale);
            if r != me {
                leave[r].push(p);
                keep[p] = false;
            }
        }
        let received = self.send(&ps, &leave);
        if leave.iter().any(|l| !l.is_empty()) {
            ps.retain(&keep);
            let mut k = keep.iter();
            self.ids
                .retain(|_| *k.next().expect("one flag per particle"));
        }
        let mut arrived = 0;
        for (part, part_ids) in received {
            arrived += part_ids.len();
            ps.append(&part);
            self.ids.extend(part_ids);
        }
        if arrived > 0 && !self.ids.windows(2).all(|w| w[0] < w[1]) {
            let mut order: Vec<usize> = (0..self.ids.len()).collect();
            order.sort_unstable_by_key(|&k| self.ids[k]);
            ps = ps.select(&order);
            self.ids = order.iter().map(|&k| self.ids[k]).collect();
        }
        self.traffic.arrived += arrived as u64;
        self.owned = ps.len();
        if stale || arrived > 0 {
            self.map_owners(&ps.x);
        }
        self.traffic.time += t.elapsed();
        ps
    }

    /// Appends to the own particles `ps` copies of the other ranks' particles within the halo
    /// reach of this rank's blocks, in rank order (each rank's in id order).
    fn exchange_halo(&mut self, mut ps: Particles<D>) -> Particles<D> {
        let t = Instant::now();
        let (me, size, reach, b) = (
            self.comm.rank(),
            self.comm.size(),
            self.reach,
            block_nodes::<D>(),
        );
        let mut stale = false;
        let mut to = vec![Vec::new(); size];
        let mut dests = Vec::new();
        // Within one block of reach: a particle's halo box meets at most the next block on
        // each side, read from the owner map's neighbour table.
        let near = 2 * reach <= b;
        let alone = size == 1;
        for (p, x) in ps.x.iter().enumerate().filter(|_| !alone) {
            let base = self.at.base(x);
            let block = self.at.block_of_node(&base);
            dests.clear();
            match self.owners.index(&block).filter(|_| near) {
                Some(i) => {
                    let side: [i64; D] = std::array::from_fn(|a| {
                        let o = base[a] - block[a] * b;
                        (o + reach >= b) as i64 - (o < reach) as i64
                    });
                    if side == [0; D] {
                        continue;
                    }
                    let neighbours = self.owners.neighbours(i);
                    // The neighbours at offsets δ with δ_a ∈ {0, side_a}, δ ≠ 0: one bit per
                    // axis that moves.
                    'offsets: for bits in 1..1usize << D {
                        let (mut k, mut stride) = (0, 1);
                        for a in 0..D {
                            let d = if bits >> a & 1 == 1 { side[a] } else { 0 };
                            if bits >> a & 1 == 1 && d == 0 {
                                continue 'offsets;
                            }
                            k += (d + 1) as usize * stride;
                            stride *= 3;
                        }
                        let r = neighbours[k];
                        if r != u32::MAX && r as usize != me && !dests.contains(&(r as usize)) {
                            dests.push(r as usize);
                        }
                    }
                }
                None => {
                    let lo: [i64; D] = std::array::from_fn(|a| (base[a] - reach).div_euclid(b));
                    let hi: [i64; D] = std::array::from_fn(|a| (base[a] + reach).div_euclid(b));
                    for_each_in_box(&lo, &hi, |block| {
                        let node: [i64; D] = std::array::from_fn(|a| block[a] * b);
                        let r = self.owner(&self.at.block_of_node(&node), &mut stale);
                        if r != me && !dests.contains(&r) {
                            dests.push(r);
                        }
                    });
                }
            }
            for &r in &dests {
                to[r].push(p);
            }
        }
        for (part, part_ids) in self.send(&ps, &to) {
            self.traffic.halo_particles += part_ids.len() as u64;
            ps.append(&part);
            self.ids.extend(part_ids);
        }
        if stale {
            self.map_owners(&ps.x[..self.owned]);
        }
        self.traffic.time += t.elapsed();
        ps
    }

    /// Sends the particles `to[r]` of `ps` to each rank `r`; returns what each rank sent here,
    /// in rank order.
    fn send(&mut self, ps: &Particles<D>, to: &[Vec<usize>]) -> Vec<(Particles<D>, Vec<u64>)> {
        let out: Vec<Vec<u8>> = to
            .iter()
            .map(|idx| {
                let mut bytes = Vec::new();
                if !idx.is_empty() {
                    let ids: Vec<u64> = idx.iter().map(|&p| self.ids[p]).collect();
                    encode_particles(ps, idx, &ids, &mut bytes);
                }
                bytes
            })
            .collect();
        self.traffic.bytes_sent += out.iter().map(|m| m.len() as u64).sum::<u64>();
        let materials = self.solver.materials().len();
        self.comm
            .exchange(out)
            .iter()
            .map(|m| {
                decode_particles(m, ps, materials)
                    .expect("a rank decodes what a rank of the same build encoded")
            })
            .collect()
    }
}

/// The stages in the order a step meets them: time step selection, then the plan.
fn stage_order<const D: usize>(solver: &ExplicitSolver<D>) -> Vec<Stage>
where
    Dim<D>: DimOps<D>,
{
    let mut stages = vec![Stage::TIME_STEP];
    stages.extend(solver.plan().ids());
    stages
}

/// The ranks' agreement on dt and on the outcome of each attempt, over [`Comm::all_gather`].
struct RankPeers<'a, C: Comm> {
    comm: &'a C,
    ids: &'a [u64],
    stages: Vec<Stage>,
    bytes: u64,
}

impl<C: Comm> RankPeers<'_, C> {
    /// Gathers every rank's outcome (a value or a failure) and returns the agreed one: the
    /// failure a serial step meets first when any rank failed, else `pick` of the values.
    fn settle<T: Copy>(
        &mut self,
        local: Result<T, Failure<Infallible>>,
        encode: impl Fn(T) -> [u8; 8],
        decode: impl Fn([u8; 8]) -> T,
        pick: impl Fn(T, T) -> T,
    ) -> Result<T, Failure<Infallible>> {
        let mut bytes = Vec::new();
        match &local {
            Ok(v) => {
                bytes.push(0);
                bytes.extend_from_slice(&encode(*v));
            }
            Err(f) => {
                bytes.push(1);
                self.wire(f).encode(&mut bytes);
            }
        }
        self.bytes += (bytes.len() * (self.comm.size() - 1)) as u64;
        let all = self.comm.all_gather(bytes);
        let failure = all
            .iter()
            .filter(|m| m[0] == 1)
            .map(|m| WireFailure::decode(&m[1..]).expect("a failure encoded by a peer"))
            .min_by_key(|f| f.key(&self.stages));
        if let Some(f) = failure {
            let stage = self
                .stages
                .iter()
                .copied()
                .find(|s| s.name() == f.stage)
                .unwrap_or(Stage::TIME_STEP);
            return Err(Failure::Guard(stage, (f.location, f.violation, f.value)));
        }
        Ok(all
            .iter()
            .map(|m| decode(m[1..9].try_into().expect("8 bytes")))
            .reduce(pick)
            .expect("at least one rank"))
    }

    /// The failure with particles named by global id.
    fn wire(&self, f: &Failure<Infallible>) -> WireFailure {
        match f {
            Failure::Guard(stage, (location, violation, value)) => WireFailure {
                stage: stage.name().to_string(),
                location: match *location {
                    Location::Particle(p) => Location::Particle(self.ids[p] as usize),
                    other => other,
                },
                violation: *violation,
                value: *value,
            },
            Failure::Solve(_, e) => match *e {},
        }
    }
}

impl<C: Comm> Peers<Infallible> for RankPeers<'_, C> {
    fn agree_dt(
        &mut self,
        local: Result<Real, Failure<Infallible>>,
    ) -> Result<Real, Failure<Infallible>> {
        self.settle(local, Real::to_le_bytes, Real::from_le_bytes, Real::min)
    }

    fn agree(&mut self, local: Result<(), Failure<Infallible>>) -> Result<(), Failure<Infallible>> {
        self.settle(local, |()| [0; 8], |_| (), |(), ()| ())
    }
}
