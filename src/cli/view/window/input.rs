//! Keys, mouse and the scene file: what the user does, turned into commands for the
//! simulation thread and changes of the view.

use super::super::sim::Command;
use super::{Source, Viewer};
use eframe::egui;
use glam::Vec3;
use phyxel::scene::Scene;
use std::time::{Duration, Instant};

impl Viewer {
    /// Keys: the same in live view and replay where they make sense.
    pub(super) fn keys(&mut self, ctx: &egui::Context) {
        let pressed = |k| ctx.input(|i| i.key_pressed(k));
        let live = matches!(self.source, Source::Live { .. });
        if pressed(egui::Key::Space) {
            match &mut self.source {
                Source::Replay(r) => r.playing = !r.playing,
                Source::Live { .. } => self.send(Command::TogglePause),
            }
        }
        if pressed(egui::Key::H) {
            self.help = !self.help;
        }
        if pressed(egui::Key::Home) {
            (self.yaw, self.pitch, self.zoom, self.pan) = (0.0, 0.0, 1.0, Vec3::ZERO);
        }
        if !live {
            return;
        }
        if pressed(egui::Key::Period) {
            self.send(Command::Step);
        }
        if pressed(egui::Key::R) {
            self.tool_depth = None;
            self.send(Command::Rebuild(None));
            self.notify("rebuilt");
        }
        if pressed(egui::Key::B) {
            let now = self.snap.backend.clone();
            let k = self
                .backends
                .iter()
                .position(|b| *b == now)
                .map_or(0, |k| k + 1);
            let next = self.backends[k % self.backends.len()].to_string();
            self.tool_depth = None;
            self.notify(format!("backend {next}: rebuilt"));
            self.send(Command::Rebuild(Some(next)));
        }
        if pressed(egui::Key::G) {
            self.send(Command::Gravity(!self.snap.gravity));
        }
        if pressed(egui::Key::OpenBracket) || pressed(egui::Key::CloseBracket) {
            let up = pressed(egui::Key::CloseBracket);
            self.speed = match (self.snap.speed, up) {
                (s, _) if s <= 0.0 => 1.0,
                (s, true) if s >= 1.0 => 0.0,
                (s, true) => s * 2.0,
                (s, false) => (s / 2.0).max(1.0 / 64.0),
            };
            self.send(Command::Speed(self.speed));
        }
        if pressed(egui::Key::P) {
            self.send(Command::ShowPhyxels(!self.snap.phyxels));
        }
        if pressed(egui::Key::C) {
            self.send(Command::Pressure(!self.snap.pressure));
        }
        if pressed(egui::Key::F) {
            self.send(Command::Arrows(!self.snap.arrows_on));
        }
        if pressed(egui::Key::N) {
            self.send(Command::Drop(None));
        }
        if pressed(egui::Key::T) {
            self.tool_depth = match self.tool_depth {
                Some(_) => {
                    self.send(Command::Tool(None));
                    None
                }
                // In front of the scene's centre by half its size: not inside a body.
                None => {
                    let depth = self.base.map(|b| {
                        let size = self.scene_size();
                        ((Vec3::from(b.position) - Vec3::from(b.target)).length() * self.zoom
                            - 0.6 * size)
                            .max(0.1 * size)
                    });
                    if depth.is_none() {
                        self.notify("no tool before the first picture");
                    }
                    depth
                }
            };
        }
    }

    /// Mouse on the image: orbit (drag), pan (right or shift drag), zoom (wheel), grab
    /// (ctrl drag or middle drag), and the tool following the pointer (wheel: deeper).
    pub(super) fn mouse(&mut self, ctx: &egui::Context, response: &egui::Response) {
        let (modifiers, scroll, pointer) =
            ctx.input(|i| (i.modifiers, i.smooth_scroll_delta.y, i.pointer.hover_pos()));
        let d = response.drag_delta();
        let grab_button = response.dragged_by(egui::PointerButton::Middle)
            || (response.dragged_by(egui::PointerButton::Primary) && modifiers.ctrl);
        if grab_button {
            if let Some((eye, dir)) = pointer.and_then(|p| self.ray_at(p)) {
                let c = if self.grabbing {
                    Command::DragTo(eye, dir)
                } else {
                    Command::Grab(eye, dir)
                };
                self.grabbing = true;
                self.send(c);
            }
        } else {
            if self.grabbing {
                self.grabbing = false;
                self.send(Command::Release);
            }
            let pan = response.dragged_by(egui::PointerButton::Secondary)
                || (response.dragged_by(egui::PointerButton::Primary) && modifiers.shift);
            if pan {
                if let Some(cam) = self.camera() {
                    let (_, _, right, up) = cam.basis();
                    let per_px = 2.0 * self.scene_size() * self.zoom / self.size.1.max(1) as f32;
                    self.pan += per_px * (-d.x * right + d.y * up);
                }
            } else if response.dragged_by(egui::PointerButton::Primary) {
                self.yaw -= 0.01 * d.x;
                self.pitch = (self.pitch - 0.01 * d.y).clamp(-1.4, 1.4);
            }
        }
        let size = self.scene_size();
        match &mut self.tool_depth {
            Some(depth) => {
                if response.hovered() {
                    *depth = (*depth - 0.0005 * scroll * size).max(1e-3);
                }
                let depth = *depth;
                if let (Some(p), Some(cam)) = (pointer, self.camera())
                    && let Some((eye, dir)) = self.ray_at(p)
                {
                    let fwd = cam.basis().1;
                    let at = eye + dir * (depth / dir.dot(fwd).max(1e-3));
                    let moved =
                        ctx.input(|i| i.pointer.delta() != egui::Vec2::ZERO) || scroll != 0.0;
                    if (response.hovered() && moved) || self.snap.tool.is_none() {
                        self.send(Command::Tool(Some(at)));
                        // Timed only while stepping: a paused simulation answers nothing.
                        if !self.snap.paused {
                            self.inputs += 1;
                            self.input_sent.push_back((self.inputs, Instant::now()));
                            self.send(Command::Input(self.inputs));
                        }
                    }
                }
            }
            None => {
                if response.hovered() {
                    self.zoom = (self.zoom * (-0.002 * scroll).exp()).clamp(0.05, 20.0);
                }
            }
        }
    }

    /// Polls the scene file and sends the scene again when it changed.
    pub(super) fn watch_file(&mut self) {
        if self.last_file_check.elapsed() < Duration::from_millis(500) {
            return;
        }
        self.last_file_check = Instant::now();
        let Source::Live {
            file: Some((path, seen)),
            commands,
            ..
        } = &mut self.source
        else {
            return;
        };
        let now = std::fs::metadata(&*path).and_then(|m| m.modified()).ok();
        if now == *seen {
            return;
        }
        *seen = now;
        let text = match Scene::load(path) {
            Ok(scene) => {
                let _ = commands.send(Command::Reload(Box::new(scene)));
                // The rebuilt world has no tool.
                self.tool_depth = None;
                format!("{}: changed, reloaded", path.display())
            }
            Err(e) => format!("not reloaded: {e}"),
        };
        self.notify(text);
    }
}
