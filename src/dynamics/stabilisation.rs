//! Residual stabilisation of the MLS fit: hourglass control for nodal integration.
//!
//! The MLS energy is evaluated at the phyxels only, from the gradient of each one's
//! local fit ([`super::gradient`]). A displacement that the fit cannot represent — the
//! layers of a bar rotating alternately, say — changes no gradient much and costs almost
//! no energy. Symmetric stencils keep such a mode nearly orthogonal to smooth loads; a
//! level interface of graded sampling couples it to bending, and the bar bends there as
//! at a hinge (docs/ACCURACY.md, "Cantilever").
//!
//! The term adds, per phyxel i, the energy of its fit's residual
//! `E_i = ½ α μ v_i Σ_j w_ij |r_ij|² / Σ_j w_ij |x_ij|²`, with
//! `r_ij = u_j − u_i − C_i b(x_ij)` and `C_i` the weighted least-squares fit of `u_j − u_i`
//! over the linear and quadratic terms `b` (the fit of the quadratic gradient basis,
//! same weights). This is the hourglass control of Ganzenmüller (2015, "An hourglass
//! control algorithm for Lagrangian Smooth Particle Hydrodynamics", CMAME 286) with a
//! quadratic instead of a linear fit, so that bending, which is quadratic, costs
//! nothing extra: `r` vanishes for every quadratic displacement, rigid motions
//! included, and acts on x, y and z alike, so `E` is invariant under rotation.
//!
//! `r` is linear in the displacement: `Σ_i E_i = ½ uᵀ K u` with a constant, symmetric
//! `K` (N/m, the same for each component) whose rows sum to zero. It is assembled once
//! at rest over each fit's neighbourhood (phyxels two influence radii apart couple) and
//! applied in differences `Σ_l K_jl (u_l − u_j)`, so that a translation adds no force in
//! rounding.

use crate::math::kernel::poly6_shape;
use crate::math::linalg;
use crate::par;
use crate::points::phyxels::Phyxels;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::gradient::{MlsStencil, quadratic_fit_inverse};

/// The stabilisation's stiffness `K` in compressed rows, the diagonal left out (it is
/// minus the row's sum).
#[derive(Clone, Debug, Default)]
pub struct Stabilisation {
    offsets: Vec<u32>,
    columns: Vec<u32>,
    values: Vec<f32>,
}

/// One phyxel's fit: `k_i = α μ v_i / Σ w |x|²` and the inverse of its moment matrix
/// (the gradient's quadratic fit). `k = 0` where that fit cannot be made.
struct Fit {
    k: f64,
    m_inv: [[f64; 9]; 9],
}

/// Neighbour offsets of phyxel i (m), their weights and basis terms.
fn neighbourhood(phyxels: &Phyxels, stencil: &MlsStencil, i: usize) -> Vec<(DVec3, f64, [f64; 9])> {
    let xi = phyxels.rest.get(i);
    let h = phyxels.radius[i];
    stencil.neighbours[stencil.row(i)]
        .iter()
        .map(|&j| {
            let x = phyxels.rest.get(j as usize) - xi;
            let w = poly6_shape(x.length_squared(), h) as f64;
            let x = x.as_dvec3();
            (x, w, linalg::quadratic_terms(x / h as f64))
        })
        .collect()
}

fn fit(phyxels: &Phyxels, stencil: &MlsStencil, i: usize, stiffness: f64) -> Fit {
    let none = Fit {
        k: 0.0,
        m_inv: [[0.0; 9]; 9],
    };
    if stiffness <= 0.0 || stencil.ill_conditioned[i] {
        return none;
    }
    let nb = neighbourhood(phyxels, stencil, i);
    let offsets: Vec<(DVec3, f64)> = nb.iter().map(|&(x, w, _)| (x, w)).collect();
    let spread: f64 = nb.iter().map(|(x, w, _)| w * x.length_squared()).sum();
    match quadratic_fit_inverse(&offsets, phyxels.radius[i] as f64) {
        Some(m_inv) if spread > 0.0 => Fit {
            k: stiffness * phyxels.volume[i] as f64 / spread,
            m_inv,
        },
        _ => none,
    }
}

fn mul(m: &[[f64; 9]; 9], b: &[f64; 9]) -> [f64; 9] {
    std::array::from_fn(|r| (0..9).map(|c| m[r][c] * b[c]).sum())
}

fn dot(a: &[f64; 9], b: &[f64; 9]) -> f64 {
    (0..9).map(|r| a[r] * b[r]).sum()
}

