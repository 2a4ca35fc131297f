//! The heads-up display (the figures line, the phase bar, the live plots) and the JSON
//! report of `--json`.

use super::{Source, Viewer};
use eframe::egui;
use glam::Vec3;
use phyxel::world::Phase;
use std::collections::VecDeque;

impl Viewer {
    /// The heads-up line.
    pub(super) fn hud_line(&self) -> String {
        let s = &self.snap;
        match &self.source {
            Source::Replay(r) => format!(
                "replay {}   frame {} of {}{}",
                r.dir.display(),
                s.steps,
                r.len().saturating_sub(1),
                if r.playing { "" } else { "   [paused]" }
            ),
            Source::Live { .. } => {
                let speed = if s.speed > 0.0 {
                    format!("speed ≤ {}×", trim(s.speed))
                } else {
                    "speed: flat out".into()
                };
                format!(
                    "{}   step {}   t = {:.4} s   dt = {:.2e} s   {:.0} steps/s   {:.2}× real time   \
                     {speed}   deepest penetration {:.2} mm{}{}{}",
                    s.backend,
                    s.steps,
                    s.time,
                    s.dt,
                    s.steps_per_second,
                    s.steps_per_second * s.dt as f64,
                    1e3 * s.max_penetration,
                    if s.gravity { "" } else { "   [no gravity]" },
                    s.tool
                        .map(|t| format!("   tool feels {:.3} N", t.2.length()))
                        .unwrap_or_default(),
                    if s.paused { "   [paused]" } else { "" },
                )
            }
        }
    }

    /// The phase bar and the two live plots.
    pub(super) fn hud_charts(&self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            let (rect, response) =
                ui.allocate_exact_size(egui::vec2(300.0, 14.0), egui::Sense::hover());
            let painter = ui.painter_at(rect);
            let mut x = rect.min.x;
            let mut tip = String::new();
            for (k, (&share, phase)) in self.snap.phase_share.iter().zip(Phase::ALL).enumerate() {
                let wdt = share as f32 * rect.width();
                let hue = k as f32 / 10.0;
                let colour: egui::Color32 = egui::ecolor::Hsva::new(hue, 0.55, 0.85, 1.0).into();
                painter.rect_filled(
                    egui::Rect::from_min_size(
                        egui::pos2(x, rect.min.y),
                        egui::vec2(wdt, rect.height()),
                    ),
                    0.0,
                    colour,
                );
                x += wdt;
                tip.push_str(&format!("{}: {:.0}%\n", phase.name(), 100.0 * share));
            }
            response.on_hover_text(tip);
            ui.label("phases");
            for (series, name, unit) in [
                (&self.energy, "energy", "J"),
                (&self.penetration, "penetration", "mm"),
            ] {
                plot(ui, series, name, unit);
            }
        });
    }

    /// One JSON line: the run's figures over the window's life and the state shown.
    pub(super) fn report(&self) -> String {
        let seconds = self.opened.elapsed().as_secs_f64();
        let s = &self.snap;
        let v = |p: Vec3| format!("[{}, {}, {}]", p.x, p.y, p.z);
        let objects: Vec<String> = s
            .objects
            .iter()
            .map(|(name, c, lo, hi)| {
                format!(
                    "{{\"name\": {:?}, \"centre\": {}, \"min\": {}, \"max\": {}}}",
                    name,
                    v(*c),
                    v(*lo),
                    v(*hi)
                )
            })
            .collect();
        let tool = s.tool.map_or("null".to_string(), |(c, r, f)| {
            format!(
                "{{\"centre\": {}, \"radius\": {r}, \"reaction\": {}}}",
                v(c),
                v(f)
            )
        });
        let camera = self.camera().map_or("null".to_string(), |c| {
            format!(
                "{{\"position\": {}, \"target\": {}, \"up\": {}, \"fov\": {}}}",
                v(c.position.into()),
                v(c.target.into()),
                v(c.up.into()),
                c.fov
            )
        });
        let image = self.image_rect.map_or("null".to_string(), |r| {
            format!("[{}, {}, {}, {}]", r.min.x, r.min.y, r.width(), r.height())
        });
        let mut lat = self.latencies.clone();
        lat.sort_by(f64::total_cmp);
        let quantile = |q: f64| {
            lat.get(((lat.len() as f64 - 1.0) * q).round() as usize)
                .map_or("null".to_string(), |s| format!("{:.1}", 1e3 * s))
        };
        let latency = format!(
            "{{\"inputs\": {}, \"median_ms\": {}, \"p95_ms\": {}, \"max_ms\": {}}}",
            lat.len(),
            quantile(0.5),
            quantile(0.95),
            quantile(1.0)
        );
        format!(
            "{{\"seconds\": {seconds:.3}, \"tool_latency\": {latency}, \"steps\": {}, \"time\": {}, \"steps_per_second\": {:.1}, \
             \"real_time\": {:.3}, \"frames_per_second\": {:.1}, \"dt\": {}, \"max_penetration\": {}, \"objects\": [{}], \"tool\": {tool}, \
             \"camera\": {camera}, \"image\": {image}}}",
            s.steps,
            s.time,
            s.steps as f64 / seconds,
            s.time / seconds,
            self.frames as f64 / seconds,
            s.dt,
            s.max_penetration,
            objects.join(", ")
        )
    }
}

/// A number without trailing zeros (0.5, 2, 0.015625).
fn trim(x: f64) -> String {
    let s = format!("{x:.6}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// A small line plot of `series` with its name and latest value.
fn plot(ui: &mut egui::Ui, series: &VecDeque<f64>, name: &str, unit: &str) {
    let (rect, _) = ui.allocate_exact_size(egui::vec2(160.0, 28.0), egui::Sense::hover());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 2.0, egui::Color32::from_gray(245));
    let (lo, hi) = series
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    if series.len() >= 2 && lo.is_finite() && hi.is_finite() {
        let span = (hi - lo).max(1e-12);
        let n = (series.len() - 1) as f32;
        let points: Vec<egui::Pos2> = series
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                egui::pos2(
                    rect.min.x + i as f32 / n * rect.width(),
                    rect.max.y - ((v - lo) / span) as f32 * rect.height(),
                )
            })
            .collect();
        painter.add(egui::Shape::line(
            points,
            egui::Stroke::new(1.5, egui::Color32::from_rgb(40, 90, 170)),
        ));
    }
    let last = series.back().copied().unwrap_or(0.0);
    ui.label(format!("{name} {last:.4} {unit}"));
}
