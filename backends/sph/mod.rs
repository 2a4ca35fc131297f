//! SPH backend: weakly compressible smoothed particles (Desbrun & Gascuel 1996,
//! "Smoothed particles: a new paradigm for animating highly deformable bodies"; state
//! equation of Becker & Teschner 2007) with optional corotated SPH elasticity (Becker,
//! Ihmsen, Teschner 2009, "Corotated SPH for deformable solids").
//!
//! Written only against phyxel's public API, as an outside crate would be.
//!
//! Per step, with the cubic-spline kernel `W` of smoothing length `h` = the phyxel lattice
//! spacing (support `2h`):
//! 1. density `ρ_i = Σ_j m_j W(x_ij)` over the current neighbours (SIMD hash grid);
//!    Tait state equation `p_i = B((ρ_i/ρ⁰_i)^γ − 1)`, `B = ρ₀ c²/γ`, `γ = 7`,
//!    `c² = K/ρ₀` with the bulk modulus `K = E/(3(1 − 2ν))`: the body's volumetric
//!    stiffness is the material's;
//! 2. pressure and artificial viscosity (Monaghan 1992):
//!    `f_i = −Σ_j m_i m_j (p_i/ρ_i² + p_j/ρ_j² + Π_ij) ∇_i W_ij` (pairwise antisymmetric:
//!    momentum is conserved exactly);
//! 3. corotated elasticity (if enabled): per phyxel the rotation `R_i` of the deformation
//!    gradient `F_i = Σ_j (x_j − x_i) d_ijᵀ` (polar decomposition by Müller et al.'s 2016
//!    quaternion iteration, warm-started), linear strain `ε = sym(R_iᵀF_i − I)`, shear
//!    stress `σ = 2μ (dev ε + τ dev ε̇)` (the volumetric part is the pressure's),
//!    `P_i = −V_i R_i σ_i`, `f_j += P_i d_ij`, `f_i += P_i d_ii` with `d_ii = −Σ_j d_ij`:
//!    every phyxel's elastic forces sum to zero.
//!
//! `d_ij = L_iᵀ V_j ∇_i W(x⁰_ij)` are the kernel gradients at rest with the Bonet–Lok
//! correction `L_i = (Σ_j V_j x⁰_ji ⊗ ∇_i W⁰_ij)⁻¹` (exact for affine fields, also at the
//! free surface). The rest density `ρ⁰_i` is the SPH density of the rest sampling, so a
//! body at rest has zero pressure also at its free surface (no particle deficiency).

mod kernel;
mod pairs;

pub use kernel::CubicSpline;
use pairs::{Fluid, density_sum, pair_forces_x8};

use glam::{Mat3, Quat, Vec3};
use phyxel::columns::{LANES, Vec3s};
use phyxel::dynamics::{
    Diagnostics, Dynamics, StepContext, damped_euler_limit, integrate_symplectic,
};
use phyxel::material::Material;
pub use phyxel::math::linalg::polar_rotation;
use phyxel::points::phyxels::Phyxels;
use phyxel::spatial::grid::Grid;
use rayon::prelude::*;
use wide::f32x8;

/// The backend's name in scenes and on the command line (`backend = "sph"`).
pub const NAME: &str = "sph";

/// Exponent γ of the Tait state equation (Becker & Teschner 2007: 7 for water).
pub const TAIT_GAMMA: f32 = 7.0;

/// CFL number: `dt ≤ CFL · h / c` (Monaghan 1992 uses 0.3–0.4).
pub const CFL: f32 = 0.3;

/// Current neighbours stored per phyxel between the density and the force pass (a
/// cubic lattice has 26 within the support); a phyxel with more is searched again.
const MAX_STORED: usize = 48;

/// Marks a phyxel whose current neighbours did not fit in [`MAX_STORED`].
const OVERFLOW: u32 = u32::MAX;

