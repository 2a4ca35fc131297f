//! Penalty and friction forces on the contact surfels (Keiser et al. 2004, §7), and the
//! area each surfel stands for.

use super::stick::{StickKey, StickMemory};
use super::*;

/// Friction regularisation speed (m/s) of the law the stick springs replaced,
/// `μ F_n v_t / max(|v_t|, FRICTION_SLIP_SPEED)`: kept for references to its creep.
pub const FRICTION_SLIP_SPEED: f32 = 1.0e-4;

/// What the friction of one patch carries across steps: the last step's elongations
/// ([`StickMemory`]), the serials that name the pair in its keys, and the step.
#[derive(Clone, Copy)]
pub struct StickContext<'a> {
    pub memory: &'a StickMemory,
    /// [`Object::serial`](crate::body::object::Object::serial) of the patch's a and b.
    pub a: u64,
    pub b: u64,
    /// The step (s): the elongation grows by `v_t dt`.
    pub dt: f32,
}

/// Area each contact surfel stands for (m²): the area its own surfel samples
/// ([`carrier_area`], set by [`super::contact_surface`] in [`ContactSurfel::area`]),
/// times its object's share of the contact surfels about it, `Σ_own W / Σ_all W`, with
/// the normalised 2-D poly6 kernel of support 2 spacings (both objects' colliding
/// surfels sample the same overlap, so inside a patch of two uniform samplings each
/// takes `1 / (ρ_a + ρ_b)`, the density estimate's area). A patch resampled evenly
/// ([`NO_SURFEL`]: no own surfel) takes the density estimate `1 / Σ_all W`.
///
/// The share, not the density, because a kernel density falls off at a patch's rim:
/// there `1 / ρ` grows, so a patch one or two surfel rows wide (a capsule or a ball
/// resting on a plane) lost total force each time a shallow row entered and took area
/// from the deep ones, and a force that falls as the overlap grows feeds energy into
/// every rocking cycle (a capsule left at rest on a plane rolled ever faster). The
/// share's rim bias cancels between its two sums.
///
/// The kernel is evaluated as `(1 − r²/h²)³`: written as `(h² − r²)³ / h⁶` its `h⁶`
/// leaves f32's range for spacings below about 8 µm or above about 30 km.
///
/// Each surfel's support is `2 · spacing ·` [`ContactSurfel::scale`]: where a graded
/// body's coarser level is in contact, its own spacing's (a balloon estimate).
/// `a`: the patch's object a.
pub fn areas(surfels: &mut [ContactSurfel], spacing: f32, a: usize, scratch: &mut PatchScratch) {
    let widest = surfels.iter().fold(1.0f32, |m, c| m.max(c.scale));
    let PatchScratch {
        grid,
        density,
        side,
        ..
    } = scratch;
    grid.rebuild(surfels.iter().map(|c| c.pos), 2.0 * spacing * widest);
    // 1 for each of a's surfels, in the grid's lane order (padded).
    side.clear();
    side.extend(
        grid.sorted()
            .iter()
            .map(|&i| f32::from(u8::from(surfels[i as usize].object == a))),
    );
    side.resize(side.len() + LANES, 0.0);
    density.clear();
    density.resize(surfels.len(), 0.0);
    let (grid, side, surfels_ro) = (&*grid, &*side, &*surfels);
    // Eight neighbours at a time over the grid's lane groups (lanes off the mask weigh 0).
    density.par_iter_mut().enumerate().for_each(|(i, out)| {
        let c = &surfels_ro[i];
        let hh = 2.0 * spacing * c.scale;
        let inv_hh2 = f32x8::splat(1.0 / (hh * hh));
        let (mut all, mut of_a) = (f32x8::ZERO, f32x8::ZERO);
        grid.for_each_lanes_within(c.pos, hh, |at, mask, d2| {
            let q = f32x8::ONE - d2 * inv_hh2;
            let w = lane_mask(mask).select(q * q * q, f32x8::ZERO);
            all += w;
            of_a = w.mul_add(load8(side, at), of_a);
        });
        let (all, of_a) = (all.reduce_add(), of_a.reduce_add());
        *out = if c.surfel == NO_SURFEL {
            std::f32::consts::PI * (hh * hh) / (4.0 * all)
        } else if c.object == a {
            of_a / all
        } else {
            (all - of_a) / all
        };
    });
    for (c, &x) in surfels.iter_mut().zip(density.iter()) {
        c.area = if c.surfel == NO_SURFEL { x } else { c.area * x };
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
///
/// Friction is a stick spring (Cundall and Strack 1979; [`super::stick`]): the
/// elongation `ξ = ξ₀ + v_t dt` from the last step's (turned into Φ's tangent plane)
/// pulls back with `k_t ξ + c_t v_t`, the normal spring's stiffness `½ k A` and
/// dashpot `c A` (so the stable step is unchanged), returned to Coulomb's cone
/// `μ F_n`; on the cone the elongation is reset so that spring and dashpot together
/// give the cone's force, `ξ = −(F_t + c_t v_t)/k_t`, as DEM codes do (reset to
/// `−F_t / k_t`, a contact vibrating at the cone slips a little each time its dashpot
/// pushes it over, and a block ratchets down a slope it sticks to). A sticking contact
/// holds its place instead of creeping at a regularised sticking speed.
pub fn forces(
    patch: &mut ContactPatch,
    p: &ContactParams,
    scratch: &mut PatchScratch,
    stick: &StickContext<'_>,
) {
    areas(&mut patch.surfels, p.force_spacing, patch.a, scratch);
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
        -(p.stiffness * len + p.damping * approach).max(0.0) * dn
    };
    let b = patch.b;
    patch.surfels.par_iter_mut().for_each(|c| {
        let fa = one_side(c.anchor_a - c.pos, c.normal, c.velocity);
        let fb = one_side(c.anchor_b - c.pos, c.normal, -c.velocity);
        let normal = 0.5 * (fa - fb) * c.area;
        c.force = normal;
        c.stick = Vec3::ZERO;
        let cap = p.friction * normal.length();
        if cap <= 0.0 {
            return;
        }
        let n = c.normal;
        let slip = c.velocity - n * n.dot(c.velocity);
        let last =
            StickKey::of(stick.a, stick.b, b, c).map_or(Vec3::ZERO, |key| stick.memory.get(&key));
        let xi = last - n * n.dot(last) + slip * stick.dt;
        let (k, damping) = (0.5 * p.stiffness * c.area, p.damping * c.area);
        let pull = -(k * xi + damping * slip);
        let size = pull.length();
        if size <= cap {
            c.force += pull;
            c.stick = xi;
        } else {
            let f = pull * (cap / size);
            c.force += f;
            c.stick = if k > 0.0 {
                -(f + damping * slip) / k
            } else {
                Vec3::ZERO
            };
        }
    });
}

/// Records the elongations of `patches`' contact surfels (those with a colliding
/// surfel and an anchor) as the next step's memory, after a step of `dt` (s);
/// `serial(k)` names object k.
pub fn keep_sticks(
    patches: &[ContactPatch],
    serial: impl Fn(usize) -> u64,
    memory: &mut StickMemory,
    dt: f32,
) {
    for patch in patches {
        let (a, b) = (serial(patch.a), serial(patch.b));
        for c in patch.surfels.iter().filter(|c| c.stick != Vec3::ZERO) {
            if let Some(key) = StickKey::of(a, b, patch.b, c) {
                memory.push(key, c.stick);
            }
        }
    }
    memory.commit(dt);
}
