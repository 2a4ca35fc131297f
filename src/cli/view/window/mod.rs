//! The window of `phyxel view`: draws the latest snapshot (or a replayed frame) with the
//! software splat renderer into a texture, overlays the contact forces and the grab
//! spring, shows the heads-up display (figures, phase bar, live plots) and turns mouse
//! and keys into commands for the simulation thread.

mod hud;
mod input;

use super::replay::Replay;
use super::sim::{Command, Shared, Snapshot};
use eframe::egui;
use glam::{Quat, Vec3};
use phyxel::app::render::{Camera, Image, RenderOptions, camera_for, render};
use phyxel::io::frame::Frame;
use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime};

/// How often the window looks for a new snapshot (as often as the simulation publishes
/// one: a pass without a new state would cost a whole frame of software OpenGL for
/// nothing). Input repaints at once.
const FRAME_INTERVAL: Duration = super::sim::PUBLISH_EVERY;

/// How often the window looks for the picture of an input it sent.
const INPUT_POLL: Duration = Duration::from_millis(4);

/// Heights (points) of the heads-up panel above the image and the key line below.
const HUD_HEIGHT: f32 = 56.0;
const HELP_HEIGHT: f32 = 22.0;

/// Most pixels the software splat renderer draws per frame (the texture is scaled up to
/// the window by OpenGL): a 1280 × 720 window is drawn at 853 × 480, in a third of
/// the time, leaving the cores to the simulation.
const MAX_RENDER_PIXELS: u32 = 409_600;

/// Points kept in each live plot (at one per snapshot, about 15 s).
const PLOT_POINTS: usize = 500;

/// Where the pictures come from.
pub(crate) enum Source {
    Live {
        shared: Arc<Shared>,
        commands: Sender<Command>,
        /// The scene file (watched for changes) and its modification time.
        file: Option<(PathBuf, Option<SystemTime>)>,
    },
    Replay(Replay),
}

/// What the window was asked for besides the source.
pub(crate) struct WindowOptions {
    pub screenshot: Option<PathBuf>,
    /// `--after`: the step (live) or frame (replay) of the screenshot.
    pub after: u64,
    /// Close after this many wall seconds (measurements).
    pub seconds: Option<f64>,
    /// Print a JSON line with the state and the figures when closing.
    pub report: bool,
    /// Image pixels per window pixel; `None`: automatic.
    pub render_scale: Option<f32>,
}

/// The window's outcome: `Err` with a message for the user.
pub(crate) type Exit = Arc<Mutex<Option<Result<(), String>>>>;

/// The window.
pub(crate) struct Viewer {
    source: Source,
    opts: WindowOptions,
    exit: Exit,
    texture: Option<egui::TextureHandle>,
    /// The camera fitted to the first frame, turned by `yaw`, `pitch`, scaled by `zoom`
    /// and moved by `pan`.
    base: Option<Camera>,
    yaw: f32,
    pitch: f32,
    zoom: f32,
    pan: Vec3,
    /// The state and view last drawn, and the image size.
    drawn: Option<(u64, [f32; 6], bool)>,
    size: (u32, u32),
    /// Tool mode: the tool follows the mouse at this view depth (m).
    tool_depth: Option<f32>,
    grabbing: bool,
    speed: f64,
    backends: Vec<&'static str>,
    notice: Option<(String, Instant)>,
    energy: VecDeque<f64>,
    penetration: VecDeque<f64>,
    last_plotted: u64,
    shot_taken: Arc<Mutex<Option<Arc<egui::ColorImage>>>>,
    shot_requested: bool,
    opened: Instant,
    frames: u64,
    last_file_check: Instant,
    /// The latest snapshot (the window's copy).
    snap: Snapshot,
    /// Image rectangle in the window (points) of the last frame.
    image_rect: Option<egui::Rect>,
    /// Replay: moved to the screenshot's frame after fitting the camera.
    jumped: bool,
    /// The key list shown (`h`).
    help: bool,
    /// The first frame drawn: the camera is fitted to it.
    first: Option<Frame>,
    /// The simulation's first frame the camera was fitted to (a new one: refit).
    fitted_to: Option<Arc<Frame>>,
    /// Image pixels per window pixel (`--render-scale`); `None`: within MAX_RENDER_PIXELS.
    render_scale: Option<f32>,
    /// Tool inputs sent (numbered) and not yet on screen, and the input-to-screen
    /// latencies measured (s).
    inputs: u64,
    input_sent: VecDeque<(u64, Instant)>,
    latencies: Vec<f64>,
}

