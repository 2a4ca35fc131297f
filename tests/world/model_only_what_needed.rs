//! A feature a scene does not use costs nothing: asserted from the per-phase work
//! counters (work items, not times).

use phyxel::scene::{BuildOptions, Scene};
use phyxel::world::phase::Phase;

fn run(name: &str, steps: usize, render: bool) -> phyxel::World {
    let scene = Scene::builtin(name).unwrap();
    let mut w = scene.build(&BuildOptions::default()).unwrap();
    w.render_contacts = render;
    for _ in 0..steps {
        w.step();
    }
    w
}

/// `two-spheres` (μ = 0, elastic, no frames written): the spheres do touch (contact
/// surfels forced), yet no friction is evaluated, no render surface is resampled, the
/// topology phase does nothing (no object can break, none asks for self-collision), and
/// the MLS backends keep no plastic state at all.
#[test]
fn unused_features_do_no_work() {
    let w = run("two-spheres", 150, false);
    assert!(
        w.record.times.work(Phase::Forces) > 0,
        "the spheres must touch for this test"
    );
    assert_eq!(w.record.friction_work, 0, "friction work with μ = 0");
    assert_eq!(
        w.record.times.work(Phase::Resample),
        0,
        "render resampling without frames"
    );
    assert_eq!(
        w.record.times.work(Phase::Topology),
        0,
        "topology work (fracture check, self-collision) though no object can break or needs it"
    );
    for o in w.objects.iter().filter(|o| !o.is_static()) {
        // The backend that ran, not a fresh one: `None` means it keeps no plastic state.
        let d = o.dynamics.diagnostics(&o.phyxels, &o.material);
        assert_eq!(
            d.max_plastic_strain, None,
            "{}: plastic state for an elastic material",
            o.name
        );
    }
}

/// The counters are live: with friction (`incline`, μ = 0.5) friction is evaluated, and
/// with frames written the contact surface is resampled.
#[test]
fn used_features_do_work() {
    let w = run("incline", 200, true);
    assert!(w.record.friction_work > 0);
    assert!(w.record.times.work(Phase::Resample) > 0);
}

/// The plastic-state check above is live: in `plastic-pile` (plastic blobs thrown onto
/// a plane) the running backends keep plastic state and report flow (a plastic strain
/// norm above zero, dimensionless) once the blobs have landed.
#[test]
fn plastic_materials_keep_plastic_state() {
    let w = run("plastic-pile", 1500, false);
    let flowed = w
        .objects
        .iter()
        .filter(|o| !o.is_static())
        .filter_map(|o| {
            o.dynamics
                .diagnostics(&o.phyxels, &o.material)
                .max_plastic_strain
        })
        .fold(0.0f32, f32::max);
    assert!(flowed > 0.0, "no plastic flow reported");
}

/// Static objects are never stepped: in `sphere-on-plane` the dynamics phase counts only
/// the ball's phyxels, every step.
#[test]
fn static_objects_have_no_dynamics() {
    let steps = 20;
    let w = run("sphere-on-plane", steps, false);
    let ball = w.objects.iter().find(|o| !o.is_static()).unwrap();
    assert_eq!(
        w.record.times.work(Phase::Dynamics),
        (ball.phyxels.len() * steps) as u64
    );
}

/// Surfels finer than the force carriers (`object::FORCE_CARRIER_SPACING`) are tested
/// for contact only when a render surface needs them (`World::render_contacts`): the
/// `scale` spheres with 20,000 surfels on 150 phyxels (13,657 carriers of 40,000
/// surfels), 60 steps into their contact, once without and once with frames. Reference:
/// the run with every colliding surfel found. Without frames the detection tests fewer
/// candidates and finds only carriers, and the runs are the same bit for bit: positions,
/// velocities and the reported penetration depth (which is taken over the carriers).
#[test]
fn surfels_finer_than_the_carriers_are_tested_only_for_frames() {
    let scene = Scene::builtin("scale").unwrap();
    let opts = BuildOptions {
        surfels: Some(20_000),
        phyxels: Some(150),
        ..Default::default()
    };
    let run = |render: bool| {
        let mut w = scene.build(&opts).unwrap();
        w.render_contacts = render;
        for _ in 0..60 {
            w.step();
        }
        w
    };
    let (lean, full) = (run(false), run(true));
    let carriers: usize = lean
        .objects
        .iter()
        .map(|o| o.force_carrier.iter().filter(|&&c| c).count())
        .sum();
    let surfels: usize = lean.objects.iter().map(|o| o.surfels.len()).sum();
    assert!(
        2 * carriers < surfels,
        "{carriers} carriers of {surfels} surfels: no thinning to test"
    );
    let non_carriers = |w: &phyxel::World| {
        w.contact
            .detections
            .iter()
            .map(|d| {
                let (a, b) = (&w.objects[d.a].force_carrier, &w.objects[d.b].force_carrier);
                d.a_in_b.iter().filter(|c| !a[c.surfel as usize]).count()
                    + d.b_in_a.iter().filter(|c| !b[c.surfel as usize]).count()
            })
            .sum::<usize>()
    };
    assert!(
        non_carriers(&full) > 0,
        "the spheres must overlap for this test"
    );
    assert_eq!(non_carriers(&lean), 0);
    let (tested, tested_full) = (
        lean.record.times.work(Phase::Detect),
        full.record.times.work(Phase::Detect),
    );
    println!(
        "{carriers} carriers of {surfels} surfels; candidates tested: {tested} without frames, {tested_full} with"
    );
    assert!(2 * tested < tested_full);
    assert_eq!(
        lean.record.times.work(Phase::ContactSurface),
        full.record.times.work(Phase::ContactSurface)
    );
    assert_eq!(
        lean.record.max_penetration.to_bits(),
        full.record.max_penetration.to_bits()
    );
    for (a, b) in lean.objects.iter().zip(&full.objects) {
        assert_eq!(a.phyxels.pos, b.phyxels.pos);
        assert_eq!(a.phyxels.vel, b.phyxels.vel);
    }
}
