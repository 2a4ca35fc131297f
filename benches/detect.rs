//! Collision detection and whole steps at scale: two spheres of radius R = 0.1 m whose
//! surfaces overlap by 5 mm (centres 0.195 m apart, at rest, no gravity), sampled with
//! 10k, 100k and 1M surfels each (surfel spacing `√(4πR²/N)`) and 390, 2,800 and 20,000
//! phyxels each: the paper's size, the performance issue's 1M size, and their log-linear
//! interpolation (the phyxel count grows with the resolution, `N^0.86`).
//!
//! Every measured step starts from the same state: before each step the phyxels and
//! surfels are restored from a copy taken after building (outside the timed region), so
//! the overlap stays 5 mm and every step tests the same candidates. Per size:
//!
//! - `detect_<size>/step`: a whole `world.step()` (dynamics, advection, broad phase,
//!   surfel grids, detection, contact surface, forces, distribution);
//! - `detect_<size>/phases`: the detection phases alone, `broad_phase + grids +
//!   detect`, as timed by the step's own phase timers (`world.record.times`); the World's phase
//!   functions are private, so each iteration still runs a whole step, but only these
//!   three phases count. Throughput is in candidate surfels (surfels of either sphere in
//!   the broad phase's intersection box): µs per candidate = 1000 / (Kelem/s).
//!
//! - `threads_100k/1` and `/2`, `threads_1m/1` and `/2`: the whole step at 100k and at
//!   1M in a 1- and a 2-thread rayon pool.
//!
//! After each size a table of per-phase medians over every step criterion ran (warm-up
//! included) is printed to stderr, with the candidate and colliding counts, followed by
//! a single-thread split of the candidates by path through detection (`paths`: near the
//! other surface, far inside it, far outside) with the time per candidate of each.
//!
//! 1M surfels per sphere runs with criterion's smallest sample count (10): a step takes
//! tens of milliseconds, and building the 1M world about ten seconds.
//! `PHYXEL_BENCH_1M=0` leaves the 1M size out.
//!
//! Run: `cargo bench --bench detect -- --warm-up-time 1 --measurement-time 5`
//! (one criterion size: append `detect_100k`). Numbers go to docs/PERFORMANCE.md.

use criterion::{
    BenchmarkGroup, Criterion, Throughput, criterion_group, criterion_main, measurement::WallTime,
};
use glam::Vec3;
use phyxel::contact::field::{FAR_NEIGHBOURS, SurfaceField, grid_cell};
use phyxel::scene::{BuildOptions, Scene};
use phyxel::spatial::broad_phase::{Aabb, points_in_box};
use phyxel::spatial::grid::Grid;
use phyxel::world::phase::{Phase, PhaseTimes};
use phyxel::{Phyxels, Surfels, World};
use std::f32::consts::PI;
use std::time::{Duration, Instant};

/// Sphere radius (m).
const R: f32 = 0.1;
/// Overlap of the two surfaces (m): centres are `2R − OVERLAP` apart. At most the 1M
/// size's phyxel spacing (7 mm), or the scene check refuses bodies that start inside one
/// another.
const OVERLAP: f32 = 0.005;
/// Phyxels per sphere for `n` surfels per sphere: 390 at 10k (the paper), 20,000 at 1M
/// (the performance issue), log-linear in between.
fn phyxels_for(n: usize) -> u32 {
    let slope = (20_000.0f64 / 390.0).ln() / 100.0f64.ln();
    (390.0 * (n as f64 / 1.0e4).powf(slope)).round() as u32
}

/// The detection phases measured by the `phases` benches.
const DETECTION: [Phase; 3] = [Phase::BroadPhase, Phase::Grids, Phase::Detect];

/// Surfel spacing that samples a sphere of radius `R` with about `n` surfels.
fn surfel_spacing(n: usize) -> f32 {
    (4.0 * PI * R * R / n as f32).sqrt()
}

fn scene_toml(n: usize) -> String {
    let x = 0.5 * (2.0 * R - OVERLAP);
    let s = surfel_spacing(n);
    let phyxels = phyxels_for(n);
    let sphere = |name: &str, x: f32| {
        format!(
            "[[objects]]\nname = \"{name}\"\nshape = {{ type = \"sphere\", radius = {R} }}\n\
             phyxels = {phyxels}\nsurfel_spacing = {s:e}\nposition = [{x}, 0.0, 0.0]\n\
             velocity = [0.0, 0.0, 0.0]\n\
             material = {{ density = 1000.0, young = 1.0e5, poisson = 0.3 }}\n"
        )
    };
    format!(
        "name = \"detect-bench\"\ngravity = [0.0, 0.0, 0.0]\n\n{}\n{}",
        sphere("left", -x),
        sphere("right", x)
    )
}