impl Viewer {
    pub(crate) fn new(source: Source, opts: WindowOptions, speed: f64, exit: Exit) -> Self {
        let render_scale = opts.render_scale;
        Self {
            source,
            opts,
            exit,
            texture: None,
            base: None,
            yaw: 0.0,
            pitch: 0.0,
            zoom: 1.0,
            pan: Vec3::ZERO,
            drawn: None,
            size: (0, 0),
            tool_depth: None,
            grabbing: false,
            speed,
            backends: phyxel::backends::NAMES.to_vec(),
            notice: None,
            energy: VecDeque::new(),
            penetration: VecDeque::new(),
            last_plotted: u64::MAX,
            shot_taken: Arc::new(Mutex::new(None)),
            shot_requested: false,
            opened: Instant::now(),
            frames: 0,
            last_file_check: Instant::now(),
            snap: Snapshot::default(),
            image_rect: None,
            jumped: false,
            help: false,
            first: None,
            fitted_to: None,
            render_scale,
            inputs: 0,
            input_sent: VecDeque::new(),
            latencies: Vec::new(),
        }
    }

    /// The fitted camera turned, zoomed and panned by the mouse.
    fn camera(&self) -> Option<Camera> {
        let base = self.base?;
        let target = Vec3::from(base.target);
        let offset = Vec3::from(base.position) - target;
        let turn = Quat::from_rotation_y(self.yaw) * Quat::from_rotation_x(self.pitch);
        Some(Camera {
            position: (target + self.pan + self.zoom * (turn * offset)).to_array(),
            target: (target + self.pan).to_array(),
            ..base
        })
    }

    fn send(&self, c: Command) {
        if let Source::Live { commands, .. } = &self.source {
            let _ = commands.send(c);
        }
    }

    fn notify(&mut self, text: impl Into<String>) {
        self.notice = Some((text.into(), Instant::now()));
    }

    /// The ray through a window point, if it lies on the image.
    fn ray_at(&self, pos: egui::Pos2) -> Option<(Vec3, Vec3)> {
        let rect = self.image_rect?;
        let cam = self.camera()?;
        let (w, h) = self.size;
        let x = (pos.x - rect.min.x) / rect.width() * w as f32;
        let y = (pos.y - rect.min.y) / rect.height() * h as f32;
        Some(cam.ray(x, y, w, h))
    }

    /// The scene's size (m): the fitted camera's distance to its target.
    fn scene_size(&self) -> f32 {
        self.base.map_or(1.0, |b| {
            (Vec3::from(b.position) - Vec3::from(b.target)).length() * 0.5
        })
    }

    /// The latest state: a copy of the simulation's snapshot, or the replay's frame.
    fn refresh(&mut self) {
        match &mut self.source {
            Source::Live { shared, .. } => {
                let s = shared.snapshot.lock().expect("snapshot lock");
                if s.version != self.snap.version {
                    self.snap = s.clone();
                    drop(s);
                    if let Some(n) = self.snap.notice.take() {
                        self.notify(n);
                    }
                    // A rebuilt or reloaded scene: the camera is fitted to it again.
                    if let (Some(new), Some(old)) = (&self.snap.first, &self.fitted_to)
                        && !Arc::ptr_eq(new, old)
                    {
                        (self.base, self.first) = (None, None);
                    }
                }
            }
            Source::Replay(r) => {
                // The camera is fitted to the first frame, as in the live view; then the
                // screenshot's frame is shown.
                if self.base.is_some() && !self.jumped {
                    self.jumped = true;
                    if self.opts.screenshot.is_some() {
                        r.index = self.opts.after.min(r.len() - 1);
                    }
                }
                r.advance();
                if (self.snap.steps != r.index || self.snap.frame.is_empty())
                    && let Some((frame, index)) = r.current()
                {
                    self.snap.frame = Arc::new(frame.clone());
                    self.snap.steps = index;
                }
                self.snap.done = self.snap.steps >= self.opts.after.min(r.len() - 1);
                self.snap.error = r.error.clone();
            }
        }
        if self.snap.steps != self.last_plotted {
            self.last_plotted = self.snap.steps;
            for (series, v) in [
                (&mut self.energy, self.snap.energy),
                (&mut self.penetration, 1e3 * self.snap.penetration as f64),
            ] {
                series.push_back(v);
                if series.len() > PLOT_POINTS {
                    series.pop_front();
                }
            }
        }
    }

