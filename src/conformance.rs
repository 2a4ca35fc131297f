//! The conformance suite: what every dynamics backend must do on the contact pipeline,
//! run for each built-in backend by `tests/dynamics/backends.rs` and callable for a backend of
//! your own ([`run`] with [`Backend::Custom`], as `tests/custom_dynamics.rs` does).
//!
//! | case | scene | reference | passes when |
//! |---|---|---|---|
//! | [`Case::Momentum`] | two balls colliding, no gravity, 0.2 s | Newton's third law | total momentum within `momentum` × one ball's `m v` at every step; they touch and part |
//! | [`Case::Rest`] | a ball at rest, E = 1e5 and 1e15 Pa, 100 steps | no strain, no force | kinetic energy exactly 0 J |
//! | [`Case::FarFromOrigin`] | a stiff ball 1 m out, 1 m/s, 2,000 steps | rigid translation | energy ½ m v² within `translation`, moved v t within 1e-3 |
//! | [`Case::Scaling`] | a 5 mm and a 5 µm ball | t ∝ L (same material) | stable bounds in ratio 1e-3 within 1e-3; energy within 1e-4 over 100 steps |
//! | [`Case::Fragments`] | 0, 1 and 2 phyxels from the backend's constructor | free fall | steps finite; a lone free phyxel has `v = g t` within 1e-5 |
//! | [`Case::Threads`] | two balls colliding, 1 and 2 threads | determinism | the same bits |
//!
//! A prescribed-motion backend (`kinematic`) is not asked for momentum in a collision
//! (it takes any impulse) nor to fall ([`Backend::prescribed`]).

use crate::World;
use crate::dynamics::Dynamics;
use crate::material::Material;
use crate::points::phyxels::Phyxels;
use crate::scene::{BuildOptions, Scene};
use glam::Vec3;

/// Builds the backend under test for an object's phyxels and material.
pub type Factory = dyn Fn(&Phyxels, &Material) -> Box<dyn Dynamics> + Sync;

/// The backend under test.
#[derive(Clone, Copy)]
pub enum Backend<'a> {
    /// A name of the registry ([`crate::backends::NAMES`] or `kinematic`): objects are
    /// built as a scene naming it builds them (its sampling included).
    Named(&'a str),
    /// A caller's backend, put on every moving object of a scene built for `mls`.
    Custom {
        name: &'a str,
        factory: &'a Factory,
        /// Its motion is prescribed (a tool): no momentum or free-fall checks.
        prescribed: bool,
    },
}

impl Backend<'_> {
    /// The label of the backend in messages.
    pub fn name(&self) -> &str {
        match self {
            Backend::Named(n) | Backend::Custom { name: n, .. } => n,
        }
    }

    /// Its motion is prescribed rather than integrated (`kinematic`).
    pub fn prescribed(&self) -> bool {
        match self {
            Backend::Named(n) => *n == crate::backends::KINEMATIC,
            Backend::Custom { prescribed, .. } => *prescribed,
        }
    }
}

/// Relative tolerances of the suite's checks that depend on the method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerances {
    /// Momentum drift in a collision, relative to one ball's `m v`.
    pub momentum: f64,
    /// Energy error of a rigid translation far from the origin, relative to ½ m v².
    pub translation: f64,
}

impl Default for Tolerances {
    fn default() -> Self {
        Self {
            momentum: 1e-4,
            translation: 1e-5,
        }
    }
}

/// The cases of the suite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Case {
    Momentum,
    Rest,
    FarFromOrigin,
    Scaling,
    Fragments,
    Threads,
}

impl Case {
    pub const ALL: [Case; 6] = [
        Case::Momentum,
        Case::Rest,
        Case::FarFromOrigin,
        Case::Scaling,
        Case::Fragments,
        Case::Threads,
    ];
}

/// Runs every case for `backend`; returns each failing case with its message (empty:
/// the backend conforms).
pub fn run(backend: Backend<'_>, tolerances: &Tolerances) -> Vec<(Case, String)> {
    Case::ALL
        .into_iter()
        .filter_map(|case| check(case, backend, tolerances).err().map(|e| (case, e)))
        .collect()
}

/// Runs one case; a panic in it is its failure.
pub fn check(case: Case, backend: Backend<'_>, tolerances: &Tolerances) -> Result<(), String> {
    let name = backend.name();
    // A backend that panics fails the case with the panic's message.
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match case {
        Case::Momentum => momentum(backend, tolerances),
        Case::Rest => rest(backend),
        Case::FarFromOrigin => far_from_origin(backend, tolerances),
        Case::Scaling => scaling(backend),
        Case::Fragments => fragments(backend),
        Case::Threads => threads(backend),
    }))
    .unwrap_or_else(|panic| {
        let message = panic
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default();
        Err(format!("panicked: {message}"))
    });
    result.map_err(|e| format!("{name}, {case:?}: {e}"))
}

