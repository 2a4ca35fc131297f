//! `phyxel view`: the simulation live in a window. The simulation steps in its own
//! thread and publishes snapshots (the render surface and the run's figures); the
//! window draws the latest one with the software splat renderer and never waits for a
//! step. Space pauses, `.` steps once while paused, `r` rebuilds the scene, dragging
//! orbits the camera and the wheel zooms. `--screenshot FILE --after N` runs N steps,
//! draws one frame, saves the window's pixels as PNG and exits (for tests under Xvfb);
//! `--seconds S` closes after S wall seconds and prints steps/s, × real time and frames/s
//! (for measurements).

use eframe::egui;
use glam::Vec3;
use phyxel::app::render::{Camera, Image, RenderOptions, camera_for, render};
use phyxel::io::frame::Frame;
use phyxel::scene::{BuildOptions, Scene};
use phyxel::world::output::surface_frame;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What `phyxel view` was asked for.
pub(crate) struct ViewOptions {
    pub build: BuildOptions,
    pub size: (u32, u32),
    pub screenshot: Option<PathBuf>,
    pub after: u64,
    /// Close after this many wall seconds and print the run's figures (measurements).
    pub seconds: Option<f64>,
}

/// The latest state the simulation thread published.
#[derive(Default)]
struct Snapshot {
    frame: Frame,
    steps: u64,
    time: f64,
    dt: f32,
    steps_per_second: f64,
    max_penetration: f32,
    error: Option<String>,
}

/// Shared between the window and the simulation thread.
struct Shared {
    snapshot: Mutex<Snapshot>,
    paused: AtomicBool,
    single_steps: AtomicU64,
    rebuild: AtomicBool,
    quit: AtomicBool,
    /// Stop after this many steps (`--after`); `u64::MAX`: run on.
    stop_at: u64,
}

/// The display's frame interval.
const FRAME_INTERVAL: Duration = Duration::from_millis(16);

/// How often the simulation publishes a snapshot while running.
const PUBLISH_EVERY: Duration = Duration::from_millis(30);

/// Builds the world and steps it until asked to quit, publishing snapshots.
fn simulate(scene: Scene, build: BuildOptions, shared: Arc<Shared>) {
    let publish = |world: &phyxel::World, rate: f64| {
        let mut s = shared.snapshot.lock().expect("snapshot lock");
        s.frame = surface_frame(world);
        s.steps = world.steps;
        s.time = world.time;
        s.dt = world.dt;
        s.steps_per_second = rate;
        s.max_penetration = world.record.max_penetration;
    };
    loop {
        let mut world = match scene.build(&build) {
            Ok(w) => w,
            Err(e) => {
                shared.snapshot.lock().expect("snapshot lock").error = Some(e.to_string());
                return;
            }
        };
        world.render_contacts = true;
        publish(&world, 0.0);
        // Steps per second over the last half second of stepping (or since the start).
        let (mut last, mut counted, mut since) = (Instant::now(), 0u64, Instant::now());
        let mut rate = 0.0;
        rayon::scope(|_| {
            while !shared.quit.load(Ordering::Relaxed) {
                if shared.rebuild.swap(false, Ordering::Relaxed) {
                    return;
                }
                let single = shared.single_steps.load(Ordering::Relaxed) > 0;
                let run = !shared.paused.load(Ordering::Relaxed) || single;
                if !run || world.steps >= shared.stop_at || world.non_finite.is_some() {
                    std::thread::sleep(Duration::from_millis(5));
                    continue;
                }
                if single {
                    shared.single_steps.fetch_sub(1, Ordering::Relaxed);
                }
                world.step();
                counted += 1;
                let window = since.elapsed().as_secs_f64();
                rate = counted as f64 / window.max(1e-9);
                if window >= 0.5 {
                    (counted, since) = (0, Instant::now());
                }
                let last_step = world.steps >= shared.stop_at || world.non_finite.is_some();
                if last.elapsed() >= PUBLISH_EVERY || single || last_step {
                    publish(&world, rate);
                    last = Instant::now();
                }
            }
        });
        if shared.quit.load(Ordering::Relaxed) {
            return;
        }
        // Asked to rebuild: the loop builds the scene afresh.
    }
}

