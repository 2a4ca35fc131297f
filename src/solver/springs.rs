//! The contact springs that implicit bodies take into their solve: each contact
//! surfel's penalty force (paper eqs. 3–7) differentiated along the contact normal,
//! built from the contact patches after the forces phase and read by the next step's
//! solve ([`super::solve`]).

use crate::body::object::Object;
use crate::contact::detect::PairDetection;
use crate::contact::distribute::{Couple, moments, spread_weights};
use crate::contact::params::contact_params;
use crate::contact::stick::{StickKey, StickMemory};
use crate::contact::{ContactPatch, carrier_area};
use crate::spatial::grid::Grid;
use glam::{Mat3, Vec3};

/// One side of a [`ContactSpring`]: an object and the phyxels the contact surfel's
/// motion is read from and its force spread to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringSide {
    /// The object (index into `World::objects`).
    pub object: u32,
    /// Its phyxels and their normalised weights: `ContactSprings::weights[start..end]`.
    pub start: u32,
    pub end: u32,
    /// The couple's map `f ↦ ω` (1/m): phyxel `j` takes `ŵⱼ (f + ω × rⱼ)`, `rⱼ` its
    /// offset from the weights' centroid, which acts at the surfel (zero: at the
    /// centroid).
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
///
/// A side's offsets `rⱼ` are its phyxels' positions from their weighted centroid at
/// the time of reading: the positions at the build for the springs built from this
/// step's patches, and a rigid fit about where the phyxels are now for a spring kept
/// from the step before ([`keep_parted`]) or a tool that has moved since.
#[derive(Clone, Debug, Default)]
pub struct ContactSprings {
    pub springs: Vec<ContactSpring>,
    /// (phyxel, normalised weight) lists of the springs' sides.
    pub weights: Vec<(u32, f32)>,
}

impl ContactSprings {
    pub fn clear(&mut self) {
        self.springs.clear();
        self.weights.clear();
    }

    /// A side's (phyxel, normalised weight) list.
    pub fn weights_of(&self, side: &SpringSide) -> &[(u32, f32)] {
        &self.weights[side.start as usize..side.end as usize]
    }

