//! Sleeping (`world::sleep`): a still group stops being stepped, wakes when something
//! moving touches it, and decides the same on any thread count.
//!
//! References: a sleeping body's state is not touched (bitwise the same over the
//! steps it sleeps); `sleep = false` is the run without the feature (bitwise the same
//! as long as nothing has fallen asleep in the other); momentum and energy bounds as
//! stated per test.

use crate::common;

use phyxel::World;
use phyxel::scene::Scene;

/// Two 0.1 m soft boxes (E = 1e5 Pa, Kelvin–Voigt damping 0.01 s) set down on a static
/// plane 5 cm apart.
const SCENE: &str = r#"
name = "box-at-rest"
gravity = [0.0, -9.81, 0.0]

[[objects]]
name = "ground"
shape = { type = "plane", size = [0.8, 0.4] }
spacing = 0.025
static = true
material = { young = 1.0e6, friction = 0.5, contact_damping = 4.0 }

[[objects]]
name = "box"
shape = { type = "box", size = [0.1, 0.1, 0.1] }
spacing = 0.025
position = [0.0, 0.052, 0.0]
material = { young = 1.0e5, damping = 0.01, friction = 0.5, contact_damping = 4.0 }

[[objects]]
name = "block"
shape = { type = "box", size = [0.1, 0.1, 0.1] }
spacing = 0.025
position = [0.15, 0.052, 0.0]
material = { young = 1.0e5, damping = 0.01, friction = 0.5, contact_damping = 4.0 }
"#;

fn world(sleep: bool, backend: &str) -> World {
    let mut scene = Scene::parse(SCENE, "box-at-rest").unwrap();
    scene.sleep = Some(sleep);
    common::build(&scene, Some(backend))
}

/// Steps until every moving body sleeps, at most `limit` simulated seconds; returns
/// the time (s).
fn settle(w: &mut World, limit: f64) -> f64 {
    while w.time < limit {
        w.step();
        if w.objects.iter().all(|o| o.is_static() || o.is_asleep()) {
            return w.time;
        }
    }
    panic!(
        "not asleep after {limit} s: {:?}",
        w.objects.iter().map(|o| o.is_asleep()).collect::<Vec<_>>()
    );
}

/// Both bodies settle and fall asleep within 2 s on both MLS backends (the sleep test
/// needs 0.5 s of stillness); while they sleep their state does not change by a bit,
/// their velocities are zero, and with `sleep = false` the same scene keeps both awake
/// and stepping.
#[test]
fn a_still_group_sleeps_and_is_left_alone() {
    for backend in ["mls", "mls-implicit"] {
        let mut w = world(true, backend);
        let t = settle(&mut w, 2.0);
        assert!(t >= 0.5, "{backend}: asleep at {t} s");
        let before = common::state_bits(&w);
        for _ in 0..50 {
            w.step();
        }
        assert_eq!(
            before,
            common::state_bits(&w),
            "{backend}: a sleeping body moved"
        );
        assert_eq!(w.energy().kinetic, 0.0);
        let mut awake = world(false, backend);
        while awake.time < t + 0.1 {
            awake.step();
        }
        assert!(awake.objects.iter().all(|o| !o.is_asleep()), "{backend}");
    }
}

/// Until something falls asleep, `sleep = true` and `sleep = false` give the same bits:
/// the sleep test itself changes nothing.
#[test]
fn sleeping_changes_nothing_before_a_body_sleeps() {
    let (mut on, mut off) = (world(true, "mls"), world(false, "mls"));
    while on.objects.iter().all(|o| !o.is_asleep()) {
        assert_eq!(common::state_bits(&on), common::state_bits(&off));
        on.step();
        off.step();
    }
    assert!(on.time > 0.5);
}

/// The block, woken and slid at the sleeping box at 1 m/s, wakes it on contact: the
/// box moves off afterwards (its centre of mass travels more than 1 mm along the throw
/// within 0.3 s), the state stays finite, and the kinetic energy never exceeds the
/// throw's (no energy from waking).
#[test]
fn a_moving_body_wakes_what_it_touches() {
    let mut w = world(true, "mls-implicit");
    settle(&mut w, 2.0);
    let box_at = w.objects[1].phyxels.centre_of_mass();
    let block = &mut w.objects[2];
    for j in 0..block.phyxels.len() {
        block.phyxels.vel.set(j, glam::Vec3::new(-1.0, 0.0, 0.0));
    }
    block.wake();
    let thrown = w.energy().kinetic;
    assert!(w.objects[1].is_asleep());
    let mut woke = false;
    let end = w.time + 0.3;
    while w.time < end {
        w.step();
        woke |= !w.objects[1].is_asleep();
        assert!(w.all_finite());
        assert!(w.energy().kinetic <= thrown * (1.0 + 1e-6));
    }
    assert!(woke, "the box never woke");
    let moved = box_at[0] - w.objects[1].phyxels.centre_of_mass()[0];
    assert!(moved > 1e-3, "the box moved {moved} m");
}

/// One and two threads put the same bodies to sleep at the same step and end in the
/// same bits.
#[test]
fn sleeping_does_not_depend_on_the_thread_count() {
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut w = world(true, "mls");
            let t = settle(&mut w, 2.0);
            (t, common::state_bits(&w))
        })
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one.0.to_bits(), two.0.to_bits());
    assert!(one.1 == two.1, "the states differ");
}
