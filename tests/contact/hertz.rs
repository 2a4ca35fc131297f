//! Hertz contact of an elastic sphere pressed onto a rigid plane
//! (`phyxel::validate::hertz_plane`; the references are in that module's docs).

use phyxel::validate::{
    HertzCase, HertzRun, approach_fit, hertz_approach_coefficient, hertz_plane, load_for,
};

fn case(radius: f32, young: f32, poisson: f32, per_radius: f32) -> HertzCase {
    HertzCase {
        radius,
        young,
        poisson,
        per_radius,
        resampled_forces: false,
        contact_stiffness: None,
        refined_per_radius: None,
    }
}

fn finite(r: &HertzRun) -> bool {
    [
        r.contact_force,
        r.radius,
        r.pressure,
        r.profile_rms,
        r.approach,
    ]
    .iter()
    .all(|x| x.is_finite())
}

/// A sphere (8 phyxels across its radius, ν = 0.3) pressed onto a rigid plane by the load
/// that gives Hertz's patch radius 0.15 R, in two cases: R = 0.1 m, E = 1e5 Pa and
/// R = 0.05 m, E = 1e7 Pa (load 4.9 N and 124 N).
///
/// References:
/// - Newton: over the run's last 0.3 s (scaled) the sphere is at rest, so the contact
///   carries the load: the force swings by less than 1% of the load over that window
///   (unsettled, the sphere's bounce swings it ±30%) and its mean is the load within 1%
///   (measured 0.00%).
/// - Similarity of linear elastostatics: with lengths in R, stresses in E and the
///   engine's contact constants dimensionless (penalty stiffness `κE*/h`, surfel spacing
///   `h/5`), both cases must show the same relative patch radius, central pressure and
///   approach over R. Tolerance 2 percentage points, for f32 rounding and the step counts
///   (identical to four digits measured). An absolute constant in the contact pipeline
///   (a length, a speed, a pressure) would break this.
#[test]
fn a_pressed_sphere_carries_its_load_and_scales_with_r_and_e() {
    let cases = [case(0.1, 1.0e5, 0.3, 8.0), case(0.05, 1.0e7, 0.3, 8.0)];
    let runs: Vec<HertzRun> = cases
        .iter()
        .map(|c| hertz_plane(c, load_for(c, 0.15), "mls").unwrap())
        .collect();
    for (c, r) in cases.iter().zip(&runs) {
        println!(
            "R {} E {}: load {:.3} N carried {:.3} N; a {:.5} m (Hertz {:.5}); p0 {:.4e} Pa \
             (Hertz {:.4e}); approach/R {:.5}; profile RMS {:.3} p0",
            c.radius,
            c.young,
            r.load,
            r.contact_force,
            r.radius,
            r.hertz_radius,
            r.pressure,
            r.hertz_pressure,
            r.approach / c.radius as f64,
            r.profile_rms
        );
        assert!(finite(r), "{r:?}");
        assert!(
            r.force_swing < 0.01,
            "not at rest: the contact force swings by {:.1}% of the load",
            100.0 * r.force_swing
        );
        assert!(
            (r.contact_force / r.load - 1.0).abs() < 0.01,
            "force balance: {} N carried of {} N",
            r.contact_force,
            r.load
        );
    }
    let ratios = |(c, r): (&HertzCase, &HertzRun)| {
        [
            r.radius / r.hertz_radius,
            r.pressure / r.hertz_pressure,
            r.approach / c.radius as f64 / (r.hertz_radius / c.radius as f64).powi(2),
        ]
    };
    let a = ratios((&cases[0], &runs[0]));
    let b = ratios((&cases[1], &runs[1]));
    for (k, name) in ["patch radius", "central pressure", "approach"]
        .iter()
        .enumerate()
    {
        assert!(
            (a[k] - b[k]).abs() < 0.02,
            "{name}: {:.4} of Hertz's at R 0.1 m, E 1e5 Pa against {:.4} at R 0.05 m, E 1e7 Pa",
            a[k],
            b[k]
        );
    }
}

