//! `mpm-cli surface DIR`: a triangle mesh of the fluid's free surface per 3D snapshot,
//! reconstructed with `splashsurf_lib` (an SPH density of the particles, cubic spline kernel,
//! sampled on a marching-cubes grid and contoured at a fraction of the rest density), written
//! as binary PLY files `DIR/surface/surface_NNNNNN.ply` that Blender, ParaView and MeshLab
//! open, with each vertex's velocity, speed and material taken from the particles around it
//! (`ply`). Of a 2D run, the fluid's outline at the same density level by marching squares,
//! as an SVG drawing `DIR/surface/outline_NNNNNN.svg` (`outline`).
//!
//! Parameters are relative to the particle radius `r`, by default half the median particle
//! spacing (`volume0^(1/3) / 2`, so that splashsurf's particle volume `(2r)³` is the
//! particles' own; without `volume0` in the snapshot, the finest spacing the stored scene
//! samples the surface's materials with): kernel smoothing length 2 r (compact support 4 r), marching-cubes cells of
//! 0.5 r, iso-surface at 0.6 of the rest density (splashsurf's own defaults). Each frame is
//! reconstructed on one thread (frames run in parallel), so the files do not depend on the
//! number of threads.

mod outline;
mod ply;

use crate::error::CliError;
use crate::files::{hint, read_file};
use crate::render::{particle_spacing, select_snapshots};
use crate::scene::{self, ModelDef, SamplingDef};
use mpm_io::Data;
use rayon::prelude::*;
use splashsurf_lib::nalgebra::Vector3;
use splashsurf_lib::{reconstruct_surface, Parameters, SpatialDecomposition};
use std::path::{Path, PathBuf};

/// Options of `mpm-cli surface`.
#[derive(Clone, Debug)]
pub struct SurfaceOptions {
    /// Output directory of a run (holding `snap_*.h5`).
    pub dir: PathBuf,
    /// Only this frame (default: every frame).
    pub frame: Option<u64>,
    /// Materials whose particles form the surface, by name (default: every fluid material).
    pub materials: Vec<String>,
    /// Particle radius (m); default half the median particle spacing.
    pub radius: Option<f64>,
    /// Kernel smoothing length, in particle radii (the compact support is twice this).
    pub smoothing_length: f64,
    /// Edge length of the marching-cubes cells, in particle radii.
    pub cube_size: f64,
    /// Iso-surface level as a fraction of the rest density.
    pub iso: f64,
    /// Whether `.h5` files without a checksum block are read (`--unchecked`; unsafe, see
    /// [`crate::files`]).
    pub trust: mpm_io::Verify,
}

impl Default for SurfaceOptions {
    fn default() -> Self {
        Self {
            dir: PathBuf::new(),
            frame: None,
            materials: Vec::new(),
            radius: None,
            smoothing_length: 2.0,
            cube_size: 0.5,
            iso: 0.6,
            trust: mpm_io::Verify::Required,
        }
    }
}

/// One mesh (3D) or outline (2D) written.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceFile {
    /// The PLY (3D) or SVG (2D) file.
    pub path: PathBuf,
    /// Snapshot frame number.
    pub frame: u64,
    /// Dimension of the run.
    pub dim: usize,
    /// Particles that entered the reconstruction.
    pub particles: usize,
    /// Vertices of the mesh (3D).
    pub vertices: usize,
    /// Triangles of the mesh (3D).
    pub triangles: usize,
    /// Segments of the outline (2D).
    pub segments: usize,
    /// Volume enclosed by the mesh (m³, by the divergence theorem), or area enclosed by the
    /// outline (m², 2D).
    pub volume: f64,
}

/// The most marching-cubes cells a reconstruction may span (the bounding box of the particles
/// over the cell volume); beyond it the options are refused rather than exhausting memory.
const MAX_CELLS: f64 = 2e9;

