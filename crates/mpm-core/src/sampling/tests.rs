use super::*;
use std::f64::consts::PI;

fn lattice(per_axis: usize, jitter: Real, seed: u64) -> Sampling {
    Sampling::Lattice {
        per_axis,
        jitter,
        seed,
    }
}

fn total(v: &[Real]) -> Real {
    v.iter().sum()
}

#[test]
fn rng_matches_splitmix64_and_is_uniform_and_deterministic() {
    // Reference outputs of SplitMix64 seeded with 0.
    let mut rng = Rng::new(0);
    assert_eq!(rng.next_u64(), 0xE220_A839_7B1D_CDAF);
    assert_eq!(rng.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    assert_eq!(rng.next_u64(), 0x06C4_5D18_8009_454F);

    let n = 100_000;
    let mut rng = Rng::new(42);
    let draws: Vec<Real> = (0..n).map(|_| rng.uniform()).collect();
    assert!(draws.iter().all(|&u| (0.0..1.0).contains(&u)));
    let mean = draws.iter().sum::<Real>() / n as Real;
    assert!((mean - 0.5).abs() < 0.01, "mean {mean}");
    let var = draws.iter().map(|u| (u - mean).powi(2)).sum::<Real>() / n as Real;
    assert!((var - 1.0 / 12.0).abs() < 0.005, "variance {var}");

    let mut again = Rng::new(42);
    assert!(draws.iter().all(|&u| u == again.uniform()));
    let mut other = Rng::new(43);
    assert_ne!(draws[0], other.uniform());
}

#[test]
fn lattice_box_aligned_to_cells_is_exact_2d_and_3d() {
    // 2D: 5 × 2 cells, 3² particles per cell.
    let origin = Vector::<2>::new(0.1, -0.2);
    let dx = 0.05;
    let shape = Shape::Box {
        min: origin + Vector::<2>::new(2.0, 3.0) * dx,
        max: origin + Vector::<2>::new(7.0, 5.0) * dx,
    };
    for jitter in [0.0, 0.3] {
        let (xs, vols) = sample(&shape, &lattice(3, jitter, 7), &origin, dx);
        assert_eq!(xs.len(), 10 * 9);
        assert_eq!(vols.len(), xs.len());
        let rel = (total(&vols) - shape.volume()).abs() / shape.volume();
        assert!(rel < 1e-12, "relative volume error {rel}");
        // Every cell holds exactly 9 particles.
        let mut counts = std::collections::HashMap::new();
        for x in &xs {
            let c: [i64; 2] = std::array::from_fn(|a| ((x[a] - origin[a]) / dx).floor() as i64);
            *counts.entry(c).or_insert(0) += 1;
        }
        assert_eq!(counts.len(), 10);
        assert!(counts.values().all(|&c| c == 9));
    }

    // 3D: 3 × 2 × 4 cells, 2³ particles per cell.
    let origin = Vector::<3>::new(-1.0, 0.25, 2.0);
    let dx = 0.1;
    let shape = Shape::Box {
        min: origin + Vector::<3>::new(1.0, 2.0, 0.0) * dx,
        max: origin + Vector::<3>::new(4.0, 4.0, 4.0) * dx,
    };
    let (xs, vols) = sample(&shape, &lattice(2, 0.0, 0), &origin, dx);
    assert_eq!(xs.len(), 24 * 8);
    assert!(xs.iter().all(|x| shape.contains(x)));
    assert!(vols.iter().all(|&v| (v - 0.05f64.powi(3)).abs() < 1e-18));
    let rel = (total(&vols) - shape.volume()).abs() / shape.volume();
    assert!(rel < 1e-12, "relative volume error {rel}");
}

#[test]
fn lattice_jitter_is_bounded_and_deterministic() {
    let origin = Vector::<2>::zeros();
    let dx = 0.1;
    let h = dx / 2.0;
    let shape = Shape::Box {
        min: Vector::<2>::zeros(),
        max: Vector::<2>::new(1.0, 1.0),
    };
    let (plain, _) = sample(&shape, &lattice(2, 0.0, 0), &origin, dx);
    let (a, _) = sample(&shape, &lattice(2, 0.25, 5), &origin, dx);
    let (b, _) = sample(&shape, &lattice(2, 0.25, 5), &origin, dx);
    let (c, _) = sample(&shape, &lattice(2, 0.25, 6), &origin, dx);
    assert_eq!(plain.len(), 400);
    assert_eq!(a, b);
    assert_ne!(a, c);
    let mut max_shift: Real = 0.0;
    for (p, q) in plain.iter().zip(&a) {
        max_shift = max_shift.max((p - q).amax());
    }
    assert!(max_shift <= 0.25 * h + 1e-15);
    assert!(max_shift > 0.2 * h, "jitter barely used: {max_shift}");
}

/// Relative error of the lattice estimate of the shape's measure at spacing `dx`.
fn lattice_volume_error<const D: usize>(shape: &Shape<D>, dx: Real) -> Real {
    let (_, vols) = sample(shape, &lattice(2, 0.0, 0), &Vector::<D>::zeros(), dx);
    (total(&vols) - shape.volume()).abs() / shape.volume()
}

#[test]
fn lattice_disk_and_sphere_volume_converges() {
    let disk = Shape::Sphere {
        center: Vector::<2>::new(0.013, -0.007),
        radius: 0.3,
    };
    assert!((disk.volume() - PI * 0.09).abs() < 1e-15);
    let coarse = lattice_volume_error(&disk, 0.3 / 2.5);
    let fine = lattice_volume_error(&disk, 0.3 / 40.0);
    // Measured: 1.9 % at r/dx = 2.5, 0.009 % at r/dx = 40.
    assert!(coarse < 0.05, "disk error {coarse}");
    assert!(fine < 0.002, "disk error {fine}");
    assert!(fine < coarse / 4.0, "disk errors {coarse} → {fine}");

    let sphere = Shape::Sphere {
        center: Vector::<3>::new(0.013, -0.007, 0.021),
        radius: 0.3,
    };
    assert!((sphere.volume() - 4.0 / 3.0 * PI * 0.027).abs() < 1e-15);
    let coarse = lattice_volume_error(&sphere, 0.3 / 2.5);
    let fine = lattice_volume_error(&sphere, 0.3 / 20.0);
    // Measured: 0.84 % at r/dx = 2.5, 0.028 % at r/dx = 20.
    assert!(coarse < 0.05, "sphere error {coarse}");
    assert!(fine < 0.002, "sphere error {fine}");
    assert!(fine < coarse / 4.0, "sphere errors {coarse} → {fine}");
}

#[test]
fn shape_contains_bounds_and_volume() {
    // Box with corners given in reverse order.
    let b = Shape::Box {
        min: Vector::<2>::new(1.0, 2.0),
        max: Vector::<2>::new(0.0, 0.0),
    };
    assert_eq!(b.volume(), 2.0);
    assert_eq!(
        b.bounds(),
        (Vector::<2>::zeros(), Vector::<2>::new(1.0, 2.0))
    );
    assert!(b.contains(&Vector::<2>::new(0.5, 1.5)));
    assert!(!b.contains(&Vector::<2>::new(1.5, 1.5)));

    // 2D cylinder: side-view rectangle along the diagonal, 2r × 2L.
    let s = 0.5f64.sqrt();
    let cyl = Shape::Cylinder {
        center: Vector::<2>::new(1.0, 1.0),
        axis: Vector::<2>::new(2.0, 2.0), // not unit on purpose
        radius: 0.1,
        half_length: 0.5,
    };
    assert!((cyl.volume() - 0.2).abs() < 1e-15);
    let (lo, hi) = cyl.bounds();
    let ext = 0.5 * s + 0.1 * s;
    assert!((hi - Vector::<2>::new(1.0 + ext, 1.0 + ext)).amax() < 1e-15);
    assert!((lo - Vector::<2>::new(1.0 - ext, 1.0 - ext)).amax() < 1e-15);
    assert!(cyl.contains(&Vector::<2>::new(1.0 + 0.45 * s, 1.0 + 0.45 * s)));
    assert!(!cyl.contains(&Vector::<2>::new(1.0 + 0.55 * s, 1.0 + 0.55 * s)));
    assert!(cyl.contains(&Vector::<2>::new(1.0 + 0.09 * s, 1.0 - 0.09 * s)));
    assert!(!cyl.contains(&Vector::<2>::new(1.0 + 0.11 * s, 1.0 - 0.11 * s)));
    let err = lattice_volume_error(&cyl, 0.005);
    assert!(err < 0.01, "2D cylinder error {err}");

    // 3D cylinder along z: πr² · 2L, bounds r × r × L.
    let cyl = Shape::Cylinder {
        center: Vector::<3>::zeros(),
        axis: Vector::<3>::new(0.0, 0.0, 1.0),
        radius: 0.2,
        half_length: 0.4,
    };
    assert!((cyl.volume() - PI * 0.04 * 0.8).abs() < 1e-15);
    let (lo, hi) = cyl.bounds();
    assert!((hi - Vector::<3>::new(0.2, 0.2, 0.4)).amax() < 1e-15);
    assert!((lo + Vector::<3>::new(0.2, 0.2, 0.4)).amax() < 1e-15);
    assert!(cyl.contains(&Vector::<3>::new(0.1, 0.1, 0.39)));
    assert!(!cyl.contains(&Vector::<3>::new(0.15, 0.15, 0.0)));
    assert!(!cyl.contains(&Vector::<3>::new(0.0, 0.0, 0.41)));
    let err = lattice_volume_error(&cyl, 0.01);
    assert!(err < 0.01, "3D cylinder error {err}");
}

/// The lattice-sampling bound on `|Σ V_p − A|` for a polygon: only the `h`-cells an edge
/// passes through can be misclassified, and an edge of length ℓ meets at most
/// `√2 ℓ/h + 2` of them, so the error is below `h² Σ (√2 ℓ/h + 2) = √2 P h + 2 n h²` (m²).
fn polygon_bound(vertices: &[[Real; 2]], h: Real) -> Real {
    let n = vertices.len();
    let perimeter: Real = (0..n)
        .map(|i| {
            let (a, b) = (vertices[i], vertices[(i + 1) % n]);
            (b[0] - a[0]).hypot(b[1] - a[1])
        })
        .sum();
    2f64.sqrt() * perimeter * h + 2.0 * n as Real * h * h
}

/// `[x, y]` rotated by `deg` degrees counter-clockwise about `c`.
fn rotated(p: [Real; 2], c: [Real; 2], deg: Real) -> [Real; 2] {
    let (s, co) = deg.to_radians().sin_cos();
    let (x, y) = (p[0] - c[0], p[1] - c[1]);
    [c[0] + co * x - s * y, c[1] + s * x + co * y]
}

#[test]
fn polygon_lattice_volume_matches_the_area_within_the_bound() {
    let origin = Vector::<2>::zeros();
    let dx = 0.05;
    let h = dx / 2.0;
    // L-shape with every edge on a lattice cell face (multiples of h): exact.
    let l_shape = vec![
        [0.1, 0.1],
        [0.6, 0.1],
        [0.6, 0.3],
        [0.3, 0.3],
        [0.3, 0.7],
        [0.1, 0.7],
    ];
    let area = 0.5 * 0.2 + 0.2 * 0.4;
    for vertices in [l_shape.clone(), l_shape.iter().rev().copied().collect()] {
        assert!((polygon_area(&vertices).abs() - area).abs() < 1e-15);
        let shape = Shape::<2>::Polygon { vertices };
        assert!((shape.volume() - area).abs() < 1e-15);
        let (xs, vols) = sample(&shape, &lattice(2, 0.0, 0), &origin, dx);
        assert_eq!(xs.len(), (area / (h * h)).round() as usize);
        assert!((total(&vols) - area).abs() < 1e-12 * area);
    }
    // A triangle with slanted edges: within the bound, and converging with h.
    let tri = vec![[0.113, 0.207], [0.871, 0.152], [0.402, 0.733]];
    let area = polygon_area(&tri).abs();
    let shape = Shape::<2>::Polygon {
        vertices: tri.clone(),
    };
    for dx in [0.05, 0.0125] {
        let (_, vols) = sample(&shape, &lattice(2, 0.0, 0), &origin, dx);
        let err = (total(&vols) - area).abs();
        let bound = polygon_bound(&tri, dx / 2.0);
        assert!(
            err <= bound,
            "triangle at dx = {dx}: error {err} > bound {bound}"
        );
        // Measured: 0.40 % at dx = 0.05, 0.0015 % at dx = 0.0125 (the bound: 38 %, 9 %).
        assert!(err < 0.01 * area, "triangle at dx = {dx}: error {err}");
    }
    // Poisson disks share the exact area.
    let poisson = Sampling::PoissonDisk {
        radius: 0.02,
        seed: 1,
    };
    let (xs, vols) = sample(&shape, &poisson, &origin, dx);
    assert!(xs.len() > 100 && xs.iter().all(|x| shape.contains(x)));
    assert!((total(&vols) - area).abs() < 1e-12 * area);
}

#[test]
fn tilted_square_has_the_volume_of_the_untilted_one_within_the_bound() {
    let origin = Vector::<2>::zeros();
    let (dx, h) = (0.04, 0.02);
    let square = [[0.2, 0.2], [0.6, 0.2], [0.6, 0.6], [0.2, 0.6]];
    let upright = Shape::<2>::Polygon {
        vertices: square.to_vec(),
    };
    let (_, vols) = sample(&upright, &lattice(2, 0.0, 0), &origin, dx);
    let v0 = total(&vols);
    assert!((v0 - 0.16).abs() < 1e-12);
    for deg in [10.0, 30.0, 45.0, 73.0] {
        let tilted: Vec<[Real; 2]> = square
            .iter()
            .map(|&p| rotated(p, [0.4, 0.4], deg))
            .collect();
        let shape = Shape::<2>::Polygon {
            vertices: tilted.clone(),
        };
        assert!((shape.volume() - 0.16).abs() < 1e-14);
        for jitter in [0.0, 0.3] {
            let (xs, vols) = sample(&shape, &lattice(2, jitter, 4), &origin, dx);
            let err = (total(&vols) - v0).abs();
            let bound = polygon_bound(&tilted, h);
            assert!(err <= bound, "{deg}°: error {err} > bound {bound}");
            // Lattice points are tested before the jitter moves them.
            assert!(jitter > 0.0 || xs.iter().all(|x| shape.contains(x)));
        }
    }
}

#[test]
fn polygon_defects_are_named() {
    use PolygonDefect::*;
    let ok = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    assert_eq!(polygon_defect(&ok), None);
    assert_eq!(polygon_defect(&ok[..2]), Some(TooFewVertices(2)));
    let nan = [[0.0, 0.0], [1.0, Real::NAN], [0.0, 1.0]];
    assert_eq!(polygon_defect(&nan), Some(NonFinite(1)));
    let line = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]];
    assert_eq!(polygon_defect(&line), Some(ZeroArea));
    // A bow tie: edges 0 and 2 cross.
    let bow = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
    assert_eq!(polygon_defect(&bow), Some(SelfIntersecting(0, 2)));
    let repeated = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    assert_eq!(polygon_defect(&repeated), Some(RepeatedVertex(1, 2)));
    // A spike folding back along its own edge (adjacent edges 1 and 2 overlap).
    let spike = [[0.0, 0.0], [2.0, 0.0], [3.0, 0.0], [2.5, 0.0], [0.0, 1.0]];
    assert!(matches!(
        polygon_defect(&spike),
        Some(SelfIntersecting(_, _))
    ));
    // A vertex touching a non-adjacent edge.
    let touch = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 0.0], [0.0, 2.0]];
    assert!(matches!(
        polygon_defect(&touch),
        Some(SelfIntersecting(_, _))
    ));
    // Invalid polygons and any polygon in 3D sample nothing.
    let o = Vector::<2>::zeros();
    let bow = Shape::<2>::Polygon {
        vertices: bow.to_vec(),
    };
    assert!(sample(&bow, &lattice(2, 0.0, 0), &o, 0.1).0.is_empty());
    let in_3d = Shape::<3>::Polygon {
        vertices: ok.to_vec(),
    };
    assert!(
        sample(&in_3d, &lattice(2, 0.0, 0), &Vector::<3>::zeros(), 0.1)
            .0
            .is_empty()
    );
}

