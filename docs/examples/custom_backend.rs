//! A custom `Dynamics` backend: damped springs between rest neighbours (a mass-spring
//! solid), written against the public API, swapped into a ball built from the builder,
//! dropped on the ground beside an `mls` ball. The same contact pipeline drives both;
//! each one's lowest point is printed as they land.
//! `cargo run --release --example custom_backend`
use phyxel::columns::Vec3s;
use phyxel::dynamics::{Dynamics, StepContext, integrate_symplectic};
use phyxel::scene::{BuildOptions, ObjectSpec, Scene};
use phyxel::spatial::grid::Grid;
use phyxel::{Material, Phyxels};

/// Springs of `stiffness` (N/m) and `damping` (N·s/m) between phyxels closer than 1.5
/// spacings at rest.
struct Springs {
    pairs: Vec<(u32, u32, f32)>,
    stiffness: f32,
    damping: f32,
    force: Vec3s,
}

impl Springs {
    fn new(p: &Phyxels, stiffness: f32, damping: f32) -> Self {
        let reach = 1.5 * p.spacing[0];
        let grid = Grid::build(p.rest.iter(), reach);
        let mut pairs = Vec::new();
        for i in 0..p.len() {
            grid.for_each_within(p.rest.get(i), reach, |j, d2| {
                if j > i {
                    pairs.push((i as u32, j as u32, d2.sqrt()));
                }
            });
        }
        let force = Vec3s::zeros(p.len());
        Self {
            pairs,
            stiffness,
            damping,
            force,
        }
    }
}

impl Dynamics for Springs {
    fn name(&self) -> &str {
        "springs"
    }

    /// Equal and opposite spring and dashpot forces along each pair (momentum kept),
    /// then the library's symplectic Euler (gravity, contact forces, fixed phyxels).
    fn step(&mut self, p: &mut Phyxels, ctx: &StepContext<'_>) {
        self.force.fill_zero();
        for &(i, j, rest) in &self.pairs {
            let (i, j) = (i as usize, j as usize);
            // Relative positions with the carries, as the built-in backends read them.
            let d = (p.pos.get(j) - p.pos.get(i)) + (p.pos_carry.get(j) - p.pos_carry.get(i));
            let len = d.length().max(1e-12);
            let n = d / len;
            let closing = (p.vel.get(j) - p.vel.get(i)).dot(n);
            let f = n * (self.stiffness * (len - rest) + self.damping * closing);
            self.force.add(i, f);
            self.force.add(j, -f);
        }
        integrate_symplectic(p, &self.force, ctx);
    }

    /// A fifth of the lightest phyxel's spring period.
    fn stable_dt(&self, p: &Phyxels, _: &Material) -> f32 {
        let m = p.mass[..p.len()]
            .iter()
            .fold(f32::INFINITY, |a, &b| a.min(b));
        0.2 * (m / self.stiffness).sqrt()
    }
}

fn main() -> Result<(), phyxel::scene::SceneError> {
    let ball = |name: &str, x: f32| {
        let ball = ObjectSpec::sphere(0.08)
            .named(name)
            .spacing(0.02)
            .young(1e5);
        ball.position([x, 0.1, 0.0])
    };
    let scene = Scene::new("springs beside mls")
        .object(ObjectSpec::plane([0.8, 0.4]).spacing(0.02))
        .object(ball("springs", -0.15))
        .object(ball("mls", 0.15));
    let mut world = scene.build(&BuildOptions::default())?;
    let k = world
        .objects
        .iter()
        .position(|o| o.name == "springs")
        .expect("the ball");
    let springs = Springs::new(&world.objects[k].phyxels, 2000.0, 0.5);
    world.objects[k].set_dynamics(Box::new(springs));
    // The world took its dt from `mls`; the springs may need a smaller one.
    world.dt = world.dt.min(0.9 * world.stable_dt().0);
    let lowest = |o: &phyxel::Object| o.phyxels.pos.iter().fold(f32::INFINITY, |y, p| y.min(p.y));
    for step in 1..=(0.6 / world.dt) as usize {
        world.step();
        if step % 200 == 0 {
            let (a, b) = (&world.objects[k], world.object_named("mls").unwrap());
            let (ya, yb) = (lowest(a), lowest(b));
            println!(
                "t {:.3} s: lowest phyxel, springs {ya:+.4} m, mls {yb:+.4} m",
                world.time
            );
        }
    }
    Ok(())
}
