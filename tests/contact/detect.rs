//! Collision detection against independent references: the exact signed distance of a
//! sphere, the analytic inside/outside of spheres and boxes, and the analytic set of
//! surfels of one sphere inside another.

use glam::Vec3;
use phyxel::body::shape::Shape;
use phyxel::columns::Vec3s;
use phyxel::contact::field::{FarHint, SurfaceField, SurfelRows, exp_neg, grid_cell};
use phyxel::scene::{BuildOptions, Scene};
use phyxel::spatial::grid::Grid;
use phyxel::world::phase::Phase;

/// Sampled surface of a shape with its grid, owned.
struct Sampled {
    pos: Vec3s,
    normal: Vec3s,
    radius: Vec<f32>,
    grid: Grid,
}

impl Sampled {
    fn new(shape: &Shape, spacing: f32) -> Self {
        Self::of(shape.sample_surface(spacing))
    }

    fn of(s: phyxel::body::shape::SurfaceSample) -> Self {
        let pos = Vec3s::from_points(&s.positions);
        let normal = Vec3s::from_points(&s.normals);
        let r_max = s.radii.iter().fold(0.0f32, |a, &b| a.max(b));
        let grid = Grid::build(pos.iter(), grid_cell(r_max));
        Self {
            pos,
            normal,
            radius: s.radii,
            grid,
        }
    }

    fn surface(&self) -> SurfaceField<'_> {
        SurfaceField::new(&self.pos, &self.normal, &self.radius, &self.grid)
    }

    /// The grid's surfel columns, for the SIMD kernel (`with_rows`).
    fn rows(&self) -> SurfelRows {
        let mut rows = SurfelRows::default();
        rows.rebuild(&self.grid, &self.pos, &self.normal, &self.radius);
        rows
    }
}

/// Deterministic points: xorshift in [-1, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    }
    fn dir(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.next(), self.next(), self.next());
            if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}

const R: f32 = 0.1;
/// Default sampling: the `two-spheres` scene's surfel spacing.
const DEFAULT_SPACING: f32 = 0.0035;

/// Largest |f(x) − (|x| − R)| / R over points within two spacings of a sampled sphere.
fn sphere_f_error(spacing: f32) -> f32 {
    let sphere = Sampled::new(&Shape::Sphere { radius: R }, spacing);
    let surf = sphere.surface();
    let mut rng = Rng(7);
    let mut worst = 0.0f32;
    for _ in 0..2000 {
        let d = rng.next() * 2.0 * spacing;
        let x = rng.dir() * (R + d);
        let f = surf.sample(x).unwrap().f;
        worst = worst.max((f - d).abs() / R);
    }
    worst
}

/// `f(x)` of a sampled sphere (R = 0.1 m) against the exact signed distance `|x| − R`
/// for points within two surfel spacings `h` of the surface, at h = 10, 5, 3.5 (the
/// default) and 2.5 mm. The error is second order: measured 0.61–0.64 h²/R at every
/// spacing (0.61%, 0.16%, 0.076%, 0.040% of R). Tolerance: 1.6 h²/R (m) at each spacing
/// (2.5× the measured), and halving the spacing from 10 to 5 mm must cut the error at
/// least 3× (measured 3.9×; a constant offset in `f` of 0.5 mm fails both).
#[test]
fn implicit_surface_matches_sphere_distance() {
    let spacings = [0.01f32, 0.005, DEFAULT_SPACING, 0.0025];
    let mut errors = Vec::new();
    for spacing in spacings {
        let e = sphere_f_error(spacing);
        let c = e * R * R / (spacing * spacing);
        println!(
            "surfel spacing {spacing:.4} m: max |f − (|x| − R)| = {:.4}% of R = {c:.3} h²/R",
            100.0 * e
        );
        assert!(
            e * R < 1.6 * spacing * spacing / R,
            "spacing {spacing} m: error {:.4}% of R above 1.6 h²/R",
            100.0 * e
        );
        errors.push(e);
    }
    let ratio = errors[0] / errors[1];
    println!("halving the spacing cut the error {ratio:.2}×");
    assert!(
        ratio >= 3.0,
        "halving the spacing cut the error only {ratio}×"
    );
}

