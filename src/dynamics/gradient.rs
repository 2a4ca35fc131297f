//! Moving-least-squares estimate of the displacement gradient (Müller et al. 2004, §4.2).
//!
//! For phyxel i with rest neighbours j within its influence radius `h_i`:
//! moment matrix `A_i = Σ_j x_ij x_ijᵀ w_ij`, weights `d_j = A_i⁻¹ x_ij w_ij`,
//! `d_i = −Σ_j d_j`, and the gradient `∇u_i = Σ_j (u_j − u_i) d_jᵀ` — exact for affine
//! displacement fields wherever `A_i` has full rank. The stencil is built once at rest.

use crate::columns::Vec3s;
use crate::math::kernel::poly6_shape;
use crate::math::linalg;
use crate::par;
use crate::points::phyxels::Phyxels;
use glam::{DMat3, DVec3, Mat3, Vec3};
use rayon::prelude::*;

pub use crate::material::GradientBasis;
pub use crate::math::linalg::MAX_CONDITION;

/// Precomputed MLS stencil of a phyxel set (compressed rows, one per phyxel).
#[derive(Clone, Debug, Default)]
pub struct MlsStencil {
    /// `offsets[i]..offsets[i + 1]` are phyxel i's neighbours.
    pub offsets: Vec<u32>,
    pub neighbours: Vec<u32>,
    /// `d_j` for each (i, j) entry.
    pub d: Vec<Vec3>,
    /// `d_i = −Σ_j d_j`.
    pub d_self: Vec<Vec3>,
    /// Phyxels whose moment matrix was rank-deficient or ill-conditioned.
    pub ill_conditioned: Vec<bool>,
}

impl MlsStencil {
    /// Builds the stencil from the rest positions and influence radii of `phyxels`.
    pub fn build(phyxels: &Phyxels) -> Self {
        Self::build_with(phyxels, GradientBasis::Linear)
    }

    /// Builds the stencil with the given fit basis.
    pub fn build_with(phyxels: &Phyxels, basis: GradientBasis) -> Self {
        let n = phyxels.len();
        let grid = phyxels.rest_grid();
        let rows: Vec<(Vec<u32>, Vec<Vec3>, Vec3, bool)> = (0..n)
            .into_par_iter()
            .with_min_len(par::point_task())
            .map(|i| {
                let xi = phyxels.rest.get(i);
                let h = phyxels.radius[i];
                let mut nb: Vec<(u32, f32)> = Vec::new();
                grid.for_each_within(xi, h, |j, d2| {
                    if j != i {
                        nb.push((j as u32, d2));
                    }
                });
                nb.sort_unstable_by_key(|e| e.0);
                // The weights matter only up to a factor per row (`A⁻¹ x w` and the
                // quadratic fit do not change when all of a row's weights scale), so the
                // unnormalised poly6 shape: the normalised kernel's 1/h⁹ overflows f32
                // below about 15 µm spacing, which makes every weight infinite.
                let mut a = DMat3::ZERO;
                for &(j, d2) in &nb {
                    let x = (phyxels.rest.get(j as usize) - xi).as_dvec3();
                    let w = poly6_shape(d2, h) as f64;
                    a += linalg::outer(x, x * w);
                }
                let (a_inv, ill) = linalg::pseudo_inverse(a);
                let offsets: Vec<(DVec3, f64)> = nb
                    .iter()
                    .map(|&(j, d2)| {
                        (
                            (phyxels.rest.get(j as usize) - xi).as_dvec3(),
                            poly6_shape(d2, h) as f64,
                        )
                    })
                    .collect();
                let quadratic = match basis {
                    GradientBasis::Quadratic if !ill => quadratic_weights(&offsets, h as f64),
                    _ => None,
                };
                let ds: Vec<Vec3> = quadratic.unwrap_or_else(|| {
                    offsets
                        .iter()
                        .map(|&(x, w)| (a_inv * (x * w)).as_vec3())
                        .collect()
                });
                let d_self = -ds.iter().copied().sum::<Vec3>();
                (nb.into_iter().map(|e| e.0).collect(), ds, d_self, ill)
            })
            .collect();
        let mut s = Self {
            offsets: Vec::with_capacity(n + 1),
            ..Default::default()
        };
        s.offsets.push(0);
        for (nb, ds, d_self, ill) in rows {
            s.neighbours.extend_from_slice(&nb);
            s.d.extend_from_slice(&ds);
            s.offsets.push(s.neighbours.len() as u32);
            s.d_self.push(d_self);
            s.ill_conditioned.push(ill);
        }
        s
    }

