//! A tool driven from code: a rigid `kinematic` sphere (R = 3 cm) pressed 1 cm into a
//! soft ball (E = 20 kPa) resting on the ground, then drawn back; the force the tool
//! feels (`Kinematic::reaction`) is printed against the indentation as it goes.
//! `cargo run --release --example tool`
use phyxel::dynamics::kinematic::Kinematic;
use phyxel::glam::Vec3;
use phyxel::scene::{BuildOptions, ObjectSpec, Scene};

fn main() -> Result<(), phyxel::scene::SceneError> {
    let ground = ObjectSpec::plane([0.6, 0.6]).spacing(0.02);
    let ball = ObjectSpec::sphere(0.1)
        .named("ball")
        .spacing(0.012)
        .position([0.0, 0.101, 0.0])
        .young(2e4)
        .backend("mls-implicit");
    let tool = ObjectSpec::sphere(0.03)
        .named("tool")
        .spacing(0.006)
        .position([0.0, 0.24, 0.0])
        .young(1e9)
        .backend("kinematic");
    let scene = Scene::new("tool").object(ground).object(ball).object(tool);
    let mut world = scene.build(&BuildOptions::default())?;
    let id = world.object_named("tool").expect("the tool").id;
    // Let the ball settle under its weight (0.5 s), then find its top.
    for _ in 0..60 {
        world.step();
    }
    let ball = &world.object_named("ball").expect("the ball").phyxels;
    let top = ball.pos.iter().fold(f32::NEG_INFINITY, |y, p| y.max(p.y));
    let touch = top + 0.03; // the tool's centre when it first touches
    println!("dt {:.2e} s; the ball's top at y = {top:.4} m", world.dt);
    for target in [touch - 0.01, touch + 0.01] {
        let drive = world
            .object_mut(id)
            .and_then(|o| o.dynamics_mut::<Kinematic>());
        let drive = drive.expect("a kinematic tool");
        drive.target = Some(Vec3::new(0.0, target, 0.0));
        drive.max_speed = 0.02;
        for step in 0..400 {
            world.step();
            let tool = world.object(id).expect("the tool");
            let y = tool.phyxels.centre_of_mass()[1] as f32;
            let force = tool.dynamics_as::<Kinematic>().unwrap().reaction();
            if step % 10 == 0 && y < touch + 0.002 {
                let depth = (touch - y) * 1e3;
                println!(
                    "tool at {y:.4} m: indentation {depth:6.2} mm, force {:7.4} N",
                    force.y
                );
            }
            if (y - target).abs() < 1e-5 {
                break;
            }
        }
    }
    Ok(())
}