    /// The offsets `rⱼ = xⱼ − Σₖ ŵₖ xₖ` of a side's phyxels at positions `pos(phyxel)`,
    /// in the order of its weights, computed about the first phyxel (a local origin:
    /// no cancellation against the positions' magnitude).
    pub fn offsets<'a>(
        &'a self,
        side: &SpringSide,
        pos: impl Fn(usize) -> Vec3 + 'a,
    ) -> impl Iterator<Item = Vec3> + 'a {
        let weights = self.weights_of(side);
        let origin = weights
            .first()
            .map_or(Vec3::ZERO, |&(j, _)| pos(j as usize));
        let (mut sum, mut total) = (Vec3::ZERO, 0.0f32);
        for &(j, w) in weights {
            sum += (pos(j as usize) - origin) * w;
            total += w;
        }
        let centroid = origin + sum / total;
        weights
            .iter()
            .map(move |&(j, _)| pos(j as usize) - centroid)
    }

    /// Velocity of a side's contact surfel from its phyxels' `velocity(phyxel)` at
    /// positions `pos(phyxel)`: the weighted mean plus the weights' fitted rotation at
    /// the surfel (the transpose of [`ContactSprings::spread`]).
    pub fn velocity(
        &self,
        side: &SpringSide,
        pos: impl Fn(usize) -> Vec3,
        velocity: impl Fn(usize) -> Vec3,
    ) -> Vec3 {
        let (mut mean, mut moment) = (Vec3::ZERO, Vec3::ZERO);
        for (&(j, w), r) in self.weights_of(side).iter().zip(self.offsets(side, pos)) {
            let v = velocity(j as usize) * w;
            mean += v;
            moment += r.cross(v);
        }
        mean + side.couple.transpose() * moment
    }

    /// Spreads `f` over a side's phyxels at positions `pos(phyxel)`:
    /// `add(phyxel, ŵⱼ (f + ω × rⱼ))`.
    pub fn spread(
        &self,
        side: &SpringSide,
        f: Vec3,
        pos: impl Fn(usize) -> Vec3,
        mut add: impl FnMut(usize, Vec3),
    ) {
        let omega = side.couple * f;
        for (&(j, w), r) in self.weights_of(side).iter().zip(self.offsets(side, pos)) {
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
        let (first, second, flip) = if oa.is_prescribed() || oa.is_asleep() {
            (patch.b, patch.a, -1.0f32)
        } else {
            (patch.a, patch.b, 1.0)
        };
        for c in &patch.surfels {
            let normal = -flip * c.normal;
            let Some((a, b, given)) = sides(objects, grids, first, second, c.pos, near, knn, out)
            else {
                continue;
            };
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

/// The sides of a spring at `at` between objects `first` (side a, which moves) and
/// `second`, their weights appended to `out`, and side b's velocity when its motion is
/// given (a tool); `None` (nothing appended) when a moving side has no phyxels to
/// spread to (no grid, or no weight), so that no spring is made rather than a wrong one.
#[allow(clippy::too_many_arguments)]
fn sides(
    objects: &[Object],
    grids: &[Option<Grid>],
    first: usize,
    second: usize,
    at: Vec3,
    near: &mut Vec<(usize, f32)>,
    knn: &mut Vec<(usize, f32)>,
    out: &mut ContactSprings,
) -> Option<(SpringSide, Option<SpringSide>, Option<Vec3>)> {
    let a = side(objects, grids, first, at, near, knn, out)?;
    let b = side(objects, grids, second, at, near, knn, out);
    let ob = &objects[second];
    if b.is_none() && !ob.is_frozen() {
        out.weights.truncate(a.start as usize);
        return None;
    }
    let given = b
        .as_ref()
        .filter(|_| ob.is_prescribed())
        .map(|b| out.velocity(b, |j| ob.phyxels.pos.get(j), |j| ob.phyxels.vel.get(j)));
    Some((a, b, given))
}

/// One side of a spring at `at` on object `k`: the phyxels that take a force there in
/// `contact::distribute`, with its normalised weights and couple, appended to `out`;
/// `None` for a frozen object (static or asleep: it does not move) and when there are
/// none.
fn side(
    objects: &[Object],
    grids: &[Option<Grid>],
    k: usize,
    at: Vec3,
    near: &mut Vec<(usize, f32)>,
    knn: &mut Vec<(usize, f32)>,
    out: &mut ContactSprings,
) -> Option<SpringSide> {
    let o = &objects[k];
    if o.is_frozen() {
        return None;
    }
    let grid = grids[k].as_ref()?;
    let h = o.distribution_radius();
    let widened = spread_weights::<false>(at, grid, h, near, knn);
    // The couple of `distribute`, from the weights' moments about the surfel.
    let (total, m1, m2) = moments(near, &o.phyxels, at);
    if total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let (_, map) = Couple::map(at, total, m1, m2);
    let couple = if widened { Mat3::ZERO } else { map.as_mat3() };
    let start = out.weights.len() as u32;
    for &(j, w) in near.iter() {
        out.weights.push((j as u32, w / total));
    }
    Some(SpringSide {
        object: k as u32,
        start,
        end: out.weights.len() as u32,
        couple,
    })
}

/// Speed factor of [`margin`]: a step's travel at the body's fastest phyxel's speed, and
/// half again for a speed that grows within the step.
pub const MARGIN_SPEED_FACTOR: f32 = 1.5;

/// How far outside another object an implicit body's surfels are found as gaps (m):
/// [`MARGIN_SPEED_FACTOR`] times a step's travel at its fastest phyxel's speed, plus
/// gravity's `|g| dt²`, at most two phyxel spacings (beyond the surface's kernels no
/// gap is found anyway). 0 for a body that is not implicit, is asleep or is prescribed:
/// only a solve can take a contact before it closes ([`speculate`]).
pub fn margin(o: &Object, dt: f32, gravity: Vec3) -> f32 {
    if !o.is_implicit() || o.is_frozen() || o.is_prescribed() {
        return 0.0;
    }
    let v = &o.phyxels.vel;
    let speed2 = (0..o.phyxels.len()).fold(0.0f32, |m, j| m.max(v.get(j).length_squared()));
    let reach = MARGIN_SPEED_FACTOR * dt * speed2.sqrt() + gravity.length() * dt * dt;
    reach.min(2.0 * o.phyxel_spacing)
}

/// Appends to `out` a gap spring for each surfel found outside the other object of a
/// pair in a solve within the pair's margin ([`PairDetection::a_near_b`], `b_near_a`),
/// for pairs that do not touch yet (no colliding surfel) and that none of the first
/// `parted` springs of `out` join (those [`keep_parted`] kept): the spring pushes only
/// once the step closes its gap (its force is `−k gap` at the step's start, with no
/// dashpot until the contact is made), so that the solve stops an approach where the
/// surfaces meet instead of finding it one step late at a whole step's overlap, whose
/// spring energy the approach did not supply. It acts midway between the surfel and its
/// projection, along the other surface's normal there; its area is the surfel's own
/// ([`carrier_area`]) times its object's share of the pair's density
/// (`A_other / (A_own + A_other)`, each object's carrier spacing squared standing for
/// the other's area), as a contact surfel's would be.
#[allow(clippy::too_many_arguments)]
pub fn speculate(
    detections: &[PairDetection],
    objects: &[Object],
    grids: &[Option<Grid>],
    dt: f32,
    parted: usize,
    out: &mut ContactSprings,
    near: &mut Vec<(usize, f32)>,
    knn: &mut Vec<(usize, f32)>,
) {
    for d in detections {
        // None for a touching pair: a contact surfel's area is its object's share of
        // the contact surfels about it, so at a rim whose other side carries the whole
        // area a gap spring would add to it, and the rim's force would fall as the
        // gap's surfel entered (a negative stiffness: the rolling capsule on a coarse
        // plane gained 0.4 mJ); and its friction would have no anchor.
        let touching = !d.a_in_b.is_empty() || !d.b_in_a.is_empty();
        if touching || (d.a_near_b.is_empty() && d.b_near_a.is_empty()) {
            continue;
        }
        let (oa, ob) = (&objects[d.a], &objects[d.b]);
        if !oa.contact_in_solve(ob) {
            continue;
        }
        let pair = |s: &ContactSpring| {
            let (x, y) = (s.a.object as usize, s.b_object as usize);
            (x, y) == (d.a, d.b) || (x, y) == (d.b, d.a)
        };
        if out.springs[..parted].iter().any(pair) {
            continue;
        }
        let p = contact_params(oa, ob, dt);
        for (own, other, gaps) in [(d.a, d.b, &d.a_near_b), (d.b, d.a, &d.b_near_a)] {
            let (o, other_object) = (&objects[own], &objects[other]);
            let other_area = other_object.carrier_spacing * other_object.carrier_spacing;
            for c in gaps {
                let s = c.surfel as usize;
                let x = o.surfels.pos.get(s);
                let at = 0.5 * (x + c.projection);
                // Side a moves: the surfel's object pushed out along the other's normal.
                let (first, second, normal) = if o.is_prescribed() || o.is_asleep() {
                    (other, own, -c.normal)
                } else {
                    (own, other, c.normal)
                };
                let Some((a, b, given)) = sides(objects, grids, first, second, at, near, knn, out)
                else {
                    continue;
                };
                let own_area = carrier_area(
                    o.surfels.radius[s],
                    o.surfels.rest_normal.get(s),
                    o.carrier_spacing,
                );
                let area = own_area * other_area / (own_area + other_area);
                let stiffness = 0.5 * p.stiffness * area;
                out.springs.push(ContactSpring {
                    normal,
                    stiffness,
                    damping: 0.0,
                    force: stiffness * c.depth.min(0.0),
                    friction: p.friction,
                    stick: Vec3::ZERO,
                    key: None,
                    a,
                    b,
                    b_object: second as u32,
                    given,
                });
            }
        }
    }
}

/// Fixes the sides of `springs` whose bodies have fallen asleep since they were built:
/// a sleeping side b is held where it is (as a static one), and a spring whose side a
/// sleeps while side b moves by its own dynamics is turned round (side b becomes side a,
/// the normal and the friction anchor's elongation reversed; it keeps no friction
/// memory, whose key names the other orientation).
pub fn fix_sleeping(springs: &mut ContactSprings, objects: &[Object]) {
    let asleep = |s: &SpringSide| objects[s.object as usize].is_asleep();
    for sp in &mut springs.springs {
        if sp.b.as_ref().is_some_and(asleep) {
            (sp.b, sp.given) = (None, None);
        }
        if asleep(&sp.a)
            && let Some(b) = sp.b.filter(|b| !objects[b.object as usize].is_prescribed())
        {
            *sp = ContactSpring {
                normal: -sp.normal,
                stick: -sp.stick,
                key: None,
                b_object: sp.a.object,
                a: b,
                b: None,
                given: None,
                ..*sp
            };
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
    let mean = |s: &SpringSide| {
        let p = &objects[s.object as usize].phyxels;
        last.velocity(s, |j| p.pos.get(j), |j| p.vel.get(j))
    };
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
            out.weights.extend_from_slice(last.weights_of(s));
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
