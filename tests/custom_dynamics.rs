//! Embedding proof: a backend written outside the crate, against the public API only,
//! drives objects through the same step (dynamics, surfel advection, contact phases).

use glam::{Mat3, Vec3};
use phyxel::body::shape::Shape;
use phyxel::columns::Vec3s;
use phyxel::dynamics::{Dynamics, StepContext, integrate_symplectic};
use phyxel::material::Material;
use phyxel::points::phyxels::Phyxels;
use phyxel::points::surfels::Surfels;
use phyxel::spatial::grid::Grid;
use phyxel::{Object, World};

/// Damped springs between rest neighbours (a mass-spring solid).
struct Springs {
    pairs: Vec<(u32, u32, f32)>,
    stiffness: f32,
    damping: f32,
    force: Vec3s,
}

impl Springs {
    fn new(p: &Phyxels, stiffness: f32, damping: f32) -> Self {
        let grid = Grid::build(p.rest.iter(), p.spacing[0] * 1.5);
        let mut pairs = Vec::new();
        for i in 0..p.len() {
            grid.for_each_within(p.rest.get(i), p.spacing[i] * 1.5, |j, d2| {
                if j > i {
                    pairs.push((i as u32, j as u32, d2.sqrt()));
                }
            });
        }
        Self {
            pairs,
            stiffness,
            damping,
            force: Vec3s::zeros(p.len()),
        }
    }
}

impl Dynamics for Springs {
    fn name(&self) -> &str {
        "springs"
    }

    fn step(&mut self, p: &mut Phyxels, ctx: &StepContext<'_>) {
        self.force.fill_zero();
        for &(i, j, rest) in &self.pairs {
            let (i, j) = (i as usize, j as usize);
            let d = p.pos.get(j) - p.pos.get(i);
            let len = d.length().max(1e-12);
            let n = d / len;
            let rel = (p.vel.get(j) - p.vel.get(i)).dot(n);
            let f = n * (self.stiffness * (len - rest) + self.damping * rel);
            self.force.add(i, f);
            self.force.add(j, -f);
        }
        integrate_symplectic(p, &self.force, ctx);
    }

    fn stable_dt(&self, p: &Phyxels, _m: &Material) -> f32 {
        let m = p.mass[..p.len()]
            .iter()
            .fold(f32::INFINITY, |a, &b| a.min(b));
        0.2 * (m / self.stiffness).sqrt()
    }
}

fn spring_ball(id: u32, centre: Vec3, velocity: Vec3) -> Object {
    let shape = Shape::Sphere { radius: 0.1 };
    let vol = shape.sample_volume(0.025);
    let surf = shape.sample_surface(0.01);
    let material = Material::default();
    let pts: Vec<Vec3> = vol.positions.iter().map(|&x| x + centre).collect();
    let mut p = Phyxels::at_rest(&pts, vol.cell_volume, material.density);
    for i in 0..p.len() {
        p.vel.set(i, velocity);
    }
    let s_pts: Vec<Vec3> = surf.positions.iter().map(|&x| x + centre).collect();
    let surfels = Surfels::at_rest(&s_pts, &surf.normals, &surf.radii);
    let dynamics = Box::new(Springs::new(&p, 2000.0, 0.5));
    Object::new(id, format!("ball{id}"), surfels, p, material, dynamics)
}