    /// Draws the frame into the texture when the state or the view changed.
    fn draw(&mut self, ctx: &egui::Context, w: u32, h: u32) {
        let view = [
            self.yaw, self.pitch, self.zoom, self.pan.x, self.pan.y, self.pan.z,
        ];
        let key = (self.snap.steps, view, self.snap.pressure);
        let resized = (w, h) != self.size;
        if self.drawn == Some(key) && !resized && self.texture.is_some() {
            return;
        }
        let frame: &Frame = &self.snap.frame;
        if frame.is_empty() {
            return;
        }
        self.drawn = Some(key);
        self.size = (w, h);
        // Fitted to the first frame, again at each new image size (the first frames of
        // a window are laid out before the panels have their sizes).
        if self.first.is_none() {
            self.fitted_to = self.snap.first.clone();
        }
        let first = self
            .first
            .get_or_insert_with(|| self.snap.first.as_deref().unwrap_or(frame).clone());
        if self.base.is_none() || resized {
            let fit = RenderOptions {
                width: w,
                height: h,
                ..RenderOptions::default()
            };
            // The scene's camera, as `run --png` uses it; else one fitted to the first frame.
            let fit = RenderOptions {
                camera: self.snap.camera,
                ..fit
            };
            self.base = Some(camera_for(first, &fit));
        }
        let opts = RenderOptions {
            width: w,
            height: h,
            camera: self.camera(),
            supersample: 1,
            contact_levels: self.snap.pressure,
            ..RenderOptions::default()
        };
        let image: Image = render(frame, &opts);
        let color = egui::ColorImage::from_rgb([w as usize, h as usize], &image.rgb);
        match &mut self.texture {
            Some(t) => t.set(color, egui::TextureOptions::LINEAR),
            None => {
                self.texture =
                    Some(ctx.load_texture("surfels", color, egui::TextureOptions::LINEAR))
            }
        }
        // Inputs whose step this picture shows: on screen at the end of this pass.
        while let Some(&(n, sent)) = self.input_sent.front() {
            if n > self.snap.input {
                break;
            }
            self.latencies.push(sent.elapsed().as_secs_f64());
            self.input_sent.pop_front();
        }
    }

    /// Force arrows, the grab spring and the tool's outline over the image.
    fn overlay(&self, painter: &egui::Painter, rect: egui::Rect) {
        let Some(cam) = self.camera() else { return };
        let (w, h) = self.size;
        let to_screen = |p: Vec3| {
            cam.project(p, w, h).map(|(x, y, _)| {
                egui::pos2(
                    rect.min.x + x / w as f32 * rect.width(),
                    rect.min.y + y / h as f32 * rect.height(),
                )
            })
        };
        if !self.snap.arrows.is_empty() {
            let top = self
                .snap
                .arrows
                .iter()
                .map(|a| a.1.length())
                .fold(0.0f32, f32::max);
            let length = 0.15 * self.scene_size();
            for &(at, f) in &self.snap.arrows {
                if top <= 0.0 {
                    break;
                }
                // The force on the patch's second body (the first gets the opposite).
                let tip = at - f * (length / top);
                if let (Some(a), Some(b)) = (to_screen(at), to_screen(tip)) {
                    painter.arrow(a, b - a, egui::Stroke::new(2.0, egui::Color32::BLACK));
                }
            }
        }
        if let Some((from, to)) = self.snap.grab
            && let (Some(a), Some(b)) = (to_screen(from), to_screen(to))
        {
            painter.line_segment([a, b], egui::Stroke::new(2.0, egui::Color32::DARK_GREEN));
            painter.circle_filled(b, 4.0, egui::Color32::DARK_GREEN);
        }
    }

    /// Saves the window once the wanted state is drawn, then closes.
    fn screenshot(&mut self, ctx: &egui::Context) {
        let Some(path) = self.opts.screenshot.clone() else {
            return;
        };
        if self.snap.done
            && self.drawn.is_some_and(|d| d.0 == self.snap.steps)
            && !self.shot_requested
        {
            self.shot_requested = true;
            let slot = self.shot_taken.clone();
            ctx.request_screenshot(move |img| *slot.lock().expect("shot lock") = Some(img));
        }
        let Some(img) = self.shot_taken.lock().expect("shot lock").take() else {
            return;
        };
        let rgb: Vec<u8> = img
            .pixels
            .iter()
            .flat_map(|p| [p.r(), p.g(), p.b()])
            .collect();
        let out = Image {
            width: img.width() as u32,
            height: img.height() as u32,
            rgb,
        };
        let result = out
            .write_png(&path)
            .map_err(|e| format!("--screenshot {}: {e}", path.display()));
        self.close(ctx, result);
    }

