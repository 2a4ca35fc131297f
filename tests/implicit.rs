//! The implicit MLS backend (`mls-implicit`): the same bar as the explicit backend at a
//! frame-rate step, and solves that converge or say they did not.

use phyxel::app::summary::summarize;
use phyxel::app::validate;
use phyxel::backends::mls::MlsImplicit;
use phyxel::scene::{BuildOptions, Scene};

/// The cantilever (E = 1e8 Pa, 4 phyxels through the 0.1 m thickness) stepped at 1/60 s
/// for 3 s settles (backward Euler damps its first mode by 0.2 per period) at a tip
/// deflection within 15% of Euler–Bernoulli's qL⁴/(8EI) (the explicit backend's
/// tolerance at this resolution), and within 2% of the explicit backend's static
/// deflection (its mean over the first half period from rest): the same discretisation,
/// a step 760 times longer. Every step converged (or reached the f32 floor) in at most
/// 4 Newton iterations.
#[test]
fn a_stiff_bar_at_a_frame_rate_step_sags_as_the_explicit_one() {
    let mut scene = Scene::builtin("cantilever").unwrap();
    scene.objects[0].spacing = 0.025;
    scene.objects[0].surfel_spacing = Some(0.025);
    let (d_ref, _) = validate::euler_bernoulli(&scene);
    let mut world = scene
        .build(&BuildOptions {
            backend: Some("mls-implicit".into()),
            dt: Some(1.0 / 60.0),
            ..BuildOptions::default()
        })
        .unwrap();
    let bar = &world.objects[0].phyxels;
    let x_max = (0..bar.len())
        .map(|i| bar.rest.x[i])
        .fold(f32::MIN, f32::max);
    let tip: Vec<usize> = (0..bar.len())
        .filter(|&i| bar.rest.x[i] > x_max - 0.0125)
        .collect();
    for _ in 0..180 {
        world.step();
    }
    assert!(world.all_finite());
    let p = &world.objects[0].phyxels;
    let sag = tip
        .iter()
        .map(|&i| (p.rest.y[i] - p.pos.y[i]) as f64)
        .sum::<f64>()
        / tip.len() as f64;
    assert!(
        ((sag - d_ref) / d_ref).abs() < 0.15,
        "sag {sag} m against {d_ref} m"
    );
    let (explicit, _, _) = validate::cantilever(0.025, 0, "mls").unwrap();
    assert!(
        ((sag - explicit) / explicit).abs() < 0.02,
        "implicit {sag} m, explicit {explicit} m"
    );
    let o = &world.objects[0];
    let stats = o.dynamics_as::<MlsImplicit>().unwrap().solver_stats();
    assert_eq!(stats.steps, 180);
    assert_eq!(stats.unconverged, 0, "{stats:?}");
    assert!(stats.newton_iterations <= 4 * 180, "{stats:?}");
}

/// A solve stopped before it converged is never silent: with no Newton iteration
/// allowed, every step of the cantilever is counted unconverged, and the run summary
/// carries a warning naming the body and the backend.
#[test]
fn an_unconverged_solve_is_a_warning() {
    let scene = Scene::builtin("cantilever").unwrap();
    let mut world = scene
        .build(&BuildOptions {
            backend: Some("mls-implicit".into()),
            dt: Some(1.0 / 120.0),
            ..BuildOptions::default()
        })
        .unwrap();
    world.objects[0]
        .dynamics_mut::<MlsImplicit>()
        .unwrap()
        .max_newton = 0;
    for _ in 0..5 {
        world.step();
    }
    let stats = world.objects[0]
        .dynamics_as::<MlsImplicit>()
        .unwrap()
        .solver_stats();
    assert_eq!(stats.unconverged, 5, "{stats:?}");
    let summary = summarize(&world, &scene, 5, 0.0, ([0.0; 3], world.energy()), 0);
    let warning = summary
        .warnings
        .iter()
        .find(|w| w.contains("solver tolerance"))
        .expect("a solver warning");
    assert!(
        warning.contains("'bar'") && warning.contains("mls-implicit"),
        "{warning}"
    );
    assert_eq!(summary.bodies[0].solver.unwrap().unconverged, 5);
}

/// A mixed pair: the `two-spheres` collision with the left sphere on `mls-implicit` and
/// the right one on `mls`. Reference: conservation of momentum (the contact forces are
/// equal and opposite, and each backend conserves its own body's momentum): the total
/// stays within 1e-4 of one sphere's incoming momentum through the collision, the state
/// stays finite, and both spheres bounce back (their velocities change sign).
#[test]
fn an_implicit_body_collides_with_an_explicit_one() {
    let mut scene = Scene::builtin("two-spheres").unwrap();
    scene.objects[0].backend = Some("mls-implicit".into());
    let mut world = scene.build(&BuildOptions::default()).unwrap();
    assert_eq!(world.objects[0].dynamics.name(), "mls-implicit");
    assert_eq!(world.objects[1].dynamics.name(), "mls");
    let incoming = world.objects[0].phyxels.momentum()[0];
    let mut collided = false;
    for _ in 0..400 {
        world.step();
        collided |= !world.patches.is_empty();
        let p = world.momentum();
        assert!(
            p.iter().all(|c| c.abs() < 1e-4 * incoming),
            "momentum {p:?} against {incoming}"
        );
    }
    assert!(collided && world.all_finite());
    let v = |k: usize| world.objects[k].phyxels.momentum()[0];
    assert!(v(0) < 0.0 && v(1) > 0.0, "bounced: {} and {}", v(0), v(1));
}