/// A user backend (the `Springs` above) runs through `World::step`: two spring balls
/// (R = 0.1 m) fly for 0.2 s without gravity, at 1.02 and 0.51 m/s, and do not meet.
/// Checked: every value stays finite; each component of the total momentum stays within
/// 1e-5 of `Σ_k |p₀,k|` (kg·m/s) of its start (the springs obey Newton's third law;
/// measured: 8e-8 of it, f32 round-off); every object still runs the user backend;
/// and each ball's surfels travel with it: their centroid moves more than 0.05 m from its
/// rest position (the balls travel 0.20 and 0.10 m) and stays within 1% of the radius
/// (1 mm) of the phyxel centre of mass (measured: 1.1e-7 and 1.9e-7 m). The balls only
/// translate (undeformed springs), so this checks the translation of the surfels, not
/// the core's gradient estimate for a backend without one; that is
/// `gradientless_backend_surfels_follow_affine_motion`.
#[test]
fn user_backend_drives_the_pipeline() {
    let objects = vec![
        spring_ball(0, Vec3::new(-0.3, 0.0, 0.0), Vec3::new(1.0, 0.2, 0.0)),
        spring_ball(1, Vec3::new(0.3, 0.0, 0.0), Vec3::new(-0.5, 0.0, 0.1)),
    ];
    let mut world = World::new(objects, Vec3::ZERO, 0.0);
    world.dt = world.stable_dt().0;
    let p0 = world.momentum();
    let steps = (0.2 / world.dt) as usize;
    for _ in 0..steps {
        world.step();
    }
    assert!(world.all_finite());
    let p1 = world.momentum();
    let scale = p0.iter().map(|c| c.abs()).sum::<f64>();
    println!("momentum {p0:?} -> {p1:?} kg·m/s");
    for k in 0..3 {
        assert!(
            (p1[k] - p0[k]).abs() < 1e-5 * scale,
            "momentum {p0:?} -> {p1:?}"
        );
    }
    for o in &world.objects {
        assert_eq!(o.dynamics.name(), "springs");
        let c = o.phyxels.centre_of_mass();
        let s: Vec3 = o.surfels.pos.iter().sum::<Vec3>() / o.surfels.len() as f32;
        let off = (s - Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32)).length();
        println!(
            "{}: surfel centroid {off:.2e} m from the centre of mass",
            o.name
        );
        assert!(
            off < 0.01 * 0.1,
            "surfel centroid {s} is {off} m from the centre of mass"
        );
        let moved = (s - o.surfels.rest.iter().sum::<Vec3>() / o.surfels.len() as f32).length();
        assert!(
            moved > 0.05,
            "surfels did not follow the phyxels (moved {moved} m)"
        );
    }
}

/// A backend without a displacement gradient (the springs) still gets exact surfel
/// advection from the core's MLS estimate (`Object::advect_surfels`, linear basis, exact
/// for affine fields): with the phyxels placed at `x = F x₀ + c` (stretch, shear and
/// rotation of a few percent, c = (0.1, −0.2, 0.05) m), every surfel lands at `F s₀ + c` to 1e-4 of
/// the 0.1 m radius (f32 positions; measured 7e-8 m) and its normal at
/// `normalize(F⁻ᵀ n₀)` to 1e-4 (measured 3e-7). With the estimate left out (zero
/// gradient) the first surfel is already 7e-4 m off.
#[test]
fn gradientless_backend_surfels_follow_affine_motion() {
    let mut obj = spring_ball(0, Vec3::new(0.05, -0.02, 0.03), Vec3::ZERO);
    assert!(obj.dynamics.displacement_gradient().is_none());
    let f = Mat3::from_cols_array(&[1.05, 0.02, 0.0, -0.03, 0.97, 0.01, 0.0, 0.04, 1.02]);
    let c = Vec3::new(0.1, -0.2, 0.05);
    for i in 0..obj.phyxels.len() {
        let x = obj.phyxels.rest.get(i);
        obj.phyxels.pos.set(i, f * x + c);
    }
    obj.advect_surfels();
    let f_inv_t = f.inverse().transpose();
    let (mut worst, mut worst_n) = (0.0f32, 0.0f32);
    for i in 0..obj.surfels.len() {
        let want = f * obj.surfels.rest.get(i) + c;
        let err = (obj.surfels.pos.get(i) - want).length();
        worst = worst.max(err);
        assert!(err < 1e-4 * 0.1, "surfel {i}: position error {err:e} m");
        let n = (f_inv_t * obj.surfels.rest_normal.get(i)).normalize();
        let nerr = (obj.surfels.normal.get(i) - n).length();
        worst_n = worst_n.max(nerr);
        assert!(nerr < 1e-4, "surfel {i}: normal error {nerr:e}");
    }
    println!("gradient-less advection: position error {worst:e} m, normal error {worst_n:e}");
}

