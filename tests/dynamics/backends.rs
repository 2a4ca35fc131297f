//! The built-in backends on the same contact pipeline: the conformance suite over the
//! whole registry (`phyxel::conformance`), then resting contact, SPH weak
//! compressibility, LJ equilibrium, a mixed-backend collision. Scenes are the built-in
//! ones with coarser surfels (the contact pipeline's cost), so the whole module runs in
//! about three minutes.

use crate::common;
use glam::Vec3;
use phyxel::World;
use phyxel::backends::lj::LjDynamics;
use phyxel::backends::sph::SphDynamics;
use phyxel::conformance::{Backend, Case, Tolerances, run};
use phyxel::dynamics::Dynamics;
use phyxel::scene::{BuildOptions, Scene};

/// The backends with explicit contact forces (the implicit one settles at another dt).
const EXPLICIT: [&str; 3] = ["mls", "sph", "lj"];

/// A built-in scene with every surfel spacing at least `surfel` (m).
fn coarse(name: &str, surfel: f32) -> Scene {
    let mut scene = Scene::builtin(name).unwrap();
    for o in &mut scene.objects {
        o.surfel_spacing = Some(o.surfel_spacing.unwrap_or(0.0).max(surfel));
    }
    scene
}

fn com_velocity(w: &World, k: usize) -> Vec3 {
    let p = w.objects[k].phyxels.momentum();
    let m = w.objects[k].phyxels.total_mass();
    Vec3::new((p[0] / m) as f32, (p[1] / m) as f32, (p[2] / m) as f32)
}

/// Deepest colliding surfel of the current step (m).
fn current_penetration(w: &World) -> f32 {
    w.contact
        .detections
        .iter()
        .map(|d| d.max_depth())
        .fold(0.0, f32::max)
}

/// `sphere-on-plane` with each backend: an elastic ball (R = 0.1 m, E = 100 kPa) dropped
/// 2 cm onto a rigid plane comes to rest within 1.5 s of simulated time: state finite,
/// centre of mass speed below 2 cm/s, resting penetration of the surfels into the plane
/// below 5% of the radius (5 mm); the resting centre height lies near Hertz's static
/// indentation `δ = (9F²/(16E*²R))^(1/3)` (F = mg, 1/E* = (1−ν²)/E, rigid plane: ≈ 9.5 mm)
/// below the untouched height R: within 1.5 mm on `mls`, 2 mm on `sph` and 2.5 mm on `lj`
/// (measured 0.7 mm below it, 1.6 and 2.0 mm above; the Lennard-Jones bonds make a ball
/// stiffer than its nominal E). The largest penetration over the run (impact) is
/// printed; it is discretisation-limited and reported by `phyxel compare`.
#[test]
fn sphere_on_plane_settles_with_each_explicit_backend() {
    let scene = coarse("sphere-on-plane", 0.01);
    let ball = &scene.objects[1];
    let radius = 0.1f32;
    let m = &ball.material;
    let e_star = m.young / (1.0 - m.poisson * m.poisson);
    for b in EXPLICIT {
        let mut w = common::build(&scene, Some(b));
        let steps = (1.5 / w.dt).ceil() as usize;
        for _ in 0..steps {
            w.step();
        }
        assert!(w.all_finite(), "{b}: state became non-finite");
        let v = com_velocity(&w, 1).length();
        let pen = current_penetration(&w);
        let weight = w.objects[1].phyxels.total_mass() as f32 * 9.81;
        let delta = (9.0 * weight * weight / (16.0 * e_star * e_star * radius)).cbrt();
        let top = w.objects[0]
            .surfels
            .pos
            .iter()
            .fold(f32::NEG_INFINITY, |a, p| a.max(p.y));
        let height = w.objects[1].phyxels.centre_of_mass()[1] as f32 - top;
        println!(
            "{b}: {steps} steps, |v| {v:.2e} m/s, resting penetration {pen:.2e} m, max over run \
             {:.2e} m, centre height {height:.4} m (Hertz {:.4} m)",
            w.record.max_penetration,
            radius - delta
        );
        assert!(v < 0.02, "{b}: still moving at {v} m/s");
        assert!(
            pen < 0.05 * radius,
            "{b}: resting penetration {pen} m exceeds 5% of the radius"
        );
        let tolerance = match b {
            "mls" => 0.0015,
            "sph" => 0.002,
            _ => 0.0025,
        };
        assert!(
            (height - (radius - delta)).abs() < tolerance,
            "{b}: resting centre {height} m above the plane, Hertz {} m",
            radius - delta
        );
    }
}

