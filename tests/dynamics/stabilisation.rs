//! The MLS fit's residual stabilisation (`phyxel::dynamics::stabilisation`) against a
//! brute-force evaluation of its definition, and its invariants.

use glam::{DVec3, Quat, Vec3};
use phyxel::body::shape::Shape;
use phyxel::body::shape::graded::{Grading, Refinement, Zone};
use phyxel::dynamics::gradient::MlsStencil;
use phyxel::dynamics::stabilisation::Stabilisation;
use phyxel::material::{GradientBasis, Material};
use phyxel::math::kernel::poly6_shape;
use phyxel::points::phyxels::Phyxels;

/// A 0.2 × 0.1 × 0.1 m box sampled at 0.025 m, 2× finer over x < 0: a level interface
/// through the middle.
fn graded_box() -> Phyxels {
    let shape = Shape::Box {
        size: [0.2, 0.1, 0.1],
    };
    let grading = Grading {
        base: 0.025,
        zones: vec![Refinement {
            zone: Zone::Box {
                min: Vec3::new(-0.1, -0.05, -0.05),
                max: Vec3::new(0.0, 0.05, 0.05),
            },
            spacing: 0.0125,
        }],
    };
    let (v, _) = shape.sample_volume_graded(&grading);
    Phyxels::at_rest(&v.positions, v.cell_volume, 1000.0).with_volumes(&v.volumes, 1000.0)
}

/// Solves the symmetric system `m c = r` (9 × 9, f64) by Gaussian elimination with
/// partial pivoting.
#[allow(clippy::needless_range_loop)] // index loops mirror the elimination's formulas
fn solve9(mut m: [[f64; 9]; 9], mut r: [DVec3; 9]) -> [DVec3; 9] {
    for col in 0..9 {
        let p = (col..9)
            .max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))
            .unwrap();
        m.swap(col, p);
        r.swap(col, p);
        for row in col + 1..9 {
            let f = m[row][col] / m[col][col];
            for k in col..9 {
                m[row][k] -= f * m[col][k];
            }
            r[row] -= r[col] * f;
        }
    }
    let mut c = [DVec3::ZERO; 9];
    for row in (0..9).rev() {
        let mut s = r[row];
        for k in row + 1..9 {
            s -= c[k] * m[row][k];
        }
        c[row] = s / m[row][row];
    }
    c
}