/// Reconstructs the surfaces of the chosen frames and writes one PLY file per frame.
pub fn surface(opts: &SurfaceOptions) -> Result<Vec<SurfaceFile>, CliError> {
    let bad = |m: String| CliError::BadInput(format!("error: surface: {m}"));
    for (name, v) in [
        ("--smoothing-length", opts.smoothing_length),
        ("--cube-size", opts.cube_size),
        ("--iso", opts.iso),
        ("--radius", opts.radius.unwrap_or(1.0)),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(bad(format!("{name} {v}: must be a positive number")));
        }
    }
    if opts.iso >= MAX_ISO {
        return Err(bad(format!(
            "--iso {}: must be below {MAX_ISO} (a fraction of the rest density; a fluid is \
             never compressed that far)",
            opts.iso
        )));
    }
    let chosen = select_snapshots(&opts.dir, opts.frame, opts.frame.is_none()).map_err(bad)?;
    let out_dir = opts.dir.join("surface");
    let created = !out_dir.exists();
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| CliError::Other(format!("error: {}: {e}", out_dir.display())))?;
    let written: Vec<Result<SurfaceFile, CliError>> = chosen
        .par_iter()
        .map(|(frame, path)| {
            let f = fluid_particles(path, opts).map_err(bad)?;
            if f.positions.is_empty() {
                return Err(bad(format!(
                    "frame {frame} has no particles of the chosen materials"
                )));
            }
            let empty = || {
                bad(format!(
                    "frame {frame}: the surface is empty: no region of the {} particles \
                     reaches --iso {} of the rest density (give a smaller --iso or a larger \
                     --smoothing-length)",
                    f.positions.len(),
                    opts.iso
                ))
            };
            let title = format!(
                "mpm-cli surface: frame {frame}, t = {} s, radius {} m",
                f.time, f.radius
            );
            let (name, bytes, counts, volume) = if f.dim == 2 {
                let (support, cell) = sizes(&f, opts).map_err(bad)?;
                let segments = outline::outline(&f.positions, f.radius, support, cell, opts.iso)
                    .map_err(bad)?;
                if segments.is_empty() {
                    return Err(empty());
                }
                let svg = outline::svg(&segments, f.lo.xy(), f.hi.xy(), &title);
                let area = outline::enclosed_area(&segments);
                let name = format!("outline_{frame:06}.svg");
                (name, svg.into_bytes(), (0, 0, segments.len()), area)
            } else {
                let mesh = reconstruct(&f, opts).map_err(bad)?;
                if mesh.1.is_empty() {
                    return Err(empty());
                }
                let vertices: Vec<Vector3<f64>> =
                    mesh.0.iter().map(|v| Vector3::from(*v)).collect();
                let particles = ply::Particles {
                    positions: &f.positions,
                    velocities: f.velocities.as_deref(),
                    materials: &f.materials,
                    support: 2.0 * opts.smoothing_length * f.radius,
                };
                let attributes = ply::attributes(&particles, &vertices);
                let mut comments = vec![title];
                comments.extend(
                    (f.names.iter().enumerate()).map(|(k, name)| format!("material {k} = {name}")),
                );
                let bytes = ply::ply_bytes(&vertices, &attributes, &mesh.1, &comments);
                let counts = (mesh.0.len(), mesh.1.len(), 0);
                let volume = enclosed_volume(&mesh.0, &mesh.1);
                (format!("surface_{frame:06}.ply"), bytes, counts, volume)
            };
            let path = out_dir.join(name);
            std::fs::write(&path, bytes).map_err(|e| {
                CliError::Other(format!("error: cannot write {}: {e}", path.display()))
            })?;
            Ok(SurfaceFile {
                path,
                frame: *frame,
                dim: f.dim,
                particles: f.positions.len(),
                vertices: counts.0,
                triangles: counts.1,
                segments: counts.2,
                volume,
            })
        })
        .collect();
    if let Some(i) = written.iter().position(Result::is_err) {
        // A failed command leaves nothing behind: the meshes of this call are removed, and
        // the folder if this call made it.
        for f in written.iter().flatten() {
            let _ = std::fs::remove_file(&f.path);
        }
        if created {
            let _ = std::fs::remove_dir(&out_dir);
        }
        return Err(written
            .into_iter()
            .nth(i)
            .and_then(Result::err)
            .expect("an error"));
    }
    Ok(written.into_iter().flatten().collect())
}

/// `--iso` must stay below this fraction of the rest density.
const MAX_ISO: f64 = 2.0;

/// Largest mean number of neighbour candidates per particle (particles in the 3³ kernel-sized
/// cells around it): about 6.4 times the particles within the kernel's reach, whose lists
/// splashsurf keeps. The defaults give about 216 (8 particles per cell of the kernel's reach),
/// so a radius or smoothing length up to twice the default passes; the limit refuses one that
/// makes every particle a neighbour of every other (memory quadratic in the particle count).
const MAX_NEIGHBOURS: f64 = 2048.0;

/// The particles of one snapshot that form the surface.
struct FluidFrame {
    /// Positions (m).
    positions: Vec<Vector3<f64>>,
    /// Velocities (m/s), when the snapshot has them.
    velocities: Option<Vec<Vector3<f64>>>,
    /// Material index of each particle.
    materials: Vec<u32>,
    /// The scene's material names, by index.
    names: Vec<String>,
    /// Particle radius (m).
    radius: f64,
    /// Time of the snapshot (s).
    time: f64,
    /// Largest edge of the scene's grid box (m).
    domain: f64,
    /// Dimension of the run.
    dim: usize,
    /// Lower corner of the scene's grid box (m; 0 beyond the run's dimension).
    lo: Vector3<f64>,
    /// Upper corner of the scene's grid box (m).
    hi: Vector3<f64>,
}

