//! The contact springs that implicit bodies take into their solve: each contact
//! surfel's penalty force (paper eqs. 3–7) differentiated along the contact normal,
//! built from the contact patches after the forces phase and read by the next step's
//! solve ([`super::solve`]).

use crate::body::object::Object;
use crate::contact::ContactPatch;
use crate::contact::distribute::{Couple, moments, spread_weights};
use crate::contact::params::contact_params;
use crate::contact::stick::{StickKey, StickMemory};
use crate::spatial::grid::Grid;
use glam::{Mat3, Vec3};

/// One side of a [`ContactSpring`]: an object and the phyxels the contact surfel's
/// motion is read from and its force spread to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringSide {
    /// The object (index into `World::objects`).
    pub object: u32,
    /// Its phyxels, their normalised weights and offsets from the weights' centroid:
    /// `ContactSprings::weights[start..end]`, `offsets[start..end]`.
    pub start: u32,
    pub end: u32,
    /// The couple's map `f ↦ ω` (1/m): phyxel `j` takes `ŵⱼ (f + ω × rⱼ)`, which acts
    /// at the surfel (zero: at the weights' centroid).
    pub couple: Mat3,
}

/// The linearised penalty spring and dashpot of one contact surfel, with its friction
/// (Keiser et al. 2004, eqs. 3–7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactSpring {
    /// Unit normal along which the force on side a pushes it out of side b.
    pub normal: Vec3,
    /// dF/dδ, `½ k A` (N/m): the force on a grows by this per metre of approach.
    pub stiffness: f32,
    /// dF/dv, `c A` (N·s/m), per m/s of approach speed.
    pub damping: f32,
    /// The normal force on a at the start of the step (N): the spring adds
    /// `max(0, force + change)`. Negative for a gap (a spring of a pair that has just
    /// parted): its side is `−force / stiffness` metres away.
    pub force: f32,
    /// Coulomb coefficient μ of the pair (0: frictionless).
    pub friction: f32,
    /// The friction anchor's elongation at the step's start (m): side a's tangential
    /// displacement against b since the contact last stuck, in the contact's tangent
    /// plane ([`crate::contact::stick`]; its tangential stiffness is `stiffness`).
    pub stick: Vec3,
    /// The contact across steps (its [`StickMemory`] entry; `None`: a resampled
    /// surfel, which keeps none).
    pub key: Option<StickKey>,
    pub a: SpringSide,
    /// `None` when the other side is a static object (it does not move).
    pub b: Option<SpringSide>,
    /// The object of side b, static or not (index into `World::objects`).
    pub b_object: u32,
    /// Velocity of side b at the build when its motion is prescribed (a tool, m/s): the
    /// solve takes it as given. `None` for a static side (at rest) and a side that
    /// moves by its own dynamics.
    pub given: Option<Vec3>,
}

/// The contact springs of the last step, over the whole world.
#[derive(Clone, Debug, Default)]
pub struct ContactSprings {
    pub springs: Vec<ContactSpring>,
    /// (phyxel, normalised weight) lists of the springs' sides.
    pub weights: Vec<(u32, f32)>,
    /// Each weight's phyxel offset from its side's weighted centroid (m), at the step's
    /// start.
    pub offsets: Vec<Vec3>,
}

impl ContactSprings {
    pub fn clear(&mut self) {
        self.springs.clear();
        self.weights.clear();
        self.offsets.clear();
    }

    /// A side's (phyxel, normalised weight) list and the phyxels' offsets.
    pub fn weights_of(&self, side: &SpringSide) -> (&[(u32, f32)], &[Vec3]) {
        let r = side.start as usize..side.end as usize;
        (&self.weights[r.clone()], &self.offsets[r])
    }

    /// Velocity of a side's contact surfel from its phyxels' `velocity(phyxel)`: the
    /// weighted mean plus the weights' fitted rotation at the surfel (the transpose of
    /// [`ContactSprings::spread`]).
    pub fn velocity(&self, side: &SpringSide, velocity: impl Fn(usize) -> Vec3) -> Vec3 {
        let (weights, offsets) = self.weights_of(side);
        let (mut mean, mut moment) = (Vec3::ZERO, Vec3::ZERO);
        for (&(j, w), &r) in weights.iter().zip(offsets) {
            let v = velocity(j as usize) * w;
            mean += v;
            moment += r.cross(v);
        }
        mean + side.couple.transpose() * moment
    }

    /// Spreads `f` over a side's phyxels: `add(phyxel, ŵⱼ (f + ω × rⱼ))`.
    pub fn spread(&self, side: &SpringSide, f: Vec3, mut add: impl FnMut(usize, Vec3)) {
        let (weights, offsets) = self.weights_of(side);
        let omega = side.couple * f;
        for (&(j, w), &r) in weights.iter().zip(offsets) {
            add(j as usize, (f + omega.cross(r)) * w);
        }
    }
}