/// The built-in `two-spheres` scene with every object's backend replaced by the user's
/// springs (`Object::dynamics` is public): the spheres meet, the contact pipeline pushes
/// them apart (x velocities reversed), and the total momentum stays at its initial value
/// (zero) to 1e-5 of one sphere's `m v` (kg·m/s) through the collision.
#[test]
fn user_backend_runs_the_two_spheres_scene() {
    let mut scene = phyxel::scene::Scene::builtin("two-spheres").unwrap();
    for o in &mut scene.objects {
        o.surfel_spacing = Some(0.01); // coarser surfels: a faster test
    }
    let mut world = scene.build(&Default::default()).unwrap();
    for o in &mut world.objects {
        o.dynamics = Box::new(Springs::new(&o.phyxels, 2000.0, 0.5));
    }
    world.dt = 0.9 * world.stable_dt().0;
    let scale = world.objects[0].phyxels.total_mass() * 1.0;
    let steps = (0.25 / world.dt) as usize;
    let (mut contact, mut worst) = (0, 0.0f64);
    for _ in 0..steps {
        world.step();
        contact += !world.patches.is_empty() as usize;
        let p = world.momentum();
        worst = worst.max((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() / scale);
    }
    assert!(world.all_finite());
    assert!(contact > 5, "the spheres never touched");
    assert!(worst < 1e-5, "momentum drift {worst:e} of m v");
    let vx = |k: usize| world.objects[k].phyxels.momentum()[0];
    assert!(
        vx(0) < 0.0 && vx(1) > 0.0,
        "the spheres did not bounce apart: {} {}",
        vx(0),
        vx(1)
    );
    assert!(world.objects.iter().all(|o| o.dynamics.name() == "springs"));
}

/// A backend that reports the given bound, which is not usable (NaN, 0 or negative).
struct NoBound(f32);

impl Dynamics for NoBound {
    fn name(&self) -> &str {
        "no-bound"
    }

    fn step(&mut self, p: &mut Phyxels, ctx: &StepContext<'_>) {
        let zero = Vec3s::zeros(p.len());
        integrate_symplectic(p, &zero, ctx);
    }

    fn stable_dt(&self, _p: &Phyxels, _m: &Material) -> f32 {
        self.0
    }
}

/// A NaN, zero or negative stable bound from a user backend is reported by
/// `World::stable_dt` with its object, not skipped (`f32::min` drops NaN, which would
/// report the other object's bound).
#[test]
fn an_unusable_bound_is_reported() {
    for bad in [f32::NAN, 0.0, -1.0] {
        let mut broken = spring_ball(1, Vec3::new(0.3, 0.0, 0.0), Vec3::ZERO);
        broken.dynamics = Box::new(NoBound(bad));
        let world = World::new(
            vec![
                spring_ball(0, Vec3::new(-0.3, 0.0, 0.0), Vec3::ZERO),
                broken,
            ],
            Vec3::ZERO,
            1e-4,
        );
        let (dt, limiter) = world.stable_dt();
        assert!(
            dt.is_nan() == bad.is_nan() && (bad.is_nan() || dt == bad),
            "{bad}: {dt}"
        );
        assert_eq!(limiter, Some(1), "{bad}");
    }
}

/// `World::step` refuses a time step that is not a finite number > 0 (`World::new`
/// takes it as given) instead of running backwards, freezing or turning NaN.
#[test]
#[should_panic(expected = "World::dt = 0: must be a finite number > 0")]
fn stepping_with_a_zero_dt_panics() {
    let mut world = World::new(
        vec![spring_ball(0, Vec3::ZERO, Vec3::ZERO)],
        Vec3::ZERO,
        0.0,
    );
    world.step();
}

/// Replacing an object's phyxel columns with another count (they are public) is named
/// as such by `World::step`, not an index panic inside the advection.
#[test]
#[should_panic(
    expected = "object 'ball0' (id 0) has 1257 surfels and 432 phyxels but was \
                           built with 1257 and 280"
)]
fn replacing_the_phyxels_with_another_count_panics_clearly() {
    let mut world = World::new(
        vec![spring_ball(0, Vec3::ZERO, Vec3::ZERO)],
        Vec3::ZERO,
        1e-4,
    );
    let finer = Shape::Sphere { radius: 0.1 }.sample_volume(0.0215);
    let o = &mut world.objects[0];
    o.phyxels = Phyxels::at_rest(&finer.positions, finer.cell_volume, 1000.0);
    world.step();
}