/// A resting SPH block (0.2 × 0.1 × 0.2 m, ρ = 1000 kg/m³, E = 100 kPa, ν = 0.3) on a
/// rigid plane under gravity: after 0.4 s its largest SPH density deviation
/// `|ρ/ρ⁰ − 1|` matches the analytic peak volume strain within ±30%. Reference: the
/// free block is under uniaxial stress, `ρ g H` = 981 Pa at the bottom, so its volume
/// strain there is `ρ g H (1 − 2ν)/E` = 0.39% (bulk modulus `K = E/(3(1 − 2ν))`);
/// measured 0.34% (the contact spreads the load over the bottom layers). The densities
/// are recomputed by a fresh `SphDynamics` on the final state, independent of the run's
/// backend state.
#[test]
fn sph_resting_block_keeps_its_density() {
    let scene = Scene::parse(
        r#"
name = "sph-block"
gravity = [0.0, -9.81, 0.0]
[[objects]]
name = "ground"
shape = { type = "plane", size = [0.5, 0.5] }
spacing = 0.025
surfel_spacing = 0.01
static = true
material = { young = 1.0e7, contact_damping = 4.0 }
[[objects]]
name = "block"
shape = { type = "box", size = [0.2, 0.1, 0.2] }
spacing = 0.025
surfel_spacing = 0.01
position = [0.0, 0.051, 0.0]
backend = "sph"
material = { density = 1000.0, young = 1.0e5, poisson = 0.3, damping = 1.0e-3, contact_damping = 4.0 }
"#,
        "sph-block",
    )
    .unwrap();
    let mut w = scene.build(&BuildOptions::default()).unwrap();
    let steps = (0.4 / w.dt).ceil() as usize;
    for _ in 0..steps {
        w.step();
    }
    assert!(w.all_finite());
    let o = &w.objects[1];
    assert_eq!(o.dynamics.name(), "sph");
    let mut sph = SphDynamics::new(&o.phyxels, &o.material);
    sph.compute_forces(&o.phyxels, &o.material);
    let (rho, rho0) = (sph.density(), sph.rest_density());
    let worst = (0..o.phyxels.len())
        .map(|i| (rho[i] / rho0[i] - 1.0).abs())
        .fold(0.0f32, f32::max);
    let v = com_velocity(&w, 1).length();
    let (rho_m, g, height, young, poisson) = (1000.0f32, 9.81f32, 0.1f32, 1.0e5f32, 0.3f32);
    let reference = rho_m * g * height * (1.0 - 2.0 * poisson) / young;
    println!(
        "sph block: {steps} steps, largest |ρ/ρ0 − 1| = {worst:.5} (analytic {reference:.5}), \
         |v| {v:.2e} m/s"
    );
    assert!(
        (worst / reference - 1.0).abs() < 0.3,
        "largest density deviation {worst}, analytic {reference}"
    );
    assert!(v < 0.01, "the block is not at rest ({v} m/s)");
}

