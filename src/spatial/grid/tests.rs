use super::*;
use cells::{P2, P3, hash};

/// The cells of a box `lo..=hi`.
fn cells(lo: [i32; 3], hi: [i32; 3]) -> impl Iterator<Item = [i32; 3]> {
    (lo[2]..=hi[2]).flat_map(move |z| {
        (lo[1]..=hi[1]).flat_map(move |y| (lo[0]..=hi[0]).map(move |x| [x, y, z]))
    })
}

/// A dense layout gives every cell of the points' box its own bucket (checked over
/// every cell of boxes of 1 to 1000 cells, at negative and positive positions), and
/// is chosen exactly when the box holds no more cells than `DENSE_TABLE_FACTOR`
/// times the hashed table's buckets.
#[test]
fn dense_layout_has_no_collisions_in_the_box() {
    for (n, lo, hi) in [
        (1, [0, 0, 0], [0, 0, 0]),
        (100, [-3, 5, -7], [2, 9, -2]),
        (500, [-1000, 40, 7], [-991, 49, 16]),
        (64, [i32::MAX - 3, 0, i32::MIN], [i32::MAX, 3, i32::MIN + 3]),
    ] {
        let layout = Layout::new(n, Some([lo, hi]));
        assert!(layout.p2 != P2, "{lo:?}..{hi:?} not dense");
        let mut seen = vec![false; layout.mask + 1];
        for c in cells(lo, hi) {
            let b = hash(c, layout);
            assert!(!seen[b], "cell {c:?} shares bucket {b}");
            seen[b] = true;
        }
    }
    // 11 × 11 × 11 = 1331 cells: dense with 2048 buckets while DENSE_TABLE_FACTOR
    // (2) times the hashed table of n points (2n rounded up to a power of two) has
    // at least 1331 buckets, i.e. from n = 257 on.
    let box_ = Some([[0; 3], [10; 3]]);
    assert_eq!(
        Layout::new(666, box_),
        Layout {
            mask: 2047,
            p2: 11,
            p3: 121
        }
    );
    assert_eq!(
        Layout::new(257, box_),
        Layout {
            mask: 2047,
            p2: 11,
            p3: 121
        }
    );
    assert_eq!(
        Layout::new(256, box_),
        Layout {
            mask: 511,
            p2: P2,
            p3: P3
        }
    );
    assert_eq!(Layout::new(500, None).p2, P2);
}

/// The lane bounds leave out every point with a NaN coordinate, whatever its other
/// coordinates and its lane, and agree with the scalar fold (NaN points placed far
/// outside the others' box, infinite coordinates kept).
#[test]
fn lane_bounds_skip_nan_points() {
    let mut pts: Vec<Vec3> = (0..37)
        .map(|i| Vec3::new(i as f32 * 0.1, (i % 5) as f32, -(i as f32)))
        .collect();
    pts[3] = Vec3::new(-1e9, f32::NAN, 1e9);
    pts[12] = Vec3::new(1e9, -1e9, f32::NAN);
    pts[20] = Vec3::new(f32::NAN, 1e9, -1e9);
    pts[36] = Vec3::new(f32::NAN, -1e9, 1e9);
    pts[7].x = f32::INFINITY;
    let cols = Vec3s::from_points(&pts);
    let (x, y, z) = (&cols.x[..37], &cols.y[..37], &cols.z[..37]);
    let scalar = pts
        .iter()
        .filter(|p| !p.is_nan())
        .fold(None, |b: Option<(Vec3, Vec3)>, &p| {
            Some(b.map_or((p, p), |(lo, hi)| (lo.min(p), hi.max(p))))
        });
    assert_eq!(lane_bounds(x, y, z), scalar);
    let (lo, hi) = scalar.expect("points");
    assert_eq!((lo, hi.x), (Vec3::new(0.0, 0.0, -35.0), f32::INFINITY));
    let nan = vec![f32::NAN; 9];
    assert_eq!(lane_bounds(&nan, &nan, &nan), None);
}
