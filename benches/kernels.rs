//! SIMD kernels against their scalar references, single-threaded, same inputs:
//! implicit-surface kernel sums and contact-force distribution.
//! Run: `cargo bench --bench kernels -- --warm-up-time 1 --measurement-time 3 --noplot`;
//! the ratios go to docs/PERFORMANCE.md.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use phyxel::columns::Vec3s;
use phyxel::grid::Grid;
use phyxel::implicit::{ImplicitSurface, SurfelRows, grid_cell};
use phyxel::shape::Shape;
use std::hint::black_box;

/// Implicit-surface kernel sums (eq. 1): the batched SIMD kernel (hits in batches,
/// lane `exp`, one row multiply-add per hit over `SurfelRows`) against the scalar
/// per-hit reference, at 4096 points within ±1.5 spacings of a sphere of radius 0.1 m
/// sampled with 10k surfels (each point a fresh grid query).
fn implicit_sums(c: &mut Criterion) {
    let r = 0.1f32;
    let spacing = (4.0 * std::f32::consts::PI * r * r / 10_000.0).sqrt();
    let s = Shape::Sphere { radius: r }.sample_surface(spacing);
    let pos = Vec3s::from_points(&s.positions);
    let normal = Vec3s::from_points(&s.normals);
    let r_max = s.radii.iter().fold(0.0f32, |a, &b| a.max(b));
    let grid = Grid::build(pos.iter(), grid_cell(r_max));
    let mut rows = SurfelRows::default();
    rows.rebuild(&grid, &pos, &normal, &s.radii);
    let reference = ImplicitSurface::new(&pos, &normal, &s.radii, &grid);
    let surface = reference.with_rows(&rows);
    let golden = 0.618_034f32;
    let points: Vec<Vec3> = (0..4096)
        .map(|i| {
            let f = i as f32;
            let z = 1.0 - 2.0 * (f + 0.5) / 4096.0;
            let phi = std::f32::consts::TAU * golden * f;
            let rho = (1.0 - z * z).sqrt();
            let depth = ((f * 0.37).fract() - 0.5) * 3.0 * spacing;
            Vec3::new(rho * phi.cos(), rho * phi.sin(), z) * (r + depth)
        })
        .collect();
    let mut g = c.benchmark_group("implicit_sums");
    g.throughput(Throughput::Elements(points.len() as u64));
    g.bench_function("simd", |b| {
        b.iter(|| {
            points
                .iter()
                .map(|&x| surface.weighted_sums(black_box(x)).0)
                .sum::<f32>()
        })
    });
    g.bench_function("scalar", |b| {
        b.iter(|| {
            points
                .iter()
                .map(|&x| reference.weighted_sums(black_box(x)).0)
                .sum::<f32>()
        })
    });
    g.finish();
}

/// Contact-force distribution (eqs. 8–9): SIMD lane groups of the phyxel grid against
/// the scalar per-phyxel reference, 2,000 contact surfels in a shell half an influence
/// radius around `two-spheres`' first sphere (390 phyxels, about 40 within reach each).
fn distribution(c: &mut Criterion) {
    use phyxel::contact::{ContactSurfel, DistributeScratch, distribute, distribute_reference};
    let scene = phyxel::scene::Scene::builtin("two-spheres").expect("built-in scene");
    let w = scene
        .build(&phyxel::scene::BuildOptions::default())
        .expect("scene builds");
    let o = &w.objects[0];
    let h = o.max_influence;
    let grid = Grid::build(o.phyxels.pos.iter(), h);
    let c0 = o.phyxels.centre_of_mass();
    let centre = Vec3::new(c0[0] as f32, c0[1] as f32, c0[2] as f32);
    let radius = o
        .surfels
        .pos
        .iter()
        .map(|p| p.distance(centre))
        .fold(0.0f32, f32::max);
    let golden = 0.618_034f32;
    let surfels: Vec<ContactSurfel> = (0..2000)
        .map(|i| {
            let f = i as f32;
            let z = 1.0 - 2.0 * (f + 0.5) / 2000.0;
            let phi = std::f32::consts::TAU * golden * f;
            let rho = (1.0 - z * z).sqrt();
            let dir = Vec3::new(rho * phi.cos(), rho * phi.sin(), z);
            let r = radius + ((f * 0.37).fract() - 0.5) * h;
            ContactSurfel {
                pos: centre + r * dir,
                normal: dir,
                object: 0,
                area: 1.0,
                force: -dir,
                anchor_a: Vec3::ZERO,
                anchor_b: Vec3::ZERO,
                velocity: Vec3::ZERO,
            }
        })
        .collect();
    let mut g = c.benchmark_group("distribute");
    g.throughput(Throughput::Elements(surfels.len() as u64));
    let mut phyxels = o.phyxels.clone();
    let mut scratch = DistributeScratch::default();
    g.bench_function("simd", |b| {
        b.iter(|| {
            distribute(
                black_box(&surfels),
                1.0,
                &mut phyxels,
                &grid,
                h,
                &mut scratch,
            )
        })
    });
    g.bench_function("scalar", |b| {
        b.iter(|| {
            distribute_reference(
                black_box(&surfels),
                1.0,
                &mut phyxels,
                &grid,
                h,
                &mut scratch,
            )
        })
    });
    g.finish();
}

criterion_group!(benches, implicit_sums, distribution);
criterion_main!(benches);
