//! MLS elasticity against independent references: affine consistency, rotation
//! invariance, the isotropic Hooke law, the patch test and Newton's third law.

use glam::{DMat3, DVec3, Mat3, Quat, Vec3};
use phyxel::backends::mls::MlsDynamics;
use phyxel::body::shape::Shape;
use phyxel::material::Material;
use phyxel::points::phyxels::Phyxels;

/// A deterministic pseudo-random generator (xorshift), so failures reproduce.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    }
    fn mat(&mut self, scale: f32) -> Mat3 {
        Mat3::from_cols_array(&std::array::from_fn(|_| self.next() * scale))
    }
}

/// A box of phyxels (0.2 × 0.1 × 0.15 m at 0.02 m spacing) and its MLS backend.
fn block(material: &Material) -> (Phyxels, MlsDynamics) {
    let v = Shape::Box {
        size: [0.2, 0.1, 0.15],
    }
    .sample_volume(0.02);
    let p = Phyxels::at_rest(&v.positions, v.cell_volume, material.density);
    let m = MlsDynamics::new(&p, material);
    (p, m)
}

/// Also a sphere, whose boundary neighbourhoods are irregular.
fn ball(material: &Material) -> (Phyxels, MlsDynamics) {
    let v = Shape::Sphere { radius: 0.1 }.sample_volume(0.02);
    let p = Phyxels::at_rest(&v.positions, v.cell_volume, material.density);
    let m = MlsDynamics::new(&p, material);
    (p, m)
}

/// A graded sphere (`shape::graded`): 0.02 m spacing, 4× finer within 4 cm of its
/// bottom, with the shape's grading for its surfels.
fn graded_ball() -> (
    phyxel::body::shape::VolumeSample,
    phyxel::body::shape::graded::Grading,
) {
    use phyxel::body::shape::graded::{Grading, Refinement, Zone};
    let grading = Grading {
        base: 0.02,
        zones: vec![Refinement {
            zone: Zone::Sphere {
                centre: Vec3::new(0.0, -0.1, 0.0),
                radius: 0.04,
            },
            spacing: 0.005,
        }],
    };
    let (v, _) = Shape::Sphere { radius: 0.1 }.sample_volume_graded(&grading);
    (v, grading)
}

fn deform(p: &mut Phyxels, f: impl Fn(Vec3) -> Vec3) {
    for i in 0..p.len() {
        let x = f(p.rest.get(i));
        p.pos.set(i, x);
    }
}

fn max_abs(m: Mat3) -> f32 {
    m.to_cols_array().iter().fold(0.0f32, |a, v| a.max(v.abs()))
}

/// MLS is first-order consistent (Müller et al. 2004, eq. 7): for a random affine
/// displacement `u = B x + c`, the gradient equals B at every phyxel, boundary included,
/// on a box, a sphere and a graded sphere (three levels, each phyxel with its own
/// spacing and influence radius). Tolerance: 1e-4 relative to |B| (f32 arithmetic).
#[test]
fn affine_fields_give_exact_gradient() {
    let mat = Material::default();
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let graded = {
        let (v, _) = graded_ball();
        let p = Phyxels::at_rest(&v.positions, v.cell_volume, mat.density)
            .with_volumes(&v.volumes, mat.density);
        let m = MlsDynamics::new(&p, &mat);
        (p, m)
    };
    for (mut p, mut m) in [block(&mat), ball(&mat), graded] {
        assert_eq!(
            m.ill_conditioned(),
            0,
            "a solid lattice has no ill-conditioned phyxel"
        );
        for _ in 0..5 {
            let b = rng.mat(0.05);
            let c = Vec3::new(rng.next(), rng.next(), rng.next()) * 0.01;
            deform(&mut p, |x| x + b * x + c);
            m.compute_forces(&p, &mat, 1e-4);
            let grad = phyxel::Dynamics::displacement_gradient(&m).unwrap();
            for (i, g) in grad.iter().enumerate() {
                let err = max_abs(*g - b) / max_abs(b);
                assert!(err < 1e-4, "phyxel {i}: relative gradient error {err:e}");
            }
        }
    }
}

/// A rigid rotation (40° about an oblique axis) plus translation must give zero strain
/// (the Green strain is rotation invariant). Reference: forces of a deformation with the
/// same largest displacement (a uniform 1-axis stretch); the ratio must stay below 1e-5.
#[test]
fn rigid_motion_gives_no_strain_or_force() {
    let mat = Material::default();
    let (mut p, mut m) = ball(&mat);
    let q = Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 40f32.to_radians());
    let t = Vec3::new(0.03, -0.02, 0.01);
    deform(&mut p, |x| q * x + t);
    let u_max = (0..p.len())
        .map(|i| (p.pos.get(i) - p.rest.get(i)).length())
        .fold(0.0, f32::max);
    m.compute_forces(&p, &mat, 1e-4);
    let strain = m.diagnostics_strain();
    let f_rot = max_force(&m);
    let stretch = u_max / 0.1;
    deform(&mut p, |x| Vec3::new(x.x * (1.0 + stretch), x.y, x.z));
    m.compute_forces(&p, &mat, 1e-4);
    let f_ref = max_force(&m);
    assert!(
        strain < 1e-5,
        "largest strain under rigid rotation: {strain:e}"
    );
    assert!(
        f_rot / f_ref < 1e-5,
        "force ratio rotation/stretch {:e}",
        f_rot / f_ref
    );
}

