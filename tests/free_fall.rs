//! A free elastic sphere in free fall: stable at the stable time step, keeps its shape,
//! and its centre of mass follows the discrete free-fall law exactly.

use phyxel::World;
use phyxel::scene::{BuildOptions, Scene};

fn falling_sphere(dt_factor: f32) -> World {
    let scene = Scene::builtin("falling-sphere").unwrap();
    let probe = scene.build(&BuildOptions::default()).unwrap();
    let stable = probe.stable_dt().0;
    scene
        .build(&BuildOptions {
            dt: Some(stable * dt_factor),
            allow_unstable: true,
            ..Default::default()
        })
        .unwrap()
}

fn max_strain(world: &World) -> f32 {
    let o = &world.objects[0];
    o.dynamics
        .diagnostics(&o.phyxels, &o.material)
        .max_strain
        .unwrap()
}

/// 2,000 steps at exactly the stable dt: all state finite, largest strain below 1e-3
/// over the whole run (a free body must not deform), and the centre of mass at
/// `y₀ − g dt² n(n+1)/2` (symplectic Euler's exact discrete free fall) to 1e-4 of the drop.
#[test]
fn free_fall_at_stable_dt_keeps_shape() {
    let mut world = falling_sphere(1.0);
    let y0 = world.objects[0].phyxels.centre_of_mass()[1];
    let mut worst = 0.0f32;
    let n = 2000u64;
    for _ in 0..n {
        world.step();
        worst = worst.max(max_strain(&world));
    }
    assert!(world.all_finite(), "state became non-finite");
    assert!(worst < 1e-3, "largest strain during free fall {worst:e}");
    let dt = world.dt as f64;
    let drop = 9.81 * dt * dt * (n * (n + 1)) as f64 / 2.0;
    let y = world.objects[0].phyxels.centre_of_mass()[1];
    let err = ((y0 - y) - drop).abs() / drop;
    assert!(
        err < 1e-4,
        "free-fall drop {} m vs {drop} m (relative error {err:e})",
        y0 - y
    );
}

/// The stable bound is not needlessly small: twice above it, the same run blows up
/// (non-finite state or strain above 1) within 2,000 steps.
#[test]
fn well_above_stable_dt_blows_up() {
    let mut world = falling_sphere(2.0);
    let mut blew_up = false;
    for _ in 0..2000 {
        world.step();
        if !world.all_finite() || max_strain(&world) > 1.0 {
            blew_up = true;
            break;
        }
    }
    assert!(
        blew_up,
        "dt = 2x the stable bound did not blow up: the bound is too conservative"
    );
}