/// Options of the SPH method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphOptions {
    /// Corotated elasticity (Becker et al. 2009): the body holds its shape. Without it
    /// the body is a weakly compressible fluid.
    pub elasticity: bool,
    /// Artificial viscosity α of Monaghan's `Π_ij` (dimensionless).
    pub alpha: f32,
}

impl Default for SphOptions {
    fn default() -> Self {
        Self {
            elasticity: true,
            alpha: 0.1,
        }
    }
}

/// Weakly compressible SPH, optionally with corotated elasticity, for one object.
pub struct SphDynamics {
    options: SphOptions,
    kernel: CubicSpline,
    /// Rest density per phyxel `ρ⁰_i` (kg/m³): the SPH density of the rest sampling.
    rest_density: Vec<f32>,
    /// Current density `ρ_i` (kg/m³).
    density: Vec<f32>,
    /// `p_i / ρ_i²` (m⁵/(kg·s²)).
    pressure_term: Vec<f32>,
    /// Rest stencil rows: `nbr[off[i]..off[i + 1]]`, sorted; `d[k]` the corrected kernel
    /// gradient `d_ij` (1/m); `rev[k]` the entry of i in row j.
    off: Vec<u32>,
    nbr: Vec<u32>,
    d: Vec<Vec3>,
    /// `d_in[k] = d[rev[k]]`: the gradient entry `d_ji` of the reverse bond, stored along
    /// row i so the force gather reads memory in order.
    d_in: Vec<Vec3>,
    d_self: Vec<Vec3>,
    /// `Σ_j x⁰_ji d_ijᵀ` (the identity where the correction is exact), so that
    /// `∇u_i = Σ_j x_ji d_ijᵀ − rest_sum_i` needs no rest positions. Summed in the
    /// step's order, so a body at rest has `∇u = 0` exactly: `F = (I − Σ⁰) + Σ` leaves
    /// a strain of an ulp, which the stiffest materials turn into forces at rest.
    rest_sum: Vec<Mat3>,
    /// Current neighbours from the density pass, `MAX_STORED` slots per phyxel, and
    /// their number ([`OVERFLOW`]: search again).
    current: Vec<u32>,
    current_len: Vec<u32>,
    /// Rotation of each phyxel (warm start of the polar decomposition).
    rotation: Vec<Quat>,
    /// `P_i = −V_i R_i σ_i` (N per unit `d`).
    stress_force: Vec<Mat3>,
    /// `∇u_i = F_i − I` (column b = ∂u/∂x_b), for surfel advection.
    grad: Vec<Mat3>,
    internal: Vec3s,
    grid: Grid,
    /// Largest strain norm and stored energy (J) of the last step.
    max_strain: f32,
    energy: f64,
    /// Stored energy per phyxel (J), summed in phyxel order into `energy`: a parallel
    /// reduction's order depends on work stealing and changes its last bits run to run.
    phyxel_energy: Vec<f64>,
    /// Smallest lattice spacing (m), for the CFL bound and the default damping.
    spacing: f32,
}

impl SphDynamics {
    /// SPH with the default options (elasticity on) for `phyxels` (any subset of an
    /// object's phyxels works: the rest state is measured on what is given).
    pub fn new(phyxels: &Phyxels, material: &Material) -> Self {
        Self::with_options(phyxels, material, SphOptions::default())
    }

