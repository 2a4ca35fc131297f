//! The peers' speed against error: `chart OUT.svg RESULTS.jsonl...` draws one panel per
//! case, |error| across and wall seconds per simulated second up (both logarithmic), one
//! colour per engine and method, filled marks for one thread and rings for two. Prints
//! each case's Pareto front (the points no other point beats on both axes).

use plotters::prelude::*;
use serde_json::Value;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (out, inputs) = args
        .split_first()
        .ok_or("usage: chart OUT.svg RESULTS.jsonl...")?;
    let mut rows: Vec<Value> = Vec::new();
    for path in inputs {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
        for line in text.lines().filter(|l| l.starts_with('{')) {
            rows.push(serde_json::from_str(line).map_err(|e| format!("{path}: {e}"))?);
        }
    }
    let f = |r: &Value, k: &str| r[k].as_f64().unwrap_or(f64::NAN);
    let s = |r: &Value, k: &str| r[k].as_str().unwrap_or("").to_string();
    let series = |r: &Value| format!("{} {}", s(r, "engine"), s(r, "method"));
    let mut names: Vec<String> = rows.iter().map(series).collect();
    names.sort();
    names.dedup();
    let cases = ["cantilever", "ball-impact"];
    let root = SVGBackend::new(out, (1200, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((1, 2));
    for (panel, case) in panels.iter().zip(cases) {
        let pts: Vec<&Value> = rows
            .iter()
            .filter(|r| s(r, "case") == case && f(r, "error").is_finite())
            .collect();
        let x = |r: &Value| (100.0 * f(r, "error").abs()).max(0.1);
        let y = |r: &Value| f(r, "wall_per_sim");
        let (x_max, y_min, y_max) = pts.iter().fold((1.0f64, 1e9f64, 1e-3f64), |a, r| {
            (a.0.max(x(r)), a.1.min(y(r)), a.2.max(y(r)))
        });
        let title = match case {
            "cantilever" => "cantilever: tip sag against Euler–Bernoulli",
            _ => "ball on a box: contact time against Hertz",
        };
        let mut chart = ChartBuilder::on(panel)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(
                (0.1f64..x_max * 1.5).log_scale(),
                (y_min / 1.5..y_max * 1.5).log_scale(),
            )?;
        chart
            .configure_mesh()
            .x_desc("|error| (%)")
            .y_desc("wall s per simulated s")
            .draw()?;
        for (k, name) in names.iter().enumerate() {
            let colour = Palette99::pick(k).to_rgba();
            let mine: Vec<&&Value> = pts.iter().filter(|r| &series(r) == name).collect();
            if mine.is_empty() {
                continue;
            }
            chart
                .draw_series(mine.iter().map(|r| {
                    let filled = r["threads"].as_u64() == Some(1);
                    let style = if filled {
                        colour.filled()
                    } else {
                        colour.stroke_width(2)
                    };
                    Circle::new((x(r), y(r)), 5, style)
                }))?
                .label(name.as_str())
                .legend(move |(a, b)| Circle::new((a, b), 5, colour.filled()));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 12))
            .draw()?;
        println!("{case}: the front (fastest for its error; one thread and two)");
        for r in &pts {
            let beaten = pts
                .iter()
                .any(|o| x(o) <= x(r) && y(o) <= y(r) && (x(o) < x(r) || y(o) < y(r)));
            if !beaten {
                println!(
                    "  {:<34} res {:>4} threads {} dt {:.2e}: {:+7.2}% at {:8.3} s/s",
                    series(r),
                    f(r, "resolution"),
                    r["threads"],
                    f(r, "dt"),
                    100.0 * f(r, "error"),
                    y(r)
                );
            }
        }
    }
    root.present()?;
    Ok(())
}
