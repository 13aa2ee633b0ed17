//! Checks of the symmetric block patterns (slots, refills, products, invalid input) against
//! dense matrices, and of the DoF map.

use super::*;

/// Block couplings of a small irregular graph on 7 blocks (both orders, repeats).
fn irregular_couplings() -> Vec<(usize, usize)> {
    vec![
        (0, 3),
        (3, 0),
        (1, 2),
        (6, 1),
        (2, 5),
        (4, 4),
        (5, 6),
        (0, 6),
        (2, 1),
        (3, 5),
    ]
}

#[test]
fn block_slots_agree_with_the_scalar_pattern() {
    let bs = 3;
    let couplings = irregular_couplings();
    let p = SymmetricPattern::from_block_couplings(7, bs, couplings.iter().copied()).unwrap();
    let q = SymmetricPattern::from_block_rows(7, bs, |i, out| {
        for &(a, b) in &couplings {
            if a == i {
                out.push(b);
            }
            if b == i {
                out.push(a);
            }
        }
    })
    .unwrap();
    assert_eq!((p.col_ptr(), p.row_idx()), (q.col_ptr(), q.row_idx()));
    assert_eq!((p.dim(), p.num_blocks(), p.block_size()), (21, 7, 3));
    // Block columns: 7 diagonal blocks (6 lower entries each) + 7 distinct off-diagonal pairs.
    assert_eq!(p.nnz(), 7 * 6 + 7 * 9);
    assert_eq!(p.block_column_blocks(1).collect::<Vec<_>>(), vec![1, 2, 6]);
    assert_eq!(p.block_column_blocks(6).collect::<Vec<_>>(), vec![6]);
    // Every stored entry through the block view has the slot of the scalar lookup.
    let mut a = SymmetricMatrix::new(p.clone());
    let starts: Vec<usize> = (0..7).map(|i| p.block_column_range(i).start).collect();
    a.refill_block_columns(|col| {
        let i = col.block();
        for k in 0..col.num_blocks() {
            let j = col.block_row(k);
            assert_eq!(col.position(j), Some(k));
            for b in 0..bs {
                for r in 0..bs {
                    if k == 0 && r < b {
                        continue;
                    }
                    let slot = starts[i] + col.slot(k, r, b);
                    assert_eq!(p.slot(j * bs + r, i * bs + b), Some(slot));
                    assert_eq!(p.slot(i * bs + b, j * bs + r), Some(slot));
                    col.set(k, r, b, (j * bs + r) as f64 * 100.0 + (i * bs + b) as f64);
                }
            }
        }
        assert_eq!(col.position(i + 100), None);
    });
    // Every slot was written exactly once with its (row, col) code.
    let dense = a.to_dense();
    for c in 0..21 {
        for r in c..21 {
            let expected = match p.slot(r, c) {
                Some(_) => r as f64 * 100.0 + c as f64,
                None => 0.0,
            };
            assert_eq!(dense[(r, c)], expected);
            assert_eq!(dense[(c, r)], expected);
        }
    }
    assert_eq!(p.slot(0, 4), None);
    assert_eq!(p.slot(0, 21), None);
}

