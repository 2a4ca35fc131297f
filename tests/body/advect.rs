//! The fast surfel advection (per-phyxel affine table, direct column writes) against the
//! scalar reference sum of Müller et al. (2004, §5).

use glam::{Mat3, Quat, Vec3};
use phyxel::body::advect::SurfelBinding;
use phyxel::body::shape::Shape;
use phyxel::dynamics::gradient::MlsStencil;
use phyxel::material::Material;
use phyxel::points::phyxels::Phyxels;
use phyxel::points::surfels::Surfels;

/// A 0.1 m sphere centred 2.5 m from the origin, its phyxels rotated, stretched and bent
/// (non-uniform gradients) and given a swirling velocity; gradients by MLS. Surfels
/// `surfel_spacing` apart (m).
fn deformed_ball(surfel_spacing: f32) -> (Surfels, Phyxels, Vec<Mat3>) {
    let centre = Vec3::new(2.0, -1.0, 1.0);
    let shape = Shape::Sphere { radius: 0.1 };
    let vol = shape.sample_volume(0.02);
    let surf = shape.sample_surface(surfel_spacing);
    let shift = |p: &[Vec3]| p.iter().map(|&x| x + centre).collect::<Vec<_>>();
    let mat = Material::default();
    let mut p = Phyxels::at_rest(&shift(&vol.positions), vol.cell_volume, mat.density);
    let s = Surfels::at_rest(&shift(&surf.positions), &surf.normals, &surf.radii);
    let rot = Mat3::from_quat(Quat::from_axis_angle(
        Vec3::new(1.0, 2.0, -0.5).normalize(),
        0.7,
    ));
    let stretch = Mat3::from_diagonal(Vec3::new(1.2, 0.9, 1.05));
    for i in 0..p.len() {
        let d = p.rest.get(i) - centre;
        let bend = Vec3::new(0.0, 3.0 * d.x * d.x, -2.0 * d.x * d.y);
        p.pos.set(
            i,
            centre + rot * (stretch * d + bend) + Vec3::new(0.3, 0.1, -0.2),
        );
        p.vel.set(i, Vec3::new(-d.y, d.x, 0.5) * 2.0);
    }
    let mut grad = vec![Mat3::ZERO; p.len()];
    MlsStencil::build(&p).displacement_gradients(&p.pos, &p.rest, &mut grad);
    (s, p, grad)
}

/// Positions agree to 2e-6 m: both are `s₀ + u` with `|s₀| ≈ 2.5 m` (f32 ulp 2.4e-7 m),
/// and the table regroups `u` as `Σ w c_i + g (s₀ − o)`, so a few ulp of round-off of
/// terms up to the object size times `|∇u|` separate them. Normals (unit) and velocities
/// (≈ 1 m/s) agree to 1e-6: the same weighted sums in the same order.
/// Two samplings: one surfel count not a multiple of the eight-surfel lane groups (a
/// partial last group), and one of several parallel chunks of surfels.
#[test]
fn fast_advection_matches_reference() {
    let counts: Vec<usize> = [0.01, 0.004].map(compare_with_reference).into();
    assert!(
        counts.iter().any(|n| n % 8 != 0),
        "a partial lane group ({counts:?})"
    );
    assert!(
        counts.iter().any(|&n| n > 4096),
        "more than one chunk ({counts:?})"
    );
}

/// [`fast_advection_matches_reference`] at one surfel spacing; returns the surfel count.
fn compare_with_reference(surfel_spacing: f32) -> usize {
    let (s, p, grad) = deformed_ball(surfel_spacing);
    let spread = grad
        .iter()
        .map(|g| {
            (*g - grad[0])
                .abs()
                .to_cols_array()
                .iter()
                .fold(0.0f32, |a, v| a.max(*v))
        })
        .fold(0.0, f32::max);
    assert!(spread > 1e-2, "gradients vary over the object ({spread})");
    let mut binding = SurfelBinding::build(&s, &p);
    let (mut fast, mut reference) = (s.clone(), s.clone());
    // Twice, so the second step runs on the kept table and reads advected normals.
    for _ in 0..2 {
        binding.advect(&mut fast, &p, &grad);
        phyxel::testing::advect_reference(&binding, &mut reference, &p, &grad);
    }
    let (mut dp, mut dn, mut dv, mut moved) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for i in 0..s.len() {
        dp = dp.max((fast.pos.get(i) - reference.pos.get(i)).length());
        dn = dn.max((fast.normal.get(i) - reference.normal.get(i)).length());
        dv = dv.max((fast.vel.get(i) - reference.vel.get(i)).length());
        moved = moved.max((reference.pos.get(i) - s.rest.get(i)).length());
    }
    assert!(moved > 0.1, "the deformation moves surfels ({moved} m)");
    assert!(dp < 2e-6, "position difference {dp:e} m");
    assert!(dn < 1e-6, "normal difference {dn:e}");
    assert!(dv < 1e-6, "velocity difference {dv:e} m/s");
    eprintln!(
        "{} surfels: max differences: position {dp:e} m, normal {dn:e}, velocity {dv:e} m/s",
        s.len()
    );
    assert!(fast.all_finite());
    s.len()
}
