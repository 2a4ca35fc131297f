//! SIMD kernels against their scalar references, single-threaded, same inputs:
//! implicit-surface kernel sums, contact-force distribution and the MLS forces.
//! Run: `cargo bench --bench kernels -- --warm-up-time 1 --measurement-time 3 --noplot`;
//! the scalar versions are the SIMD kernels' test oracles; their speed ratio is not a
//! target (docs/PERFORMANCE.md, "Rules").

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use phyxel::body::shape::Shape;
use phyxel::columns::Vec3s;
use phyxel::contact::field::{SurfaceField, SurfelRows, grid_cell};
use phyxel::spatial::grid::Grid;
use std::hint::black_box;

/// Implicit-surface kernel sums (eq. 1): the SIMD kernel (each lane group of the grid
/// query with a hit becomes eight lane weights, `exp_neg`, added with the surfels'
/// `SurfelRows` columns into lane sums) against the scalar
/// reference (scalar grid query, libm `exp`, per-hit adds) and against the per-hit
/// kernel over the lane query, at 4096 points within ±1.5 spacings of a sphere of radius 0.1 m
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
    let reference = SurfaceField::new(&pos, &normal, &s.radii, &grid);
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
    // The scalar reference: scalar grid query, libm `exp`, per-hit vector adds.
    g.bench_function("scalar", |b| {
        b.iter(|| {
            points
                .iter()
                .map(|&x| phyxel::testing::weighted_sums_scalar(&reference, black_box(x)).0)
                .sum::<f32>()
        })
    });
    // The per-hit kernel over the lane query (the step's path outside the rows' region):
    // separates the kernel's gain from the query's.
    g.bench_function("scalar_kernel_lane_query", |b| {
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
    use phyxel::contact::{ContactSurfel, DistributeScratch, distribute};
    use phyxel::testing::distribute_reference;
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
                surfel: phyxel::contact::NO_SURFEL,
                area: 1.0,
                force: -dir,
                anchor_a: Vec3::ZERO,
                anchor_b: Vec3::ZERO,
                velocity: Vec3::ZERO,
                stick: Vec3::ZERO,
                scale: 1.0,
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

/// MLS internal forces (gradients, law, force gather) of a deformed, moving ball: the lane
/// kernel (`compute_forces`) against the scalar reference (`compute_forces_reference`),
/// at the phyxel counts of one `scale` object at 10k and at 1M surfels (about 390 and
/// 20k phyxels).
fn mls_forces(c: &mut Criterion) {
    use phyxel::backends::mls::MlsDynamics;
    use phyxel::material::Material;
    use phyxel::points::phyxels::Phyxels;
    let mat = Material::default();
    // The kernel runs rayon tasks: one thread, as the other kernels here.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    let mut g = c.benchmark_group("mls_forces");
    for (label, phyxels) in [("390", 390.0f32), ("20k", 20_000.0)] {
        let r = 0.1f32;
        let spacing = (4.0 / 3.0 * std::f32::consts::PI * r.powi(3) / phyxels).cbrt();
        let v = Shape::Sphere { radius: r }.sample_volume(spacing);
        let mut p = Phyxels::at_rest(&v.positions, v.cell_volume, mat.density);
        for i in 0..p.len() {
            let x = p.rest.get(i);
            p.pos
                .set(i, x + Vec3::new(0.02 * x.y, -0.01 * x.x, 0.03 * x.z));
            p.vel.set(i, Vec3::new(x.z, 0.5 * x.x, -x.y));
        }
        let mut m = MlsDynamics::new(&p, &mat);
        g.throughput(Throughput::Elements(p.len() as u64));
        // Timed on the pool's thread: `install` per iteration would add its hand-over.
        g.bench_function(format!("simd/{label}"), |b| {
            pool.install(|| b.iter(|| m.compute_forces(black_box(&p), &mat, 1e-4)))
        });
        g.bench_function(format!("scalar/{label}"), |b| {
            pool.install(|| {
                b.iter(|| {
                    phyxel::testing::compute_forces_reference(&mut m, black_box(&p), &mat, 1e-4)
                })
            })
        });
    }
    g.finish();
}

criterion_group!(benches, implicit_sums, distribution, mls_forces);
criterion_main!(benches);
