//! Lazy advection (`World::lazy_advection`) advects only the surfels a step reads, and
//! changes no result: after `World::sync_surfels` the state has the same bits as a run
//! that advected every surfel at every step.
//!
//! Reference: the same run with lazy advection off. Tolerance: bitwise equality of every
//! phyxel and surfel position and velocity, the deepest penetration and the contact
//! patches' surfel counts.

use crate::common;

use phyxel::World;
use phyxel::scene::{BuildOptions, Scene};

/// `scene` built with `options`, stepped `steps` times with lazy advection `lazy`
/// (then synced), and the number of steps after which some surfels were stale.
fn run(
    scene: &str,
    options: &BuildOptions,
    steps: usize,
    lazy: bool,
    render: bool,
) -> (World, usize) {
    let mut w = Scene::builtin(scene).unwrap().build(options).unwrap();
    w.lazy_advection = lazy;
    w.render_contacts |= render;
    let mut stale = 0;
    for _ in 0..steps {
        w.step();
        stale += usize::from(w.objects.iter().any(|o| !o.surfels_current()));
    }
    w.sync_surfels();
    assert!(w.objects.iter().all(|o| o.surfels_current()));
    (w, stale)
}

fn assert_same(scene: &str, eager: &World, lazy: &World) {
    assert_eq!(
        eager.record.max_penetration.to_bits(),
        lazy.record.max_penetration.to_bits(),
        "{scene}: deepest penetration"
    );
    let patches =
        |w: &World| -> Vec<usize> { w.contact.patches.iter().map(|p| p.surfels.len()).collect() };
    assert_eq!(patches(eager), patches(lazy), "{scene}: contact patches");
    let (a, b) = (common::state_bits(eager), common::state_bits(lazy));
    assert_eq!(a.len(), b.len());
    let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    assert_eq!(
        differing,
        0,
        "{scene}: {differing} of {} values differ",
        a.len()
    );
}

/// `scale` at 100k surfels per sphere through its deep contact (the far-field paths
/// run): same bits, with surfels left stale after most steps and fewer advected.
#[test]
fn lazy_advection_changes_no_bit_in_deep_contact() {
    let options = BuildOptions {
        surfels: Some(100_000),
        ..Default::default()
    };
    let steps = 150;
    let (eager, _) = run("scale", &options, steps, false, false);
    let (lazy, stale) = run("scale", &options, steps, true, false);
    assert!(
        stale > steps / 2,
        "lazy advection left surfels stale after {stale} of {steps} steps"
    );
    let moved = |w: &World| w.record.times.work(phyxel::world::Phase::Advect);
    assert!(
        moved(&lazy) < moved(&eager),
        "lazy advection moved {} surfels, eager {}",
        moved(&lazy),
        moved(&eager)
    );
    assert_same("scale", &eager, &lazy);
}

/// `sphere-on-plane` at 100k surfels: the plane's surfels under the sphere query its
/// surface far from the contact, beyond the sphere's current surfels; the step brings
/// them current and runs its contact phases again (then advects the sphere eagerly for
/// a while). Same bits.
#[test]
fn lazy_advection_runs_the_contact_again_when_a_query_reaches_stale_surfels() {
    let options = BuildOptions {
        surfels: Some(100_000),
        ..Default::default()
    };
    let steps = 400;
    let (eager, _) = run("sphere-on-plane", &options, steps, false, false);
    let (lazy, stale) = run("sphere-on-plane", &options, steps, true, false);
    assert!(
        lazy.record.lazy_reruns > 0,
        "no query reached stale surfels"
    );
    assert!(stale > 0);
    assert_eq!(eager.record.lazy_reruns, 0);
    assert_same("sphere-on-plane", &eager, &lazy);
}

/// Built-in scenes with many bodies, plastic flow (new rest shapes), fracture, a tool
/// and a render surface: same bits with lazy advection.
#[test]
fn lazy_advection_changes_no_bit_on_the_builtin_scenes() {
    let default = BuildOptions::default();
    for (scene, steps, render) in [
        ("two-spheres", 160, true),
        ("pile", 120, false),
        ("plastic-pile", 120, false),
        ("plastic-fracture", 200, false),
        ("newtons-cradle", 100, true),
    ] {
        let (eager, _) = run(scene, &default, steps, false, render);
        let (lazy, _) = run(scene, &default, steps, true, render);
        assert_same(scene, &eager, &lazy);
    }
}