/// `text` built with `backend` on its moving objects, at the default dt of the result.
fn build(text: &str, backend: Backend<'_>) -> Result<World, String> {
    let scene = Scene::parse(text, "conformance").map_err(|e| e.to_string())?;
    let (named, factory): (Option<&str>, Option<&Factory>) = match backend {
        Backend::Named(n) if n == crate::backends::KINEMATIC => (None, None),
        Backend::Named(n) => (Some(n), None),
        Backend::Custom { factory, .. } => (None, Some(factory)),
    };
    let options = BuildOptions {
        backend: named.map(str::to_string),
        ..Default::default()
    };
    let mut world = scene.build(&options).map_err(|e| e.to_string())?;
    if named.is_none() {
        for o in world.objects.iter_mut().filter(|o| !o.is_static()) {
            let dynamics = match factory {
                Some(f) => f(&o.phyxels, &o.material),
                None => Box::new(crate::dynamics::kinematic::Kinematic::new(&o.phyxels)),
            };
            o.set_dynamics(dynamics);
        }
        let (bound, _) = world.stable_dt();
        world.dt = world.default_dt(bound);
    }
    Ok(world)
}

fn balls(gravity: bool) -> String {
    format!(
        r#"
        name = "balls"
        gravity = [0.0, {g}, 0.0]
        [[objects]]
        shape = {{ type = "sphere", radius = 0.1 }}
        spacing = 0.025
        surfel_spacing = 0.01
        position = [-0.12, 0.0, 0.0]
        velocity = [1.0, 0.0, 0.0]
        [[objects]]
        shape = {{ type = "sphere", radius = 0.1 }}
        spacing = 0.025
        surfel_spacing = 0.01
        position = [0.12, 0.0, 0.0]
        velocity = [-1.0, 0.0, 0.0]
        "#,
        g = if gravity { -9.81 } else { 0.0 }
    )
}

