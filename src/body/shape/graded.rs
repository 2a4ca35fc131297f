//! Graded sampling: phyxels and surfels finer inside given zones, grading back to the
//! base spacing.
//!
//! The base lattice's cells (edge `spacing`) are split in eight, level by level, as
//! an octree: a cell of edge `c` is split while some zone asks for a spacing finer than
//! `c` and lies within [`GRADE`]` · c` of the cell. Each leaf whose centre is inside the
//! shape is a phyxel with the leaf's cell as its starting volume (then fitted to the
//! solid's moments, [`super::quadrature`]); the surfels of level `k` are the shape's
//! surface sampled at `surfel_spacing / 2ᵏ`, kept where the leaf under them has level
//! `k`. Neighbouring leaves differ by at most one level (a factor 2 in spacing): a leaf
//! of edge `c` that touches a cell split twice finer would lie within
//! `c + (√3/2)c < 2c` of that cell's zone and be split itself.

use glam::Vec3;
use rayon::prelude::*;

use super::{Shape, SurfaceSample, VolumeSample, fitted_count, lattice_axis};

/// Width of each level's band around a zone, in that level's cells: 2 keeps
/// neighbouring leaves within a factor 2 of each other (module doc).
pub const GRADE: f32 = 2.0;

/// Deepest level a zone may ask for: 2⁶ = 64 times finer than the base spacing (the
/// base lattice's sdf tests then grow 64³-fold inside the zone).
pub const MAX_LEVEL: u32 = 6;

/// Where a body is sampled finer, in object-local coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Zone {
    Box { min: Vec3, max: Vec3 },
    Sphere { centre: Vec3, radius: f32 },
}

impl Zone {
    /// Distance from the zone to the axis-aligned box `[lo, hi]` (0 where they meet).
    pub fn distance_to_box(&self, lo: Vec3, hi: Vec3) -> f32 {
        match *self {
            Zone::Box { min, max } => (min - hi).max(lo - max).max(Vec3::ZERO).length(),
            Zone::Sphere { centre, radius } => {
                (centre.clamp(lo, hi).distance(centre) - radius).max(0.0)
            }
        }
    }
}

/// A zone and the phyxel spacing it asks for (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Refinement {
    pub zone: Zone,
    pub spacing: f32,
}

/// The base spacing and the zones sampled finer.
#[derive(Clone, Debug, PartialEq)]
pub struct Grading {
    /// Phyxel spacing outside every zone's band (m).
    pub base: f32,
    pub zones: Vec<Refinement>,
}

/// A leaf cell: its centre, edge (m) and level (edge = base / 2^level).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    pub centre: Vec3,
    pub edge: f32,
    pub level: u32,
}

impl Grading {
    /// The level a zone's spacing asks for: the first whose edge `base / 2ᵏ` is no
    /// coarser than it (within 0.1%), at most [`MAX_LEVEL`].
    pub fn level_of(&self, spacing: f32) -> u32 {
        let ratio = self.base / spacing;
        if ratio <= 1.001 {
            return 0;
        }
        ((ratio / 1.001).log2().ceil() as u32).min(MAX_LEVEL)
    }

    /// Deepest level any zone asks for.
    pub fn finest_level(&self) -> u32 {
        self.zones
            .iter()
            .map(|r| self.level_of(r.spacing))
            .max()
            .unwrap_or(0)
    }

    /// True when the cell `[lo, hi]` at `level` is split.
    fn split(&self, lo: Vec3, hi: Vec3, level: u32) -> bool {
        let edge = self.base / (1u32 << level) as f32;
        self.zones.iter().any(|r| {
            level < self.level_of(r.spacing) && r.zone.distance_to_box(lo, hi) < GRADE * edge
        })
    }

    /// The leaves under the base cell centred at `centre`, depth first in z, y, x order.
    fn leaves(&self, centre: Vec3, level: u32, out: &mut Vec<Cell>) {
        let edge = self.base / (1u32 << level) as f32;
        let half = Vec3::splat(0.5 * edge);
        if !self.split(centre - half, centre + half, level) {
            out.push(Cell {
                centre,
                edge,
                level,
            });
            return;
        }
        let q = 0.25 * edge;
        for z in [-q, q] {
            for y in [-q, q] {
                for x in [-q, q] {
                    self.leaves(centre + Vec3::new(x, y, z), level + 1, out);
                }
            }
        }
    }