/// A named displacement field (m of x, m).
type Field = (&'static str, Box<dyn Fn(Vec3) -> Vec3>);

/// `Σ_i ½ α μ v_i Σ_j w_ij |r_ij|² / Σ_j w_ij |x_ij|²` evaluated by its definition: per
/// phyxel, the weighted least-squares fit of `u_j − u_i` over `x, y, z, x², y², z², xy,
/// yz, zx` (offsets in units of h), solved by elimination, and its residual (J).
fn brute_force_energy(p: &Phyxels, st: &MlsStencil, alpha: f64, mu: f64, u: &[DVec3]) -> f64 {
    let mut total = 0.0;
    for i in 0..p.len() {
        let row = &st.neighbours[st.row(i)];
        if row.len() < 12 || st.ill_conditioned[i] {
            continue;
        }
        let h = p.radius[i];
        let xi = p.rest.get(i);
        let terms = |x: DVec3| {
            let q = x / h as f64;
            [
                q.x,
                q.y,
                q.z,
                q.x * q.x,
                q.y * q.y,
                q.z * q.z,
                q.x * q.y,
                q.y * q.z,
                q.z * q.x,
            ]
        };
        let nb: Vec<(DVec3, f64, DVec3)> = row
            .iter()
            .map(|&j| {
                let x = p.rest.get(j as usize) - xi;
                let w = poly6_shape(x.length_squared(), h) as f64;
                (x.as_dvec3(), w, u[j as usize] - u[i])
            })
            .collect();
        let mut m = [[0.0f64; 9]; 9];
        let mut r = [DVec3::ZERO; 9];
        for &(x, w, du) in &nb {
            let b = terms(x);
            for a in 0..9 {
                for c in 0..9 {
                    m[a][c] += w * b[a] * b[c];
                }
                r[a] += du * (w * b[a]);
            }
        }
        let c = solve9(m, r);
        let (mut rss, mut spread) = (0.0, 0.0);
        for &(x, w, du) in &nb {
            let b = terms(x);
            let fit = (0..9).fold(DVec3::ZERO, |s, a| s + c[a] * b[a]);
            rss += w * (du - fit).length_squared();
            spread += w * x.length_squared();
        }
        total += 0.5 * alpha * mu * p.volume[i] as f64 * rss / spread;
    }
    total
}

/// A displacement no quadratic reproduces (m): smooth waves of 2–3 spacings plus a
/// deterministic rough part.
fn rough_field(p: &Phyxels) -> Vec<DVec3> {
    (0..p.len())
        .map(|j| {
            let x = p.rest.get(j).as_dvec3();
            let h = (j as u32).wrapping_mul(2_654_435_761);
            let c = |s: u32| ((h >> s) & 0xff) as f64 / 127.5 - 1.0;
            1e-4 * DVec3::new(
                (40.0 * x.x).sin() * (30.0 * x.y).cos() + 0.3 * c(0),
                (50.0 * x.z).sin() + 0.3 * c(8),
                (35.0 * x.x + 20.0 * x.y).cos() + 0.3 * c(16),
            )
        })
        .collect()
}

/// The assembled stabilisation's energy `½ uᵀ K u` on a graded box under a rough field
/// equals the definition evaluated by brute force (independent fit by elimination in
/// f64): tolerance 1e-4 relative, for the rounding of K to f32. `K` is symmetric (1e-5
/// of its row's largest entry).
#[test]
fn energy_is_the_fits_residual() {
    let p = graded_box();
    let st = MlsStencil::build_with(&p, GradientBasis::Quadratic);
    let (alpha, mu) = (1.0, 4.0e7);
    let k = Stabilisation::build(&p, &st, mu, |_| alpha);
    let u = rough_field(&p);
    let assembled = k.energy(|j| u[j].as_vec3());
    let reference = brute_force_energy(&p, &st, alpha, mu, &u);
    println!(
        "{} phyxels: assembled {assembled:.6e} J, brute force {reference:.6e} J ({:+.2e})",
        p.len(),
        assembled / reference - 1.0
    );
    assert!(reference > 0.0);
    assert!((assembled / reference - 1.0).abs() < 1e-4);
    for j in 0..k.len() {
        let largest = k.row(j).fold(0.0f32, |a, (_, v)| a.max(v.abs()));
        for (l, v) in k.row(j) {
            let back = k.row(l).find(|&(m, _)| m == j).map_or(0.0, |e| e.1);
            assert!(
                (v - back).abs() <= 1e-5 * largest,
                "K[{j}][{l}] = {v}, K[{l}][{j}] = {back}"
            );
        }
    }
}

/// No force for a quadratic displacement, a rigid turn of 90° about a tilted axis, or
/// their sum (bending costs nothing extra, and the term is invariant under rotation):
/// `|K u|` within 1e-4 of `|K u|` for a rough field of the same size, phyxel by phyxel
/// at worst (f32 entries). And the rough field's energy is positive.
#[test]
fn vanishes_on_quadratic_fields_and_rigid_turns() {
    let p = graded_box();
    let st = MlsStencil::build_with(&p, GradientBasis::Quadratic);
    let k = Stabilisation::build(&p, &st, 4.0e7, |_| 1.0);
    let turn = Quat::from_axis_angle(
        Vec3::new(1.0, 2.0, 3.0).normalize(),
        0.5 * std::f32::consts::PI,
    );
    let quadratic = |x: Vec3| {
        Vec3::new(
            0.3 * x.x * x.y - 0.2 * x.z * x.z + 0.1 * x.x,
            0.5 * x.x * x.x + 0.05 * x.y,
            -0.4 * x.y * x.z + 0.2 * x.x * x.z,
        )
    };
    let fields: [Field; 3] = [
        ("quadratic", Box::new(quadratic)),
        ("rigid turn", Box::new(move |x: Vec3| turn * x - x)),
        (
            "turned quadratic",
            Box::new(move |x: Vec3| turn * (x + quadratic(x)) - x + Vec3::new(0.5, -1.0, 2.0)),
        ),
    ];
    let rough = rough_field(&p);
    let rough_size = rough.iter().map(|u| u.length()).fold(0.0, f64::max) as f32;
    let rough_force = (0..p.len())
        .map(|j| k.product_at(j, |l| rough[l].as_vec3()).length())
        .fold(0.0f32, f32::max);
    assert!(k.energy(|j| rough[j].as_vec3()) > 0.0);
    for (name, field) in fields {
        let u: Vec<Vec3> = (0..p.len()).map(|j| field(p.rest.get(j))).collect();
        let size = u.iter().map(|v| v.length()).fold(0.0f32, f32::max);
        let force = (0..p.len())
            .map(|j| k.product_at(j, |l| u[l]).length())
            .fold(0.0f32, f32::max);
        let relative = (force / size) / (rough_force / rough_size);
        println!(
            "{name}: largest |K u| {force:.3e} N for |u| {size:.3e} m ({relative:.1e} of rough)"
        );
        assert!(relative < 1e-4, "{name}: {relative:.2e}");
    }
}

/// The stabilisation enters only where the material asks for it: by default at weight 1
/// where a graded cloud's levels meet and nowhere on a uniform cloud; a given weight
/// applies to every phyxel, and `stabilisation = 0` turns it off. Read through the
/// elastic energy of a rough field, which the term raises.
#[test]
fn default_weight_follows_the_grading() {
    use phyxel::backends::mls::MlsDynamics;
    let energy = |p: &Phyxels, mat: &Material| {
        let mut q = p.clone();
        let u = rough_field(p);
        for (j, uj) in u.iter().enumerate() {
            q.pos.set(j, q.rest.get(j) + uj.as_vec3());
        }
        let mut m = MlsDynamics::new(&q, mat);
        m.compute_forces(&q, mat, 1e-4);
        phyxel::Dynamics::diagnostics(&m, &q, mat)
            .elastic_energy
            .unwrap()
    };
    let graded = graded_box();
    let uniform = {
        let v = Shape::Box {
            size: [0.2, 0.1, 0.1],
        }
        .sample_volume_nodal(0.025);
        Phyxels::at_rest(&v.positions, v.cell_volume, 1000.0).with_volumes(&v.volumes, 1000.0)
    };
    let default = Material::default();
    let with = |a: f32| Material {
        stabilisation: a,
        ..Material::default()
    };
    // The level interface's phyxels: 1% of the rough field's energy (all phyxels: 6%).
    assert!(energy(&graded, &default) > 1.002 * energy(&graded, &with(0.0)));
    assert!(energy(&graded, &with(1.0)) > 1.01 * energy(&graded, &default));
    assert_eq!(energy(&uniform, &default), energy(&uniform, &with(0.0)));
    assert!(energy(&uniform, &with(1.0)) > 1.01 * energy(&uniform, &default));
}
