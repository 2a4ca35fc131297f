//! The simulation thread of `phyxel view`: it steps the world, applies the window's and
//! the event script's commands between steps, paces the run to the chosen speed and
//! publishes snapshots. The window never waits for a step, and a step never waits for
//! the window.

use super::bodies::{
    GRAB_DAMPING, GRAB_OMEGA, Grab, add_body, bounds, drop_point, pick, remove_body,
};
use super::script::Script;
use glam::Vec3;
use phyxel::World;
use phyxel::dynamics::kinematic::Kinematic;
use phyxel::io::frame::Frame;
use phyxel::scene::{BuildOptions, Scene};
use phyxel::world::output::surface_frame;
use phyxel::world::{Phase, PhaseTimes};
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What the window (or the event script) asks of the simulation.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Command {
    TogglePause,
    /// One step while paused.
    Step,
    /// Build the scene afresh (with this backend, if given).
    Rebuild(Option<String>),
    /// Replace the scene (the file changed on disk) and build it.
    Reload(Box<Scene>),
    Gravity(bool),
    /// Simulated seconds per wall second at most; 0: as fast as the machine steps.
    Speed(f64),
    /// Show the tool sphere and send it towards this point; `None` removes it.
    Tool(Option<Vec3>),
    /// Grab the body under the ray (eye, unit direction) with a spring.
    Grab(Vec3, Vec3),
    /// Move the grab spring's end to the grab depth along this ray.
    DragTo(Vec3, Vec3),
    /// Let go (the body keeps its velocity: a throw).
    Release,
    /// Drop a new sphere here (`None`: above the scene's centre).
    Drop(Option<Vec3>),
    /// Draw the phyxels instead of the surface.
    ShowPhyxels(bool),
    /// Colour the contact surface by pressure.
    Pressure(bool),
    /// Publish each contact patch's total force (drawn as arrows).
    Arrows(bool),
    /// The window's input number `n` was sent before this: the snapshot after the next
    /// step says so (`Snapshot::input`), which times input to screen.
    Input(u64),
}

/// The latest state the simulation published.
#[derive(Clone, Default)]
pub(crate) struct Snapshot {
    /// Shared: the window copies a snapshot without copying its points.
    pub frame: Arc<Frame>,
    pub steps: u64,
    pub time: f64,
    pub dt: f32,
    pub steps_per_second: f64,
    /// Deepest penetration over the run and in the last step (m).
    pub max_penetration: f32,
    pub penetration: f32,
    /// Kinetic + elastic + potential + contact energy (J).
    pub energy: f64,
    /// Share of the step time per phase since the last snapshot ([`Phase::ALL`] order).
    pub phase_share: [f64; 10],
    /// Per contact patch: centroid (m) and total force on its first body (N).
    pub arrows: Vec<(Vec3, Vec3)>,
    /// The tool's centre (m), radius (m) and reaction (N).
    pub tool: Option<(Vec3, f32, Vec3)>,
    /// The grab spring: the grabbed point and where it is pulled (m).
    pub grab: Option<(Vec3, Vec3)>,
    /// Per object: name, centre of mass, surfel bounds (m).
    pub objects: Vec<(String, Vec3, Vec3, Vec3)>,
    pub paused: bool,
    pub gravity: bool,
    /// The display toggles the simulation keeps (phyxels, pressure, force arrows).
    pub phyxels: bool,
    pub pressure: bool,
    pub arrows_on: bool,
    pub speed: f64,
    pub backend: String,
    pub error: Option<String>,
    /// True once the run reached `stop_at` (or a non-finite state, or a scripted pause).
    pub done: bool,
    /// The state went non-finite: where (the run stops there).
    pub non_finite: Option<String>,
    /// A message for the user (a failed rebuild, a body that could not be added).
    pub notice: Option<String>,
    /// The last window input (`Command::Input`) followed by a step.
    pub input: u64,
    /// Counts the snapshots published: the window copies only a new one.
    pub version: u64,
    /// The render surface right after the build: the window fits its camera to it,
    /// whenever it starts drawing.
    pub first: Option<Arc<Frame>>,
    /// The scene's `[camera]`, which the window starts from when given.
    pub camera: Option<phyxel::app::render::Camera>,
}