/// A column built by hand with the wrong length (a `collect` one short of the count, or
/// without the SIMD padding) is named by `Object::new`, not an index panic inside the
/// dynamics.
#[test]
#[should_panic(expected = "Object::new 'ball': phyxels.fixed holds 279 entries, not 280")]
fn an_unpadded_column_is_named() {
    let b = spring_ball(0, Vec3::ZERO, Vec3::ZERO);
    let mut p = b.phyxels.clone();
    let n = p.len();
    p.fixed = (0..n).map(|i| (p.pos.get(i).y > 0.09) as u8).collect();
    p.fixed.pop(); // one short of the point count (280: a multiple of 8, no padding)
    Object::new(
        0,
        "ball",
        b.surfels.clone(),
        p,
        Material::default(),
        Box::new(NoBound(f32::NAN)),
    );
}

/// A backend whose force buffer was built for no phyxels (or for another object):
/// `integrate_symplectic` says so with both counts, not "range end index 8 out of range
/// for slice of length 0" from a SIMD lane load.
#[test]
#[should_panic(
    expected = "integrate_symplectic: the internal forces hold 0 points, the phyxels 280"
)]
fn a_force_buffer_of_the_wrong_size_is_named() {
    struct Unsized(Vec3s);
    impl Dynamics for Unsized {
        fn name(&self) -> &str {
            "unsized"
        }
        fn step(&mut self, p: &mut Phyxels, ctx: &StepContext<'_>) {
            integrate_symplectic(p, &self.0, ctx);
        }
        fn stable_dt(&self, _p: &Phyxels, _m: &Material) -> f32 {
            1e-3
        }
    }
    let mut b = spring_ball(0, Vec3::ZERO, Vec3::ZERO);
    b.dynamics = Box::new(Unsized(Vec3s::zeros(0)));
    let mut world = World::new(vec![b], Vec3::ZERO, 1e-4);
    world.step();
}

/// A surfel disk radius of 0 would make every kernel weight of the surface zero (the
/// object would pass through others): refused, naming the surfel.
#[test]
#[should_panic(expected = "Object::new 'ball': surfels.radius[3] = 0: must be finite and > 0")]
fn a_zero_surfel_radius_is_refused() {
    let b = spring_ball(0, Vec3::ZERO, Vec3::ZERO);
    let mut s = b.surfels.clone();
    s.radius[3] = 0.0;
    Object::new(
        0,
        "ball",
        s,
        b.phyxels.clone(),
        Material::default(),
        Box::new(NoBound(f32::NAN)),
    );
}

/// Two objects with one id would share the static caches and collide with fragment
/// ids: `World::step` names both.
#[test]
#[should_panic(expected = "objects 'ball3' and 'ball3' share the id 3")]
fn duplicate_object_ids_are_named() {
    let mut world = World::new(
        vec![spring_ball(3, Vec3::new(-0.5, 0.0, 0.0), Vec3::ZERO)],
        Vec3::ZERO,
        1e-4,
    );
    world.step();
    world
        .objects
        .push(spring_ball(3, Vec3::new(0.5, 0.0, 0.0), Vec3::ZERO));
    world.step();
}

/// A material made invalid after `Object::new` (the field is public) is refused by the
/// next step, naming the object, rather than stepped with Young's modulus 0.
#[test]
#[should_panic(expected = "object 'ball0' (id 0): invalid material: young = 0")]
fn a_material_made_invalid_later_is_named() {
    let mut world = World::new(
        vec![spring_ball(0, Vec3::ZERO, Vec3::ZERO)],
        Vec3::ZERO,
        1e-4,
    );
    world.objects[0].material.young = 0.0;
    world.step();
}

/// `World::time` is the sum of the steps' dt, also when dt changes between steps (the
/// load ramp reads it; `steps · dt` would not be the elapsed time).
#[test]
fn world_time_sums_the_steps() {
    let mut world = World::new(
        vec![spring_ball(0, Vec3::ZERO, Vec3::ZERO)],
        Vec3::ZERO,
        1e-4,
    );
    for dt in [1e-4f32, 5e-5, 2e-4] {
        world.dt = dt;
        world.step();
    }
    let want = 1e-4f32 as f64 + 5e-5f32 as f64 + 2e-4f32 as f64;
    assert!(
        (world.time - want).abs() < 1e-15,
        "{} against {want}",
        world.time
    );
}