fn max_force(m: &MlsDynamics) -> f32 {
    m.internal_forces()
        .iter()
        .map(|f| f.length())
        .fold(0.0, f32::max)
}

trait StrainDiag {
    fn diagnostics_strain(&self) -> f32;
}
impl StrainDiag for MlsDynamics {
    fn diagnostics_strain(&self) -> f32 {
        let p = Phyxels::default();
        phyxel::Dynamics::diagnostics(self, &p, &Material::default())
            .max_strain
            .unwrap()
    }
}

/// A homogeneous deformation `x = F x₀` gives at every phyxel the stress of the isotropic
/// Hooke law `σ = λ tr(ε) I + 2μ ε`, `ε = ½(FᵀF − I)`, computed here independently in f64.
/// Tolerance: 1e-4 relative to |σ|.
#[test]
fn homogeneous_strain_gives_hooke_stress() {
    let mat = Material {
        young: 2.0e6,
        poisson: 0.35,
        ..Default::default()
    };
    let (mut p, mut m) = block(&mat);
    let f = Mat3::from_cols_array(&[1.02, 0.005, -0.01, 0.0, 0.97, 0.015, 0.01, 0.0, 1.01]);
    deform(&mut p, |x| f * x);
    m.compute_forces(&p, &mat, 1e-4);
    let fd = f.as_dmat3();
    let eps = (fd.transpose() * fd - DMat3::IDENTITY) * 0.5;
    let (e, nu) = (mat.young as f64, mat.poisson as f64);
    let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let mu = e / (2.0 * (1.0 + nu));
    let tr = eps.x_axis.x + eps.y_axis.y + eps.z_axis.z;
    let sigma = DMat3::from_diagonal(DVec3::splat(lambda * tr)) + eps * (2.0 * mu);
    let scale = sigma
        .to_cols_array()
        .iter()
        .fold(0.0f64, |a, v| a.max(v.abs()));
    for i in 0..p.len() {
        let s = m.stress(&mat, i).as_dmat3();
        let err = (s - sigma)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |a, v| a.max(v.abs()))
            / scale;
        assert!(err < 1e-4, "phyxel {i}: relative stress error {err:e}");
    }
}

/// Patch test: under homogeneous stress the interior is in equilibrium, so phyxels whose
/// neighbours' neighbourhoods are all complete (farther than 2 h from the boundary) feel
/// (almost) no force.
/// Reference: the largest boundary force; interior forces must stay below 1e-3 of it.
#[test]
fn homogeneous_strain_is_in_equilibrium_inside() {
    let mat = Material::default();
    let v = Shape::Box {
        size: [0.4, 0.4, 0.4],
    }
    .sample_volume(0.02);
    let mut p = Phyxels::at_rest(&v.positions, v.cell_volume, mat.density);
    let mut m = MlsDynamics::new(&p, &mat);
    deform(&mut p, |x| Vec3::new(1.01 * x.x, x.y - 0.005 * x.z, x.z));
    m.compute_forces(&p, &mat, 1e-4);
    let h = p.radius[0];
    let (mut inner, mut outer) = (0.0f32, 0.0f32);
    for i in 0..p.len() {
        let x = p.rest.get(i);
        let f = m.internal_forces().get(i).length();
        if x.abs().max_element() < 0.2 - 2.0 * h {
            inner = inner.max(f);
        } else {
            outer = outer.max(f);
        }
    }
    assert!(
        outer > 0.0 && 0.2 - 2.0 * h > 0.02,
        "the block must have an interior"
    );
    assert!(
        inner < 1e-3 * outer,
        "interior force {inner:e} vs boundary {outer:e}"
    );
}

/// Newton's third law: for any deformation, internal forces sum to zero, because
/// `d_i = −Σ_j d_j` (Müller et al. 2004, eq. 16). Tolerance: |Σf| < 1e-5 Σ|f|.
#[test]
fn internal_forces_sum_to_zero() {
    let mat = Material {
        damping: 0.001,
        ..Default::default()
    };
    let (mut p, mut m) = ball(&mat);
    let mut rng = Rng(42);
    for i in 0..p.len() {
        let x = p.rest.get(i);
        p.pos
            .set(i, x + Vec3::new(rng.next(), rng.next(), rng.next()) * 0.003);
        p.vel
            .set(i, Vec3::new(rng.next(), rng.next(), rng.next()) * 0.1);
    }
    m.compute_forces(&p, &mat, 1e-4);
    let f = m.internal_forces();
    let (mut sum, mut abs) = (DVec3::ZERO, 0.0f64);
    for i in 0..p.len() {
        sum += f.get(i).as_dvec3();
        abs += f.get(i).length() as f64;
    }
    assert!(abs > 0.0);
    assert!(
        sum.length() < 1e-5 * abs,
        "|Σf| = {:e}, Σ|f| = {abs:e}",
        sum.length()
    );
}