/// The study behind docs/ACCURACY.md's Hertz table (19 minutes on two cores):
/// `cargo test --release --test contact hertz:: -- --ignored --nocapture`. Every (R, E, ν) of the
/// issue's matrix at 8, 12 and 16 phyxels per radius (load for a = 0.15 R), then R = 0.1 m,
/// E = 1e5 Pa at 8, 12 and 16 phyxels per radius and ν = 0.25, 0.4 with three loads
/// (a = 0.12, 0.15, 0.19 R) for the approach fit `δ = c F^{2/3} + b F`. Asserts only
/// finite results and force balance within 5%; the errors are what it reports.
#[test]
#[ignore]
fn hertz_study() {
    println!("| R (m) | E (Pa) | ν | per R | load (N) | force | a | p₀ | profile RMS | swing |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let row = |c: &HertzCase, r: &HertzRun| {
        println!(
            "| {} | {:.0e} | {} | {} | {:.4} | {:+.1}% | {:+.1}% | {:+.1}% | {:.3} | {:.1e} |",
            c.radius,
            c.young,
            c.poisson,
            c.per_radius,
            r.load,
            100.0 * (r.contact_force / r.load - 1.0),
            100.0 * (r.radius / r.hertz_radius - 1.0),
            100.0 * (r.pressure / r.hertz_pressure - 1.0),
            r.profile_rms,
            r.force_swing
        );
        assert!(finite(r) && (r.contact_force / r.load - 1.0).abs() < 0.05);
    };
    for per in [8.0, 12.0, 16.0] {
        for radius in [0.05, 0.1, 0.2] {
            for young in [1.0e4, 1.0e5, 1.0e7] {
                for poisson in [0.25, 0.4] {
                    let c = case(radius, young, poisson, per);
                    row(&c, &hertz_plane(&c, load_for(&c, 0.15), "mls").unwrap());
                }
            }
        }
    }
    println!("\n| ν | per R | approach c / Hertz's | b (m/N) |");
    for poisson in [0.25, 0.4] {
        for per in [8.0, 12.0, 16.0] {
            let c = case(0.1, 1.0e5, poisson, per);
            let runs: Vec<HertzRun> = [0.12, 0.15, 0.19]
                .iter()
                .map(|&q| hertz_plane(&c, load_for(&c, q), "mls").unwrap())
                .collect();
            for r in &runs {
                row(&c, r);
            }
            let (coef, b) = approach_fit(&runs);
            println!(
                "| {poisson} | {per} | {:+.1}% | {b:.3e} |",
                100.0 * (coef / hertz_approach_coefficient(&c) - 1.0)
            );
        }
    }
}

/// The paper's configuration on the same case (docs/ACCURACY.md, "The paper's
/// configuration"): `cargo test --release --test contact -- --ignored --nocapture
/// hertz::hertz_paper`. R = 0.1 m, E = 1e5 Pa, ν = 0.3, a = 0.15 R, at 8 and 12
/// phyxels per radius, default and paper side by side. Asserts only finite results and force balance
/// within 5%.
#[test]
#[ignore]
fn hertz_paper_preset() {
    use phyxel::scene::Preset;
    println!("| preset | per R | force | a | p₀ | profile RMS |");
    println!("|---|---|---|---|---|---|");
    for per in [8.0, 12.0] {
        for preset in [Preset::Default, Preset::Paper] {
            let c = case(0.1, 1.0e5, 0.3, per);
            let r = phyxel::validate::with_preset(preset, || {
                hertz_plane(&c, load_for(&c, 0.15), "mls").unwrap()
            });
            println!(
                "| {} | {per} | {:+.1}% | {:+.1}% | {:+.1}% | {:.3} |",
                preset.name(),
                100.0 * (r.contact_force / r.load - 1.0),
                100.0 * (r.radius / r.hertz_radius - 1.0),
                100.0 * (r.pressure / r.hertz_pressure - 1.0),
                r.profile_rms
            );
            assert!(finite(&r) && (r.contact_force / r.load - 1.0).abs() < 0.05);
        }
    }
}