/// The chosen materials' particles in snapshot `path`, with the particle radius, the time and
/// the size of the scene's domain.
fn fluid_particles(path: &Path, opts: &SurfaceOptions) -> Result<FluidFrame, String> {
    let s = read_file(path, opts.trust).map_err(|e| format!("{e}{}", hint(&e)))?;
    let dim = s.header.dim as usize;
    if !(2..=3).contains(&dim) {
        return Err(format!(
            "{}: surfaces need 2D or 3D snapshots; this run is {dim}D",
            path.display()
        ));
    }
    let stored = scene::parse(Path::new("scene.toml"), &s.header.scene)
        .map_err(|_| format!("{}: the stored scene cannot be read", path.display()))?;
    let materials = &stored.scene.materials;
    let names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
    let chosen: Vec<u32> = if opts.materials.is_empty() {
        let fluids: Vec<u32> = (0..materials.len() as u32)
            .filter(|&k| matches!(materials[k as usize].model, ModelDef::Tait(_)))
            .collect();
        if fluids.is_empty() {
            return Err(format!(
                "the scene has no fluid material; choose materials with --material (materials: \
                 {})",
                names.join(", ")
            ));
        }
        fluids
    } else {
        opts.materials
            .iter()
            .map(|m| {
                names
                    .iter()
                    .position(|n| n == m)
                    .map(|k| k as u32)
                    .ok_or_else(|| {
                        format!(
                            "--material: no material \"{m}\" (materials: {})",
                            names.join(", ")
                        )
                    })
            })
            .collect::<Result<_, _>>()?
    };
    let Some(Data::F64 { values: x, shape }) = s.field("x").map(|f| &f.data) else {
        return Err(format!("{}: no positions `x`", path.display()));
    };
    let n = shape[0];
    let material: Vec<u32> = match s.field("material").map(|f| &f.data) {
        Some(Data::U32 { values, .. }) if values.len() == n => values.clone(),
        _ if materials.len() == 1 => vec![0; n],
        _ => return Err(format!("{}: no field `material`", path.display())),
    };
    let kept: Vec<usize> = (0..n).filter(|&p| chosen.contains(&material[p])).collect();
    // 2D positions and velocities get a zero third component.
    let row = |values: &[f64], p: usize| {
        Vector3::from_fn(|a, _| if a < dim { values[dim * p + a] } else { 0.0 })
    };
    let positions = kept.iter().map(|&p| row(x, p)).collect();
    let velocities = match s.field("v").map(|f| &f.data) {
        Some(Data::F64 { values, shape }) if shape[..] == [n, dim] => {
            Some(kept.iter().map(|&p| row(values, p)).collect())
        }
        _ => None,
    };
    let radius = match opts.radius {
        Some(r) => r,
        None => {
            0.5 * particle_spacing(&s, dim)
                .or_else(|| sampled_spacing(&stored.scene, &chosen))
                .ok_or_else(|| {
                    format!(
                        "{}: no `volume0` and no body of the chosen materials in the stored \
                         scene to derive the particle spacing from; give --radius",
                        path.display()
                    )
                })?
        }
    };
    let grid = &stored.scene.grid;
    let domain = (0..dim)
        .map(|a| grid.max[a] - grid.min[a])
        .fold(0.0, f64::max);
    Ok(FluidFrame {
        positions,
        velocities,
        materials: kept.iter().map(|&p| material[p]).collect(),
        names: names.iter().map(|n| n.to_string()).collect(),
        radius,
        time: s.header.time,
        domain,
        dim,
        lo: Vector3::from_fn(|a, _| if a < dim { grid.min[a] } else { 0.0 }),
        hi: Vector3::from_fn(|a, _| if a < dim { grid.max[a] } else { 0.0 }),
    })
}

/// The smallest particle spacing (m) the stored scene samples the chosen materials' bodies
/// with: the cell size over the particles per cell and axis on a lattice, the minimum distance
/// with Poisson-disk sampling. `None` when no body is of those materials.
fn sampled_spacing(scene: &scene::Scene, chosen: &[u32]) -> Option<f64> {
    scene
        .bodies
        .iter()
        .filter(|b| chosen.contains(&(b.material_index as u32)))
        .map(|b| match b.sampling {
            SamplingDef::Lattice { per_axis, .. } => scene.grid.dx / f64::from(per_axis.max(1)),
            SamplingDef::Poisson { poisson_radius, .. } => poisson_radius,
        })
        .min_by(f64::total_cmp)
}

/// A triangle mesh: vertices (m) and triangles (indices, counter-clockwise seen from outside).
type Mesh = (Vec<[f64; 3]>, Vec<[usize; 3]>);

