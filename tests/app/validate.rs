//! The quick validation suite (`phyxel validate --quick`) through the library: every
//! case within its tolerance, the error falling from the coarsest to the finest
//! resolution where it is resolution-driven, every hard case stable or refused; the
//! quick suite's wall time (budget: two minutes in release) is printed, not asserted.

use phyxel::app::validate::{self, CASES, Row};
use std::time::Instant;

/// The failing rows as a table (empty when none fails).
fn failures(rows: &[Row]) -> Vec<Row> {
    rows.iter().filter(|r| !r.pass).cloned().collect()
}

/// One test for the whole quick suite, so its wall time is measured end to end.
///
/// Resolution-driven cases (the `true` entries of [`CASES`]): the cantilever's deflection
/// and frequency (quadrature and clamp errors, O(spacing)), the incline's creep (∝ dt) and
/// the free body's energy departure (symplectic Euler, falls with dt). The others are
/// not: MLS consistency is exact up to f32 round-off, the Hertz approach includes the
/// bulk compression of body-loaded spheres, momentum is conserved to round-off at
/// every resolution, the free body's initial energy is one state against its closed
/// form, and the cradle hands on momentum at every resolution. The
/// `dt-above-bound` case must be refused with the `--dt` remedy and, forced with
/// `--allow-unstable`, go non-finite (its note says so; docs/ACCURACY.md).
#[test]
fn quick_suite_within_tolerance_and_converging() {
    let t0 = Instant::now();
    let mut rows = validate::run_accuracy(&[], true, None, |l| eprintln!("validate: {l}"));
    rows.extend(validate::run_stability(&[], true, None, |l| {
        eprintln!("validate: {l}")
    }));
    let took = t0.elapsed().as_secs_f64();
    print!("{}", validate::table(&rows));
    println!("quick suite: {took:.1} s");

    for (case, _, _) in CASES {
        assert!(
            rows.iter().any(|r| r.case == *case),
            "case {case} produced no row"
        );
    }
    for case in validate::STABILITY_CASES {
        assert!(
            rows.iter().any(|r| r.case == *case),
            "stability case {case} produced no row"
        );
    }
    let failed = failures(&rows);
    assert!(
        failed.is_empty(),
        "rows failed:\n{}",
        validate::table(&failed)
    );

    let conv = validate::convergence(&rows);
    assert!(!conv.is_empty());
    for (case, backend, first, last) in &conv {
        println!("{case} ({backend}): {first:.3e} -> {last:.3e}");
        assert!(
            last < first,
            "{case} ({backend}): error does not fall from the coarsest ({first:.3e}) to the finest ({last:.3e}) resolution"
        );
    }
    let refused = rows
        .iter()
        .find(|r| r.group == "stability" && r.status == "refused" && r.note.contains("--dt"))
        .expect("dt above the bound must be refused with the remedy");
    // docs/ACCURACY.md: forced with --allow-unstable, the refused run blows up (goes
    // non-finite, or first leaves the range where f32 resolves its surfels).
    assert!(
        refused.note.contains("[forced with --allow-unstable: ")
            && (refused.note.contains("non-finite") || refused.note.contains("blew up")),
        "{}: the forced run did not go non-finite: {}",
        refused.case,
        refused.note
    );
    // The two-minute budget is reported, not asserted: wall times on a shared machine
    // are noise (docs/ACCURACY.md records the measured time).
    println!("quick suite took {took:.1} s (budget 120 s)");
}

/// `uniaxial_stress`, the squeeze case's reference, against two closed forms: without
/// the volume term the law is Saint-Venant–Kirchhoff, whose uniaxial nominal stress is
/// `E λ(λ² − 1)/2` exactly (1e-6 relative: the Lamé constants are f32); with it, the small-strain slope is the Young's
/// modulus of Lamé λ + k_v and μ, `μ(3λ′ + 2μ)/(λ′ + μ)` (a central difference at
/// ±1e-5, 1e-4 relative).
#[test]
fn uniaxial_stress_matches_closed_forms() {
    use phyxel::material::Material;
    let svk = Material {
        volume_stiffness: 0.0,
        ..Material::default()
    };
    for stretch in [0.9, 0.96, 1.0, 1.05] {
        let want = svk.young as f64 * stretch * (stretch * stretch - 1.0) / 2.0;
        let got = validate::uniaxial_stress(&svk, stretch);
        assert!(
            (got - want).abs() <= 1e-6 * svk.young as f64,
            "stretch {stretch}: {got} vs {want}"
        );
    }
    let m = Material::default();
    let (lambda, mu) = m.lame();
    let (l, mu) = ((lambda + m.k_volume()) as f64, mu as f64);
    let young = mu * (3.0 * l + 2.0 * mu) / (l + mu);
    let h = 1e-5;
    let slope = (validate::uniaxial_stress(&m, 1.0 + h) - validate::uniaxial_stress(&m, 1.0 - h))
        / (2.0 * h);
    assert!(
        (slope / young - 1.0).abs() < 1e-4,
        "small-strain slope {slope} vs {young}"
    );
    assert!(
        young > m.young as f64 * 1.01,
        "the volume term stiffens: {young}"
    );
}
