//! Sleeping: a body that has stayed still, among neighbours that have too, stops being
//! stepped, advected and tested for contact with static objects and other sleeping
//! bodies, until something moving touches it ("model only what a scene needs").
//!
//! A body is still while every phyxel's mean position over each interval of
//! 1/[`SLEEP_SAMPLES`] of its [`still_time`] stays within [`SLEEP_SPEED`] times the
//! still time of its mean over the first interval (a slower creep counts as still), and
//! no phyxel strays farther than [`SLEEP_SHAKE`] of the spacing (a vibration in place
//! within it, such as a contact chattering at an edge, averages out). It is
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

/// The largest vibration in place that counts as still, as a fraction of the body's
/// phyxel spacing: no phyxel may stray farther than this from where the still time
/// began (`pile-20`'s blocks chattering on an edge against a wall move 0.5 mm, 4% of
/// their spacing, every other step).
pub const SLEEP_SHAKE: f32 = 0.1;

/// Check intervals per [`still_time`]: each phyxel's position is averaged over an
/// interval and compared with its average over the first. An interval of a quarter of
/// the still time (12 steps of `pile-20` at 1/120 s) averages a vibration of a few
/// steps' period down to a fraction of its amplitude (a 6-step cycle to zero, a 5-step
/// one to a sixth).
pub const SLEEP_SAMPLES: f32 = 4.0;

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
    o.is_asleep() || (!o.is_static() && o.still.checked >= still_time(o))
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
        let here = |j: usize| (p.get(j), carry.get(j));
        let test = &mut o.still;
        if o.dynamics.is_prescribed() || ramping || test.from.len() != n {
            test.restart((0..n).map(here), 0.0);
            continue;
        }
        // (Far from the origin the motion of a step may sit in the carry alone.)
        let shake = SLEEP_SHAKE * o.phyxel_spacing;
        let mut shaking = false;
        for (j, (sum, &(x0, c0))) in test.sum.iter_mut().zip(&test.from).enumerate() {
            let (x, c) = here(j);
            let d = (x - x0) + (c - c0);
            *sum += d;
            shaking |= d.length_squared() > shake * shake;
        }
        if shaking {
            test.restart((0..n).map(here), 0.0);
            continue;
        }
        test.steps += 1;
        test.time += dt;
        if test.time - test.checked < window / SLEEP_SAMPLES {
            continue;
        }
        // The first interval's mean is what the others are compared with: the still
        // clock is checked from the second on.
        let steps = test.steps as f32;
        if test.base.is_empty() {
            test.base.extend(test.sum.iter().map(|&d| d / steps));
        } else {
            let far = |(&d, &b): (&glam::Vec3, &glam::Vec3)| {
                (d / steps - b).length_squared() > reach * reach
            };
            if test.sum.iter().zip(&test.base).any(far) {
                test.restart((0..n).map(here), 0.0);
                continue;
            }
            test.checked = test.time;
        }
        test.sum.fill(glam::Vec3::ZERO);
        test.steps = 0;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{BuildOptions, Scene};
    use glam::Vec3;

    /// A soft box (0.1 m, spacing 0.025 m) alone, with no gravity: its phyxels are moved
    /// by hand.
    fn body() -> Object {
        let scene = Scene::parse(
            r#"
name = "still"
gravity = [0.0, 0.0, 0.0]
[[objects]]
name = "box"
shape = { type = "box", size = [0.1, 0.1, 0.1] }
spacing = 0.025
material = { young = 1.0e5 }
"#,
            "still",
        )
        .unwrap();
        let mut w = scene.build(&BuildOptions::default()).unwrap();
        w.objects.remove(0)
    }

    /// Seconds until `settle` finds the box settled when every phyxel sits at
    /// `rest + offset(step)`, at most `limit` steps of `dt` (None: never).
    fn settled_after(offset: impl Fn(usize) -> Vec3, dt: f32, limit: usize) -> Option<f32> {
        let mut objects = vec![body()];
        let rest: Vec<Vec3> = (0..objects[0].phyxels.len())
            .map(|j| objects[0].phyxels.pos.get(j))
            .collect();
        let (mut springs, mut scratch) = (ContactSprings::default(), SleepScratch::default());
        for k in 0..limit {
            let o = &mut objects[0];
            for (j, &x) in rest.iter().enumerate() {
                o.phyxels.pos.set(j, x + offset(k));
            }
            settle(
                &mut objects,
                &[],
                &mut springs,
                dt,
                (k as f64 + 1.0) * dt as f64,
                &mut scratch,
            );
            if objects[0].is_asleep() {
                return Some((k + 1) as f32 * dt);
            }
        }
        None
    }

    /// The verdicts against the definitions: a vibration in place of a 6-step period
    /// with an amplitude of 4% of the spacing (a contact chattering at an edge) averages
    /// out, and the box sleeps after its still time (within one check interval); the
    /// same vibration at 20% of the spacing is beyond [`SLEEP_SHAKE`] and never sleeps;
    /// a steady creep at twice [`SLEEP_SPEED`] never sleeps, one at half of it does.
    #[test]
    fn still_means_no_drift_and_no_more_than_a_small_vibration() {
        let dt = 1.0 / 120.0;
        let still = still_time(&body());
        let spacing = body().phyxel_spacing;
        let limit = (3.0 * still / dt) as usize;
        let shake = |amplitude: f32| {
            move |k: usize| Vec3::X * amplitude * (std::f32::consts::TAU * k as f32 / 6.0).sin()
        };
        let t = settled_after(shake(0.04 * spacing), dt, limit).expect("vibrating in place");
        assert!(
            t >= still && t <= still * (1.0 + 1.0 / SLEEP_SAMPLES) + 2.0 * dt,
            "asleep at {t} s, still time {still} s"
        );
        assert_eq!(settled_after(shake(0.2 * spacing), dt, limit), None);
        let creep = |speed: f32| move |k: usize| Vec3::X * speed * k as f32 * dt;
        assert_eq!(settled_after(creep(2.0 * SLEEP_SPEED), dt, limit), None);
        assert!(settled_after(creep(0.5 * SLEEP_SPEED), dt, limit).is_some());
    }
}