/// Degenerate sampling: a one-phyxel-thick plate has rank-2 moment matrices everywhere.
/// They must be detected (every phyxel flagged) and handled by the pseudo-inverse, so the
/// in-plane gradient stays exact (affine in-plane field to 1e-4) and nothing is NaN.
#[test]
fn coplanar_neighbourhoods_are_detected_and_handled() {
    let mat = Material::default();
    let v = Shape::Box {
        size: [0.2, 0.01, 0.2],
    }
    .sample_volume(0.02);
    let mut p = Phyxels::at_rest(&v.positions, v.cell_volume, mat.density);
    assert!(
        p.rest.iter().all(|x| x.y.abs() < 1e-6),
        "one layer expected"
    );
    let mut m = MlsDynamics::new(&p, &mat);
    assert_eq!(
        m.ill_conditioned(),
        p.len(),
        "every coplanar neighbourhood is ill-conditioned"
    );
    let b = Mat3::from_cols(
        Vec3::new(0.01, 0.0, 0.02),
        Vec3::ZERO,
        Vec3::new(-0.03, 0.0, 0.005),
    );
    deform(&mut p, |x| x + b * x);
    m.compute_forces(&p, &mat, 1e-4);
    let grad = phyxel::Dynamics::displacement_gradient(&m).unwrap();
    for g in grad {
        assert!(g.is_finite());
        assert!(
            max_abs(*g - b) / max_abs(b) < 1e-4,
            "in-plane gradient {g} vs {b}"
        );
    }
    assert!(m.internal_forces().all_finite());
}

/// Surfel advection reproduces an affine motion exactly: with phyxels at `x = F x₀ + c`,
/// every surfel lands at `F s₀ + c` (to 1e-4 of the radius, f32 positions) and its normal at
/// `normalize(F⁻ᵀ n₀)` (to 1e-4), since `u(s) = Σ w (u_i + ∇u_i (s₀ − x₀ᵢ))` is exact for
/// affine fields (Müller et al. 2004, §5). On a uniform and a graded sphere (surfels of
/// three disk radii over phyxels of three spacings).
#[test]
fn surfels_follow_affine_motion_exactly() {
    let shape = Shape::Sphere { radius: 0.1 };
    let (vol, surf) = (shape.sample_volume(0.02), shape.sample_surface(0.01));
    affine_advection(&vol, &surf);
    let (vol, grading) = graded_ball();
    let (surf, levels) = shape.sample_surface_graded(0.01, &grading);
    assert_eq!(levels.iter().max(), Some(&2));
    affine_advection(&vol, &surf);
}

/// `surfels_follow_affine_motion_exactly` on one sampling.
fn affine_advection(
    vol: &phyxel::body::shape::VolumeSample,
    surf: &phyxel::body::shape::SurfaceSample,
) {
    use phyxel::Object;
    use phyxel::points::surfels::Surfels;
    let mat = Material::default();
    let p = Phyxels::at_rest(&vol.positions, vol.cell_volume, mat.density)
        .with_volumes(&vol.volumes, mat.density);
    let s = Surfels::at_rest(&surf.positions, &surf.normals, &surf.radii);
    let dynamics = MlsDynamics::new(&p, &mat);
    let mut obj = Object::new(0, "ball", s, p, mat.clone(), Box::new(dynamics));
    let f = Mat3::from_cols_array(&[1.05, 0.02, 0.0, -0.03, 0.97, 0.01, 0.0, 0.04, 1.02]);
    let c = Vec3::new(0.1, -0.2, 0.05);
    deform(&mut obj.phyxels, |x| f * x + c);
    // One force evaluation fills the backend's gradient (zero dt: nothing moves).
    let ctx = phyxel::StepContext::new(0.0, Vec3::ZERO, &mat);
    obj.dynamics.step(&mut obj.phyxels, &ctx);
    obj.advect_surfels();
    let f_inv_t = f.inverse().transpose();
    for i in 0..obj.surfels.len() {
        let want = f * obj.surfels.rest.get(i) + c;
        let err = (obj.surfels.pos.get(i) - want).length();
        assert!(err < 1e-4 * 0.1, "surfel {i}: position error {err:e} m");
        let n = (f_inv_t * obj.surfels.rest_normal.get(i)).normalize();
        let nerr = (obj.surfels.normal.get(i) - n).length();
        assert!(nerr < 1e-4, "surfel {i}: normal error {nerr:e}");
    }
}

