//! Contact on bodies that are not convex or not thick: a ring dropped over a peg (the
//! ring's hole is concave), a ball dropped into a cup (a mesh made here) and a ball
//! dropped on a thin plate. Besides the outcome, the
//! detection's shortcuts (the early "clearly outside" on `f`, the far candidates
//! classified by the other body's phyxels, `f` extended linearly in deep overlap) are
//! checked during the runs against the paper's full test (eq. 2, `ImplicitSurface::inside`:
//! project onto the other surface, compare with its normal) on every force carrier near
//! the other body. The margin, 0.2 mm (5% of the surfel spacing), covers the full test's
//! projection tolerance and f32 rounding; an early "outside" for `f` above −4 times its
//! threshold fails both tests. The overlaps here stay within the kernel's reach, so
//! the far candidates' classification by phyxels is not exercised (the hard case
//! `deep-penetration` is where it matters).

use glam::Vec3;
use phyxel::World;
use phyxel::contact::implicit::{ImplicitSurface, grid_cell};
use phyxel::scene::{BuildOptions, Scene};
use phyxel::spatial::grid::Grid;
use std::collections::HashSet;

fn world(text: &str) -> World {
    Scene::parse(text, "concave")
        .unwrap()
        .build(&BuildOptions::default())
        .unwrap()
}

/// For the pair of objects `a`, `b` (indices) in `w`'s last contact phase: every force
/// carrier of either side that the paper's full test finds inside the other, farther
/// than `margin` (m) from its surface, is among the detected colliding surfels, and
/// every one it finds outside beyond `margin` is not. Returns the carriers compared.
fn shortcuts_agree(w: &World, a: usize, b: usize, margin: f32) -> usize {
    let detection = w.detections.iter().find(|d| (d.a, d.b) == (a, b));
    let mut compared = 0;
    for (obj, other) in [(a, b), (b, a)] {
        let found: HashSet<u32> = detection
            .map(|d| if obj == d.a { &d.a_in_b } else { &d.b_in_a })
            .into_iter()
            .flatten()
            .map(|c| c.surfel)
            .collect();
        let s = &w.objects[other].surfels;
        let n = s.len();
        let r_max = s.radius[..n].iter().fold(0.0f32, |m, &r| m.max(r));
        let grid = Grid::build(s.pos.iter().take(n), grid_cell(r_max));
        let surf = ImplicitSurface::new(&s.pos, &s.normal, &s.radius[..n], &grid);
        let o = &w.objects[obj];
        for i in (0..o.surfels.len()).filter(|&i| o.force_carrier[i]) {
            let x: Vec3 = o.surfels.pos.get(i);
            // Far from the other body the full test need not run: nothing is inside.
            if surf.sample_near(x).is_none() && !found.contains(&(i as u32)) {
                continue;
            }
            let Some((inside, p)) = surf.inside(x) else {
                continue;
            };
            if p.signed_distance.abs() <= margin {
                continue;
            }
            compared += 1;
            assert_eq!(
                found.contains(&(i as u32)),
                inside,
                "step {}: surfel {i} of '{}' at {x}, {} m from '{}''s surface: the \
                 pipeline and the full test disagree",
                w.steps,
                o.name,
                p.signed_distance,
                w.objects[other].name
            );
        }
    }
    compared
}