/// Phyxels built with another density than the material's (the backends' bounds read
/// the material, the forces the masses: SPH's bound comes out about 30 times too large
/// for a 1000-fold mismatch) are refused, naming the phyxel and both figures.
#[test]
#[should_panic(expected = "phyxel 0 has mass")]
fn a_mass_that_is_not_density_times_volume_is_refused() {
    let b = spring_ball(0, Vec3::ZERO, Vec3::ZERO);
    let vol = Shape::Sphere { radius: 0.1 }.sample_volume(0.025);
    let light = Phyxels::at_rest(&vol.positions, vol.cell_volume, 1.0);
    Object::new(
        0,
        "ball",
        b.surfels.clone(),
        light,
        Material::default(),
        Box::new(NoBound(f32::NAN)),
    );
}

/// `BuildOptions::backend` takes the names of `backends::NAMES` only (`"static"` would
/// freeze every object without a word).
#[test]
fn unknown_backend_override_is_an_error() {
    let scene = phyxel::scene::Scene::builtin("two-spheres").unwrap();
    for name in ["static", "nope"] {
        let opts = phyxel::scene::BuildOptions {
            backend: Some(name.to_string()),
            ..Default::default()
        };
        let e = scene.build(&opts).expect_err("refused").to_string();
        assert!(e.contains(&format!("backend override \"{name}\"")), "{e}");
    }
}

/// A scene changed in code is checked by `Scene::build` as a file would be by
/// `Scene::load`: errors naming the field, not a panic in sampling or a NaN world.
#[test]
fn a_scene_changed_in_code_is_checked_by_build() {
    let base = phyxel::scene::Scene::builtin("two-spheres").unwrap();
    let mut negative = base.clone();
    negative.objects[0].spacing = -0.05;
    let mut soft = base.clone();
    soft.objects[1].material.young = 0.0;
    let mut nan = base.clone();
    nan.gravity = [f32::NAN; 3];
    for (scene, want) in [
        (negative, "objects[0]"),
        (soft, "objects[1].material"),
        (nan, "gravity"),
    ] {
        let e = scene
            .build(&Default::default())
            .expect_err(want)
            .to_string();
        assert!(e.starts_with("two-spheres: ") && e.contains(want), "{e}");
    }
}

/// `Object::new` refuses a material `Material::validate` refuses (here Young's modulus
/// 0), naming the object, instead of a body that turns NaN a few steps later.
#[test]
#[should_panic(expected = "Object::new 'soft': invalid material: young = 0")]
fn object_with_an_invalid_material_panics() {
    let ball = spring_ball(0, Vec3::ZERO, Vec3::ZERO);
    let material = Material {
        young: 0.0,
        ..Material::default()
    };
    Object::new(
        1,
        "soft",
        ball.surfels,
        ball.phyxels,
        material,
        Box::new(NoBound(f32::NAN)),
    );
}

/// Springs that, from their `at`-th step, write NaN into one phyxel's velocity, or
/// (with `gradient`) into its displacement gradient only (broken user backends).
struct Poisoned {
    springs: Springs,
    steps: u32,
    at: u32,
    phyxel: usize,
    /// `Some`: report this gradient (zero, NaN at `phyxel` from step `at`) and leave the
    /// velocities alone.
    gradient: Option<Vec<Mat3>>,
}

impl Poisoned {
    fn new(p: &Phyxels, at: u32, phyxel: usize, gradient: bool) -> Self {
        Self {
            springs: Springs::new(p, 2000.0, 0.5),
            steps: 0,
            at,
            phyxel,
            gradient: gradient.then(|| vec![Mat3::ZERO; p.len()]),
        }
    }
}

impl Dynamics for Poisoned {
    fn name(&self) -> &str {
        "poisoned"
    }

    fn step(&mut self, p: &mut Phyxels, ctx: &StepContext<'_>) {
        self.springs.step(p, ctx);
        self.steps += 1;
        if self.steps == self.at {
            match &mut self.gradient {
                Some(g) => g[self.phyxel] = Mat3::from_diagonal(Vec3::splat(f32::NAN)),
                None => p.vel.set(self.phyxel, Vec3::new(0.0, f32::NAN, 0.0)),
            }
        }
    }

    fn stable_dt(&self, p: &Phyxels, m: &Material) -> f32 {
        self.springs.stable_dt(p, m)
    }