/// The orthogonal projection from points up to two spacings (h = 3.5 mm) off a sampled
/// sphere (R = 0.1 m) converges and lands on the exact sphere `|x| = R` within
/// 0.12 mm (0.12% of R; 2.5× the measured worst, 0.049 mm).
#[test]
fn projection_lands_on_sphere() {
    let sphere = Sampled::new(&Shape::Sphere { radius: R }, DEFAULT_SPACING);
    let surf = sphere.surface();
    let mut rng = Rng(11);
    let mut worst = 0.0f32;
    for _ in 0..1000 {
        let x = rng.dir() * (R + rng.next() * 2.0 * DEFAULT_SPACING);
        let p = surf.project(x).unwrap();
        assert!(p.converged, "projection from {x} did not converge");
        worst = worst.max((p.point.length() - R).abs());
    }
    println!("worst projection off the sphere: {worst:.3e} m");
    assert!(
        worst < 1.2e-4,
        "a projection lands {worst} m off the sphere"
    );
}

/// Far from the origin the projection still converges, in about as many steps as near
/// it, and lands within 1% of R of the sphere: its tolerance has a floor at the f32
/// round-off of the point's coordinates (`implicit::PROJECTION_ROUNDOFF_EPS`). Without
/// the floor, 102 of these 500 projections run to the iteration limit 10 m out, 427
/// 100 m out (mean 17.7 steps) and 469 1000 m out (the coordinates' f32 spacing there is
/// 0.95 µm, 7.6 µm and 61 µm, against a tolerance of 10⁻⁴ of the smallest σ).
#[test]
fn projection_converges_far_from_the_origin() {
    let s = Shape::Sphere { radius: R }.sample_surface(DEFAULT_SPACING);
    for offset in [0.0f32, 10.0, 100.0, 1000.0] {
        let c = Vec3::new(offset, -0.5 * offset, 0.25 * offset);
        let moved: Vec<Vec3> = s.positions.iter().map(|&p| p + c).collect();
        let pos = Vec3s::from_points(&moved);
        let normal = Vec3s::from_points(&s.normals);
        let r_max = s.radii.iter().fold(0.0f32, |a, &b| a.max(b));
        let grid = Grid::build(pos.iter(), grid_cell(r_max));
        let surf = SurfaceField::new(&pos, &normal, &s.radii, &grid);
        let mut rng = Rng(5);
        let (mut converged, mut steps) = (0, 0);
        let n = 500;
        for _ in 0..n {
            let x = c + rng.dir() * (R + rng.next() * 2.0 * DEFAULT_SPACING);
            let p = surf.project(x).unwrap();
            converged += p.converged as u32;
            steps += p.iterations;
            let off = ((p.point - c).length() - R).abs();
            assert!(
                off < 0.01 * R,
                "{offset} m out: projection {off} m off the sphere"
            );
        }
        let mean = steps as f32 / n as f32;
        println!("{offset} m out: {converged} of {n} converged, {mean:.2} steps on average");
        assert_eq!(converged, n, "{offset} m out: projections left unconverged");
        assert!(mean < 3.0, "{offset} m out: {mean} steps per projection");
    }
}

/// Inside test (eq. 2) against the analytic signed distance of a sphere and a box:
/// every point farther than one surfel spacing from the surface is classified correctly,
/// deep inside and far outside included.
#[test]
fn inside_test_matches_analytic_shapes() {
    let shapes = [
        Shape::Sphere { radius: R },
        Shape::Box {
            size: [0.2, 0.1, 0.15],
        },
    ];
    for shape in shapes {
        let spacing = 0.005;
        let sampled = Sampled::new(&shape, spacing);
        let surf = sampled.surface();
        let mut rng = Rng(3);
        let half = shape.half_extents();
        let (mut inside_n, mut outside_n) = (0, 0);
        while inside_n + outside_n < 3000 {
            let x = Vec3::new(rng.next(), rng.next(), rng.next()) * half * 1.6;
            let d = shape.sdf(x);
            if d.abs() <= spacing {
                continue;
            }
            let (inside, _) = surf.inside(x).unwrap();
            assert_eq!(
                inside,
                d < 0.0,
                "{shape:?}: point {x} at signed distance {d}"
            );
            if inside {
                inside_n += 1
            } else {
                outside_n += 1
            }
        }
        assert!(
            inside_n > 300 && outside_n > 300,
            "both sides sampled: {inside_n} / {outside_n}"
        );
    }
}

