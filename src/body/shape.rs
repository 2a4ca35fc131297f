//! Built-in primitive shapes.
//!
//! A shape supplies what the engine needs to turn it into a deformable object: an exact
//! signed distance and normal (for contact queries), analytic volume and area (for mass and
//! surfel sizing), phyxels on a cubic lattice (the simulated volume) and evenly spread
//! surfels (the rendered and collided surface).

use std::f32::consts::{PI, TAU};

use crate::body::mesh::Surface;
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::Arc;

/// A built-in shape in object-local coordinates, centred at the origin.
///
/// Call [`Shape::validate`] first: the other methods assume valid parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Shape {
    Sphere {
        radius: f32,
    },
    /// Full edge lengths along x, y, z.
    Box {
        #[serde(deserialize_with = "crate::scene::exact_array")]
        size: [f32; 3],
    },
    /// Axis along local y; `length` is the distance between the two hemisphere centres (the straight part).
    Capsule {
        radius: f32,
        length: f32,
    },
    /// Lies in the local x-z plane around the y axis; `major` = centre-line radius, `minor` = tube radius.
    Torus {
        major: f32,
        minor: f32,
    },
    /// A one-sided ground patch: the top face is the local plane y = 0 with normal +y,
    /// extents `size = [sx, sz]` along x and z. Its phyxels are one layer just below (y = -spacing/2).
    Plane {
        #[serde(deserialize_with = "crate::scene::exact_array")]
        size: [f32; 2],
    },
    /// A closed triangle mesh from an OBJ or PLY file, `path` relative to the scene file,
    /// scaled by `scale` and centred on its bounding box (see [`crate::body::mesh`]). Loaded by
    /// [`Shape::load_mesh`] (done by `Scene::load` and `ObjectSpec::build`).
    Mesh {
        path: String,
        #[serde(default = "one")]
        scale: f32,
        #[serde(skip)]
        mesh: Option<Arc<Surface>>,
    },
}

fn one() -> f32 {
    1.0
}

/// Surface samples (surfels): oriented disks that together cover the surface.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceSample {
    pub positions: Vec<Vec3>,
    /// Outward unit normals, one per position.
    pub normals: Vec<Vec3>,
    /// Disk radii, one per position; large enough that neighbouring disks overlap.
    pub radii: Vec<f32>,
}

/// Volume samples (phyxels) on a simple cubic lattice.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VolumeSample {
    pub positions: Vec<Vec3>,
    /// Volume each sample stands for (spacing^3 on the lattice).
    pub cell_volume: f32,
}

/// Fraction of a cell by which an extent may exceed a whole number of cells and still be
/// treated as that whole number, so float rounding never adds a layer of points lying on
/// the boundary itself.
const FIT_TOLERANCE: f32 = 1e-3;

impl Shape {
    /// Checks parameters; `Err` names the offending field and its value, because shapes
    /// usually come from hand-written scene files.
    pub fn validate(&self) -> Result<(), String> {
        self.validate_sizes()?;
        // Sizes each in range can still give a volume or area past f32's range (a sphere
        // of radius 1e19 m), which every count and mass derives from.
        let (v, a) = (self.volume(), self.area());
        if v.is_finite() && a.is_finite() {
            Ok(())
        } else {
            Err(format!(
                "the shape's volume ({v:e} m³) or area ({a:e} m²) leaves f32's range: \
                 use smaller sizes (metres)"
            ))
        }
    }

    fn validate_sizes(&self) -> Result<(), String> {
        match *self {
            Shape::Sphere { radius } => positive("radius", radius),
            Shape::Box { size } => size
                .iter()
                .enumerate()
                .try_for_each(|(i, &s)| positive(&format!("size[{i}]"), s)),
            Shape::Capsule { radius, length } => {
                positive("radius", radius)?;
                positive("length", length)
            }
            Shape::Mesh {
                ref path, scale, ..
            } => {
                if path.is_empty() {
                    return Err("path = \"\": must name an .obj or .ply file".into());
                }
                positive("scale", scale)
            }
            Shape::Torus { major, minor } => {
                positive("major", major)?;
                positive("minor", minor)?;
                if minor < major {
                    Ok(())
                } else {
                    Err(format!(
                        "minor = {minor}: must be less than major = {major} (the tube would self-intersect)"
                    ))
                }
            }
            Shape::Plane { size } => size
                .iter()
                .enumerate()
                .try_for_each(|(i, &s)| positive(&format!("size[{i}]"), s)),
        }
    }

