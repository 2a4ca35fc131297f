use super::*;

/// One valid instance of every shape, with non-trivial proportions.
pub(super) fn shapes() -> Vec<Shape> {
    vec![
        Shape::Sphere { radius: 0.5 },
        Shape::Box {
            size: [0.4, 0.25, 0.1],
        },
        Shape::Capsule {
            radius: 0.2,
            length: 0.5,
        },
        Shape::Torus {
            major: 0.5,
            minor: 0.15,
        },
        Shape::Plane { size: [2.0, 1.0] },
    ]
}

/// Largest half extent: the length scale that tolerances are relative to.
fn scale(shape: &Shape) -> f32 {
    shape.half_extents().max_element()
}

/// Deterministic pseudo-random numbers in [0, 1) (a 64-bit LCG), so tests are reproducible.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    fn in_box(&mut self, half: Vec3) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * 2.0 * half - half
    }
}

/// Reference: surfels lie on the surface, |sdf| < 1e-4 * scale; their normals are unit
/// (within 1e-4), agree with `normal(p)` within 1e-3 and point outward
/// (sdf(p + 1e-3 * scale * n) > 0); no value is NaN and every radius is > 0.
#[test]
fn surfels_lie_on_surface_with_outward_normals() {
    for shape in shapes() {
        let s = shape.sample_surface(0.02);
        let l = scale(&shape);
        assert!(!s.positions.is_empty(), "{shape:?}");
        assert_eq!(s.positions.len(), s.normals.len());
        assert_eq!(s.positions.len(), s.radii.len());
        for ((&p, &n), &r) in s.positions.iter().zip(&s.normals).zip(&s.radii) {
            assert!(
                p.is_finite() && n.is_finite() && r.is_finite() && r > 0.0,
                "{shape:?} {p} {n} {r}"
            );
            assert!(
                shape.sdf(p).abs() < 1e-4 * l,
                "{shape:?}: sdf({p}) = {}",
                shape.sdf(p)
            );
            assert!((n.length() - 1.0).abs() < 1e-4, "{shape:?}: |{n}| != 1");
            assert!(
                n.distance(shape.normal(p)) < 1e-3,
                "{shape:?} at {p}: {n} vs {}",
                shape.normal(p)
            );
            assert!(
                shape.sdf(p + 1e-3 * l * n) > 0.0,
                "{shape:?}: {n} points inward at {p}"
            );
        }
    }
}

/// Reference: the analytic area / spacing^2; counts agree within 10%.
#[test]
fn surfel_counts_match_area() {
    let spacing = 0.02;
    for shape in shapes()
        .into_iter()
        .filter(|s| !matches!(s, Shape::Plane { .. }))
    {
        let expected = shape.area() / (spacing * spacing);
        let got = shape.sample_surface(spacing).positions.len() as f32;
        assert!(
            (got / expected - 1.0).abs() < 0.1,
            "{shape:?}: {got} surfels, expected {expected}"
        );
    }
    let plane = Shape::Plane { size: [2.0, 1.0] };
    assert_eq!(plane.sample_surface(spacing).positions.len(), 100 * 50);
}

/// Reference: a perfectly even sampling has one nearest-neighbour distance; for the sphere
/// and torus the coefficient of variation (std / mean) of that distance is below 0.25.
#[test]
fn surfels_are_evenly_spread() {
    for (shape, spacing) in [
        (Shape::Sphere { radius: 0.5 }, 0.05),
        (
            Shape::Torus {
                major: 0.5,
                minor: 0.15,
            },
            0.03,
        ),
    ] {
        let p = shape.sample_surface(spacing).positions;
        let nearest: Vec<f32> = p
            .iter()
            .enumerate()
            .map(|(i, a)| {
                p.iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .map(|(_, b)| a.distance(*b))
                    .fold(f32::INFINITY, f32::min)
            })
            .collect();
        let n = nearest.len() as f32;
        let mean = nearest.iter().sum::<f32>() / n;
        let var = nearest.iter().map(|d| (d - mean).powi(2)).sum::<f32>() / n;
        let cv = var.sqrt() / mean;
        assert!(cv < 0.25, "{shape:?}: nearest-neighbour CV = {cv}");
    }
}

/// Reference: the analytic volume; phyxel count * cell volume agrees within 10% at
/// spacing = radius / 8 (tube radius for the torus).
#[test]
fn phyxel_volume_matches_analytic() {
    for (shape, radius) in [
        (Shape::Sphere { radius: 0.5 }, 0.5),
        (
            Shape::Capsule {
                radius: 0.2,
                length: 0.5,
            },
            0.2,
        ),
        (
            Shape::Torus {
                major: 0.5,
                minor: 0.15,
            },
            0.15,
        ),
    ] {
        let v = shape.sample_volume(radius / 8.0);
        let got = v.positions.len() as f32 * v.cell_volume;
        let expected = shape.volume();
        assert!(
            (got / expected - 1.0).abs() < 0.1,
            "{shape:?}: {got} vs {expected}"
        );
    }
}

