//! The contact springs that implicit bodies take into their solve
//! ([`crate::dynamics::implicit`]): each contact surfel's penalty force (paper eqs. 3–7)
//! differentiated along the contact normal.

use super::params::{DISTRIBUTION_SUPPORT, contact_params};
use super::*;
use crate::body::object::Object;
use crate::dynamics::implicit::{ContactSpring, ContactSprings, SpringSide};

/// True if the contact between `a` and `b` joins an implicit solve: every side that
/// moves is implicit (and one does), and the pair is frictionless. Friction is
/// explicit, computed from the normal force of the step's start: with the normal force
/// changed in the solve, a block sliding on the `incline` lost 0.17% of its
/// acceleration (docs/BACKENDS.md); a frictional pair keeps explicit contact, and its
/// stable bound.
pub fn springs_apply(a: &Object, b: &Object) -> bool {
    let joins = |o: &Object| o.is_static() || o.dynamics.is_implicit();
    joins(a)
        && joins(b)
        && !(a.is_static() && b.is_static())
        && a.material.friction * b.material.friction == 0.0
}

/// Appends to `out` the springs of the patches whose pair [`springs_apply`]. A spring's
/// side a is the patch's side a unless that one is static. The force `f = ½ k δ A` of a
/// contact surfel ([`forces`]) changes by `½ k A` per metre of approach `δ` and by
/// `c A` per m/s of approach speed (the dashpot acts on each side's half). Its motion is
/// read from, and its force spread to, the phyxels that take its force in
/// [`distribute`], with the same normalised weights and without the couple (the change
/// is along the normal, nearly through both sides' weighted centroids).
///
/// `grids[k]`: the phyxel grid of object k, built this step for its pairs.
pub fn springs(
    patches: &[ContactPatch],
    objects: &[Object],
    grids: &[Option<Grid>],
    dt: f32,
    out: &mut ContactSprings,
    near: &mut Vec<(usize, f32)>,
    knn: &mut Vec<(usize, f32)>,
) {
    for patch in patches {
        let (oa, ob) = (&objects[patch.a], &objects[patch.b]);
        if !springs_apply(oa, ob) {
            continue;
        }
        let p = contact_params(oa, ob, dt);
        // Side a pushes along −n (Φ's normal points from a into b).
        let (first, second, flip) = if oa.is_static() {
            (patch.b, patch.a, -1.0f32)
        } else {
            (patch.a, patch.b, 1.0)
        };
        for c in &patch.surfels {
            let normal = -flip * c.normal;
            let mut side = |k: usize| -> Option<SpringSide> {
                let o = &objects[k];
                if o.is_static() {
                    return None;
                }
                let grid = grids[k].as_ref()?;
                let h = DISTRIBUTION_SUPPORT * o.max_influence;
                super::distribute::spread_weights::<false>(c.pos, grid, h, near, knn);
                let total: f32 = near.iter().map(|e| e.1).sum();
                if total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                    return None;
                }
                let start = out.weights.len() as u32;
                out.weights
                    .extend(near.iter().map(|&(j, w)| (j as u32, w / total)));
                Some(SpringSide {
                    object: k as u32,
                    start,
                    end: out.weights.len() as u32,
                })
            };
            let Some(a) = side(first) else {
                continue;
            };
            let b = side(second);
            if b.is_none() && !objects[second].is_static() {
                // No phyxels to spread to (no grid): no spring rather than a wrong one.
                out.weights.truncate(a.start as usize);
                continue;
            }
            out.springs.push(ContactSpring {
                normal,
                stiffness: 0.5 * p.stiffness * c.area,
                damping: p.damping * c.area,
                force: (flip * c.force).dot(normal).max(0.0),
                applied: true,
                a,
                b,
            });
        }
    }
}

/// Appends to `out` the springs of `last` whose pair has no patch this step (its
/// surfaces have just parted), as springs not applied: each keeps its weights and
/// normal, and its force becomes the linearised force at the current velocities,
/// `force − k dt · approach`, negative by the gap the side opened. Such a spring pushes
/// only once the step closes that gap, so a resting body that lifts off for a step is
/// caught where the surfaces meet, instead of falling into an overlap whose spring
/// energy its fall did not supply (a stiff box at dt = 1/120 s bounced 0.6 mm on a plane
/// every three steps). A spring whose gap has reached `max_gap` (m) is dropped.
pub fn keep_parted(
    last: &ContactSprings,
    patches: &[ContactPatch],
    objects: &[Object],
    dt: f32,
    max_gap: f32,
    out: &mut ContactSprings,
) {
    // A patch of the pair (against a static side: any patch of side a).
    let touching = |a: u32, b: Option<SpringSide>| {
        let involves = |p: &ContactPatch, k: u32| p.a == k as usize || p.b == k as usize;
        patches
            .iter()
            .any(|p| involves(p, a) && b.is_none_or(|b| involves(p, b.object)))
    };
    let mean = |s: &SpringSide| last.mean(s, |j| objects[s.object as usize].phyxels.vel.get(j));
    for sp in &last.springs {
        if touching(sp.a.object, sp.b) {
            continue;
        }
        let rel = mean(&sp.a) - sp.b.as_ref().map_or(Vec3::ZERO, mean);
        let force = sp.force.min(0.0) - sp.stiffness * dt * sp.normal.dot(rel);
        if force.partial_cmp(&(-sp.stiffness * max_gap)) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        let mut copy = |s: &SpringSide| {
            let start = out.weights.len() as u32;
            out.weights.extend_from_slice(last.weights_of(s));
            SpringSide {
                object: s.object,
                start,
                end: out.weights.len() as u32,
            }
        };
        let a = copy(&sp.a);
        let b = sp.b.as_ref().map(&mut copy);
        out.springs.push(ContactSpring {
            force,
            applied: false,
            a,
            b,
            ..*sp
        });
    }
}
