//! Speed-against-error charts of the accuracy rows (feature `plots`).

use super::*;

/// Registers a system sans-serif TTF with plotters' text renderer (once); false when
/// none is found.
#[cfg(feature = "plots")]
fn register_font() -> bool {
    use std::sync::OnceLock;
    static FOUND: OnceLock<bool> = OnceLock::new();
    *FOUND.get_or_init(|| {
        let candidates = [
            "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/TTF/DejaVuSans.ttf",
            "/usr/share/fonts/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
            "/Library/Fonts/Arial.ttf",
            "C:\\Windows\\Fonts\\arial.ttf",
        ];
        for c in candidates {
            if let Ok(bytes) = std::fs::read(c) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font(
                    "sans-serif",
                    plotters::style::FontStyle::Normal,
                    bytes,
                )
                .is_ok()
                {
                    return true;
                }
            }
        }
        false
    })
}

/// [`plot`] in a build without the `plots` feature: writes nothing, returns an error.
#[cfg(not(feature = "plots"))]
pub fn plot(_rows: &[Row], dir: &std::path::Path) -> Result<Vec<String>, String> {
    Err(format!(
        "{}: no charts: phyxel was built without the `plots` feature (enable it in Cargo.toml)",
        dir.display()
    ))
}

/// One chart per case of the accuracy rows: seconds per step (x, log) against relative
/// error (y, log), one series per backend, the tolerance as a dashed line; written as
/// `DIR/CASE.svg` and `DIR/CASE.png`. Returns notes (e.g. no font found: SVG only).
/// In a build without the `plots` feature it writes nothing and returns an error.
#[cfg(feature = "plots")]
pub fn plot(rows: &[Row], dir: &std::path::Path) -> Result<Vec<String>, String> {
    let font = register_font();
    let mut notes = Vec::new();
    if !font {
        notes.push("no system TTF font found (DejaVuSans.ttf): charts written as SVG only".into());
    }
    let mut cases: Vec<&str> = Vec::new();
    for r in rows.iter().filter(|r| r.group == "accuracy") {
        if !cases.contains(&r.case.as_str()) {
            cases.push(&r.case);
        }
    }
    for case in cases {
        let sel: Vec<&Row> = rows
            .iter()
            .filter(|r| r.case == case && r.seconds_per_step > 0.0 && r.rel_error.is_finite())
            .collect();
        if sel.is_empty() {
            continue;
        }
        let svg = dir.join(format!("{case}.svg"));
        chart(
            plotters::prelude::SVGBackend::new(&svg, (800, 560)),
            case,
            &sel,
        )
        .map_err(|e| format!("{}: {e}", svg.display()))?;
        if font {
            let png = dir.join(format!("{case}.png"));
            chart(
                plotters::prelude::BitMapBackend::new(&png, (800, 560)),
                case,
                &sel,
            )
            .map_err(|e| format!("{}: {e}", png.display()))?;
        }
        notes.push(format!(
            "wrote {}",
            svg.with_extension("{svg,png}").display()
        ));
    }
    Ok(notes)
}

#[cfg(feature = "plots")]
fn chart<DB: plotters::prelude::DrawingBackend>(
    backend: DB,
    case: &str,
    rows: &[&Row],
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let floor = 1e-9;
    let ys = rows
        .iter()
        .map(|r| r.rel_error.max(floor))
        .chain(rows.iter().map(|r| r.tolerance.max(floor)));
    let (ymin, ymax) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    let xs = rows.iter().map(|r| r.seconds_per_step);
    let (xmin, xmax) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    let root = backend.into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let mut c = ChartBuilder::on(&root)
        .caption(format!("{case}: speed against error"), ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(
            (xmin / 1.5..xmax * 1.5).log_scale(),
            (ymin / 3.0..ymax * 3.0).log_scale(),
        )
        .map_err(e)?;
    c.configure_mesh()
        .x_desc("wall seconds per step")
        .y_desc("relative error")
        .x_label_formatter(&|x| format!("{x:.0e}"))
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(e)?;
    let tol = rows[0].tolerance.max(floor);
    c.draw_series(DashedLineSeries::new(
        [(xmin / 1.5, tol), (xmax * 1.5, tol)],
        6,
        4,
        RED.stroke_width(1),
    ))
    .map_err(e)?
    .label(format!("tolerance {}", rows[0].tolerance))
    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    let mut series: Vec<String> = rows.iter().map(|r| r.series()).collect();
    series.sort_unstable();
    series.dedup();
    for (k, b) in series.iter().enumerate() {
        let color = [BLUE, GREEN, MAGENTA, CYAN, BLACK][k % 5].to_rgba();
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.series() == *b)
            .map(|r| (r.seconds_per_step, r.rel_error.max(floor)))
            .collect();
        c.draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
            .map_err(e)?
            .label(b.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        c.draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
            .map_err(e)?;
    }
    c.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(e)?;
    root.present().map_err(e)?;
    Ok(())
}