/// Appends to `out` the springs of the patches whose pair joins a solve ([`Object::contact_in_solve`]) (the
/// pipeline spreads none of their force: the solve applies it). A spring's side a is
/// the patch's side a unless that one's motion is prescribed (static, a tool). The force `f = ½ k δ A` of a contact
/// surfel ([`crate::contact::forces`]) changes by `½ k A` per metre of approach `δ` and by `c A` per
/// m/s of approach speed (the dashpot acts on each side's half); its friction is the
/// pair's μ. Its motion is read from, and its force spread to, the phyxels that take
/// its force in [`crate::contact::distribute()`], with the same normalised weights and couple.
///
/// `grids[k]`: the phyxel grid of object k, built this step for its pairs.
#[allow(clippy::too_many_arguments)]
pub fn build(
    patches: &[ContactPatch],
    objects: &[Object],
    grids: &[Option<Grid>],
    memory: &StickMemory,
    dt: f32,
    out: &mut ContactSprings,
    near: &mut Vec<(usize, f32)>,
    knn: &mut Vec<(usize, f32)>,
) {
    for patch in patches {
        let (oa, ob_patch) = (&objects[patch.a], &objects[patch.b]);
        if !oa.contact_in_solve(ob_patch) {
            continue;
        }
        let p = contact_params(oa, ob_patch, dt);
        // Side a pushes along −n (Φ's normal points from a into b).
        let (first, second, flip) = if oa.is_prescribed() {
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
                let h = o.distribution_radius();
                let widened = spread_weights::<false>(c.pos, grid, h, near, knn);
                // The couple of `distribute`, from the weights' moments about the surfel.
                let (total, m1, m2) = moments(near, &o.phyxels, c.pos);
                if total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                    return None;
                }
                let (centroid, map) = Couple::map(c.pos, total, m1, m2);
                let couple = if widened { Mat3::ZERO } else { map.as_mat3() };
                let start = out.weights.len() as u32;
                for &(j, w) in near.iter() {
                    out.weights.push((j as u32, w / total));
                    out.offsets.push(o.phyxels.pos.get(j) - centroid);
                }
                Some(SpringSide {
                    object: k as u32,
                    start,
                    end: out.weights.len() as u32,
                    couple,
                })
            };
            let Some(a) = side(first) else {
                continue;
            };
            let b = side(second);
            if b.is_none() && !objects[second].is_static() {
                // No phyxels to spread to (no grid): no spring rather than a wrong one.
                out.weights.truncate(a.start as usize);
                out.offsets.truncate(a.start as usize);
                continue;
            }
            let ob = &objects[second];
            let given = b
                .as_ref()
                .filter(|_| ob.is_prescribed())
                .map(|b| out.velocity(b, |j| ob.phyxels.vel.get(j)));
            let key = StickKey::of(oa.serial(), ob_patch.serial(), patch.b, c);
            // The spring turns with the contact: its part along the new normal is gone.
            let stick = match key.filter(|_| p.friction > 0.0) {
                Some(key) => {
                    let xi = memory.get(&key);
                    xi - normal * normal.dot(xi)
                }
                None => Vec3::ZERO,
            };
            out.springs.push(ContactSpring {
                normal,
                stiffness: 0.5 * p.stiffness * c.area,
                damping: p.damping * c.area,
                force: (flip * c.force).dot(normal).max(0.0),
                friction: p.friction,
                stick,
                key,
                a,
                b,
                b_object: second as u32,
                given,
            });
        }
    }
}

/// Appends to `out` the springs of `last` whose pair has no patch this step (its
/// surfaces have just parted), as gaps: each keeps its weights and
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
    let touching = |a: u32, b: u32| {
        let involves = |p: &ContactPatch, k: u32| p.a == k as usize || p.b == k as usize;
        patches.iter().any(|p| involves(p, a) && involves(p, b))
    };
    let mean = |s: &SpringSide| last.velocity(s, |j| objects[s.object as usize].phyxels.vel.get(j));
    for sp in &last.springs {
        if touching(sp.a.object, sp.b_object) {
            continue;
        }
        let rel = mean(&sp.a) - sp.b.as_ref().map_or(Vec3::ZERO, mean);
        let force = sp.force.min(0.0) - sp.stiffness * dt * sp.normal.dot(rel);
        if force.partial_cmp(&(-sp.stiffness * max_gap)) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        let mut copy = |s: &SpringSide| {
            let start = out.weights.len() as u32;
            let (weights, offsets) = last.weights_of(s);
            out.weights.extend_from_slice(weights);
            out.offsets.extend_from_slice(offsets);
            SpringSide {
                start,
                end: out.weights.len() as u32,
                ..*s
            }
        };
        let a = copy(&sp.a);
        let b = sp.b.as_ref().map(&mut copy);
        out.springs.push(ContactSpring { force, a, b, ..*sp });
    }
}
