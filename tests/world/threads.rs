//! Results do not depend on the number of threads: every parallel loop writes disjoint
//! outputs in a fixed order (gathers per phyxel, colliding surfels in surfel order,
//! contact patches in pair order, force distribution sequential), and the only
//! reductions are maxima, integer counts and the implicit solve's sums over its members
//! (in a fixed tree).
//!
//! Reference: the same run on one thread. Tolerance: bitwise equality of every phyxel
//! and surfel position and velocity after the run.

use crate::common;

use phyxel::World;
use phyxel::scene::{BuildOptions, Scene};

fn run_on(threads: usize, scene: &str, steps: usize) -> World {
    run_with(threads, scene, &BuildOptions::default(), steps)
}

fn run_with(threads: usize, scene: &str, options: &BuildOptions, steps: usize) -> World {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut w = Scene::builtin(scene).unwrap().build(options).unwrap();
        for _ in 0..steps {
            w.step();
        }
        w
    })
}

/// Both runs end in the same bits: the largest penetration and every phyxel and surfel
/// position and velocity.
fn assert_same_state(one: &World, two: &World) {
    assert_eq!(
        one.record.max_penetration.to_bits(),
        two.record.max_penetration.to_bits()
    );
    let (a, b) = (common::state_bits(one), common::state_bits(two));
    assert_eq!(a.len(), b.len());
    let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    assert_eq!(differing, 0, "{differing} of {} values differ", a.len());
}

/// `two-spheres` through its collision (contact in steps ~75–200): 1 and 2 threads give
/// bitwise identical states, and the run did handle contact.
#[test]
fn one_and_two_threads_agree_bitwise() {
    let steps = 160;
    let one = run_on(1, "two-spheres", steps);
    let two = run_on(2, "two-spheres", steps);
    assert!(one.record.max_penetration > 0.0, "the spheres must collide");
    assert_same_state(&one, &two);
}

/// `pile` on `mls-implicit` through 48 steps of 1/120 s: its four bodies land on the
/// plane and on each other and are solved as one island with some thousand contact
/// springs (read, spread and summed member by member in parallel: `solver::solve`); 1
/// and 2 threads give bitwise identical states.
#[test]
fn an_implicit_island_agrees_bitwise_on_one_and_two_threads() {
    let options = BuildOptions {
        backend: Some("mls-implicit".into()),
        ..Default::default()
    };
    let steps = 48;
    let one = run_with(1, "pile", &options, steps);
    let two = run_with(2, "pile", &options, steps);
    assert!(
        one.contact.springs.springs.len() > 500,
        "{} springs: the bodies must rest in contact",
        one.contact.springs.springs.len()
    );
    assert!(
        one.contact.springs.springs.iter().any(|sp| sp.b.is_some()),
        "two bodies must touch (an island of several)"
    );
    assert_same_state(&one, &two);
}

/// `scale` at 100k surfels per sphere through 150 steps: the contact gets deeper than
/// two kernel reaches, so detection runs its far-field path (per-surfel start radii kept
/// from step to step, the grid region widened by the depth, coarse far grids) on both
/// thread counts; the states stay bitwise identical.
#[test]
fn deep_contact_agrees_bitwise_on_one_and_two_threads() {
    let options = BuildOptions {
        surfels: Some(100_000),
        ..Default::default()
    };
    let steps = 150;
    let one = run_with(1, "scale", &options, steps);
    let two = run_with(2, "scale", &options, steps);
    let (_, r_max) = phyxel::contact::field::radius_range(&one.objects[0].surfels.radius);
    let reach = phyxel::contact::field::grid_cell(r_max);
    assert!(
        one.record.max_penetration > 2.0 * reach,
        "penetration {} m must exceed two kernel reaches ({reach} m)",
        one.record.max_penetration
    );
    assert_same_state(&one, &two);
}

/// The elastic energy each backend reports (a diagnostic of `run --json`) has the same
/// bits on 1 and 2 threads, on every run (a parallel reduction's order follows work
/// stealing: summed that way, about one `pile` run in twenty on `sph` prints a different
/// last digit). Reference: the 1-thread run; five 2-thread runs of each, so that a
/// stealing-dependent order has chances to show.
#[test]
fn reported_elastic_energy_is_the_same_on_any_thread_count() {
    for backend in ["sph", "lj"] {
        let options = BuildOptions {
            backend: Some(backend.into()),
            ..Default::default()
        };
        let energies = |w: &World| -> Vec<u64> {
            w.objects
                .iter()
                .filter_map(|o| {
                    o.dynamics
                        .diagnostics(&o.phyxels, &o.material)
                        .elastic_energy
                })
                .map(f64::to_bits)
                .collect()
        };
        let one = energies(&run_with(1, "pile", &options, 120));
        assert!(one.len() >= 4, "{backend}: every body reports an energy");
        for _ in 0..5 {
            let two = energies(&run_with(2, "pile", &options, 120));
            assert_eq!(
                one, two,
                "{backend}: elastic energies differ between thread counts"
            );
        }
    }
}