/// The lane kernel (`compute_forces`, eight phyxels per `f32x8`) against its scalar
/// reference (`compute_forces_reference`, glam matrices per phyxel), on a ball with a
/// random deformation of 5% strain and random velocities, over five materials: the
/// calibrated and the paper's strain form, no viscosity, no volume term, and plastic flow
/// (five steps, so the plastic strain both flows and hits its cap).
/// Tolerance, from f32 rounding of the same formulas in a different operation order:
/// forces to 1e-5 of the largest force (N), gradients to 1e-6 (dimensionless),
/// plastic strains to 1e-6 (dimensionless); the strain norms to 1e-6 relative.
#[test]
fn lane_kernel_matches_scalar_reference() {
    use phyxel::dynamics::Dynamics;
    use phyxel::material::StrainForm;
    let base = Material::default();
    let materials = [
        ("calibrated", base.clone()),
        (
            "paper strain",
            Material {
                strain: StrainForm::Paper,
                ..base.clone()
            },
        ),
        (
            "no viscosity, no volume term",
            Material {
                damping: 0.0,
                volume_stiffness: 0.0,
                ..base.clone()
            },
        ),
        (
            "plastic",
            Material {
                plastic_yield: 0.01,
                plastic_creep: 2000.0,
                plastic_max: 0.02,
                ..base.clone()
            },
        ),
        (
            "plastic, fracture",
            Material {
                plastic_yield: 0.01,
                plastic_creep: 2000.0,
                plastic_max: 0.5,
                fracture: true,
                ..base.clone()
            },
        ),
    ];
    for (name, mat) in materials {
        let (mut p, mut lanes) = ball(&mat);
        let mut scalar = MlsDynamics::new(&p, &mat);
        let mut rng = Rng(7);
        let b = rng.mat(0.05);
        for i in 0..p.len() {
            let x = p.rest.get(i);
            let jitter = Vec3::new(rng.next(), rng.next(), rng.next()) * 0.0005;
            p.pos.set(i, x + b * x + jitter);
            p.vel
                .set(i, Vec3::new(rng.next(), rng.next(), rng.next()) * 0.2);
        }
        for step in 0..5 {
            lanes.compute_forces(&p, &mat, 1e-4);
            phyxel::testing::compute_forces_reference(&mut scalar, &p, &mat, 1e-4);
            let (fl, fs) = (lanes.internal_forces(), scalar.internal_forces());
            let fmax = fs.iter().fold(0.0f32, |a, f| a.max(f.length()));
            assert!(fmax > 0.0, "{name}: no force");
            for i in 0..p.len() {
                let err = (fl.get(i) - fs.get(i)).length();
                assert!(
                    err <= 1e-5 * fmax,
                    "{name}, step {step}, phyxel {i}: force {} vs {} (max {fmax})",
                    fl.get(i),
                    fs.get(i)
                );
            }
            let (gl, gs) = (
                lanes.displacement_gradient().unwrap(),
                scalar.displacement_gradient().unwrap(),
            );
            for (i, (a, b)) in gl.iter().zip(gs).enumerate() {
                assert!(max_abs(*a - *b) <= 1e-6, "{name}: gradient {i}: {a} vs {b}");
            }
            let (pl, ps) = (lanes.plastic_strain(), scalar.plastic_strain());
            assert_eq!(pl.len(), ps.len());
            for (i, (a, b)) in pl.iter().zip(ps).enumerate() {
                assert!(max_abs(*a - *b) <= 1e-6, "{name}: plastic {i}: {a} vs {b}");
            }
            let (sl, ss) = (
                lanes.diagnostics(&p, &mat).max_strain.unwrap(),
                scalar.diagnostics(&p, &mat).max_strain.unwrap(),
            );
            assert!(
                (sl - ss).abs() <= 1e-6 * ss,
                "{name}: max strain {sl} vs {ss}"
            );
        }
        if mat.is_plastic() {
            let flowed = lanes
                .plastic_strain()
                .iter()
                .filter(|e| max_abs(**e) > 0.0)
                .count();
            assert!(flowed > 0, "{name}: no plastic flow to compare");
        }
    }
}

/// A quadratic displacement field with every second-order term, a different Hessian per
/// component, plus an affine part: `u_k(x) = ½ (x − x₀)ᵀ H_k (x − x₀) + (B x)_k` (m, with
/// x in m and H_k in 1/m). Returns the field and its analytic gradient
/// (column b = ∂u/∂x_b, as `MlsStencil::gradient_of`), both in f64.
fn quadratic_field() -> (impl Fn(DVec3) -> DVec3, impl Fn(DVec3) -> DMat3) {
    // Symmetric, all six entries non-zero and distinct between components.
    let sym = |xx: f64, yy: f64, zz: f64, xy: f64, yz: f64, zx: f64| {
        DMat3::from_cols(
            DVec3::new(xx, xy, zx),
            DVec3::new(xy, yy, yz),
            DVec3::new(zx, yz, zz),
        )
    };
    let h = [
        sym(0.8, -0.5, 0.3, 0.6, -0.4, 0.9),
        sym(-0.3, 0.7, -0.6, -0.8, 0.5, 0.4),
        sym(0.5, 0.2, 0.9, 0.3, 0.7, -0.7),
    ];
    let b = DMat3::from_cols_array(&[0.01, -0.02, 0.015, 0.005, 0.01, -0.01, 0.02, 0.0, -0.015]);
    let x0 = DVec3::new(0.03, -0.02, 0.01);
    let u = move |x: DVec3| {
        let y = x - x0;
        DVec3::new(
            0.5 * y.dot(h[0] * y),
            0.5 * y.dot(h[1] * y),
            0.5 * y.dot(h[2] * y),
        ) + b * x
    };
    // Row k of the gradient is (H_k (x − x₀))ᵀ.
    let grad = move |x: DVec3| {
        let y = x - x0;
        DMat3::from_cols(h[0] * y, h[1] * y, h[2] * y).transpose() + b
    };
    (u, grad)
}

