//! Pairs handled in order (`pairs_in_order`, on with `preset = "paper"`; Keiser et al.
//! 2004, §8): each contact pair meets the surfaces `S ∖ C ∪ Φ` the pairs before it in
//! the same step left, instead of the original surfaces.

use crate::common;
use phyxel::World;
use phyxel::scene::Scene;

fn with_forces_on_phi(name: &str, in_order: bool) -> World {
    let mut scene = Scene::builtin(name).unwrap();
    scene.resampled_forces = Some(true);
    scene.pairs_in_order = Some(in_order);
    let w = common::build(&scene, None);
    assert_eq!(w.pairs_in_order, in_order);
    w
}

/// With a single pair in contact nothing precedes it, so in order and independently
/// must agree to the bit (`two-spheres`, forces on the resampled Φ, 150 steps through
/// the collision's deepest point). Reference: the two paths' definition.
#[test]
fn a_single_pair_is_the_same_in_order() {
    let (mut a, mut b) = (
        with_forces_on_phi("two-spheres", true),
        with_forces_on_phi("two-spheres", false),
    );
    let mut touched = 0;
    for _ in 0..150 {
        a.step();
        b.step();
        touched += !a.contact.patches.is_empty() as u32;
        assert_eq!(a.contact.patches, b.contact.patches, "step {}", a.steps);
    }
    assert!(touched > 20, "in contact in {touched} steps");
    for (oa, ob) in a.objects.iter().zip(&b.objects) {
        assert_eq!(oa.phyxels.pos, ob.phyxels.pos);
    }
}

/// `newtons-cradle` for 0.3 s: the pulse crosses the row, and the middle spheres touch
/// both neighbours in the same steps, so later pairs meet surfaces an earlier pair
/// changed. References: Newton's laws (the total momentum stays the incoming one within
/// 1e-4, as for independent pairs: each patch's forces are equal and opposite whatever
/// surface it was built on); the paper's observation that the order makes "only little
/// difference" (the last sphere's share of the momentum within 1% of the independent
/// run's).
#[test]
fn the_cradle_in_order_conserves_momentum_and_barely_differs() {
    let (mut a, mut b) = (
        with_forces_on_phi("newtons-cradle", true),
        with_forces_on_phi("newtons-cradle", false),
    );
    let p_in = a.objects[0].phyxels.momentum()[0];
    let mut shared = 0;
    for _ in 0..(0.3 / a.dt) as usize {
        a.step();
        b.step();
        let total: f64 = a.objects.iter().map(|o| o.phyxels.momentum()[0]).sum();
        assert!(
            (total - p_in).abs() < 1e-4 * p_in,
            "momentum {total} of {p_in}"
        );
        // A sphere in two patches this step: its second pair met the changed surface.
        let in_two = (0..a.objects.len()).any(|k| {
            a.contact
                .patches
                .iter()
                .filter(|p| p.a == k || p.b == k)
                .count()
                > 1
        });
        shared += in_two as u32;
    }
    let last = |w: &World| w.objects[4].phyxels.momentum()[0] / p_in;
    println!(
        "in order: last sphere {:.5}, independent {:.5}; {shared} steps with a sphere in two pairs",
        last(&a),
        last(&b)
    );
    assert!(shared > 10, "{shared} steps with a sphere in two pairs");
    assert!((last(&a) / last(&b) - 1.0).abs() < 0.01);
}
