//! Vertex attributes of a surface mesh, interpolated from the particles, and the binary PLY
//! file that carries them.
//!
//! Each vertex gets the particles' velocity (m/s) and speed as a normalised SPH average
//! (Shepard: `Σ_j v_j W(x − x_j) / Σ_j W(x − x_j)` over the particles within the kernel's
//! reach, cubic spline kernel, equal particle volumes), so each component lies between the
//! smallest and the largest of the particles around it, and the material most present around it
//! (the largest such average of each material's indicator).

use splashsurf_lib::nalgebra::Vector3;
use splashsurf_lib::sph_interpolation::SphInterpolator;

/// The particles a surface is made of, with what the vertices take from them.
pub(super) struct Particles<'a> {
    /// Positions (m).
    pub positions: &'a [Vector3<f64>],
    /// Velocities (m/s), when the snapshot has them.
    pub velocities: Option<&'a [Vector3<f64>]>,
    /// Material index of each particle, in the scene's list.
    pub materials: &'a [u32],
    /// The kernel's reach (m).
    pub support: f64,
}

/// Per-vertex attributes.
pub(super) struct Attributes {
    /// Velocity (m/s), when the particles have one.
    velocity: Option<Vec<Vector3<f64>>>,
    /// Material index in the scene's list.
    material: Vec<u32>,
}

/// The attributes of `vertices` (m) interpolated from `particles`.
pub(super) fn attributes(particles: &Particles<'_>, vertices: &[Vector3<f64>]) -> Attributes {
    let n = particles.positions.len();
    // Equal volumes: with the normalisation only their ratios matter.
    let sph = SphInterpolator::new(particles.positions, &vec![1.0; n], 1.0, particles.support);
    let velocity = particles.velocities.map(|v| {
        sph.interpolate_vector_quantity(v, vertices, true)
            .into_iter()
            .map(|v| v.map(|c| if c.is_finite() { c } else { 0.0 }))
            .collect()
    });
    let mut kinds: Vec<u32> = particles.materials.to_vec();
    kinds.sort_unstable();
    kinds.dedup();
    let material = match kinds[..] {
        [] => vec![0; vertices.len()],
        [only] => vec![only; vertices.len()],
        _ => {
            let shares: Vec<Vec<f64>> = kinds
                .iter()
                .map(|&k| {
                    let indicator: Vec<f64> = particles
                        .materials
                        .iter()
                        .map(|&m| f64::from(u8::from(m == k)))
                        .collect();
                    sph.interpolate_scalar_quantity(&indicator, vertices, true)
                })
                .collect();
            (0..vertices.len())
                .map(|i| {
                    let best = (0..kinds.len())
                        .max_by(|&a, &b| shares[a][i].total_cmp(&shares[b][i]).then(b.cmp(&a)))
                        .unwrap_or(0);
                    kinds[best]
                })
                .collect()
        }
    };
    Attributes { velocity, material }
}

/// A binary little-endian PLY file: `float` vertex coordinates (m), then, when known, `float`
/// velocity `vx vy vz` (m/s) and `speed` (m/s), and `int material` (index into the materials
/// named in the comments), and triangles as `uchar`-counted `int` index lists.
pub(super) fn ply_bytes(
    vertices: &[Vector3<f64>],
    attributes: &Attributes,
    triangles: &[[usize; 3]],
    comments: &[String],
) -> Vec<u8> {
    let mut header = String::from("ply\nformat binary_little_endian 1.0\n");
    for c in comments {
        header.push_str(&format!("comment {c}\n"));
    }
    header.push_str(&format!(
        "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        vertices.len()
    ));
    if attributes.velocity.is_some() {
        header.push_str(
            "property float vx\nproperty float vy\nproperty float vz\nproperty float speed\n",
        );
    }
    header.push_str(&format!(
        "property int material\nelement face {}\nproperty list uchar int vertex_indices\n\
         end_header\n",
        triangles.len()
    ));
    let mut out = header.into_bytes();
    let f32_bytes = |x: f64| (x as f32).to_le_bytes();
    for (i, v) in vertices.iter().enumerate() {
        for c in v.iter() {
            out.extend_from_slice(&f32_bytes(*c));
        }
        if let Some(velocity) = &attributes.velocity {
            let u = velocity[i];
            for c in u.iter() {
                out.extend_from_slice(&f32_bytes(*c));
            }
            out.extend_from_slice(&f32_bytes(u.norm()));
        }
        out.extend_from_slice(&(attributes.material[i] as i32).to_le_bytes());
    }
    for t in triangles {
        out.push(3);
        for &i in t {
            out.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_attributes_average_the_particles_around_and_the_file_has_their_bytes() {
        // Two particles 0.1 m apart, kernel reach 0.2 m: a vertex between them gets a velocity
        // between theirs and the material of the nearer one.
        let positions = [Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.1, 0.0, 0.0)];
        let velocities = [Vector3::new(1.0, 0.0, 0.0), Vector3::new(3.0, -1.0, 0.0)];
        let particles = Particles {
            positions: &positions,
            velocities: Some(&velocities),
            materials: &[0, 2],
            support: 0.2,
        };
        let vertices = [
            Vector3::new(0.02, 0.0, 0.0),
            Vector3::new(0.05, 0.0, 0.0),
            Vector3::new(0.09, 0.01, 0.0),
        ];
        let a = attributes(&particles, &vertices);
        let v = a.velocity.as_ref().expect("velocity");
        assert!(v
            .iter()
            .all(|u| (1.0..=3.0).contains(&u.x) && (-1.0..=0.0).contains(&u.y)));
        // Midway: the plain mean; nearer a particle: nearer its velocity.
        assert!((v[1].x - 2.0).abs() < 1e-12 && (v[1].y + 0.5).abs() < 1e-12);
        assert!(v[0].x < 2.0 && v[2].x > 2.0);
        assert_eq!((a.material[0], a.material[2]), (0, 2));
        let b = ply_bytes(&vertices, &a, &[[0, 1, 2]], &["test".into()]);
        let text = String::from_utf8_lossy(&b);
        let end = text.find("end_header\n").expect("end_header") + "end_header\n".len();
        assert!(text.starts_with("ply\nformat binary_little_endian 1.0\ncomment test\n"));
        assert!(text.contains("element vertex 3\n") && text.contains("element face 1\n"));
        assert!(text.contains("property float speed\nproperty int material\n"));
        // x y z vx vy vz speed (f32) and material (i32) per vertex; one triangle.
        assert_eq!(b.len() - end, 3 * 32 + 13);
    }
}