/// Checks the Poisson-disk invariants by brute force and returns the sample.
fn check_poisson<const D: usize>(shape: &Shape<D>, radius: Real, seed: u64) -> Vec<Vector<D>> {
    let sampling = Sampling::PoissonDisk { radius, seed };
    let (xs, vols) = sample(shape, &sampling, &Vector::<D>::zeros(), 1.0);
    assert!(xs.len() > 50);
    assert!(xs.iter().all(|x| shape.contains(x)));
    for i in 0..xs.len() {
        for j in 0..i {
            let d = (xs[i] - xs[j]).norm();
            assert!(
                d >= radius * (1.0 - 1e-12),
                "points {i}, {j} at {d} < {radius}"
            );
        }
    }
    assert!((total(&vols) - shape.volume()).abs() < 1e-12 * shape.volume());
    assert!(vols.iter().all(|&v| v == vols[0]));
    let (again, _) = sample(shape, &sampling, &Vector::<D>::zeros(), 1.0);
    assert_eq!(xs, again);
    let other = Sampling::PoissonDisk {
        radius,
        seed: seed + 1,
    };
    assert_ne!(xs, sample(shape, &other, &Vector::<D>::zeros(), 1.0).0);
    xs
}

#[test]
fn poisson_disk_respects_min_distance_and_shape_and_is_deterministic() {
    let disk = Shape::Sphere {
        center: Vector::<2>::new(0.5, -0.25),
        radius: 1.0,
    };
    let xs = check_poisson(&disk, 0.1, 3);
    // No large holes: every probe point in the disk is within 2r of a sample.
    for i in -20..=20 {
        for j in -20..=20 {
            let p = Vector::<2>::new(0.5 + i as Real * 0.05, -0.25 + j as Real * 0.05);
            if disk.contains(&p) {
                let d = xs
                    .iter()
                    .map(|x| (x - p).norm())
                    .fold(Real::INFINITY, Real::min);
                assert!(d < 0.2, "hole of size {d} at {p}");
            }
        }
    }
    let sphere = Shape::Sphere {
        center: Vector::<3>::new(0.1, 0.2, 0.3),
        radius: 1.0,
    };
    check_poisson(&sphere, 0.25, 11);
    let cyl = Shape::Cylinder {
        center: Vector::<3>::zeros(),
        axis: Vector::<3>::new(1.0, 1.0, 0.0),
        radius: 0.3,
        half_length: 1.0,
    };
    check_poisson(&cyl, 0.1, 0);
}

