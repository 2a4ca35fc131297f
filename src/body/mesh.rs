//! Triangle meshes as object shapes (`shape = { type = "mesh", path = ... }`): loading
//! (OBJ via `tobj`, ASCII/binary PLY via `ply-rs-bw`), checks (closed, manifold,
//! consistently oriented, finite, non-empty), and sampling: surfels area-weighted over the
//! triangles then thinned Poisson-disk to the target spacing, phyxels on the cubic lattice
//! inside the surface by generalized winding number.

use crate::io::import::read_ply;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::f32::consts::PI;
use std::path::Path;

/// The surface of a `mesh` shape: a closed triangle mesh or an oriented point cloud.
#[derive(Clone, Debug, PartialEq)]
pub enum Surface {
    Triangles(TriMesh),
    Points(PointCloud),
}

impl Surface {
    /// Loads `path`: `.obj`, or `.ply` with faces (a mesh) or with normals and no faces
    /// (an oriented point cloud); scaled by `scale` and centred on its bounding box.
    pub fn load(path: &Path, scale: f32) -> Result<Self, String> {
        let name = path.display();
        let is_ply = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("ply"));
        if is_ply && path.exists() {
            return match load_ply(path)? {
                Loaded::Mesh((v, t)) => Ok(Surface::Triangles(
                    TriMesh::new(v, t)
                        .map_err(|e| format!("{name}: {e}"))?
                        .scaled_centred(scale),
                )),
                Loaded::Points(p, n) => Ok(Surface::Points(
                    PointCloud::new(p, n)
                        .map_err(|e| format!("{name}: {e}"))?
                        .scaled_centred(scale),
                )),
            };
        }
        TriMesh::load(path, scale).map(Surface::Triangles)
    }

    pub fn half_extents(&self) -> Vec3 {
        match self {
            Surface::Triangles(m) => m.half_extents(),
            Surface::Points(c) => c.half_extents(),
        }
    }

    pub fn area(&self) -> f32 {
        match self {
            Surface::Triangles(m) => m.area(),
            Surface::Points(c) => c.areas.iter().sum(),
        }
    }

    pub fn signed_volume(&self) -> f32 {
        match self {
            Surface::Triangles(m) => m.signed_volume(),
            Surface::Points(c) => c.volume(),
        }
    }

    pub fn sdf(&self, p: Vec3) -> f32 {
        match self {
            Surface::Triangles(m) => m.sdf(p),
            Surface::Points(c) => c.sdf(p),
        }
    }

    pub fn lattice_inside(&self, xs: &[f32], ys: &[f32], zs: &[f32]) -> Vec<Vec3> {
        lattice_points(xs, ys, zs)
            .into_par_iter()
            .filter(|&p| match self {
                Surface::Triangles(m) => m.contains(p),
                Surface::Points(c) => c.winding_number(p) > 0.5,
            })
            .collect()
    }

    pub fn sample_surface(&self, spacing: f32) -> (Vec<Vec3>, Vec<Vec3>, f32) {
        match self {
            Surface::Triangles(m) => m.sample_surface(spacing),
            Surface::Points(c) => c.sample_surface(spacing),
        }
    }
}

/// An oriented point cloud (positions with outward normals) sampling a closed surface.
/// Each point stands for an area `areas[i]` (from its 6 nearest neighbours); inside is
/// where the point-cloud generalized winding number (Barill et al. 2018) exceeds ½.
#[derive(Clone, Debug, PartialEq)]
pub struct PointCloud {
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub areas: Vec<f32>,
}

/// Largest net normal `|Σ aᵢ nᵢ|` of an oriented point cloud, as a share of its area,
/// taken as closed: area estimates of an uneven sampling leave a few percent; a flat
/// cloud gives 100%, a hemisphere 50%.
const OPEN_CLOUD_NET_NORMAL: f32 = 0.2;