    /// Exact signed distance, negative inside.
    ///
    /// The plane returns the height `p.y` above the infinite plane y = 0, ignoring its
    /// x-z bounds; as a collider it acts only over its patch, where its surfels are (a
    /// body beside the patch falls past it), so a caller asking whether a point is under
    /// the patch bounds `p.x` and `p.z` by `size` too (as the scene's start-overlap check
    /// does).
    pub fn sdf(&self, p: Vec3) -> f32 {
        match *self {
            Shape::Sphere { radius } => p.length() - radius,
            Shape::Box { size } => {
                let q = p.abs() - Vec3::from_array(size) * 0.5;
                q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
            }
            Shape::Capsule { radius, length } => {
                (p - capsule_spine_point(p, length)).length() - radius
            }
            Shape::Torus { major, minor } => {
                Vec2::new(Vec2::new(p.x, p.z).length() - major, p.y).length() - minor
            }
            Shape::Plane { .. } => p.y,
            Shape::Mesh { ref mesh, .. } => mesh.as_ref().map_or(f32::INFINITY, |m| m.sdf(p)),
        }
    }

    /// Outward unit normal of the closest surface point: the analytic gradient of
    /// [`Shape::sdf`]. Where the gradient is undefined (the centre, a spine, a box's medial
    /// planes) one of the equally close directions is returned, never NaN.
    pub fn normal(&self, p: Vec3) -> Vec3 {
        match *self {
            Shape::Sphere { .. } => p.normalize_or(Vec3::Y),
            Shape::Box { size } => {
                let q = p.abs() - Vec3::from_array(size) * 0.5;
                if q.max_element() > 0.0 {
                    (q.max(Vec3::ZERO) * p.signum()).normalize_or(Vec3::Y)
                } else {
                    // Inside: the nearest face is the one with the largest (least negative) q.
                    let axis = if q.x >= q.y && q.x >= q.z {
                        0
                    } else if q.y >= q.z {
                        1
                    } else {
                        2
                    };
                    let mut n = Vec3::ZERO;
                    n[axis] = if p[axis] < 0.0 { -1.0 } else { 1.0 };
                    n
                }
            }
            Shape::Capsule { length, .. } => {
                (p - capsule_spine_point(p, length)).normalize_or(Vec3::X)
            }
            Shape::Torus { major, .. } => {
                let radial = Vec3::new(p.x, 0.0, p.z).normalize_or(Vec3::X);
                (p - radial * major).normalize_or(radial)
            }
            Shape::Plane { .. } => Vec3::Y,
            Shape::Mesh { .. } => {
                let h = 1e-4 * self.half_extents().max_element().max(1e-6);
                Vec3::new(
                    self.sdf(p + h * Vec3::X) - self.sdf(p - h * Vec3::X),
                    self.sdf(p + h * Vec3::Y) - self.sdf(p - h * Vec3::Y),
                    self.sdf(p + h * Vec3::Z) - self.sdf(p - h * Vec3::Z),
                )
                .normalize_or(Vec3::Y)
            }
        }
    }

    /// Lattice points the volume sampler tests at `spacing`: those of the shape's
    /// bounding box (one layer for a plane), as `f64` so that no count overflows. Sampling
    /// costs this many sdf evaluations, however few points it keeps (a thin torus keeps
    /// few of a large box).
    pub fn lattice_points(&self, spacing: f32) -> f64 {
        let axis = |half: f32| {
            (2.0 * half as f64 / spacing as f64 - FIT_TOLERANCE as f64)
                .ceil()
                .max(1.0)
        };
        let h = self.half_extents();
        axis(h.x) * axis(h.y) * axis(h.z)
    }

    /// Analytic volume; a plane is a surface, so 0.
    pub fn volume(&self) -> f32 {
        match *self {
            Shape::Sphere { radius } => 4.0 / 3.0 * PI * radius.powi(3),
            Shape::Box { size } => size.iter().product(),
            Shape::Capsule { radius, length } => {
                PI * radius * radius * (length + 4.0 / 3.0 * radius)
            }
            Shape::Torus { major, minor } => 2.0 * PI * PI * major * minor * minor,
            Shape::Plane { .. } => 0.0,
            Shape::Mesh { ref mesh, .. } => mesh.as_ref().map_or(0.0, |m| m.signed_volume()),
        }
    }

    /// Analytic surface area; for a plane only the top face, the only side that collides.
    pub fn area(&self) -> f32 {
        match *self {
            Shape::Sphere { radius } => 4.0 * PI * radius * radius,
            Shape::Box { size: [x, y, z] } => 2.0 * (x * y + y * z + z * x),
            Shape::Capsule { radius, length } => TAU * radius * (length + 2.0 * radius),
            Shape::Torus { major, minor } => 4.0 * PI * PI * major * minor,
            Shape::Plane { size: [x, z] } => x * z,
            Shape::Mesh { ref mesh, .. } => mesh.as_ref().map_or(0.0, |m| m.area()),
        }
    }