/// One measured step: seconds per phase (in `Phase::ALL` order), candidates tested,
/// colliding surfels found.
type Record = ([f64; Phase::ALL.len()], u64, usize);

/// A world and the state every measured step starts from.
struct Bench {
    world: World,
    start: Vec<(Phyxels, Surfels)>,
    /// Every measured step.
    records: Vec<Record>,
}

impl Bench {
    fn new(n: usize) -> Self {
        let t = Instant::now();
        let scene = Scene::parse(&scene_toml(n), "detect bench").expect("bench scene parses");
        let world = scene
            .build(&BuildOptions::default())
            .expect("bench scene builds");
        let start = world
            .objects
            .iter()
            .map(|o| (o.phyxels.clone(), o.surfels.clone()))
            .collect();
        let o = &world.objects[0];
        eprintln!(
            "detect bench n = {n}: {} surfels and {} phyxels per sphere, surfel spacing {:.3e} m, \
             dt {:.3e} s, built in {:.1} s",
            o.surfels.len(),
            o.phyxels.len(),
            surfel_spacing(n),
            world.dt,
            t.elapsed().as_secs_f64()
        );
        Self {
            world,
            start,
            records: Vec::new(),
        }
    }

    /// Restores the start state (not timed), runs one step and records its phase times.
    /// Returns the step's whole wall time and that of the detection phases.
    fn step(&mut self) -> (Duration, Duration) {
        for (o, (p, s)) in self.world.objects.iter_mut().zip(&self.start) {
            o.phyxels.clone_from(p);
            o.surfels.clone_from(s);
        }
        let before: PhaseTimes = self.world.record.times.clone();
        let t = Instant::now();
        self.world.step();
        let whole = t.elapsed();
        let after = &self.world.record.times;
        let secs = Phase::ALL.map(|p| after.seconds(p) - before.seconds(p));
        let tested = after.work(Phase::Detect) - before.work(Phase::Detect);
        let colliding = self
            .world
            .detections
            .iter()
            .map(|d| d.a_in_b.len() + d.b_in_a.len())
            .sum();
        self.records.push((secs, tested, colliding));
        let detection = DETECTION.iter().map(|&p| secs[p as usize]).sum::<f64>();
        (whole, Duration::from_secs_f64(detection))
    }

