//! Penalty and friction forces on the contact surfels (Keiser et al. 2004, §7), and the
//! area each surfel stands for.

use super::*;

/// Friction regularisation speed (m/s): below it Coulomb friction is viscous
/// (`μ F_n v_t / FRICTION_SLIP_SPEED`). Explicit integration of that stiff viscous term
/// does not hold a sticking contact to this speed times `F_t/(μ F_n)`: a block on the 20°
/// `incline` (μ = 0.5, where that bound is 0.07 mm/s) creeps at 0.24–0.35 mm/s at
/// dt = 0.1 ms, in proportion to dt (docs/ACCURACY.md, "Known limits").
pub const FRICTION_SLIP_SPEED: f32 = 1.0e-4;

/// Area each contact surfel stands for: `1 / Σ_j W(|x_i − x_j|)` with the normalised
/// 2-D poly6 kernel of support 2 spacings (a kernel density estimate of surfels per m²,
/// exact for any uniform sampling, unlike a k-nearest radius).
///
/// The kernel is evaluated as `4/(π h²) · (1 − r²/h²)³`: written as `4/(π h⁸) · (h² −
/// r²)³` its `h⁸` leaves f32's range for spacings below about 8 µm (every area 0, so no
/// contact force) or above about 30 km (areas infinite, forces NaN).
pub fn areas(surfels: &mut [ContactSurfel], spacing: f32, scratch: &mut PatchScratch) {
    let hh = 2.0 * spacing;
    let norm = 4.0 / (std::f32::consts::PI * (hh * hh));
    let PatchScratch { grid, density, .. } = scratch;
    grid.rebuild(surfels.iter().map(|c| c.pos), hh);
    density.clear();
    density.resize(surfels.len(), 0.0);
    let grid = &*grid;
    let inv_hh2 = f32x8::splat(1.0 / (hh * hh));
    // Eight neighbours at a time over the grid's lane groups (lanes off the mask weigh 0).
    density.par_iter_mut().enumerate().for_each(|(i, rho)| {
        let mut sum = f32x8::ZERO;
        grid.for_each_lanes_within(surfels[i].pos, hh, |_, mask, d2| {
            let q = f32x8::ONE - d2 * inv_hh2;
            sum += lane_mask(mask).select(q * q * q, f32x8::ZERO);
        });
        *rho = norm * sum.reduce_add();
    });
    for (c, &rho) in surfels.iter_mut().zip(density.iter()) {
        c.area = 1.0 / rho;
    }
}

/// Penalty and friction force on each contact surfel (paper eqs. 3–7), with Newton's
/// third law and the factor ½, times the surfel's area.
///
/// `d₁ = s₁ − s_c` runs from Φ to the original surface of object a, `d₂` likewise for b.
/// `s₁`, `s₂` are the ends of the colliding surfel's segment (the surfel and its
/// orthogonal projection onto the other surface): `s_c` lies on that segment, which is
/// the other surface's normal line, so its end there is `s_c`'s orthogonal projection,
/// and the surfel's own end is too up to the (second-order) angle between the two
/// normals, which the projection onto Φ's normal below removes to first order. This is
/// more accurate than the paper's closest surfel when the penetration is below a surfel
/// spacing, and costs no implicit-surface sample (docs/ARCHITECTURE.md).
/// Only the component of `d` along Φ's normal is kept: a frictionless contact must push
/// along the contact normal, and the tangential part of `d` is sampling noise (rim
/// surfels of a curved body) that would make a resting body drift; friction alone acts
/// tangentially.
pub fn forces(patch: &mut ContactPatch, p: &ContactParams, scratch: &mut PatchScratch) {
    areas(&mut patch.surfels, p.force_spacing, scratch);
    let one_side = |d: Vec3, n: Vec3, v_rel: Vec3| -> Vec3 {
        let d = d.dot(n) * n;
        let len = d.length();
        if len <= 0.0 {
            return Vec3::ZERO;
        }
        let dn = d / len;
        let approach = v_rel.dot(dn);
        // Spring plus dashpot, clamped to push only: a separating contact must not
        // stick through its damping term.
        let pen = -(p.stiffness * len + p.damping * approach).max(0.0) * dn;
        if p.friction > 0.0 {
            let vt = v_rel - approach * dn;
            let speed = vt.length();
            let scale = p.friction * pen.length() / speed.max(FRICTION_SLIP_SPEED);
            pen - scale * vt
        } else {
            pen
        }
    };
    patch.surfels.par_iter_mut().for_each(|c| {
        let fa = one_side(c.anchor_a - c.pos, c.normal, c.velocity);
        let fb = one_side(c.anchor_b - c.pos, c.normal, -c.velocity);
        c.force = 0.5 * (fa - fb) * c.area;
    });
}