    /// Axis-aligned half extents of the shape's bounding box (a plane is flat: y extent 0).
    pub fn half_extents(&self) -> Vec3 {
        match *self {
            Shape::Sphere { radius } => Vec3::splat(radius),
            Shape::Box { size } => Vec3::from_array(size) * 0.5,
            Shape::Capsule { radius, length } => Vec3::new(radius, 0.5 * length + radius, radius),
            Shape::Torus { major, minor } => Vec3::new(major + minor, minor, major + minor),
            Shape::Plane { size: [x, z] } => Vec3::new(0.5 * x, 0.0, 0.5 * z),
            // Unknown until loaded: no size check can fail on it.
            Shape::Mesh { ref mesh, .. } => {
                mesh.as_ref().map_or(Vec3::INFINITY, |m| m.half_extents())
            }
        }
    }

    /// Phyxels: the cell centres of a simple cubic lattice at `spacing` that lie inside
    /// (sdf < 0), in z, then y, then x order.
    ///
    /// The lattice is symmetric about the origin and, per axis, has as many points as fit
    /// strictly inside the bounding box, so a box whose size is a multiple of `spacing` is
    /// tiled exactly and a plate thinner than one cell keeps its mid-plane layer.
    /// Every shape gets at least one phyxel: if none of those centres is inside, the
    /// lattice through the origin is tried (a thin rod keeps its spine, a tiny sphere its
    /// centre), and failing that (only a torus thinner than the spacing can get there) a
    /// single phyxel on the tube's centre-line.
    /// Plane: one layer at y = -spacing/2 over the patch.
    ///
    /// # Panics
    /// If `spacing` is not a finite number > 0, or for a mesh not loaded yet
    /// ([`Shape::load_mesh`]).
    pub fn sample_volume(&self, spacing: f32) -> VolumeSample {
        check_spacing(spacing);
        self.check_loaded("sample_volume");
        let cell_volume = spacing.powi(3);
        if let Shape::Plane { size: [x, z] } = *self {
            let y = -0.5 * spacing;
            let xs = lattice_axis(fitted_count(0.5 * x, spacing), spacing);
            let zs = lattice_axis(fitted_count(0.5 * z, spacing), spacing);
            let positions = zs
                .flat_map(|z| xs.clone().map(move |x| Vec3::new(x, y, z)))
                .collect();
            return VolumeSample {
                positions,
                cell_volume,
            };
        }

        if let Shape::Mesh {
            mesh: Some(ref m), ..
        } = *self
        {
            let half = m.half_extents().to_array();
            let axes =
                |counts: [usize; 3]| counts.map(|n| lattice_axis(n, spacing).collect::<Vec<_>>());
            let [xs, ys, zs] = axes(half.map(|h| fitted_count(h, spacing)));
            let mut positions = m.lattice_inside(&xs, &ys, &zs);
            if positions.is_empty() {
                let [xs, ys, zs] = axes(half.map(|h| 2 * (h / spacing).floor() as usize + 1));
                positions = m.lattice_inside(&xs, &ys, &zs);
            }
            if positions.is_empty() {
                positions.push(Vec3::ZERO);
            }
            return VolumeSample {
                positions,
                cell_volume,
            };
        }
        let half = self.half_extents().to_array();
        let fitted = self.lattice_inside(half.map(|h| fitted_count(h, spacing)), spacing);
        let positions = if fitted.is_empty() {
            let through_origin = half.map(|h| 2 * (h / spacing).floor() as usize + 1);
            let kept = self.lattice_inside(through_origin, spacing);
            if kept.is_empty() {
                vec![self.core_point()]
            } else {
                kept
            }
        } else {
            fitted
        };
        VolumeSample {
            positions,
            cell_volume,
        }
    }