    /// Prints per-phase medians over the recorded steps.
    fn report(&self, label: &str, source: &str) {
        let n = self.records.len();
        if n == 0 {
            return;
        }
        let median = |f: &dyn Fn(&Record) -> f64| {
            let mut v: Vec<f64> = self.records.iter().map(f).collect();
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let ms = |x: f64| x * 1.0e3;
        let candidates = self.records[0].1;
        let colliding = self.records[0].2;
        let stable = self
            .records
            .iter()
            .all(|r| r.1 == candidates && r.2 == colliding);
        eprintln!("{label}: medians over {n} steps ({source})");
        for p in Phase::ALL {
            eprintln!(
                "  {:<16} {:>10.3} ms/step",
                p.name(),
                ms(median(&|r| r.0[p as usize]))
            );
        }
        let det = median(&|r| DETECTION.iter().map(|&p| r.0[p as usize]).sum());
        let whole = median(&|r| r.0.iter().sum());
        eprintln!(
            "  whole step (sum) {:>10.3} ms/step\n  detection phases {:>10.3} ms/step \
             (broad_phase + grids + detect)",
            ms(whole),
            ms(det)
        );
        eprintln!(
            "  candidates/step {candidates}, colliding/step {colliding}{}; \
             detection {:.3} µs/candidate, detect alone {:.3} µs/candidate",
            if stable { "" } else { " (NOT constant!)" },
            det * 1.0e6 / candidates.max(1) as f64,
            median(&|r| r.0[Phase::Detect as usize]) * 1.0e6 / candidates.max(1) as f64,
        );
    }

    /// Where detection's time goes, single thread, on the start state: the candidates of
    /// the left sphere against the right sphere's implicit surface, split like
    /// `colliding_surfels` splits them. *Near*: within the kernels' reach of the other
    /// surface, projected from there. *Far inside* (analytically inside the other
    /// sphere): projected starting with the far-field sample, whose `k_nearest` of
    /// `FAR_NEIGHBOURS` surfels is timed alone too. *Far outside*: rejected by the
    /// phyxel-volume query (not timed here).
    fn paths(&self) {
        let (sa, sb) = (&self.start[0].1, &self.start[1].1);
        let r_max = sb.radius[..sb.len()].iter().fold(0.0f32, |a, &b| a.max(b));
        let grid = Grid::build(sb.pos.iter(), grid_cell(r_max));
        let surface = SurfaceField::new(&sb.pos, &sb.normal, &sb.radius, &grid);
        let bounds = Aabb::of(&sa.pos)
            .intersection(&Aabb::of(&sb.pos))
            .expect("the spheres overlap");
        let mut candidates = Vec::new();
        points_in_box(&sa.pos, &bounds, &mut candidates);
        let centre_b = Vec3::new(0.5 * (2.0 * R - OVERLAP), 0.0, 0.0);
        // Per-call wall times (s); medians, since a preempted call would skew a mean.
        let (mut sample, mut near, mut far, mut knn_far) = (vec![], vec![], vec![], vec![]);
        let mut far_out = 0usize;
        let mut knn = Vec::with_capacity(FAR_NEIGHBOURS);
        let mut depth_far = 0.0f64;
        for &c in &candidates {
            let x = sa.pos.get(c as usize);
            let t = Instant::now();
            let s = std::hint::black_box(surface.sample_near(x));
            sample.push(t.elapsed().as_secs_f64());
            let depth = R - (x - centre_b).length();
            if s.is_none() && depth <= 0.0 {
                far_out += 1;
                continue;
            }
            let t = Instant::now();
            std::hint::black_box(surface.project(x));
            let dt = t.elapsed().as_secs_f64();
            if s.is_some() {
                near.push(dt);
            } else {
                far.push(dt);
                depth_far += depth as f64;
                let t = Instant::now();
                grid.k_nearest(x, FAR_NEIGHBOURS, &mut knn);
                knn_far.push(t.elapsed().as_secs_f64());
            }
        }
        // "median (mean)" in µs: the mean also counts preempted calls, but it is what
        // adds up to the phase's time when the cost depends on depth.
        let us = |v: &mut Vec<f64>| {
            if v.is_empty() {
                return "-".to_string();
            }
            v.sort_by(f64::total_cmp);
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            format!("{:.3} ({:.3})", v[v.len() / 2] * 1.0e6, mean * 1.0e6)
        };
        let spacing = sb.len() as f64;
        let spacing = (4.0 * std::f64::consts::PI * (R as f64).powi(2) / spacing).sqrt();
        eprintln!(
            "  paths (left sphere's {} candidates, one thread, µs per call: median (mean)): \
             kernel reach {:.3} mm, overlap {:.1} surfel spacings\n  sample_near {}; near {}: \
             project {}; far inside {} (mean depth {:.2} mm): project {}, \
             k_nearest({FAR_NEIGHBOURS}) alone {}; far outside {far_out}",
            candidates.len(),
            grid_cell(r_max) * 1.0e3,
            OVERLAP as f64 / spacing,
            us(&mut sample),
            near.len(),
            us(&mut near),
            far.len(),
            depth_far * 1.0e3 / far.len().max(1) as f64,
            us(&mut far),
            us(&mut knn_far),
        );
    }
}

fn bench_size(g: &mut BenchmarkGroup<'_, WallTime>, b: &mut Bench) {
    g.bench_function("step", |bn| {
        bn.iter_custom(|iters| (0..iters).map(|_| b.step().0).sum())
    });
    // Criterion's per-element rate for the phases: candidates per step (fixed).
    let candidates = b.records.last().map_or(1, |r| r.1);
    g.throughput(Throughput::Elements(candidates));
    g.bench_function("phases", |bn| {
        bn.iter_custom(|iters| (0..iters).map(|_| b.step().1).sum())
    });
}

fn detect(c: &mut Criterion) {
    let with_1m = std::env::var("PHYXEL_BENCH_1M").map_or(true, |v| v != "0");
    let sizes = [("10k", 10_000), ("100k", 100_000), ("1m", 1_000_000)];
    for (size, n) in sizes {
        if n == 1_000_000 && !with_1m {
            continue;
        }
        // Criterion's smallest sample count where a step takes tens of milliseconds.
        let samples = if n >= 1_000_000 { 10 } else { 100 };
        let label = format!("detect_{size}");
        let mut g = c.benchmark_group(&label);
        g.sample_size(samples);
        let mut b = Bench::new(n);
        bench_size(&mut g, &mut b);
        g.finish();
        b.report(&label, "criterion warm-up and samples");
        b.paths();
        if n >= 100_000 {
            threads(c, &format!("threads_{size}"), samples, &mut b);
        }
    }
}

/// Whole steps of `b` in a 1- and a 2-thread pool (the loop runs inside the pool, as
/// `phyxel run` does).
fn threads(c: &mut Criterion, label: &str, samples: usize, b: &mut Bench) {
    let mut g = c.benchmark_group(label);
    g.sample_size(samples);
    for n in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .expect("thread pool");
        g.bench_function(n.to_string(), |bn| {
            bn.iter_custom(|iters| pool.install(|| (0..iters).map(|_| b.step().0).sum()))
        });
    }
    g.finish();
}

criterion_group!(benches, detect);

criterion_main!(benches);