/// Between the threads.
pub(crate) struct Shared {
    pub snapshot: Mutex<Snapshot>,
    pub quit: std::sync::atomic::AtomicBool,
    /// Stop after this many steps (`--after`); `u64::MAX`: run on.
    pub stop_at: u64,
}

/// How often the simulation publishes a snapshot while running.
pub(crate) const PUBLISH_EVERY: Duration = Duration::from_millis(30);

/// The simulation's state besides the world.
struct Sim {
    scene: Scene,
    build: BuildOptions,
    paused: bool,
    gravity: Vec3,
    gravity_on: bool,
    speed: f64,
    tool: Option<u32>,
    grab: Option<Grab>,
    show_phyxels: bool,
    pressure: bool,
    arrows: bool,
    drops: u32,
    /// Wall time and simulated time the pace counts from.
    pace_from: Option<(Instant, f64)>,
    script: Script,
    published: std::cell::Cell<u64>,
    first: Option<Arc<Frame>>,
    /// A message for the next snapshot.
    notice: Option<String>,
    /// The last input received, and the last one followed by a step.
    input_received: u64,
    input_stepped: u64,
}

/// Builds the world and steps it until asked to quit, publishing snapshots.
pub(crate) fn simulate(
    scene: Scene,
    build: BuildOptions,
    speed: f64,
    script: Script,
    commands: Receiver<Command>,
    shared: Arc<Shared>,
    threads: usize,
) {
    let mut sim = Sim {
        scene,
        build,
        paused: false,
        gravity: Vec3::ZERO,
        gravity_on: true,
        speed,
        tool: None,
        grab: None,
        show_phyxels: false,
        pressure: false,
        arrows: false,
        drops: 0,
        pace_from: None,
        script,
        published: std::cell::Cell::new(0),
        first: None,
        notice: None,
        input_received: 0,
        input_stepped: 0,
    };
    // The simulation's own pool, one thread short of the cores: the window (and the
    // software rasteriser) keeps a core, so a worker is not preempted in the middle of a
    // fork-join (on 2 cores, a 2-thread pool beside the window stepped no faster than
    // this 1-thread one, docs/PERFORMANCE.md). Stepping inside the pool also keeps the
    // parallel loops off rayon's cold path from an outside thread.
    let report = shared.clone();
    let run = std::panic::AssertUnwindSafe(move || {
        match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
            Ok(pool) => pool.install(move || sim.run(&commands, &shared)),
            Err(_) => rayon::scope(move |_| sim.run(&commands, &shared)),
        }
    });
    // A panic in the engine must reach the window (which then closes with its message),
    // not leave it drawing a frozen picture.
    if let Err(panic) = std::panic::catch_unwind(run) {
        let what = panic
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "unknown panic".into());
        let mut s = report.snapshot.lock().unwrap_or_else(|p| p.into_inner());
        s.error = Some(format!("the simulation stopped: {what}"));
        s.version += 1;
    }
}