/// MLS gradients of `u` (evaluated in f64 at the f32 rest positions, passed as f32) on
/// the stencil of `basis`, and their largest error against the analytic gradient
/// relative to the largest analytic gradient, per phyxel.
fn gradient_errors(
    p: &Phyxels,
    basis: phyxel::dynamics::gradient::GradientBasis,
    u: &impl Fn(DVec3) -> DVec3,
    grad: &impl Fn(DVec3) -> DMat3,
) -> Vec<f64> {
    let st = phyxel::dynamics::gradient::MlsStencil::build_with(p, basis);
    let field: Vec<Vec3> = p.rest.iter().map(|x| u(x.as_dvec3()).as_vec3()).collect();
    let mut g = vec![Mat3::ZERO; p.len()];
    st.gradients(&field, &mut g);
    let abs_max = |m: DMat3| m.to_cols_array().iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let scale = p
        .rest
        .iter()
        .map(|x| abs_max(grad(x.as_dvec3())))
        .fold(0.0, f64::max);
    (0..p.len())
        .map(|i| abs_max(g[i].as_dmat3() - grad(p.rest.get(i).as_dvec3())) / scale)
        .collect()
}

/// The default quadratic MLS basis (`GradientBasis::Quadratic`) is second-order
/// consistent: for a quadratic displacement with all six second-order terms and a different
/// Hessian per component (`quadratic_field`, |∇u| up to about 0.15), the gradient equals
/// the analytic one at every phyxel of a box and a ball — boundary phyxels included, whose
/// one-sided neighbourhoods the linear basis gets wrong (see the next test). Every phyxel
/// must have taken the quadratic fit (its weights differ from the linear basis's: no
/// fallback). Tolerance: 1e-5 relative to the largest gradient (f32 field values and
/// weights; measured 4e-7).
#[test]
fn quadratic_basis_is_exact_for_quadratic_fields() {
    use phyxel::dynamics::gradient::{GradientBasis, MlsStencil};
    let mat = Material::default();
    let (u, grad) = quadratic_field();
    for (name, (p, _)) in [("box", block(&mat)), ("ball", ball(&mat))] {
        let quad = MlsStencil::build_with(&p, GradientBasis::Quadratic);
        let lin = MlsStencil::build_with(&p, GradientBasis::Linear);
        let fitted = (0..p.len())
            .filter(|&i| quad.d[quad.row(i)] != lin.d[lin.row(i)])
            .count();
        assert_eq!(fitted, p.len(), "{name}: phyxels without the quadratic fit");
        let err = gradient_errors(&p, GradientBasis::Quadratic, &u, &grad);
        let worst = err.iter().copied().fold(0.0, f64::max);
        println!("{name}: quadratic basis, worst relative gradient error {worst:e}");
        for (i, e) in err.iter().enumerate() {
            assert!(
                *e < 1e-5,
                "{name}, phyxel {i}: relative gradient error {e:e}"
            );
        }
    }
}

/// The linear basis (`GradientBasis::Linear`, Müller et al. 2004) is exact for affine
/// fields (random `u = B x + c`, every phyxel, 1e-4 relative to |B|) but not for the
/// quadratic field of the previous test: where the neighbourhood is one-sided (the
/// boundary) its largest error must exceed 1e-2 of the largest gradient (measured 0.12),
/// a thousand times the quadratic basis's tolerance, so the two bases differ.
#[test]
fn linear_basis_is_exact_only_for_affine_fields() {
    use phyxel::dynamics::gradient::GradientBasis;
    let mat = Material::default();
    let (u, grad) = quadratic_field();
    let mut rng = Rng(0xD1B5_4A32_D192_ED03);
    for (name, (p, _)) in [("box", block(&mat)), ("ball", ball(&mat))] {
        for _ in 0..3 {
            let b = rng.mat(0.05).as_dmat3();
            let c = DVec3::new(rng.next() as f64, rng.next() as f64, rng.next() as f64) * 0.01;
            let err = gradient_errors(&p, GradientBasis::Linear, &|x| b * x + c, &|_| b);
            for (i, e) in err.iter().enumerate() {
                assert!(*e < 1e-4, "{name}, phyxel {i}: affine gradient error {e:e}");
            }
        }
        let err = gradient_errors(&p, GradientBasis::Linear, &u, &grad);
        let worst = err.iter().copied().fold(0.0, f64::max);
        println!("{name}: linear basis, worst relative quadratic-field error {worst:e}");
        assert!(
            worst > 1e-2,
            "{name}: the linear basis reproduced a quadratic field ({worst:e})"
        );
    }
}

