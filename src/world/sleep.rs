//! Sleeping: a group of bodies in contact that has stayed still stops being stepped,
//! advected and tested for contact among itself and with static objects, until
//! something moving touches it ("model only what a scene needs").
//!
//! A body is still while every phyxel stays within [`SLEEP_SPEED`] times its
//! [`still_time`] of where it was when its still time began, checked [`SLEEP_SAMPLES`]
//! times per still time (a smaller vibration, or a slower creep, counts as still). A
//! group (bodies joined by overlapping boxes, static objects left out) falls asleep once
//! every body in it has been still for its [`still_time`], none is a tool, and no load
//! is still ramping. Its velocities are set to zero and its state is kept as it is.
//! The broad phase wakes a sleeping body whose box overlaps an awake moving one (a
//! tool, a body falling onto it), and with it every sleeping body it touches.
//! Everything is decided in object order from the step's state, so it does not depend
//! on the thread count. Scene key `sleep` (default on), [`crate::World::sleep`].

use crate::body::object::Object;
use crate::spatial::broad_phase::Pair;

/// Mean speed (m/s) below which a body counts as at rest: each phyxel stays within
/// this speed times the body's [`still_time`] of where its still time began (0.6 mm for
/// the `pile` box). A speed, not a length, so that lengths and times scaled alike (t ∝ L)
/// give the same verdict, and a stiff body translating at 1 m/s is never still.
pub const SLEEP_SPEED: f32 = 1.0e-3;

/// Displacement checks per [`still_time`]: a body's phyxels are compared with where
/// its still time began this often, not every step (a check costs as much as a tenth of
/// a small body's step).
pub const SLEEP_SAMPLES: f32 = 16.0;

/// How long a body must stay still before it sleeps, in crossings of its own pressure
/// wave (its size over its P-wave speed: 0.6 s for the `pile` box, 0.1 s for the stiff
/// cantilever). A time of the body's own keeps the test the same at any length scale.
pub const SLEEP_CROSSINGS: f32 = 50.0;

/// Seconds `o` must stay still before it sleeps ([`SLEEP_CROSSINGS`]; infinite for a
/// material without a wave speed).
pub fn still_time(o: &Object) -> f32 {
    let size = o.phyxel_spacing * (o.phyxels.len() as f32).cbrt();
    let t = SLEEP_CROSSINGS * size / o.material.wave_speed();
    if t.is_finite() && t > 0.0 {
        t
    } else {
        f32::INFINITY
    }
}

/// Wakes every sleeping body in a pair with a body that is neither static nor asleep,
/// and returns whether any woke (the pairs must then be found again: the woken body's
/// pairs with other sleeping bodies were skipped).
pub(super) fn wake_touched(objects: &mut [Object], pairs: &[Pair]) -> bool {
    let mut woke = false;
    for p in pairs {
        let (a, b) = (!objects[p.a].is_frozen(), !objects[p.b].is_frozen());
        for (k, other) in [(p.a, b), (p.b, a)] {
            if other && objects[k].is_asleep() {
                objects[k].wake();
                woke = true;
            }
        }
    }
    woke
}

/// After a step of `dt` ending at `time` (s): advances each awake body's still time
/// (restarted, from the current positions, when a phyxel has moved too far),
/// then puts to sleep the groups, joined by this step's `pairs`, whose bodies have all
/// been still for their [`still_time`].
pub(super) fn settle(
    objects: &mut [Object],
    pairs: &[Pair],
    dt: f32,
    time: f64,
    scratch: &mut SleepScratch,
) {
    let SleepScratch { group, ready } = scratch;
    for o in objects.iter_mut() {
        if o.is_frozen() {
            continue;
        }
        let ramping = o.load != glam::Vec3::ZERO && time < o.load_ramp as f64;
        let window = still_time(o);
        let reach = SLEEP_SPEED * window;
        let (p, carry) = (&o.phyxels.pos, &o.phyxels.pos_carry);
        let n = o.phyxels.len();
        let anchor = &mut o.still_from;
        let here = |j: usize| (p.get(j), carry.get(j));
        if o.dynamics.is_prescribed() || ramping || anchor.len() != n {
            anchor.clear();
            anchor.extend((0..n).map(here));
            (o.still_for, o.still_checked) = (0.0, 0.0);
            continue;
        }
        o.still_for += dt;
        if o.still_for - o.still_checked < window / SLEEP_SAMPLES {
            continue;
        }
        // (Far from the origin the motion of a step may sit in the carry alone.)
        let moved = (0..n).any(|j| {
            let ((x, c), (x0, c0)) = (here(j), anchor[j]);
            ((x - x0) + (c - c0)).length_squared() > reach * reach
        });
        if moved {
            for (j, a) in anchor.iter_mut().enumerate() {
                *a = here(j);
            }
            (o.still_for, o.still_checked) = (0.0, 0.0);
        } else {
            o.still_checked = o.still_for;
        }
    }
    // Union–find over the pairs of moving objects (static objects join nothing).
    group.clear();
    group.extend(0..objects.len());
    fn root(group: &mut [usize], mut k: usize) -> usize {
        while group[k] != k {
            group[k] = group[group[k]];
            k = group[k];
        }
        k
    }
    for p in pairs {
        if objects[p.a].is_static() || objects[p.b].is_static() {
            continue;
        }
        let (ra, rb) = (root(group, p.a), root(group, p.b));
        if ra != rb {
            group[ra.max(rb)] = ra.min(rb);
        }
    }
    // A group is ready when each body in it is asleep or has been still long enough
    // (the verdict is kept at the group's root).
    ready.clear();
    ready.resize(objects.len(), true);
    for (k, o) in objects.iter().enumerate() {
        if !o.is_static() {
            let r = root(group, k);
            ready[r] &= o.is_asleep() || o.still_checked >= still_time(o);
        }
    }
    for (k, o) in objects.iter_mut().enumerate() {
        if !o.is_frozen() && ready[root(group, k)] {
            o.fall_asleep();
        }
    }
}

/// Buffers of [`settle`] (no allocation in the steady step).
#[derive(Default)]
pub(super) struct SleepScratch {
    group: Vec<usize>,
    ready: Vec<bool>,
}