    fn displacement_gradient(&self) -> Option<&[Mat3]> {
        self.gradient.as_deref()
    }
}

/// A backend that writes NaN is caught at the end of that very step, by object, backend,
/// phyxel and quantity (`World::non_finite`), before contact could carry it into the
/// other object: `None` for the steps before, then exactly the injected value.
#[test]
fn a_backend_nan_is_reported_at_its_step() {
    let mut broken = spring_ball(1, Vec3::new(0.3, 0.0, 0.0), Vec3::new(-1.0, 0.0, 0.0));
    broken.dynamics = Box::new(Poisoned::new(&broken.phyxels, 4, 7, false));
    let objects = vec![
        spring_ball(0, Vec3::new(-0.3, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0)),
        broken,
    ];
    let mut world = World::new(objects, Vec3::ZERO, 0.0);
    world.dt = world.stable_dt().0;
    for _ in 0..3 {
        world.step();
        assert_eq!(world.non_finite, None, "step {}", world.steps);
    }
    world.step();
    let e = world
        .non_finite
        .clone()
        .expect("the NaN of step 4 is reported");
    assert_eq!(
        (e.step, e.object_id, e.object.as_str(), e.backend.as_str()),
        (4, 1, "ball1", "poisoned")
    );
    assert_eq!((e.index, e.quantity), (7, "phyxel velocity"));
    assert_eq!(e.source(), "the dynamics step");
    world.step();
    assert_eq!(world.non_finite, Some(e), "the first event is kept");
}

/// A backend whose displacement gradient turns NaN while its phyxels stay finite: the
/// surfels it advects are caught in that step (by the broad phase's box), as surfel
/// positions written by the advection.
#[test]
fn a_nan_gradient_is_reported_as_the_surfels() {
    let mut broken = spring_ball(0, Vec3::ZERO, Vec3::new(-1.0, 0.0, 0.0));
    broken.dynamics = Box::new(Poisoned::new(&broken.phyxels, 3, 7, true));
    let mut world = World::new(vec![broken], Vec3::ZERO, 0.0);
    world.dt = world.stable_dt().0;
    for _ in 0..4 {
        world.step();
    }
    let e = world
        .non_finite
        .clone()
        .expect("the NaN gradient of step 3 is reported");
    assert_eq!((e.step, e.quantity), (3, "surfel position"));
    assert_eq!(e.source(), "the surfel advection");
    assert!(world.objects[0].phyxels.all_finite());
}

/// A blown-up object takes no part in contact: after its backend writes NaN (step 4),
/// its box overlaps nothing, so the other ball, which would have hit it (the same balls
/// unpoisoned are paired: reference run), stays finite and is never paired with it,
/// whether the broken ball comes first or second in the object list.
#[test]
fn a_blown_up_object_takes_no_part_in_contact() {
    let run = |poisoned: Option<usize>| {
        let mut balls = vec![
            spring_ball(0, Vec3::new(-0.15, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0)),
            spring_ball(1, Vec3::new(0.15, 0.0, 0.0), Vec3::new(-1.0, 0.0, 0.0)),
        ];
        if let Some(k) = poisoned {
            balls[k].dynamics = Box::new(Poisoned::new(&balls[k].phyxels, 4, 7, false));
        }
        let mut world = World::new(balls, Vec3::ZERO, 0.0);
        world.dt = world.stable_dt().0;
        let mut touched = 0;
        for _ in 0..(0.15 / world.dt) as usize {
            world.step();
            touched += !world.pairs.is_empty() as usize;
        }
        (world, touched)
    };
    let (_, touched) = run(None);
    assert!(touched > 0, "the reference balls never touched");
    for k in 0..2 {
        let (world, touched) = run(Some(k));
        let e = world.non_finite.as_ref().expect("reported");
        assert_eq!((e.step, e.object_id), (4, k as u32));
        assert_eq!(
            touched, 0,
            "the blown-up ball {k} still took part in contact"
        );
        let other = &world.objects[1 - k];
        assert!(
            other.phyxels.all_finite() && other.surfels.all_finite(),
            "NaN spread from ball {k}"
        );
    }
}

