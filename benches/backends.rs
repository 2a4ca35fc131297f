//! One backend step of a block resting on a plane, per backend, at 10k and 100k phyxels,
//! on one core (a one-thread rayon pool), neighbour search included.
//! Run: `cargo bench --bench backends`; throughput is in phyxels per second
//! (µs per particle-step = 1e6 / throughput); numbers go to docs/PERFORMANCE.md.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use phyxel::dynamics::StepContext;
use phyxel::scene::{BuildOptions, Scene};

/// A block of about `n` phyxels resting on a static plane.
fn block_scene(n: u32, backend: &str) -> Scene {
    Scene::parse(
        &format!(
            r#"
name = "block-{n}"
[[objects]]
name = "ground"
shape = {{ type = "plane", size = [0.6, 0.6] }}
spacing = 0.05
surfel_spacing = 0.02
static = true
[[objects]]
name = "block"
shape = {{ type = "box", size = [0.4, 0.2, 0.4] }}
phyxels = {n}
surfels = 4000
position = [0.0, 0.1, 0.0]
backend = "{backend}"
"#
        ),
        "bench",
    )
    .expect("bench scene is valid")
}

fn backend_steps(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    let mut g = c.benchmark_group("backend_step");
    g.sample_size(10);
    for n in [10_000u32, 100_000] {
        for backend in ["mls", "sph", "lj"] {
            let scene = block_scene(n, backend);
            let mut world = pool.install(|| scene.build(&BuildOptions::default()).unwrap());
            // A few whole steps: the block touches the plane and carries contact forces.
            pool.install(|| (0..3).for_each(|_| world.step()));
            let (dt, gravity) = (world.dt, world.gravity);
            let o = &mut world.objects[1];
            g.throughput(Throughput::Elements(o.phyxels.len() as u64));
            g.bench_function(format!("{backend}/{n}"), |b| {
                b.iter(|| {
                    pool.install(|| {
                        let ctx = StepContext::new(dt, gravity, &o.material);
                        o.dynamics.step(&mut o.phyxels, &ctx);
                    })
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, backend_steps);
criterion_main!(benches);
