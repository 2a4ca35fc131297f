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
/// `World::energy` turns potential into kinetic energy (J): the potential falls by
/// `m g Δy` within 1e-4, and the total stays within 1% of the potential drop (symplectic
/// Euler's kinetic energy trails it by `1/(n + 1)`, 0.05%).
#[test]
fn free_fall_at_stable_dt_keeps_shape() {
    let mut world = falling_sphere(1.0);
    let y0 = world.objects[0].phyxels.centre_of_mass()[1];
    let e0 = world.energy();
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
    let e1 = world.energy();
    let m = world.objects[0].phyxels.total_mass();
    let fall = m * 9.81 * (y0 - y);
    let lost = e0.potential - e1.potential;
    assert!(
        (lost / fall - 1.0).abs() < 1e-4,
        "potential fell {lost} J, m g Δy {fall} J"
    );
    let gain = e1.total() - e0.total();
    assert!(
        gain.abs() < 0.01 * fall,
        "energy changed {gain} J of {fall} J"
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

/// A steel ball (E = 200 GPa, ρ = 7800 kg/m³, r = 5 cm, 12.5 mm phyxels) at y = 3 m, at
/// its default dt (0.69 µs).
fn steel_ball_at_3_m() -> World {
    let text = r#"
        name = "steel"
        [[objects]]
        shape = { type = "sphere", radius = 0.05 }
        spacing = 0.0125
        position = [0.0, 3.0, 0.0]
        material = { young = 2.0e11, density = 7800.0 }
    "#;
    Scene::parse(text, "steel")
        .unwrap()
        .build(&BuildOptions::default())
        .unwrap()
}

/// A stiff body far from the origin moves by less than its positions' resolution per
/// step: a steel ball (E = 200 GPa, ρ = 7800 kg/m³, r = 5 cm, 12.5 mm phyxels, stable dt
/// 0.69 µs) at y = 3 m (f32 ulp 2.4·10⁻⁷ m) falling for 20,000 steps moves at most
/// 9.3·10⁻⁸ m per step. Reference: symplectic Euler's discrete free fall
/// `g dt² n(n+1)/2` (m), matched to 1e-3 of the 0.93 mm drop by the centre of mass (f64
/// mean of the f32 positions, each within half an ulp, 1.3·10⁻⁴ of the drop, of the
/// compensated sum). Without the compensated position sum (`Phyxels::pos_carry`) each
/// step's motion, under half the ulp, rounds away and the ball does not move.
#[test]
fn slow_motion_far_from_the_origin_is_not_rounded_away() {
    let mut world = steel_ball_at_3_m();
    let y0 = world.objects[0].phyxels.centre_of_mass()[1];
    let n = 20_000u64;
    for _ in 0..n {
        world.step();
    }
    let dt = world.dt as f64;
    let want = 9.81 * dt * dt * (n * (n + 1) / 2) as f64;
    let drop = y0 - world.objects[0].phyxels.centre_of_mass()[1];
    assert!(
        (drop - want).abs() < 1e-3 * want,
        "dropped {drop:e} m, free fall {want:e} m (dt {dt:e} s)"
    );
}

/// The energy balance of a fall too slow for the f32 positions: the steel ball of the
/// test above (dt 0.69 µs) at y = 3 m falls 100 steps, 2.3·10⁻⁹ m in all, a hundredth of
/// its positions' ulp, so the positions do not change; the compensated sums' carries
/// hold the drop. Reference: symplectic Euler's discrete free fall, `v_n = n g dt` and a
/// drop of `g dt² n(n+1)/2`, so the potential loss is the kinetic gain times
/// `(n+1)/n` (J), matched within 1e-3. `World::energy` reads the heights with the
/// carries: without them the potential stays put while the kinetic energy grows, a
/// false energy gain.
#[test]
fn free_fall_energy_balances_before_the_positions_move() {
    let mut world = steel_ball_at_3_m();
    let e0 = world.energy();
    let n = 100;
    for _ in 0..n {
        world.step();
    }
    let e1 = world.energy();
    let gain = e1.kinetic - e0.kinetic;
    let loss = e0.potential - e1.potential;
    let want = gain * (n + 1) as f64 / n as f64;
    assert!(gain > 0.0, "kinetic gain {gain:e} J");
    assert!(
        (loss - want).abs() <= 1e-3 * want,
        "kinetic gain {gain:e} J, potential loss {loss:e} J, expected {want:e} J"
    );
}
