//! Whole steps of the built-in scenes and the MLS force kernel.
//! Run: `cargo bench --bench step`; numbers go to docs/PERFORMANCE.md.

use criterion::{Criterion, criterion_group, criterion_main};
use phyxel::scene::{BuildOptions, Scene};
use std::hint::black_box;

fn steps(c: &mut Criterion) {
    let mut g = c.benchmark_group("step");
    for name in ["falling-sphere", "two-spheres", "cantilever"] {
        let scene = Scene::builtin(name).unwrap();
        let mut world = scene.build(&BuildOptions::default()).unwrap();
        g.bench_function(name, |b| b.iter(|| world.step()));
    }
    g.finish();
}

fn mls_forces(c: &mut Criterion) {
    let scene = Scene::builtin("cantilever").unwrap();
    let world = scene.build(&BuildOptions::default()).unwrap();
    let o = &world.objects[0];
    let mut mls = phyxel::backends::mls::MlsDynamics::new(&o.phyxels, &o.material);
    c.bench_function("mls_forces/cantilever", |b| {
        b.iter(|| mls.compute_forces(black_box(&o.phyxels), &o.material, world.dt))
    });
}

criterion_group!(benches, steps, mls_forces);
criterion_main!(benches);