    /// Level of the leaf containing `x`, the base cells tiling
    /// `[−half_lattice, half_lattice]` (a point beyond them is taken at the nearest).
    fn level_at(&self, x: Vec3, half_lattice: Vec3) -> u32 {
        // The base cell containing x: cells tile [−half_lattice, half_lattice].
        let b = self.base;
        let rel = (x + half_lattice) / b;
        let counts = (2.0 * half_lattice / b).round();
        let idx = rel.floor().clamp(Vec3::ZERO, counts - Vec3::ONE);
        let mut centre = -half_lattice + (idx + Vec3::splat(0.5)) * b;
        let mut level = 0;
        loop {
            let edge = b / (1u32 << level) as f32;
            let half = Vec3::splat(0.5 * edge);
            if !self.split(centre - half, centre + half, level) {
                return level;
            }
            let q = 0.25 * edge;
            centre += Vec3::select(x.cmpge(centre), Vec3::splat(q), Vec3::splat(-q));
            level += 1;
        }
    }
}

impl Shape {
    /// Half extents of the base lattice's cells at `spacing`: `counts · spacing / 2`
    /// per axis, the lattice of [`Shape::sample_volume`].
    fn lattice_half(&self, spacing: f32) -> ([usize; 3], Vec3) {
        let counts = self
            .half_extents()
            .to_array()
            .map(|h| fitted_count(h, spacing));
        let half = Vec3::from_array(counts.map(|n| 0.5 * n as f32 * spacing));
        (counts, half)
    }

    /// Phyxels of a graded lattice (module doc) with volumes fitted to the solid's
    /// moments, each leaf's cell its starting volume: for the nodal-integration
    /// backends. `cell_volume` is the base cell's. A shape with no exact moments (a point
    /// cloud) keeps the leaves' cell volumes.
    ///
    /// # Panics
    /// As [`Shape::sample_volume`], and for a plane (a surface has no volume to grade).
    pub fn sample_volume_graded(&self, grading: &Grading) -> (VolumeSample, Vec<u32>) {
        let spacing = grading.base;
        super::check_spacing(spacing);
        self.check_loaded("sample_volume_graded");
        assert!(
            !matches!(self, Shape::Plane { .. }),
            "Shape::sample_volume_graded: a plane has no volume to grade"
        );
        let (counts, _) = self.lattice_half(spacing);
        let [xs, ys, zs] = counts.map(|n| lattice_axis(n, spacing).collect::<Vec<_>>());
        let mut cells = Vec::new();
        for &z in &zs {
            for &y in &ys {
                for &x in &xs {
                    grading.leaves(Vec3::new(x, y, z), 0, &mut cells);
                }
            }
        }
        let inside: Vec<bool> = cells.par_iter().map(|c| self.sdf(c.centre) < 0.0).collect();
        let kept: Vec<Cell> = cells
            .into_iter()
            .zip(inside)
            .filter_map(|(c, i)| i.then_some(c))
            .collect();
        let positions: Vec<Vec3> = kept.iter().map(|c| c.centre).collect();
        let levels: Vec<u32> = kept.iter().map(|c| c.level).collect();
        let cells: Vec<f32> = kept.iter().map(|c| c.edge.powi(3)).collect();
        let volumes = match self.moments() {
            Some(m) => super::quadrature::fitted_volumes(&positions, &cells, &m),
            None => cells,
        };
        let sample = VolumeSample {
            positions,
            cell_volume: spacing.powi(3),
            volumes,
        };
        (sample, levels)
    }