/// The paper's strain form (`strain = "paper"`, as Müller et al. 2004 write it: strain
/// `ε = JᵀJ − I`, stress `σ = λ tr(ε) I + 2μ ε`, force `f = −2 v J σ d`, i.e. the energy
/// density `½ ε:σ` differentiated with respect to J) under a homogeneous deformation
/// `x = F x₀` of a block (strains of 1–3%), against that law computed here in f64:
/// - the stress at every phyxel is `σ` (Pa) of the paper's strain, twice the
///   Green–Saint-Venant stress at small strain; tolerance 1e-4 relative to |σ|, as the
///   calibrated form's test (f32 strain of a 1e-6-accurate gradient; measured 5e-5);
/// - the virial of the internal forces, `Σ_j f_j x₀_jᵀ` (N·m), equals
///   `−V (2 F σ + k_v (det F − 1) cof F)` (V: total volume; the volume term of eq. 11
///   with `k_v = 0.1 E`), exactly for any stencil that reproduces affine fields, since
///   `Σ_j d_ij x₀_ijᵀ = I`: four times the calibrated form's first Piola stress at small
///   strain. Tolerance 1e-4 relative to the largest entry (measured 6e-6).
#[test]
fn paper_strain_form_gives_its_hooke_law() {
    use phyxel::material::StrainForm;
    let mat = Material {
        young: 2.0e6,
        poisson: 0.35,
        damping: 0.0,
        strain: StrainForm::Paper,
        ..Default::default()
    };
    let (mut p, mut m) = block(&mat);
    assert_eq!(m.ill_conditioned(), 0);
    let f = Mat3::from_cols_array(&[1.02, 0.005, -0.01, 0.0, 0.97, 0.015, 0.01, 0.0, 1.01]);
    deform(&mut p, |x| f * x);
    m.compute_forces(&p, &mat, 1e-4);
    let fd = f.as_dmat3();
    let eps = fd.transpose() * fd - DMat3::IDENTITY;
    let (e, nu) = (mat.young as f64, mat.poisson as f64);
    let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let mu = e / (2.0 * (1.0 + nu));
    let tr = eps.x_axis.x + eps.y_axis.y + eps.z_axis.z;
    let sigma = DMat3::from_diagonal(DVec3::splat(lambda * tr)) + eps * (2.0 * mu);
    let abs_max = |m: DMat3| m.to_cols_array().iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let mut stress_err = 0.0f64;
    for i in 0..p.len() {
        let err = abs_max(m.stress(&mat, i).as_dmat3() - sigma) / abs_max(sigma);
        stress_err = stress_err.max(err);
        assert!(err < 1e-4, "phyxel {i}: relative stress error {err:e}");
    }
    let kv = 0.1 * e;
    let det = fd.determinant();
    let cof = fd.inverse().transpose() * det;
    let volume: f64 = (0..p.len()).map(|i| p.volume[i] as f64).sum();
    let want = -(fd * sigma * 2.0 + cof * (kv * (det - 1.0))) * volume;
    let mut virial = DMat3::ZERO;
    let forces = m.internal_forces();
    for j in 0..p.len() {
        let (fj, xj) = (forces.get(j).as_dvec3(), p.rest.get(j).as_dvec3());
        virial += DMat3::from_cols(fj * xj.x, fj * xj.y, fj * xj.z);
    }
    let err = abs_max(virial - want) / abs_max(want);
    println!("paper form: stress error {stress_err:e}, virial error {err:e}");
    assert!(
        err < 1e-4,
        "virial {virial} vs {want}: relative error {err:e}"
    );
}

/// Saint-Venant's pure bending of curvature `kappa` (1/m) about z, Poisson's ratio `nu`:
/// `u_x = −κxy`, `u_y = ½κ(x² + ν(y² − z²))`, `u_z = νκyz`, whose only stress is
/// `σ_xx = −Eκy`.
fn bend(p: &mut Phyxels, kappa: f64, nu: f64) {
    deform(p, |x| {
        let (x, y, z) = (x.x as f64, x.y as f64, x.z as f64);
        let u = DVec3::new(
            -kappa * x * y,
            0.5 * kappa * (x * x + nu * (y * y - z * z)),
            nu * kappa * y * z,
        );
        (DVec3::new(x, y, z) + u).as_vec3()
    });
}

/// The elastic energy (J) that `mls` reports for `shape`'s nodal sampling at `spacing`
/// (m) bent by [`bend`] with curvature `kappa` (1/m), against the closed form
/// `½(E + k_v(1 − 2ν)²) κ² ∫y² dV` for the shape's `y2` = `∫y² dV` (m⁵), and the
/// phyxels (at rest, before the bend).
fn bending_energy(
    shape: &Shape,
    spacing: f32,
    mat: &Material,
    kappa: f64,
    y2: f64,
) -> (f64, f64, Phyxels) {
    let (e, nu, kv) = (mat.young as f64, mat.poisson as f64, mat.k_volume() as f64);
    let v = shape.sample_volume_nodal(spacing);
    let rest = Phyxels::at_rest(&v.positions, v.cell_volume, mat.density)
        .with_volumes(&v.volumes, mat.density);
    let mut p = rest.clone();
    let mut m = MlsDynamics::new(&p, mat);
    bend(&mut p, kappa, nu);
    m.compute_forces(&p, mat, 1e-4);
    let energy = phyxel::Dynamics::diagnostics(&m, &p, mat)
        .elastic_energy
        .unwrap();
    let exact = 0.5 * (e + kv * (1.0 - 2.0 * nu).powi(2)) * kappa * kappa * y2;
    (energy, exact, rest)
}