    /// SPH with explicit options.
    pub fn with_options(phyxels: &Phyxels, _material: &Material, options: SphOptions) -> Self {
        let n = phyxels.len();
        let spacing = lattice_spacing(phyxels);
        let kernel = CubicSpline::new(spacing);
        let support = kernel.support();
        let rest: Vec<Vec3> = phyxels.rest.iter().collect();
        let grid = Grid::build(rest.iter().copied(), support);
        let (off, nbr) = rest_rows(&rest, &grid, support);
        // The rest density by the step's own sum (same grid, order and distances), so
        // that a body at rest has a density ratio of exactly 1 and no pressure: summed
        // in stencil order it is a few ulps off, which the Tait law's stiffness turns
        // into forces on a body at rest.
        let zero = Vec3s::zeros(n);
        let rest_density: Vec<f32> = (0..n)
            .map(|i| {
                density_sum(
                    &grid,
                    kernel,
                    &phyxels.rest,
                    &zero,
                    &phyxels.mass,
                    i,
                    |_| {},
                )
            })
            .collect();
        let (d, d_self) = corrected_gradients(&rest, &off, &nbr, kernel, &phyxels.volume);
        let rest_sum: Vec<Mat3> = (0..n)
            .map(|i| {
                let mut m = Mat3::ZERO;
                for k in off[i] as usize..off[i + 1] as usize {
                    m += outer(rest[nbr[k] as usize] - rest[i], d[k]);
                }
                m
            })
            .collect();
        let rev = reverse_entries(&off, &nbr);
        Self {
            options,
            kernel,
            density: rest_density.clone(),
            rest_density,
            pressure_term: vec![0.0; n],
            off,
            nbr,
            d_in: rev.iter().map(|&r| d[r as usize]).collect(),
            d,
            d_self,
            rest_sum,
            current: vec![0; n * MAX_STORED],
            current_len: vec![0; n],
            rotation: vec![Quat::IDENTITY; n],
            stress_force: vec![Mat3::ZERO; n],
            grad: vec![Mat3::ZERO; n],
            internal: Vec3s::zeros(n),
            grid,
            max_strain: 0.0,
            energy: 0.0,
            phyxel_energy: vec![0.0; n],
            spacing,
        }
    }

    /// Current SPH density per phyxel (kg/m³), from the last step.
    pub fn density(&self) -> &[f32] {
        &self.density
    }

    /// Rest density per phyxel (kg/m³).
    pub fn rest_density(&self) -> &[f32] {
        &self.rest_density
    }

    /// The kernel in use.
    pub fn kernel(&self) -> CubicSpline {
        self.kernel
    }

    /// Internal forces of the last step (N).
    pub fn internal_forces(&self) -> &Vec3s {
        &self.internal
    }

    /// Tait coefficient `B = ρ₀ c²/γ` with `c² = K/ρ₀` (Pa).
    fn tait_b(material: &Material) -> f32 {
        bulk_modulus(material) / TAIT_GAMMA
    }

    /// Kelvin–Voigt time τ (s) of the elastic shear stress.
    pub fn tau(&self, material: &Material) -> f32 {
        material.damping_time(self.spacing, material.wave_speed())
    }

