//! phyxel's elastic backends and Rapier's soft bodies on the peer cases (`src/lib.rs`):
//! one JSON line per run on stdout, progress on stderr.
//!
//! `cargo bench --manifest-path benches/peers/Cargo.toml -- [--quick] [--threads 1,2]
//! [--engines phyxel,rapier] [--cases cantilever,ball-impact]`

use phyxel_peers::{ContactTimer, Record, ball, cantilever};
use serde_json::json;
use std::time::Instant;

struct Options {
    quick: bool,
    threads: Vec<usize>,
    engines: Vec<String>,
    cases: Vec<String>,
}

fn options() -> Options {
    let mut o = Options {
        quick: false,
        threads: vec![1, 2],
        engines: vec!["phyxel".into(), "rapier".into()],
        cases: vec!["cantilever".into(), "ball-impact".into()],
    };
    let list = |v: Option<String>| -> Vec<String> {
        v.expect("a list after the flag")
            .split(',')
            .map(str::to_string)
            .collect()
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--quick" => o.quick = true,
            "--threads" => {
                o.threads = list(args.next())
                    .iter()
                    .map(|t| t.parse().expect("--threads takes counts, e.g. 1,2"))
                    .collect()
            }
            "--engines" => o.engines = list(args.next()),
            "--cases" => o.cases = list(args.next()),
            // cargo bench passes --bench.
            "--bench" => {}
            other => panic!("unknown argument {other}"),
        }
    }
    o
}

fn main() {
    let o = options();
    for &threads in &o.threads {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            for engine in &o.engines {
                for case in &o.cases {
                    let records = match (engine.as_str(), case.as_str()) {
                        ("phyxel", "cantilever") => phyxel_engine::cantilever(o.quick),
                        ("phyxel", "ball-impact") => phyxel_engine::ball(o.quick),
                        ("rapier", "cantilever") => rapier_engine::cantilever(o.quick),
                        ("rapier", "ball-impact") => rapier_engine::ball(o.quick),
                        _ => panic!("unknown engine {engine} or case {case}"),
                    };
                    for mut r in records {
                        r.threads = threads;
                        println!("{}", r.json());
                    }
                }
            }
        });
    }
}

/// The resolutions: the coarse one alone with `--quick`.
fn resolutions<T: Copy>(all: &[T], quick: bool) -> Vec<T> {
    if quick {
        all[..1].to_vec()
    } else {
        all.to_vec()
    }
}

mod phyxel_engine {
    use super::*;
    use phyxel::scene::{BuildOptions, Scene};

    /// `(backend, dt)`: `mls` at its stable step, `mls-implicit` at a millisecond and at a
    /// frame (the static sag does not depend on dt; the swing's damping does).
    const CANTILEVER_RUNS: [(&str, Option<f32>); 3] = [
        ("mls", None),
        ("mls-implicit", Some(1e-3)),
        ("mls-implicit", Some(1.0 / 60.0)),
    ];

    /// phyxel's own cantilever measurement (`phyxel validate`'s quick rows): the mean tip
    /// deflection from rest to the first maximum (settled, at frame-rate steps:
    /// [`settled_sag`]), at 3 to 9 phyxels through the thickness (at odd counts a layer
    /// lies on the clamp's face; at even counts the bar is held half a spacing deeper).
    pub fn cantilever(quick: bool) -> Vec<Record> {
        let mut out = Vec::new();
        for through in resolutions(&[3u32, 4, 5, 6, 7, 8, 9], quick) {
            let spacing = (cantilever::THICKNESS / through as f64) as f32;
            for (backend, dt) in CANTILEVER_RUNS {
                eprintln!("phyxel {backend} cantilever, {through} through, dt {dt:?}");
                let (mut d, period, info) =
                    phyxel::validate::cantilever_at(spacing, 0, backend, dt)
                        .unwrap_or_else(|e| panic!("{e}"));
                if dt.is_some_and(|dt| dt > SWING_DT) {
                    d = settled_sag(spacing, backend, dt);
                }
                let (sim_time, wall) = steady_cantilever(spacing, backend, dt);
                out.push(Record {
                    engine: "phyxel",
                    method: backend.into(),
                    case: "cantilever",
                    resolution: through as f64,
                    points: info.phyxels,
                    threads: 0,
                    dt: info.dt as f64,
                    sim_time,
                    wall,
                    measured: d,
                    reference: cantilever::euler_bernoulli_tip(),
                    extra: json!({ "period": period, "surfels": info.surfels }),
                });
            }
        }
        out
    }