/// The plain fixed-point projection `x ← x − f(x) n(x)` (the paper's; the reference for
/// the secant steps of [`SurfaceField::project`]): the point, whether `|f|` fell
/// below `tol` within the projection's step limit, and the steps taken.
fn plain_projection(surf: &SurfaceField<'_>, x: Vec3, tol: f32) -> (Vec3, bool, u32) {
    let limit = phyxel::contact::field::MAX_PROJECTION_ITERATIONS;
    let mut p = x;
    for k in 0..limit {
        let s = surf.sample(p).unwrap();
        if s.f.abs() < tol {
            return (p, true, k);
        }
        p -= s.f * s.normal;
    }
    (p, surf.sample(p).unwrap().f.abs() < tol, limit)
}

/// The secant-step projection against the plain fixed point, from points within three
/// spacings of a box (edges and corners, where `f` changes slower than the distance)
/// and a coarsely sampled sphere: it converges at least as often, takes fewer steps in
/// all, and its points lie as close to the analytic surface (within 1% of the spacing
/// of the plain one's error, per point). Tolerance of both: the projection's own,
/// `PROJECTION_TOLERANCE` of the smallest surfel radius.
#[test]
fn secant_projection_beats_the_plain_fixed_point() {
    let shapes = [
        (
            Shape::Box {
                size: [0.2, 0.1, 0.15],
            },
            0.01,
        ),
        (Shape::Sphere { radius: R }, 0.02),
    ];
    for (shape, spacing) in shapes {
        let sampled = Sampled::new(&shape, spacing);
        let surf = sampled.surface();
        let (r_min, _) = phyxel::contact::field::radius_range(&sampled.radius);
        let tol = phyxel::contact::field::PROJECTION_TOLERANCE * r_min;
        let mut rng = Rng(17);
        let half = shape.half_extents();
        let (mut n, mut conv, mut conv_plain, mut steps, mut steps_plain) = (0, 0, 0, 0, 0);
        while n < 1000 {
            let x = Vec3::new(rng.next(), rng.next(), rng.next()) * (half + 3.0 * spacing);
            if shape.sdf(x).abs() > 3.0 * spacing {
                continue;
            }
            n += 1;
            let p = surf.project(x).unwrap();
            let (q, q_conv, q_steps) = plain_projection(&surf, x, tol);
            conv += p.converged as u32;
            conv_plain += q_conv as u32;
            steps += p.iterations;
            steps_plain += q_steps;
            if p.converged && q_conv {
                let (e, e_plain) = (shape.sdf(p.point).abs(), shape.sdf(q).abs());
                assert!(
                    e <= e_plain + 0.01 * spacing,
                    "{shape:?} from {x}: {e} m off the surface, plain {e_plain} m"
                );
            }
        }
        println!(
            "{shape:?}: converged {conv} (plain {conv_plain}) of {n}, steps {steps} (plain {steps_plain})"
        );
        assert!(
            conv >= conv_plain,
            "{shape:?}: {conv} < {conv_plain} converged"
        );
        assert!(
            steps < steps_plain,
            "{shape:?}: {steps} ≥ {steps_plain} steps"
        );
    }
}

/// A far-field hint ([`FarHint`]: where a deep point's nearest-surfel search starts)
/// changes only the work: from points 2 to 14 surfel spacings inside a sphere (beyond
/// every kernel), projections with no hint, a hint 100× too small, 10× too large and
/// the radius learned by the previous call are bitwise equal (reference: the unhinted
/// projection; tolerance: none). The learned radius is the 8th-nearest surfel's
/// distance: at least the depth, within 3 spacings of it (Fibonacci sampling, `R` =
/// 0.1 m, spacing 5 mm).
#[test]
fn far_hints_change_only_the_work() {
    let spacing = 0.005;
    let sphere = Sampled::new(&Shape::Sphere { radius: R }, spacing);
    let surf = sphere.surface();
    let mut rng = Rng(13);
    let mut learned = FarHint::default();
    for _ in 0..500 {
        let depth = spacing * (2.0 + 12.0 * rng.next().abs());
        let x = rng.dir() * (R - depth);
        assert!(surf.sample_near(x).is_none(), "{x} is beyond every kernel");
        let reference = surf.project(x).unwrap();
        let mut fresh = FarHint::default();
        assert_eq!(surf.project_hinted(x, None, &mut fresh), Some(reference));
        let r8 = fresh.0;
        assert!(
            r8 >= depth * 0.999 && r8 <= depth + 3.0 * spacing,
            "learned radius {r8} at depth {depth}"
        );
        for mut hint in [FarHint(r8 * 0.01), FarHint(r8 * 10.0), learned] {
            assert_eq!(
                surf.project_hinted(x, None, &mut hint),
                Some(reference),
                "hint {hint:?} at {x}"
            );
        }
        learned = fresh;
    }
}