    /// Internal forces of the current state into `self.internal` (N).
    pub fn compute_forces(&mut self, phyxels: &Phyxels, material: &Material) {
        let n = phyxels.len();
        let kernel = self.kernel;
        let support = kernel.support();
        self.grid.rebuild_columns(&phyxels.pos, support);
        let b_tait = Self::tait_b(material);
        let k_bulk = bulk_modulus(material) as f64;
        let (_, mu) = material.lame();
        let tau = self.tau(material);
        let elastic = self.options.elasticity;
        let pos = &phyxels.pos;
        let carry = &phyxels.pos_carry;
        let vel = &phyxels.vel;
        let mass = &phyxels.mass;
        let volume = &phyxels.volume;
        let grid = &self.grid;
        let rest_density = &self.rest_density;
        let (off, nbr, d) = (&self.off, &self.nbr, &self.d);
        let rest_sum = &self.rest_sum;
        // Pass 1: density, pressure, and the elastic stress of each phyxel.
        let max_strain = self
            .density
            .par_iter_mut()
            .zip(self.phyxel_energy.par_iter_mut())
            .zip(self.pressure_term.par_iter_mut())
            .zip(self.stress_force.par_iter_mut())
            .zip(self.grad.par_iter_mut())
            .zip(self.rotation.par_iter_mut())
            .zip(self.current.par_chunks_mut(MAX_STORED))
            .zip(self.current_len.par_iter_mut())
            .enumerate()
            .map(
                |(i, (((((((rho_out, e_out), pt), pf), gr), q), slots), len))| {
                    let xi = pos.get(i);
                    let mut count = 0usize;
                    let rho = density_sum(grid, kernel, pos, carry, mass, i, |j| {
                        if j != i {
                            if count < MAX_STORED {
                                slots[count] = j as u32;
                            }
                            count += 1;
                        }
                    });
                    *len = if count <= MAX_STORED {
                        count as u32
                    } else {
                        OVERFLOW
                    };
                    let ratio = rho / rest_density[i];
                    let p = b_tait * (ratio.powi(TAIT_GAMMA as i32) - 1.0);
                    *rho_out = rho;
                    *pt = if rho > 0.0 { p / (rho * rho) } else { 0.0 };
                    let dv = (ratio - 1.0) as f64;
                    let mut e = 0.5 * k_bulk * dv * dv * volume[i] as f64;
                    let mut strain_norm = (ratio - 1.0).abs();
                    if elastic {
                        let (vi, mut sum, mut fd) = (vel.get(i), Mat3::ZERO, Mat3::ZERO);
                        let ci = carry.get(i);
                        for k in off[i] as usize..off[i + 1] as usize {
                            let j = nbr[k] as usize;
                            // With the position sums' carries (`Phyxels::pos_carry`), so that
                            // rounding far from the origin does not strain a stiff body.
                            sum += outer((pos.get(j) - xi) + (carry.get(j) - ci), d[k]);
                            fd += outer(vel.get(j) - vi, d[k]);
                        }
                        // ∇u as a difference of like sums (0 at rest), and the strain from
                        // it and the rotation's own part, not as `sym(Rᵀ F) − I`.
                        let g = sum - rest_sum[i];
                        *q = polar_rotation(Mat3::IDENTITY + g, *q);
                        let r = Mat3::from_quat(*q);
                        let rt = r.transpose();
                        let eps = (sym(rt) - Mat3::IDENTITY) + sym(rt * g);
                        let eps_rate = sym(rt * fd);
                        let sigma = (dev(eps) + dev(eps_rate) * tau) * (2.0 * mu);
                        *pf = r * sigma * (-volume[i]);
                        *gr = g;
                        let de = dev(eps);
                        e += (mu * frob2(de)) as f64 * volume[i] as f64;
                        strain_norm = strain_norm.max(frob2(eps).sqrt());
                    }
                    *e_out = e;
                    strain_norm
                },
            )
            .reduce(|| 0.0, f32::max);
        self.energy = self.phyxel_energy.iter().sum();
        self.max_strain = max_strain;
        // Pass 2: pressure, viscosity and the gathered elastic forces.
        let alpha = self.options.alpha;
        let c = (bulk_modulus(material) / material.density).sqrt();
        let h = kernel.h;
        let (density, pt) = (&self.density, &self.pressure_term);
        let (stress, d_self, d_in) = (&self.stress_force, &self.d_self, &self.d_in);
        let (current, current_len) = (&self.current, &self.current_len);
        let fluid = Fluid {
            pos,
            carry,
            vel,
            mass,
            pressure_term: pt,
            density,
            kernel,
            alpha_c_h: alpha * c * h,
        };
        let Vec3s { x, y, z, .. } = &mut self.internal;
        x[..n]
            .par_iter_mut()
            .zip(y[..n].par_iter_mut())
            .zip(z[..n].par_iter_mut())
            .enumerate()
            .for_each(|(i, ((fx, fy), fz))| {
                let (xi, vi, ci) = (pos.get(i), vel.get(i), carry.get(i));
                let (mi, pti, rhoi) = (mass[i], pt[i], density[i]);
                let mut f = Vec3::ZERO;
                let mut pair = |j: usize, _: f32| {
                    // With the carries, as the density (and `pair_forces_x8`).
                    let xij = (xi - pos.get(j)) + (ci - carry.get(j));
                    let r2 = xij.length_squared();
                    if j == i || r2 <= 0.0 {
                        return;
                    }
                    let vij = vi - vel.get(j);
                    let vx = vij.dot(xij);
                    let mut s = pti + pt[j];
                    if vx < 0.0 && alpha > 0.0 {
                        let mu_ij = h * vx / (r2 + 0.01 * h * h);
                        s += -alpha * c * mu_ij / (0.5 * (rhoi + density[j]));
                    }
                    // Paired as `pair_forces_x8`: `mi · mj` overflows f32 for phyxels
                    // above about 2e19 kg (a planet's), `s · ∇W` for micrometre ones.
                    f -= xij * ((mi * s) * (mass[j] * kernel.grad_over_r(r2)));
                };
                match current_len[i] {
                    OVERFLOW => grid.for_each_within(xi, support, &mut pair),
                    len => {
                        let list = &current[i * MAX_STORED..i * MAX_STORED + len as usize];
                        f += pair_forces_x8(i, list, &fluid);
                    }
                }
                if elastic {
                    f += stress[i] * d_self[i];
                    for k in off[i] as usize..off[i + 1] as usize {
                        f += stress[nbr[k] as usize] * d_in[k];
                    }
                }
                *fx = f.x;
                *fy = f.y;
                *fz = f.z;
            });
    }
}

