//! Triangle meshes of the shapes, for mesh frames (`run --mesh`): the primitives'
//! generated surfaces at a given edge length, a `mesh` shape's own triangles; in the
//! shape's local coordinates, outward-oriented, closed except the one-sided `plane`.

use super::Shape;
use crate::body::mesh::Surface;
use glam::Vec3;
use std::collections::HashMap;
use std::f32::consts::{PI, TAU};

/// Vertices and outward triangles.
pub type Triangles = (Vec<Vec3>, Vec<[u32; 3]>);

impl Shape {
    /// The shape's surface as triangles with edges of about `edge` (m): a `mesh`
    /// shape's own triangles (whatever `edge`), `None` for a point cloud.
    pub fn triangulate(&self, edge: f32) -> Option<Triangles> {
        let steps = |length: f32| ((length / edge).ceil() as usize).max(1);
        Some(match *self {
            Shape::Sphere { radius } => capsule(radius, 0.0, steps),
            Shape::Capsule { radius, length } => capsule(radius, length, steps),
            Shape::Box { size } => cuboid(Vec3::from(size), steps),
            Shape::Torus { major, minor } => torus(major, minor, steps),
            Shape::Plane { size } => plane(size, steps),
            Shape::Mesh { ref mesh, .. } => match mesh.as_deref()? {
                Surface::Triangles(m) => (m.vertices.clone(), m.triangles.clone()),
                Surface::Points(_) => return None,
            },
        })
    }
}

/// A capsule along y (a sphere when `length` is 0): rings of latitude from the top pole
/// to the bottom one, the straight part between the hemispheres' equators.
fn capsule(r: f32, length: f32, steps: impl Fn(f32) -> usize) -> Triangles {
    let around = steps(TAU * r).max(8);
    let cap = steps(0.5 * PI * r).max(2);
    let middle = if length > 0.0 { steps(length) } else { 0 };
    // Ring heights and radii, top pole excluded and bottom pole excluded.
    let mut rings: Vec<(f32, f32)> = Vec::new();
    for k in 1..=cap {
        let a = 0.5 * PI * k as f32 / cap as f32;
        rings.push((0.5 * length + r * a.cos(), r * a.sin()));
    }
    for k in 1..=middle {
        rings.push((0.5 * length - length * k as f32 / middle as f32, r));
    }
    for k in 1..cap {
        let a = 0.5 * PI * k as f32 / cap as f32;
        rings.push((-0.5 * length - r * a.sin(), r * a.cos()));
    }
    let mut v = vec![Vec3::new(0.0, 0.5 * length + r, 0.0)];
    for &(y, rho) in &rings {
        for j in 0..around {
            let t = TAU * j as f32 / around as f32;
            v.push(Vec3::new(rho * t.cos(), y, -rho * t.sin()));
        }
    }
    v.push(Vec3::new(0.0, -0.5 * length - r, 0.0));
    let bottom = (v.len() - 1) as u32;
    let at = |ring: usize, j: usize| (1 + ring * around + j % around) as u32;
    let mut t = Vec::new();
    for j in 0..around {
        t.push([0, at(0, j), at(0, j + 1)]);
    }
    for ring in 0..rings.len() - 1 {
        for j in 0..around {
            let (a, b, c, d) = (
                at(ring, j),
                at(ring, j + 1),
                at(ring + 1, j),
                at(ring + 1, j + 1),
            );
            t.push([a, c, d]);
            t.push([a, d, b]);
        }
    }
    let last = rings.len() - 1;
    for j in 0..around {
        t.push([bottom, at(last, j + 1), at(last, j)]);
    }
    (v, t)
}

/// A box of full edge lengths `size`, centred on the origin: each face a grid, the
/// grids' shared edges welded.
fn cuboid(size: Vec3, steps: impl Fn(f32) -> usize) -> Triangles {
    let n = [steps(size.x), steps(size.y), steps(size.z)];
    let mut index: HashMap<[usize; 3], u32> = HashMap::new();
    let mut v = Vec::new();
    let mut vertex = |p: [usize; 3]| {
        *index.entry(p).or_insert_with(|| {
            let c: [f32; 3] = std::array::from_fn(|a| (p[a] as f32 / n[a] as f32 - 0.5) * size[a]);
            v.push(Vec3::from(c));
            (v.len() - 1) as u32
        })
    };
    let mut t = Vec::new();
    // Face normal along axis `a`, at side 0 or n[a]; `u`, `w` the other axes in the
    // order that makes (u × w) point along +a.
    for a in 0..3 {
        let (u, w) = ((a + 1) % 3, (a + 2) % 3);
        for side in [0, n[a]] {
            for i in 0..n[u] {
                for j in 0..n[w] {
                    let p = |di: usize, dj: usize| {
                        let mut q = [0; 3];
                        q[a] = side;
                        q[u] = i + di;
                        q[w] = j + dj;
                        q
                    };
                    let (p00, p10, p01, p11) = (
                        vertex(p(0, 0)),
                        vertex(p(1, 0)),
                        vertex(p(0, 1)),
                        vertex(p(1, 1)),
                    );
                    if side == 0 {
                        t.push([p00, p01, p11]);
                        t.push([p00, p11, p10]);
                    } else {
                        t.push([p00, p10, p11]);
                        t.push([p00, p11, p01]);
                    }
                }
            }
        }
    }
    (v, t)
}

/// A torus in the x-z plane around y: a grid over the centre line and the tube.
fn torus(major: f32, minor: f32, steps: impl Fn(f32) -> usize) -> Triangles {
    let (nu, nv) = (steps(TAU * major).max(8), steps(TAU * minor).max(6));
    let mut v = Vec::with_capacity(nu * nv);
    for i in 0..nu {
        let u = TAU * i as f32 / nu as f32;
        for j in 0..nv {
            let w = TAU * j as f32 / nv as f32;
            let rho = major + minor * w.cos();
            v.push(Vec3::new(rho * u.cos(), minor * w.sin(), rho * u.sin()));
        }
    }
    let at = |i: usize, j: usize| ((i % nu) * nv + j % nv) as u32;
    let mut t = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
            t.push([a, c, d]);
            t.push([a, d, b]);
        }
    }
    (v, t)
}

/// The top face of a `plane` (y = 0, extents `size` along x and z), facing +y: open.
fn plane(size: [f32; 2], steps: impl Fn(f32) -> usize) -> Triangles {
    let (nx, nz) = (steps(size[0]), steps(size[1]));
    let mut v = Vec::new();
    for i in 0..=nx {
        for k in 0..=nz {
            let x = (i as f32 / nx as f32 - 0.5) * size[0];
            let z = (k as f32 / nz as f32 - 0.5) * size[1];
            v.push(Vec3::new(x, 0.0, z));
        }
    }
    let at = |i: usize, k: usize| (i * (nz + 1) + k) as u32;
    let mut t = Vec::new();
    for i in 0..nx {
        for k in 0..nz {
            t.push([at(i, k), at(i, k + 1), at(i + 1, k + 1)]);
            t.push([at(i, k), at(i + 1, k + 1), at(i + 1, k)]);
        }
    }
    (v, t)
}