    /// Surfels of a graded sampling: those of [`Shape::sample_surface`] at
    /// `surfel_spacing / 2ᵏ` where the leaf of the phyxel lattice under them has level
    /// `k` (module doc), each with its level's disk radius. Also returns each surfel's
    /// level.
    ///
    /// # Panics
    /// As [`Shape::sample_surface`].
    pub fn sample_surface_graded(
        &self,
        surfel_spacing: f32,
        grading: &Grading,
    ) -> (SurfaceSample, Vec<u32>) {
        let (_, half) = self.lattice_half(grading.base);
        let mut out = SurfaceSample::default();
        let mut levels = Vec::new();
        for level in 0..=grading.finest_level() {
            let s = self.sample_surface(surfel_spacing / (1u32 << level) as f32);
            for ((p, n), r) in s.positions.into_iter().zip(s.normals).zip(s.radii) {
                if grading.level_at(p, half) == level {
                    out.positions.push(p);
                    out.normals.push(n);
                    out.radii.push(r);
                    levels.push(level);
                }
            }
        }
        (out, levels)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere_grading() -> (Shape, Grading) {
        let shape = Shape::Sphere { radius: 0.1 };
        let grading = Grading {
            base: 0.02,
            zones: vec![Refinement {
                zone: Zone::Sphere {
                    centre: Vec3::new(0.0, -0.1, 0.0),
                    radius: 0.03,
                },
                spacing: 0.005,
            }],
        };
        (shape, grading)
    }

    /// Neighbouring leaves differ by at most one level (the module doc's argument,
    /// checked by brute force): any two leaf centres closer than the sum of their
    /// half diagonals (touching cells) are within a factor 2 in edge.
    #[test]
    fn neighbouring_leaves_differ_by_one_level_at_most() {
        let (shape, grading) = sphere_grading();
        let (sample, levels) = shape.sample_volume_graded(&grading);
        assert_eq!(grading.finest_level(), 2);
        assert!(levels.contains(&2) && levels.contains(&0));
        let edge = |l: u32| grading.base / (1u32 << l) as f32;
        for i in 0..levels.len() {
            for j in 0..levels.len() {
                let d = (sample.positions[i] - sample.positions[j]).abs();
                let reach = 0.5 * (edge(levels[i]) + edge(levels[j])) * 1.0001;
                if d.max_element() <= reach {
                    assert!(
                        levels[i].abs_diff(levels[j]) <= 1,
                        "leaves {i} (level {}) and {j} (level {}) touch",
                        levels[i],
                        levels[j]
                    );
                }
            }
        }
    }

    /// The surfels' levels are the phyxel leaves' under them, and each level's disks
    /// cover its share of the surface: the disks' area `Σ π r²/2` (the sampler's radius
    /// is twice the per-surfel area) is the sphere's within 5% (the seams between
    /// levels are the rest).
    #[test]
    fn graded_surfels_cover_the_surface_once() {
        let (shape, grading) = sphere_grading();
        let (s, levels) = shape.sample_surface_graded(0.01, &grading);
        assert!(levels.contains(&2) && levels.contains(&0));
        let area: f32 = s
            .radii
            .iter()
            .map(|r| 0.5 * std::f32::consts::PI * r * r)
            .sum();
        let exact = shape.area();
        assert!(
            (area / exact - 1.0).abs() < 0.05,
            "disks cover {area} m² of {exact} m²"
        );
        // Finest surfels only near the zone: within its band (2 level-1 cells) of it.
        for (p, &l) in s.positions.iter().zip(&levels) {
            if l == 2 {
                assert!(p.distance(Vec3::new(0.0, -0.1, 0.0)) < 0.03 + 2.0 * 0.01 + 0.02);
            }
        }
    }

    /// The graded phyxels' fitted volumes integrate the sphere's moments up to the
    /// second exactly (relative 1e-5, f32 volumes), each within the fit's factor of its
    /// leaf's cell: mass and inertia are the solid's whatever the grading.
    #[test]
    fn graded_volumes_integrate_the_moments() {
        let (shape, grading) = sphere_grading();
        let (sample, levels) = shape.sample_volume_graded(&grading);
        let exact = shape.moments().unwrap();
        let (mut v, mut second) = (0.0f64, 0.0f64);
        for (i, p) in sample.positions.iter().enumerate() {
            let w = sample.volumes[i] as f64;
            v += w;
            second += w * (p.y as f64).powi(2);
            let cell = (grading.base / (1u32 << levels[i]) as f32).powi(3);
            let ratio = sample.volumes[i] / cell;
            assert!(
                (0.25..=4.0).contains(&ratio),
                "phyxel {i}: {ratio}× its cell"
            );
        }
        assert!(
            (v / exact.volume - 1.0).abs() < 1e-5,
            "{v} against {}",
            exact.volume
        );
        let want = exact.second.y_axis.y;
        assert!(
            (second / want - 1.0).abs() < 1e-4,
            "{second} against {want}"
        );
    }
}
