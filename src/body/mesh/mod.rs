//! Meshes and point clouds as object shapes (`shape = { type = "mesh", path = ... }`):
//! a [`Surface`] is a closed triangle mesh or an oriented point cloud. Loading
//! (OBJ via `tobj`, ASCII/binary PLY via `ply-rs-bw`), checks (closed, manifold,
//! consistently oriented, finite, non-empty), and sampling: surfels area-weighted over the
//! triangles then thinned Poisson-disk to the target spacing, phyxels on the cubic lattice
//! inside the surface by generalized winding number.

mod cloud;
mod load;
mod trimesh;

pub use cloud::PointCloud;
pub use trimesh::TriMesh;

use load::{Loaded, load_ply};

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

    /// Triangles, or points of a cloud: the terms of one winding number.
    pub fn elements(&self) -> usize {
        match self {
            Surface::Triangles(m) => m.triangles.len(),
            Surface::Points(c) => c.points.len(),
        }
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

/// The lattice points of per-axis coordinates, z slowest (the phyxel order of shapes).
fn lattice_points(xs: &[f32], ys: &[f32], zs: &[f32]) -> Vec<Vec3> {
    zs.iter()
        .flat_map(|&z| {
            ys.iter()
                .flat_map(move |&y| xs.iter().map(move |&x| Vec3::new(x, y, z)))
        })
        .collect()
}