    /// Above this step (s) the swing is read settled, not averaged over its first half
    /// period: at 1/60 s backward Euler damps the swing within a period (ω dt = 0.6) and
    /// the half period is six samples, so that mean lies 6–8% below the static sag.
    const SWING_DT: f32 = 0.01;

    /// The built-in cantilever at phyxel and surfel spacing `spacing` on `backend` at `dt`
    /// (`None`: its default).
    fn cantilever_world(spacing: f32, backend: &str, dt: Option<f32>) -> phyxel::world::World {
        let mut scene = Scene::builtin("cantilever").expect("built in");
        scene.objects[0].spacing = spacing;
        scene.objects[0].surfel_spacing = Some(spacing);
        let opts = BuildOptions {
            dt,
            backend: Some(backend.into()),
            ..Default::default()
        };
        scene.build(&opts).unwrap_or_else(|e| panic!("{e}"))
    }

    /// The settled sag (m): the tip's mean deflection over the last 0.5 s of a 2 s run,
    /// as Rapier's damped bar is read.
    fn settled_sag(spacing: f32, backend: &str, dt: Option<f32>) -> f64 {
        let mut w = cantilever_world(spacing, backend, dt);
        let tip = phyxel::validate::CantileverTip::of(&w, spacing);
        let steps = (2.0 / w.dt as f64).round() as usize;
        let last = (0.5 / w.dt as f64).round() as usize;
        let mut sum = 0.0;
        for k in 0..steps {
            w.step();
            if k >= steps - last {
                sum += tip.deflection(&w);
            }
        }
        sum / last as f64
    }

    /// The cantilever's stepping cost, apart from its measurement (which stops at the
    /// first maximum, a few steps at a frame): `(simulated s, wall s)` over 0.2 s after
    /// an untimed first step, as every engine here is timed.
    fn steady_cantilever(spacing: f32, backend: &str, dt: Option<f32>) -> (f64, f64) {
        let mut w = cantilever_world(spacing, backend, dt);
        w.step();
        let steps = (0.2 / w.dt as f64).ceil() as usize;
        let t = Instant::now();
        for _ in 0..steps {
            w.step();
        }
        (steps as f64 * w.dt as f64, t.elapsed().as_secs_f64())
    }

    /// The finest ball `mls-implicit` runs (per radius): at 16 (17,000 phyxels) a run of
    /// 0.16 s takes over 20 minutes and 3 GB (the skyline factor of a soft 3D body, and
    /// the contact solve's iterations).
    const IMPLICIT_BALL_MAX: u32 = 12;

    /// `mls` at its stable step and `mls-implicit` at a millisecond (its contact solve
    /// is the cost on a soft ball: 120 wall s per simulated s at 1/240 s and 8 per radius).
    const BALL_RUNS: [(&str, Option<f32>); 2] = [("mls", None), ("mls-implicit", Some(1e-3))];

