//! Contact output (`World::contact_totals`, `contact::ContactPoint`): what the library
//! reports a contact did, checked against Newton's laws.

use glam::DVec3;
use phyxel::contact::ContactPoint;
use phyxel::scene::{BuildOptions, Scene};

/// A soft box (0.1 m, E = 1e5 Pa, 64 phyxels, damped) set on a static plane and left to
/// settle for 0.6 s, then watched for 0.1 s. Reference: Newton's second law. Over the
/// window the box's momentum changes by less than 0.2% of its weight's impulse (checked:
/// it is at rest), so the contact force on it must balance its weight: the mean
/// reported total force on the box is within 1% of `m g` upwards (3e-6 measured), and
/// its sideways part within 1% of the weight. The patch's centroid lies under the box's centre of
/// mass (within one surfel spacing, 5 mm) and its area within 25% of the 0.01 m² face
/// (the kernel estimate of each surfel's area loses up to half a kernel along the
/// 0.4 m rim: 0.4 × 0.005 / 0.01 = 20%; −15% measured). Each contact surfel's penalty and friction
/// parts add up to its force, along and across its normal.
#[test]
fn a_resting_box_carries_its_weight() {
    let text = r#"
        name = "box-on-plane"
        gravity = [0.0, -9.81, 0.0]
        [[objects]]
        name = "ground"
        shape = { type = "plane", size = [0.4, 0.4] }
        spacing = 0.025
        surfel_spacing = 0.005
        static = true
        material = { young = 1.0e6, friction = 0.5 }
        [[objects]]
        name = "box"
        shape = { type = "box", size = [0.1, 0.1, 0.1] }
        spacing = 0.025
        surfel_spacing = 0.005
        position = [0.0, 0.0505, 0.0]
        material = { young = 1.0e5, damping = 2.0e-3, friction = 0.5 }
    "#;
    let scene = Scene::parse(text, "box-on-plane").unwrap();
    let mut world = scene.build(&BuildOptions::default()).unwrap();
    let dt = world.dt as f64;
    let settle = (0.6 / dt) as usize;
    let window = (0.1 / dt) as usize;
    for _ in 0..settle {
        world.step();
    }
    let mass = world.objects[1].phyxels.total_mass();
    let weight = mass * 9.81;
    let p0 = DVec3::from(world.objects[1].phyxels.momentum());
    let mut sum = DVec3::ZERO;
    let mut last = None;
    for _ in 0..window {
        world.step();
        let totals = world.contact_totals();
        assert_eq!(totals.len(), 1, "one pair in contact");
        let t = totals[0];
        assert_eq!((t.a, t.b), (0, 1));
        // The force is on a (the ground): the box takes the opposite.
        sum -= DVec3::from(t.force);
        last = Some(t);
    }
    let dp = DVec3::from(world.objects[1].phyxels.momentum()) - p0;
    assert!(
        dp.length() < 2e-3 * weight * window as f64 * dt,
        "the box is not at rest: momentum change {dp:?}"
    );
    let mean = sum / window as f64;
    println!(
        "mean contact force {mean:?} N, weight {weight} N, momentum change {dp:?} over {window} steps"
    );
    assert!(
        (mean.y - weight).abs() < 0.01 * weight,
        "mean contact force {mean:?} N against the weight {weight} N"
    );
    assert!(
        mean.x.hypot(mean.z) < 0.01 * weight,
        "sideways contact force {mean:?} N"
    );
    let t = last.unwrap();
    let com = DVec3::from(world.objects[1].phyxels.centre_of_mass());
    let c = DVec3::from(t.centroid);
    assert!(
        (c.x - com.x).hypot(c.z - com.z) < 0.005,
        "centroid {c:?} under the box at {com:?}"
    );
    assert!(
        (t.area - 0.01).abs() < 0.25 * 0.01,
        "contact area {} m² against the 0.01 m² face",
        t.area
    );
    println!("area {} m², centroid {c:?}, box at {com:?}", t.area);
    assert!(t.normal_force > 0.0 && t.peak_pressure > 0.0 && t.max_penetration > 0.0);
    for c in &world.patches[0].surfels {
        let p = ContactPoint::of(c);
        let sum = glam::Vec3::from(p.penalty_force) + glam::Vec3::from(p.friction_force);
        assert!((sum - c.force).length() <= 1e-5 * c.force.length().max(1e-12));
        let n = glam::Vec3::from(p.normal);
        assert!(glam::Vec3::from(p.friction_force).dot(n).abs() <= 1e-4 * c.force.length());
        assert!(
            glam::Vec3::from(p.slip_velocity).dot(n).abs() <= 1e-4 * c.velocity.length().max(1e-12)
        );
    }
}