/// Relative radius ρ = (n / n_max)^(1/D) of a Poisson-disk sample of the unit box, counted in
/// the interior `[0.1, 0.9]^D` to avoid boundary effects. `n_max` is the count of the densest
/// packing with minimum distance `r`: hexagonal `2/(√3 r²)` per unit area in 2D, FCC `√2/r³`
/// per unit volume in 3D.
fn relative_radius<const D: usize>(radius: Real, seed: u64) -> Real {
    let shape = Shape::Box {
        min: Vector::<D>::zeros(),
        max: Vector::<D>::repeat(1.0),
    };
    let sampling = Sampling::PoissonDisk { radius, seed };
    let (xs, _) = sample(&shape, &sampling, &Vector::<D>::zeros(), 1.0);
    let inner = xs
        .iter()
        .filter(|x| x.iter().all(|c| (0.1..0.9).contains(c)))
        .count() as Real;
    let measure = 0.8f64.powi(D as i32);
    let n_max = match D {
        2 => 2.0 / (3f64.sqrt() * radius * radius) * measure,
        _ => 2f64.sqrt() / radius.powi(3) * measure,
    };
    (inner / n_max).powf(1.0 / D as Real)
}

#[test]
fn poisson_disk_density_is_reasonable() {
    // Bounds. A dense packing would give n/n_max ≈ 0.6–0.9, but Poisson-disk sets are random
    // and pack looser: even a maximal random sequential one reaches only the jamming limit,
    // packing fraction 0.547 of 0.9069 (hexagonal) in 2D, n/n_max ≈ 0.60 (Feder 1980), and
    // 0.384 of 0.7405 (FCC) in 3D, n/n_max ≈ 0.52 (Torquato, Uche & Stillinger 2006).
    // Bridson's sampler with k = 30 stops a little short of maximal. We therefore test the
    // relative radius ρ = (n/n_max)^(1/D) against [0.65, 0.85], the range Lagae & Dutré
    // (2008, "A comparison of methods for generating Poisson disk distributions") give for
    // well-spread Poisson-disk sets. Measured here: ρ ≈ 0.73 (2D) and ρ ≈ 0.74 (3D).
    for seed in 0..3 {
        let rho2 = relative_radius::<2>(0.02, seed);
        assert!((0.65..0.85).contains(&rho2), "2D ρ = {rho2}");
        let rho3 = relative_radius::<3>(0.05, seed);
        assert!((0.65..0.85).contains(&rho3), "3D ρ = {rho3}");
    }
}