    /// The ball at `per_radius` phyxels per radius, surfels at a third of that spacing,
    /// on a static plane 10⁴ times stiffer.
    fn ball_scene(per_radius: u32) -> Scene {
        let s = ball::RADIUS / per_radius as f64;
        let text = format!(
            r#"
name = "ball-impact"
gravity = [0.0, 0.0, 0.0]
[[objects]]
name = "box"
shape = {{ type = "plane", size = [0.4, 0.4] }}
spacing = {s}
surfel_spacing = {ss}
static = true
material = {{ density = {rho}, young = {e_box}, poisson = {nu} }}
[[objects]]
name = "ball"
shape = {{ type = "sphere", radius = {r} }}
spacing = {s}
surfel_spacing = {ss}
position = [0.0, {y}, 0.0]
velocity = [0.0, {v}, 0.0]
rotation = [0.0, 0.0, 90.0]
material = {{ density = {rho}, young = {e}, poisson = {nu} }}
"#,
            ss = s / 3.0,
            rho = ball::DENSITY,
            e = ball::YOUNG,
            e_box = ball::YOUNG * 1e4,
            nu = ball::POISSON,
            r = ball::RADIUS,
            y = ball::RADIUS + ball::GAP,
            v = -ball::SPEED,
        );
        Scene::parse(&text, "ball-impact").unwrap_or_else(|e| panic!("{e}"))
    }

    pub fn ball(quick: bool) -> Vec<Record> {
        let mut out = Vec::new();
        for per_radius in resolutions(&[8u32, 12, 16], quick) {
            for (backend, dt) in BALL_RUNS {
                if backend == "mls-implicit" && per_radius > IMPLICIT_BALL_MAX {
                    continue;
                }
                eprintln!("phyxel {backend} ball, {per_radius} per radius, dt {dt:?}");
                let scene = ball_scene(per_radius);
                let opts = BuildOptions {
                    dt,
                    backend: Some(backend.into()),
                    ..Default::default()
                };
                let mut w = scene.build(&opts).unwrap_or_else(|e| panic!("{e}"));
                let steps = (ball::DURATION / w.dt as f64).ceil() as usize;
                let mut timer = ContactTimer::default();
                let mut wall = 0.0;
                for k in 1..=steps {
                    let t = Instant::now();
                    w.step();
                    if k > 1 {
                        wall += t.elapsed().as_secs_f64();
                    }
                    let p = &w.objects[1].phyxels;
                    let vy = p.momentum()[1] / p.total_mass();
                    timer.push(k as f64 * w.dt as f64, vy, p.centre_of_mass()[1]);
                }
                out.push(ball_record(
                    "phyxel",
                    backend,
                    per_radius,
                    w.objects[1].phyxels.len(),
                    w.dt as f64,
                    (steps - 1) as f64 * w.dt as f64,
                    wall,
                    &timer,
                ));
            }
        }
        out
    }
}

/// The ball's record from its timer.
#[allow(clippy::too_many_arguments)]
fn ball_record(
    engine: &'static str,
    method: &str,
    per_radius: u32,
    points: usize,
    dt: f64,
    sim_time: f64,
    wall: f64,
    timer: &ContactTimer,
) -> Record {
    let c = timer.contact(-ball::SPEED);
    Record {
        engine,
        method: method.into(),
        case: "ball-impact",
        resolution: per_radius as f64,
        points,
        threads: 0,
        dt,
        sim_time,
        wall,
        measured: c.as_ref().map_or(f64::NAN, |c| c.time),
        reference: ball::hertz_contact_time(),
        extra: c.map_or_else(
            || {
                let (v, lowest) = timer.trace().unwrap_or((f64::NAN, f64::NAN));
                json!({ "contact": "none found", "final_velocity": v, "lowest_centre": lowest })
            },
            |c| json!({ "restitution": c.restitution, "lowest_centre": c.lowest }),
        ),
    }
}

mod rapier_engine {
    use super::*;
    use rapier3d::prelude::*;

    /// `(solver, substeps, dt)`: the FEM and constraint solvers at a frame with 4
    /// substeps (Rapier's recommended set-up), and FEM at a frame with one.
    const CANTILEVER_RUNS: [(SoftBodySolver, usize, f32); 3] = [
        (SoftBodySolver::Fem, 4, 1.0 / 60.0),
        (SoftBodySolver::Fem, 1, 1.0 / 60.0),
        (SoftBodySolver::Constraints, 4, 1.0 / 60.0),
    ];

