//! An embedding program, as a user of the library writes one: a scene written in code,
//! built, stepped and read back by id and name (`World::object`, `World::object_named`),
//! also after the object list changed under the caller (reordered, or a fracture that
//! replaced an object by pieces).

use glam::Vec3;
use phyxel::World;
use phyxel::scene::{BuildOptions, Scene};

/// A ball above a static ground patch, as TOML text in the program.
const BALL_ON_GROUND: &str = r#"
gravity = [0.0, -9.81, 0.0]

[[objects]]
name = "ground"
shape = { type = "plane", size = [0.6, 0.6] }
spacing = 0.025
static = true

[[objects]]
name = "ball"
shape = { type = "sphere", radius = 0.05 }
spacing = 0.02
position = [0.0, 0.2, 0.0]
"#;

/// A scene written in code builds and steps; the ball is found by name and by id, also
/// after the caller reversed `World::objects` (the getters search, indices do not), and
/// it has fallen as 50 steps of symplectic Euler free fall do, `g dt² n(n+1)/2` (within
/// 1%). Unknown names and ids give `None`.
#[test]
fn a_scene_in_code_is_read_back_by_name_and_id() {
    let scene = Scene::parse(BALL_ON_GROUND, "in-code").expect("a valid scene");
    let mut world = scene.build(&BuildOptions::default()).expect("it builds");
    let id = world.object_named("ball").expect("the ball").id;
    let y0 = world.object(id).expect("by id").phyxels.centre_of_mass()[1];
    let steps = 50;
    for _ in 0..steps {
        world.step();
    }
    assert!(world.non_finite.is_none() && world.all_finite());
    world.objects.reverse();
    let ball = world.object(id).expect("found after reordering");
    assert_eq!(ball.name, "ball");
    let fell = y0 - ball.phyxels.centre_of_mass()[1];
    // Symplectic Euler: after n steps the fall is g dt² n(n+1)/2.
    let (n, dt) = (steps as f64, world.dt as f64);
    let expected = 0.5 * 9.81 * dt * dt * n * (n + 1.0);
    assert!(
        (fell - expected).abs() < 0.01 * expected,
        "fell {fell} m, expected {expected} m"
    );
    world.object_mut(id).expect("mutable").load = Vec3::new(0.0, 1.0, 0.0);
    assert_eq!(world.object_named("ball").map(|o| o.load.y), Some(1.0));
    assert!(world.object_named("nothing").is_none());
    assert!(world.object(u32::MAX - 1).is_none());
}

/// An empty world (every object removed) steps without a panic, has no stable bound
/// (`World::stable_dt` gives infinity and no limiter) and no energy or momentum.
#[test]
fn an_empty_world_steps() {
    let mut world = World::new(Vec::new(), Vec3::new(0.0, -9.81, 0.0), 1e-3);
    let (bound, limiter) = world.stable_dt();
    assert!(bound == f32::INFINITY && limiter.is_none(), "{bound}");
    world.step();
    assert_eq!(world.steps, 1);
    assert_eq!(world.momentum(), [0.0; 3]);
    assert_eq!(world.energy().total(), 0.0);
    assert!(world.object(0).is_none());
}

/// After a fracture the broken object's id is gone and its pieces name it as their
/// `parent`: the plastic bar of `plastic-fracture`, torn by hand (its lower half moved
/// 1 m down) is found by neither its id nor its name, and its pieces by their names
/// `bar.0`, `bar.1` and their ids.
#[test]
fn pieces_of_a_broken_object_are_found_by_parent() {
    let scene = Scene::builtin("plastic-fracture").expect("built-in");
    let mut world = scene.build(&BuildOptions::default()).expect("it builds");
    let bar = world
        .objects
        .iter()
        .find(|o| !o.is_static())
        .expect("a moving object");
    let (id, name) = (bar.id, bar.name.clone());
    world.step();
    let p = &mut world.object_mut(id).expect("by id").phyxels;
    let mid = (0..p.len()).map(|i| p.pos.get(i).y).sum::<f32>() / p.len() as f32;
    for i in 0..p.len() {
        if p.pos.get(i).y < mid {
            p.pos.set(i, p.pos.get(i) - Vec3::Y);
        }
    }
    world.step();
    assert!(world.object(id).is_none(), "the broken object's id is gone");
    assert!(world.object_named(&name).is_none());
    let pieces: Vec<u32> = world
        .objects
        .iter()
        .filter(|o| o.parent == Some(id))
        .map(|o| o.id)
        .collect();
    assert!(pieces.len() >= 2, "pieces {pieces:?}");
    for (k, piece) in pieces.iter().enumerate() {
        let o = world.object(*piece).expect("a piece by id");
        assert_eq!(
            world.object_named(&format!("{name}.{k}")).map(|o| o.id),
            Some(o.id)
        );
    }
}