/// Reference: a box whose edges are multiples of the spacing is tiled exactly:
/// 0.4 x 0.1 x 0.1 at 0.025 gives 16 * 4 * 4 phyxels, whose volume is the box's (1e-5 relative).
#[test]
fn box_multiple_of_spacing_is_tiled_exactly() {
    let shape = Shape::Box {
        size: [0.4, 0.1, 0.1],
    };
    let v = shape.sample_volume(0.025);
    assert_eq!(v.positions.len(), 16 * 4 * 4);
    let total = v.positions.len() as f32 * v.cell_volume;
    assert!((total / shape.volume() - 1.0).abs() < 1e-5);
    // Symmetric about the origin: the centroid is 0 (to rounding).
    let centroid = v.positions.iter().sum::<Vec3>() / v.positions.len() as f32;
    assert!(centroid.length() < 1e-6, "{centroid}");
}

/// Reference: phyxels are cell centres inside the shape (sdf < 0, exact); the plane's
/// are one layer at y = -spacing/2 (1e-7) covering the patch (40 x 20 at 0.05 on 2 x 1).
#[test]
fn phyxels_are_inside() {
    for shape in shapes() {
        let spacing = 0.05;
        let v = shape.sample_volume(spacing);
        assert!(!v.positions.is_empty(), "{shape:?}");
        assert_eq!(v.cell_volume, spacing.powi(3));
        for &p in &v.positions {
            if let Shape::Plane { size: [x, z] } = shape {
                assert!((p.y + 0.5 * spacing).abs() < 1e-7, "{p}");
                assert!(p.x.abs() < 0.5 * x && p.z.abs() < 0.5 * z, "{p}");
            } else {
                assert!(shape.sdf(p) < 0.0, "{shape:?}: phyxel {p} outside");
            }
        }
    }
    assert_eq!(
        Shape::Plane { size: [2.0, 1.0] }
            .sample_volume(0.05)
            .positions
            .len(),
        40 * 20
    );
}

/// Reference: every shape gets phyxels when thinner than the spacing: a plate keeps its
/// mid-plane layer (40 x 1 x 40 at y = 0), a thin capsule its spine (11 points on the
/// y axis), a tiny sphere its centre, and a thin or coarsely sampled torus at least one
/// point; all of them inside (sdf < 0).
#[test]
fn thin_shapes_still_get_phyxels() {
    let s = 0.025;
    let plate = Shape::Box {
        size: [1.0, 0.01, 1.0],
    }
    .sample_volume(s)
    .positions;
    assert_eq!(plate.len(), 40 * 40);
    assert!(plate.iter().all(|p| p.y == 0.0));

    let rod = Shape::Capsule {
        radius: 0.6 * s,
        length: 10.0 * s,
    }
    .sample_volume(s)
    .positions;
    assert_eq!(rod.len(), 11);
    assert!(rod.iter().all(|p| p.x == 0.0 && p.z == 0.0));

    for radius in [0.3 * s, 0.6 * s] {
        let dot = Shape::Sphere { radius }.sample_volume(s).positions;
        assert_eq!(dot, vec![Vec3::ZERO], "radius {radius}");
    }

    let ring = Shape::Torus {
        major: 0.51,
        minor: 0.001,
    };
    let v = ring.sample_volume(s).positions;
    assert!(!v.is_empty());
    assert!(v.iter().all(|p| ring.sdf(*p) < s), "{v:?}");
}

/// Reference: the sdf at points with hand-computed distances (1e-6 absolute).
#[test]
fn sdf_known_values() {
    let cases = [
        (Shape::Sphere { radius: 1.0 }, Vec3::new(0.0, 2.0, 0.0), 1.0),
        (Shape::Sphere { radius: 1.0 }, Vec3::ZERO, -1.0),
        (
            Shape::Box {
                size: [2.0, 2.0, 2.0],
            },
            Vec3::new(2.0, 2.0, 1.0),
            2.0_f32.sqrt(),
        ),
        (
            Shape::Box {
                size: [2.0, 4.0, 6.0],
            },
            Vec3::ZERO,
            -1.0,
        ),
        (
            Shape::Capsule {
                radius: 0.5,
                length: 2.0,
            },
            Vec3::new(0.0, 3.0, 0.0),
            1.5,
        ),
        (
            Shape::Capsule {
                radius: 0.5,
                length: 2.0,
            },
            Vec3::new(1.0, 0.7, 0.0),
            0.5,
        ),
        (
            Shape::Torus {
                major: 1.0,
                minor: 0.25,
            },
            Vec3::ZERO,
            0.75,
        ),
        (
            Shape::Torus {
                major: 1.0,
                minor: 0.25,
            },
            Vec3::new(0.0, 0.0, -1.0),
            -0.25,
        ),
        (
            Shape::Plane { size: [1.0, 1.0] },
            Vec3::new(5.0, -0.3, 0.0),
            -0.3,
        ),
    ];
    for (shape, p, d) in cases {
        assert!(
            (shape.sdf(p) - d).abs() < 1e-6,
            "{shape:?} at {p}: {} vs {d}",
            shape.sdf(p)
        );
    }
}