    /// The FEM solver's cap on conjugate-gradient iterations per solve. Rapier's default,
    /// 20, leaves the stiff bar unconverged: at 5 nodes through it swings with 0.6 m
    /// amplitude at a frame and settles 14 times too low. 200 and 1,000 give the same sag
    /// (10.83 and 10.80 mm): converged.
    const FEM_CG_CAP: usize = 1000;

    fn name(solver: SoftBodySolver, substeps: usize) -> String {
        let s = match solver {
            SoftBodySolver::Fem => "fem",
            SoftBodySolver::Constraints => "constraints",
        };
        format!("{s}/{substeps} substeps")
    }

    /// Lumped masses of a box's nodes on an `n[0] × n[1] × n[2]` grid of spacing `h`:
    /// each node carries the volume of the half-cells around it, so gravity loads the bar
    /// as a uniform body (Rapier's `mass` splits a total evenly over the nodes).
    fn lumped_masses(n: [usize; 3], h: [f64; 3], density: f64) -> Vec<f32> {
        let w = |i: usize, n: usize| if i == 0 || i + 1 == n { 0.5 } else { 1.0 };
        let mut m = Vec::with_capacity(n[0] * n[1] * n[2]);
        for i in 0..n[0] {
            for j in 0..n[1] {
                for k in 0..n[2] {
                    let v = w(i, n[0]) * w(j, n[1]) * w(k, n[2]) * h[0] * h[1] * h[2];
                    m.push((density * v) as f32);
                }
            }
        }
        m
    }

    /// Rapier's cantilever: a tetrahedralised grid of 5, 7 and 9 nodes through the
    /// thickness (4, 6 and 8 cells; cubic cells), corotational cells with Rapier's default
    /// damping ratio 1, nodes at x ≤ −0.45 m pinned. The static sag: the mean tip
    /// deflection over the last half second of a 2 s run (11 periods).
    pub fn cantilever(quick: bool) -> Vec<Record> {
        let mut out = Vec::new();
        for through in resolutions(&[5usize, 7, 9], quick) {
            for (solver, substeps, dt) in CANTILEVER_RUNS {
                eprintln!(
                    "rapier {} cantilever, {through} nodes through",
                    name(solver, substeps)
                );
                let cells = through - 1;
                let h = cantilever::THICKNESS / cells as f64;
                let along = (cantilever::LENGTH / h).round() as usize + 1;
                let n = [along, through, through];
                let half = Vector::new(
                    (cantilever::LENGTH / 2.0) as f32,
                    (cantilever::THICKNESS / 2.0) as f32,
                    (cantilever::THICKNESS / 2.0) as f32,
                );
                let builder = SoftBodyBuilder::cuboid(Vector::ZERO, half, n[0], n[1], n[2])
                    .cell_model(SoftBodyCellModel::Corotational)
                    .material(SoftBodyMaterial {
                        young_modulus: cantilever::YOUNG as f32,
                        poisson_ratio: cantilever::POISSON as f32,
                        ..Default::default()
                    })
                    .solver(solver)
                    .no_surface_collider()
                    .can_sleep(false);
                let pos: Vec<Vector> = builder.particle_positions().to_vec();
                let masses = node_masses(&pos, n, h, cantilever::DENSITY);
                let clamp_x = -cantilever::LENGTH / 2.0 + cantilever::CLAMP + 1e-4;
                let tip_x = cantilever::LENGTH / 2.0 - 1e-4;
                let pinned: Vec<u32> = (0..pos.len() as u32)
                    .filter(|&i| (pos[i as usize].x as f64) < clamp_x)
                    .collect();
                let tip: Vec<usize> = (0..pos.len())
                    .filter(|&i| pos[i].x as f64 > tip_x)
                    .collect();
                let pinned_count = pinned.len();
                let mut world = PhysicsWorld::new();
                world.gravity = Vector::new(0.0, -cantilever::GRAVITY as f32, 0.0);
                world.integration_parameters.dt = dt;
                world.integration_parameters.num_solver_iterations = substeps;
                world
                    .integration_parameters
                    .soft_bodies
                    .fem
                    .max_linear_iterations = FEM_CG_CAP;
                let handle =
                    world.insert_soft_body(builder.masses(masses).pinned_particles(pinned));
                let steps = (2.0 / dt as f64).round() as usize;
                let tail = (0.5 / dt as f64).round() as usize;
                let (mut wall, mut sum) = (0.0, 0.0);
                for k in 0..steps {
                    let t = Instant::now();
                    world.step();
                    if k > 0 {
                        wall += t.elapsed().as_secs_f64();
                    }
                    if k >= steps - tail {
                        let sb = &world.soft_bodies[handle];
                        let y = tip
                            .iter()
                            .map(|&i| sb.particle_position(i).y as f64)
                            .sum::<f64>()
                            / tip.len() as f64;
                        sum += -y;
                    }
                }
                out.push(Record {
                    engine: "rapier",
                    method: name(solver, substeps),
                    case: "cantilever",
                    resolution: (through - 1) as f64,
                    points: pos.len(),
                    threads: 0,
                    dt: dt as f64,
                    sim_time: (steps - 1) as f64 * dt as f64,
                    wall,
                    measured: sum / tail as f64,
                    reference: cantilever::euler_bernoulli_tip(),
                    extra: json!({ "nodes_through": through, "pinned_nodes": pinned_count }),
                });
            }
        }
        out
    }

