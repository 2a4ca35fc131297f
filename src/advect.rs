//! Surfel advection: surfels follow the phyxels' MLS displacement field (Müller et al.
//! 2004, §5): `u(s) = Σ w_i (u_i + ∇u_i (s₀ − x₀ᵢ)) / Σ w_i`, normals `n ∝ J⁻ᵀ n₀`
//! with `J = I + Σ w_i ∇u_i / Σ w_i`. Weights use rest positions, so they are fixed
//! and precomputed once.

use crate::grid::Grid;
use crate::kernel::poly6_shape;
use crate::mls::cofactor;
use crate::phyxels::Phyxels;
use crate::surfels::Surfels;
use glam::{Mat3, Vec3};
use rayon::prelude::*;

/// Number of nearest phyxels a surfel binds to when too few lie within its reach.
pub const MIN_BINDING: usize = 4;

/// A surfel binds to the phyxels within `BINDING_FRACTION · h_i` of it at rest.
/// The first-order term `∇u_i (s₀ − x₀ᵢ)` makes the field exact for affine motion with
/// any neighbours, so a reach of about 1.5 phyxel spacings suffices and costs a tenth
/// of the full influence radius (docs/ARCHITECTURE.md).
pub const BINDING_FRACTION: f32 = 0.5;

/// Fixed binding of each surfel to nearby phyxels, with normalised weights.
#[derive(Clone, Debug, Default)]
pub struct SurfelBinding {
    offsets: Vec<u32>,
    phyxel: Vec<u32>,
    weight: Vec<f32>,
    /// Rest offset `s₀ − x₀ᵢ`.
    offset: Vec<Vec3>,
    /// Advected (position, normal, velocity) per surfel, kept between steps so the step
    /// does not allocate.
    scratch: Vec<(Vec3, Vec3, Vec3)>,
}

impl SurfelBinding {
    /// Binds every surfel to the phyxels within [`BINDING_FRACTION`] of their influence
    /// radius at rest, or to its [`MIN_BINDING`] nearest phyxels when fewer lie there.
    pub fn build(surfels: &Surfels, phyxels: &Phyxels) -> Self {
        let mut b = Self {
            offsets: vec![0],
            ..Default::default()
        };
        if phyxels.is_empty() {
            b.offsets.resize(surfels.len() + 1, 0);
            return b;
        }
        let grid: Grid = phyxels.rest_grid();
        let reach = grid.cell() * BINDING_FRACTION;
        let rows: Vec<Vec<(u32, f32, Vec3)>> = (0..surfels.len())
            .into_par_iter()
            .map(|s| {
                let x = surfels.rest.get(s);
                let mut row = Vec::new();
                grid.for_each_within(x, reach, |i, d2| {
                    let w = poly6_shape(d2, phyxels.radius[i] * BINDING_FRACTION);
                    if w > 0.0 {
                        row.push((i as u32, w, x - phyxels.rest.get(i)));
                    }
                });
                if row.len() < MIN_BINDING {
                    row.clear();
                    let mut knn = Vec::new();
                    grid.k_nearest(x, MIN_BINDING, &mut knn);
                    let h = knn.last().map_or(1.0, |e| e.1.sqrt()) * 1.5 + 1e-12;
                    for (i, d2) in knn {
                        row.push((i as u32, poly6_shape(d2, h), x - phyxels.rest.get(i)));
                    }
                }
                row.sort_unstable_by_key(|e| e.0);
                let sum: f32 = row.iter().map(|e| e.1).sum();
                row.iter_mut().for_each(|e| e.1 /= sum);
                row
            })
            .collect();
        for row in rows {
            for (i, w, o) in row {
                b.phyxel.push(i);
                b.weight.push(w);
                b.offset.push(o);
            }
            b.offsets.push(b.phyxel.len() as u32);
        }
        b
    }

    /// Moves surfels, their normals and velocities with the phyxels, given the
    /// displacement gradient of every phyxel.
    pub fn advect(&mut self, surfels: &mut Surfels, phyxels: &Phyxels, grad: &[Mat3]) {
        let mut out = std::mem::take(&mut self.scratch);
        out.resize(surfels.len(), (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO));
        out.par_iter_mut().enumerate().for_each(|(s, out)| {
            *out = {
                let (mut u, mut g, mut v) = (Vec3::ZERO, Mat3::ZERO, Vec3::ZERO);
                for k in self.offsets[s] as usize..self.offsets[s + 1] as usize {
                    let i = self.phyxel[k] as usize;
                    let w = self.weight[k];
                    let ui = phyxels.pos.get(i) - phyxels.rest.get(i);
                    u += w * (ui + grad[i] * self.offset[k]);
                    g += grad[i] * w;
                    v += w * phyxels.vel.get(i);
                }
                let j = Mat3::IDENTITY + g;
                let n0 = surfels.rest_normal.get(s);
                // J⁻ᵀ n₀ ∝ cof(J) n₀ (cofactor avoids dividing by det J; sign kept for det > 0).
                let cof = cofactor(j);
                let n = (cof * n0).try_normalize().unwrap_or(surfels.normal.get(s));
                (surfels.rest.get(s) + u, n, v)
            };
        });
        surfels.pos.par_set_from(&out, |o| o.0);
        surfels.normal.par_set_from(&out, |o| o.1);
        surfels.vel.par_set_from(&out, |o| o.2);
        self.scratch = out;
    }
}
