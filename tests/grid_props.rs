//! Property tests of `phyxel::spatial::grid::Grid` against brute force.
//!
//! Reference: a linear scan over all points computing, in f32 and in this order,
//! `d = p − x` per coordinate and `d² = d.x*d.x + d.y*d.y + d.z*d.z`, and accepting
//! `d² <= r*r` — the grid's documented reporting rule. Because the grid evaluates the
//! very same f32 expression, every comparison here is *exact*: equal index sets and
//! bit-identical squared distances, no tolerance.
//!
//! Run: `cargo test --release --test grid_props`.

use glam::Vec3;
use phyxel::columns::Vec3s;
use phyxel::spatial::grid::Grid;
use proptest::collection::vec;
use proptest::prelude::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

// ---------------------------------------------------------------------------------
// Brute-force references
// ---------------------------------------------------------------------------------

/// The reference squared distance (same f32 operations, same order as the grid).
fn d2(p: Vec3, x: Vec3) -> f32 {
    let (dx, dy, dz) = (p.x - x.x, p.y - x.y, p.z - x.z);
    dx * dx + dy * dy + dz * dz
}

/// Brute-force range query: `(index, d²)` of every point with `d² <= r*r`, by index.
fn brute_within(points: &[Vec3], x: Vec3, r: f32) -> Vec<(usize, u32)> {
    let r2 = r * r;
    points
        .iter()
        .enumerate()
        .filter_map(|(i, &p)| {
            let d = d2(p, x);
            (d <= r2).then_some((i, d.to_bits()))
        })
        .collect()
}

/// Grid range query as `(index, d² bits)` sorted by index (duplicates kept, so that a
/// point reported twice makes the comparison fail).
fn grid_within(grid: &Grid, x: Vec3, r: f32) -> Vec<(usize, u32)> {
    let mut out = Vec::new();
    grid.for_each_within(x, r, |i, d| out.push((i, d.to_bits())));
    out.sort_unstable();
    out
}

/// The scalar reference query, in the same form as [`grid_within`].
fn grid_within_scalar(grid: &Grid, x: Vec3, r: f32) -> Vec<(usize, u32)> {
    let mut out = Vec::new();
    phyxel::testing::for_each_within_scalar(grid, x, r, |i, d| out.push((i, d.to_bits())));
    out.sort_unstable();
    out
}

/// The lane-group range query, unpacked to `(index, d² bits)` sorted by index (a point
/// in two calls, or a set bit on padding, makes the comparison fail).
fn grid_lanes_within(grid: &Grid, x: Vec3, r: f32) -> Vec<(usize, u32)> {
    let mut out = Vec::new();
    let order = grid.sorted();
    grid.for_each_lanes_within(x, r, |at, mask, d2| {
        let d2 = d2.to_array();
        for (l, d) in d2.iter().enumerate() {
            if mask & (1 << l) != 0 {
                out.push((order[at + l] as usize, d.to_bits()));
            }
        }
    });
    out.sort_unstable();
    out
}

/// Brute-force k nearest: every point with a non-NaN distance, sorted by
/// `(d², index)`, first `k` kept.
fn brute_knn(points: &[Vec3], x: Vec3, k: usize) -> Vec<(usize, f32)> {
    let mut all: Vec<(usize, f32)> = points
        .iter()
        .enumerate()
        .map(|(i, &p)| (i, d2(p, x)))
        .filter(|&(_, d)| !d.is_nan())
        .collect();
    all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    all.truncate(k);
    all
}

/// Checks every range query of `queries × radii`, per point (lanes and scalar), per
/// lane group and as a yes/no (`any_within`), against
/// brute force (exact).
fn check_range(
    points: &[Vec3],
    cell: f32,
    queries: &[Vec3],
    radii: &[f32],
) -> Result<(), TestCaseError> {
    let grid = Grid::build(points.iter().copied(), cell);
    prop_assert_eq!(grid.len(), points.len());
    for &x in queries {
        for &r in radii {
            let want = brute_within(points, x, r);
            prop_assert_eq!(
                grid_within(&grid, x, r),
                want.clone(),
                "x = {:?}, r = {}, cell = {}",
                x,
                r,
                cell
            );
            prop_assert_eq!(
                grid.any_within(x, r),
                !want.is_empty(),
                "any: x = {:?}, r = {}, cell = {}",
                x,
                r,
                cell
            );
            prop_assert_eq!(
                grid_within_scalar(&grid, x, r),
                want.clone(),
                "scalar: x = {:?}, r = {}, cell = {}",
                x,
                r,
                cell
            );
            prop_assert_eq!(
                grid_lanes_within(&grid, x, r),
                want,
                "lanes: x = {:?}, r = {}, cell = {}",
                x,
                r,
                cell
            );
        }
    }
    Ok(())
}