    /// Node masses of the cuboid grid, matched to the builder's positions by their grid
    /// indices (so the lumping does not depend on the builder's numbering).
    fn node_masses(pos: &[Vector], n: [usize; 3], h: f64, density: f64) -> Vec<f32> {
        let lumped = lumped_masses(n, [h; 3], density);
        let origin = [
            -cantilever::LENGTH / 2.0,
            -cantilever::THICKNESS / 2.0,
            -cantilever::THICKNESS / 2.0,
        ];
        pos.iter()
            .map(|p| {
                let idx = |x: f32, o: f64| ((x as f64 - o) / h).round() as usize;
                let (i, j, k) = (
                    idx(p.x, origin[0]),
                    idx(p.y, origin[1]),
                    idx(p.z, origin[2]),
                );
                lumped[(i * n[1] + j) * n[2] + k]
            })
            .collect()
    }

    /// A unit icosphere: the icosahedron split `levels` times, outward triangles.
    fn icosphere(levels: usize) -> (Vec<Vector>, Vec<[u32; 3]>) {
        let t = (1.0 + 5f32.sqrt()) / 2.0;
        let mut v: Vec<Vector> = [
            (-1.0, t, 0.0),
            (1.0, t, 0.0),
            (-1.0, -t, 0.0),
            (1.0, -t, 0.0),
            (0.0, -1.0, t),
            (0.0, 1.0, t),
            (0.0, -1.0, -t),
            (0.0, 1.0, -t),
            (t, 0.0, -1.0),
            (t, 0.0, 1.0),
            (-t, 0.0, -1.0),
            (-t, 0.0, 1.0),
        ]
        .iter()
        .map(|&(x, y, z)| Vector::new(x, y, z).normalize())
        .collect();
        let mut f: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..levels {
            let mut mid = std::collections::HashMap::new();
            let mut split = |a: u32, b: u32, v: &mut Vec<Vector>| -> u32 {
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    v.push(((v[a as usize] + v[b as usize]) * 0.5).normalize());
                    v.len() as u32 - 1
                })
            };
            let mut next = Vec::with_capacity(f.len() * 4);
            for [a, b, c] in f {
                let (ab, bc, ca) = (
                    split(a, b, &mut v),
                    split(b, c, &mut v),
                    split(c, a, &mut v),
                );
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            f = next;
        }
        (v, f)
    }

    /// The finest ball the FEM solver runs (cells per radius; 43 s of wall time for the
    /// 0.16 s run at 8, growing past 10 minutes at 16).
    const FEM_BALL_MAX: u32 = 12;

    /// FEM at a 240th of a second (at a millisecond it costs 1,250 wall s per simulated
    /// s at 8 cells per radius: 2.5 min for this run alone) and the constraints at a
    /// millisecond.
    const BALL_RUNS: [(SoftBodySolver, usize, f32); 2] = [
        (SoftBodySolver::Fem, 4, 1.0 / 240.0),
        (SoftBodySolver::Constraints, 4, 1e-3),
    ];

    /// Rapier's ball: an icosphere (1,280 triangles) filled with cells of R/8, R/12 and
    /// R/16, mass split evenly over the nodes (no gravity here: only the total and the
    /// inertia matter), thrown at a fixed cuboid collider.
    pub fn ball(quick: bool) -> Vec<Record> {
        let mut out = Vec::new();
        for per_radius in resolutions(&[8u32, 12, 16], quick) {
            for (solver, substeps, dt) in BALL_RUNS {
                if solver == SoftBodySolver::Fem && per_radius > FEM_BALL_MAX {
                    continue;
                }
                eprintln!(
                    "rapier {} ball, {per_radius} per radius, dt {dt}",
                    name(solver, substeps)
                );
                let (unit, tris) = icosphere(3);
                let r = ball::RADIUS as f32;
                let centre = Vector::new(0.0, (ball::RADIUS + ball::GAP) as f32, 0.0);
                let verts: Vec<Vector> = unit.iter().map(|&u| centre + u * r).collect();
                let cell = r / per_radius as f32;
                let builder = SoftBodyBuilder::volumetric(&verts, &tris, cell)
                    .expect("a closed sphere")
                    .cell_model(SoftBodyCellModel::Corotational)
                    .material(SoftBodyMaterial {
                        young_modulus: ball::YOUNG as f32,
                        poisson_ratio: ball::POISSON as f32,
                        ..Default::default()
                    })
                    .solver(solver)
                    .mass(ball::mass() as f32)
                    .can_sleep(false);
                let mut world = PhysicsWorld::new();
                world.gravity = Vector::ZERO;
                world.integration_parameters.dt = dt;
                world.integration_parameters.num_solver_iterations = substeps;
                world
                    .integration_parameters
                    .soft_bodies
                    .fem
                    .max_linear_iterations = FEM_CG_CAP;
                world.insert(
                    RigidBodyBuilder::fixed().translation(Vector::new(0.0, -0.1, 0.0)),
                    ColliderBuilder::cuboid(0.5, 0.1, 0.5),
                );
                let handle = world.insert_soft_body(builder);
                let n = world.soft_bodies[handle].num_particles();
                let v0 = Vector::new(0.0, -ball::SPEED as f32, 0.0);
                for i in 0..n {
                    world.soft_bodies[handle].set_particle_velocity(i, v0);
                }
                let steps = (ball::DURATION / dt as f64).ceil() as usize;
                let mut timer = ContactTimer::default();
                let mut wall = 0.0;
                for k in 1..=steps {
                    let t = Instant::now();
                    world.step();
                    if k > 1 {
                        wall += t.elapsed().as_secs_f64();
                    }
                    let sb = &world.soft_bodies[handle];
                    let vy = sb.particle_velocities().map(|v| v.y as f64).sum::<f64>() / n as f64;
                    timer.push(k as f64 * dt as f64, vy, sb.center_of_mass().y as f64);
                }
                out.push(ball_record(
                    "rapier",
                    &name(solver, substeps),
                    per_radius,
                    n,
                    dt as f64,
                    (steps - 1) as f64 * dt as f64,
                    wall,
                    &timer,
                ));
            }
        }
        out
    }
}