/// Where the patch's error comes from (docs/ACCURACY.md, "Hertz on a rigid plane"):
/// `cargo test --release --test contact -- --ignored --nocapture hertz::hertz_sources` (the
/// longest part of the study). R = 0.1 m, E = 1e5 Pa, load for `a = 0.15 R`:
/// - resolution: ν = 0.25 and 0.4 at 24 phyxels per radius (58,000 phyxels), and
///   ν = 0.25 at 32 (140,000), beside the study's 8, 12 and 16; and the approach fit
///   at 24 (ν = 0.25, three loads);
/// - the penalty layer: `contact_stiffness` κ = 4 (default), 16 and 64 at 8, 12 and 16
///   per radius, ν = 0.25. The spring's overlap under Hertz's pressure is
///   `4h/(πκa)` of Hertz's approach (26% at 8 per radius and κ = 4), a Winkler layer in
///   series with the sphere that flattens the patch (`benches/hertz/winkler.py` gives
///   what that layer alone does to Hertz's contact).
///
/// Asserts only finite results, and force balance within 5% at the default κ; the
/// errors are what it reports.
#[test]
#[ignore]
fn hertz_sources() {
    println!("| ν | per R | κ | force | a | p₀ | profile RMS | swing | steps/s |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let row = |c: &HertzCase| {
        let r = hertz_plane(c, load_for(c, 0.15), "mls").unwrap();
        println!(
            "| {} | {} | {} | {:+.1}% | {:+.1}% | {:+.1}% | {:.3} | {:.1e} | {:.0} |",
            c.poisson,
            c.per_radius,
            c.contact_stiffness
                .unwrap_or(phyxel::material::Material::default().contact_stiffness),
            100.0 * (r.contact_force / r.load - 1.0),
            100.0 * (r.radius / r.hertz_radius - 1.0),
            100.0 * (r.pressure / r.hertz_pressure - 1.0),
            r.profile_rms,
            r.force_swing,
            1.0 / r.info.seconds_per_step
        );
        assert!(finite(&r));
        assert!(c.contact_stiffness.is_some() || (r.contact_force / r.load - 1.0).abs() < 0.05);
    };
    for kappa in [None, Some(16.0), Some(64.0)] {
        for per in [8.0, 12.0, 16.0] {
            row(&HertzCase {
                contact_stiffness: kappa,
                refined_per_radius: None,
                ..case(0.1, 1.0e5, 0.25, per)
            });
        }
    }
    for (poisson, per) in [(0.25, 24.0), (0.4, 24.0), (0.25, 32.0)] {
        row(&case(0.1, 1.0e5, poisson, per));
    }
    // The approach at 24 per radius, as the study's fit at 8 to 16.
    let c = case(0.1, 1.0e5, 0.25, 24.0);
    let runs: Vec<HertzRun> = [0.12, 0.15, 0.19]
        .iter()
        .map(|&q| hertz_plane(&c, load_for(&c, q), "mls").unwrap())
        .collect();
    assert!(runs.iter().all(finite));
    let (coef, b) = approach_fit(&runs);
    println!(
        "\n24 per R, ν 0.25: approach c {:+.1}% of Hertz's, b {b:.3e} m/N; a at 0.12 / 0.15 / \
         0.19 R {:+.1} / {:+.1} / {:+.1}%, p₀ {:+.1} / {:+.1} / {:+.1}%",
        100.0 * (coef / hertz_approach_coefficient(&c) - 1.0),
        100.0 * (runs[0].radius / runs[0].hertz_radius - 1.0),
        100.0 * (runs[1].radius / runs[1].hertz_radius - 1.0),
        100.0 * (runs[2].radius / runs[2].hertz_radius - 1.0),
        100.0 * (runs[0].pressure / runs[0].hertz_pressure - 1.0),
        100.0 * (runs[1].pressure / runs[1].hertz_pressure - 1.0),
        100.0 * (runs[2].pressure / runs[2].hertz_pressure - 1.0),
    );
}