/// A Lennard-Jones lattice at rest stays at rest: a 0.2 m box sampled at 2.5 cm gets
/// exactly the 6 axis and 12 face-diagonal bonds per interior phyxel (counted
/// analytically), and 200 steps of the whole `World::step` without gravity (contact
/// pipeline, integrator, dashpots) move no phyxel by more than 1e-6 of the spacing. The
/// rest force is zero by construction (each bond's σ comes from its own rest length, so
/// `u = 1` exactly): its check (below 1e-6 of `k a`, `k = 0.4 E a`, N) only guards that
/// choice; one σ for all bonds would leave the face diagonals pulling.
#[test]
fn lj_rest_lattice_stays_at_rest() {
    let scene = Scene::parse(
        r#"
gravity = [0.0, 0.0, 0.0]
[[objects]]
shape = { type = "box", size = [0.2, 0.2, 0.2] }
spacing = 0.025
backend = "lj"
material = { density = 1000.0, young = 1.0e5, poisson = 0.25 }
"#,
        "lj-lattice",
    )
    .unwrap();
    let mut w = scene.build(&BuildOptions::default()).unwrap();
    let o = &w.objects[0];
    let a = 0.025f32;
    let k = 0.4 * o.material.young * a;
    let mut lj = LjDynamics::new(&o.phyxels, &o.material);
    let (bonds, broken) = lj.bonds();
    // An n³ lattice (n = 8) has 3n²(n − 1) axis bonds and 6n(n − 1)² face diagonals.
    assert_eq!(bonds, 3 * 8 * 8 * 7 + 6 * 8 * 7 * 7, "bond count");
    assert_eq!(broken, 0);
    lj.compute_forces(&o.phyxels, &o.material);
    let f = lj.internal_forces();
    let worst = (0..o.phyxels.len())
        .map(|i| f.get(i).length())
        .fold(0.0f32, f32::max);
    assert!(
        worst < 1e-6 * k * a,
        "rest force {worst} N vs k a = {} N",
        k * a
    );
    for _ in 0..200 {
        w.step();
    }
    let p = &w.objects[0].phyxels;
    let moved = (0..p.len())
        .map(|i| (p.pos.get(i) - p.rest.get(i)).length())
        .fold(0.0f32, f32::max);
    assert!(moved < 1e-6 * a, "the lattice moved {moved} m");
}

/// A mixed scene without gravity: an MLS sphere (R = 0.1 m) at 1 m/s hits a free SPH
/// block (0.3 × 0.2 × 0.3 m). The total momentum stays at its initial value to 1e-4 of
/// the sphere's `m v` (kg·m/s) at every step, and the block takes up momentum (at least
/// 10% of the sphere's: the objects do interact through the pipeline).
#[test]
fn mixed_mls_sphere_onto_sph_block_conserves_momentum() {
    let scene = Scene::parse(
        r#"
gravity = [0.0, 0.0, 0.0]
[[objects]]
name = "ball"
shape = { type = "sphere", radius = 0.1 }
spacing = 0.025
surfel_spacing = 0.01
position = [0.0, 0.22, 0.0]
velocity = [0.0, -1.0, 0.0]
backend = "mls"
[[objects]]
name = "block"
shape = { type = "box", size = [0.3, 0.2, 0.3] }
spacing = 0.025
surfel_spacing = 0.01
backend = "sph"
"#,
        "mixed",
    )
    .unwrap();
    let mut w = scene.build(&BuildOptions::default()).unwrap();
    assert_eq!(w.objects[0].dynamics.name(), "mls");
    assert_eq!(w.objects[1].dynamics.name(), "sph");
    let p0 = w.momentum();
    let scale = w.objects[0].phyxels.total_mass();
    let steps = (0.15 / w.dt).ceil() as usize;
    let mut worst = 0.0f64;
    for _ in 0..steps {
        w.step();
        let p = w.momentum();
        let d: f64 = (0..3).map(|k| (p[k] - p0[k]).powi(2)).sum::<f64>().sqrt();
        worst = worst.max(d / scale);
    }
    assert!(w.all_finite());
    let block = w.objects[1].phyxels.momentum()[1];
    println!("mixed: {steps} steps, drift {worst:.2e}, block momentum {block:.4} kg m/s");
    assert!(worst < 1e-4, "momentum drift {worst:e} of m v");
    assert!(
        block < -0.1 * scale,
        "the block took up too little momentum ({block})"
    );
}

/// A fast impact (10 m/s) of a Lennard-Jones ball (R = 0.1 m, E = 100 kPa) on a rigid
/// plane breaks bonds past the cutoff; the topology phase then splits the ball: more than
/// one object besides the ground after 0.1 s. (Measured without the topology phase, by
/// wrapping the backend: 51% of the 1,932 bonds break by 0.1 s at 10 m/s, 16% at 4 m/s,
/// 26 bonds at 2 m/s; docs/BACKENDS.md.)
#[test]
fn fast_lj_impact_breaks_the_ball() {
    let mut scene = coarse("sphere-on-plane", 0.01);
    scene.objects[1].velocity = [0.0, -10.0, 0.0];
    let mut w = common::build(&scene, Some("lj"));
    assert!(w.objects[1].dynamics.can_fracture(&w.objects[1].material));
    let steps = (0.1 / w.dt).ceil() as usize;
    for _ in 0..steps {
        w.step();
    }
    assert!(w.all_finite());
    let pieces = w.objects.iter().filter(|o| !o.is_static()).count();
    assert!(pieces > 1, "the ball stayed in one piece");
}