/// A soft ring (torus: major radius 80 mm, tube radius 25 mm, E = 1e5 Pa, 528 phyxels)
/// dropped off-centre onto the rounded top of a static peg (capsule, radius 20 mm) and
/// left for 1.33 s: it catches on the peg with the inside of its hole, slides down around
/// it and comes to rest on the ground.
///
/// References: geometry and the full inside test. The ring rests on the ground (its
/// centre a tube radius above it, within 5 mm) with the peg through its hole: its centre
/// lies within `major − minor − peg radius` = 35 mm of the peg's axis, which a ring
/// beside the peg cannot reach. The deepest overlap over the run stays under a quarter
/// of the tube radius (6.25 mm; measured 4.8 mm), where the two sides of the tube are
/// far from confusing the inside test. Every 100 steps the detected colliding carriers
/// of the ring–peg pair equal the full test's (module docs).
#[test]
fn a_ring_drops_over_a_peg() {
    let mut w = world(
        r#"
        gravity = [0.0, -9.81, 0.0]
        [[objects]]
        name = "ground"
        shape = { type = "plane", size = [0.5, 0.5] }
        spacing = 0.02
        surfel_spacing = 0.004
        static = true
        position = [0.0, -0.2, 0.0]
        material = { young = 1.0e6, friction = 0.3 }
        [[objects]]
        name = "peg"
        shape = { type = "capsule", radius = 0.02, length = 0.3 }
        spacing = 0.01
        surfel_spacing = 0.004
        static = true
        position = [0.0, -0.03, 0.0]
        material = { young = 1.0e6, friction = 0.3 }
        [[objects]]
        name = "ring"
        shape = { type = "torus", major = 0.08, minor = 0.025 }
        spacing = 0.0125
        surfel_spacing = 0.004
        position = [0.045, 0.18, 0.0]
        material = { young = 1.0e5, friction = 0.3 }
        "#,
    );
    let steps = (1.33 / w.dt) as u64;
    let (mut compared, mut touching) = (0, 0);
    for k in 1..=steps {
        w.step();
        assert!(w.non_finite.is_none(), "{:?}", w.non_finite);
        if k % 100 == 0 {
            compared += shortcuts_agree(&w, 1, 2, 0.0002);
            touching += w.detections.iter().any(|d| (d.a, d.b) == (1, 2)) as u32;
        }
    }
    let c = w.objects[2].phyxels.centre_of_mass();
    let off_axis = c[0].hypot(c[2]);
    println!(
        "ring at {c:?}: {off_axis:.4} m off the peg's axis; deepest overlap {:.4} m; \
         {compared} carriers compared over {touching} checks in contact",
        w.record.max_penetration
    );
    assert!(
        touching >= 3,
        "the ring touched the peg in {touching} checks"
    );
    assert!(compared > 200, "{compared} carriers compared");
    assert!(
        (c[1] - (-0.2 + 0.025)).abs() < 0.005,
        "ring centre at y = {}",
        c[1]
    );
    assert!(
        off_axis < 0.035,
        "the peg is not through the ring: {off_axis} m"
    );
    assert!(
        w.record.max_penetration < 0.25 * 0.025,
        "deepest overlap {} m",
        w.record.max_penetration
    );
}

/// A ball (R = 50 mm, E = 1e5 Pa) dropped from 10 cm onto a static plate 12 mm thick
/// (three surfel spacings) and watched for 0.8 s, through its first bounces. Reference:
/// the plate's two faces. A surfel that crossed more than half the thickness would be
/// nearer the far face and test as outside (the limit of any inside test on a thin
/// body, docs/SCENES.md "Limits"): the deepest overlap must stay under half the
/// thickness (6 mm; measured 3.3 mm), and the ball must end on top (centre above the top
/// face by more than 0.9 R). The detected colliding carriers equal the full test's every
/// 100 steps (module docs).
#[test]
fn a_ball_stays_on_a_thin_plate() {
    let mut w = world(
        r#"
        gravity = [0.0, -9.81, 0.0]
        [[objects]]
        name = "plate"
        shape = { type = "box", size = [0.3, 0.012, 0.3] }
        spacing = 0.006
        surfel_spacing = 0.004
        static = true
        material = { young = 1.0e6, friction = 0.3 }
        [[objects]]
        name = "ball"
        shape = { type = "sphere", radius = 0.05 }
        spacing = 0.0125
        surfel_spacing = 0.004
        position = [0.0, 0.16, 0.0]
        material = { young = 1.0e5, friction = 0.3 }
        "#,
    );
    let steps = (0.8 / w.dt) as u64;
    let mut compared = 0;
    for k in 1..=steps {
        w.step();
        assert!(w.non_finite.is_none(), "{:?}", w.non_finite);
        if k % 100 == 0 {
            compared += shortcuts_agree(&w, 0, 1, 0.0002);
        }
    }
    let c = w.objects[1].phyxels.centre_of_mass();
    println!(
        "ball at {c:?}; deepest overlap {:.4} m; {compared} carriers compared",
        w.record.max_penetration
    );
    assert!(compared > 100, "{compared} carriers compared");
    assert!(
        w.record.max_penetration > 0.0,
        "the ball never touched the plate"
    );
    assert!(
        w.record.max_penetration < 0.5 * 0.012,
        "deepest overlap {} m",
        w.record.max_penetration
    );
    assert!(c[1] > 0.006 + 0.9 * 0.05, "ball centre at y = {}", c[1]);
}