/// The detection's early out ([`phyxel::contact::detect::OUTSIDE_FRACTION`]): every point near a
/// sphere's and a box's surface (within two kernel reaches, where `sample_near` answers)
/// whose implicit `f` exceeds that fraction of the reach is outside by the full inside
/// test (eq. 2, projection). Reference: the projection; tolerance: none (all agree), and
/// the early out must fire for a good share of the points.
#[test]
fn early_outside_agrees_with_the_inside_test() {
    let shapes = [
        Shape::Sphere { radius: R },
        Shape::Box {
            size: [0.2, 0.1, 0.15],
        },
    ];
    for shape in shapes {
        let sampled = Sampled::new(&shape, 0.005);
        let surf = sampled.surface();
        let limit = phyxel::contact::detect::OUTSIDE_FRACTION * surf.reach();
        let mut rng = Rng(11);
        let half = shape.half_extents();
        let (mut tested, mut early) = (0, 0);
        while tested < 4000 {
            let x = Vec3::new(rng.next(), rng.next(), rng.next()) * half * 1.3;
            if shape.sdf(x).abs() > 2.0 * surf.reach() {
                continue;
            }
            let Some(near) = surf.sample_near(x) else {
                continue;
            };
            tested += 1;
            if near.f > limit {
                early += 1;
                let (inside, p) = surf.inside(x).unwrap();
                assert!(
                    !inside,
                    "{shape:?}: {x} has f = {} but is inside ({p:?})",
                    near.f
                );
            }
        }
        assert!(early > 1000, "{shape:?}: early outs {early} of {tested}");
    }
}

/// A kernel grid (with its rows, as the step uses it) and a far-field grid over only
/// the surfels in a box (`Grid::rebuild_subset`, `SurfaceField::with_region`) give the results of grids
/// over every surfel: samples (far-field ones included), projections and nearest
/// surfels at points in the box, on its boundary and far outside it (where the queries
/// fall back to the grids of all surfels). On a uniform sphere, and on a graded one
/// (`shape::graded`: surfels 4× finer about the box, wider kernels outside it).
/// Reference:
/// the whole-surface grid; tolerance: the f32 round-off of a different summation order
/// (1e-6 m on positions, 1e-5 relative on weights), nearest surfels exactly equal.
#[test]
fn region_grid_matches_the_whole_surface() {
    for sphere in uniform_and_graded(R, 0.005, 0.01) {
        region_matches_whole(&sphere);
    }
}

