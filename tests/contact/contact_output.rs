//! Contact output (`World::contact_totals`, `contact::ContactPoint`): what the library
//! reports a contact did, checked against Newton's laws.

use crate::common;

use glam::DVec3;
use phyxel::contact::ContactPoint;
use phyxel::io::frame::Format;
use phyxel::scene::{BuildOptions, Scene};
use std::collections::HashMap;
use std::path::Path;

/// A soft box (0.1 m, E = 1e5 Pa, 64 phyxels, damped) set on a static plane and left to
/// settle for 0.6 s, then watched for 0.1 s. Reference: Newton's second law. Over the
/// window the box's momentum changes by less than 0.2% of its weight's impulse (checked:
/// it is at rest), so the contact force on it must balance its weight: the mean
/// reported total force on the box is within 1% of `m g` upwards (3e-6 measured), and
/// its sideways part within 1% of the weight. The patch's centroid lies under the box's centre of
/// mass (within one surfel spacing, 5 mm) and its area within 25% of the 0.01 m² face
/// (the kernel estimate of each surfel's area loses up to half a kernel along the
/// 0.4 m rim: 0.4 × 0.005 / 0.01 = 20%; −15% measured). Each contact surfel's penalty and friction
/// parts add up to its force, along and across its normal. The contact frame written
/// for ParaView (`contacts_NNNNN.ply` and `.vtp`) holds the same contact surfels: read
/// back, its forces sum to the reported total (to f32 rounding, 1e-4 relative) and its
/// areas to the reported area. Sleeping is off: a sleeping pair reports no contact.
#[test]
fn a_resting_box_carries_its_weight() {
    let text = r#"
        name = "box-on-plane"
        gravity = [0.0, -9.81, 0.0]
        sleep = false
        [[objects]]
        name = "ground"
        shape = { type = "plane", size = [0.4, 0.4] }
        spacing = 0.025
        surfel_spacing = 0.005
        static = true
        material = { young = 1.0e6, friction = 0.5 }
        [[objects]]
        name = "box"
        shape = { type = "box", size = [0.1, 0.1, 0.1] }
        spacing = 0.025
        surfel_spacing = 0.005
        position = [0.0, 0.0505, 0.0]
        material = { young = 1.0e5, damping = 2.0e-3, friction = 0.5 }
    "#;
    let scene = Scene::parse(text, "box-on-plane").unwrap();
    let mut world = scene.build(&BuildOptions::default()).unwrap();
    let dt = world.dt as f64;
    let settle = (0.6 / dt) as usize;
    let window = (0.1 / dt) as usize;
    for _ in 0..settle {
        world.step();
    }
    let mass = world.objects[1].phyxels.total_mass();
    let weight = mass * 9.81;
    let p0 = DVec3::from(world.objects[1].phyxels.momentum());
    let mut sum = DVec3::ZERO;
    let mut last = None;
    for _ in 0..window {
        world.step();
        let totals = world.contact_totals();
        assert_eq!(totals.len(), 1, "one pair in contact");
        let t = totals[0];
        assert_eq!((t.a, t.b), (0, 1));
        // The force is on a (the ground): the box takes the opposite.
        sum -= DVec3::from(t.force);
        last = Some(t);
    }
    let dp = DVec3::from(world.objects[1].phyxels.momentum()) - p0;
    assert!(
        dp.length() < 2e-3 * weight * window as f64 * dt,
        "the box is not at rest: momentum change {dp:?}"
    );
    let mean = sum / window as f64;
    println!(
        "mean contact force {mean:?} N, weight {weight} N, momentum change {dp:?} over {window} steps"
    );
    assert!(
        (mean.y - weight).abs() < 0.01 * weight,
        "mean contact force {mean:?} N against the weight {weight} N"
    );
    assert!(
        mean.x.hypot(mean.z) < 0.01 * weight,
        "sideways contact force {mean:?} N"
    );
    let t = last.unwrap();
    let com = DVec3::from(world.objects[1].phyxels.centre_of_mass());
    let c = DVec3::from(t.centroid.expect("a patch that carries force has area"));
    assert!(
        (c.x - com.x).hypot(c.z - com.z) < 0.005,
        "centroid {c:?} under the box at {com:?}"
    );
    assert!(
        (t.area - 0.01).abs() < 0.25 * 0.01,
        "contact area {} m² against the 0.01 m² face",
        t.area
    );
    println!("area {} m², centroid {c:?}, box at {com:?}", t.area);
    assert!(t.normal_force > 0.0 && t.peak_pressure > 0.0 && t.max_penetration > 0.0);
    for c in &world.contact.patches[0].surfels {
        let p = ContactPoint::of(c);
        let sum = glam::Vec3::from(p.penalty_force) + glam::Vec3::from(p.friction_force);
        assert!((sum - c.force).length() <= 1e-5 * c.force.length().max(1e-12));
        let n = glam::Vec3::from(p.normal);
        assert!(glam::Vec3::from(p.friction_force).dot(n).abs() <= 1e-4 * c.force.length());
        assert!(
            glam::Vec3::from(p.slip_velocity).dot(n).abs() <= 1e-4 * c.velocity.length().max(1e-12)
        );
    }
    check_contact_frames(&world, &t);
}

