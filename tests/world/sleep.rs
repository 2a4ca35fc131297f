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

/// A ball rolling along a long slab, and two boxes in a row beyond the slab's end, each
/// overlapping the next by 2 mm: ball, slab, middle box and end box are joined by their
/// boxes, on a static plane.
const CHAIN: &str = r#"
name = "chain"
gravity = [0.0, -9.81, 0.0]

[[objects]]
name = "ground"
shape = { type = "plane", size = [1.4, 0.6] }
spacing = 0.025
static = true
material = { young = 1.0e6, friction = 0.5, contact_damping = 4.0 }

[[objects]]
name = "slab"
shape = { type = "box", size = [0.6, 0.05, 0.2] }
spacing = 0.025
position = [0.0, 0.026, 0.0]
material = { young = 1.0e5, damping = 0.01, friction = 0.5, contact_damping = 4.0 }

[[objects]]
name = "middle"
shape = { type = "box", size = [0.1, 0.1, 0.1] }
spacing = 0.025
position = [0.348, 0.051, 0.0]
material = { young = 1.0e5, damping = 0.01, friction = 0.5, contact_damping = 4.0 }

[[objects]]
name = "end"
shape = { type = "box", size = [0.1, 0.1, 0.1] }
spacing = 0.025
position = [0.446, 0.051, 0.0]
material = { young = 1.0e5, damping = 0.01, friction = 0.5, contact_damping = 4.0 }

[[objects]]
name = "ball"
shape = { type = "sphere", radius = 0.05 }
spacing = 0.02
position = [-0.2, 0.102, 0.0]
velocity = [0.3, 0.0, 0.0]
material = { young = 1.0e6, damping = 1.0e-3, friction = 0.5, contact_damping = 4.0 }
"#;

/// Sleeping needs only the neighbours still, not the whole heap: in `CHAIN` the ball
/// keeps rolling along the slab (no rolling resistance but damping), so the slab under
/// it, and the middle box beside the slab, stay awake; the end box touches only the
/// middle one, settles and sleeps (one group for all four, it never would). References:
/// it sleeps within 3 s while the ball still moves (faster than 1 cm/s); its state does
/// not change by a bit while it sleeps; the middle box keeps pushing on it as on a
/// static object, so the total energy (with the contact springs' from the first step,
/// which counts the initial overlaps) never rises (above 1e-6 of it, for rounding), and
/// nothing sinks half a phyxel spacing.
#[test]
fn a_body_sleeps_beside_a_neighbour_that_still_moves() {
    let mut scene = Scene::parse(CHAIN, "chain").unwrap();
    scene.sleep = Some(true);
    let mut w = common::build(&scene, Some("mls-implicit"));
    let end = 3;
    let speed = |w: &World, k: usize| {
        let o = &w.objects[k].phyxels;
        o.momentum().iter().map(|c| c * c).sum::<f64>().sqrt() / o.total_mass()
    };
    // From the first step on: its contact phase counts the initial overlaps' energy.
    w.step();
    let start = w.energy().total();
    while !w.objects[end].is_asleep() {
        assert!(w.time < 3.0, "the end box never slept");
        w.step();
        assert!(w.energy().total() <= start + 1e-6 * start.abs());
    }
    assert!(
        speed(&w, 4) > 0.01,
        "the ball stopped: {} m/s",
        speed(&w, 4)
    );
    assert!(!w.objects[4].is_asleep() && !w.objects[1].is_asleep());
    let asleep_at = w.time;
    let before = common::object_bits(&w.objects[end]);
    for _ in 0..60 {
        w.step();
        assert!(w.all_finite());
        assert!(w.energy().total() <= start + 1e-6 * start.abs());
    }
    let o = &w.objects[end];
    assert!(o.is_asleep(), "woke after {} s", w.time - asleep_at);
    assert!(before == common::object_bits(o), "a sleeping body moved");
    println!(
        "end box asleep at {asleep_at:.2} s; ball at {:.3} m/s; max penetration {:.2e} m",
        speed(&w, 4),
        w.record.max_penetration
    );
    assert!(w.record.max_penetration < 0.0125);
}
