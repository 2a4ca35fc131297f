//! Closed triangle meshes as shapes: checks, winding number, distance, and surfels
//! sampled area-weighted over the triangles.

use super::cloud::thin_to;
use super::load::{Loaded, load_obj, load_ply, load_stl};
use super::*;

/// A closed, consistently outward-oriented triangle mesh, centred on its bounding box.
#[derive(Clone, Debug, PartialEq)]
pub struct TriMesh {
    pub vertices: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Loads `path` (`.obj` or `.ply`), scales it by `scale`, centres it on its bounding
    /// box and checks it can be filled. Errors name the file and what is wrong.
    pub fn load(path: &Path, scale: f32) -> Result<Self, String> {
        let name = path.display();
        if !path.exists() {
            return Err(format!("{name}: no such mesh file"));
        }
        if path.is_dir() {
            return Err(format!("{name}: a directory, not a mesh file"));
        }
        crate::io::check_input_file(path, crate::io::INPUT_FILE_LIMIT)
            .map_err(|e| format!("{name}: {e}"))?;
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_lowercase())
            .unwrap_or_default();
        let (vertices, triangles) = match ext.as_str() {
            "obj" => load_obj(path)?,
            "stl" => load_stl(path)?,
            "ply" => match load_ply(path)? {
                Loaded::Mesh(raw) => raw,
                Loaded::Points(..) => {
                    return Err(format!(
                        "{name}: a point cloud (no 'face' element), not a mesh"
                    ));
                }
            },
            "" => {
                return Err(format!(
                    "{name}: no file extension, so no mesh format: name it .obj, .ply or .stl"
                ));
            }
            _ => {
                return Err(format!(
                    "{name}: unknown mesh format '.{ext}' (supported: .obj, .ply, .stl)"
                ));
            }
        };
        let mesh = Self::new(vertices, triangles).map_err(|e| format!("{name}: {e}"))?;
        Ok(mesh.scaled_centred(scale))
    }

    /// Checks and orients a mesh: finite vertices, indices in range, at least one
    /// triangle, every edge shared by exactly two triangles with opposite directions
    /// (closed, manifold, consistently oriented); turned outward if it was inside out.
    pub fn new(vertices: Vec<Vec3>, mut triangles: Vec<[u32; 3]>) -> Result<Self, String> {
        if triangles.is_empty() {
            return Err("empty mesh: no triangles".into());
        }
        if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "vertex {i} has a non-finite coordinate {}",
                vertices[i]
            ));
        }
        let n = vertices.len() as u32;
        if let Some((t, tri)) = triangles
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&v| v >= n))
        {
            return Err(format!(
                "triangle {t} refers to vertex {} but the mesh has {n} vertices",
                tri.iter().max().unwrap()
            ));
        }
        // Directed edges: each must appear once, and its reverse once.
        let mut edges: HashMap<(u32, u32), usize> = HashMap::with_capacity(3 * triangles.len());
        for (t, tri) in triangles.iter().enumerate() {
            if tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0] {
                continue; // degenerate: no area, no edges
            }
            for k in 0..3 {
                let e = (tri[k], tri[(k + 1) % 3]);
                if let Some(t0) = edges.insert(e, t) {
                    return Err(format!(
                        "non-manifold or inconsistently oriented mesh: edge ({}, {}) is used in \
                         the same direction by triangles {t0} and {t}; phyxel fill needs a closed, \
                         consistently oriented surface",
                        e.0, e.1
                    ));
                }
            }
        }
        for (t, tri) in triangles.iter().enumerate() {
            if tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0] {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                if !edges.contains_key(&(b, a)) {
                    return Err(format!(
                        "open mesh: edge ({a}, {b}) of triangle {t} has no neighbouring \
                         triangle (a hole or boundary); phyxel fill needs a closed surface"
                    ));
                }
            }
        }
        let mut mesh = Self {
            vertices,
            triangles: Vec::new(),
        };
        triangles.retain(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0]);
        mesh.triangles = triangles;
        let vol = mesh.signed_volume();
        if vol == 0.0 || vol.is_nan() {
            return Err("the mesh encloses no volume".into());
        }
        if vol < 0.0 {
            for t in &mut mesh.triangles {
                t.swap(1, 2);
            }
        }
        Ok(mesh)
    }

    pub(super) fn scaled_centred(mut self, scale: f32) -> Self {
        let (lo, hi) = self.bounds();
        let c = 0.5 * (lo + hi);
        for v in &mut self.vertices {
            *v = (*v - c) * scale;
        }
        self
    }

    /// Axis-aligned bounds of the vertices.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.vertices
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            })
    }

    /// Half the bounding box size.
    pub fn half_extents(&self) -> Vec3 {
        let (lo, hi) = self.bounds();
        0.5 * (hi - lo)
    }

    pub(super) fn corners(&self, t: usize) -> [Vec3; 3] {
        self.triangles[t].map(|i| self.vertices[i as usize])
    }

    /// Enclosed volume (positive once oriented outward).
    pub fn signed_volume(&self) -> f32 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t).map(Vec3::as_dvec3);
                a.dot(b.cross(c)) / 6.0
            })
            .sum::<f64>() as f32
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    /// Generalized winding number of the surface about `p` (1 inside, 0 outside).
    pub fn winding_number(&self, p: Vec3) -> f32 {
        let p = p.as_dvec3();
        let mut sum = 0.0f64;
        for t in 0..self.triangles.len() {
            let [a, b, c] = self.corners(t).map(|v| v.as_dvec3() - p);
            let (la, lb, lc) = (a.length(), b.length(), c.length());
            let num = a.dot(b.cross(c));
            let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
            sum += 2.0 * num.atan2(den);
        }
        (sum / (4.0 * std::f64::consts::PI)) as f32
    }

    /// True when `p` is inside the closed surface.
    pub fn contains(&self, p: Vec3) -> bool {
        self.winding_number(p) > 0.5
    }

    /// Distance from `p` to the surface.
    pub fn distance(&self, p: Vec3) -> f32 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                (closest_on_triangle(p.as_dvec3(), a.as_dvec3(), b.as_dvec3(), c.as_dvec3())
                    - p.as_dvec3())
                .length() as f32
            })
            .fold(f32::INFINITY, f32::min)
    }

    /// Signed distance (negative inside).
    pub fn sdf(&self, p: Vec3) -> f32 {
        let d = self.distance(p);
        if self.contains(p) { -d } else { d }
    }

    /// Of the surface samples `points` with outward `normals`, how many have their point
    /// `offset` outside along the normal still inside the solid (winding number above
    /// one half), and how many were tested: a mesh whose parts overlap (two cubes in one
    /// file) has part of its surface inside itself. At most `budget` winding-number
    /// terms are spent (samples evenly strided, at least one).
    pub fn buried_samples(
        &self,
        points: &[Vec3],
        normals: &[Vec3],
        offset: f32,
        budget: f64,
    ) -> (usize, usize) {
        let per = self.triangles.len().max(1) as f64;
        let want = ((budget / per) as usize).clamp(1, points.len().max(1));
        let stride = points.len().div_ceil(want).max(1);
        let picked: Vec<usize> = (0..points.len()).step_by(stride).collect();
        let buried = picked
            .par_iter()
            .filter(|&&i| self.winding_number(points[i] + offset * normals[i]) > 0.5)
            .count();
        (buried, picked.len())
    }

    /// Lattice points inside the surface (the lattice given by per-axis coordinates).
    pub fn lattice_inside(&self, xs: &[f32], ys: &[f32], zs: &[f32]) -> Vec<Vec3> {
        lattice_points(xs, ys, zs)
            .into_par_iter()
            .filter(|&p| self.contains(p))
            .collect()
    }

    /// Area-weighted vertex normals.
    pub(super) fn vertex_normals(&self) -> Vec<Vec3> {
        let mut n = vec![Vec3::ZERO; self.vertices.len()];
        for (t, tri) in self.triangles.iter().enumerate() {
            let [a, b, c] = self.corners(t);
            let fn_ = (b - a).cross(c - a); // length = 2 × area
            for &v in tri {
                n[v as usize] += fn_;
            }
        }
        n.into_iter().map(|v| v.normalize_or_zero()).collect()
    }

    /// Surfels about `spacing` apart: `round(area / spacing²)` of them (the density of the
    /// built-in shapes), by area-weighted random samples (fixed seed) thinned Poisson-disk
    /// with a radius tuned to the target count. Normals: the interpolated vertex normal
    /// where it is within 30° of the face normal (smooth parts), else the face normal
    /// (creases). Returns positions, normals and the disk radius.
    pub fn sample_surface(&self, spacing: f32) -> (Vec<Vec3>, Vec<Vec3>, f32) {
        let area = self.area();
        let target = (area / (spacing * spacing)).round().max(1.0) as usize;
        // Candidates: 8 per target surfel, area-weighted.
        let mut cdf = Vec::with_capacity(self.triangles.len());
        let mut acc = 0.0f64;
        for t in 0..self.triangles.len() {
            let [a, b, c] = self.corners(t);
            acc += 0.5 * (b - a).cross(c - a).length() as f64;
            cdf.push(acc);
        }
        let vn = self.vertex_normals();
        let mut rng = SplitMix(0x5eed_1234_abcd_0042);
        let n_cand = (8 * target).max(64);
        let mut cand = Vec::with_capacity(n_cand);
        for _ in 0..n_cand {
            let u = rng.next_f64() * acc;
            let t = cdf
                .partition_point(|&c| c < u)
                .min(self.triangles.len() - 1);
            let [a, b, c] = self.corners(t);
            let (mut r1, mut r2) = (rng.next_f64() as f32, rng.next_f64() as f32);
            if r1 + r2 > 1.0 {
                (r1, r2) = (1.0 - r1, 1.0 - r2);
            }
            let p = a + r1 * (b - a) + r2 * (c - a);
            let face = (b - a).cross(c - a).normalize_or_zero();
            let tri = self.triangles[t];
            let smooth = ((1.0 - r1 - r2) * vn[tri[0] as usize]
                + r1 * vn[tri[1] as usize]
                + r2 * vn[tri[2] as usize])
                .normalize_or_zero();
            let n = if smooth.dot(face) > 30f32.to_radians().cos() {
                smooth
            } else {
                face
            };
            cand.push((p, n));
        }
        let best = thin_to(&cand, target, spacing);
        let pos: Vec<Vec3> = best.iter().map(|&i| cand[i].0).collect();
        let nrm: Vec<Vec3> = best.iter().map(|&i| cand[i].1).collect();
        let radius = (2.0 * area / (PI * pos.len().max(1) as f32)).sqrt();
        (pos, nrm, radius)
    }
}

/// Greedy Poisson-disk thinning in candidate order: indices of kept candidates no two
/// closer than `r`.
pub(super) fn thin(cand: &[(Vec3, Vec3)], r: f32) -> Vec<usize> {
    let cell = |p: Vec3| (p / r).floor().as_ivec3();
    let mut grid: HashMap<glam::IVec3, Vec<usize>> = HashMap::new();
    let mut kept = Vec::new();
    'next: for (i, &(p, _)) in cand.iter().enumerate() {
        let c = cell(p);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(v) = grid.get(&(c + glam::IVec3::new(dx, dy, dz)))
                        && v.iter().any(|&j| cand[j].0.distance_squared(p) < r * r)
                    {
                        continue 'next;
                    }
                }
            }
        }
        grid.entry(c).or_default().push(i);
        kept.push(i);
    }
    kept
}

/// A small deterministic generator (SplitMix64).
pub(super) struct SplitMix(u64);

impl SplitMix {
    pub(super) fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The point of triangle `abc` closest to `p` (Ericson, Real-Time Collision Detection).
pub(super) fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}
