//! The world's private cache (grids, boxes, scratch) is never the source of a result:
//! dropped between steps ([`World::clear_cache`]), it is rebuilt by the next step and
//! the run ends in the same bits.
//!
//! Reference: the same run with the cache kept. Tolerance: bitwise equality of every
//! phyxel and surfel position and velocity, and of the largest penetration.

use crate::common;

use phyxel::World;
use phyxel::scene::{BuildOptions, Scene};

fn run(scene: &str, steps: usize, clear_every: Option<usize>) -> World {
    let mut w = Scene::builtin(scene)
        .unwrap()
        .build(&BuildOptions::default())
        .unwrap();
    for k in 0..steps {
        if clear_every.is_some_and(|n| k % n == 0) {
            w.clear_cache();
        }
        w.step();
    }
    w
}

/// `two-spheres` through its collision (contact in steps ~75–200, so the grid regions
/// sized by the last step's depth are in use) and `pile` (a static plane whose box and
/// grids are otherwise kept from step to step): clearing the cache every step, or every
/// seventh, changes no bit.
#[test]
fn a_dropped_cache_changes_no_result() {
    for (scene, steps) in [("two-spheres", 200), ("pile", 150)] {
        let kept = run(scene, steps, None);
        assert!(
            kept.record.max_penetration > 0.0,
            "{scene}: the run had contact"
        );
        for every in [1, 7] {
            let cleared = run(scene, steps, Some(every));
            assert_eq!(
                kept.record.max_penetration.to_bits(),
                cleared.record.max_penetration.to_bits(),
                "{scene}, cleared every {every}: deepest penetration"
            );
            let (a, b) = (common::state_bits(&kept), common::state_bits(&cleared));
            let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
            assert_eq!(a.len(), b.len());
            assert_eq!(
                differing, 0,
                "{scene}, cleared every {every}: {differing} values differ"
            );
        }
    }
}