impl PointCloud {
    /// Checks (finite, non-zero normals, at least 4 points) and estimates point areas.
    pub fn new(points: Vec<Vec3>, normals: Vec<Vec3>) -> Result<Self, String> {
        if points.len() < 4 {
            return Err(format!(
                "empty point cloud: {} points, need at least 4",
                points.len()
            ));
        }
        if let Some(i) = points.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "vertex {i} has a non-finite coordinate {}",
                points[i]
            ));
        }
        // A cloud flat in one axis (one point, a line, a plane) encloses nothing; said here,
        // since its area estimates come out zero and every later check would misreport it.
        let (lo, hi) = bounds(&points);
        let extent = hi - lo;
        if extent.min_element() <= 0.0 {
            return Err(format!(
                "the points span no volume: their bounding box is {} × {} × {} \
                 (all on one plane, line or point)",
                extent.x, extent.y, extent.z
            ));
        }
        let mut unit = Vec::with_capacity(normals.len());
        for (i, n) in normals.iter().enumerate() {
            let u = n.normalize_or_zero();
            if !n.is_finite() || u == Vec3::ZERO {
                return Err(format!("vertex {i} has a zero or non-finite normal {n}"));
            }
            unit.push(u);
        }
        let mut c = Self {
            points,
            normals: unit,
            areas: Vec::new(),
        };
        c.estimate_areas();
        c.check_closed()?;
        Ok(c)
    }

    /// An oriented cloud must sample a closed surface with outward normals: then
    /// `Σ aᵢ nᵢ` vanishes (a closed surface has no net normal) and the enclosed volume
    /// `⅓ Σ aᵢ xᵢ·nᵢ` is positive. A flat or open cloud, or one with inward normals,
    /// would otherwise become a body of one phyxel or none.
    fn check_closed(&self) -> Result<(), String> {
        let area: f32 = self.areas.iter().sum();
        let net = (0..self.points.len())
            .map(|i| self.areas[i] * self.normals[i])
            .sum::<Vec3>()
            .length();
        if net > OPEN_CLOUD_NET_NORMAL * area {
            return Err(format!(
                "the points do not sample a closed surface: their area-weighted normals sum \
                 to {:.0}% of the area (a closed surface gives about 0)",
                100.0 * net / area
            ));
        }
        let volume = self.volume();
        if volume <= 0.0 {
            return Err(format!(
                "the normals point inward: the enclosed volume comes out {volume:e} \
                 (outward normals give a positive volume)"
            ));
        }
        Ok(())
    }

    fn scaled_centred(mut self, scale: f32) -> Self {
        let (lo, hi) = bounds(&self.points);
        let centre = 0.5 * (lo + hi);
        for p in &mut self.points {
            *p = (*p - centre) * scale;
        }
        for a in &mut self.areas {
            *a *= scale * scale;
        }
        self
    }

    /// Area per point from the local density: with d the mean distance to the 6 nearest
    /// neighbours and ρ = 3d, aᵢ = πρ² / (points within ρ). A ball of radius ρ cuts a
    /// sphere (of any radius) in a cap of area exactly πρ², so the estimate is unbiased on
    /// curved surfaces too.
    fn estimate_areas(&mut self) {
        let (lo, hi) = bounds(&self.points);
        let d = hi - lo;
        let box_area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
        let h0 = (box_area / self.points.len() as f32).sqrt().max(1e-9);
        let cell = h0;
        let key = |p: Vec3| ((p - lo) / cell).floor().as_ivec3();
        let mut grid: HashMap<glam::IVec3, Vec<u32>> = HashMap::new();
        for (i, &p) in self.points.iter().enumerate() {
            grid.entry(key(p)).or_default().push(i as u32);
        }
        // Distances from p to the points within `reach` cells, self excluded.
        let near = |i: usize, reach: i32| -> Vec<f32> {
            let p = self.points[i];
            let c = key(p);
            let mut dist = Vec::new();
            for dz in -reach..=reach {
                for dy in -reach..=reach {
                    for dx in -reach..=reach {
                        if let Some(v) = grid.get(&(c + glam::IVec3::new(dx, dy, dz))) {
                            dist.extend(
                                v.iter()
                                    .filter(|&&j| j as usize != i)
                                    .map(|&j| self.points[j as usize].distance(p)),
                            );
                        }
                    }
                }
            }
            dist
        };
        self.areas = (0..self.points.len())
            .into_par_iter()
            .map(|i| {
                let mut reach = 1;
                let mut dist = near(i, reach);
                while dist.len() < 6 && reach < 8 {
                    reach *= 2;
                    dist = near(i, reach);
                }
                dist.sort_by(f32::total_cmp);
                let k = dist.len().min(6);
                if k == 0 {
                    return h0 * h0;
                }
                let rho = 3.0 * dist[..k].iter().sum::<f32>() / k as f32;
                let reach = (rho / cell).ceil() as i32;
                let inside = near(i, reach).iter().filter(|&&d| d < rho).count() + 1;
                PI * rho * rho / inside as f32
            })
            .collect();
    }

    pub fn half_extents(&self) -> Vec3 {
        let (lo, hi) = bounds(&self.points);
        0.5 * (hi - lo)
    }

    /// Enclosed volume by the divergence theorem, ⅓ Σ aᵢ (xᵢ − c)·nᵢ, about the centre
    /// `c` of the bounds: the same for a closed surface (Σ aᵢ nᵢ = 0), and neither the
    /// round-off nor a sampling's small net normal then scales with the distance from
    /// the origin.
    pub fn volume(&self) -> f32 {
        let (lo, hi) = bounds(&self.points);
        let centre = 0.5 * (lo + hi);
        (0..self.points.len())
            .map(|i| self.areas[i] * (self.points[i] - centre).dot(self.normals[i]))
            .sum::<f32>()
            / 3.0
    }

    /// Point-cloud generalized winding number about `q` (≈1 inside, ≈0 outside).
    pub fn winding_number(&self, q: Vec3) -> f32 {
        let mut w = 0.0f64;
        for i in 0..self.points.len() {
            let d = (self.points[i] - q).as_dvec3();
            // Regularised within a point's own footprint.
            let r = d.length().max(0.5 * (self.areas[i] as f64).sqrt());
            w += self.areas[i] as f64 * d.dot(self.normals[i].as_dvec3()) / (r * r * r);
        }
        (w / (4.0 * std::f64::consts::PI)) as f32
    }

    /// Distance to the nearest point, negative inside.
    pub fn sdf(&self, q: Vec3) -> f32 {
        let d = self
            .points
            .iter()
            .map(|p| p.distance(q))
            .fold(f32::INFINITY, f32::min);
        if self.winding_number(q) > 0.5 { -d } else { d }
    }

    /// The points thinned Poisson-disk towards `round(area / spacing²)` (all of them
    /// when the cloud is sparser than that), with their normals and the disk radius.
    pub fn sample_surface(&self, spacing: f32) -> (Vec<Vec3>, Vec<Vec3>, f32) {
        let area: f32 = self.areas.iter().sum();
        let target = (area / (spacing * spacing)).round().max(1.0) as usize;
        let cand: Vec<(Vec3, Vec3)> = self
            .points
            .iter()
            .zip(&self.normals)
            .map(|(&p, &n)| (p, n))
            .collect();
        let kept = thin_to(&cand, target, spacing);
        let pos: Vec<Vec3> = kept.iter().map(|&i| cand[i].0).collect();
        let nrm: Vec<Vec3> = kept.iter().map(|&i| cand[i].1).collect();
        let radius = (2.0 * area / (PI * pos.len().max(1) as f32)).sqrt();
        (pos, nrm, radius)
    }
}

fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    points
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}

/// Poisson-disk thinning of `cand` with the exclusion radius bisected so the count comes
/// within 0.5% of `target` (or as close as the candidates allow).
fn thin_to(cand: &[(Vec3, Vec3)], target: usize, spacing: f32) -> Vec<usize> {
    if cand.len() <= target {
        return (0..cand.len()).collect();
    }
    let (mut lo, mut hi) = (0.05 * spacing, 1.5 * spacing);
    let mut best = thin(cand, spacing);
    for _ in 0..24 {
        let r = 0.5 * (lo + hi);
        let kept = thin(cand, r);
        let err = (kept.len() as f32 - target as f32).abs();
        if err < (best.len() as f32 - target as f32).abs() {
            best = kept.clone();
        }
        if err <= 0.005 * target as f32 {
            break;
        }
        if kept.len() > target {
            lo = r;
        } else {
            hi = r;
        }
    }
    best
}

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
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_lowercase())
            .unwrap_or_default();
        let (vertices, triangles) = match ext.as_str() {
            "obj" => load_obj(path)?,
            "ply" => match load_ply(path)? {
                Loaded::Mesh(raw) => raw,
                Loaded::Points(..) => {
                    return Err(format!(
                        "{name}: a point cloud (no 'face' element), not a mesh"
                    ));
                }
            },
            _ => {
                return Err(format!(
                    "{name}: unknown mesh format '.{ext}' (supported: .obj, .ply)"
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

    fn scaled_centred(mut self, scale: f32) -> Self {
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

    fn corners(&self, t: usize) -> [Vec3; 3] {
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

    /// Lattice points inside the surface (the lattice given by per-axis coordinates).
    pub fn lattice_inside(&self, xs: &[f32], ys: &[f32], zs: &[f32]) -> Vec<Vec3> {
        lattice_points(xs, ys, zs)
            .into_par_iter()
            .filter(|&p| self.contains(p))
            .collect()
    }

    /// Area-weighted vertex normals.
    fn vertex_normals(&self) -> Vec<Vec3> {
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
fn thin(cand: &[(Vec3, Vec3)], r: f32) -> Vec<usize> {
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
struct SplitMix(u64);

impl SplitMix {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The point of triangle `abc` closest to `p` (Ericson, Real-Time Collision Detection).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
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

type Raw = (Vec<Vec3>, Vec<[u32; 3]>);

/// OBJ statements that carry no geometry the loader uses (names, groups, smoothing,
/// materials, free-form surfaces); they are skipped. Any other keyword is an error, so a
/// damaged file does not load as a silently smaller mesh.
const OBJ_SKIPPED: [&str; 28] = [
    "vp",
    "l",
    "p",
    "o",
    "g",
    "s",
    "mg",
    "usemtl",
    "mtllib",
    "usemap",
    "maplib",
    "lod",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "end",
];

/// The first OBJ line (1-based) whose vertex or face data does not parse, or whose
/// keyword is not OBJ's, for error messages (the OBJ parser does not report lines).
fn obj_bad_line(path: &Path) -> Option<(usize, String)> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut vertices = 0i64;
    for (k, line) in text.lines().enumerate() {
        let mut tok = line.split_whitespace();
        let ok = match tok.next() {
            Some("v") => {
                vertices += 1;
                let c: Vec<_> = tok.collect();
                c.len() >= 3 && c.iter().all(|t| t.parse::<f32>().is_ok())
            }
            Some("vn") | Some("vt") => tok.all(|t| t.parse::<f32>().is_ok()),
            Some("f") => {
                let c: Vec<_> = tok.collect();
                c.len() >= 3
                    && c.iter().all(|t| {
                        let i = t.split('/').next().and_then(|i| i.parse::<i64>().ok());
                        i.is_some_and(|i| i != 0 && i.abs() <= vertices)
                    })
            }
            Some(word) => word.starts_with('#') || OBJ_SKIPPED.contains(&word),
            None => true,
        };
        if !ok {
            return Some((k + 1, line.trim().to_string()));
        }
    }
    None
}

fn load_obj(path: &Path) -> Result<Raw, String> {
    let name = path.display();
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj(path, &opts).map_err(|e| match obj_bad_line(path) {
        Some((line, text)) => format!("{name}: line {line}: cannot read OBJ ({e}): '{text}'"),
        None => format!("{name}: cannot read OBJ: {e}"),
    })?;
    // The parser skips what it does not know; a line that is not OBJ is refused here.
    if let Some((line, text)) = obj_bad_line(path) {
        return Err(format!(
            "{name}: line {line}: not an OBJ statement: '{text}'"
        ));
    }
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for m in &models {
        let base = vertices.len() as u32;
        let p = &m.mesh.positions;
        vertices.extend(p.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        triangles.extend(
            m.mesh
                .indices
                .chunks_exact(3)
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
    }
    Ok((vertices, triangles))
}

/// What a PLY file holds.
enum Loaded {
    Mesh(Raw),
    Points(Vec<Vec3>, Vec<Vec3>),
}

/// Three scalar properties of every vertex as vectors; the error names the file, the
/// vertex and the missing property.
fn vertex_vectors(
    verts: &[ply_rs_bw::ply::DefaultElement],
    props: [&str; 3],
    name: &impl std::fmt::Display,
) -> Result<Vec<Vec3>, String> {
    verts
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let mut c = [0.0f32; 3];
            for (k, prop) in props.iter().enumerate() {
                c[k] = e
                    .get(*prop)
                    .and_then(|p| p.to_f32_lossy())
                    .ok_or_else(|| format!("{name}: element 'vertex' {i}: no scalar '{prop}'"))?;
            }
            Ok(Vec3::from(c))
        })
        .collect()
}

fn load_ply(path: &Path) -> Result<Loaded, String> {
    let name = path.display();
    let ply = read_ply(path)?;
    let verts = ply
        .payload
        .get("vertex")
        .ok_or_else(|| format!("{name}: no 'vertex' element"))?;
    let vertices = vertex_vectors(verts, ["x", "y", "z"], &name)?;
    let Some(faces) = ply.payload.get("face") else {
        // A point cloud: usable with normals.
        let has_normals = verts
            .first()
            .is_some_and(|e| ["nx", "ny", "nz"].iter().all(|k| e.contains_key(*k)));
        if !has_normals {
            return Err(format!(
                "{name}: no 'face' element, and no normals (nx ny nz) for an oriented point \
                 cloud: a mesh shape needs triangles or oriented points"
            ));
        }
        let normals = vertex_vectors(verts, ["nx", "ny", "nz"], &name)?;
        return Ok(Loaded::Points(vertices, normals));
    };
    let mut triangles = Vec::with_capacity(faces.len());
    for (i, f) in faces.iter().enumerate() {
        let idx = f
            .get("vertex_indices")
            .or_else(|| f.get("vertex_index"))
            .and_then(|p| p.to_u32_list())
            .ok_or_else(|| {
                format!("{name}: element 'face' {i}: no integer list 'vertex_indices'")
            })?;
        if idx.len() < 3 {
            return Err(format!(
                "{name}: element 'face' {i}: {} vertices, need at least 3",
                idx.len()
            ));
        }
        for k in 1..idx.len() - 1 {
            triangles.push([idx[0], idx[k], idx[k + 1]]);
        }
    }
    Ok(Loaded::Mesh((vertices, triangles)))
}

/// The lattice points of per-axis coordinates, z slowest (the phyxel order of shapes).
fn lattice_points(xs: &[f32], ys: &[f32], zs: &[f32]) -> Vec<Vec3> {
    zs.iter()
        .flat_map(|&z| {
            ys.iter()
                .flat_map(move |&y| xs.iter().map(move |&x| Vec3::new(x, y, z)))
        })
        .collect()
}
