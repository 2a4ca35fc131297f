//! Results do not depend on the number of threads: every parallel loop writes disjoint
//! outputs in a fixed order (gathers per phyxel, colliding surfels in surfel order,
//! contact patches in pair order, force distribution sequential), and the only
//! reductions are maxima and integer counts.
//!
//! Reference: the same run on one thread. Tolerance: bitwise equality of every phyxel
//! and surfel position and velocity after the run.

use phyxel::World;
use phyxel::scene::{BuildOptions, Scene};

fn run_on(threads: usize, scene: &str, steps: usize) -> World {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut w = Scene::builtin(scene)
            .unwrap()
            .build(&BuildOptions::default())
            .unwrap();
        for _ in 0..steps {
            w.step();
        }
        w
    })
}

fn bits(w: &World) -> Vec<u32> {
    let mut out = Vec::new();
    for o in &w.objects {
        for col in [
            &o.phyxels.pos,
            &o.phyxels.vel,
            &o.surfels.pos,
            &o.surfels.vel,
        ] {
            for v in [&col.x, &col.y, &col.z] {
                out.extend(v.iter().map(|x| x.to_bits()));
            }
        }
    }
    out
}

/// `two-spheres` through its collision (contact in steps ~75–200): 1 and 2 threads give
/// bitwise identical states, and the run did handle contact.
#[test]
fn one_and_two_threads_agree_bitwise() {
    let steps = 160;
    let one = run_on(1, "two-spheres", steps);
    let two = run_on(2, "two-spheres", steps);
    assert!(one.max_penetration > 0.0, "the spheres must collide");
    assert_eq!(one.max_penetration.to_bits(), two.max_penetration.to_bits());
    let (a, b) = (bits(&one), bits(&two));
    assert_eq!(a.len(), b.len());
    let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    assert_eq!(differing, 0, "{differing} of {} values differ", a.len());
}
