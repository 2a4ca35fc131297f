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
