//! Spatial hash grid vs the `kiddo` k-d tree on a 100,000-point jittered cubic lattice
//! (spacing 1, jitter ±0.25 per coordinate, fixed seed), single thread.
//!
//! - `build`: grid rebuild in place (the per-step case: `rebuild` is
//!   `Grid::rebuild_columns` from SoA columns, buckets and prefix sum in lanes;
//!   `rebuild_scalar` is the scalar reference `Grid::rebuild`) and a fresh grid;
//! - `range`: build + a fixed-radius query (~30 neighbours) at every point;
//! - `knn16`: build + the 16 nearest points of every point;
//! - `sphere_1m/rebuild`: rebuild over the 1M surfels of a scale-scene sphere (radius
//!   0.1, spiral order, cell of the fine surfel grid ≈ 2.5 spacings; its box holds 11.4M
//!   cells, so the layout is hashed), also against the scalar reference;
//! - `sphere_1m_morton/rebuild`: the same points in the engine's surfel storage order
//!   (Morton order, `phyxel::spatial::morton`);
//! - `sphere_1m_far/rebuild`: the same, with the far-field grid's cells
//!   (`implicit::FAR_GRID_FACTOR` times larger; dense layout), which a step of the 1M
//!   `scale` scene builds over a whole sphere when a far-field search may leave the
//!   contact region. (The step's kernel-size surfel grid covers only that region.)
//!
//! Run: `cargo bench --bench grid -- --warm-up-time 1 --measurement-time 3`.
//! Throughput is in points, so µs per point = 1 / (Melem/s); numbers go to
//! docs/PERFORMANCE.md.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use phyxel::columns::Vec3s;
use phyxel::contact::field::FAR_GRID_FACTOR;
use phyxel::scene::SURFEL_ORDER_CELL;
use phyxel::spatial::grid::Grid;
use phyxel::spatial::morton;
use std::hint::black_box;
use std::num::NonZeroUsize;

/// Lattice dimensions: 50 × 50 × 40 = 100,000 points.
const DIMS: [usize; 3] = [50, 50, 40];
/// Query radius; with the lattice's boundary, the mean neighbour count (self
/// included) is printed once at start-up (≈ 30).
const RADIUS: f32 = 2.0;
/// Neighbours per k-nearest query.
const K: usize = 16;

/// SplitMix64: a small deterministic generator (no extra dependency).
struct SplitMix(u64);

impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [-1, 1).
    fn symmetric(&mut self) -> f32 {
        ((self.next_u64() >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    }
}

fn lattice() -> Vec<Vec3> {
    let mut rng = SplitMix(0x5EED);
    let mut pts = Vec::with_capacity(DIMS.iter().product());
    for z in 0..DIMS[2] {
        for y in 0..DIMS[1] {
            for x in 0..DIMS[0] {
                let jitter = Vec3::new(rng.symmetric(), rng.symmetric(), rng.symmetric()) * 0.25;
                pts.push(Vec3::new(x as f32, y as f32, z as f32) + jitter);
            }
        }
    }
    pts
}

fn grid_range(grid: &mut Grid, pts: &[Vec3]) -> usize {
    grid.rebuild(pts.iter().copied(), RADIUS);
    let mut acc = 0usize;
    for &p in pts {
        grid.for_each_within(p, RADIUS, |j, _d2| acc = acc.wrapping_add(j));
    }
    acc
}

fn kiddo_range(arr: &[[f32; 3]]) -> usize {
    let tree: ImmutableKdTree<f32, 3> = ImmutableKdTree::new_from_slice(arr).unwrap();
    let mut acc = 0usize;
    for p in arr {
        tree.query(p)
            .within::<SquaredEuclidean<f32>>(RADIUS * RADIUS)
            .unsorted()
            .visit(|q| acc = acc.wrapping_add(q.item as usize));
    }
    acc
}

fn grid_knn(grid: &mut Grid, pts: &[Vec3], out: &mut Vec<(usize, f32)>) -> usize {
    grid.rebuild(pts.iter().copied(), RADIUS);
    let mut acc = 0usize;
    for &p in pts {
        grid.k_nearest(p, K, out);
        acc = acc.wrapping_add(out[K - 1].0);
    }
    acc
}

fn kiddo_knn(arr: &[[f32; 3]]) -> usize {
    let tree: ImmutableKdTree<f32, 3> = ImmutableKdTree::new_from_slice(arr).unwrap();
    let k = NonZeroUsize::new(K).unwrap();
    let mut acc = 0usize;
    for p in arr {
        let nn = tree
            .query(p)
            .nearest_n::<SquaredEuclidean<f32>>(k)
            .execute();
        acc = acc.wrapping_add(nn[K - 1].item as usize);
    }
    acc
}

fn grid_vs_kiddo(c: &mut Criterion) {
    let pts = lattice();
    let arr: Vec<[f32; 3]> = pts.iter().map(|p| p.to_array()).collect();
    let cols = Vec3s::from_points(&pts);
    let n = pts.len();

    // Sanity: same neighbourhoods from both structures.
    let mut grid = Grid::build(pts.iter().copied(), RADIUS);
    let mut count = 0usize;
    for &p in &pts {
        grid.for_each_within(p, RADIUS, |_, _| count += 1);
    }
    let tree: ImmutableKdTree<f32, 3> = ImmutableKdTree::new_from_slice(&arr).unwrap();
    let mut kcount = 0usize;
    for p in &arr {
        tree.query(p)
            .within::<SquaredEuclidean<f32>>(RADIUS * RADIUS)
            .unsorted()
            .visit(|_| kcount += 1);
    }
    assert_eq!(
        count, kcount,
        "grid and kiddo disagree on the range queries"
    );
    let mut out = Vec::new();
    assert_eq!(
        grid_knn(&mut grid, &pts, &mut out),
        kiddo_knn(&arr),
        "grid and kiddo disagree on the 16th neighbours"
    );
    eprintln!(
        "grid bench: {n} points, radius {RADIUS}, mean neighbours (self included) {:.1}",
        count as f64 / n as f64
    );

    let mut g = c.benchmark_group("grid");
    g.throughput(Throughput::Elements(n as u64));
    g.sample_size(20);
    g.bench_function("build/rebuild", |b| {
        b.iter(|| grid.rebuild_columns(black_box(&cols), RADIUS))
    });
    g.bench_function("build/rebuild_scalar", |b| {
        b.iter(|| grid.rebuild(black_box(&cols).iter(), RADIUS))
    });
    g.bench_function("build/fresh", |b| {
        b.iter(|| Grid::build(black_box(&pts).iter().copied(), RADIUS))
    });
    g.bench_function("build/kiddo", |b| {
        b.iter(|| ImmutableKdTree::<f32, 3>::new_from_slice(black_box(&arr)).unwrap())
    });
    g.bench_function("range/grid", |b| {
        b.iter(|| grid_range(&mut grid, black_box(&pts)))
    });
    g.bench_function("range/kiddo", |b| b.iter(|| kiddo_range(black_box(&arr))));
    g.bench_function("knn16/grid", |b| {
        b.iter(|| grid_knn(&mut grid, black_box(&pts), &mut out))
    });
    g.bench_function("knn16/kiddo", |b| b.iter(|| kiddo_knn(black_box(&arr))));
    g.finish();
}

/// 1M points on a sphere of radius 0.1 in the spiral (golden-angle) order of
/// `Shape::sample_surface`.
fn sphere_1m() -> Vec<Vec3> {
    let n = 1_000_000;
    let golden_angle = std::f32::consts::PI * (3.0 - 5.0_f32.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let rho = (1.0 - y * y).max(0.0).sqrt();
            let (s, c) = (i as f32 * golden_angle).sin_cos();
            0.1 * Vec3::new(rho * c, y, rho * s)
        })
        .collect()
}

fn sphere_rebuild(c: &mut Criterion) {
    let pts = sphere_1m();
    let spacing = (4.0 * std::f32::consts::PI * 0.01 / pts.len() as f32).sqrt();
    let cell = 2.5 * spacing;
    let mut grid = Grid::build(pts.iter().copied(), cell);
    let cols = Vec3s::from_points(&pts);
    let mut g = c.benchmark_group("grid");
    g.throughput(Throughput::Elements(pts.len() as u64));
    g.sample_size(20);
    g.bench_function("sphere_1m/rebuild", |b| {
        b.iter(|| grid.rebuild_columns(black_box(&cols), cell))
    });
    g.bench_function("sphere_1m/rebuild_scalar", |b| {
        b.iter(|| grid.rebuild(black_box(&cols).iter(), cell))
    });
    // The same points in the engine's storage order (Morton order of cells of 4 surfel
    // spacings, `scene::SURFEL_ORDER_CELL`).
    let order = morton::order(&pts, SURFEL_ORDER_CELL * spacing);
    let morton_cols = Vec3s::from_points(&order.iter().map(|&i| pts[i]).collect::<Vec<_>>());
    g.bench_function("sphere_1m_morton/rebuild", |b| {
        b.iter(|| grid.rebuild_columns(black_box(&morton_cols), cell))
    });
    g.bench_function("sphere_1m_morton/rebuild_scalar", |b| {
        b.iter(|| grid.rebuild(black_box(&morton_cols).iter(), cell))
    });
    // The coarse far-field grid of the same points (cells of `FAR_GRID_FACTOR` kernel
    // cells): its box holds fewer cells than points, so its layout is dense.
    let far_cell = FAR_GRID_FACTOR * cell;
    g.bench_function("sphere_1m_far/rebuild", |b| {
        b.iter(|| grid.rebuild_columns(black_box(&morton_cols), far_cell))
    });
    g.bench_function("sphere_1m_far/rebuild_scalar", |b| {
        b.iter(|| grid.rebuild(black_box(&morton_cols).iter(), far_cell))
    });
    g.finish();
}

criterion_group!(benches, grid_vs_kiddo, sphere_rebuild);
criterion_main!(benches);