impl Sim {
    /// The stepping loop: builds the world (again on a rebuild) and steps it until asked
    /// to quit.
    fn run(&mut self, commands: &Receiver<Command>, shared: &Shared) {
        let sim = self;
        let quit = || shared.quit.load(std::sync::atomic::Ordering::Relaxed);
        let mut last_good: Option<(Scene, BuildOptions)> = None;
        'build: loop {
            let mut world = match sim.scene.build(&sim.build) {
                Ok(w) => {
                    last_good = Some((sim.scene.clone(), sim.build.clone()));
                    if let Some(hint) = phyxel::app::hint::backend_hint(&w) {
                        eprintln!("note: {hint}");
                    }
                    w
                }
                // A reloaded file or another backend that does not build: say so and go
                // on with what ran before.
                Err(e) if last_good.is_some() => {
                    (sim.scene, sim.build) = last_good.take().expect("checked");
                    sim.notice = Some(format!("not rebuilt: {e}"));
                    continue 'build;
                }
                Err(e) => {
                    let mut s = shared.snapshot.lock().expect("snapshot lock");
                    s.error = Some(e.to_string());
                    s.version += 1;
                    return;
                }
            };
            world.render_contacts = true;
            sim.gravity = world.gravity;
            if !sim.gravity_on {
                world.gravity = Vec3::ZERO;
            }
            (sim.tool, sim.grab, sim.pace_from, sim.drops) = (None, None, None, 0);
            sim.script.rewind();
            let mut times = world.record.times.clone();
            sim.first = None;
            sim.publish(&world, 0.0, &mut times, shared);
            let (mut last, mut counted, mut since) = (Instant::now(), 0u64, Instant::now());
            let mut rate = 0.0;
            while !quit() {
                let mut single = false;
                while let Ok(c) = commands.try_recv() {
                    match c {
                        Command::Rebuild(backend) => {
                            if backend.is_some() {
                                sim.build.backend = backend;
                            }
                            continue 'build;
                        }
                        Command::Reload(scene) => {
                            sim.scene = *scene;
                            continue 'build;
                        }
                        Command::Step => single = true,
                        c => sim.apply(c, &mut world),
                    }
                }
                for c in sim.script.due(world.steps) {
                    sim.apply(c, &mut world);
                }
                // Paused by the script: a screenshot run ends here rather than waiting
                // for ever. The events left are due at later steps, which a pause never
                // reaches (a resume scheduled for step 3 after a pause at step 0 hung).
                let stuck = sim.paused && shared.stop_at != u64::MAX;
                let done = world.steps >= shared.stop_at || world.non_finite.is_some() || stuck;
                if (sim.paused && !single) || done {
                    sim.pace_from = None;
                    if last.elapsed() >= PUBLISH_EVERY {
                        sim.publish(&world, rate, &mut times, shared);
                        last = Instant::now();
                    }
                    std::thread::sleep(Duration::from_millis(5));
                    continue;
                }
                if let Some(wait) = sim.ahead(world.time) {
                    std::thread::sleep(wait);
                    continue;
                }
                sim.pull(&mut world);
                world.step();
                // New input is published at once: the user waits for it.
                let answered = sim.input_stepped != sim.input_received;
                sim.input_stepped = sim.input_received;
                counted += 1;
                let window = since.elapsed().as_secs_f64();
                rate = counted as f64 / window.max(1e-9);
                if window >= 0.5 {
                    (counted, since) = (0, Instant::now());
                }
                let last_step = world.steps >= shared.stop_at || world.non_finite.is_some();
                if last.elapsed() >= PUBLISH_EVERY || single || last_step || answered {
                    sim.publish(&world, rate, &mut times, shared);
                    last = Instant::now();
                }
            }
            return;
        }
    }

    /// Applies one command between steps.
    fn apply(&mut self, c: Command, world: &mut World) {
        match c {
            Command::TogglePause => {
                self.paused = !self.paused;
                self.pace_from = None;
            }
            Command::Gravity(on) => {
                self.gravity_on = on;
                world.gravity = if on { self.gravity } else { Vec3::ZERO };
            }
            Command::Speed(s) => {
                self.speed = s.max(0.0);
                self.pace_from = None;
            }
            Command::Tool(Some(p)) => match self.tool {
                Some(id) => {
                    if let Some(k) = world
                        .object_mut(id)
                        .and_then(|o| o.dynamics_mut::<Kinematic>())
                    {
                        k.target = Some(p);
                    }
                }
                None => match add_body(world, p, "tool", true) {
                    Ok(id) => self.tool = Some(id),
                    Err(e) => self.notice = Some(format!("no tool: {e}")),
                },
            },
            Command::Tool(None) => {
                if let Some(id) = self.tool.take() {
                    remove_body(world, id);
                }
            }
            Command::Grab(eye, dir) => self.grab = pick(world, eye, dir),
            Command::DragTo(eye, dir) => {
                if let Some(g) = &mut self.grab {
                    g.target = eye + g.depth * dir;
                }
            }
            Command::Release => self.grab = None,
            Command::Drop(at) => {
                let at = at.unwrap_or_else(|| drop_point(world, self.drops));
                self.drops += 1;
                if let Err(e) = add_body(world, at, &format!("drop{}", self.drops), false) {
                    self.notice = Some(format!("no sphere dropped: {e}"));
                }
            }
            Command::Input(n) => self.input_received = n,
            Command::ShowPhyxels(on) => self.show_phyxels = on,
            Command::Pressure(on) => self.pressure = on,
            Command::Arrows(on) => self.arrows = on,
            Command::Step | Command::Rebuild(_) | Command::Reload(_) => {}
        }
    }

    /// How long to wait before the next step so that simulated time runs at `speed` ×
    /// wall time; `None`: step now. A run slower than that steps flat out, and the pace
    /// counts afresh after a stall (no burst of catching up).
    fn ahead(&mut self, time: f64) -> Option<Duration> {
        if self.speed <= 0.0 {
            return None;
        }
        let (wall, sim) = *self.pace_from.get_or_insert((Instant::now(), time));
        let due = sim + self.speed * wall.elapsed().as_secs_f64();
        if time > due {
            let wait = (time - due) / self.speed;
            return Some(Duration::from_secs_f64(wait.min(0.005)));
        }
        if due - time > 0.1 * self.speed {
            self.pace_from = Some((Instant::now(), time));
        }
        None
    }

    /// Adds the grab spring's force to the grabbed phyxels: `k (target − x̄) − c v̄` on
    /// the body's whole mass, spread over the grabbed phyxels by mass.
    fn pull(&mut self, world: &mut World) {
        let dt = world.dt;
        let Some(g) = &self.grab else { return };
        let Some(o) = world.object_mut(g.object) else {
            self.grab = None;
            return;
        };
        let p = &mut o.phyxels;
        let Some((mass, x, v)) = g.mean(p) else {
            self.grab = None;
            return;
        };
        // The spring pulls the whole body at GRAB_OMEGA, but acts on the grabbed phyxels
        // alone: its damping, integrated explicitly on their mass, is stable only while
        // c dt < m (a 3,000-phyxel ball went NaN in 7 steps with the whole mass).
        let body = (p.total_mass() as f32).min(0.5 * mass / (GRAB_DAMPING * GRAB_OMEGA * dt));
        let k = body * GRAB_OMEGA * GRAB_OMEGA;
        let c = 2.0 * GRAB_DAMPING * body * GRAB_OMEGA;
        let f = k * (g.target - x) - c * v;
        for &i in &g.phyxels {
            let share = p.mass[i] / mass;
            p.force.add(i, f * share);
        }
    }

    /// Publishes the world's state for the window.
    fn publish(&mut self, world: &World, rate: f64, times: &mut PhaseTimes, shared: &Shared) {
        let mut frame = if self.show_phyxels {
            phyxel_frame(world)
        } else {
            surface_frame(world)
        };
        if self.pressure {
            pressure_levels(world, &mut frame);
        }
        let now = &world.record.times;
        let spent: Vec<f64> = Phase::ALL
            .iter()
            .map(|&p| now.seconds(p) - times.seconds(p))
            .collect();
        let total: f64 = spent.iter().sum();
        // Without a step since the last snapshot, the last shares stay.
        let mut phase_share = shared.snapshot.lock().expect("snapshot lock").phase_share;
        if total > 0.0 {
            for (s, t) in phase_share.iter_mut().zip(&spent) {
                *s = t / total;
            }
        }
        *times = now.clone();
        let arrows = world
            .patches
            .iter()
            .filter(|p| self.arrows && !p.surfels.is_empty())
            .map(|p| {
                let n = p.surfels.len() as f32;
                let centroid = p.surfels.iter().map(|c| c.pos).sum::<Vec3>() / n;
                // Each contact surfel's force acts on object a.
                let force = p.surfels.iter().map(|c| c.force).sum();
                (centroid, force)
            })
            .collect();
        let tool = self.tool.and_then(|id| world.object(id)).and_then(|o| {
            let k = o.dynamics_as::<Kinematic>()?;
            let r = 0.5 * bounds(o).map_or(0.0, |(lo, hi)| (hi - lo).max_element());
            Some((k.centre(), r, k.reaction()))
        });
        let grab = self.grab.as_ref().and_then(|g| {
            let (_, x, _) = g.mean(&world.object(g.object)?.phyxels)?;
            Some((x, g.target))
        });
        let objects = world
            .objects
            .iter()
            .map(|o| {
                let c = Vec3::from(o.phyxels.centre_of_mass().map(|c| c as f32));
                let (lo, hi) = bounds(o).unwrap_or((c, c));
                (o.name.clone(), c, lo, hi)
            })
            .collect();
        let penetration = world
            .patches
            .iter()
            .flat_map(|p| &p.surfels)
            .map(|c| (c.anchor_a - c.anchor_b).length())
            .fold(0.0f32, f32::max);
        let backend = world
            .objects
            .iter()
            .find(|o| !o.is_static() && Some(o.id) != self.tool)
            .map_or(String::new(), |o| o.dynamics.name().to_string());
        let frame = Arc::new(frame);
        let first = self.first.get_or_insert_with(|| frame.clone()).clone();
        let snapshot = Snapshot {
            frame,
            steps: world.steps,
            time: world.time,
            dt: world.dt,
            steps_per_second: rate,
            max_penetration: world.record.max_penetration,
            penetration,
            // Without the tool's motion, which the user supplies.
            energy: world.energy().total()
                - self
                    .tool
                    .and_then(|id| world.object(id))
                    .map_or(0.0, |o| o.phyxels.kinetic_energy()),
            phase_share,
            arrows,
            tool,
            grab,
            objects,
            paused: self.paused,
            gravity: self.gravity_on,
            phyxels: self.show_phyxels,
            pressure: self.pressure,
            arrows_on: self.arrows,
            speed: self.speed,
            backend,
            error: None,
            done: world.steps >= shared.stop_at
                || world.non_finite.is_some()
                || (self.paused && shared.stop_at != u64::MAX),
            non_finite: world.non_finite.as_ref().map(|e| e.to_string()),
            notice: self.notice.take(),
            input: self.input_stepped,
            version: self.published.get() + 1,
            first: Some(first),
            camera: self.scene.camera,
        };
        self.published.set(snapshot.version);
        *shared.snapshot.lock().expect("snapshot lock") = snapshot;
    }
}