fn momentum(backend: Backend<'_>, tol: &Tolerances) -> Result<(), String> {
    if backend.prescribed() {
        return Ok(());
    }
    let mut w = build(&balls(false), backend)?;
    let scale = w.objects[0].phyxels.total_mass();
    let steps = (0.2 / w.dt).ceil() as usize;
    let (mut contact, mut worst) = (0, 0.0f64);
    for _ in 0..steps {
        w.step();
        contact += usize::from(!w.contact.patches.is_empty());
        let p = w.momentum();
        worst = worst.max((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() / scale);
    }
    let vx = |k: usize| w.objects[k].phyxels.momentum()[0];
    if !w.all_finite() {
        return Err("non-finite state".into());
    }
    if worst >= tol.momentum {
        return Err(format!("momentum drift {worst:e} of m v"));
    }
    if contact == 0 || vx(0) >= 0.0 || vx(1) <= 0.0 {
        return Err(format!(
            "the balls did not touch and part ({contact} contact steps)"
        ));
    }
    Ok(())
}

fn rest(backend: Backend<'_>) -> Result<(), String> {
    for young in [1.0e5, 1.0e15] {
        let text = format!(
            r#"
            name = "rest"
            gravity = [0.0, 0.0, 0.0]
            [[objects]]
            shape = {{ type = "sphere", radius = 0.1 }}
            spacing = 0.025
            position = [3.7, -1.2, 0.4]
            material = {{ young = {young:e}, poisson = 0.45 }}
            "#
        );
        let mut w = build(&text, backend)?;
        for _ in 0..100 {
            w.step();
        }
        let k = w.objects[0].phyxels.kinetic_energy();
        if k != 0.0 || !w.all_finite() {
            return Err(format!("E = {young:e} Pa: kinetic energy {k:e} J at rest"));
        }
    }
    Ok(())
}

/// `value` is a number below `bound`: a NaN is not, so a NaN fails the check.
fn below(value: f64, bound: f64) -> bool {
    value < bound
}

/// Kinetic plus elastic energy of object 0 (J).
fn energy(w: &World) -> f64 {
    let o = &w.objects[0];
    let d = o.dynamics.diagnostics(&o.phyxels, &o.material);
    o.phyxels.kinetic_energy() + d.elastic_energy.unwrap_or(0.0)
}

fn far_from_origin(backend: Backend<'_>, tol: &Tolerances) -> Result<(), String> {
    let text = r#"
        name = "far"
        gravity = [0.0, 0.0, 0.0]
        [[objects]]
        shape = { type = "sphere", radius = 0.1 }
        spacing = 0.025
        position = [1.0, 0.0, 0.0]
        velocity = [1.0, 0.0, 0.0]
        material = { young = 1e13 }
    "#;
    let mut w = build(text, backend)?;
    let x0 = w.objects[0].phyxels.centre_of_mass()[0];
    let e0 = 0.5 * w.objects[0].phyxels.total_mass();
    for _ in 0..2000 {
        w.step();
    }
    let e = energy(&w);
    if !below((e - e0).abs(), tol.translation * e0) {
        return Err(format!("energy {e} J against {e0} J"));
    }
    let moved = w.objects[0].phyxels.centre_of_mass()[0] - x0;
    if !below((moved - w.time).abs(), 1e-3 * w.time) {
        return Err(format!("moved {moved} m in {} s", w.time));
    }
    Ok(())
}

fn scaling(backend: Backend<'_>) -> Result<(), String> {
    let text = |s: f32| {
        format!(
            r#"
            name = "small"
            gravity = [0.0, 0.0, 0.0]
            [[objects]]
            shape = {{ type = "sphere", radius = {r:e} }}
            spacing = {s:e}
            surfel_spacing = {t:e}
            velocity = [1.0, 0.0, 0.0]
            "#,
            r = 5.0 * s,
            t = 0.5 * s
        )
    };
    let bound = |s: f32| -> Result<f32, String> {
        let w = build(&text(s), backend)?;
        let o = &w.objects[0];
        Ok(o.dynamics.stable_dt(&o.phyxels, &o.material))
    };
    let (big, small) = (bound(1e-3)?, bound(1e-6)?);
    let scaled = if big == f32::INFINITY {
        small == f32::INFINITY
    } else {
        small.is_finite() && (small / big / 1e-3 - 1.0).abs() < 1e-3
    };
    if !scaled {
        return Err(format!(
            "stable bounds {big:e} s at 1 mm, {small:e} s at 1 µm"
        ));
    }
    let mut w = build(&text(1e-6), backend)?;
    let e0 = 0.5 * w.objects[0].phyxels.total_mass();
    for _ in 0..100 {
        w.step();
    }
    let e = energy(&w);
    if !below((e - e0).abs(), 1e-4 * e0) {
        return Err(format!("energy {e:e} J against {e0:e} J"));
    }
    Ok(())
}

fn fragments(backend: Backend<'_>) -> Result<(), String> {
    let m = Material::default();
    let g = Vec3::new(0.0, -9.81, 0.0);
    let sets: [&[Vec3]; 3] = [
        &[],
        &[Vec3::ZERO],
        &[Vec3::ZERO, Vec3::new(0.025, 0.0, 0.0)],
    ];
    for pts in sets {
        let mut p = Phyxels::at_rest(pts, 0.025f32.powi(3), m.density);
        let mut d: Box<dyn Dynamics> = match backend {
            Backend::Named(n) => crate::backends::create(n, &p, &m)?,
            Backend::Custom { factory, .. } => factory(&p, &m),
        };
        let bound = d.stable_dt(&p, &m);
        let n = pts.len();
        if bound.is_nan() || bound <= 0.0 {
            return Err(format!("{n} phyxels: stable dt {bound}"));
        }
        let dt = bound.min(1e-3);
        let ctx = crate::dynamics::StepContext::new(dt, g, &m);
        for _ in 0..10 {
            d.step(&mut p, &ctx);
        }
        if !p.all_finite() {
            return Err(format!("{n} phyxels: non-finite"));
        }
        if n == 1 && !backend.prescribed() {
            let (v, want) = (p.vel.get(0).y, -9.81 * 10.0 * dt);
            if (v / want - 1.0).abs() >= 1e-5 {
                return Err(format!("a lone phyxel: v {v} m/s, g t {want} m/s"));
            }
        }
    }
    Ok(())
}

fn threads(backend: Backend<'_>) -> Result<(), String> {
    let positions = |threads: usize| -> Result<Vec<[u32; 3]>, String> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| e.to_string())?;
        pool.install(|| {
            let mut w = build(&balls(true), backend)?;
            for _ in 0..(0.05 / w.dt).ceil() as usize {
                w.step();
            }
            Ok(w.objects
                .iter()
                .flat_map(|o| o.phyxels.pos.iter().map(|p| p.to_array().map(f32::to_bits)))
                .collect())
        })
    };
    if positions(1)? != positions(2)? {
        return Err("1 and 2 threads give different positions".into());
    }
    Ok(())
}