/// The rest neighbours of each phyxel within the kernel support, as sorted rows
/// (`nbr[off[i]..off[i + 1]]`), with an exactly symmetric test ((a − b)² = (b − a)² in
/// IEEE), so that `j` is in `i`'s row exactly when `i` is in `j`'s.
fn rest_rows(rest: &[Vec3], grid: &Grid, support: f32) -> (Vec<u32>, Vec<u32>) {
    let n = rest.len();
    let s2 = support * support;
    let mut off = Vec::with_capacity(n + 1);
    let mut nbr: Vec<u32> = Vec::new();
    off.push(0u32);
    let mut row = Vec::new();
    for i in 0..n {
        row.clear();
        grid.for_each_within(rest[i], support * 1.001, |j, _| {
            if j != i && (rest[i] - rest[j]).length_squared() < s2 {
                row.push(j as u32);
            }
        });
        row.sort_unstable();
        nbr.extend_from_slice(&row);
        off.push(nbr.len() as u32);
    }
    (off, nbr)
}

/// Kernel gradients at rest `d_ij = L_iᵀ V_j ∇_i W(x⁰_ij)` with the Bonet–Lok correction
/// `L_i` where the neighbourhood spans 3D (else a scale only), and `d_ii = −Σ_j d_ij`.
fn corrected_gradients(
    rest: &[Vec3],
    off: &[u32],
    nbr: &[u32],
    kernel: CubicSpline,
    volume: &[f32],
) -> (Vec<Vec3>, Vec<Vec3>) {
    let n = rest.len();
    let mut d = vec![Vec3::ZERO; nbr.len()];
    let mut d_self = vec![Vec3::ZERO; n];
    for i in 0..n {
        let (a, b) = (off[i] as usize, off[i + 1] as usize);
        let mut m = Mat3::ZERO;
        for k in a..b {
            let j = nbr[k] as usize;
            let xij = rest[i] - rest[j];
            let r2 = xij.length_squared();
            let g = xij * (kernel.grad_over_r(r2) * volume[j]);
            d[k] = g;
            m += outer(-xij, g);
        }
        // Bonet–Lok correction where the neighbourhood spans 3D; else a scale only.
        let tr = m.x_axis.x + m.y_axis.y + m.z_axis.z;
        let l = if tr > 0.0 && m.determinant() > 1e-3 * (tr / 3.0).powi(3) {
            m.inverse()
        } else if tr > 0.0 {
            Mat3::from_diagonal(Vec3::splat(3.0 / tr))
        } else {
            Mat3::ZERO
        };
        let mut sum = Vec3::ZERO;
        for dk in &mut d[a..b] {
            *dk = l.transpose() * *dk;
            sum += *dk;
        }
        d_self[i] = -sum;
    }
    (d, d_self)
}