/// The SPH backend's polar decomposition (Müller et al. 2016 quaternion iteration)
/// recovers the rotation R of `F = R S` (S symmetric positive definite, 20% stretch and
/// shear) from a cold start within 1e-3 per matrix entry after repeated calls (as across
/// steps: warm-started); reference: R itself.
#[test]
fn sph_polar_rotation_recovers_the_rotation() {
    use glam::{Mat3, Quat};
    use phyxel::backends::sph::polar_rotation;
    let r = Mat3::from_quat(Quat::from_axis_angle(
        Vec3::new(1.0, 2.0, -0.5).normalize(),
        2.0,
    ));
    let s = Mat3::from_cols(
        Vec3::new(1.2, 0.1, 0.0),
        Vec3::new(0.1, 0.9, 0.05),
        Vec3::new(0.0, 0.05, 1.1),
    );
    let mut q = Quat::IDENTITY;
    for _ in 0..20 {
        q = polar_rotation(r * s, q);
    }
    let got = Mat3::from_quat(q);
    let err = (0..3)
        .map(|c| (got.col(c) - r.col(c)).abs().max_element())
        .fold(0.0f32, f32::max);
    assert!(err < 1e-3, "rotation off by {err}: {got} vs {r}");
}

/// The LJ lattice's stiffness matches the elastic constant it is calibrated to,
/// `C₁₁ = 1.2 E` (docs/BACKENDS.md), with no library constant in the reference: under a
/// uniaxial strain e = 1e-4 along x (an affine stretch of an 8³ lattice, spacing a),
/// the bonds crossing the mid-plane pull the two halves together (N). In the bulk each
/// a² of the plane carries `C₁₁ e a²`: one axis bond (stretch e a, force k e a) and
/// four face diagonals (x-force k e a / 2 each) of equal springs k, so `C₁₁ = 3k/a`, the
/// axis bond carries `C₁₁ e a²/3` and each diagonal `C₁₁ e a²/6`. The finite lattice
/// has n² axis bonds and 4n(n − 1) diagonals across the plane:
/// `F = C₁₁ e a² (n²/3 + 4n(n − 1)/6)`. Tolerance 1% (measured 0.003%; the LJ bond's
/// nonlinearity at this strain is below 0.1%).
#[test]
fn lj_lattice_stiffness_matches_the_calibration() {
    let scene = Scene::parse(
        r#"
gravity = [0.0, 0.0, 0.0]
[[objects]]
shape = { type = "box", size = [0.2, 0.2, 0.2] }
spacing = 0.025
backend = "lj"
material = { young = 1.0e5, poisson = 0.25 }
"#,
        "lj-stretch",
    )
    .unwrap();
    let w = scene.build(&BuildOptions::default()).unwrap();
    let o = &w.objects[0];
    let mut p = o.phyxels.clone();
    let strain = 1e-4f32;
    let cx = p.rest.iter().map(|x| x.x).sum::<f32>() / p.len() as f32;
    for i in 0..p.len() {
        let r = p.rest.get(i);
        p.pos
            .set(i, Vec3::new(cx + (r.x - cx) * (1.0 + strain), r.y, r.z));
    }
    let mut lj = LjDynamics::new(&p, &o.material);
    lj.compute_forces(&p, &o.material);
    let f = lj.internal_forces();
    let pull: f32 = (0..p.len())
        .filter(|&i| p.rest.get(i).x > cx)
        .map(|i| f.get(i).x)
        .sum();
    let (a, n) = (0.025f32, 8.0f32);
    let c11 = 1.2 * o.material.young;
    let expected = -c11 * strain * a * a * (n * n / 3.0 + 4.0 * n * (n - 1.0) / 6.0);
    println!("pull {pull} N, expected {expected} N");
    assert!(
        (pull / expected - 1.0).abs() < 0.01,
        "pull {pull} N vs {expected} N"
    );
}

