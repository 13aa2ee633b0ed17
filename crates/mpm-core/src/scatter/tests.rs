//! Checks of the block scatter: conservation, bitwise independence of the thread count and
//! equality with the plain serial scatter, prefetching, channel sets, the stable sort, and
//! the sparse layout with its window loads.

use super::*;
use crate::test_util::Lcg;
use crate::{Real, Stencil};

/// Particles: positions (m), masses (kg), velocities (m/s).
struct Cloud<const D: usize> {
    x: Vec<Vector<D>>,
    m: Vec<Real>,
    v: Vec<Vector<D>>,
}

/// `n` particles uniform in grid units `[2, size − 3]` (every kernel's stencil inside).
fn cloud<const D: usize>(spec: &GridSpec<D>, n: usize, seed: u64) -> Cloud<D> {
    let mut r = Lcg(seed);
    let x = (0..n)
        .map(|_| {
            Vector::<D>::from_fn(|a, _| {
                let span = (spec.size[a] - 5) as Real;
                spec.origin[a] + (2.0 + span * r.next()) * spec.dx
            })
        })
        .collect();
    let m = (0..n).map(|_| 0.5 + r.next()).collect();
    let v = (0..n)
        .map(|_| Vector::<D>::from_fn(|_, _| 4.0 * r.next() - 2.0))
        .collect();
    Cloud { x, m, v }
}

type Sums<const D: usize> = (Vec<Real>, Vec<Vector<D>>);

/// The sparse layout of the blocks `blocks` reaches.
fn layout_of<const D: usize>(spec: &GridSpec<D>, blocks: &Blocks<D>) -> NodeLayout<D> {
    let mut layout = NodeLayout::default();
    layout.begin(spec);
    blocks.mark(&mut layout);
    layout.finish();
    layout
}

/// Values stored in `layout`'s order spread onto the dense grid (zero where not stored).
fn to_dense<const D: usize, T: NodeValue>(
    spec: &GridSpec<D>,
    layout: &NodeLayout<D>,
    values: &[T],
) -> Vec<T> {
    assert_eq!(values.len(), layout.len());
    (0..spec.num_nodes())
        .map(|i| {
            layout
                .index(&spec.multi_index(i))
                .map_or(T::zero(), |k| values[k])
        })
        .collect()
}

/// Block scatter of `Σ w m` and `Σ w m v`, spread onto the dense grid.
fn block_scatter<const D: usize>(
    blocks: &Blocks<D>,
    buffers: &mut BlockBuffers<Sums<D>>,
    spec: &GridSpec<D>,
    kernel: Kernel,
    c: &Cloud<D>,
) -> Sums<D> {
    let layout = layout_of(spec, blocks);
    let (mut mass, mut momentum) = (Vec::new(), Vec::new());
    blocks.scatter(
        buffers,
        &layout,
        (&mut mass, &mut momentum),
        |p, window, (mb, pb)| {
            Stencil::new(kernel, spec, &c.x[p]).for_each(|node, w, _| {
                let k = window.local(&node);
                mb[k] += w * c.m[p];
                pb[k] += c.v[p] * (w * c.m[p]);
            });
        },
    );
    (
        to_dense(spec, &layout, &mass),
        to_dense(spec, &layout, &momentum),
    )
}

/// The plain serial scatter in particle order, straight into the grid.
fn serial_scatter<const D: usize>(
    spec: &GridSpec<D>,
    kernel: Kernel,
    c: &Cloud<D>,
    keep: impl Fn(usize) -> bool,
) -> Sums<D> {
    let mut mass = vec![0.0; spec.num_nodes()];
    let mut momentum = vec![Vector::<D>::zeros(); spec.num_nodes()];
    for p in (0..c.x.len()).filter(|&p| keep(p)) {
        Stencil::new(kernel, spec, &c.x[p]).for_each(|node, w, _| {
            let i = spec.linear_index(&node).unwrap();
            mass[i] += w * c.m[p];
            momentum[i] += c.v[p] * (w * c.m[p]);
        });
    }
    (mass, momentum)
}

fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

fn bits<const D: usize>((mass, momentum): &Sums<D>) -> Vec<u64> {
    let mut b: Vec<u64> = mass.iter().map(|m| m.to_bits()).collect();
    b.extend(momentum.iter().flat_map(|p| p.iter().map(|c| c.to_bits())));
    b
}