/// Checks every k-nearest query of `queries × ks` against brute force: the list of
/// distances must be identical (exact f32), every returned index must be a distinct
/// point at exactly the returned distance. Ties may legitimately be resolved either
/// way here, so indices are not compared with the reference.
fn check_knn(
    points: &[Vec3],
    cell: f32,
    queries: &[Vec3],
    ks: &[usize],
) -> Result<(), TestCaseError> {
    let grid = Grid::build(points.iter().copied(), cell);
    let mut out = Vec::new();
    for &x in queries {
        // `nearest` agrees with the brute-force nearest distance (exact f32).
        let near = grid.nearest(x);
        let want = brute_knn(points, x, 1);
        prop_assert_eq!(
            near.map(|e| e.1.to_bits()),
            want.first().map(|e| e.1.to_bits()),
            "nearest, x = {:?}",
            x
        );
        for &k in ks {
            grid.k_nearest(x, k, &mut out);
            let want = brute_knn(points, x, k);
            let got_d: Vec<u32> = out.iter().map(|e| e.1.to_bits()).collect();
            let want_d: Vec<u32> = want.iter().map(|e| e.1.to_bits()).collect();
            prop_assert_eq!(got_d, want_d, "x = {:?}, k = {}, cell = {}", x, k, cell);
            let mut idx: Vec<usize> = out.iter().map(|e| e.0).collect();
            for &(i, d) in &out {
                prop_assert_eq!(d.to_bits(), d2(points[i], x).to_bits());
            }
            idx.sort_unstable();
            idx.dedup();
            prop_assert_eq!(idx.len(), out.len(), "an index was returned twice");
            // Any starting radius gives the same list (only the work differs).
            let mut from = Vec::new();
            for r0 in [1e-6 * cell, 0.3 * cell, 7.0 * cell, 0.0, f32::NAN] {
                grid.k_nearest_from(x, k, r0, &mut from);
                prop_assert_eq!(&from, &out, "k_nearest_from r0 = {}, x = {:?}", r0, x);
            }
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------
// Strategies
// ---------------------------------------------------------------------------------

fn vec3(lo: f32, hi: f32) -> impl Strategy<Value = Vec3> {
    (lo..hi, lo..hi, lo..hi).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// A coordinate anywhere from ±1e-30 to ±1e30 (log-uniform magnitude), or 0.
fn huge_coord() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => (any::<bool>(), -30.0f32..30.0)
            .prop_map(|(neg, e)| if neg { -(10f32.powf(e)) } else { 10f32.powf(e) }),
        1 => Just(0.0f32),
    ]
}

fn huge_vec3() -> impl Strategy<Value = Vec3> {
    (huge_coord(), huge_coord(), huge_coord()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// Integer lattice points scaled by `step`: many exactly equal distances (ties) and
/// points exactly on cell faces.
fn lattice(n: usize, half: i32, step: f32) -> impl Strategy<Value = Vec<Vec3>> {
    vec((-half..half, -half..half, -half..half), 0..n).prop_map(move |v| {
        v.into_iter()
            .map(|(a, b, c)| Vec3::new(a as f32, b as f32, c as f32) * step)
            .collect()
    })
}

/// Few distinct points, each repeated several times.
fn duplicated() -> impl Strategy<Value = Vec<Vec3>> {
    (vec(vec3(-3.0, 3.0), 1..6), vec(0usize..6, 0..120))
        .prop_map(|(base, picks)| picks.iter().map(|&i| base[i % base.len()]).collect())
}

/// Radii from zero to far beyond the clouds, in units of `scale`.
fn radii(scale: f32) -> impl Strategy<Value = Vec<f32>> {
    vec(
        prop_oneof![
            1 => Just(0.0f32),
            1 => 0.0f32..0.05,
            6 => 0.05f32..4.0,
            1 => 4.0f32..20.0,
            1 => Just(1.0e4f32),
        ]
        .prop_map(move |r| r * scale),
        1..5,
    )
}

/// Queries: every data point (up to 40) and a few arbitrary points.
fn queries(points: &[Vec3], extra: Vec<Vec3>) -> Vec<Vec3> {
    points.iter().copied().take(40).chain(extra).collect()
}

// ---------------------------------------------------------------------------------
// Build: lanes against the scalar reference
// ---------------------------------------------------------------------------------

/// Points for the build comparison: ordinary, ±1e30 (saturated cell indices), infinite
/// and NaN coordinates, lattice points on cell faces.
fn build_points() -> impl Strategy<Value = Vec<Vec3>> {
    let coord = prop_oneof![
        6 => -5.0f32..5.0,
        2 => huge_coord(),
        1 => (-8i32..8).prop_map(|k| k as f32 * 0.25),
        1 => prop_oneof![Just(f32::INFINITY), Just(f32::NEG_INFINITY), Just(f32::NAN)],
    ];
    vec(
        (coord.clone(), coord.clone(), coord).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
        0..200,
    )
}

proptest! {
    /// `Grid::rebuild_columns` (buckets eight points at a time from SoA columns, the
    /// prefix sum eight buckets at a time) builds the grid of the scalar `Grid::rebuild`
    /// bit for bit: the same sorted order and coordinates, and the same bucket table
    /// (every query at every point and a few others reports the same indices and d²).
    /// Every length mod 8 occurs (0..200 points).
    #[test]
    fn lane_build_matches_scalar_build(
        points in build_points(),
        cell in prop_oneof![Just(0.25f32), 1e-3f32..1e3],
        extra in vec(vec3(-7.0, 7.0), 0..4),
        r in prop_oneof![Just(0.0f32), 0.0f32..3.0],
    ) {
        let mut lanes = Grid::default();
        let mut scalar = Grid::default();
        lanes.rebuild_columns(&Vec3s::from_points(&points), cell);
        scalar.rebuild(points.iter().copied(), cell);
        prop_assert_eq!(lanes.sorted(), scalar.sorted());
        let bits = |g: &Grid| {
            g.sorted_points().map(|c| c.iter().map(|v| v.to_bits()).collect::<Vec<u32>>())
        };
        prop_assert_eq!(bits(&lanes), bits(&scalar));
        prop_assert_eq!(lanes.len(), scalar.len());
        for x in queries(&points, extra) {
            let hits = |g: &Grid| {
                let mut h = Vec::new();
                g.for_each_within(x, r * cell, |i, d2| h.push((i, d2.to_bits())));
                h
            };
            prop_assert_eq!(hits(&lanes), hits(&scalar));
        }
    }
}

proptest! {
    /// `Grid::rebuild_subset` (the subset copied into columns, then the lane build)
    /// builds the scalar `Grid::rebuild` of the subset's points, with the indices mapped
    /// back through the subset: the same sorted order and coordinates bit for bit, and the
    /// same answers to every query. The subset is any list of indices (repeats allowed).
    #[test]
    fn subset_build_matches_scalar_build_of_the_subset(
        points in build_points(),
        picks in vec(any::<prop::sample::Index>(), 0..150),
        cell in prop_oneof![Just(0.25f32), 1e-3f32..1e3],
        r in 0.0f32..3.0,
    ) {
        prop_assume!(!points.is_empty());
        let subset: Vec<u32> = picks.iter().map(|k| k.index(points.len()) as u32).collect();
        let mut sub = Grid::default();
        sub.rebuild_subset(&Vec3s::from_points(&points), &subset, cell);
        let mut scalar = Grid::default();
        scalar.rebuild(subset.iter().map(|&i| points[i as usize]), cell);
        let mapped: Vec<u32> = scalar.sorted().iter().map(|&k| subset[k as usize]).collect();
        prop_assert_eq!(sub.sorted(), &mapped[..]);
        let bits = |g: &Grid| {
            g.sorted_points().map(|c| c.iter().map(|v| v.to_bits()).collect::<Vec<u32>>())
        };
        prop_assert_eq!(bits(&sub), bits(&scalar));
        prop_assert_eq!(sub.len(), points.len());
        for x in queries(&points, Vec::new()) {
            let mut a = Vec::new();
            sub.for_each_within(x, r * cell, |i, d2| a.push((i, d2.to_bits())));
            let mut b = Vec::new();
            scalar.for_each_within(x, r * cell, |k, d2| b.push((subset[k] as usize, d2.to_bits())));
            prop_assert_eq!(a, b);
        }
    }
}

// ---------------------------------------------------------------------------------
// Range queries
// ---------------------------------------------------------------------------------

proptest! {
    /// Uniform random clouds (0–300 points, including empty), cell sizes from a tenth to
    /// ten times the typical spacing, radii from 0 to 1e4 × cell.
    /// Reference: brute force; tolerance: exact index sets and bit-identical d².
    #[test]
    fn range_matches_brute_force_uniform(
        points in vec(vec3(-5.0, 5.0), 0..300),
        cell in 0.05f32..5.0,
        extra in vec(vec3(-7.0, 7.0), 0..8),
        rs in radii(1.0),
    ) {
        check_range(&points, cell, &queries(&points, extra), &rs)?;
    }

    /// Lattice clouds: exact distance ties, points on cell faces and radii that hit
    /// lattice distances exactly (r = 0.5·√k).
    /// Reference: brute force; tolerance: exact.
    #[test]
    fn range_matches_brute_force_lattice(
        points in lattice(250, 4, 0.5),
        cell in prop_oneof![Just(0.5f32), Just(1.0), Just(0.25), 0.1f32..3.0],
        extra in vec(vec3(-3.0, 3.0), 0..5),
        ks in vec(0u32..40, 1..5),
    ) {
        let rs: Vec<f32> = ks.iter().map(|&k| 0.5 * (k as f32).sqrt()).collect();
        check_range(&points, cell, &queries(&points, extra), &rs)?;
    }

    /// Duplicated points (few distinct positions, each repeated): every copy reported.
    /// Reference: brute force; tolerance: exact.
    #[test]
    fn range_matches_brute_force_duplicates(
        points in duplicated(),
        cell in 0.05f32..5.0,
        extra in vec(vec3(-4.0, 4.0), 0..5),
        rs in radii(1.0),
    ) {
        check_range(&points, cell, &queries(&points, extra), &rs)?;
    }

    /// All points inside one cell (cell 1, coordinates in [3, 3.999)).
    /// Reference: brute force; tolerance: exact.
    #[test]
    fn range_matches_brute_force_one_cell(
        points in vec(vec3(3.0, 3.999), 0..200),
        extra in vec(vec3(2.0, 5.0), 0..5),
        rs in radii(0.3),
    ) {
        check_range(&points, 1.0, &queries(&points, extra), &rs)?;
    }

    /// Points spread over ±1e30 (log-uniform magnitudes, cells saturating the i32 cell
    /// index), cells from 1e-3 to 1e3, radii up to 1e4 × cell and 1e30.
    /// Reference: brute force; tolerance: exact.
    #[test]
    fn range_matches_brute_force_huge_range(
        points in vec(huge_vec3(), 0..150),
        cell in prop_oneof![0.001f32..1.0, 1.0f32..1000.0],
        extra in vec(huge_vec3(), 0..5),
        rs in radii(1.0),
        big in prop_oneof![Just(1.0e10f32), Just(1.0e20), Just(1.0e30)],
    ) {
        let mut rs = rs.into_iter().map(|r| r * cell).collect::<Vec<_>>();
        rs.push(big);
        check_range(&points, cell, &queries(&points, extra), &rs)?;
    }

    /// Dense clouds (600–1,500 points) with radii of several cells: query boxes with
    /// more rows than the row-separation table covers, so the per-hit row filter runs,
    /// besides the shared-bucket cases of small tables in the tests above.
    /// Reference: brute force; tolerance: exact.
    #[test]
    fn range_matches_brute_force_large_boxes(
        points in vec(vec3(-4.0, 4.0), 600..1500),
        rs in vec(0.5f32..2.5, 1..3),
        extra in vec(vec3(-4.0, 4.0), 0..5),
    ) {
        check_range(&points, 0.25, &queries(&points, extra), &rs)?;
    }

    /// Clouds with NaN and infinite coordinates mixed in: NaN points are never reported,
    /// infinite ones only when the f32 test accepts them (an infinite r²).
    /// Reference: brute force; tolerance: exact.
    #[test]
    fn range_matches_brute_force_non_finite(
        points in vec(vec3(-5.0, 5.0), 0..100),
        odd in vec((0usize..100, 0usize..3, prop_oneof![
            Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY)
        ]), 0..10),
        cell in 0.1f32..3.0,
        rs in radii(1.0),
    ) {
        let mut points = points;
        for (i, axis, v) in odd {
            if let Some(p) = points.get_mut(i) {
                p[axis] = v;
            }
        }
        let mut rs = rs;
        rs.push(f32::INFINITY);
        let qs: Vec<Vec3> = points.iter().copied().filter(|p| p.is_finite()).take(30).collect();
        check_range(&points, cell, &qs, &rs)?;
    }
}

// ---------------------------------------------------------------------------------
// k nearest
// ---------------------------------------------------------------------------------

proptest! {
    /// Uniform clouds, k from 1 to beyond the point count (then all points return).
    /// Reference: brute force sorted by (d², index); tolerance: exact equality of the
    /// distance lists; indices checked to be distinct and at their reported distance.
    #[test]
    fn knn_matches_brute_force_uniform(
        points in vec(vec3(-5.0, 5.0), 0..200),
        cell in 0.05f32..5.0,
        extra in vec(vec3(-8.0, 8.0), 0..6),
        ks in vec(1usize..250, 1..4),
    ) {
        check_knn(&points, cell, &queries(&points, extra), &ks)?;
    }

    /// Lattice and duplicated clouds: many exact ties, compared by distance only.
    /// Reference: brute force; tolerance: exact distances.
    #[test]
    fn knn_matches_brute_force_ties(
        points in prop_oneof![lattice(150, 3, 1.0), duplicated()],
        cell in prop_oneof![Just(1.0f32), 0.1f32..3.0],
        extra in vec(vec3(-3.0, 3.0), 0..5),
        ks in vec(1usize..40, 1..4),
    ) {
        check_knn(&points, cell, &queries(&points, extra), &ks)?;
    }

    /// Points spread over ±1e30 and all points in one cell, plus NaN points mixed in
    /// (never returned: k is capped by the finite-distance points).
    /// Reference: brute force; tolerance: exact distances.
    #[test]
    fn knn_matches_brute_force_extreme(
        points in prop_oneof![vec(huge_vec3(), 0..100), vec(vec3(3.0, 3.999), 0..100)],
        nans in vec(0usize..100, 0..5),
        cell in prop_oneof![Just(1.0f32), 0.001f32..1000.0],
        ks in vec(1usize..120, 1..4),
    ) {
        let mut points = points;
        for i in nans {
            if let Some(p) = points.get_mut(i) {
                p.y = f32::NAN;
            }
        }
        let qs: Vec<Vec3> = points.iter().copied().filter(|p| p.is_finite()).take(30).collect();
        check_knn(&points, cell, &qs, &ks)?;
    }

    /// The documented tie-break (nearest first, equal distances by increasing index):
    /// here the full `(index, d²)` lists must equal the reference exactly.
    /// Reference: brute force sorted by (d², index); tolerance: exact.
    #[test]
    fn knn_breaks_ties_by_index(
        points in prop_oneof![lattice(150, 3, 1.0), duplicated(), vec(vec3(-5.0, 5.0), 0..150)],
        cell in 0.1f32..3.0,
        ks in vec(1usize..60, 1..4),
    ) {
        let grid = Grid::build(points.iter().copied(), cell);
        let mut out = Vec::new();
        for &x in points.iter().take(30) {
            for &k in &ks {
                grid.k_nearest(x, k, &mut out);
                let got: Vec<(usize, u32)> = out.iter().map(|e| (e.0, e.1.to_bits())).collect();
                let want: Vec<(usize, u32)> =
                    brute_knn(&points, x, k).iter().map(|e| (e.0, e.1.to_bits())).collect();
                prop_assert_eq!(got, want);
            }
        }
    }
}

// ---------------------------------------------------------------------------------
// Rebuild
// ---------------------------------------------------------------------------------

proptest! {
    /// `rebuild` of a grid first built over other points (of another size and cell)
    /// answers exactly like a fresh `build` over the new points, range and k-nearest.
    /// Reference: a fresh `Grid::build` (and brute force for the range queries);
    /// tolerance: exact.
    #[test]
    fn rebuild_matches_fresh_build(
        first in prop_oneof![vec(vec3(-5.0, 5.0), 0..300), vec(huge_vec3(), 0..50)],
        first_cell in 0.05f32..5.0,
        second in prop_oneof![vec(vec3(-3.0, 3.0), 0..200), duplicated(), lattice(150, 3, 0.5)],
        cell in 0.05f32..5.0,
        rs in radii(1.0),
        k in 1usize..30,
    ) {
        let mut grid = Grid::build(first.iter().copied(), first_cell);
        grid.rebuild(second.iter().copied(), cell);
        let fresh = Grid::build(second.iter().copied(), cell);
        prop_assert_eq!(grid.len(), fresh.len());
        prop_assert_eq!(grid.indexed(), fresh.indexed());
        prop_assert_eq!(grid.cell(), fresh.cell());
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for &x in second.iter().take(40) {
            for &r in &rs {
                let got = grid_within(&grid, x, r);
                prop_assert_eq!(&got, &grid_within(&fresh, x, r));
                prop_assert_eq!(&got, &brute_within(&second, x, r));
            }
            grid.k_nearest(x, k, &mut a);
            fresh.k_nearest(x, k, &mut b);
            prop_assert_eq!(&a, &b);
        }
    }
}

// ---------------------------------------------------------------------------------
// Deterministic edge cases
// ---------------------------------------------------------------------------------

/// Empty grids (built empty, or `Default`) report nothing and return no neighbours.
#[test]
fn empty_grids_report_nothing() {
    let mut out = vec![(0, 0.0)];
    for grid in [
        Grid::build(std::iter::empty::<Vec3>(), 1.0),
        Grid::default(),
    ] {
        assert!(grid.is_empty());
        assert_eq!(grid.indexed(), 0);
        grid.for_each_within(Vec3::ZERO, f32::INFINITY, |_, _| panic!("reported"));
        assert!(!grid.any_within(Vec3::ZERO, f32::INFINITY));
        grid.k_nearest(Vec3::ZERO, 3, &mut out);
        assert!(out.is_empty());
    }
}

/// Invalid queries report nothing: NaN or negative radius, NaN query point; k-nearest
/// of a non-finite point or with k = 0 is empty. An infinite radius reports every
/// non-NaN point (exact equality with brute force).
#[test]
fn invalid_queries_and_infinite_radius() {
    let points = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 2.0, 3.0),
        Vec3::new(f32::NAN, 0.0, 0.0),
        Vec3::new(1.0e30, -1.0e30, 0.0),
        Vec3::new(f32::INFINITY, 0.0, 0.0),
    ];
    let grid = Grid::build(points.iter().copied(), 0.5);
    assert_eq!(grid.len(), 5);
    assert_eq!(grid.indexed(), 4);
    for r in [f32::NAN, -1.0, -0.0 - 1.0e-30] {
        grid.for_each_within(Vec3::ZERO, r, |_, _| panic!("reported for r = {r}"));
    }
    grid.for_each_within(Vec3::new(0.0, f32::NAN, 0.0), 10.0, |_, _| panic!("NaN x"));
    let mut out = Vec::new();
    grid.k_nearest(Vec3::new(f32::INFINITY, 0.0, 0.0), 2, &mut out);
    assert!(out.is_empty());
    grid.k_nearest(Vec3::ZERO, 0, &mut out);
    assert!(out.is_empty());
    let x = Vec3::new(0.1, 0.2, 0.3);
    assert_eq!(
        grid_within(&grid, x, f32::INFINITY),
        brute_within(&points, x, f32::INFINITY)
    );
    assert_eq!(grid_within(&grid, x, f32::INFINITY).len(), 4);
    // k larger than the indexed points: all 4, the infinite one last.
    grid.k_nearest(x, 10, &mut out);
    assert_eq!(
        out.iter().map(|e| e.0).collect::<Vec<_>>(),
        vec![0, 1, 3, 4]
    );
}

/// A query exactly on a cell face, with the radius reaching exactly the neighbours
/// across the face, and a radius-0 query at a duplicated point.
#[test]
fn boundaries_and_radius_zero() {
    let points: Vec<Vec3> = (-3..=3).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
    let grid = Grid::build(points.iter().copied(), 1.0);
    let got: Vec<usize> = grid_within(&grid, Vec3::ZERO, 1.0)
        .iter()
        .map(|e| e.0)
        .collect();
    assert_eq!(got, vec![2, 3, 4]);
    let dup = [Vec3::splat(0.5); 5];
    let grid = Grid::build(dup.iter().copied(), 1.0);
    assert_eq!(grid_within(&grid, Vec3::splat(0.5), 0.0).len(), 5);
    assert!(grid_within(&grid, Vec3::splat(0.5000001), 0.0).is_empty());
}

/// Round-off at the boundary (cases that a grid searching exactly `x ± r` gets wrong):
/// with r = 0 a point 4e-28 away is accepted because its d² underflows to 0,
/// although it lies in another cell; and r = 1e20 has r*r = ∞, which accepts a point
/// 3e27 away in a cell far outside `x ± r` (saturated cell indices).
/// Reference: brute force; tolerance: exact.
#[test]
fn round_off_at_the_boundary() {
    let points = vec![
        Vec3::ZERO,
        Vec3::new(0.0, 8.976_240_7e-29, -3.943_643_7e-28),
    ];
    let grid = Grid::build(points.iter().copied(), 0.001);
    let got = grid_within(&grid, Vec3::ZERO, 0.0);
    assert_eq!(got, brute_within(&points, Vec3::ZERO, 0.0));
    assert_eq!(got.len(), 2);

    let points = vec![
        Vec3::new(7.899_892e20, 3.313_555e27, 4.333_881_7e26),
        Vec3::ONE,
    ];
    let grid = Grid::build(points.iter().copied(), 0.001);
    let got = grid_within(&grid, points[0], 1.0e20);
    assert_eq!(got, brute_within(&points, points[0], 1.0e20));
    assert_eq!(got.len(), 2);
}

// ---------------------------------------------------------------------------------
// Allocation-free rebuild and queries
// ---------------------------------------------------------------------------------

/// Counts this thread's heap allocations (tests run on separate threads).
struct CountingAlloc;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn count_allocation() {
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_allocation();
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count_allocation();
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_allocation();
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

fn allocations() -> usize {
    ALLOCATIONS.with(|c| c.get())
}

/// After a first build, `rebuild` with as many or fewer points, range queries (small
/// boxes, large boxes with the row filter, whole scans) and k-nearest with a reused
/// output vector and `nearest` make no heap allocation.
#[test]
fn rebuild_and_queries_do_not_allocate() {
    let cloud = |n: usize, s: f32| -> Vec<Vec3> {
        (0..n)
            .map(|i| {
                let f = i as f32;
                Vec3::new(
                    (f * 0.618 * s).fract(),
                    (f * 0.414 * s).fract(),
                    (f * 0.732).fract(),
                ) * 10.0
            })
            .collect()
    };
    let a = cloud(5000, 1.0);
    let b = cloud(5000, 1.3);
    let c = cloud(3000, 0.7);
    let mut grid = Grid::build(a.iter().copied(), 0.5);
    let mut out = Vec::with_capacity(5000);
    let before = allocations();
    let mut found = 0usize;
    // The last build takes a dense table larger than the hashed one (about 24k cells).
    for (pts, cell) in [(&b, 0.5), (&c, 0.8), (&a, 0.3), (&a, 0.35)] {
        grid.rebuild(pts.iter().copied(), cell);
        for &x in pts.iter().take(50) {
            for r in [0.0, 0.3, 1.0, 3.0, 100.0] {
                grid.for_each_within(x, r, |_, _| found += 1);
            }
            grid.k_nearest(x, 16, &mut out);
            found += out.len() + grid.nearest(x).map_or(0, |e| e.0.min(1));
        }
    }
    let after = allocations();
    assert!(found > 0);
    assert_eq!(after - before, 0, "rebuild or queries allocated");
}