/// The phyxels as a frame: discs of a third of their spacing, facing the camera.
fn phyxel_frame(world: &World) -> Frame {
    let mut frame = Frame::default();
    for o in &world.objects {
        let p = &o.phyxels;
        for i in 0..p.len() {
            frame.push(
                p.pos.get(i),
                Vec3::ZERO,
                0.35 * p.spacing[i],
                o.id as i32,
                0,
            );
        }
    }
    frame
}

/// Sets each contact splat's `contact` flag to a pressure level 1..=255: the pressure
/// (|normal force| / area) of the nearest force carrier of its patch, over the largest
/// pressure in the frame.
fn pressure_levels(world: &World, frame: &mut Frame) {
    let carriers: Vec<(Vec3, f32)> = world
        .patches
        .iter()
        .flat_map(|p| &p.surfels)
        .filter(|c| c.area > 0.0)
        .map(|c| (c.pos, c.force.dot(c.normal).abs() / c.area))
        .collect();
    let top = carriers.iter().map(|c| c.1).fold(0.0f32, f32::max);
    if top <= 0.0 {
        return;
    }
    for i in 0..frame.len() {
        if frame.contact[i] == 0 {
            continue;
        }
        let p = frame.pos[i];
        let nearest = carriers
            .iter()
            .min_by(|a, b| {
                (a.0 - p)
                    .length_squared()
                    .total_cmp(&(b.0 - p).length_squared())
            })
            .map_or(0.0, |c| c.1);
        frame.contact[i] = 1 + (254.0 * (nearest / top).clamp(0.0, 1.0)) as u8;
    }
}

