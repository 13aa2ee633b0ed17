//! Triangle meshes in 3D, parsed from Wavefront OBJ text, and their inside test, for bodies
//! clipped to a mesh ([`super::Body::mesh`]).
//!
//! Only `v` (vertex) and `f` (face) records are read; faces with more than three corners are
//! split into a fan of triangles, `f 1/2/3` style references use their first number, and
//! negative (relative) indices are supported. Every other record is ignored.
//!
//! A point is inside when the generalised winding number of the mesh about it exceeds ½ in
//! magnitude (Jacobson et al. 2013). The winding number is exact for closed meshes of either
//! orientation and degrades gracefully for meshes with small holes.

use rayon::prelude::*;

/// A triangle mesh in 3D (m).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions (m).
    pub vertices: Vec<[f64; 3]>,
    /// Triangles as vertex indices.
    pub triangles: Vec<[usize; 3]>,
}

/// Largest number of triangles read (memory and run-time guard).
pub const MAX_TRIANGLES: usize = 2_000_000;

/// Parses OBJ text. Errors are one-line messages naming, for syntax errors, the line.
pub fn parse_obj(text: &str) -> Result<TriMesh, String> {
    let mut mesh = TriMesh::default();
    for (ln, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        let mut parts = line.split_whitespace();
        match parts.next() {
            Some("v") => {
                let mut p = [0.0; 3];
                for c in &mut p {
                    let tok = parts
                        .next()
                        .ok_or_else(|| format!("line {}: a vertex needs 3 coordinates", ln + 1))?;
                    *c = tok
                        .parse::<f64>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| format!("line {}: bad coordinate \"{tok}\"", ln + 1))?;
                }
                mesh.vertices.push(p);
            }
            Some("f") => {
                let n = mesh.vertices.len() as i64;
                let mut idx = Vec::new();
                for tok in parts {
                    let first = tok.split('/').next().unwrap_or("");
                    let i: i64 = first
                        .parse()
                        .map_err(|_| format!("line {}: bad vertex index \"{tok}\"", ln + 1))?;
                    let i = if i < 0 { n + i } else { i - 1 };
                    if i < 0 || i >= n {
                        return Err(format!(
                            "line {}: vertex index {first} out of range (1..={n} defined so far)",
                            ln + 1
                        ));
                    }
                    idx.push(i as usize);
                }
                if idx.len() < 3 {
                    return Err(format!("line {}: a face needs at least 3 vertices", ln + 1));
                }
                for k in 1..idx.len() - 1 {
                    mesh.triangles.push([idx[0], idx[k], idx[k + 1]]);
                }
                if mesh.triangles.len() > MAX_TRIANGLES {
                    return Err(format!("more than {MAX_TRIANGLES} triangles"));
                }
            }
            _ => {}
        }
    }
    if mesh.triangles.is_empty() {
        return Err("no faces (an OBJ mesh needs `f` records)".into());
    }
    Ok(mesh)
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Rotation matrix for Euler angles (degrees) applied about the fixed x, then y, then z axes:
/// `R = Rz · Ry · Rx`.
pub fn euler_rotation(deg: [f64; 3]) -> [[f64; 3]; 3] {
    let [a, b, c] = deg.map(f64::to_radians);
    let (sa, ca) = a.sin_cos();
    let (sb, cb) = b.sin_cos();
    let (sc, cc) = c.sin_cos();
    let rx = [[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]];
    let ry = [[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]];
    let rz = [[cc, -sc, 0.0], [sc, cc, 0.0], [0.0, 0.0, 1.0]];
    matmul(&rz, &matmul(&ry, &rx))
}

fn matmul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

impl TriMesh {
    /// The mesh with `x ↦ R (scale ⊙ x) + translation`, `R` from [`euler_rotation`].
    pub fn transformed(
        &self,
        scale: [f64; 3],
        rotation_deg: [f64; 3],
        translation: [f64; 3],
    ) -> Self {
        let r = euler_rotation(rotation_deg);
        let vertices = self
            .vertices
            .iter()
            .map(|v| {
                let s = [v[0] * scale[0], v[1] * scale[1], v[2] * scale[2]];
                std::array::from_fn(|i| dot(r[i], s) + translation[i])
            })
            .collect();
        Self {
            vertices,
            triangles: self.triangles.clone(),
        }
    }

    /// Bounding box of the vertices used by triangles (m).
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for t in &self.triangles {
            for &i in t {
                for a in 0..3 {
                    lo[a] = lo[a].min(self.vertices[i][a]);
                    hi[a] = hi[a].max(self.vertices[i][a]);
                }
            }
        }
        (lo, hi)
    }

    /// Enclosed volume (m³, absolute value of the signed volume; exact for closed meshes).
    pub fn volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i]);
                dot(a, cross(b, c)) / 6.0
            })
            .sum::<f64>()
            .abs()
    }

    /// Generalised winding number about `p` (1 inside a closed, outward-oriented mesh, 0
    /// outside, −1 inside an inward-oriented one).
    pub fn winding_number(&self, p: [f64; 3]) -> f64 {
        let mut omega = 0.0;
        for t in &self.triangles {
            let a = sub(self.vertices[t[0]], p);
            let b = sub(self.vertices[t[1]], p);
            let c = sub(self.vertices[t[2]], p);
            let (la, lb, lc) = (norm(a), norm(b), norm(c));
            let det = dot(a, cross(b, c));
            let den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
            omega += 2.0 * det.atan2(den);
        }
        omega / (4.0 * std::f64::consts::PI)
    }

    /// Whether `p` is inside the mesh (|winding number| > ½).
    pub fn contains(&self, p: [f64; 3]) -> bool {
        self.winding_number(p).abs() > 0.5
    }

    /// [`Self::contains`] for many points, in parallel.
    pub fn contains_all(&self, points: &[[f64; 3]]) -> Vec<bool> {
        points.par_iter().map(|p| self.contains(*p)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit cube [0, 1]³ as 6 quads.
    pub const CUBE: &str =
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
        f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

    #[test]
    fn cube_inside_test_and_volume() {
        let m = parse_obj(CUBE).expect("valid OBJ");
        assert_eq!(m.triangles.len(), 12);
        assert!((m.volume() - 1.0).abs() < 1e-12);
        assert!((m.winding_number([0.5, 0.5, 0.5]) - 1.0).abs() < 1e-9);
        assert!(m.contains([0.1, 0.9, 0.5]));
        assert!(!m.contains([1.1, 0.5, 0.5]));
        assert!(!m.contains([-0.5, 2.0, 0.5]));
        let t = m.transformed([2.0, 1.0, 1.0], [0.0, 0.0, 90.0], [10.0, 0.0, 0.0]);
        // x ∈ [0, 2] scaled, rotated 90° about z: (x, y) → (−y, x), then shifted by 10 in x.
        let (lo, hi) = t.bounds();
        assert!((lo[0] - 9.0).abs() < 1e-12 && (hi[0] - 10.0).abs() < 1e-12);
        assert!((lo[1]).abs() < 1e-12 && (hi[1] - 2.0).abs() < 1e-12);
        assert!(t.contains([9.5, 1.5, 0.5]));
    }

    #[test]
    fn bad_obj_is_an_error() {
        assert!(parse_obj("v 0 0 0\n").is_err());
        assert!(parse_obj("v 0 0\nf 1 1 1\n").is_err());
        assert!(parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").is_err());
        assert!(parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").is_ok());
    }
}