/// `World` and `Object` print a summary with `{:?}` (the columns are too long to print):
/// each object's name, backend and counts, and the step.
#[test]
fn world_debug_prints_a_summary() {
    let mut world = World::new(
        vec![spring_ball(0, Vec3::ZERO, Vec3::ZERO)],
        Vec3::ZERO,
        1e-4,
    );
    world.step();
    let text = format!("{world:?}");
    let o = &world.objects[0];
    for part in [
        "name: \"ball0\"".to_string(),
        "backend: \"springs\"".to_string(),
        format!("surfels: {}", o.surfels.len()),
        format!("phyxels: {}", o.phyxels.len()),
        "steps: 1".to_string(),
    ] {
        assert!(text.contains(&part), "{text} lacks {part}");
    }
    assert!(
        text.len() < 2000,
        "not a summary: {} characters",
        text.len()
    );
}

/// Springs that may break, with or without their own `fragment`.
struct BreakingSprings {
    springs: Springs,
    own_fragment: bool,
}

impl Dynamics for BreakingSprings {
    fn name(&self) -> &str {
        "breaking-springs"
    }

    fn step(&mut self, p: &mut Phyxels, ctx: &StepContext<'_>) {
        self.springs.step(p, ctx);
    }

    fn stable_dt(&self, p: &Phyxels, m: &Material) -> f32 {
        self.springs.stable_dt(p, m)
    }

    fn can_fracture(&self, _m: &Material) -> bool {
        true
    }

    fn fragment(&self, p: &Phyxels, _m: &Material) -> Option<Box<dyn Dynamics>> {
        self.own_fragment.then(|| {
            Box::new(BreakingSprings {
                springs: Springs::new(p, 2000.0, 0.5),
                own_fragment: true,
            }) as Box<dyn Dynamics>
        })
    }
}

/// A user backend that may fracture splits through its own `Dynamics::fragment`: a ball
/// torn in two (its x > 0 half moved 1 m away) becomes two objects driven by the user's
/// backend, with the mass conserved; without an override (the default declines) it
/// stays whole.
#[test]
fn a_user_backend_fractures_through_fragment() {
    for own in [true, false] {
        let mut ball = spring_ball(0, Vec3::ZERO, Vec3::ZERO);
        ball.dynamics = Box::new(BreakingSprings {
            springs: Springs::new(&ball.phyxels, 2000.0, 0.5),
            own_fragment: own,
        });
        let mut world = World::new(vec![ball], Vec3::ZERO, 1e-4);
        let mass = world.objects[0].phyxels.total_mass();
        world.step();
        let p = &mut world.objects[0].phyxels;
        for i in 0..p.len() {
            if p.pos.get(i).x > 0.0 {
                p.pos.set(i, p.pos.get(i) + Vec3::X);
            }
        }
        world.step();
        let names: Vec<&str> = world.objects.iter().map(|o| o.dynamics.name()).collect();
        if own {
            assert_eq!(names, ["breaking-springs"; 2], "split into two pieces");
            let after: f64 = world.objects.iter().map(|o| o.phyxels.total_mass()).sum();
            assert!((after - mass).abs() < 1e-9 * mass, "mass {mass} -> {after}");
        } else {
            assert_eq!(names, ["breaking-springs"], "no fragment: kept whole");
        }
    }
}

/// A phyxel mass overwritten with NaN after `Object::new` (the column is public) is
/// refused by the next step, naming the object and the phyxel: it makes the momentum
/// and energy NaN while every position stays finite.
#[test]
#[should_panic(expected = "object 'ball0' (id 0): phyxels.mass[3] = NaN")]
fn a_mass_made_nan_later_is_named() {
    let mut world = World::new(
        vec![spring_ball(0, Vec3::ZERO, Vec3::ZERO)],
        Vec3::ZERO,
        1e-4,
    );
    world.objects[0].phyxels.mass[3] = f32::NAN;
    world.step();
}

/// A zero surfel normal is refused by `Object::new`: detection reads normals as
/// directions, and two balls with zero normals pass through each other silently.
#[test]
#[should_panic(expected = "Object::new 'ball': surfel 7 has a normal of length 0")]
fn a_zero_surfel_normal_is_refused() {
    let b = spring_ball(0, Vec3::ZERO, Vec3::ZERO);
    let mut s = b.surfels.clone();
    s.normal.set(7, Vec3::ZERO);
    Object::new(
        0,
        "ball",
        s,
        b.phyxels.clone(),
        Material::default(),
        Box::new(NoBound(f32::NAN)),
    );
}

