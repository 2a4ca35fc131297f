//! A triangle mesh that follows an object's phyxels: the mesh a user brought (a `mesh`
//! shape's own triangles), its vertices bound to the phyxels like surfels and moved by
//! the same MLS displacement field ([`SurfelBinding`]) when a mesh frame is written.

use crate::body::advect::SurfelBinding;
use crate::points::phyxels::Phyxels;
use crate::points::surfels::Surfels;
use glam::{Mat3, Vec3};

/// An object's output mesh: vertices (as surfels: rest and current positions), the
/// triangles over them, and the vertices' binding to the phyxels.
#[derive(Clone, Debug)]
pub struct OutputMesh {
    /// The vertices: `rest` where the object was built, `pos` where the last
    /// [`OutputMesh::follow`] moved them.
    pub vertices: Surfels,
    /// Outward-oriented triangles (vertex indices).
    pub triangles: Vec<[u32; 3]>,
    binding: SurfelBinding,
}

impl OutputMesh {
    /// The mesh with `vertices` at rest (world coordinates) and `triangles`, bound to
    /// the rest positions of `phyxels`.
    pub fn new(vertices: &[Vec3], triangles: Vec<[u32; 3]>, phyxels: &Phyxels) -> Self {
        let normals = vertex_normals(vertices, &triangles);
        let radii = vec![0.0; vertices.len()];
        let vertices = Surfels::at_rest(vertices, &normals, &radii);
        let binding = SurfelBinding::build(&vertices, phyxels);
        Self {
            vertices,
            triangles,
            binding,
        }
    }

    /// A point cloud's output: `points` with their `normals` (world coordinates) and no
    /// triangles, bound to the rest positions of `phyxels`; its normals follow the body
    /// as surfel normals do.
    pub fn points(points: &[Vec3], normals: &[Vec3], phyxels: &Phyxels) -> Self {
        let radii = vec![0.0; points.len()];
        let vertices = Surfels::at_rest(points, normals, &radii);
        let binding = SurfelBinding::build(&vertices, phyxels);
        Self {
            vertices,
            triangles: Vec::new(),
            binding,
        }
    }

    /// Unit vertex normals: from the deformed triangles, or a point cloud's own advected
    /// normals.
    pub fn normals(&self) -> Vec<Vec3> {
        if self.triangles.is_empty() {
            return (0..self.vertices.len())
                .map(|i| self.vertices.normal.get(i))
                .collect();
        }
        vertex_normals(&self.positions(), &self.triangles)
    }

    /// Moves the vertices with the phyxels, given the displacement gradient of every
    /// phyxel (the same field as the surfels').
    pub fn follow(&mut self, phyxels: &Phyxels, grad: &[Mat3]) {
        self.binding.advect(&mut self.vertices, phyxels, grad);
    }

    /// The mesh cut along a fracture: vertex v goes to piece `piece[v]`, a triangle to
    /// the piece of its three vertices (a triangle whose vertices went to different
    /// pieces is dropped, so the crack is left open), and each piece's part is bound at
    /// its current shape to that piece's `phyxels` (whose rest is their current
    /// positions). A point cloud's points go by their piece. `None` for a piece that gets
    /// no triangle (no point).
    pub fn split(&self, piece: &[u32], phyxels: &[Phyxels]) -> Vec<Option<OutputMesh>> {
        let pos = self.positions();
        let normals: Vec<Vec3> = (0..self.vertices.len())
            .map(|i| self.vertices.normal.get(i))
            .collect();
        (0..phyxels.len())
            .map(|c| {
                let c = c as u32;
                let mut index = vec![u32::MAX; pos.len()];
                let (mut p, mut n) = (Vec::new(), Vec::new());
                let mut take = |v: u32| {
                    let v = v as usize;
                    if index[v] == u32::MAX {
                        index[v] = p.len() as u32;
                        p.push(pos[v]);
                        n.push(normals[v]);
                    }
                    index[v]
                };
                if self.triangles.is_empty() {
                    for v in (0..pos.len()).filter(|&v| piece[v] == c) {
                        take(v as u32);
                    }
                    return (!p.is_empty())
                        .then(|| OutputMesh::points(&p, &n, &phyxels[c as usize]));
                }
                let triangles: Vec<[u32; 3]> = self
                    .triangles
                    .iter()
                    .filter(|t| t.iter().all(|&v| piece[v as usize] == c))
                    .map(|t| t.map(&mut take))
                    .collect();
                (!triangles.is_empty())
                    .then(|| OutputMesh::new(&p, triangles, &phyxels[c as usize]))
            })
            .collect()
    }

    /// Takes the vertices' current positions as their rest positions and binds them
    /// anew to `phyxels` (whose rest shape was renewed by plastic flow).
    pub fn renew_rest(&mut self, phyxels: &Phyxels) {
        self.vertices.rest = self.vertices.pos.clone();
        self.vertices.rest_normal = self.vertices.normal.clone();
        self.binding = SurfelBinding::build(&self.vertices, phyxels);
    }

    /// The current vertex positions.
    pub fn positions(&self) -> Vec<Vec3> {
        (0..self.vertices.len())
            .map(|i| self.vertices.pos.get(i))
            .collect()
    }
}

/// Unit vertex normals of a triangle mesh: the area-weighted sum of the normals of the
/// triangles around each vertex (+z where a vertex has no triangle of positive area).
pub fn vertex_normals(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; vertices.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        // |(b − a) × (c − a)| is twice the area: the sum weights by area.
        let face = (b - a).cross(c - a);
        for &i in t {
            n[i as usize] += face;
        }
    }
    n.iter()
        .map(|v| v.try_normalize().unwrap_or(Vec3::Z))
        .collect()
}