/// Brittleness without the topology phase: an LJ bar (0.3 × 0.1 × 0.1 m, E = 100 kPa)
/// whose two halves fly apart at ±5 m/s (far above what its bonds can hold: the wave
/// speed is 11 m/s, so the strain rate tears it) breaks bonds past the cutoff and the
/// halves separate by more than the cutoff; pulled apart at ±1 mm/s (strain of 0.1%
/// over 0.1 s) it breaks none. Integrated by the backend alone, no gravity.
#[test]
fn lj_bonds_break_only_past_the_cutoff() {
    let scene = Scene::parse(
        r#"
gravity = [0.0, 0.0, 0.0]
[[objects]]
shape = { type = "box", size = [0.3, 0.1, 0.1] }
spacing = 0.025
backend = "lj"
material = { young = 1.0e5, poisson = 0.25 }
"#,
        "lj-bar",
    )
    .unwrap();
    let w = scene.build(&BuildOptions::default()).unwrap();
    let o = &w.objects[0];
    for (speed, breaks) in [(5.0f32, true), (1e-3, false)] {
        let mut p = o.phyxels.clone();
        for i in 0..p.len() {
            let s = if p.rest.get(i).x > 0.0 { speed } else { -speed };
            p.vel.set(i, Vec3::new(s, 0.0, 0.0));
        }
        let mut lj = LjDynamics::new(&p, &o.material);
        let dt = 0.9 * lj.stable_dt(&p, &o.material);
        let ctx = phyxel::dynamics::StepContext::new(dt, Vec3::ZERO, &o.material);
        for _ in 0..(0.1 / dt) as usize {
            lj.step(&mut p, &ctx);
        }
        assert!(p.all_finite());
        let (bonds, broken) = lj.bonds();
        let gap = (0..p.len())
            .filter(|&i| p.rest.get(i).x > 0.0)
            .map(|i| p.pos.get(i).x)
            .fold(f32::INFINITY, f32::min)
            - (0..p.len())
                .filter(|&i| p.rest.get(i).x < 0.0)
                .map(|i| p.pos.get(i).x)
                .fold(f32::NEG_INFINITY, f32::max);
        println!("speed {speed}: {broken} of {bonds} bonds broken, gap {gap} m");
        if breaks {
            assert!(broken > 0, "no bond broke at {speed} m/s");
            assert!(gap > 1.5 * 0.025, "the halves did not separate ({gap} m)");
        } else {
            assert_eq!(broken, 0, "bonds broke at {speed} m/s");
        }
    }
}