fn region_matches_whole(sphere: &Sampled) {
    let whole = sphere.surface();
    let region = phyxel::spatial::broad_phase::Aabb {
        min: Vec3::new(0.06, -0.04, -0.04),
        max: Vec3::new(0.12, 0.04, 0.04),
    };
    let mut members = Vec::new();
    phyxel::spatial::broad_phase::points_in_box(&sphere.pos, &region, &mut members);
    assert!(members.len() < sphere.radius.len() / 2);
    let mut grid = Grid::default();
    grid.rebuild_subset(&sphere.pos, &members, sphere.grid.cell());
    let far = phyxel::spatial::grid::LazyGrid::default();
    let all = phyxel::spatial::grid::LazyGrid::default();
    // As the step builds it: the lane-group kernel over the region grid's columns.
    let mut rows = SurfelRows::default();
    rows.rebuild(&grid, &sphere.pos, &sphere.normal, &sphere.radius);
    let part = SurfaceField::new(&sphere.pos, &sphere.normal, &sphere.radius, &grid)
        .with_region(region, &members, &all, &far)
        .with_rows(&rows);
    let mut rng = Rng(5);
    for k in 0..3000 {
        // Two thirds near the box (inside, on and across its faces), a third anywhere.
        let x = if k % 3 == 2 {
            Vec3::new(rng.next(), rng.next(), rng.next()) * 0.15
        } else {
            Vec3::new(0.09, 0.0, 0.0) + Vec3::new(rng.next(), rng.next(), rng.next()) * 0.05
        };
        let (w, ws, wn) = whole.weighted_sums(x);
        let (w2, ws2, wn2) = part.weighted_sums(x);
        assert!(
            (w - w2).abs() <= 1e-5 * w.max(1e-30),
            "weights at {x}: {w} vs {w2}"
        );
        assert!((ws - ws2).length() <= 1e-5 * ws.length().max(1e-30), "{x}");
        assert!((wn - wn2).length() <= 1e-5 * wn.length().max(1e-30), "{x}");
        assert_eq!(
            whole.nearest(x).map(|e| e.0),
            part.nearest(x).map(|e| e.0),
            "{x}"
        );
        match (whole.project(x), part.project(x)) {
            (Some(a), Some(b)) => assert!((a.point - b.point).length() < 1e-6, "{x}"),
            (a, b) => assert_eq!(a.is_some(), b.is_some(), "{x}"),
        }
    }
}

fn two_spheres(gap: f32) -> phyxel::World {
    let text = format!(
        r#"
        name = "overlap"
        gravity = [0.0, 0.0, 0.0]
        [[objects]]
        shape = {{ type = "sphere", radius = 0.1 }}
        spacing = 0.025
        surfel_spacing = 0.005
        position = [{a}, 0.0, 0.0]
        [[objects]]
        shape = {{ type = "sphere", radius = 0.1 }}
        spacing = 0.025
        surfel_spacing = 0.005
        position = [{b}, 0.0, 0.0]
        "#,
        a = -0.1 - gap / 2.0,
        b = 0.1 + gap / 2.0
    );
    Scene::parse(&text, "overlap")
        .unwrap()
        .build(&BuildOptions::default())
        .unwrap()
}

/// Two spheres (R = 0.1 m) overlapping by 3 cm: the colliding surfels of each equal the
/// analytic set (its surfels with `|s − c_other| < R`) except within one surfel spacing of
/// the intersection curve, and their depth is `R − |s − c_other|` to 10% of a spacing;
/// `max_penetration` is the 3 cm of the deepest surfel (to 2 mm: no surfel sits exactly
/// on the pole).
#[test]
fn overlapping_spheres_give_the_analytic_colliding_set() {
    let mut world = two_spheres(-0.03);
    world.step();
    assert_eq!(world.contact.detections.len(), 1);
    let d = &world.contact.detections[0];
    let spacing = 0.005;
    for (obj, other, found) in [(0, 1, &d.a_in_b), (1, 0, &d.b_in_a)] {
        let c_other = world.objects[other].phyxels.centre_of_mass();
        let c_other = Vec3::new(c_other[0] as f32, c_other[1] as f32, c_other[2] as f32);
        let s = &world.objects[obj].surfels;
        let found_set: std::collections::HashSet<u32> = found.iter().map(|c| c.surfel).collect();
        let mut checked = 0;
        for i in 0..s.len() {
            let dist = (s.pos.get(i) - c_other).length();
            if (dist - R).abs() <= spacing {
                continue;
            }
            checked += 1;
            assert_eq!(
                found_set.contains(&(i as u32)),
                dist < R,
                "surfel {i} of object {obj} at {dist} m"
            );
        }
        assert!(checked > 1000);
        for c in found {
            let dist = (s.pos.get(c.surfel as usize) - c_other).length();
            if (dist - R).abs() > spacing {
                assert!(
                    (c.depth - (R - dist)).abs() < 0.1 * spacing,
                    "depth {} vs {}",
                    c.depth,
                    R - dist
                );
            }
        }
    }
    // The deepest surfel is the pole of one sphere, 3 cm inside the other.
    assert!(
        (world.record.max_penetration - 0.03).abs() < 0.002,
        "max penetration {}",
        world.record.max_penetration
    );
}