    /// Prints the report (if asked) and closes the window.
    fn close(&mut self, ctx: &egui::Context, result: Result<(), String>) {
        *self.exit.lock().expect("exit lock") = Some(result);
        if let Source::Live { shared, .. } = &self.source {
            shared.quit.store(true, Ordering::Relaxed);
        }
        ctx.send_viewport_cmd(egui::ViewportCommand::Close);
    }
}

impl eframe::App for Viewer {
    /// `--json`: one line however the window closes (a screenshot, `--seconds`, the
    /// user), unless it closes on an error.
    fn on_exit(&mut self, _gl: Option<&eframe::glow::Context>) {
        let failed = matches!(*self.exit.lock().expect("exit lock"), Some(Err(_)));
        if self.opts.report && !failed {
            println!("{}", self.report());
        }
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.frames += 1;
        if let Some(limit) = self.opts.seconds
            && self.opened.elapsed().as_secs_f64() >= limit
        {
            self.opts.seconds = None;
            self.close(&ctx, Ok(()));
            return;
        }
        self.refresh();
        // A live error ends the session; a replay's (a frame that cannot be read) is
        // shown, and ends only a headless screenshot run.
        if let Some(e) = self.snap.error.clone()
            && (matches!(self.source, Source::Live { .. }) || self.opts.screenshot.is_some())
        {
            self.close(&ctx, Err(e));
            return;
        }
        self.keys(&ctx);
        self.watch_file();
        let line = self.hud_line();
        // Fixed heights and one-line labels: the image has the same size live and in a
        // replay, so a replay draws the same picture.
        egui::Panel::top("hud")
            .exact_size(HUD_HEIGHT)
            .resizable(false)
            .show(ui, |ui| {
                ui.add(egui::Label::new(line).truncate());
                match &mut self.source {
                    Source::Live { .. } => self.hud_charts(ui),
                    Source::Replay(r) => {
                        let last = r.len().saturating_sub(1);
                        ui.add(egui::Slider::new(&mut r.index, 0..=last).text("frame"));
                    }
                }
            });
        egui::Panel::bottom("help")
            .exact_size(HELP_HEIGHT)
            .resizable(false)
            .show(ui, |ui| {
                let notice = self
                    .notice
                    .as_ref()
                    .filter(|n| n.1.elapsed() < Duration::from_secs(4))
                    .map(|n| format!("   — {}", n.0))
                    .unwrap_or_default();
                let help = if self.help {
                    match self.source {
                        Source::Live { .. } => {
                            "space pause · . step · r reset · b backend · g gravity · [ ] speed · \
                         t tool (wheel: push) · ctrl-drag grab/throw · n drop · p phyxels · \
                         c pressure · f forces · drag orbit · right-drag pan · wheel zoom · \
                         home view · h hide"
                        }
                        Source::Replay(_) => {
                            "space play/pause · slider: frame · drag orbit · right-drag pan · \
                         wheel zoom · home view · h hide"
                        }
                    }
                } else {
                    "h: keys"
                };
                ui.add(egui::Label::new(format!("{help}{notice}")).truncate());
            });
        egui::CentralPanel::default().show(ui, |ui| {
            let avail = ui.available_size();
            let (w, h) = (avail.x.max(16.0) as u32, avail.y.max(16.0) as u32);
            // The splats are drawn on the CPU: at most MAX_RENDER_PIXELS, scaled up by GL.
            let scale = self
                .render_scale
                .unwrap_or_else(|| (MAX_RENDER_PIXELS as f32 / (w * h) as f32).sqrt().min(1.0));
            let (rw, rh) = (
                ((w as f32 * scale).round() as u32).max(16),
                ((h as f32 * scale).round() as u32).max(16),
            );
            self.draw(&ctx, rw, rh);
            if let Some(t) = &self.texture {
                let response = ui.add(
                    egui::Image::new((t.id(), egui::vec2(w as f32, h as f32)))
                        .sense(egui::Sense::click_and_drag()),
                );
                self.image_rect = Some(response.rect);
                self.overlay(ui.painter(), response.rect);
                self.mouse(&ctx, &response);
            }
        });
        self.screenshot(&ctx);
        // While input waits for its picture, look again soon.
        ctx.request_repaint_after(if self.input_sent.is_empty() {
            FRAME_INTERVAL
        } else {
            INPUT_POLL
        });
    }
}
