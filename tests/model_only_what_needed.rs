//! A feature a scene does not use costs nothing: asserted from the per-phase work
//! counters (work items, not times).

use phyxel::scene::{BuildOptions, Scene};
use phyxel::timing::Phase;

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
        w.times.work(Phase::Forces) > 0,
        "the spheres must touch for this test"
    );
    assert_eq!(w.friction_work, 0, "friction work with μ = 0");
    assert_eq!(
        w.times.work(Phase::Resample),
        0,
        "render resampling without frames"
    );
    assert_eq!(
        w.times.work(Phase::Topology),
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
    assert!(w.friction_work > 0);
    assert!(w.times.work(Phase::Resample) > 0);
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
        w.times.work(Phase::Dynamics),
        (ball.phyxels.len() * steps) as u64
    );
}