/// The surface of a frame's particles.
fn reconstruct(f: &FluidFrame, opts: &SurfaceOptions) -> Result<Mesh, String> {
    let (positions, radius) = (&f.positions, f.radius);
    let (support, cube) = sizes(f, opts)?;
    let (mut lo, mut hi) = (positions[0], positions[0]);
    for p in positions {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let margin = support + cube;
    let cells: f64 = (0..3)
        .map(|a| (hi[a] - lo[a] + 2.0 * margin) / cube)
        .product();
    if cells.is_nan() || cells > MAX_CELLS {
        return Err(format!(
            "the marching-cubes grid would have {cells:.2e} cells (at most {MAX_CELLS:.0e}); \
             give a larger --cube-size or --radius"
        ));
    }
    let neighbours = neighbour_candidates(positions, lo, support);
    if neighbours > MAX_NEIGHBOURS {
        return Err(format!(
            "with a kernel reach of {support:.3e} m each particle would have about \
             {neighbours:.0} neighbour candidates (at most {MAX_NEIGHBOURS}); give a smaller \
             --radius or --smoothing-length"
        ));
    }
    let mut params = Parameters::new(radius, 2.0 * opts.smoothing_length * radius, cube);
    params.iso_surface_threshold = opts.iso;
    // One thread per frame: the mesh is then the same for any thread count.
    params.enable_multi_threading = false;
    params.spatial_decomposition = SpatialDecomposition::default();
    let r = reconstruct_surface::<i64, f64>(positions, &params)
        .map_err(|e| format!("surface reconstruction failed: {e}"))?;
    let vertices: Vec<[f64; 3]> = r.mesh.vertices.iter().map(|v| [v.x, v.y, v.z]).collect();
    let mut triangles = r.mesh.triangles;
    // Orient the triangles so that the normals point out of the fluid.
    if enclosed_volume(&vertices, &triangles) < 0.0 {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    Ok((vertices, triangles))
}

/// The kernel's reach and the grid's cell size (m) for a frame, each checked against the
/// scene's domain, as is the particle radius.
fn sizes(f: &FluidFrame, opts: &SurfaceOptions) -> Result<(f64, f64), String> {
    let cube = opts.cube_size * f.radius;
    let support = 2.0 * opts.smoothing_length * f.radius;
    for (what, len) in [
        ("the particle radius (--radius)", f.radius),
        (
            "the kernel's reach (--radius × 2 --smoothing-length)",
            support,
        ),
        ("the marching-cubes cell (--radius × --cube-size)", cube),
    ] {
        if len > f.domain {
            return Err(format!(
                "{what} is {len:.3e} m, larger than the scene's domain ({:.3e} m)",
                f.domain
            ));
        }
    }
    Ok((support, cube))
}

/// The mean number of particles in the 3³ cells of edge `support` (m) around each particle,
/// cells counted from `lo`: an upper bound on the neighbours within `support`, found in time
/// linear in the particle count.
fn neighbour_candidates(positions: &[Vector3<f64>], lo: Vector3<f64>, support: f64) -> f64 {
    let cell = |p: &Vector3<f64>| ((p - lo) / support).map(|c| c.floor() as i64);
    let mut counts = std::collections::HashMap::<Vector3<i64>, u64>::new();
    for p in positions {
        *counts.entry(cell(p)).or_default() += 1;
    }
    let mut pairs = 0u64;
    for (c, n) in &counts {
        for o in 0..27i64 {
            let d = Vector3::new(o % 3 - 1, o / 3 % 3 - 1, o / 9 - 1);
            pairs += n * counts.get(&(c + d)).copied().unwrap_or(0);
        }
    }
    pairs as f64 / positions.len() as f64
}

/// The volume enclosed by a closed, consistently oriented triangle mesh (m³): the sum over
/// triangles of `a · (b × c) / 6` (divergence theorem); positive for outward normals.
pub fn enclosed_volume(vertices: &[[f64; 3]], triangles: &[[usize; 3]]) -> f64 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i]);
            let cross = [
                b[1] * c[2] - b[2] * c[1],
                b[2] * c[0] - b[0] * c[2],
                b[0] * c[1] - b[1] * c[0],
            ];
            (a[0] * cross[0] + a[1] * cross[1] + a[2] * cross[2]) / 6.0
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_volume_of_a_unit_tetrahedron_and_cube() {
        let v = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        // Outward orientation of the four faces.
        let t = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        assert!((enclosed_volume(&v, &t) - 1.0 / 6.0).abs() < 1e-15);
        // Translation does not change it.
        let w: Vec<[f64; 3]> = v
            .iter()
            .map(|p| [p[0] + 5.0, p[1] - 2.0, p[2] + 1.0])
            .collect();
        assert!((enclosed_volume(&w, &t) - 1.0 / 6.0).abs() < 1e-12);
    }
}