impl Stabilisation {
    /// Assembles `K` for `phyxels` with the rest stencil `stencil`, shear modulus `shear`
    /// (Pa; the law's small-strain μ) and the dimensionless weight `alpha(i)` of each
    /// phyxel's fit (0: none).
    pub fn build(
        phyxels: &Phyxels,
        stencil: &MlsStencil,
        shear: f64,
        alpha: impl Fn(usize) -> f64 + Sync,
    ) -> Self {
        let n = stencil.len();
        let fits: Vec<Fit> = (0..n)
            .into_par_iter()
            .with_min_len(par::point_task())
            .map(|i| fit(phyxels, stencil, i, alpha(i) * shear))
            .collect();
        // Rows that name phyxel j, in increasing order (j's own among them).
        let mut rows_of: Vec<Vec<(u32, u32)>> = vec![Vec::new(); n];
        for i in 0..n {
            if fits[i].k == 0.0 {
                continue;
            }
            rows_of[i].push((i as u32, 0));
            for (slot, &j) in stencil.neighbours[stencil.row(i)].iter().enumerate() {
                rows_of[j as usize].push((i as u32, slot as u32 + 1));
            }
        }
        rows_of.iter_mut().for_each(|r| r.sort_unstable());
        let rows: Vec<Vec<(u32, f32)>> = (0..n)
            .into_par_iter()
            .with_min_len(par::point_task())
            .map(|j| {
                let mut entries: Vec<(u32, f64)> = Vec::new();
                for &(i, at) in &rows_of[j] {
                    let (i, at) = (i as usize, at as usize);
                    let f = &fits[i];
                    let nb = neighbourhood(phyxels, stencil, i);
                    let ids = &stencil.neighbours[stencil.row(i)];
                    let mut beta = [0.0f64; 9];
                    for (_, w, b) in &nb {
                        (0..9).for_each(|r| beta[r] += w * b[r]);
                    }
                    let gamma = mul(&f.m_inv, &beta);
                    // Row `at` of `T_i = Dᵀ S D` over [i, neighbours], with
                    // `S_st = w_s δ_st − w_s w_t b_sᵀ M⁻¹ b_t` and `D Δ = u_nb − u_i`.
                    if at == 0 {
                        let sw: f64 = nb.iter().map(|e| e.1).sum();
                        entries.push((i as u32, f.k * (sw - dot(&beta, &gamma))));
                        for (&l, (_, w, b)) in ids.iter().zip(&nb) {
                            entries.push((l, -f.k * w * (1.0 - dot(b, &gamma))));
                        }
                    } else {
                        let (_, ws, bs) = &nb[at - 1];
                        let g = mul(&f.m_inv, bs);
                        entries.push((i as u32, -f.k * ws * (1.0 - dot(bs, &gamma))));
                        for (t, (&l, (_, w, b))) in ids.iter().zip(&nb).enumerate() {
                            let own = if t + 1 == at { *ws } else { 0.0 };
                            entries.push((l, f.k * (own - ws * w * dot(b, &g))));
                        }
                    }
                }
                entries.sort_by_key(|e| e.0);
                let mut row: Vec<(u32, f32)> = Vec::new();
                let mut k = 0;
                while k < entries.len() {
                    let col = entries[k].0;
                    let mut sum = 0.0f64;
                    while k < entries.len() && entries[k].0 == col {
                        sum += entries[k].1;
                        k += 1;
                    }
                    if col as usize != j && sum != 0.0 {
                        row.push((col, sum as f32));
                    }
                }
                row
            })
            .collect();
        let mut s = Self {
            offsets: Vec::with_capacity(n + 1),
            ..Default::default()
        };
        s.offsets.push(0);
        for row in rows {
            s.columns.extend(row.iter().map(|e| e.0));
            s.values.extend(row.iter().map(|e| e.1));
            s.offsets.push(s.columns.len() as u32);
        }
        s
    }

    /// Number of phyxels.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Row j's off-diagonal entries `(l, K_jl)` (N/m); the diagonal is minus their sum.
    pub fn row(&self, j: usize) -> impl Iterator<Item = (usize, f32)> + '_ {
        let r = self.offsets[j] as usize..self.offsets[j + 1] as usize;
        self.columns[r.clone()]
            .iter()
            .zip(&self.values[r])
            .map(|(&l, &v)| (l as usize, v))
    }

    /// `(K u)_j = Σ_l K_jl (u_l − u_j)` (N per m of `u`).
    #[inline]
    pub fn product_at(&self, j: usize, u: impl Fn(usize) -> Vec3) -> Vec3 {
        let uj = u(j);
        self.row(j)
            .fold(Vec3::ZERO, |s, (l, k)| s + (u(l) - uj) * k)
    }

    /// `out_j += scale · (K u)_j` for every phyxel, in parallel (each row's sum in a fixed
    /// order, so the result does not depend on the thread count).
    pub fn add_product(&self, u: impl Fn(usize) -> Vec3 + Sync, scale: f32, out: &mut [Vec3]) {
        out.par_iter_mut()
            .with_min_len(par::point_task())
            .enumerate()
            .for_each(|(j, o)| *o += self.product_at(j, &u) * scale);
    }

    /// The energy `½ uᵀ K u = −¼ Σ_j Σ_l K_jl |u_j − u_l|²` (J).
    pub fn energy(&self, u: impl Fn(usize) -> Vec3) -> f64 {
        let mut e = 0.0f64;
        for j in 0..self.len() {
            let uj = u(j);
            for (l, k) in self.row(j) {
                e -= 0.25 * k as f64 * (uj - u(l)).length_squared() as f64;
            }
        }
        e
    }
}
