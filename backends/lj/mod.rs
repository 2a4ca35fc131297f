//! Lennard-Jones backend: a particle solid held together by pairwise Lennard-Jones
//! bonds with a cutoff and damping (Tonnesen 1998, "Dynamically coupled particle systems
//! for geometric modeling, reconstruction, and animation"); brittle: bonds stretched past
//! the cutoff break for good.
//!
//! Written only against phyxel's public API, as an outside crate would be.
//!
//! **Bonds.** Phyxels closer than [`BOND_RADIUS`] lattice spacings at rest (on a cubic
//! lattice: the 6 nearest neighbours at `a` and the 12 face diagonals at `√2 a`) are
//! bonded. Each bond has its own `σ_ij = r⁰_ij / 2^(1/6)`, so its rest length is exactly
//! the minimum of its potential `V(r) = 4ε_ij((σ_ij/r)¹² − (σ_ij/r)⁶)`: the rest lattice
//! is exactly at equilibrium. (One σ for all pairs cannot do that on a cubic lattice: with
//! the cutoff past `a` the face diagonals pull, with the cutoff below `√2 a` the lattice
//! has no shear stiffness at all. docs/BACKENDS.md has the reasoning.)
//!
//! With `u = (r⁰/r)⁶`: `V(r) − V(r⁰) = ε(u − 1)²` and the repulsive force along the bond
//! `F(r) = 12 ε u (u − 1) / r`; the bond stiffness at rest is `k = V''(r⁰) = 72 ε / r⁰²`
//! (= 72·2^(−1/3) ε/σ²).
//!
//! **Stiffness from E.** A simple cubic lattice of spacing `a` with springs `k` to its 6
//! nearest and 12 face-diagonal neighbours has `C₁₁ = 3k/a`, `C₁₂ = C₄₄ = k/a`, so
//! `E = 2.5 k/a` and `ν = 1/4` (a central-force lattice fixes ν). Hence
//! `k = 0.4 E a` for every bond and `ε_ij = k r⁰_ij² / 72`.
//!
//! **Brittle cutoff.** A bond stretched past `CUTOFF · r⁰_ij` carries no force from then
//! on, except the repulsive branch (`r < r⁰`), which keeps broken pieces from passing
//! through each other until the topology phase splits them.
//!
//! **Damping.** A dashpot `c = τ k` along each intact bond (Kelvin–Voigt per bond), τ the
//! material's damping time (default: damping ratio 0.1 on the fastest mode).

use glam::Vec3;
use phyxel::columns::Vec3s;
use phyxel::dynamics::{
    Diagnostics, Dynamics, StepContext, damped_euler_limit, integrate_symplectic,
};
use phyxel::material::Material;
use phyxel::points::phyxels::Phyxels;
use phyxel::spatial::grid::Grid;
use rayon::prelude::*;
use std::sync::atomic::AtomicU8;
use std::sync::atomic::Ordering::Relaxed;

/// The backend's name in scenes and on the command line (`backend = "lj"`).
pub const NAME: &str = "lj";

/// Rest distance (in lattice spacings) below which two phyxels are bonded: between the
/// face diagonal `√2` and the body diagonal `√3` of a cubic lattice.
pub const BOND_RADIUS: f32 = 1.5;

/// A bond breaks when stretched past this multiple of its rest length. The LJ force
/// peaks at `1.109 r⁰` (the inflection of V) and has fallen to a quarter of its peak at
/// `1.5 r⁰`: past the peak the bond softens, strain localises and the body cracks.
pub const CUTOFF: f32 = 1.5;

/// Bond stiffness `k = BOND_STIFFNESS · E · a` (N/m) for the 6 + 12 bond cubic lattice.
pub const BOND_STIFFNESS: f32 = 0.4;

/// Fraction of the Gershgorin bound `2/ω_max` used as the stable step (the LJ bond is
/// 2.7 times stiffer at 5% compression than at rest).
const STABILITY_MARGIN: f32 = 0.8;

/// Pairwise Lennard-Jones bonds for one object.
pub struct LjDynamics {
    /// Bond rows: `nbr[off[i]..off[i + 1]]`; every bond appears in both rows.
    off: Vec<u32>,
    nbr: Vec<u32>,
    /// Rest length `r⁰_ij` (m) per entry.
    rest_length: Vec<f32>,
    /// Stiffness `k_ij = 72 ε_ij / r⁰²` (N/m) per entry.
    stiffness: Vec<f32>,
    /// 1 once the bond has broken (both entries of a bond agree: same distance).
    broken: Vec<AtomicU8>,
    internal: Vec3s,
    /// Lattice spacing (m).
    spacing: f32,
    /// Largest `Σ_j 2 k_ij / m_i` (1/s²): Gershgorin bound of `ω²_max`.
    omega2_max: f32,
    energy: f64,
    /// Bond energy per phyxel (J), summed in phyxel order into `energy`: a parallel
    /// reduction's order depends on work stealing and changes its last bits run to run.
    phyxel_energy: Vec<f64>,
    max_strain: f32,
}