/// Disjoint objects: no pair, and no narrow-phase work at all (zero candidates tested,
/// no surfel grid built).
#[test]
fn disjoint_objects_cost_no_narrow_phase() {
    let mut world = two_spheres(0.05);
    for _ in 0..3 {
        world.step();
    }
    assert!(world.contact.pairs.is_empty());
    assert!(world.contact.detections.is_empty());
    assert_eq!(world.record.times.work(Phase::Detect), 0);
    assert_eq!(world.record.times.work(Phase::Grids), 0);
    assert_eq!(world.record.max_penetration, 0.0);
}

/// A sphere of radius `r` sampled at `spacing`, and the same sphere graded from a base
/// 4× coarser to `spacing` within 0.06 m of (r, 0, 0) (two levels), its surfels at
/// `surfels` on the base level and 4× finer in the zone (the kernels' cutoffs then
/// differ fourfold, so a query in the fine region reads only as far as its own kernels
/// reach: `SurfelRows::reach_near`).
fn uniform_and_graded(r: f32, spacing: f32, surfels: f32) -> [Sampled; 2] {
    use phyxel::body::shape::graded::{Grading, Refinement, Zone};
    let shape = Shape::Sphere { radius: r };
    let grading = Grading {
        base: 4.0 * spacing,
        zones: vec![Refinement {
            zone: Zone::Sphere {
                centre: Vec3::new(r, 0.0, 0.0),
                radius: 0.06,
            },
            spacing,
        }],
    };
    let (graded, _) = shape.sample_surface_graded(surfels, &grading);
    [Sampled::new(&shape, spacing), Sampled::of(graded)]
}

/// The SIMD kernel sums of the implicit surface (each lane group of the grid query
/// with a hit: eight weights by a lane-wise `exp`, added into lane sums, read as far as
/// the kernels near the point reach) against the scalar reference
/// (`weighted_sums_scalar`: the scalar grid query to the widest kernel's reach, libm
/// `exp`, one hit at a time), at 2000 points within ±1.5 spacings of a sampled sphere
/// (R = 0.1 m, spacing 3.5 mm), uniform and graded ([`uniform_and_graded`]; half the
/// points near the fine region). Tolerance: relative 1e-5 of Σθ and of |Σθ s|, |Σθ n|
/// (f32 summation order and `exp` rounding differ, nothing else).
#[test]
fn simd_kernel_sums_match_scalar_reference() {
    let r = 0.1;
    let spacing = 0.0035;
    for (k, sampled) in uniform_and_graded(r, spacing, 4.0 * spacing)
        .iter()
        .enumerate()
    {
        kernel_sums_match_scalar(sampled, r, spacing, k == 1);
    }
}

fn kernel_sums_match_scalar(sampled: &Sampled, r: f32, spacing: f32, graded: bool) {
    let rows = sampled.rows();
    let surface = sampled.surface().with_rows(&rows);
    let reference = sampled.surface();
    let mut rng = Rng(7);
    let mut compared = 0;
    for k in 0..2000 {
        let mut d = rng.dir();
        if graded && k % 2 == 0 {
            d = (d * 0.3 + Vec3::X).normalize();
        }
        let x = d * (r + 1.5 * spacing * rng.next());
        let (w, s, n) = surface.weighted_sums(x);
        let (w0, s0, n0) = phyxel::testing::weighted_sums_scalar(&reference, x);
        assert!(
            (w - w0).abs() <= 1e-5 * w0.abs().max(1e-30),
            "Σθ {w} vs {w0} at {x}"
        );
        assert!(
            (s - s0).length() <= 1e-5 * s0.length().max(1e-30),
            "Σθs at {x}"
        );
        assert!(
            (n - n0).length() <= 1e-5 * n0.length().max(1e-30),
            "Σθn at {x}"
        );
        compared += (w0 > 0.0) as usize;
    }
    assert!(compared > 1500, "too few points within reach: {compared}");
}

/// Samples from kept hits (`SurfaceField::sample_near_kept`, as Brent's evaluations
/// take them) against fresh `sample_near` queries, on the spheres of the test above: at
/// 2000 random points, each followed by points 0.2, 1 and 1.9% of a kernel reach away
/// (within `NEAR_HITS_SLACK` = 2%: read from the kept hits) and one 5% away (a fresh
/// query). Tolerance: `f` within 1e-6 m and normals within 1e-5 (summation order only),
/// and `None` exactly where `sample_near` gives `None`.
#[test]
fn kept_hits_sample_like_fresh_queries() {
    let r = 0.1;
    let spacing = 0.0035;
    for (k, sampled) in uniform_and_graded(r, spacing, 4.0 * spacing)
        .iter()
        .enumerate()
    {
        kept_hits_sample_like_fresh(sampled, r, spacing, k == 1);
    }
}