/// Nodal integration's bending energy on a graded cloud (`shape::graded`): the
/// pure-bending field of `box_bending_energy_is_exact` on a 0.4 × 0.1 × 0.1 m box bar
/// at 4 phyxels across, refined 2× over x < 0 and, separately, 4× within 4 cm of one
/// end's centre, against the same closed form (`∫y² dV = l t⁴/12`). The quadratic MLS
/// fit is exact for this field wherever a phyxel's moment matrix is well conditioned,
/// also across a level interface, and the fitted volumes integrate `y²` exactly:
/// tolerance 2e-3, as for the uniform box. Also: no ill-conditioned phyxel.
#[test]
fn bending_energy_is_exact_on_a_graded_cloud() {
    use phyxel::body::shape::graded::{Grading, Refinement, Zone};
    let mat = Material {
        young: 1.0e6,
        poisson: 0.3,
        ..Default::default()
    };
    let (e, nu, kv) = (mat.young as f64, mat.poisson as f64, mat.k_volume() as f64);
    let kappa = 0.02f64;
    let shape = Shape::Box {
        size: [0.4, 0.1, 0.1],
    };
    let exact = 0.5 * (e + kv * (1.0 - 2.0 * nu).powi(2)) * kappa * kappa * 0.4 * 1e-4 / 12.0;
    let zones = [
        Refinement {
            zone: Zone::Box {
                min: Vec3::new(-0.2, -0.05, -0.05),
                max: Vec3::new(0.0, 0.05, 0.05),
            },
            spacing: 0.0125,
        },
        Refinement {
            zone: Zone::Sphere {
                centre: Vec3::new(-0.2, 0.0, 0.0),
                radius: 0.04,
            },
            spacing: 0.00625,
        },
    ];
    for zone in zones {
        let grading = Grading {
            base: 0.025,
            zones: vec![zone],
        };
        let (v, levels) = shape.sample_volume_graded(&grading);
        let p0 = Phyxels::at_rest(&v.positions, v.cell_volume, mat.density)
            .with_volumes(&v.volumes, mat.density);
        let mut p = p0.clone();
        let mut m = MlsDynamics::new(&p, &mat);
        bend(&mut p, kappa, nu);
        m.compute_forces(&p, &mat, 1e-4);
        let energy = phyxel::Dynamics::diagnostics(&m, &p, &mat)
            .elastic_energy
            .unwrap();
        let ill = phyxel::dynamics::gradient::MlsStencil::build_with(&p0, mat.gradient)
            .ill_conditioned
            .iter()
            .filter(|&&b| b)
            .count();
        println!(
            "{zone:?}: {} phyxels over {} levels, energy {energy:.6e} J against {exact:.6e} J \
             ({:+.3}%), {ill} ill-conditioned",
            p0.len(),
            levels.iter().max().unwrap() + 1,
            100.0 * (energy / exact - 1.0)
        );
        assert!((energy / exact - 1.0).abs() < 2e-3, "{zone:?}");
        assert_eq!(ill, 0, "{zone:?}");
    }
}

/// A box's bending energy under nodal integration is exact (docs/ACCURACY.md,
/// "Cantilever"): for the pure-bending field of linear elasticity (Saint-Venant:
/// `u_x = −κxy`, `u_y = ½κ(x² + ν(y² − z²))`, `u_z = νκyz`, so `σ_xx = −Eκy` is the only
/// stress) the reported elastic energy equals `∫ ½(E + k_v(1 − 2ν)²) κ² y² dV` =
/// `½(E + k_v(1 − 2ν)²) κ² L b t³/12` (J; the second term is the volume penalty's, as
/// `det J − 1 = (1 − 2ν) ε_xx` to first order) at 3, 4, 5 and 8 phyxels through the
/// thickness. The quadratic basis makes each phyxel's strain exact, so what is left is
/// the quadrature of `y²` across the thickness: the cell centres' midpoint rule with
/// equal volumes would keep `1 − 1/n²` of it (−6.25% at 4 through); the volumes fitted
/// to the box's moments (`shape::quadrature`) keep all of it. Tolerance 2e-3 (κ = 0.02 /m: strains up
/// to 1e-3, whose Green-strain terms are of order 1e-3 of the energy; f32 positions).
/// The same sum gives the rotational inertia about the long axis: within 1e-5 of the
/// solid box's `M t²/6`.
#[test]
fn box_bending_energy_is_exact() {
    let mat = Material {
        young: 1.0e6,
        poisson: 0.3,
        ..Default::default()
    };
    let (l, t, kappa) = (0.4f32, 0.1f32, 0.02f64);
    let y2 = l as f64 * (t as f64).powi(4) / 12.0;
    for n in [3u32, 4, 5, 8] {
        let spacing = t / n as f32;
        let shape = Shape::Box { size: [l, t, t] };
        let (energy, exact, p) = bending_energy(&shape, spacing, &mat, kappa, y2);
        // The rotational inertia about the long axis, `Σ m (y² + z²)`, is the same
        // quadrature: exact against a solid box's `M (t² + t²)/12`.
        let inertia: f64 = (0..p.len())
            .map(|i| {
                let x = p.rest.get(i).as_dvec3();
                p.mass[i] as f64 * (x.y * x.y + x.z * x.z)
            })
            .sum();
        let total: f64 = p.mass.iter().map(|&m| m as f64).sum();
        let solid = total * 2.0 * (t as f64).powi(2) / 12.0;
        assert!(
            (inertia / solid - 1.0).abs() < 1e-5,
            "{n} through: rotational inertia {inertia:e} against {solid:e} kg m²"
        );
        let err = energy / exact - 1.0;
        println!(
            "{n} through: energy {energy:.6e} J, exact {exact:.6e} J ({:+.3}%)",
            100.0 * err
        );
        assert!(
            err.abs() < 2e-3,
            "{n} through: bending energy off by {:+.3}%",
            100.0 * err
        );
    }
}