#[cfg(test)]
mod fuzz {
    //! The viewer's event scripts fuzzed, headless: seed scripts mutated (a number
    //! replaced by an extreme, a line deleted, duplicated or swapped, the text cut
    //! short), each parsed and, when accepted, played on a small scene for a few steps.
    //! Every script must be refused with a message or run without a panic of the
    //! simulation thread; a non-finite state must be named. `PHYXEL_FUZZ_CASES` sets
    //! how many mutations (default [`CASES`]).

    use super::*;

    /// Mutations in a default run (about 10 s on two cores).
    const CASES: u64 = 100;
    /// Steps each accepted script is played for.
    const STEPS: u64 = 12;

    const SEEDS: &[&str] = &[
        "[[event]]\nstep = 0\ntool = [0.3, 0.0, 0.0]\n[[event]]\nstep = 3\ntool = [0.12, 0.0, 0.0]\n\
         [[event]]\nstep = 8\nremove_tool = true\n",
        "[[event]]\nstep = 1\ndrop = [0.0, 0.4, 0.0]\n[[event]]\nstep = 2\ndrop = [0.0, -0.4, 0.0]\n\
         [[event]]\nstep = 4\ngravity = false\n",
        "[[event]]\nstep = 0\ngrab = { eye = [-0.15, 0.0, 1.0], at = [-0.15, 0.0, 0.0] }\n\
         [[event]]\nstep = 2\ndrag = { eye = [-0.15, 0.0, 1.0], at = [-0.3, 0.2, 0.0] }\n\
         [[event]]\nstep = 6\nrelease = true\n",
        "[[event]]\nstep = 0\nspeed = 0.0\n[[event]]\nstep = 2\npause = true\n[[event]]\nstep = 3\n\
         pause = true\n[[event]]\nstep = 4\nphyxels = true\n[[event]]\nstep = 5\npressure = true\n\
         [[event]]\nstep = 6\narrows = true\n",
    ];