/// The contact frames of `world` as written by `run --out`, read back against `totals`.
fn check_contact_frames(world: &phyxel::World, totals: &phyxel::contact::PatchTotals) {
    let dir = common::TempDir::new("contact-output", "frames");
    phyxel::world::output::write_frame_as(world, &dir.0, 7, false, Format::Ply).unwrap();
    let cols = read_binary_ply(&dir.0.join("contacts_00007.ply"));
    let n = world.contact.patches[0].surfels.len();
    assert_eq!(cols["x"].len(), n, "one point per contact surfel");
    let sum = |k: &str| cols[k].iter().map(|&x| x as f64).sum::<f64>();
    let force = |c: &str| sum(&format!("penalty_force_{c}")) + sum(&format!("friction_force_{c}"));
    let force = DVec3::new(force("x"), force("y"), force("z"));
    let area = sum("area");
    assert!(cols["a"].iter().all(|&a| a == 0.0), "pair id a");
    assert!(cols["b"].iter().all(|&b| b == 1.0), "pair id b");
    assert!(cols["penetration"].iter().all(|&d| d >= 0.0));
    let total = DVec3::from(totals.force);
    assert!(
        (force - total).length() < 1e-4 * total.length(),
        "frame force {force:?} against total {total:?}"
    );
    assert!((area - totals.area).abs() < 1e-4 * totals.area);
    phyxel::world::output::write_frame_as(world, &dir.0, 7, false, Format::Vtk).unwrap();
    let vtp = std::fs::read(dir.0.join("contacts_00007.vtp")).unwrap();
    // The XML header (the binary data follows `<AppendedData`).
    let vtp = String::from_utf8_lossy(&vtp);
    assert!(vtp.contains(&format!("NumberOfPoints=\"{n}\"")));
    for name in [
        "Normals",
        "area",
        "penetration",
        "penalty_force",
        "friction_force",
    ] {
        assert!(
            vtp.contains(&format!("Name=\"{name}\"")),
            "vtp lacks {name}"
        );
    }
}

/// Every column of a binary little-endian PLY whose properties are all 4-byte `float`
/// or `int` (the contact frames), as f32; a reader independent of the engine's.
fn read_binary_ply(path: &Path) -> HashMap<String, Vec<f32>> {
    let bytes = std::fs::read(path).unwrap();
    let end = b"end_header\n";
    let body = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
    let header = std::str::from_utf8(&bytes[..body]).unwrap();
    let mut n = 0;
    let mut props = Vec::new();
    for line in header.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["element", "vertex", k] => n = k.parse().unwrap(),
            ["property", ty, name] => props.push((ty.to_string(), name.to_string())),
            _ => {}
        }
    }
    assert_eq!(bytes.len() - body, n * 4 * props.len(), "payload size");
    let mut cols: HashMap<String, Vec<f32>> = HashMap::new();
    for (i, chunk) in bytes[body..].chunks(4).enumerate() {
        let (ty, name) = &props[i % props.len()];
        let b: [u8; 4] = chunk.try_into().unwrap();
        let v = match ty.as_str() {
            "float" => f32::from_le_bytes(b),
            "int" => i32::from_le_bytes(b) as f32,
            other => panic!("unexpected property type {other}"),
        };
        cols.entry(name.clone()).or_default().push(v);
    }
    cols
}