/// The window.
struct Viewer {
    shared: Arc<Shared>,
    texture: Option<egui::TextureHandle>,
    /// The camera fitted to the first frame; orbited by `yaw`, `pitch`, `zoom`.
    base: Option<Camera>,
    yaw: f32,
    pitch: f32,
    zoom: f32,
    screenshot: Option<PathBuf>,
    shot_taken: Arc<Mutex<Option<Arc<egui::ColorImage>>>>,
    shot_requested: bool,
    exit: Arc<Mutex<Option<Result<(), String>>>>,
    /// The state and view last drawn (step, yaw, pitch, zoom).
    drawn: Option<(u64, f32, f32, f32)>,
    /// When the window opened, frames drawn since, and when to close (`--seconds`).
    opened: Instant,
    frames: u64,
    close_after: Option<f64>,
}

impl Viewer {
    /// The fitted camera turned by the mouse about its target.
    fn camera(&self) -> Option<Camera> {
        let base = self.base?;
        let target = Vec3::from(base.target);
        let offset = Vec3::from(base.position) - target;
        let turn = glam::Quat::from_rotation_y(self.yaw) * glam::Quat::from_rotation_x(self.pitch);
        Some(Camera {
            position: (target + self.zoom * (turn * offset)).to_array(),
            ..base
        })
    }

    fn handle_input(&mut self, ctx: &egui::Context) {
        let shared = &self.shared;
        ctx.input(|i| {
            if i.key_pressed(egui::Key::Space) {
                shared.paused.fetch_xor(true, Ordering::Relaxed);
            }
            if i.key_pressed(egui::Key::Period) {
                shared.single_steps.fetch_add(1, Ordering::Relaxed);
            }
            if i.key_pressed(egui::Key::R) {
                shared.rebuild.store(true, Ordering::Relaxed);
            }
            if i.pointer.primary_down() {
                let d = i.pointer.delta();
                self.yaw -= 0.01 * d.x;
                self.pitch = (self.pitch - 0.01 * d.y).clamp(-1.4, 1.4);
            }
            self.zoom = (self.zoom * (-0.002 * i.smooth_scroll_delta.y).exp()).clamp(0.05, 20.0);
        });
    }
}

