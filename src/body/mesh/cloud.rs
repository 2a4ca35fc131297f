//! Oriented point clouds as shapes: inside by the generalized winding number (Barill et
//! al. 2018), areas from nearest neighbours, surfels thinned from the points.

use super::trimesh::thin;
use super::*;

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
pub(super) const OPEN_CLOUD_NET_NORMAL: f32 = 0.2;

impl PointCloud {
    /// Checks (finite, non-zero normals, at least 4 points) and estimates point areas.
    pub fn new(points: Vec<Vec3>, normals: Vec<Vec3>) -> Result<Self, String> {
        if points.len() < 4 {
            let n = points.len();
            return Err(if n == 0 {
                "empty point cloud: no points, need at least 4".to_string()
            } else {
                format!(
                    "a point cloud of {n} point{}: too few to close a surface, need at least 4",
                    if n == 1 { "" } else { "s" }
                )
            });
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
    pub(super) fn check_closed(&self) -> Result<(), String> {
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

    pub(super) fn scaled_centred(mut self, scale: f32) -> Self {
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
    pub(super) fn estimate_areas(&mut self) {
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

pub(super) fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    points
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}

/// Poisson-disk thinning of `cand` with the exclusion radius bisected so the count comes
/// within 0.5% of `target` (or as close as the candidates allow).
pub(super) fn thin_to(cand: &[(Vec3, Vec3)], target: usize, spacing: f32) -> Vec<usize> {
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