/// For each row entry `(i, j)`, the index of the entry `(j, i)` (rows are symmetric).
fn reverse_entries(off: &[u32], nbr: &[u32]) -> Vec<u32> {
    let n = off.len() - 1;
    let mut rev = vec![0u32; nbr.len()];
    for i in 0..n {
        for k in off[i] as usize..off[i + 1] as usize {
            let j = nbr[k] as usize;
            let row_j = &nbr[off[j] as usize..off[j + 1] as usize];
            let at = row_j
                .binary_search(&(i as u32))
                .expect("rest rows are symmetric");
            rev[k] = off[j] + at as u32;
        }
    }
    rev
}

/// Bulk modulus `K = E / (3(1 − 2ν))` (Pa).
pub fn bulk_modulus(m: &Material) -> f32 {
    m.young / (3.0 * (1.0 - 2.0 * m.poisson))
}

/// The lattice spacing of the sampling (m): the cube root of the largest phyxel volume,
/// else the largest spacing `r_i`, else 1 (an empty set).
fn lattice_spacing(p: &Phyxels) -> f32 {
    let n = p.len();
    let v = p.volume[..n].iter().fold(0.0f32, |a, &b| a.max(b));
    let s = v.cbrt();
    if s.is_finite() && s > 0.0 {
        return s;
    }
    let r = p.spacing[..n].iter().fold(0.0f32, |a, &b| a.max(b));
    if r.is_finite() && r > 0.0 { r } else { 1.0 }
}

/// `a bᵀ`.
#[inline]
fn outer(a: Vec3, b: Vec3) -> Mat3 {
    Mat3::from_cols(a * b.x, a * b.y, a * b.z)
}

#[inline]
fn sym(m: Mat3) -> Mat3 {
    (m + m.transpose()) * 0.5
}

#[inline]
fn dev(m: Mat3) -> Mat3 {
    let tr = m.x_axis.x + m.y_axis.y + m.z_axis.z;
    m - Mat3::from_diagonal(Vec3::splat(tr / 3.0))
}

#[inline]
fn frob2(m: Mat3) -> f32 {
    m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared()
}

impl Dynamics for SphDynamics {
    fn name(&self) -> &str {
        NAME
    }

    fn step(&mut self, phyxels: &mut Phyxels, ctx: &StepContext<'_>) {
        self.compute_forces(phyxels, ctx.material);
        integrate_symplectic(phyxels, &self.internal, ctx);
    }

    /// The smaller of the CFL bound `CFL · h / c` (P-wave speed `c`) and the
    /// symplectic-Euler limit `2/ω (√(1 + ζ²) − ζ)` of the fastest lattice mode
    /// `ω = 2√3 c / h` with the Kelvin–Voigt damping ratio `ζ = τ ω / 2`; divided by
    /// `1 + α` for the artificial viscosity.
    fn stable_dt(&self, _phyxels: &Phyxels, m: &Material) -> f32 {
        let c = m.wave_speed().max((bulk_modulus(m) / m.density).sqrt());
        if c.is_nan() || c <= 0.0 {
            return f32::INFINITY;
        }
        let h = self.kernel.h;
        let cfl = CFL * h / c;
        let omega = 2.0 * 3f32.sqrt() * c / h;
        let zeta = if self.options.elasticity {
            0.5 * self.tau(m) * omega
        } else {
            0.0
        };
        let damped = damped_euler_limit(omega, zeta);
        cfl.min(damped) / (1.0 + self.options.alpha)
    }

    fn displacement_gradient(&self) -> Option<&[Mat3]> {
        self.options.elasticity.then_some(&self.grad[..])
    }

    fn diagnostics(&self, _phyxels: &Phyxels, _material: &Material) -> Diagnostics {
        Diagnostics {
            elastic_energy: Some(self.energy),
            max_strain: Some(self.max_strain),
            max_plastic_strain: None,
            flat_phyxels: None,
            solver: None,
        }
    }
}