impl eframe::App for Viewer {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.frames += 1;
        if let Some(limit) = self.close_after
            && self.opened.elapsed().as_secs_f64() >= limit
        {
            let seconds = self.opened.elapsed().as_secs_f64();
            let s = self.shared.snapshot.lock().expect("snapshot lock");
            // Simulated seconds per wall second over the whole window's life.
            println!(
                "{{\"seconds\": {seconds:.3}, \"steps\": {}, \"steps_per_second\": {:.1}, \
                 \"real_time\": {:.3}, \"frames_per_second\": {:.1}}}",
                s.steps,
                s.steps as f64 / seconds,
                s.time / seconds,
                self.frames as f64 / seconds
            );
            self.close_after = None;
            self.shared.quit.store(true, Ordering::Relaxed);
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
        self.handle_input(&ctx);
        let (frame, line, at, error) = {
            let s = self.shared.snapshot.lock().expect("snapshot lock");
            let paused = self.shared.paused.load(Ordering::Relaxed);
            let line = format!(
                "step {}   t = {:.4} s   dt = {:.2e} s   {:.0} steps/s   {:.2}× real time   \
                 deepest penetration {:.2} mm{}",
                s.steps,
                s.time,
                s.dt,
                s.steps_per_second,
                s.steps_per_second * s.dt as f64,
                1e3 * s.max_penetration,
                if paused { "   [paused]" } else { "" }
            );
            // Only a new state or a new view is drawn again.
            let key = (s.steps, self.yaw, self.pitch, self.zoom);
            let frame = (self.drawn != Some(key)).then(|| s.frame.clone());
            self.drawn = Some(key);
            (frame, line, s.steps, s.error.clone())
        };
        if let Some(e) = error {
            *self.exit.lock().expect("exit lock") = Some(Err(e));
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            return;
        }
        egui::CentralPanel::default().show(ui, |ui| {
            ui.label(line);
            let avail = ui.available_size();
            let (w, h) = (avail.x.max(16.0) as u32, avail.y.max(16.0) as u32);
            if self
                .texture
                .as_ref()
                .is_some_and(|t| t.size() != [w as usize, h as usize])
            {
                // The window changed size: draw the same state again at the new size.
                self.drawn = None;
            }
            if let Some(frame) = frame.filter(|f| !f.is_empty()) {
                if self.base.is_none() {
                    let fit = RenderOptions {
                        width: w,
                        height: h,
                        ..RenderOptions::default()
                    };
                    self.base = Some(camera_for(&frame, &fit));
                }
                let opts = RenderOptions {
                    width: w,
                    height: h,
                    camera: self.camera(),
                    supersample: 1,
                    ..RenderOptions::default()
                };
                let image: Image = render(&frame, &opts);
                let color = egui::ColorImage::from_rgb([w as usize, h as usize], &image.rgb);
                match &mut self.texture {
                    Some(t) => t.set(color, egui::TextureOptions::LINEAR),
                    None => {
                        self.texture =
                            Some(ctx.load_texture("surfels", color, egui::TextureOptions::LINEAR))
                    }
                }
            }
            if let Some(t) = &self.texture {
                ui.image((t.id(), egui::vec2(w as f32, h as f32)));
            }
        });
        if let Some(path) = &self.screenshot {
            let wanted = self.shared.stop_at;
            if at >= wanted && !self.shot_requested {
                self.shot_requested = true;
                let slot = self.shot_taken.clone();
                ctx.request_screenshot(move |img| *slot.lock().expect("shot lock") = Some(img));
            }
            if let Some(img) = self.shot_taken.lock().expect("shot lock").take() {
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
                    .write_png(path)
                    .map_err(|e| format!("--screenshot {}: {e}", path.display()));
                *self.exit.lock().expect("exit lock") = Some(result);
                self.shared.quit.store(true, Ordering::Relaxed);
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            }
        }
        // At most about 60 frames a second: the display shares the cores with the simulation
        // (and, under software OpenGL, with the rasteriser).
        ctx.request_repaint_after(FRAME_INTERVAL);
    }
}

/// Runs `phyxel view`.
pub(crate) fn view(scene: Scene, opts: ViewOptions) -> ExitCode {
    let shared = Arc::new(Shared {
        snapshot: Mutex::new(Snapshot::default()),
        paused: AtomicBool::new(false),
        single_steps: AtomicU64::new(0),
        rebuild: AtomicBool::new(false),
        quit: AtomicBool::new(false),
        stop_at: if opts.screenshot.is_some() {
            opts.after
        } else {
            u64::MAX
        },
    });
    let sim = {
        let (shared, scene, build) = (shared.clone(), scene.clone(), opts.build.clone());
        std::thread::spawn(move || simulate(scene, build, shared))
    };
    let exit = Arc::new(Mutex::new(None));
    let viewer = Viewer {
        shared: shared.clone(),
        texture: None,
        base: None,
        yaw: 0.0,
        pitch: 0.0,
        zoom: 1.0,
        screenshot: opts.screenshot.clone(),
        shot_taken: Arc::new(Mutex::new(None)),
        shot_requested: false,
        exit: exit.clone(),
        drawn: None,
        opened: Instant::now(),
        frames: 0,
        close_after: opts.seconds,
    };
    let (w, h) = opts.size;
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_inner_size([w as f32, h as f32])
            .with_title(format!("phyxel view: {}", scene.name)),
        ..Default::default()
    };
    let ran = eframe::run_native("phyxel", native, Box::new(|_cc| Ok(Box::new(viewer))));
    shared.quit.store(true, Ordering::Relaxed);
    let _ = sim.join();
    if let Err(e) = ran {
        eprintln!("error: phyxel view: cannot open a window: {e} (no display? run under xvfb-run)");
        return ExitCode::FAILURE;
    }
    match exit.lock().expect("exit lock").take() {
        Some(Err(e)) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
        _ => ExitCode::SUCCESS,
    }
}
