//! Surfel advection: the fast path (affine table, direct column writes) against the
//! scalar reference sum, on a deformed sphere with 10k surfels on 400 phyxels and 1M
//! surfels on 20k phyxels (the `scale` scene's proportions per object),
//! on rayon's default pool (as `World::advect` runs it).
//! Run: `cargo bench --bench advect -- --warm-up-time 1 --measurement-time 5 --noplot`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{Mat3, Quat, Vec3};
use phyxel::body::advect::SurfelBinding;
use phyxel::body::shape::Shape;
use phyxel::dynamics::gradient::MlsStencil;
use phyxel::points::phyxels::Phyxels;
use phyxel::points::surfels::Surfels;
use std::hint::black_box;

/// A sphere of radius 0.1 m with about `phyxels` phyxels and `surfels` surfels, rotated,
/// stretched and bent, with its MLS displacement gradients.
fn deformed_ball(phyxels: usize, surfels: usize) -> (Surfels, Phyxels, Vec<Mat3>) {
    let r = 0.1f32;
    let shape = Shape::Sphere { radius: r };
    let pi = std::f32::consts::PI;
    let vol = shape.sample_volume((4.0 / 3.0 * pi * r.powi(3) / phyxels as f32).cbrt());
    let surf = shape.sample_surface((4.0 * pi * r * r / surfels as f32).sqrt());
    let mut p = Phyxels::at_rest(&vol.positions, vol.cell_volume, 1000.0);
    let s = Surfels::at_rest(&surf.positions, &surf.normals, &surf.radii);
    let rot = Mat3::from_quat(Quat::from_axis_angle(
        Vec3::new(1.0, 2.0, -0.5).normalize(),
        0.7,
    ));
    let stretch = Mat3::from_diagonal(Vec3::new(1.2, 0.9, 1.05));
    for i in 0..p.len() {
        let d = p.rest.get(i);
        let bend = Vec3::new(0.0, 3.0 * d.x * d.x, -2.0 * d.x * d.y);
        p.pos.set(i, rot * (stretch * d + bend));
        p.vel.set(i, Vec3::new(-d.y, d.x, 0.5));
    }
    let mut grad = vec![Mat3::ZERO; p.len()];
    MlsStencil::build(&p).displacement_gradients(&p.pos, &p.rest, &mut grad);
    (s, p, grad)
}

fn advect(c: &mut Criterion) {
    for (label, phyxels, surfels) in [("10k", 400, 10_000), ("1M", 20_000, 1_000_000)] {
        let (mut s, p, grad) = deformed_ball(phyxels, surfels);
        let mut binding = SurfelBinding::build(&s, &p);
        let mut g = c.benchmark_group(format!("advect_{label}"));
        g.throughput(Throughput::Elements(s.len() as u64));
        if surfels > 100_000 {
            g.sample_size(10);
        }
        g.bench_function("fast", |b| {
            b.iter(|| binding.advect(black_box(&mut s), &p, &grad))
        });
        g.bench_function("reference", |b| {
            b.iter(|| phyxel::testing::advect_reference(&binding, black_box(&mut s), &p, &grad))
        });
        g.finish();
    }
}

criterion_group!(benches, advect);
criterion_main!(benches);