    /// Number of phyxels.
    pub fn len(&self) -> usize {
        self.d_self.len()
    }

    pub fn is_empty(&self) -> bool {
        self.d_self.is_empty()
    }

    /// Entry range of phyxel i.
    #[inline]
    pub fn row(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i] as usize..self.offsets[i + 1] as usize
    }

    /// `∇u_i = Σ_j (u_j − u_i) d_jᵀ` of the field `u` (column b holds ∂u/∂x_b).
    #[inline]
    pub fn gradient_of(&self, i: usize, u: impl Fn(usize) -> Vec3) -> Mat3 {
        let ui = u(i);
        let mut g = Mat3::ZERO;
        for k in self.row(i) {
            let du = u(self.neighbours[k] as usize) - ui;
            let d = self.d[k];
            g.x_axis += du * d.x;
            g.y_axis += du * d.y;
            g.z_axis += du * d.z;
        }
        g
    }

    /// Displacement gradient of every phyxel from current and rest positions.
    pub fn displacement_gradients(&self, pos: &Vec3s, rest: &Vec3s, out: &mut [Mat3]) {
        out.par_iter_mut()
            .with_min_len(par::point_task())
            .enumerate()
            .for_each(|(i, g)| {
                *g = self.gradient_of(i, |j| pos.get(j) - rest.get(j));
            });
    }

    /// Gradient of the field `u` (one `Vec3` per phyxel) at every phyxel. With `u` packed
    /// as one array a neighbour costs one 12-byte load instead of one from each of six
    /// SoA columns (the stencil's neighbours are scattered over the columns).
    pub fn gradients(&self, u: &[Vec3], out: &mut [Mat3]) {
        out.par_iter_mut()
            .with_min_len(par::point_task())
            .enumerate()
            .for_each(|(i, g)| {
                *g = self.gradient_of(i, |j| u[j]);
            });
    }
}

/// Largest condition number accepted for the quadratic fit (in units scaled by h).
const MAX_CONDITION_QUADRATIC: f64 = 1.0e7;

/// The inverse of the quadratic fit's moment matrix `M = Σ_j w_j b_j b_jᵀ`, `b` the
/// linear and quadratic terms of the offsets `x_j` in units of `h` (so that both are of
/// one size), for neighbours `(x_j, w_j)`; `None` when the neighbourhood cannot support
/// the fit (under 12 neighbours, or condition above [`MAX_CONDITION_QUADRATIC`]).
pub(crate) fn quadratic_fit_inverse(offsets: &[(DVec3, f64)], h: f64) -> Option<[[f64; 9]; 9]> {
    if offsets.len() < 12 {
        return None;
    }
    let mut m = [[0.0f64; 9]; 9];
    for &(x, w) in offsets {
        let p = linalg::quadratic_terms(x / h);
        for r in 0..9 {
            for c in 0..9 {
                m[r][c] += w * p[r] * p[c];
            }
        }
    }
    let (vals, vecs) = linalg::jacobi_eigen(m);
    let lmax = vals.iter().fold(0.0f64, |a, &v| a.max(v.abs()));
    if lmax.is_nan() || lmax <= 0.0 || vals.iter().any(|&v| v < lmax / MAX_CONDITION_QUADRATIC) {
        return None;
    }
    // M⁻¹ = V diag(1/λ) Vᵀ.
    let mut inv = [[0.0f64; 9]; 9];
    for (r, row) in inv.iter_mut().enumerate() {
        for (c, e) in row.iter_mut().enumerate() {
            *e = (0..9).map(|k| vecs[r][k] * vecs[c][k] / vals[k]).sum();
        }
    }
    Some(inv)
}

/// Gradient weights `d_j` of the fit `u_j − u_i ≈ ∇u x_ij + ½ x_ijᵀ H x_ij` (9 unknowns
/// per component): rows 0..3 of [`quadratic_fit_inverse`]; `None` where it is.
fn quadratic_weights(offsets: &[(DVec3, f64)], h: f64) -> Option<Vec<Vec3>> {
    let inv3 = quadratic_fit_inverse(offsets, h)?;
    let basis = |x: DVec3| linalg::quadratic_terms(x / h);
    Some(
        offsets
            .iter()
            .map(|&(x, w)| {
                let p = basis(x);
                let d: [f64; 3] =
                    std::array::from_fn(|r| (0..9).map(|c| inv3[r][c] * p[c]).sum::<f64>() * w / h);
                Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32)
            })
            .collect(),
    )
}
