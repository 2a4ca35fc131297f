//! Two soft spheres from the builder (`phyxel::scene::{Scene, ObjectSpec}`), stepped,
//! their contact force printed each step: `cargo run --release --example two_spheres`.
use phyxel::scene::{BuildOptions, ObjectSpec, Scene};

fn main() -> Result<(), phyxel::scene::SceneError> {
    let soft = ObjectSpec::sphere(0.1).phyxels(500).young(1e5);
    let left = soft.clone().position([-0.11, 0.0, 0.0]);
    let right = soft.position([0.11, 0.0, 0.0]).velocity([-2.0, 0.0, 0.0]);
    let scene = Scene::new("two soft spheres").object(left).object(right);
    let mut world = scene.build(&BuildOptions::default())?;
    for step in 1..=300 {
        world.step();
        for t in world.contact_totals() {
            println!("step {step}: {:.3} N", t.normal_force);
        }
    }
    Ok(())
}