#[test]
fn invalid_sampling_returns_empty() {
    let shape = Shape::Sphere {
        center: Vector::<2>::zeros(),
        radius: 1.0,
    };
    let o = Vector::<2>::zeros();
    let empty = |s: &Shape<2>, m: &Sampling, dx: Real| {
        let (xs, vols) = sample(s, m, &o, dx);
        xs.is_empty() && vols.is_empty()
    };
    assert!(empty(&shape, &lattice(0, 0.0, 0), 0.1));
    assert!(empty(&shape, &lattice(2, Real::NAN, 0), 0.1));
    assert!(empty(&shape, &lattice(2, 0.5, 0), 0.1));
    assert!(empty(&shape, &lattice(2, -0.1, 0), 0.1));
    assert!(empty(&shape, &lattice(2, 0.0, 0), 0.0));
    assert!(empty(&shape, &lattice(2, 0.0, 0), Real::INFINITY));
    for radius in [0.0, -0.1, Real::NAN, Real::INFINITY] {
        assert!(empty(
            &shape,
            &Sampling::PoissonDisk { radius, seed: 0 },
            0.1
        ));
    }
    let bad = Shape::Sphere {
        center: Vector::<2>::new(Real::NAN, 0.0),
        radius: 1.0,
    };
    assert!(empty(&bad, &lattice(2, 0.0, 0), 0.1));
    let flat = Shape::Box {
        min: Vector::<2>::zeros(),
        max: Vector::<2>::new(1.0, 0.0),
    };
    assert!(empty(&flat, &lattice(2, 0.0, 0), 0.1));
    let no_axis = Shape::Cylinder {
        center: Vector::<2>::zeros(),
        axis: Vector::<2>::zeros(),
        radius: 1.0,
        half_length: 1.0,
    };
    assert!(empty(
        &no_axis,
        &Sampling::PoissonDisk {
            radius: 0.1,
            seed: 0
        },
        0.1
    ));
    // A valid sampling of the same disk is not empty.
    assert!(!empty(&shape, &lattice(2, 0.0, 0), 0.1));
}