    /// Surfels spread evenly over the surface roughly `spacing` apart, with outward unit
    /// normals and disk radius r = sqrt(2 * A_per_surfel / pi) (A_per_surfel = area / count),
    /// i.e. twice the per-surfel area, so neighbouring disks overlap and leave no holes.
    ///
    /// Sphere: a golden-angle (Fibonacci) spiral of round(area / spacing^2) points.
    /// Box: a cell-centred grid per face, so no point is duplicated on an edge.
    /// Capsule: staggered rings on the cylinder, half Fibonacci spirals on the caps.
    /// Torus: staggered rings around the y axis at even steps of the tube angle, each with a
    /// point count proportional to its circumference, so the density is even.
    /// Plane: a cell-centred grid on the top face, normals +y.
    /// The order is deterministic.
    ///
    /// # Panics
    /// If `spacing` is not a finite number > 0, or for a mesh not loaded yet
    /// ([`Shape::load_mesh`]).
    pub fn sample_surface(&self, spacing: f32) -> SurfaceSample {
        check_spacing(spacing);
        self.check_loaded("sample_surface");
        if let Shape::Mesh {
            mesh: Some(ref m), ..
        } = *self
        {
            let (positions, normals, r) = m.sample_surface(spacing);
            let radii = vec![r; positions.len()];
            return SurfaceSample {
                positions,
                normals,
                radii,
            };
        }
        let mut out = SurfaceSample::default();
        let mut push = |p: Vec3, n: Vec3| {
            out.positions.push(p);
            out.normals.push(n);
        };
        match *self {
            Shape::Sphere { radius } => {
                for d in spiral(count_for(self.area() / (spacing * spacing)), 1.0, -1.0) {
                    push(d * radius, d);
                }
            }
            Shape::Box { size } => {
                let half = Vec3::from_array(size) * 0.5;
                for axis in 0..3 {
                    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                    let (nu, nv) = (count_for(size[u] / spacing), count_for(size[v] / spacing));
                    for sign in [1.0, -1.0] {
                        let mut normal = Vec3::ZERO;
                        normal[axis] = sign;
                        for j in 0..nv {
                            for i in 0..nu {
                                let mut p = normal * half[axis];
                                p[u] = (cell_centre(i, nu) - 0.5) * size[u];
                                p[v] = (cell_centre(j, nv) - 0.5) * size[v];
                                push(p, normal);
                            }
                        }
                    }
                }
            }
            Shape::Capsule { radius, length } => {
                let half = 0.5 * length;
                let cap_count = count_for(TAU * radius * radius / (spacing * spacing));
                for d in spiral(cap_count, 1.0, 0.0) {
                    push(Vec3::Y * half + d * radius, d);
                }
                // Rings from top to bottom, each half a step turned from the last.
                let rings = if length > 0.0 {
                    count_for(length / spacing)
                } else {
                    0
                };
                let per_ring = count_for(TAU * radius / spacing).max(3);
                for j in 0..rings {
                    let y = half - cell_centre(j, rings) * length;
                    for i in 0..per_ring {
                        let (s, c) = (staggered(i, j) * TAU / per_ring as f32).sin_cos();
                        let d = Vec3::new(c, 0.0, s);
                        push(Vec3::new(0.0, y, 0.0) + d * radius, d);
                    }
                }
                for d in spiral(cap_count, 1.0, 0.0) {
                    let d = d * Vec3::new(1.0, -1.0, 1.0);
                    push(Vec3::NEG_Y * half + d * radius, d);
                }
            }
            Shape::Torus { major, minor } => {
                let rings = count_for(TAU * minor / spacing).max(3);
                for j in 0..rings {
                    let (sv, cv) = (cell_centre(j, rings) * TAU).sin_cos();
                    let ring_radius = major + minor * cv;
                    let per_ring = count_for(TAU * ring_radius / spacing).max(3);
                    for i in 0..per_ring {
                        let (su, cu) = (staggered(i, j) * TAU / per_ring as f32).sin_cos();
                        let n = Vec3::new(cv * cu, sv, cv * su);
                        push(Vec3::new(ring_radius * cu, minor * sv, ring_radius * su), n);
                    }
                }
            }
            Shape::Plane { size: [x, z] } => {
                let (nx, nz) = (count_for(x / spacing), count_for(z / spacing));
                for j in 0..nz {
                    for i in 0..nx {
                        let p = Vec3::new(
                            (cell_centre(i, nx) - 0.5) * x,
                            0.0,
                            (cell_centre(j, nz) - 0.5) * z,
                        );
                        push(p, Vec3::Y);
                    }
                }
            }
            Shape::Mesh { .. } => unreachable!("handled above"),
        }
        let per_surfel = self.area() / out.positions.len() as f32;
        out.radii = vec![(2.0 * per_surfel / PI).sqrt(); out.positions.len()];
        out
    }

    /// Loads a `mesh` shape's file (`path` relative to `base`) once; other shapes: no-op.
    /// Errors name the file and what is wrong with it.
    pub fn load_mesh(&mut self, base: &Path) -> Result<(), String> {
        if let Shape::Mesh {
            path, scale, mesh, ..
        } = self
            && mesh.is_none()
        {
            let m = Surface::load(&base.join(&*path), *scale)?;
            // Finite vertices times a finite scale can still overflow f32.
            let h = m.half_extents();
            if !h.is_finite() || !m.signed_volume().is_finite() {
                return Err(format!(
                    "scale = {scale:e}: the scaled mesh's half extents {h} or its volume leave \
                     f32's range: scale it down"
                ));
            }
            *mesh = Some(Arc::new(m));
        }
        Ok(())
    }

    /// Lattice points (`counts` per axis, symmetric about the origin) with sdf < 0.
    fn lattice_inside(&self, counts: [usize; 3], spacing: f32) -> Vec<Vec3> {
        let mut inside = Vec::new();
        for z in lattice_axis(counts[2], spacing) {
            for y in lattice_axis(counts[1], spacing) {
                for x in lattice_axis(counts[0], spacing) {
                    let p = Vec3::new(x, y, z);
                    if self.sdf(p) < 0.0 {
                        inside.push(p);
                    }
                }
            }
        }
        inside
    }