impl LjDynamics {
    /// Bonds between the given phyxels (any subset of an object, e.g. a fragment):
    /// pairs closer than [`BOND_RADIUS`] spacings at rest that are also within the
    /// cutoff now.
    pub fn new(phyxels: &Phyxels, material: &Material) -> Self {
        let n = phyxels.len();
        let spacing = lattice_spacing(phyxels);
        let k = BOND_STIFFNESS * material.young * spacing;
        let radius = BOND_RADIUS * spacing;
        let rest: Vec<Vec3> = phyxels.rest.iter().collect();
        let grid = Grid::build(rest.iter().copied(), radius);
        let mut off = Vec::with_capacity(n + 1);
        off.push(0u32);
        let (mut nbr, mut rest_length) = (Vec::new(), Vec::new());
        let mut row: Vec<(u32, f32)> = Vec::new();
        for i in 0..n {
            row.clear();
            grid.for_each_within(rest[i], radius * 1.001, |j, _| {
                if j == i {
                    return;
                }
                let r0 = (rest[i] - rest[j]).length();
                let r = (phyxels.pos.get(i) - phyxels.pos.get(j)).length();
                if r0 > 0.0 && r0 < radius && r < CUTOFF * r0 {
                    row.push((j as u32, r0));
                }
            });
            row.sort_unstable_by_key(|e| e.0);
            for &(j, r0) in &row {
                nbr.push(j);
                rest_length.push(r0);
            }
            off.push(nbr.len() as u32);
        }
        let m = nbr.len();
        let omega2_max = (0..n)
            .filter(|&i| phyxels.fixed[i] == 0 && phyxels.mass[i] > 0.0)
            .map(|i| 2.0 * k * (off[i + 1] - off[i]) as f32 / phyxels.mass[i])
            .fold(0.0f32, f32::max);
        Self {
            off,
            nbr,
            rest_length,
            stiffness: vec![k; m],
            broken: (0..m).map(|_| AtomicU8::new(0)).collect(),
            internal: Vec3s::zeros(n),
            spacing,
            omega2_max,
            energy: 0.0,
            phyxel_energy: vec![0.0; n],
            max_strain: 0.0,
        }
    }

    /// Number of bonds (each counted once) and how many of them are broken.
    pub fn bonds(&self) -> (usize, usize) {
        let broken = self.broken.iter().filter(|b| b.load(Relaxed) != 0).count();
        (self.nbr.len() / 2, broken / 2)
    }

    /// Internal forces of the last step (N).
    pub fn internal_forces(&self) -> &Vec3s {
        &self.internal
    }

    /// P-wave speed `√(C₁₁/ρ)` (m/s) of the bond lattice, `C₁₁ = 3k/a = 1.2 E`.
    fn wave_speed(material: &Material) -> f32 {
        (3.0 * BOND_STIFFNESS * material.young / material.density).sqrt()
    }

    /// Dashpot time τ (s) of the bonds.
    pub fn tau(&self, material: &Material) -> f32 {
        material.damping_time(self.spacing, Self::wave_speed(material))
    }

