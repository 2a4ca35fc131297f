//! The per-pair sums of a step: pressure and viscosity forces of one phyxel eight
//! neighbours at a time, and the density sum.

use super::*;

/// What the pressure and viscosity forces read.
pub(super) struct Fluid<'a> {
    pub(super) pos: &'a Vec3s,
    /// `Phyxels::pos_carry`: relative positions are `(x_j − x_i) + (c_j − c_i)`.
    pub(super) carry: &'a Vec3s,
    pub(super) vel: &'a Vec3s,
    pub(super) mass: &'a [f32],
    pub(super) pressure_term: &'a [f32],
    pub(super) density: &'a [f32],
    pub(super) kernel: CubicSpline,
    /// `α c h` of the artificial viscosity (m²/s).
    pub(super) alpha_c_h: f32,
}

/// Pressure and artificial-viscosity force on phyxel i from the neighbours in `list`
/// (`j ≠ i`), eight at a time (`wide::f32x8`): the same terms as the scalar pair closure
/// of [`SphDynamics::compute_forces`]. Padding lanes have zero mass and zero distance
/// (masked out).
#[inline]
pub(super) fn pair_forces_x8(i: usize, list: &[u32], fl: &Fluid<'_>) -> Vec3 {
    let z = f32x8::ZERO;
    let one = f32x8::ONE;
    let two = f32x8::splat(2.0);
    let k = fl.kernel;
    let sig_h = f32x8::splat(k.sigma * k.inv_h);
    let inv_h = f32x8::splat(k.inv_h);
    let eps_h2 = f32x8::splat(0.01 * k.h * k.h);
    let ach = f32x8::splat(fl.alpha_c_h);
    let (xi, ci) = (fl.pos.get(i), fl.carry.get(i));
    let vi = [fl.vel.x[i], fl.vel.y[i], fl.vel.z[i]].map(f32x8::splat);
    let (mi, pti, rhoi) = (
        f32x8::splat(fl.mass[i]),
        f32x8::splat(fl.pressure_term[i]),
        f32x8::splat(fl.density[i]),
    );
    let mut acc = [z; 3];
    for chunk in list.chunks(LANES) {
        // Gather: x_j − x_i (with the carries), vx vy vz, m, p/ρ², ρ.
        let mut g = [[0.0f32; LANES]; 9];
        #[allow(clippy::needless_range_loop)] // lane l of nine gathered columns
        for l in 0..LANES {
            let (p, v) = match chunk.get(l) {
                Some(&j) => {
                    let j = j as usize;
                    g[6][l] = fl.mass[j];
                    g[7][l] = fl.pressure_term[j];
                    g[8][l] = fl.density[j];
                    ((fl.pos.get(j) - xi) + (fl.carry.get(j) - ci), fl.vel.get(j))
                }
                None => {
                    g[8][l] = 1.0;
                    (Vec3::ZERO, fl.vel.get(i))
                }
            };
            (g[0][l], g[1][l], g[2][l]) = (p.x, p.y, p.z);
            (g[3][l], g[4][l], g[5][l]) = (v.x, v.y, v.z);
        }
        let g = g.map(f32x8::from);
        let d = [z - g[0], z - g[1], z - g[2]];
        let dv = [vi[0] - g[3], vi[1] - g[4], vi[2] - g[5]];
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let r = r2.sqrt();
        let q = r * inv_h;
        let inner = sig_h * q * (f32x8::splat(2.25) * q - f32x8::splat(3.0));
        let t = two - q;
        let outer = f32x8::splat(-0.75) * sig_h * t * t;
        let dw = q
            .simd_lt(one)
            .select(inner, q.simd_lt(two).select(outer, z));
        let grad_over_r = r2.simd_gt(z).select(dw / r, z);
        let vx = dv[0] * d[0] + dv[1] * d[1] + dv[2] * d[2];
        let visc = -ach * vx / ((r2 + eps_h2) * f32x8::splat(0.5) * (rhoi + g[8]));
        let s = pti + g[7] + vx.simd_lt(z).select(visc, z);
        // `(mi s)(mj ∇W/r)`: each factor stays in range from micrometre to planet-sized
        // phyxels, where `mi mj` alone overflows (inf · 0 = NaN at rest).
        let coef = (mi * s) * (g[6] * grad_over_r);
        for c in 0..3 {
            acc[c] -= d[c] * coef;
        }
    }
    Vec3::new(
        acc[0].reduce_add(),
        acc[1].reduce_add(),
        acc[2].reduce_add(),
    )
}

/// SPH density `ρ_i = Σ_j m_j W(|x_j − x_i|)` (kg/m³) over the phyxels `grid` finds
/// within the kernel's support of `pos[i]`, in the grid's order, calling `visit(j)` for
/// each (i included). Distances include the position sums' carries
/// (`Phyxels::pos_carry`): the grid's distance of the rounded positions would make a
/// stiff body far from the origin breathe with their rounding. The step and the rest
/// density both use this sum, so a body at rest has a density ratio of exactly 1.
pub(super) fn density_sum(
    grid: &Grid,
    kernel: CubicSpline,
    pos: &Vec3s,
    carry: &Vec3s,
    mass: &[f32],
    i: usize,
    mut visit: impl FnMut(usize),
) -> f32 {
    let (xi, ci) = (pos.get(i), carry.get(i));
    let mut rho = 0.0f32;
    grid.for_each_within(xi, kernel.support(), |j, _| {
        let r2 = ((pos.get(j) - xi) + (carry.get(j) - ci)).length_squared();
        rho += mass[j] * kernel.w(r2);
        visit(j);
    });
    rho
}