/// SPH pressure and artificial-viscosity forces (elasticity off) against a brute-force
/// f64 evaluation of the documented formulas (docs/BACKENDS.md: Monaghan 1992 cubic
/// spline with h = a, Tait `p = (K/7)((ρ/ρ⁰)^7 − 1)` with the bulk modulus
/// `K = E/(3(1 − 2ν))` written here, `c = √(K/ρ)`,
/// `f_i = −Σ_j m_i m_j (p_i/ρ_i² + p_j/ρ_j² + Π_ij) ∇_i W_ij`) over all pairs, on a
/// jittered 8³ lattice (±10% of the spacing) with random velocities: this checks the
/// pressure law, the hash-grid neighbours and the eight-lane kernel. Tolerance 1e-3 of
/// the largest force (N).
#[test]
fn sph_pressure_forces_match_a_brute_force_reference() {
    use phyxel::backends::sph::SphOptions;
    let scene = Scene::parse(
        r#"
gravity = [0.0, 0.0, 0.0]
[[objects]]
shape = { type = "box", size = [0.2, 0.2, 0.2] }
spacing = 0.025
backend = "sph"
"#,
        "sph-brute",
    )
    .unwrap();
    let w = scene.build(&BuildOptions::default()).unwrap();
    let o = &w.objects[0];
    let m = &o.material;
    let mut p = o.phyxels.clone();
    let a = 0.025f32;
    let jitter = |i: usize, s: u32| {
        let h = (i as u32).wrapping_mul(2_654_435_761).rotate_left(s) ^ (s * 40503);
        (h % 2001) as f32 / 1000.0 - 1.0
    };
    for i in 0..p.len() {
        let r = p.rest.get(i);
        p.pos.set(
            i,
            r + 0.1 * a * Vec3::new(jitter(i, 3), jitter(i, 11), jitter(i, 19)),
        );
        p.vel.set(
            i,
            0.5 * Vec3::new(jitter(i, 5), jitter(i, 13), jitter(i, 23)),
        );
    }
    let alpha = 0.1;
    let options = SphOptions {
        elasticity: false,
        alpha,
    };
    let mut sph = SphDynamics::with_options(&p, m, options);
    sph.compute_forces(&p, m);
    let got = sph.internal_forces();
    // f64 reference.
    let n = p.len();
    let h = a as f64;
    let sigma = 1.0 / (std::f64::consts::PI * h * h * h);
    let w = |r: f64| {
        let q = r / h;
        if q < 1.0 {
            sigma * (1.0 - 1.5 * q * q + 0.75 * q * q * q)
        } else if q < 2.0 {
            sigma * 0.25 * (2.0 - q).powi(3)
        } else {
            0.0
        }
    };
    let dw = |r: f64| {
        let q = r / h;
        if q < 1.0 {
            sigma / h * (-3.0 * q + 2.25 * q * q)
        } else if q < 2.0 {
            -0.75 * sigma / h * (2.0 - q).powi(2)
        } else {
            0.0
        }
    };
    let x = |c: &phyxel::columns::Vec3s, i: usize| {
        let v = c.get(i);
        [v.x as f64, v.y as f64, v.z as f64]
    };
    let dist = |a: [f64; 3], b: [f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let density = |c: &phyxel::columns::Vec3s| -> Vec<f64> {
        (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| p.mass[j] as f64 * w(dist(x(c, i), x(c, j))))
                    .sum()
            })
            .collect()
    };
    let (rho, rho0) = (density(&p.pos), density(&p.rest));
    let k_bulk = m.young as f64 / (3.0 * (1.0 - 2.0 * m.poisson as f64));
    let c = (k_bulk / m.density as f64).sqrt();
    let pt: Vec<f64> = (0..n)
        .map(|i| k_bulk / 7.0 * ((rho[i] / rho0[i]).powi(7) - 1.0) / (rho[i] * rho[i]))
        .collect();
    let mut worst = 0.0f64;
    let mut largest = 0.0f64;
    for i in 0..n {
        let mut f = [0.0f64; 3];
        for j in 0..n {
            let (xi, xj) = (x(&p.pos, i), x(&p.pos, j));
            let r = dist(xi, xj);
            if j == i || r >= 2.0 * h {
                continue;
            }
            let d = [xi[0] - xj[0], xi[1] - xj[1], xi[2] - xj[2]];
            let (vi, vj) = (x(&p.vel, i), x(&p.vel, j));
            let vx = (0..3).map(|k| (vi[k] - vj[k]) * d[k]).sum::<f64>();
            let mut s = pt[i] + pt[j];
            if vx < 0.0 {
                let mu = h * vx / (r * r + 0.01 * h * h);
                s -= alpha as f64 * c * mu / (0.5 * (rho[i] + rho[j]));
            }
            let coef = p.mass[i] as f64 * p.mass[j] as f64 * s * dw(r) / r;
            (0..3).for_each(|k| f[k] -= d[k] * coef);
        }
        let g = got.get(i);
        let e = ((g.x as f64 - f[0]).powi(2)
            + (g.y as f64 - f[1]).powi(2)
            + (g.z as f64 - f[2]).powi(2))
        .sqrt();
        worst = worst.max(e);
        largest = largest.max((f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt());
    }
    println!("largest force {largest:.3e} N, worst difference {worst:.3e} N");
    assert!(largest > 0.0);
    assert!(
        worst < 1e-3 * largest,
        "difference {worst} N vs {largest} N"
    );
}