#[test]
fn refilling_a_pattern_gives_a_fresh_assembly() {
    let assemble_fresh = |seed: f64| {
        let p = SymmetricPattern::from_block_couplings(7, 2, irregular_couplings()).unwrap();
        let mut m = SymmetricMatrix::new(p.clone());
        let mut values = samples(seed, p.nnz()).into_iter();
        for c in 0..p.dim() {
            for k in p.col_ptr()[c]..p.col_ptr()[c + 1] {
                m.add(p.row_idx()[k], c, values.next().unwrap()).unwrap();
            }
        }
        m
    };
    let p = SymmetricPattern::from_block_couplings(7, 2, irregular_couplings()).unwrap();
    let mut m = SymmetricMatrix::new(p);
    let ptr = m.values().as_ptr();
    for seed in [1.0, 2.0] {
        // Refill by slot, after values of another state.
        m.values_mut().fill(7.0);
        m.set_zero();
        let mut values = samples(seed, m.pattern().nnz()).into_iter();
        for c in 0..m.pattern().dim() {
            for k in m.pattern().col_ptr()[c]..m.pattern().col_ptr()[c + 1] {
                let r = m.pattern().row_idx()[k];
                m.add(c, r, values.next().unwrap()).unwrap();
            }
        }
        let fresh = assemble_fresh(seed);
        assert_eq!(m.values(), fresh.values());
        assert_eq!(m.to_dense(), fresh.to_dense());
        assert_eq!(m.values().as_ptr(), ptr, "refill must not reallocate");
    }
    assert_eq!(
        m.add(0, 8, 1.0),
        Err(PatternError::NotInPattern { row: 0, col: 8 })
    );
    // The product agrees with the dense one.
    let x: Vec<f64> = (0..14).map(|i| (i as f64).sin()).collect();
    let mut y = vec![0.0; 14];
    m.mul_vec(&x, &mut y);
    let yd = m.to_dense() * DVector::from_column_slice(&x);
    assert!(rel_diff(&y, yd.as_slice()) < 1e-15);
}

#[test]
fn invalid_patterns_are_rejected() {
    assert_eq!(
        SymmetricPattern::from_couplings(3, [(0, 3)]).unwrap_err(),
        PatternError::OutOfRange {
            what: "block",
            index: 3,
            len: 3
        }
    );
    assert_eq!(
        SymmetricPattern::from_block_rows(2, 0, |_, _| {}).unwrap_err(),
        PatternError::ZeroBlockSize
    );
    // Upper-triangle row, missing diagonal, unsorted rows.
    for (cp, ri) in [
        (vec![0, 1, 2], vec![1, 0]),
        (vec![0, 1, 1], vec![0]),
        (vec![0, 3, 4], vec![0, 2, 1, 1]),
    ] {
        let n = cp.len() - 1;
        assert!(matches!(
            SymmetricPattern::from_lower_csc(n, cp, ri),
            Err(PatternError::InvalidCsc(_))
        ));
    }
    let ok = SymmetricPattern::from_lower_csc(2, vec![0, 2, 3], vec![0, 1, 1]).unwrap();
    assert_eq!(ok.slot(0, 1), Some(1));
}

#[test]
fn dof_map_round_trips_and_reports_changes() {
    let mut map = DofMap::from_predicate(10, |i| i % 3 != 0);
    assert_eq!(map.nodes(), &[1, 2, 4, 5, 7, 8]);
    assert_eq!((map.len(), map.num_nodes(), map.is_empty()), (6, 10, false));
    for k in 0..map.len() {
        assert_eq!(map.unknown(map.node(k)), Some(k));
    }
    for i in 0..10 {
        match map.unknown(i) {
            Some(k) => assert_eq!(map.node(k), i),
            None => assert_eq!(i % 3, 0),
        }
    }
    assert_eq!(map.unknown(10), None);
    let ptr = map.nodes().as_ptr();
    assert!(!map.rebuild(10, |i| i % 3 != 0), "same set");
    assert!(map.rebuild(10, |i| i % 3 != 1), "different set, same size");
    assert_eq!(map.nodes(), &[0, 2, 3, 5, 6, 8, 9]);
    assert!(map.rebuild(10, |i| i < 2), "smaller set");
    assert_eq!(map.nodes(), &[0, 1]);
    assert_eq!(map.unknown(5), None);
    assert!(map.rebuild(12, |i| i < 2), "more nodes");
    assert!(!map.rebuild(12, |i| i < 2));
    assert_eq!(
        map.nodes().as_ptr(),
        ptr,
        "no reallocation below the largest size"
    );
    assert!(map.rebuild(0, |_| true));
    assert!(map.is_empty());
}