    const EXTREMES: &[&str] = &[
        "0",
        "-1",
        "1e38",
        "3.4e38",
        "1e-39",
        "nan",
        "inf",
        "-inf",
        "4294967296",
        "-0.0",
        "999999.0",
        "0.1",
        "1e6",
        "-1e6",
    ];

    /// SplitMix64 (a seed reproduces a mutation).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        }
        fn below(&mut self, n: usize) -> usize {
            (self.next() % n.max(1) as u64) as usize
        }
    }

    /// The byte ranges of the numbers in `text`.
    fn numbers(text: &str) -> Vec<(usize, usize)> {
        let b = text.as_bytes();
        let mut out = Vec::new();
        let mut i = 0;
        while i < b.len() {
            if b[i].is_ascii_digit()
                || (b[i] == b'-' && b.get(i + 1).is_some_and(u8::is_ascii_digit))
            {
                let start = i;
                i += 1;
                while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'.' || b[i] == b'-')
                {
                    i += 1;
                }
                out.push((start, i));
            } else {
                i += 1;
            }
        }
        out
    }

    fn mutate(seed: &str, r: &mut Rng) -> String {
        let mut text = seed.to_string();
        for _ in 0..1 + r.below(2) {
            match r.below(10) {
                0..=6 => {
                    let nums = numbers(&text);
                    if !nums.is_empty() {
                        let (a, b) = nums[r.below(nums.len())];
                        text.replace_range(a..b, EXTREMES[r.below(EXTREMES.len())]);
                    }
                }
                7 => {
                    let mut lines: Vec<&str> = text.lines().collect();
                    let (i, j) = (r.below(lines.len()), r.below(lines.len()));
                    lines.swap(i, j);
                    text = lines.join("\n");
                }
                8 => {
                    let mut lines: Vec<String> = text.lines().map(String::from).collect();
                    let i = r.below(lines.len());
                    if r.below(2) == 0 {
                        lines.remove(i);
                    } else {
                        let l = lines[i].clone();
                        lines.insert(i, l);
                    }
                    text = lines.join("\n");
                }
                _ => {
                    let cut = r.below(text.len());
                    let cut = (0..=cut)
                        .rev()
                        .find(|&c| text.is_char_boundary(c))
                        .unwrap_or(0);
                    text.truncate(cut);
                }
            }
        }
        text
    }

    /// Plays `script` on `two-spheres` for [`STEPS`] steps; the final snapshot.
    fn play(script: Script) -> Snapshot {
        let scene = Scene::builtin("two-spheres").expect("built-in");
        let shared = Arc::new(Shared {
            snapshot: Mutex::new(Snapshot::default()),
            quit: std::sync::atomic::AtomicBool::new(false),
            stop_at: STEPS,
        });
        let (_send, receive) = std::sync::mpsc::channel();
        let thread = {
            let shared = shared.clone();
            std::thread::spawn(move || {
                simulate(
                    scene,
                    BuildOptions::default(),
                    0.0,
                    script,
                    receive,
                    shared,
                    1,
                )
            })
        };
        let t0 = Instant::now();
        loop {
            {
                let s = shared.snapshot.lock().expect("snapshot lock");
                if s.done || s.error.is_some() || t0.elapsed() > Duration::from_secs(60) {
                    break;
                }
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        shared
            .quit
            .store(true, std::sync::atomic::Ordering::Relaxed);
        thread.join().expect("the simulation thread returns");
        shared.snapshot.lock().expect("snapshot lock").clone()
    }

    #[test]
    fn mutated_event_scripts_are_refused_or_played_without_a_panic() {
        let cases: u64 = std::env::var("PHYXEL_FUZZ_CASES")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(CASES);
        let (mut refused, mut played) = (0, 0);
        for k in 0..cases {
            let mut r = Rng(0x7669_6577 + k);
            let seed = SEEDS[r.below(SEEDS.len())];
            let text = if k < SEEDS.len() as u64 {
                seed.to_string()
            } else {
                mutate(seed, &mut r)
            };
            match Script::parse(&text) {
                Err(m) => {
                    assert!(!m.trim().is_empty(), "case {k}: empty message for:\n{text}");
                    refused += 1;
                }
                Ok(script) => {
                    let s = play(script);
                    assert!(
                        s.error.is_none(),
                        "case {k}: the simulation stopped: {:?}\nscript:\n{text}",
                        s.error
                    );
                    assert!(s.done, "case {k}: did not reach step {STEPS}:\n{text}");
                    if let Some(nf) = &s.non_finite {
                        assert!(nf.contains("step"), "case {k}: unnamed non-finite: {nf}");
                    }
                    played += 1;
                }
            }
        }
        println!("{cases} scripts: {refused} refused, {played} played");
        assert!(
            played >= cases / 4 && refused >= cases / 10,
            "{refused} refused, {played} played"
        );
    }
}