/// A coarse Lennard-Jones ball (4 cm spacing) dropped at 5 m/s onto a plane at the
/// default dt: its energy (kinetic + gravitational, J) never rises above the initial
/// one by more than 1% (elastic energy ≥ 0 and damping only dissipate): the bonds'
/// linear wall below `WALL_START` keeps compressed bonds within the stable step's margin.
#[test]
fn fast_lj_impact_gains_no_energy() {
    let scene = Scene::parse(
        r#"
[[objects]]
name = "ball"
shape = { type = "sphere", radius = 0.1 }
spacing = 0.04
position = [0.0, 0.25, 0.0]
velocity = [0.0, -5.0, 0.0]
backend = "lj"
[[objects]]
name = "ground"
shape = { type = "plane", size = [1.0, 1.0] }
spacing = 0.05
static = true
"#,
        "lj-drop",
    )
    .unwrap();
    let mut w = scene.build(&Default::default()).unwrap();
    let energy = |w: &phyxel::World| -> f64 {
        w.objects
            .iter()
            .filter(|o| !o.is_static())
            .map(|o| {
                let p = &o.phyxels;
                let m = p.total_mass();
                p.kinetic_energy() + m * 9.81 * o.phyxels.centre_of_mass()[1]
            })
            .sum()
    };
    let e0 = energy(&w);
    let mut touched = false;
    for step in 0..100 {
        w.step();
        touched |= !w.contact.patches.is_empty();
        let e = energy(&w);
        assert!(
            e <= e0 * 1.01,
            "energy {e} J above the initial {e0} J at step {step}"
        );
    }
    assert!(touched, "the ball never reached the plane");
}

/// The LJ bond's force is minus the derivative of its energy on both sides of the
/// linear wall (central differences, 0.5% relative; f32 round-off), and force and
/// stiffness are continuous where the wall starts (at `WALL_START·r⁰`, 0.5%).
#[test]
fn lj_bond_force_is_minus_the_energy_gradient() {
    use phyxel::backends::lj::{WALL_START, bond};
    let (eps, r0) = (2.0f32, 0.04f32);
    for q in [0.7f32, 0.85, 0.94, 0.97, 1.05, 1.2] {
        let (r, h) = (q * r0, 1e-3 * r0);
        let (f, _) = bond(eps, r0, r);
        let dv = (bond(eps, r0, r + h).1 - bond(eps, r0, r - h).1) / (2.0 * h);
        assert!(
            (f + dv).abs() <= 5e-3 * f.abs(),
            "r = {q} r0: F {f} against -dV/dr {}",
            -dv
        );
    }
    let rw = WALL_START * r0;
    let h = 1e-5 * r0;
    let (below, above) = (bond(eps, r0, rw - h).0, bond(eps, r0, rw + h).0);
    assert!(
        (below - above).abs() <= 5e-3 * above.abs(),
        "force jumps: {below} {above}"
    );
    let k = |r: f32| (bond(eps, r0, r - h).0 - bond(eps, r0, r + h).0) / (2.0 * h);
    let (kb, ka) = (k(rw - 3.0 * h), k(rw + 3.0 * h));
    assert!((kb - ka).abs() <= 5e-3 * ka, "stiffness jumps: {kb} {ka}");
}

/// Every backend of the registry (`backends::NAMES` and `kinematic`) passes the
/// conformance suite (`phyxel::conformance`: momentum, rest, far from the origin,
/// scaling, fragments, thread determinism; references and tolerances in that module's
/// docs). `sph` translates far from the origin within 1e-3 of ½ m v² (measured 5.2e-4:
/// its density and stress sums round relative positions), the others within 1e-5.
#[test]
fn every_backend_in_the_registry_conforms() {
    let mut failures = Vec::new();
    for name in phyxel::backends::NAMES
        .iter()
        .copied()
        .chain([phyxel::backends::KINEMATIC])
    {
        let tolerances = match name {
            "sph" => Tolerances {
                translation: 1e-3,
                ..Default::default()
            },
            _ => Tolerances::default(),
        };
        failures.extend(run(Backend::Named(name), &tolerances));
    }
    let failed: Vec<(&str, Case)> = failures
        .iter()
        .map(|(case, e)| (e.split(',').next().unwrap_or(""), *case))
        .collect();
    assert_eq!(failed, KNOWN_FAILURES, "{failures:#?}");
}

/// Cases a backend is known to fail (docs/ACCURACY.md, "Known limits"): `mls-implicit`
/// gains energy in a free translation at its default dt of 1/120 s — a 10 TPa ball 1 m
/// from the origin ends 2,000 steps with 20 times ½ m v², the 5 µm ball with 6% more.
/// Listed so that the suite runs every backend and a fix shows here.
const KNOWN_FAILURES: [(&str, Case); 2] = [
    ("mls-implicit", Case::FarFromOrigin),
    ("mls-implicit", Case::Scaling),
];