/// Reference: a central finite difference of the sdf (step 1e-3 * scale) at 2000 random
/// points per shape; where that gradient has unit length (away from kinks and medial
/// surfaces, where an sdf's gradient is undefined) `normal` matches it within 1e-2.
/// Also `normal` is unit length (1e-5) and finite everywhere, including the origin.
#[test]
fn normal_is_sdf_gradient() {
    let mut rng = Lcg(7);
    for shape in shapes() {
        let h = 1e-3 * scale(&shape);
        let half = shape.half_extents().max(Vec3::splat(0.1)) * 1.5;
        let mut compared = 0;
        for p in (0..2000).map(|_| rng.in_box(half)).chain([Vec3::ZERO]) {
            let n = shape.normal(p);
            assert!(
                n.is_finite() && (n.length() - 1.0).abs() < 1e-5,
                "{shape:?} at {p}: {n}"
            );
            let fd = Vec3::new(
                shape.sdf(p + Vec3::X * h) - shape.sdf(p - Vec3::X * h),
                shape.sdf(p + Vec3::Y * h) - shape.sdf(p - Vec3::Y * h),
                shape.sdf(p + Vec3::Z * h) - shape.sdf(p - Vec3::Z * h),
            ) / (2.0 * h);
            if (fd.length() - 1.0).abs() < 1e-3 {
                compared += 1;
                assert!(n.distance(fd) < 1e-2, "{shape:?} at {p}: {n} vs {fd}");
            }
        }
        assert!(
            compared > 1000,
            "{shape:?}: only {compared} points compared"
        );
    }
}

/// Reference: the shapes' parameters; every invalid one is rejected with a message that
/// names the field and its value, and the valid test shapes pass.
#[test]
fn validate_names_the_bad_field() {
    for shape in shapes() {
        assert_eq!(shape.validate(), Ok(()), "{shape:?}");
    }
    let cases = [
        (Shape::Sphere { radius: -1.0 }, "radius = -1"),
        (Shape::Sphere { radius: 0.0 }, "radius = 0"),
        (Shape::Sphere { radius: f32::NAN }, "radius = NaN"),
        (
            Shape::Box {
                size: [1.0, 0.0, 1.0],
            },
            "size[1] = 0",
        ),
        (
            Shape::Box {
                size: [1.0, 1.0, f32::INFINITY],
            },
            "size[2] = inf",
        ),
        (
            Shape::Box {
                size: [-2.0, 1.0, 1.0],
            },
            "size[0] = -2",
        ),
        (
            Shape::Capsule {
                radius: 0.0,
                length: 1.0,
            },
            "radius = 0",
        ),
        (
            Shape::Capsule {
                radius: 1.0,
                length: -1.0,
            },
            "length = -1",
        ),
        (
            Shape::Capsule {
                radius: 1.0,
                length: f32::NAN,
            },
            "length = NaN",
        ),
        (
            Shape::Torus {
                major: -1.0,
                minor: 0.5,
            },
            "major = -1",
        ),
        (
            Shape::Torus {
                major: 1.0,
                minor: f32::NAN,
            },
            "minor = NaN",
        ),
        (
            Shape::Torus {
                major: 1.0,
                minor: 1.0,
            },
            "minor = 1",
        ),
        (
            Shape::Torus {
                major: 1.0,
                minor: 2.0,
            },
            "major = 1",
        ),
        (Shape::Plane { size: [0.0, 1.0] }, "size[0] = 0"),
        (Shape::Plane { size: [1.0, -0.5] }, "size[1] = -0.5"),
    ];
    for (shape, needle) in cases {
        let err = shape.validate().expect_err(&format!("{shape:?} accepted"));
        assert!(err.contains(needle), "{shape:?}: {err:?} lacks {needle:?}");
        assert!(err.contains("must"), "{err}");
    }
}

/// Reference: the scene-file form `{"type": "<kebab-case>", ...fields}`; shapes round-trip
/// exactly and unknown fields are rejected.
#[test]
fn serde_form() {
    for shape in shapes() {
        let json = serde_json::to_string(&shape).unwrap();
        assert_eq!(
            serde_json::from_str::<Shape>(&json).unwrap(),
            shape,
            "{json}"
        );
    }
    let torus: Shape =
        serde_json::from_str(r#"{"type": "torus", "major": 1, "minor": 0.25}"#).unwrap();
    assert_eq!(
        torus,
        Shape::Torus {
            major: 1.0,
            minor: 0.25
        }
    );
    let bad = serde_json::from_str::<Shape>(r#"{"type": "sphere", "radius": 1, "color": 3}"#);
    assert!(bad.is_err());
}

/// Reference: sampling is a pure function of (shape, spacing): two calls agree exactly.
#[test]
fn sampling_is_deterministic() {
    for shape in shapes() {
        assert_eq!(shape.sample_surface(0.03), shape.sample_surface(0.03));
        assert_eq!(shape.sample_volume(0.03), shape.sample_volume(0.03));
    }
}