/// A backend that drops a phyxel inside its step.
struct Shrinking;

impl Dynamics for Shrinking {
    fn name(&self) -> &str {
        "shrinking"
    }

    fn step(&mut self, p: &mut Phyxels, _ctx: &StepContext<'_>) {
        let keep: Vec<usize> = (0..p.len() - 1).collect();
        *p = p.gather(&keep);
    }

    fn stable_dt(&self, _p: &Phyxels, _m: &Material) -> f32 {
        f32::INFINITY
    }
}

/// A backend that changes the phyxel count in its step is named right after it, not by
/// an index panic in the surfel advection ("the len is 279 but the index is 279").
#[test]
#[should_panic(
    expected = "after backend 'shrinking': object 'ball0' (id 0) has 1257 surfels \
                           and 279 phyxels but was built with 1257 and 280"
)]
fn a_backend_that_changes_the_count_is_named() {
    let mut ball = spring_ball(0, Vec3::ZERO, Vec3::ZERO);
    ball.dynamics = Box::new(Shrinking);
    let mut world = World::new(vec![ball], Vec3::ZERO, 1e-4);
    world.step();
}

/// Gravity must be finite: `World::new` refuses NaN, as it is refused in scene files.
#[test]
#[should_panic(expected = "World::new: gravity = [NaN, -9.81, 0]: must be finite")]
fn a_nan_gravity_is_refused() {
    World::new(
        vec![spring_ball(0, Vec3::ZERO, Vec3::ZERO)],
        Vec3::new(f32::NAN, -9.81, 0.0),
        1e-4,
    );
}

/// The object's spacings are public fields that the grids and the contact read: a
/// carrier spacing of 0 is named by the next step, not by a grid's "cell size must be
/// > 0" panic inside the contact phases.
#[test]
#[should_panic(expected = "object 'ball0' (id 0): carrier_spacing = 0: must be finite and > 0")]
fn a_zero_carrier_spacing_is_named() {
    let mut world = World::new(
        vec![spring_ball(0, Vec3::ZERO, Vec3::ZERO)],
        Vec3::ZERO,
        1e-4,
    );
    world.objects[0].carrier_spacing = 0.0;
    world.step();
}

/// A contact phase run alone after the object list changed would read the last broad
/// phase's pairs, which name objects by index: it is refused with what to run first,
/// not an index panic inside `detect`.
#[test]
#[should_panic(
    expected = "World::run_phase(Detect): the objects changed since the last broad phase"
)]
fn a_contact_phase_after_removing_an_object_is_refused() {
    let mut world = World::new(
        vec![
            spring_ball(0, Vec3::new(-0.099, 0.0, 0.0), Vec3::ZERO),
            spring_ball(1, Vec3::new(0.099, 0.0, 0.0), Vec3::ZERO),
        ],
        Vec3::ZERO,
        1e-4,
    );
    world.step();
    assert_eq!(world.pairs.len(), 1);
    world.objects.remove(0);
    world.run_phase(phyxel::world::Phase::Detect);
}

/// A user's backend runs the library's conformance suite (`phyxel::conformance`) as the
/// built-in ones do: momentum in a collision, a body at rest, a rigid translation far
/// from the origin and thread determinism (references and tolerances in that module).
/// The springs' stable bound does not scale with the body (their stiffness is a fixed
/// 2,000 N/m), and their constructor reads `spacing[0]` (no empty fragments), so the
/// scaling and fragment cases are not asked.
#[test]
fn a_user_backend_runs_the_conformance_suite() {
    use phyxel::conformance::{Backend, Case, Tolerances, check};
    let factory = |p: &Phyxels, _m: &Material| -> Box<dyn Dynamics> {
        Box::new(Springs::new(p, 2000.0, 0.5))
    };
    let backend = Backend::Custom {
        name: "springs",
        factory: &factory,
        prescribed: false,
    };
    for case in [
        Case::Momentum,
        Case::Rest,
        Case::FarFromOrigin,
        Case::Threads,
    ] {
        check(case, backend, &Tolerances::default()).unwrap();
    }
}
