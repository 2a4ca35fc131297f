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
                "replay {}   frame {} of {}{}{}",
                r.dir.display(),
                s.steps,
                r.len().saturating_sub(1),
                if r.playing { "" } else { "   [paused]" },
                r.error
                    .as_ref()
                    .map(|e| format!("   cannot read: {e}"))
                    .unwrap_or_default()
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
                ) + &s
                    .non_finite
                    .as_ref()
                    .map(|e| format!("   STOPPED: {e}"))
                    .unwrap_or_default()
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
        use serde_json::json;
        let seconds = self.opened.elapsed().as_secs_f64();
        let s = &self.snap;
        // Non-finite numbers become null (serde_json): the line stays JSON.
        let v = |p: Vec3| json!([p.x, p.y, p.z]);
        let objects: Vec<_> = s
            .objects
            .iter()
            .map(|(name, c, lo, hi)| json!({"name": name, "centre": v(*c), "min": v(*lo), "max": v(*hi)}))
            .collect();
        let tool = s
            .tool
            .map(|(c, r, f)| json!({"centre": v(c), "radius": r, "reaction": v(f)}));
        let camera = self.camera().map(|c| {
            json!({
                "position": v(c.position.into()),
                "target": v(c.target.into()),
                "up": v(c.up.into()),
                "fov": c.fov,
            })
        });
        let image = self
            .image_rect
            .map(|r| json!([r.min.x, r.min.y, r.width(), r.height()]));
        let mut lat = self.latencies.clone();
        lat.sort_by(f64::total_cmp);
        let quantile = |q: f64| {
            lat.get(((lat.len() as f64 - 1.0) * q).round() as usize)
                .map(|s| (1e4 * s).round() / 10.0)
        };
        json!({
            "seconds": seconds,
            "tool_latency": {
                "inputs": lat.len(),
                "median_ms": quantile(0.5),
                "p95_ms": quantile(0.95),
                "max_ms": quantile(1.0),
            },
            "steps": s.steps,
            "time": s.time,
            "steps_per_second": s.steps as f64 / seconds,
            "real_time": s.time / seconds,
            "frames_per_second": self.frames as f64 / seconds,
            "dt": s.dt,
            "max_penetration": s.max_penetration,
            "non_finite": s.non_finite,
            "objects": objects,
            "tool": tool,
            "camera": camera,
            "image": image,
        })
        .to_string()
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