/// A closed surface of revolution about y as OBJ text: the profile `(r, y)` (its first
/// and last points on the axis, the edge between them along it) swept in `n` segments.
/// Every profile edge becomes a band of quads, or a fan where it meets the axis; all
/// wound alike, so the loader can orient the whole.
fn revolved_obj(profile: &[(f32, f32)], n: usize) -> String {
    let mut obj = String::new();
    let mut rings: Vec<Vec<usize>> = Vec::new();
    let mut count = 0;
    for &(r, y) in profile {
        let k = if r == 0.0 { 1 } else { n };
        let mut ring = Vec::new();
        for j in 0..k {
            let a = std::f32::consts::TAU * j as f32 / n as f32;
            obj += &format!("v {} {y} {}\n", r * a.cos(), r * a.sin());
            count += 1;
            ring.push(count);
        }
        rings.push(ring);
    }
    for w in rings.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        for j in 0..n {
            let k = (j + 1) % n;
            match (a.len(), b.len()) {
                (1, 1) => {}
                (1, _) => obj += &format!("f {} {} {}\n", a[0], b[j], b[k]),
                (_, 1) => obj += &format!("f {} {} {}\n", a[j], b[0], a[k]),
                _ => {
                    obj += &format!("f {} {} {}\n", a[j], b[j], b[k]);
                    obj += &format!("f {} {} {}\n", a[j], b[k], a[k]);
                }
            }
        }
    }
    obj
}

/// A ball (R = 30 mm, E = 1e5 Pa) dropped off-centre into a static cup (a mesh made
/// here: outer radius 70 mm, cavity radius 50 mm, 80 mm tall, walls and floor 20 mm)
/// and watched for 1.2 s: it falls past the rim (its side 5 mm inside the cavity's wall),
/// bounces on the floor and off the walls, and settles on the floor. References: the cup's geometry and the full inside test. The ball
/// ends on the floor (centre a radius above it, y = 50 mm, within 5 mm) inside the
/// cavity (its centre within 50 − 30 = 20 mm of the axis); the deepest overlap over the
/// run stays under a quarter of the wall thickness (5 mm). The detected colliding
/// carriers equal the full test's every 100 steps (module docs).
///
/// Fails today (a known defect, not yet understood): the ball ends with its centre at
/// y = 22 mm, through the 20 mm floor, while the deepest overlap recorded is 2.4 mm; and
/// a ball dropped onto the rim (centre 25 mm off the axis) bounced out, and beside the
/// outer wall a ball surfel 1.2 mm inside the cup was not detected as colliding.
#[test]
#[ignore = "known defect: the ball passes through the cup's floor (docs/ACCURACY.md, Known limits)"]
fn a_ball_drops_into_a_cup() {
    let (outer, cavity, height, floor) = (0.07f32, 0.05f32, 0.08f32, 0.02f32);
    let profile = [
        (0.0, 0.0),
        (outer, 0.0),
        (outer, height),
        (cavity, height),
        (cavity, floor),
        (0.0, floor),
    ];
    let dir = std::env::temp_dir().join(format!("phyxel-cup-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cup = dir.join("cup.obj");
    std::fs::write(&cup, revolved_obj(&profile, 48)).unwrap();
    let mut w = world(&format!(
        r#"
        gravity = [0.0, -9.81, 0.0]
        [[objects]]
        name = "cup"
        shape = {{ type = "mesh", path = "{}" }}
        spacing = 0.01
        surfel_spacing = 0.004
        static = true
        material = {{ young = 1.0e6, friction = 0.3 }}
        [[objects]]
        name = "ball"
        shape = {{ type = "sphere", radius = 0.03 }}
        spacing = 0.0075
        surfel_spacing = 0.004
        position = [0.015, 0.16, 0.0]
        material = {{ young = 1.0e5, friction = 0.3 }}
        "#,
        cup.display()
    ));
    std::fs::remove_dir_all(&dir).unwrap();
    let steps = (1.2 / w.dt) as u64;
    let (mut compared, mut touching) = (0, 0);
    for k in 1..=steps {
        w.step();
        assert!(w.non_finite.is_none(), "{:?}", w.non_finite);
        if k % 100 == 0 {
            compared += shortcuts_agree(&w, 0, 1, 0.0002);
            touching += w.detections.iter().any(|d| (d.a, d.b) == (0, 1)) as u32;
        }
    }
    let c = w.objects[1].phyxels.centre_of_mass();
    let off_axis = c[0].hypot(c[2]);
    println!(
        "ball at {c:?}: {off_axis:.4} m off the cup's axis; deepest overlap {:.4} m; \
         {compared} carriers compared over {touching} checks in contact",
        w.record.max_penetration
    );
    assert!(
        touching >= 3,
        "the ball touched the cup in {touching} checks"
    );
    assert!(compared > 100, "{compared} carriers compared");
    assert!(
        (c[1] - (floor + 0.03) as f64).abs() < 0.005,
        "ball centre at y = {}",
        c[1]
    );
    assert!(
        off_axis < (cavity - 0.03) as f64,
        "the ball is not in the cup: {off_axis} m"
    );
    assert!(
        w.record.max_penetration < 0.25 * (outer - cavity),
        "deepest overlap {} m",
        w.record.max_penetration
    );
}