/// Graded sampling against uniform on the same case (docs/ACCURACY.md, "Graded
/// sampling"): `cargo test --release --test contact hertz::hertz_graded -- --ignored
/// --nocapture`. R = 0.1 m, E = 1e5 Pa, ν = 0.3, a = 0.15 R: uniform at 8, 16
/// and 32 phyxels per radius, and 8 and 16 per radius refined to 16 or 32 within 0.4 R
/// of the contact point. Prints phyxels, wall time and the errors against Hertz; asserts
/// finite results, force balance within 1% and a graded run's phyxels under half the
/// uniform run's at its fine spacing.
#[test]
#[ignore]
fn hertz_graded() {
    println!("| sampling | phyxels | dt (s) | wall (s) | force | a | p₀ | profile RMS |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut uniform_counts = Vec::new();
    for (per, fine) in [
        (8.0, None),
        (8.0, Some(16.0)),
        (16.0, None),
        (8.0, Some(32.0)),
        (16.0, Some(32.0)),
        (32.0, None),
    ] {
        let c = HertzCase {
            refined_per_radius: fine,
            ..case(0.1, 1.0e5, 0.3, per)
        };
        let r = hertz_plane(&c, load_for(&c, 0.15), "mls").unwrap();
        let phyxels = r.info.phyxels;
        println!(
            "| {} | {phyxels} | {:.2e} | {:.0} | {:+.2}% | {:+.1}% | {:+.1}% | {:.3} |",
            match fine {
                Some(f) => format!("{per} → {f} per R"),
                None => format!("{per} per R"),
            },
            r.info.dt,
            // The run is 1 s at this case's time scale.
            r.info.seconds_per_step / r.info.dt as f64,
            100.0 * (r.contact_force / r.load - 1.0),
            100.0 * (r.radius / r.hertz_radius - 1.0),
            100.0 * (r.pressure / r.hertz_pressure - 1.0),
            r.profile_rms,
        );
        assert!(finite(&r) && (r.contact_force / r.load - 1.0).abs() < 0.01);
        match fine {
            None => uniform_counts.push((per, phyxels)),
            Some(f) => {
                if let Some(&(_, n)) = uniform_counts.iter().find(|u| u.0 == f) {
                    assert!(phyxels * 2 < n, "{phyxels} graded against {n} uniform");
                }
            }
        }
    }
}

/// A rigid sphere indenting a block to a tenth of its radius (`validate::indent`, E =
/// 1e5 Pa, ν = 0.3, Hertz's force `4/3 E* √R δ^{3/2}` as reference), the block uniform
/// against graded (refined within three contact radii of the first touch):
/// `cargo test --release --test contact hertz::indent_graded -- --ignored --nocapture`.
/// Prints phyxels, wall seconds per simulated second and the force's and patch radius's
/// errors; asserts finite forces and a graded block's phyxels under half the uniform
/// one's at its fine spacing.
#[test]
#[ignore]
fn indent_graded() {
    use phyxel::validate::indent_graded;
    println!("| block, spacings per contact radius | phyxels | dt (s) | wall (s/s) | force | a |");
    println!("|---|---|---|---|---|---|");
    let mut uniform = Vec::new();
    for (per, fine) in [(4.0, None), (2.0, Some(4.0)), (1.0, Some(4.0))] {
        let r = indent_graded(per, fine, "mls", None).unwrap();
        let phyxels = r.run.phyxels;
        println!(
            "| {} | {phyxels} | {:.2e} | {:.0} | {:+.1}% | {:+.1}% |",
            match fine {
                Some(f) => format!("{per} → {f}"),
                None => format!("{per}"),
            },
            r.run.dt,
            r.run.seconds_per_step / r.run.dt as f64,
            100.0 * (r.force / r.hertz - 1.0),
            100.0 * (r.radius / r.hertz_radius - 1.0),
        );
        assert!(r.force.is_finite() && r.force > 0.0);
        match fine {
            None => uniform.push((per, phyxels)),
            Some(f) => {
                if let Some(&(_, n)) = uniform.iter().find(|u| u.0 == f) {
                    assert!(phyxels * 2 < n, "{phyxels} graded against {n} uniform");
                }
            }
        }
    }
}
