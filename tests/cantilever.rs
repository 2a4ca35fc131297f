//! Cantilever under gravity against Euler–Bernoulli beam theory.

use phyxel::app::validate;
use phyxel::scene::Scene;

/// Tip deflection vs Euler–Bernoulli `qL⁴/(8EI)` (an independent analytic reference):
/// within 15% at the default spacing (0.025 m, 4 phyxels through the thickness), and the
/// error shrinking over three resolutions (0.025, 1/60, 0.0125 m). The remaining error
/// is the nodal (midpoint) quadrature through the thickness, the clamp position being
/// defined only to half a spacing, and shear deformation (≈1%), all O(spacing).
#[test]
fn tip_deflection_converges_to_euler_bernoulli() {
    // Euler–Bernoulli `qL⁴/(8EI)` from the scene's bar: L = 0.95 m free length,
    // b = t = 0.1 m, ρ = 1000 kg/m³, E = 1e8 Pa, g = 9.81 m/s².
    let (reference, _) = validate::euler_bernoulli(&Scene::builtin("cantilever").unwrap());
    let mut errors = Vec::new();
    for s in [0.025f32, 1.0 / 60.0, 0.0125] {
        // Time average of the tip over two whole periods (from the 1st maximum on).
        let (d, period, run) = validate::cantilever(s, 2, "mls").unwrap();
        let n = run.phyxels;
        let err = d / reference - 1.0;
        println!(
            "spacing {s:.4} m, {n} phyxels: tip {d:.5e} m vs Euler–Bernoulli {reference:.5e} m \
             ({:+.1}%), first period {period:.4} s",
            100.0 * err
        );
        errors.push(err.abs());
    }
    assert!(
        errors[0] < 0.15,
        "default resolution error {:.1}% > 15%",
        100.0 * errors[0]
    );
    assert!(
        errors[1] < errors[0] && errors[2] < errors[1],
        "error must shrink with resolution: {errors:?}"
    );
}