    /// A point as deep inside as the shape allows: the phyxel of last resort.
    fn core_point(&self) -> Vec3 {
        match *self {
            Shape::Torus { major, .. } => Vec3::new(major, 0.0, 0.0),
            _ => Vec3::ZERO,
        }
    }
}

/// `Ok` if `value` is a finite number > 0, else an error naming `field`.
fn positive(field: &str, value: f32) -> Result<(), String> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(format!("{field} = {value}: must be a finite number > 0"))
    }
}

impl Shape {
    /// Panics, naming the file, for a mesh whose file is not loaded: sampling one gave
    /// no points at all, and `Object::new` then blamed "no phyxels".
    fn check_loaded(&self, what: &str) {
        if let Shape::Mesh {
            path, mesh: None, ..
        } = self
        {
            panic!(
                "Shape::{what}: mesh \"{path}\" is not loaded: call Shape::load_mesh first \
                 (Scene::load and ObjectSpec::build do)"
            );
        }
    }
}

fn check_spacing(spacing: f32) {
    assert!(
        spacing.is_finite() && spacing > 0.0,
        "spacing = {spacing}: must be a finite number > 0"
    );
}

/// Closest point to `p` on a capsule's spine, the segment of `length` along y.
fn capsule_spine_point(p: Vec3, length: f32) -> Vec3 {
    let half = 0.5 * length;
    Vec3::new(0.0, p.y.clamp(-half, half), 0.0)
}

/// Number of symmetric lattice points `spacing` apart that fit strictly inside [-half, half]
/// (at least one, the centre).
fn fitted_count(half: f32, spacing: f32) -> usize {
    (2.0 * half / spacing - FIT_TOLERANCE).ceil().max(1.0) as usize
}

/// `n` coordinates `spacing` apart, centred on 0: they include 0 when `n` is odd and
/// straddle it when `n` is even.
fn lattice_axis(n: usize, spacing: f32) -> impl Iterator<Item = f32> + Clone {
    let mid = 0.5 * (n as f32 - 1.0);
    (0..n).map(move |i| (i as f32 - mid) * spacing)
}

/// A sample count from a real-valued target, at least one.
fn count_for(target: f32) -> usize {
    target.round().max(1.0) as usize
}

/// Centre of cell `i` of `n` equal cells over [0, 1].
fn cell_centre(i: usize, n: usize) -> f32 {
    (i as f32 + 0.5) / n as f32
}

/// Index `i` on ring `j`, shifted half a step on odd rings so neighbouring rings interleave.
fn staggered(i: usize, j: usize) -> f32 {
    i as f32 + 0.5 * (j % 2) as f32
}