/// A prism along x from −l/2 to l/2 over the polygon `section` (y, z corners,
/// counter-clockwise seen from +x), ends fanned about their centres: a `mesh` shape.
fn prism(l: f32, section: &[(f32, f32)]) -> Shape {
    use phyxel::body::mesh::{Surface, TriMesh};
    let n = section.len() as u32;
    let mut v = Vec::new();
    for x in [-0.5 * l, 0.5 * l] {
        v.extend(section.iter().map(|&(y, z)| Vec3::new(x, y, z)));
    }
    v.extend([Vec3::new(-0.5 * l, 0.0, 0.0), Vec3::new(0.5 * l, 0.0, 0.0)]);
    let (left, right) = (2 * n, 2 * n + 1);
    let mut t = Vec::new();
    for k in 0..n {
        let (a, b) = (k, (k + 1) % n);
        t.extend([
            [a, b, b + n],
            [a, b + n, a + n],
            [left, b, a],
            [right, a + n, b + n],
        ]);
    }
    Shape::Mesh {
        path: String::new(),
        scale: 1.0,
        mesh: Some(std::sync::Arc::new(Surface::Triangles(
            TriMesh::new(v, t).unwrap(),
        ))),
    }
}

/// Nodal integration's bending energy on shapes the box's sampling does not
/// special-case, each a lattice with moment-fitted volumes (`shape::quadrature`): the
/// Saint-Venant pure-bending field of `box_bending_energy_is_exact` applied to a
/// meshed square bar and a meshed round bar (0.4 m, 0.1 m across; a 64-sided section
/// of circumradius 5 cm) and a sphere (r = 5 cm), against the same closed form with
/// the shape's own `∫y² dV` (square `l t⁴/12`, polygon `l · n r⁴ sin(2π/n)(2 + cos(2π/n))/24`,
/// sphere `(4π/15) r⁵`), at 4 and 6 phyxels across. Tolerance 2e-3, as for the box
/// (Green-strain terms of order 1e-3 of the energy; f32 positions). The lattice's equal
/// cell volumes would miss `1/n²` of the bars' (−6.25% at 4 across) and, on the round
/// shapes, the volume between the lattice and the surface.
#[test]
fn bending_energy_is_exact_on_any_shape() {
    let mat = Material {
        young: 1.0e6,
        poisson: 0.3,
        ..Default::default()
    };
    let kappa = 0.02f64;
    let sides = 64;
    let round: Vec<(f32, f32)> = (0..sides)
        .map(|k| {
            let a = std::f32::consts::TAU * k as f32 / sides as f32;
            (0.05 * a.cos(), 0.05 * a.sin())
        })
        .collect();
    let (c, s) = {
        let a = std::f64::consts::TAU / sides as f64;
        (a.cos(), a.sin())
    };
    let shapes = [
        (
            "square bar",
            prism(
                0.4,
                &[(-0.05, -0.05), (0.05, -0.05), (0.05, 0.05), (-0.05, 0.05)],
            ),
            0.4 * 0.1f64.powi(4) / 12.0,
        ),
        (
            "round bar",
            prism(0.4, &round),
            0.4 * sides as f64 * 0.05f64.powi(4) * s * (2.0 + c) / 24.0,
        ),
        (
            "sphere",
            Shape::Sphere { radius: 0.05 },
            4.0 * std::f64::consts::PI / 15.0 * 0.05f64.powi(5),
        ),
    ];
    for (name, shape, y2) in shapes {
        for n in [4u32, 6] {
            let (energy, exact, p) = bending_energy(&shape, 0.1 / n as f32, &mat, kappa, y2);
            let err = energy / exact - 1.0;
            println!(
                "{name}, {n} across ({} phyxels): energy {energy:.6e} J, exact {exact:.6e} J \
                 ({:+.3}%)",
                p.len(),
                100.0 * err
            );
            assert!(
                err.abs() < 2e-3,
                "{name}, {n} across: bending energy off by {:+.3}%",
                100.0 * err
            );
        }
    }
}
