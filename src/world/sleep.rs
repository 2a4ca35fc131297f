//! Sleeping: a body that has stayed still, among neighbours that have too, stops being
//! stepped, advected and tested for contact with static objects and other sleeping
//! bodies, until something moving touches it ("model only what a scene needs").
//!
//! A body is still while every phyxel stays within [`SLEEP_SPEED`] times its
//! [`still_time`] of where it was when its still time began, checked [`SLEEP_SAMPLES`]
//! times per still time (a smaller vibration, or a slower creep, counts as still). It is
//! settled once it has been still for its [`still_time`] (a sleeping body is settled; a
//! tool or a body whose load is ramping never is). A settled body falls asleep when
//! every moving body whose box overlaps its own is settled too: its velocities are set
//! to zero and its state is kept as it is. An awake body then touches it as it would a
//! static object. So a heap sleeps around a ball still rolling on it, except for the
//! ball's neighbours.
//! The broad phase wakes a sleeping body whose box overlaps an awake body that is not
//! settled (a tool, a body falling onto it, a neighbour that started to move); it wakes
//! as settled, from where it is, so the bodies it touches wake only once it moves.
//! Everything is decided in object order from the step's state, so it does not depend
//! on the thread count. Scene key `sleep` (default on), [`crate::World::sleep`].

use crate::body::object::Object;
use crate::solver::ContactSprings;
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

/// Whether `o` is settled: asleep, or awake and still for its [`still_time`].
fn settled(o: &Object) -> bool {
    o.is_asleep() || (!o.is_static() && o.still_checked >= still_time(o))
}

/// Wakes every sleeping body in a pair with an awake moving body that is not settled,
/// as settled from where it is, and returns whether any woke (the pairs must then be
/// found again: the woken body's pairs with other sleeping bodies were skipped).
pub(super) fn wake_touched(objects: &mut [Object], pairs: &[Pair]) -> bool {
    let mut woke = false;
    for p in pairs {
        for (k, other) in [(p.a, p.b), (p.b, p.a)] {
            let o = &objects[other];
            let moving = !o.is_frozen() && !settled(o);
            if moving && objects[k].is_asleep() {
                let still = still_time(&objects[k]);
                objects[k].wake_still(still);
                woke = true;
            }
        }
    }
    woke
}

/// After a step of `dt` ending at `time` (s): advances each awake body's still time
/// (restarted, from the current positions, when a phyxel has moved too far), then puts
/// to sleep the settled bodies whose overlapping moving bodies (this step's `pairs`)
/// are all settled, and fixes their side of the contact `springs` the next solve reads.
pub(super) fn settle(
    objects: &mut [Object],
    pairs: &[Pair],
    springs: &mut ContactSprings,
    dt: f32,
    time: f64,
    scratch: &mut SleepScratch,
) {
    let SleepScratch { still, ready } = scratch;
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
    // A settled body sleeps when no moving body whose box overlaps its own is unsettled
    // (the verdicts are taken before any body falls asleep).
    still.clear();
    still.extend(objects.iter().map(settled));
    ready.clone_from(still);
    for p in pairs {
        let (sa, sb) = (objects[p.a].is_static(), objects[p.b].is_static());
        if !sa && !sb {
            ready[p.a] &= still[p.b];
            ready[p.b] &= still[p.a];
        }
    }
    let mut fell = false;
    for (k, o) in objects.iter_mut().enumerate() {
        if !o.is_frozen() && ready[k] {
            o.fall_asleep();
            fell = true;
        }
    }
    if fell {
        crate::solver::springs::fix_sleeping(springs, objects);
    }
}

/// Buffers of [`settle`] (no allocation in the steady step).
#[derive(Default)]
pub(super) struct SleepScratch {
    /// Per object, settled; and settled with every overlapping moving body settled.
    still: Vec<bool>,
    ready: Vec<bool>,
}