/// `n` unit directions on a golden-angle spiral with y running from `y_top` down to
/// `y_bottom` in equal steps; equal steps in y are equal areas on a sphere (Archimedes),
/// so the points are evenly spread over that zone.
fn spiral(n: usize, y_top: f32, y_bottom: f32) -> impl Iterator<Item = Vec3> {
    let golden_angle = PI * (3.0 - 5.0_f32.sqrt());
    (0..n).map(move |i| {
        let y = y_top + (y_bottom - y_top) * cell_centre(i, n);
        let rho = (1.0 - y * y).max(0.0).sqrt();
        let (s, c) = (i as f32 * golden_angle).sin_cos();
        Vec3::new(rho * c, y, rho * s)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One valid instance of every shape, with non-trivial proportions.
    fn shapes() -> Vec<Shape> {
        vec![
            Shape::Sphere { radius: 0.5 },
            Shape::Box {
                size: [0.4, 0.25, 0.1],
            },
            Shape::Capsule {
                radius: 0.2,
                length: 0.5,
            },
            Shape::Torus {
                major: 0.5,
                minor: 0.15,
            },
            Shape::Plane { size: [2.0, 1.0] },
        ]
    }

    /// Largest half extent: the length scale that tolerances are relative to.
    fn scale(shape: &Shape) -> f32 {
        shape.half_extents().max_element()
    }

    /// Deterministic pseudo-random numbers in [0, 1) (a 64-bit LCG), so tests are reproducible.
    struct Lcg(u64);

    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }

        fn in_box(&mut self, half: Vec3) -> Vec3 {
            Vec3::new(self.next(), self.next(), self.next()) * 2.0 * half - half
        }
    }

    /// Reference: surfels lie on the surface, |sdf| < 1e-4 * scale; their normals are unit
    /// (within 1e-4), agree with `normal(p)` within 1e-3 and point outward
    /// (sdf(p + 1e-3 * scale * n) > 0); no value is NaN and every radius is > 0.
    #[test]
    fn surfels_lie_on_surface_with_outward_normals() {
        for shape in shapes() {
            let s = shape.sample_surface(0.02);
            let l = scale(&shape);
            assert!(!s.positions.is_empty(), "{shape:?}");
            assert_eq!(s.positions.len(), s.normals.len());
            assert_eq!(s.positions.len(), s.radii.len());
            for ((&p, &n), &r) in s.positions.iter().zip(&s.normals).zip(&s.radii) {
                assert!(
                    p.is_finite() && n.is_finite() && r.is_finite() && r > 0.0,
                    "{shape:?} {p} {n} {r}"
                );
                assert!(
                    shape.sdf(p).abs() < 1e-4 * l,
                    "{shape:?}: sdf({p}) = {}",
                    shape.sdf(p)
                );
                assert!((n.length() - 1.0).abs() < 1e-4, "{shape:?}: |{n}| != 1");
                assert!(
                    n.distance(shape.normal(p)) < 1e-3,
                    "{shape:?} at {p}: {n} vs {}",
                    shape.normal(p)
                );
                assert!(
                    shape.sdf(p + 1e-3 * l * n) > 0.0,
                    "{shape:?}: {n} points inward at {p}"
                );
            }
        }
    }

    /// Reference: the analytic area / spacing^2; counts agree within 10%.
    #[test]
    fn surfel_counts_match_area() {
        let spacing = 0.02;
        for shape in shapes()
            .into_iter()
            .filter(|s| !matches!(s, Shape::Plane { .. }))
        {
            let expected = shape.area() / (spacing * spacing);
            let got = shape.sample_surface(spacing).positions.len() as f32;
            assert!(
                (got / expected - 1.0).abs() < 0.1,
                "{shape:?}: {got} surfels, expected {expected}"
            );
        }
        let plane = Shape::Plane { size: [2.0, 1.0] };
        assert_eq!(plane.sample_surface(spacing).positions.len(), 100 * 50);
    }

    /// Reference: a perfectly even sampling has one nearest-neighbour distance; for the sphere
    /// and torus the coefficient of variation (std / mean) of that distance is below 0.25.
    #[test]
    fn surfels_are_evenly_spread() {
        for (shape, spacing) in [
            (Shape::Sphere { radius: 0.5 }, 0.05),
            (
                Shape::Torus {
                    major: 0.5,
                    minor: 0.15,
                },
                0.03,
            ),
        ] {
            let p = shape.sample_surface(spacing).positions;
            let nearest: Vec<f32> = p
                .iter()
                .enumerate()
                .map(|(i, a)| {
                    p.iter()
                        .enumerate()
                        .filter(|&(j, _)| j != i)
                        .map(|(_, b)| a.distance(*b))
                        .fold(f32::INFINITY, f32::min)
                })
                .collect();
            let n = nearest.len() as f32;
            let mean = nearest.iter().sum::<f32>() / n;
            let var = nearest.iter().map(|d| (d - mean).powi(2)).sum::<f32>() / n;
            let cv = var.sqrt() / mean;
            assert!(cv < 0.25, "{shape:?}: nearest-neighbour CV = {cv}");
        }
    }

    /// Reference: the analytic volume; phyxel count * cell volume agrees within 10% at
    /// spacing = radius / 8 (tube radius for the torus).
    #[test]
    fn phyxel_volume_matches_analytic() {
        for (shape, radius) in [
            (Shape::Sphere { radius: 0.5 }, 0.5),
            (
                Shape::Capsule {
                    radius: 0.2,
                    length: 0.5,
                },
                0.2,
            ),
            (
                Shape::Torus {
                    major: 0.5,
                    minor: 0.15,
                },
                0.15,
            ),
        ] {
            let v = shape.sample_volume(radius / 8.0);
            let got = v.positions.len() as f32 * v.cell_volume;
            let expected = shape.volume();
            assert!(
                (got / expected - 1.0).abs() < 0.1,
                "{shape:?}: {got} vs {expected}"
            );
        }
    }

    /// Reference: a box whose edges are multiples of the spacing is tiled exactly:
    /// 0.4 x 0.1 x 0.1 at 0.025 gives 16 * 4 * 4 phyxels, whose volume is the box's (1e-5 relative).
    #[test]
    fn box_multiple_of_spacing_is_tiled_exactly() {
        let shape = Shape::Box {
            size: [0.4, 0.1, 0.1],
        };
        let v = shape.sample_volume(0.025);
        assert_eq!(v.positions.len(), 16 * 4 * 4);
        let total = v.positions.len() as f32 * v.cell_volume;
        assert!((total / shape.volume() - 1.0).abs() < 1e-5);
        // Symmetric about the origin: the centroid is 0 (to rounding).
        let centroid = v.positions.iter().sum::<Vec3>() / v.positions.len() as f32;
        assert!(centroid.length() < 1e-6, "{centroid}");
    }

    /// Reference: phyxels are cell centres inside the shape (sdf < 0, exact); the plane's
    /// are one layer at y = -spacing/2 (1e-7) covering the patch (40 x 20 at 0.05 on 2 x 1).
    #[test]
    fn phyxels_are_inside() {
        for shape in shapes() {
            let spacing = 0.05;
            let v = shape.sample_volume(spacing);
            assert!(!v.positions.is_empty(), "{shape:?}");
            assert_eq!(v.cell_volume, spacing.powi(3));
            for &p in &v.positions {
                if let Shape::Plane { size: [x, z] } = shape {
                    assert!((p.y + 0.5 * spacing).abs() < 1e-7, "{p}");
                    assert!(p.x.abs() < 0.5 * x && p.z.abs() < 0.5 * z, "{p}");
                } else {
                    assert!(shape.sdf(p) < 0.0, "{shape:?}: phyxel {p} outside");
                }
            }
        }
        assert_eq!(
            Shape::Plane { size: [2.0, 1.0] }
                .sample_volume(0.05)
                .positions
                .len(),
            40 * 20
        );
    }

    /// Reference: every shape gets phyxels when thinner than the spacing: a plate keeps its
    /// mid-plane layer (40 x 1 x 40 at y = 0), a thin capsule its spine (11 points on the
    /// y axis), a tiny sphere its centre, and a thin or coarsely sampled torus at least one
    /// point; all of them inside (sdf < 0).
    #[test]
    fn thin_shapes_still_get_phyxels() {
        let s = 0.025;
        let plate = Shape::Box {
            size: [1.0, 0.01, 1.0],
        }
        .sample_volume(s)
        .positions;
        assert_eq!(plate.len(), 40 * 40);
        assert!(plate.iter().all(|p| p.y == 0.0));

        let rod = Shape::Capsule {
            radius: 0.6 * s,
            length: 10.0 * s,
        }
        .sample_volume(s)
        .positions;
        assert_eq!(rod.len(), 11);
        assert!(rod.iter().all(|p| p.x == 0.0 && p.z == 0.0));

        for radius in [0.3 * s, 0.6 * s] {
            let dot = Shape::Sphere { radius }.sample_volume(s).positions;
            assert_eq!(dot, vec![Vec3::ZERO], "radius {radius}");
        }

        let ring = Shape::Torus {
            major: 0.51,
            minor: 0.001,
        };
        let v = ring.sample_volume(s).positions;
        assert!(!v.is_empty());
        assert!(v.iter().all(|p| ring.sdf(*p) < s), "{v:?}");
    }

    /// Reference: the sdf at points with hand-computed distances (1e-6 absolute).
    #[test]
    fn sdf_known_values() {
        let cases = [
            (Shape::Sphere { radius: 1.0 }, Vec3::new(0.0, 2.0, 0.0), 1.0),
            (Shape::Sphere { radius: 1.0 }, Vec3::ZERO, -1.0),
            (
                Shape::Box {
                    size: [2.0, 2.0, 2.0],
                },
                Vec3::new(2.0, 2.0, 1.0),
                2.0_f32.sqrt(),
            ),
            (
                Shape::Box {
                    size: [2.0, 4.0, 6.0],
                },
                Vec3::ZERO,
                -1.0,
            ),
            (
                Shape::Capsule {
                    radius: 0.5,
                    length: 2.0,
                },
                Vec3::new(0.0, 3.0, 0.0),
                1.5,
            ),
            (
                Shape::Capsule {
                    radius: 0.5,
                    length: 2.0,
                },
                Vec3::new(1.0, 0.7, 0.0),
                0.5,
            ),
            (
                Shape::Torus {
                    major: 1.0,
                    minor: 0.25,
                },
                Vec3::ZERO,
                0.75,
            ),
            (
                Shape::Torus {
                    major: 1.0,
                    minor: 0.25,
                },
                Vec3::new(0.0, 0.0, -1.0),
                -0.25,
            ),
            (
                Shape::Plane { size: [1.0, 1.0] },
                Vec3::new(5.0, -0.3, 0.0),
                -0.3,
            ),
        ];
        for (shape, p, d) in cases {
            assert!(
                (shape.sdf(p) - d).abs() < 1e-6,
                "{shape:?} at {p}: {} vs {d}",
                shape.sdf(p)
            );
        }
    }

    /// Reference: a central finite difference of the sdf (step 1e-3 * scale) at 2000 random
    /// points per shape; where that gradient has unit length (away from kinks and medial
    /// surfaces, where an sdf's gradient is undefined) `normal` matches it within 1e-2.
    /// Also `normal` is unit length (1e-5) and finite everywhere, including the origin.
    #[test]
    fn normal_is_sdf_gradient() {
        let mut rng = Lcg(7);
        for shape in shapes() {
            let h = 1e-3 * scale(&shape);
            let half = shape.half_extents().max(Vec3::splat(0.1)) * 1.5;
            let mut compared = 0;
            for p in (0..2000).map(|_| rng.in_box(half)).chain([Vec3::ZERO]) {
                let n = shape.normal(p);
                assert!(
                    n.is_finite() && (n.length() - 1.0).abs() < 1e-5,
                    "{shape:?} at {p}: {n}"
                );
                let fd = Vec3::new(
                    shape.sdf(p + Vec3::X * h) - shape.sdf(p - Vec3::X * h),
                    shape.sdf(p + Vec3::Y * h) - shape.sdf(p - Vec3::Y * h),
                    shape.sdf(p + Vec3::Z * h) - shape.sdf(p - Vec3::Z * h),
                ) / (2.0 * h);
                if (fd.length() - 1.0).abs() < 1e-3 {
                    compared += 1;
                    assert!(n.distance(fd) < 1e-2, "{shape:?} at {p}: {n} vs {fd}");
                }
            }
            assert!(
                compared > 1000,
                "{shape:?}: only {compared} points compared"
            );
        }
    }

    /// Reference: the shapes' parameters; every invalid one is rejected with a message that
    /// names the field and its value, and the valid test shapes pass.
    #[test]
    fn validate_names_the_bad_field() {
        for shape in shapes() {
            assert_eq!(shape.validate(), Ok(()), "{shape:?}");
        }
        let cases = [
            (Shape::Sphere { radius: -1.0 }, "radius = -1"),
            (Shape::Sphere { radius: 0.0 }, "radius = 0"),
            (Shape::Sphere { radius: f32::NAN }, "radius = NaN"),
            (
                Shape::Box {
                    size: [1.0, 0.0, 1.0],
                },
                "size[1] = 0",
            ),
            (
                Shape::Box {
                    size: [1.0, 1.0, f32::INFINITY],
                },
                "size[2] = inf",
            ),
            (
                Shape::Box {
                    size: [-2.0, 1.0, 1.0],
                },
                "size[0] = -2",
            ),
            (
                Shape::Capsule {
                    radius: 0.0,
                    length: 1.0,
                },
                "radius = 0",
            ),
            (
                Shape::Capsule {
                    radius: 1.0,
                    length: -1.0,
                },
                "length = -1",
            ),
            (
                Shape::Capsule {
                    radius: 1.0,
                    length: f32::NAN,
                },
                "length = NaN",
            ),
            (
                Shape::Torus {
                    major: -1.0,
                    minor: 0.5,
                },
                "major = -1",
            ),
            (
                Shape::Torus {
                    major: 1.0,
                    minor: f32::NAN,
                },
                "minor = NaN",
            ),
            (
                Shape::Torus {
                    major: 1.0,
                    minor: 1.0,
                },
                "minor = 1",
            ),
            (
                Shape::Torus {
                    major: 1.0,
                    minor: 2.0,
                },
                "major = 1",
            ),
            (Shape::Plane { size: [0.0, 1.0] }, "size[0] = 0"),
            (Shape::Plane { size: [1.0, -0.5] }, "size[1] = -0.5"),
        ];
        for (shape, needle) in cases {
            let err = shape.validate().expect_err(&format!("{shape:?} accepted"));
            assert!(err.contains(needle), "{shape:?}: {err:?} lacks {needle:?}");
            assert!(err.contains("must"), "{err}");
        }
    }

    /// Reference: the scene-file form `{"type": "<kebab-case>", ...fields}`; shapes round-trip
    /// exactly and unknown fields are rejected.
    #[test]
    fn serde_form() {
        for shape in shapes() {
            let json = serde_json::to_string(&shape).unwrap();
            assert_eq!(
                serde_json::from_str::<Shape>(&json).unwrap(),
                shape,
                "{json}"
            );
        }
        let torus: Shape =
            serde_json::from_str(r#"{"type": "torus", "major": 1, "minor": 0.25}"#).unwrap();
        assert_eq!(
            torus,
            Shape::Torus {
                major: 1.0,
                minor: 0.25
            }
        );
        let bad = serde_json::from_str::<Shape>(r#"{"type": "sphere", "radius": 1, "color": 3}"#);
        assert!(bad.is_err());
    }

    /// Reference: sampling is a pure function of (shape, spacing): two calls agree exactly.
    #[test]
    fn sampling_is_deterministic() {
        for shape in shapes() {
            assert_eq!(shape.sample_surface(0.03), shape.sample_surface(0.03));
            assert_eq!(shape.sample_volume(0.03), shape.sample_volume(0.03));
        }
    }
}
