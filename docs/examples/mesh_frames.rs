//! A mesh loaded, stepped and written as frames: a soft bean (an OBJ written here, a
//! stretched octahedron refined twice) dropped on the ground; every 50 steps its
//! render surface and its own triangles, moved with the body, go to
//! `target/mesh_frames/` as binary PLY (open them in ParaView or Blender).
//! `cargo run --release --example mesh_frames`
use phyxel::glam::Vec3;
use phyxel::io::frame::Format;
use phyxel::scene::{BuildOptions, ObjectSpec, Scene};
use phyxel::world::output;
use std::collections::HashMap;
use std::fmt::Write as _;

/// An octahedron refined `levels` times (each triangle into four, new vertices pushed
/// onto the unit sphere), then scaled by `axes`: an ellipsoid as OBJ text.
fn ellipsoid_obj(axes: Vec3, levels: u32) -> String {
    let mut v = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let mut t: Vec<[usize; 3]> = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    for _ in 0..levels {
        let mut mid = HashMap::new();
        let mut split = |a: usize, b: usize, v: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a] + v[b]) * 0.5).normalize());
                v.len() - 1
            })
        };
        t = t
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (
                    split(a, b, &mut v),
                    split(b, c, &mut v),
                    split(c, a, &mut v),
                );
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    let mut obj = String::new();
    for p in &v {
        let p = *p * axes;
        writeln!(obj, "v {} {} {}", p.x, p.y, p.z).unwrap();
    }
    for [a, b, c] in &t {
        writeln!(obj, "f {} {} {}", a + 1, b + 1, c + 1).unwrap();
    }
    obj
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/mesh_frames");
    std::fs::create_dir_all(&dir)?;
    let mesh = dir.join("bean.obj");
    std::fs::write(&mesh, ellipsoid_obj(Vec3::new(0.1, 0.05, 0.06), 3))?;
    let bean = ObjectSpec::mesh(mesh.to_string_lossy())
        .spacing(0.012)
        .position([0.0, 0.07, 0.0])
        .rotation([0.0, 0.0, 20.0])
        .young(3e4)
        .backend("mls-implicit");
    let ground = ObjectSpec::plane([0.5, 0.5]).spacing(0.02);
    let scene = Scene::new("bean").object(ground).object(bean);
    let options = BuildOptions {
        meshes: true, // every object's output mesh, for mesh frames
        ..Default::default()
    };
    let mut world = scene.build(&options)?;
    for frame in 0..=4 {
        if frame > 0 {
            for _ in 0..50 {
                world.step();
            }
        }
        world.sync_surfels(); // the surfels far from contact move when read
        world.follow_meshes();
        output::write_frame(&world, &dir, frame, false)?;
        let name = output::mesh_file(frame, Format::Ply);
        let mesh = output::mesh_frame(&world);
        mesh.write(&dir.join(&name), Format::Ply)?;
        let id = world.objects[1].id as i32;
        let bean = mesh.pos.iter().zip(&mesh.object).filter(|(_, o)| **o == id);
        let low = bean.fold(f32::INFINITY, |y, (p, _)| y.min(p.y));
        println!(
            "t {:.3} s: {name} ({} vertices, {} triangles, the bean's lowest vertex at {low:+.4} m)",
            world.time,
            mesh.pos.len(),
            mesh.triangles.len()
        );
    }
    println!("frames in {}", dir.display());
    Ok(())
}