fn spec_2d() -> GridSpec<2> {
    GridSpec::new(Vector::<2>::new(-0.3, 0.1), 0.01, [100, 70])
}

fn spec_3d() -> GridSpec<3> {
    GridSpec::new(Vector::<3>::new(0.2, -0.1, 0.0), 0.02, [30, 26, 20])
}

fn conserves_and_ignores_threads<const D: usize>(spec: GridSpec<D>, kernel: Kernel) {
    let c = cloud(&spec, 4000, 3 + D as u64);
    let run = |threads: usize| {
        with_threads(threads, || {
            let mut blocks = Blocks::default();
            blocks.sort(&spec, kernel, &c.x);
            assert!(
                blocks.block_count() >= 20,
                "D = {D}: {} blocks",
                blocks.block_count()
            );
            assert_eq!(blocks.order().len(), c.x.len());
            let mut buffers = BlockBuffers::default();
            let first = block_scatter(&blocks, &mut buffers, &spec, kernel, &c);
            // Reused buffers give the same sums.
            assert_eq!(
                bits(&first),
                bits(&block_scatter(&blocks, &mut buffers, &spec, kernel, &c))
            );
            first
        })
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(
        bits(&one),
        bits(&two),
        "{kernel:?} D = {D}: 1 and 2 threads"
    );
    let total_m: Real = c.m.iter().sum();
    let total_p: Vector<D> = c.v.iter().zip(&c.m).map(|(v, m)| v * *m).sum();
    let grid_m: Real = one.0.iter().sum();
    let grid_p: Vector<D> = one.1.iter().sum();
    assert!(
        (grid_m - total_m).abs() <= 1e-12 * total_m,
        "mass {grid_m} vs {total_m}"
    );
    assert!(
        (grid_p - total_p).norm() <= 1e-12 * total_m,
        "momentum {grid_p} vs {total_p}"
    );
    // Node by node the same sums as the serial scatter, up to summation order.
    let serial = serial_scatter(&spec, kernel, &c, |_| true);
    for i in 0..spec.num_nodes() {
        assert!((one.0[i] - serial.0[i]).abs() <= 1e-13 * (1.0 + serial.0[i]));
        assert!((one.1[i] - serial.1[i]).norm() <= 1e-13 * (1.0 + serial.0[i]));
    }
}

#[test]
fn scatter_conserves_totals_and_is_bitwise_thread_count_independent() {
    for kernel in [Kernel::Linear, Kernel::Quadratic, Kernel::Cubic] {
        conserves_and_ignores_threads(spec_2d(), kernel);
        conserves_and_ignores_threads(spec_3d(), kernel);
    }
}

/// Positions on a 1/8-cell lattice, dyadic masses and velocities: every product and sum is
/// exact, so any summation order gives the same bits as the plain serial scatter.
fn dyadic_matches_serial<const D: usize>(size: [usize; D]) {
    let spec = GridSpec::new(Vector::<D>::zeros(), 0.125, size);
    let mut r = Lcg(11);
    let n = 3000;
    let c = Cloud {
        x: (0..n)
            .map(|_| {
                Vector::<D>::from_fn(|a, _| {
                    let eighths = 16 + (r.next() * (8 * (size[a] - 5)) as Real) as usize;
                    eighths as Real / 8.0 * spec.dx
                })
            })
            .collect(),
        m: (0..n)
            .map(|_| (1 + (r.next() * 16.0) as u32) as Real / 16.0)
            .collect(),
        v: (0..n)
            .map(|_| Vector::<D>::from_fn(|_, _| ((r.next() * 16.0) as i32 - 8) as Real / 4.0))
            .collect(),
    };
    let serial = serial_scatter(&spec, Kernel::Quadratic, &c, |_| true);
    for threads in [1, 2] {
        let sums = with_threads(threads, || {
            let mut blocks = Blocks::default();
            blocks.sort(&spec, Kernel::Quadratic, &c.x);
            block_scatter(
                &blocks,
                &mut BlockBuffers::default(),
                &spec,
                Kernel::Quadratic,
                &c,
            )
        });
        assert_eq!(bits(&sums), bits(&serial), "D = {D}, {threads} threads");
    }
    // The sums are exact: Σ_i m_i = Σ_p m_p to the last bit.
    let total: Real = c.m.iter().sum();
    assert_eq!(serial.0.iter().sum::<Real>(), total);
}

#[test]
fn exact_scatter_equals_the_plain_serial_scatter_bitwise() {
    dyadic_matches_serial([70, 50]);
    dyadic_matches_serial([30, 22, 20]);
}

/// The prefetching scatter announces, before each particle of a block, the particle
/// `PREFETCH_AHEAD` places later in that block's order (none near the block's end, none
/// from another block), and its sums are bitwise those of the plain scatter, on 1 and 2
/// threads.
#[test]
fn prefetching_scatter_announces_each_blocks_later_particles() {
    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Event {
        Ahead(usize),
        Scatter(usize),
    }
    let (spec, kernel) = (spec_3d(), Kernel::Quadratic);
    let c = cloud(&spec, 3000, 11);
    let mut blocks = Blocks::default();
    blocks.sort(&spec, kernel, &c.x);
    let plain = block_scatter(&blocks, &mut BlockBuffers::default(), &spec, kernel, &c);
    let layout = layout_of(&spec, &blocks);
    let ahead = Blocks::<3>::PREFETCH_AHEAD;
    for threads in [1, 2] {
        let log = std::sync::Mutex::new(Vec::new());
        let (mut mass, mut momentum) = (Vec::new(), Vec::new());
        with_threads(threads, || {
            blocks.scatter_prefetching(
                &mut BlockBuffers::default(),
                &layout,
                (&mut mass, &mut momentum),
                |q| log.lock().unwrap().push(Event::Ahead(q)),
                |p, window, (mb, pb)| {
                    log.lock().unwrap().push(Event::Scatter(p));
                    Stencil::new(kernel, &spec, &c.x[p]).for_each(|node, w, _| {
                        let k = window.local(&node);
                        mb[k] += w * c.m[p];
                        pb[k] += c.v[p] * (w * c.m[p]);
                    });
                },
            )
        });
        let dense = (
            to_dense(&spec, &layout, &mass),
            to_dense(&spec, &layout, &momentum),
        );
        assert_eq!(bits(&dense), bits(&plain));
        // Each block's events, in the order they happened, are exactly the expected ones.
        let log = log.into_inner().unwrap();
        let block_of = |e: &Event| {
            let (Event::Ahead(p) | Event::Scatter(p)) = *e;
            blocks
                .ranges
                .iter()
                .position(|&(_, s, e)| blocks.order[s..e].contains(&(p as u32)))
        };
        let mut long = 0;
        for (b, &(_, start, end)) in blocks.ranges.iter().enumerate() {
            let ids: Vec<usize> = blocks.order[start..end]
                .iter()
                .map(|&p| p as usize)
                .collect();
            let mut expected = Vec::new();
            for k in 0..ids.len() {
                if k + ahead < ids.len() {
                    expected.push(Event::Ahead(ids[k + ahead]));
                }
                expected.push(Event::Scatter(ids[k]));
            }
            let seen: Vec<Event> = log
                .iter()
                .filter(|e| block_of(e) == Some(b))
                .copied()
                .collect();
            assert_eq!(seen, expected, "block {b}");
            long += usize::from(ids.len() > ahead);
        }
        assert_eq!(
            log.len(),
            2 * 3000
                - blocks
                    .ranges
                    .iter()
                    .map(|&(_, s, e)| (e - s).min(ahead))
                    .sum::<usize>()
        );
        // The cloud has blocks both longer and shorter than the look-ahead.
        assert!(
            long > 0 && long < blocks.ranges.len(),
            "{long} of {}",
            blocks.ranges.len()
        );
    }
}

#[test]
fn channel_sets_compose() {
    let spec = spec_2d();
    let kernel = Kernel::Quadratic;
    let c = cloud(&spec, 3000, 5);
    let mut blocks = Blocks::default();
    blocks.sort(&spec, kernel, &c.x);
    let mut buffers = BlockBuffers::default();
    let both = block_scatter(&blocks, &mut buffers, &spec, kernel, &c);
    let window_len = (Blocks::<2>::BLOCK_CELLS + 2).pow(2);
    let per_block = window_len * (8 + 16);
    assert_eq!(buffers.bytes(), blocks.block_count() * per_block);
    let layout = layout_of(&spec, &blocks);
    let (mut mass, mut momentum) = (Vec::new(), Vec::new());
    blocks.scatter(
        &mut BlockBuffers::default(),
        &layout,
        (&mut mass,),
        |p, window, (mb,)| {
            Stencil::new(kernel, &spec, &c.x[p]).for_each(|node, w, _| {
                mb[window.local(&node)] += w * c.m[p];
            });
        },
    );
    blocks.scatter(
        &mut BlockBuffers::default(),
        &layout,
        (&mut momentum,),
        |p, window, (pb,)| {
            Stencil::new(kernel, &spec, &c.x[p]).for_each(|node, w, _| {
                pb[window.local(&node)] += c.v[p] * (w * c.m[p]);
            });
        },
    );
    let separate = (
        to_dense(&spec, &layout, &mass),
        to_dense(&spec, &layout, &momentum),
    );
    assert_eq!(bits(&both), bits(&separate));

    // Three channels of other types, one of them switched off: a u32 count of the
    // particle–node pairs and an absent channel, which leaves its block buffers empty.
    let (mut mass, mut count) = (Vec::<Real>::new(), Vec::<u32>::new());
    let mut buffers3 = BlockBuffers::default();
    let off: Option<&mut Vec<Vector<2>>> = None;
    blocks.scatter(
        &mut buffers3,
        &layout,
        (&mut mass, off, Some(&mut count)),
        |p, window, (mb, unused, nb)| {
            assert!(unused.is_empty());
            Stencil::new(kernel, &spec, &c.x[p]).for_each(|node, w, _| {
                let k = window.local(&node);
                mb[k] += w * c.m[p];
                nb[k] += 1;
            });
        },
    );
    assert_eq!(mass.len(), layout.len());
    assert!(to_dense(&spec, &layout, &mass)
        .iter()
        .zip(&both.0)
        .all(|(a, b)| a.to_bits() == b.to_bits()));
    assert_eq!(count.iter().sum::<u32>(), 3000 * 9);
    assert_eq!(
        buffers3.bytes(),
        blocks.block_count() * window_len * (8 + 4)
    );
}

/// The parallel counting sort gives, for any number of threads (runs), the serial stable
/// sort: each kept particle once, in its own block's range, ascending within a range.
#[test]
fn sort_is_stable_and_the_same_for_any_thread_count() {
    let spec = spec_2d();
    let kernel = Kernel::Quadratic;
    let c = cloud(&spec, 5000, 21);
    let keep = |p: usize| p % 7 != 3;
    let sorted = |threads: usize| {
        with_threads(threads, || {
            let mut blocks = Blocks::default();
            blocks.sort_where(&spec, kernel, &c.x, keep);
            blocks
        })
    };
    let one = sorted(1);
    let kept: Vec<u32> = (0..5000u32).filter(|&p| keep(p as usize)).collect();
    let mut seen = one.order().to_vec();
    seen.sort_unstable();
    assert_eq!(seen, kept);
    for (r, &(id, start, end)) in one.ranges.iter().enumerate() {
        let run = &one.order()[start..end];
        assert!(
            run.windows(2).all(|w| w[0] < w[1]),
            "block {id} not ascending"
        );
        for &p in run {
            let (rank, window) = one.window_of(p as usize).unwrap();
            assert_eq!(rank, r);
            let base = Stencil::new(kernel, &spec, &c.x[p as usize]).base;
            let b = Blocks::<2>::BLOCK_CELLS as i64;
            assert!((0..2).all(|a| (0..b).contains(&(base[a] - window.origin()[a]))));
        }
    }
    assert!(one.window_of(3).is_none());
    for threads in [2, 3, 8] {
        let other = sorted(threads);
        assert_eq!(other.order(), one.order(), "{threads} threads");
        assert_eq!(other.ranges, one.ranges, "{threads} threads");
        assert_eq!(other.range_of, one.range_of, "{threads} threads");
    }
}

#[test]
fn sort_where_scatters_only_the_kept_particles() {
    let spec = spec_3d();
    let kernel = Kernel::Cubic;
    let c = cloud(&spec, 2000, 9);
    let keep = |p: usize| p % 3 == 1;
    let mut blocks = Blocks::default();
    blocks.sort_where(&spec, kernel, &c.x, keep);
    assert_eq!(blocks.order().len(), (0..2000).filter(|&p| keep(p)).count());
    assert!(blocks.order().iter().all(|&p| keep(p as usize)));
    let sums = block_scatter(&blocks, &mut BlockBuffers::default(), &spec, kernel, &c);
    let serial = serial_scatter(&spec, kernel, &c, keep);
    let kept: Real = (0..2000).filter(|&p| keep(p)).map(|p| c.m[p]).sum();
    assert!((sums.0.iter().sum::<Real>() - kept).abs() <= 1e-12 * kept);
    for i in 0..spec.num_nodes() {
        assert!((sums.0[i] - serial.0[i]).abs() <= 1e-13 * (1.0 + serial.0[i]));
        assert_eq!(sums.0[i] == 0.0, serial.0[i] == 0.0);
    }
}

/// A cloud in one corner of a large grid: the layout stores only the blocks it reaches,
/// the scatter still equals the plain serial one, and the windows loaded back from the
/// sparse storage give every particle its stencil's node values.
fn sparse_corner<const D: usize>(size: [usize; D], kernel: Kernel) {
    let spec = GridSpec::new(Vector::<D>::zeros(), 0.1, size);
    // Particles in grid units [2, 13]: the first two blocks along each axis (and their
    // overhang into the third in 3D).
    let mut r = Lcg(17);
    let n = 1500;
    let c = Cloud {
        x: (0..n)
            .map(|_| Vector::<D>::from_fn(|_, _| (2.0 + 11.0 * r.next()) * spec.dx))
            .collect(),
        m: (0..n).map(|_| 0.5 + r.next()).collect(),
        v: (0..n)
            .map(|_| Vector::<D>::from_fn(|_, _| r.next() - 0.5))
            .collect(),
    };
    let mut blocks = Blocks::default();
    blocks.sort(&spec, kernel, &c.x);
    let layout = layout_of(&spec, &blocks);
    // At most the first three blocks along each axis (two with particles, one overhang).
    assert!(layout.active().len() <= 3usize.pow(D as u32));
    assert_eq!(
        layout.len(),
        layout.active().len() * NodeLayout::<D>::BLOCK_NODES
    );
    assert!(layout.len() * 8 < spec.num_nodes(), "the layout is sparse");
    // Storage index and multi-index are inverse.
    for i in (0..layout.len()).step_by(7) {
        let node = layout.node(i);
        if (0..D).all(|a| (node[a] as usize) < size[a]) {
            assert_eq!(layout.index(&node), Some(i));
        }
    }
    assert_eq!(layout.index(&[size[0] as i64 - 1; D]), None);
    let mut buffers = BlockBuffers::default();
    let sums = block_scatter(&blocks, &mut buffers, &spec, kernel, &c);
    let serial = serial_scatter(&spec, kernel, &c, |_| true);
    for i in 0..spec.num_nodes() {
        assert!((sums.0[i] - serial.0[i]).abs() <= 1e-13 * (1.0 + serial.0[i]));
        assert!((sums.1[i] - serial.1[i]).norm() <= 1e-13 * (1.0 + serial.0[i]));
    }
    // Node values (here m_i + 1 at stored nodes) read back through the windows.
    let mut stored_values = vec![0.0; layout.len()];
    for (k, v) in stored_values.iter_mut().enumerate() {
        let node = layout.node(k);
        if let Some(i) = spec.linear_index(&node) {
            *v = serial.0[i] + 1.0;
        }
    }
    blocks.load_windows(&mut buffers, &layout, &stored_values, |s| &mut s.0);
    for p in 0..n {
        let (r, window) = blocks.window_of(p).unwrap();
        let values = &buffers.get(r).0;
        Stencil::new(kernel, &spec, &c.x[p]).for_each(|node, _, _| {
            let i = spec.linear_index(&node).unwrap();
            assert_eq!(values[window.local(&node)], serial.0[i] + 1.0);
        });
    }
}

#[test]
fn sparse_layout_stores_only_the_reached_blocks_and_windows_read_them_back() {
    for kernel in [Kernel::Linear, Kernel::Quadratic, Kernel::Cubic] {
        sparse_corner([200, 150], kernel);
        sparse_corner([90, 80, 70], kernel);
    }
    // The dense layout stores every block.
    let spec = GridSpec::<3>::new(Vector::<3>::zeros(), 0.1, [17, 9, 8]);
    let dense = NodeLayout::dense(&spec);
    assert_eq!(dense.active().len(), 3 * 2);
    for i in 0..spec.num_nodes() {
        let node = spec.multi_index(i);
        assert_eq!(dense.node(dense.index(&node).unwrap()), node);
    }
}
