//! One criterion group per phase of the step, and whole steps, on the `scale` scene
//! (two elastic spheres pressing into each other, as `phyxel run scale`) at the paper's
//! size (2 × 10k surfels, 2 × 390 phyxels) and at 2 × 100k surfels (2 × 3,900 phyxels).
//!
//! Each size is run for `WARM_STEPS` steps first, so that the spheres are in contact;
//! that state is the start of every measurement. Both sizes step with the finer one's
//! dt (the default dt shrinks with the phyxel spacing), so that they reach the same
//! stage of the same motion, as in the scaling protocol of docs/PERFORMANCE.md.
//! `phase_<name>/<size>` times [`World::run_phase`] alone on that state
//! (the phases before it in the step have run on it, so it sees what the step would
//! give it); `step/<size>` times a whole `world.step()`. Phases that change the state
//! (`dynamics`, `advect`, `distribute`) are restored from the start state before each
//! sample batch, outside the timed region. Run alone, the broad phase, the grid regions
//! and the candidate scans read every surfel position; within a step they use the
//! advection's block boxes, so `broad_phase`, `grids` and `detect` cost a step
//! less than their groups here. At 2 × 1M surfels, whole steps are criterion groups of
//! `benches/detect.rs`, and `phyxel run scale --surfels 1000000 --phyxel-count 20000
//! --json` prints the per-phase times of a run (docs/PERFORMANCE.md).
//!
//! Run: `cargo bench --bench phases -- --warm-up-time 1 --measurement-time 3 --noplot`
//! (one phase: append its name, e.g. `phase_detect`).

use criterion::{Criterion, criterion_group, criterion_main};
use phyxel::scene::{BuildOptions, Scene};
use phyxel::world::phase::Phase;
use phyxel::{Phyxels, Surfels, World};
use std::time::{Duration, Instant};

/// Steps run before measuring, so that the spheres are pressed into each other.
const WARM_STEPS: usize = 60;

struct Sized {
    label: &'static str,
    world: World,
    start: Vec<(Phyxels, Surfels)>,
}

impl Sized {
    fn new(label: &'static str, surfels: u32, phyxels: u32, dt: Option<f32>) -> Self {
        let scene = Scene::builtin("scale").expect("built-in scale scene");
        let options = BuildOptions {
            surfels: Some(surfels),
            phyxels: Some(phyxels),
            ..Default::default()
        };
        let mut world = scene.build(&options).expect("scale scene builds");
        if let Some(dt) = dt {
            assert!(dt <= world.dt, "a common dt must be stable at every size");
            world.dt = dt;
        }
        for _ in 0..WARM_STEPS {
            world.step();
        }
        let start = world
            .objects
            .iter()
            .map(|o| (o.phyxels.clone(), o.surfels.clone()))
            .collect();
        Self {
            label,
            world,
            start,
        }
    }

    /// Back to the start state, with every phase's output made from it by one step.
    fn restore(&mut self) {
        for (o, (p, s)) in self.world.objects.iter_mut().zip(&self.start) {
            o.phyxels.clone_from(p);
            o.surfels.clone_from(s);
        }
    }
}

/// Phases that change the simulated state (restored between sample batches).
fn changes_state(p: Phase) -> bool {
    matches!(p, Phase::Dynamics | Phase::Advect | Phase::Distribute)
}

fn phases(c: &mut Criterion) {
    let fine = Sized::new("100k", 100_000, 3_900, None);
    let mut sizes = [Sized::new("10k", 10_000, 390, Some(fine.world.dt)), fine];
    let mut g = c.benchmark_group("step");
    g.sample_size(20);
    for s in sizes.iter_mut() {
        g.bench_function(s.label, |b| {
            b.iter_custom(|iters| {
                let mut t = Duration::ZERO;
                for _ in 0..iters {
                    s.restore();
                    let t0 = Instant::now();
                    s.world.step();
                    t += t0.elapsed();
                }
                t
            })
        });
    }
    g.finish();
    for phase in Phase::ALL {
        let mut g = c.benchmark_group(format!("phase_{}", phase.name()));
        g.sample_size(20);
        for s in sizes.iter_mut() {
            // The step's outputs (grids, detections, patches) from the start state.
            s.restore();
            s.world.step();
            s.restore();
            g.bench_function(s.label, |b| {
                b.iter_custom(|iters| {
                    if changes_state(phase) {
                        s.restore();
                    }
                    let t0 = Instant::now();
                    for _ in 0..iters {
                        s.world.run_phase(phase);
                    }
                    t0.elapsed()
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, phases);
criterion_main!(benches);