fn kept_hits_sample_like_fresh(sampled: &Sampled, r: f32, spacing: f32, graded: bool) {
    use phyxel::contact::field::NearHits;
    let rows = sampled.rows();
    let surface = sampled.surface().with_rows(&rows);
    let reach = surface.reach();
    let mut rng = Rng(11);
    let mut kept = NearHits::default();
    let mut compared = 0;
    for k in 0..2000 {
        let mut d = rng.dir();
        if graded && k % 2 == 0 {
            d = (d * 0.3 + Vec3::X).normalize();
        }
        let x0 = d * (r + 2.0 * spacing * rng.next());
        let step = rng.dir();
        for frac in [0.0, 0.002, 0.01, 0.019, 0.05] {
            let x = x0 + frac * reach * step;
            let (got, want) = (
                surface.sample_near_kept(x, &mut kept),
                surface.sample_near(x),
            );
            match (got, want) {
                (Some(g), Some(w)) => {
                    assert!((g.f - w.f).abs() <= 1e-6, "f {} vs {} at {x}", g.f, w.f);
                    assert!((g.normal - w.normal).length() <= 1e-5, "normal at {x}");
                    compared += 1;
                }
                (None, None) => {}
                _ => panic!("kept {got:?} vs fresh {want:?} at {x}"),
            }
        }
    }
    assert!(compared > 5000, "too few points within reach: {compared}");
}

/// `exp_neg` (lane-wise `e^{−q}` from adds, multiplies and exponent bits) against
/// libm's `f64::exp` of the same f32 `q` on 0 ≤ q < 80 (the kernel needs q < 6.25).
/// Tolerance: relative 5e-7 (the polynomial's 2e-7 plus f32 rounding).
#[test]
fn exp_neg_matches_libm() {
    let mut worst = 0.0f64;
    for i in 0..80_000 {
        let q = i as f32 * 1.0e-3;
        let lanes = exp_neg(wide::f32x8::splat(q)).to_array();
        let want = (-(q as f64)).exp();
        let rel = ((lanes[0] as f64 - want) / want).abs();
        worst = worst.max(rel);
    }
    assert!(worst < 5e-7, "worst relative error {worst:e}");
}

/// The advection's block boxes change no result. Within a step the broad phase, the
/// grid regions and the candidate scans skip the blocks of 4,096 surfels whose boxes
/// miss their query boxes; `World::run_phase` trusts no block box (the caller may have
/// moved surfels) and reads every position. Reference: the same step of the same world
/// phase by phase through `run_phase`. Two spheres of 40k surfels (ten blocks each) in
/// contact: pairs, detections (candidates included), contact patches and the phyxel
/// forces after distribution are identical, bit for bit.
#[test]
fn block_boxes_change_no_result() {
    let build = || {
        let options = BuildOptions {
            surfels: Some(40_000),
            phyxels: Some(390),
            ..Default::default()
        };
        Scene::builtin("scale").unwrap().build(&options).unwrap()
    };
    let (mut stepped, mut phased) = (build(), build());
    for _ in 0..20 {
        stepped.step();
        phased.step();
    }
    stepped.step_until_topology();
    for phase in Phase::ALL.into_iter().take_while(|&p| p != Phase::Topology) {
        phased.run_phase(phase);
    }
    assert!(!stepped.contact.pairs.is_empty() && stepped.contact.detections[0].candidates > 0);
    assert!(
        stepped.contact.detections[0].a_in_b.len() > 10,
        "the spheres are in contact"
    );
    assert_eq!(stepped.contact.pairs, phased.contact.pairs);
    assert_eq!(stepped.contact.detections, phased.contact.detections);
    assert_eq!(stepped.contact.patches, phased.contact.patches);
    for (a, b) in stepped.objects.iter().zip(&phased.objects) {
        let n = a.phyxels.len();
        for c in 0..n {
            assert_eq!(a.phyxels.force.get(c), b.phyxels.force.get(c), "phyxel {c}");
        }
    }
}