    /// Bond forces of the current state into `self.internal` (N); breaks bonds past the
    /// cutoff.
    pub fn compute_forces(&mut self, phyxels: &Phyxels, material: &Material) {
        let n = phyxels.len();
        let tau = self.tau(material);
        let (pos, vel, carry) = (&phyxels.pos, &phyxels.vel, &phyxels.pos_carry);
        let (off, nbr, r0s, ks) = (&self.off, &self.nbr, &self.rest_length, &self.stiffness);
        // Each row writes only its own entries of `broken` (atomics: no per-step split).
        let broken = &self.broken;
        let Vec3s { x, y, z, .. } = &mut self.internal;
        let max_strain = x[..n]
            .par_iter_mut()
            .zip(y[..n].par_iter_mut())
            .zip(z[..n].par_iter_mut())
            .zip(self.phyxel_energy.par_iter_mut())
            .enumerate()
            .map(|(i, (((fx, fy), fz), e_out))| {
                let (xi, vi, ci) = (pos.get(i), vel.get(i), carry.get(i));
                let (mut f, mut e, mut strain) = (Vec3::ZERO, 0.0f64, 0.0f32);
                for kk in off[i] as usize..off[i + 1] as usize {
                    let j = nbr[kk] as usize;
                    // With the position sums' carries: rounding of positions far from
                    // the origin would otherwise strain stiff bonds (`Phyxels::pos_carry`).
                    let d = (xi - pos.get(j)) + (ci - carry.get(j));
                    let r = d.length();
                    let r0 = r0s[kk];
                    let mut br = broken[kk].load(Relaxed);
                    if br == 0 && r > CUTOFF * r0 {
                        br = 1;
                        broken[kk].store(1, Relaxed);
                    }
                    if r <= 0.0 || (br != 0 && r >= r0) {
                        continue;
                    }
                    let k = ks[kk];
                    let eps = k * r0 * r0 / 72.0;
                    let nrm = d / r;
                    let (mut fr, v) = bond(eps, r0, r);
                    if br == 0 {
                        fr -= tau * k * (vi - vel.get(j)).dot(nrm);
                        strain = strain.max((r / r0 - 1.0).abs());
                    }
                    f += nrm * fr;
                    e += 0.5 * v as f64;
                }
                *fx = f.x;
                *fy = f.y;
                *fz = f.z;
                *e_out = e;
                strain
            })
            .reduce(|| 0.0, f32::max);
        self.energy = self.phyxel_energy.iter().sum();
        self.max_strain = max_strain;
    }
}

/// Compression (as `r / r⁰`) below which the bond's repulsive wall continues as a
/// straight line: its stiffness there, 2.7 times the rest stiffness, is what the stable
/// step's Gershgorin margin covers. The true r⁻¹² wall stiffens without bound, so an
/// impact compresses bonds past what the stable step covers and the body gains energy.
pub const WALL_START: f32 = 0.95;

/// The bond's repulsive force along the bond (N, > 0 pushes apart) and its energy above
/// the rest minimum (J) at length `r`: Lennard-Jones `12 ε u (u − 1)/r`, `ε (u − 1)²`
/// with `u = (r⁰/r)⁶`, continued below [`WALL_START`]·r⁰ by its tangent (force
/// `F_w + K_w (r_w − r)`, `K_w = 12 ε (13u_w² − 7u_w)/r_w²`) and the matching quadratic
/// energy, so force and energy stay continuous.
#[inline]
pub fn bond(eps: f32, r0: f32, r: f32) -> (f32, f32) {
    let lj = |r: f32| {
        let u = (r0 / r).powi(6);
        (
            12.0 * eps * u * (u - 1.0) / r,
            eps * (u - 1.0) * (u - 1.0),
            u,
        )
    };
    let rw = WALL_START * r0;
    if r >= rw {
        let (f, v, _) = lj(r);
        return (f, v);
    }
    let (fw, vw, uw) = lj(rw);
    let kw = 12.0 * eps * (13.0 * uw * uw - 7.0 * uw) / (rw * rw);
    let s = rw - r;
    (fw + kw * s, vw + fw * s + 0.5 * kw * s * s)
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

impl Dynamics for LjDynamics {
    fn name(&self) -> &str {
        NAME
    }

    fn step(&mut self, phyxels: &mut Phyxels, ctx: &StepContext<'_>) {
        self.compute_forces(phyxels, ctx.material);
        integrate_symplectic(phyxels, &self.internal, ctx);
    }

    /// `margin · 2/ω · (√(1 + ζ²) − ζ)` with the Gershgorin bound
    /// `ω² ≤ max_i Σ_j 2 k_ij / m_i` and the dashpot damping ratio `ζ = τ ω / 2`.
    fn stable_dt(&self, _phyxels: &Phyxels, m: &Material) -> f32 {
        let omega = self.omega2_max.sqrt();
        if omega.is_nan() || omega <= 0.0 {
            return f32::INFINITY;
        }
        let zeta = 0.5 * self.tau(m) * omega;
        STABILITY_MARGIN * damped_euler_limit(omega, zeta)
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

    /// Brittle: bonds past the cutoff break, so the body may fall apart.
    fn fragment(&self, phyxels: &Phyxels, material: &Material) -> Option<Box<dyn Dynamics>> {
        Some(Box::new(LjDynamics::new(phyxels, material)))
    }

    fn can_fracture(&self, _material: &Material) -> bool {
        true
    }
}
