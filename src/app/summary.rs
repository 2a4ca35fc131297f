//! The run summary (`phyxel run --json`) and the loop that produces it.

use crate::app::out_dir;
use crate::app::render::{self, RenderOptions};
use crate::io::frame::Format;
use crate::io::usd::{PrimKind, UsdSeries};
use crate::scene::{BuildOptions, Scene, SceneError};
use crate::world::World;
use crate::world::output;
use crate::world::phase::Phase;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Energy gain, as a fraction of the run's energy scale, above which `run` warns
/// ([`RunSummary::energy_warning`]): symplectic Euler's energy error
/// is bounded and small at a stable dt (below 1% in the built-in scenes), a blow-up's
/// gain is orders of magnitude.
pub const ENERGY_GAIN_WARNING: f64 = 0.1;

/// How to run a scene.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    pub build: BuildOptions,
    /// Overrides the scene's step count.
    pub steps: Option<u64>,
    /// Directory for PLY frames; none written without it.
    pub out: Option<PathBuf>,
    /// Also write phyxel frames.
    pub phyxels: bool,
    /// Surfel frames hold each body's own surfels in a fixed order
    /// ([`output::Surface::Fixed`]), not the render surface.
    pub fixed_points: bool,
    /// Also write the objects' output meshes ([`output::MeshFrame`]) each frame.
    pub mesh: bool,
    /// File format of the surfel frames.
    pub format: Format,
    /// Write the frames as one USD stage, [`out_dir::STAGE`] ([`crate::io::usd`]),
    /// instead of files per frame: every object's output mesh (build with
    /// [`BuildOptions::meshes`]; an object without one, such as a fragment, as its
    /// surfels), with `fixed_points` every object's surfels and with `phyxels` its
    /// phyxels.
    pub usd: bool,
    /// Also render each frame to `surfels_NNNNN.png` in `out`, with these options (the
    /// camera: theirs, else the scene's, else fitted to the first frame).
    pub png: Option<RenderOptions>,
    /// Write each step's contact totals to this file, one JSON object per line
    /// ([`ContactLine`]).
    pub contacts: Option<PathBuf>,
    /// Clear another run's frames from `out` instead of refusing the folder
    /// ([`out_dir::prepare`]).
    pub overwrite: bool,
    /// Set (from another thread, a signal handler) to stop the run after the step in
    /// flight and its frame: the summary then says `interrupted`.
    pub interrupt: Option<Arc<AtomicBool>>,
}

/// One line of `run --contacts FILE.jsonl`: a step's contact pairs and their totals.
#[derive(Serialize)]
pub struct ContactLine<'a> {
    pub step: u64,
    /// Simulated time at the end of the step (s).
    pub time: f64,
    pub pairs: Vec<ContactPair<'a>>,
    /// On the step whose state went non-finite (the stream's last line): where
    /// ([`crate::world::NonFinite`]); values that are not numbers are `null`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub non_finite: Option<String>,
}

/// A pair of [`ContactLine`]: the objects' names and the patch's totals
/// ([`crate::contact::PatchTotals`], flattened; here `a` and `b` are the objects' ids,
/// which a fracture does not change, not their indices).
#[derive(Serialize)]
pub struct ContactPair<'a> {
    pub a_name: &'a str,
    pub b_name: &'a str,
    #[serde(flatten)]
    pub totals: crate::contact::PatchTotals,
}

/// `world`'s contact totals ([`World::contact_totals`]) with the objects' ids and names.
pub fn contact_pairs(world: &World) -> Vec<ContactPair<'_>> {
    world
        .contact_totals()
        .into_iter()
        .zip(&world.contact.patches)
        .map(|(totals, patch)| {
            let (a, b) = (&world.objects[patch.a], &world.objects[patch.b]);
            ContactPair {
                a_name: &a.name,
                b_name: &b.name,
                totals,
            }
        })
        .collect()
}

/// Writes `world`'s contact totals as one [`ContactLine`].
fn write_contacts(out: &mut impl std::io::Write, world: &World, step: u64) -> std::io::Result<()> {
    let line = ContactLine {
        step,
        time: world.time,
        pairs: contact_pairs(world),
        non_finite: world.non_finite.as_ref().map(|e| e.to_string()),
    };
    serde_json::to_writer(&mut *out, &line)?;
    out.write_all(b"\n")
}

/// One object at the end of a run.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct BodySummary {
    pub id: u32,
    pub name: String,
    pub backend: String,
    pub phyxels: usize,
    pub surfels: usize,
    /// kg
    pub mass: f64,
    /// Centre of mass (m).
    pub com: [f64; 3],
    /// Velocity of the centre of mass (m/s).
    pub velocity: [f64; 3],
    /// Largest strain norm (dimensionless), where the backend reports it.
    pub max_strain: Option<f32>,
    /// Largest plastic strain norm (dimensionless); `null` where the backend keeps no
    /// plastic state (elastic materials).
    pub max_plastic_strain: Option<f32>,
    /// Elastic energy (J), where the backend reports it.
    pub elastic_energy: Option<f64>,
    /// Iterations and residuals of an implicit backend's solves (absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solver: Option<crate::dynamics::SolverStats>,
    /// The body sleeps at the end of the run (`World::sleep`; absent when awake).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub asleep: bool,
}

/// A body whose implicit solves stopped above their tolerance: a result that is not the
/// backward-Euler step it claims to be must be said, never silently accepted.
fn solver_warning(b: &BodySummary) -> Option<String> {
    let s = b.solver?;
    (s.unconverged > 0).then(|| {
        let nan = match s.non_finite {
            0 => String::new(),
            n => format!("; {n} with a residual that is not a number"),
        };
        format!(
            "object '{}': backend {}: {} of {} steps stopped above the solver tolerance {:e} \
             (largest finite relative residual {:e}{nan}): lower dt (--dt)",
            b.name, b.backend, s.unconverged, s.steps, s.tolerance, s.max_residual
        )
    })
}

/// What `phyxel run --json` prints.
#[derive(Clone, Debug, Serialize)]
pub struct RunSummary {
    pub scene: String,
    /// The backend of the deformable objects ("mixed" when they differ).
    pub backend: String,
    /// The method's configuration (`default` or `paper`, [`crate::scene::Preset`]).
    pub preset: String,
    pub steps: u64,
    /// The run was stopped (Ctrl-C) before its last step; `steps` counts the steps run.
    pub interrupted: bool,
    /// The last step's dt (s): the scene's, unless `dt_changes` lowered it.
    pub dt: f32,
    /// Another built-in backend that would run the scene faster at the same accuracy
    /// ([`super::hint`]; absent when none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub backend_hint: Option<String>,
    /// Simulated time (s): the sum of the steps' dt.
    pub time: f64,
    /// Each lowering of dt after a rest renewal or a fracture made an object stiffer
    /// ([`crate::world::DtChange`]; none with `--allow-unstable`).
    pub dt_changes: Vec<crate::world::DtChange>,
    /// Largest stable dt over the objects (s).
    pub stable_dt: f32,
    pub objects: usize,
    pub surfels: usize,
    pub phyxels: usize,
    pub wall_seconds: f64,
    pub steps_per_second: f64,
    /// Phase name → seconds summed over the run.
    pub phase_seconds: BTreeMap<String, f64>,
    /// Phase name → work items summed over the run (phyxels stepped, pairs found,
    /// surfels gridded, candidates tested, contact surfels placed and forced).
    pub phase_work: BTreeMap<String, u64>,
    /// All state finite at the end, and the sums below (momentum, energies, strains).
    pub finite: bool,
    /// Where the state first became non-finite ([`crate::world::NonFinite`]); the run
    /// stopped at the end of that step, and `steps` counts the steps run. `null` when it
    /// stayed finite.
    pub non_finite: Option<String>,
    /// kg·m/s
    pub momentum_initial: [f64; 3],
    pub momentum_final: [f64; 3],
    /// Mechanical energy of the moving objects at the start and the end (J: kinetic,
    /// elastic, gravitational potential; [`crate::world::World::energy`]).
    pub energy_initial: crate::world::Energy,
    pub energy_final: crate::world::Energy,
    /// Set when the energy grew by more than [`ENERGY_GAIN_WARNING`] of
    /// the run's energy scale in a scene without loads (which alone could add energy):
    /// a numerical failure, often without a NaN. `null` otherwise.
    pub energy_warning: Option<String>,
    /// What the scene's build found suspect but legal ([`RunRecord::warnings`](crate::world::RunRecord::warnings): a body too
    /// coarsely sampled for its mass, a faster-than-sound approach).
    pub warnings: Vec<String>,
    /// Kinetic energy at the end (J).
    pub kinetic_energy: f64,
    /// Largest signed penetration depth of a colliding surfel over the run (m).
    pub max_penetration: f32,
    pub frames_written: u64,
    /// Objects that broke apart over the run (each split counts once, whatever the
    /// number of pieces); `objects` is the final object count.
    pub fractures: usize,
    pub bodies: Vec<BodySummary>,
    /// Each pair that touched over the run, in object-id order
    /// ([`crate::world::PairHistory`]).
    pub contacts: Vec<crate::world::PairHistory>,
}

impl RunSummary {
    /// The backend, with the preset after a slash where it is not the default
    /// (`mls/paper`): one row of `phyxel compare`.
    pub fn series(&self) -> String {
        crate::scene::Preset::series(&self.backend, &self.preset)
    }
}

/// Builds and runs `scene`, calling `progress(step)` after each step.
pub fn run(
    scene: &Scene,
    opts: &RunOptions,
    mut progress: impl FnMut(u64) + Send,
) -> Result<(World, RunSummary), SceneError> {
    let mut world = scene.build(&opts.build)?;
    // Surfels far from contact move only when read: before each frame and at the end.
    world.lazy_advection = true;
    let backend_hint = super::hint::backend_hint(&world);
    // After the build: a scene that fails to build clears nothing.
    if let Some(dir) = &opts.out {
        out_dir::prepare(dir, opts.overwrite)
            .map_err(|e| SceneError(format!("--out {}: {e}", dir.display())))?;
    }
    // The render surface is only resampled when frames are written.
    world.render_contacts = opts.out.is_some();
    let steps = opts.steps.unwrap_or(scene.steps);
    let momentum_initial = world.momentum();
    let mut energy_initial = world.energy();
    let write_frames = opts.out.clone();
    let every = scene.output.every;
    let phyxels = opts.phyxels || scene.output.phyxels;
    let kind = if opts.fixed_points {
        output::Surface::Fixed
    } else {
        output::Surface::Render
    };
    let mut frames = 0;
    let mut png = opts.png.clone();
    if let Some(p) = &mut png {
        p.camera = p.camera.or(scene.camera);
    }
    // Every file written into `out`, and each frame's simulated time, for the manifest.
    let mut written: Vec<String> = Vec::new();
    let mut times: Vec<f64> = Vec::new();
    let mut stage = match (&write_frames, opts.usd) {
        (Some(dir), true) => {
            let per_second = 1.0 / (every as f64 * world.dt as f64);
            Some(
                UsdSeries::create(&dir.join(out_dir::STAGE), per_second)
                    .map_err(|e| SceneError(format!("--out {}: {e}", dir.display())))?,
            )
        }
        _ => None,
    };
    let mut frame = |world: &World, k: u64| -> Result<(), SceneError> {
        if let Some(dir) = &write_frames {
            times.push(world.time);
            let err =
                |e: String| SceneError(format!("writing frame {k} to {}: {e}", dir.display()));
            // The render surface written as this frame's surfels (none into a USD stage).
            let written_surface = match &mut stage {
                Some(stage) => {
                    stage_frame(stage, world, kind, phyxels).map_err(|e| err(e.to_string()))?;
                    None
                }
                None => {
                    let surface =
                        output::write_frame_with(world, dir, k, phyxels, opts.format, kind)
                            .map_err(|e| err(e.to_string()))?;
                    written.extend(output::frame_files(k, phyxels, opts.format));
                    if opts.mesh {
                        let name = output::mesh_file(k, opts.format);
                        output::mesh_frame(world)
                            .write(&dir.join(&name), opts.format)
                            .map_err(|e| err(e.to_string()))?;
                        written.push(name);
                    }
                    Some(surface)
                }
            };
            if let Some(p) = &mut png {
                let surface = written_surface.unwrap_or_else(|| output::surface_frame(world));
                // One camera for the whole run: fitted to the first frame.
                p.camera = Some(render::camera_for(&surface, p));
                let name = format!("surfels_{k:05}.png");
                render::render(&surface, p)
                    .write_png(&dir.join(&name))
                    .map_err(err)?;
                written.push(name);
            }
        }
        Ok(())
    };
    frame(&world, 0)?;
    frames += write_frames.is_some() as u64;
    let contacts_err = |path: &std::path::Path, e: std::io::Error| {
        SceneError(format!("--contacts {}: {e}", path.display()))
    };
    let mut contacts = match &opts.contacts {
        // Streamed (it can be followed during the run): renamed into place at once.
        Some(path) => Some((
            crate::io::atomic::AtomicFile::create(path)
                .and_then(|f| f.into_stream())
                .map_err(|e| contacts_err(path, e))?,
            path,
        )),
        None => None,
    };
    let t0 = Instant::now();
    let mut ran = 0;
    let mut interrupted = false;
    // The loop runs on a pool thread: the steps' parallel loops then push their jobs to
    // local deques instead of rayon's global injector, which allocates one block per 63
    // calls from outside the pool (so the steady-state step allocates nothing).
    rayon::scope(|_| -> Result<(), SceneError> {
        for s in 1..=steps {
            world.step();
            ran = s;
            if s == 1 {
                // Contact energy exists only once a contact phase has run: bodies that
                // start pressed together hold it from the start (one step's motion
                // changes it little), and release it as kinetic energy.
                energy_initial.contact = world.contact_energy();
            }
            // The contacts of every step, the one that went non-finite included: the
            // stream then ends where the run did.
            if let Some((out, path)) = &mut contacts {
                write_contacts(out, &world, s).map_err(|e| contacts_err(path, e))?;
            }
            if world.non_finite.is_some() {
                // Nothing after a blow-up is a result: stop, and say where it began.
                break;
            }
            if s % every == 0 && write_frames.is_some() {
                world.sync_surfels();
                if opts.mesh || opts.usd {
                    world.follow_meshes();
                }
                frame(&world, s / every)?;
                frames += 1;
            }
            progress(s);
            if s < steps
                && opts
                    .interrupt
                    .as_ref()
                    .is_some_and(|f| f.load(Ordering::Relaxed))
            {
                // After the step's frame: every file named in the manifest is whole.
                interrupted = true;
                break;
            }
        }
        Ok(())
    })?;
    world.sync_surfels();
    if opts.mesh || opts.usd {
        world.follow_meshes();
    }
    // The last state, when the steps (or an interrupt) ended between frames; not a
    // state that went non-finite.
    if write_frames.is_some() && !ran.is_multiple_of(every) && world.non_finite.is_none() {
        frame(&world, frames)?;
        frames += 1;
    }
    if let Some((mut out, path)) = contacts {
        std::io::Write::flush(&mut out).map_err(|e| contacts_err(path, e))?;
    }
    if let (Some(stage), Some(dir)) = (stage, &opts.out) {
        stage.finish().map_err(|e| {
            SceneError(format!(
                "writing {} to {}: {e}",
                out_dir::STAGE,
                dir.display()
            ))
        })?;
        written.insert(0, out_dir::STAGE.into());
    }
    let wall = t0.elapsed().as_secs_f64();
    let start = (momentum_initial, energy_initial);
    let mut summary = summarize(&world, scene, ran, wall, start, frames);
    summary.backend_hint = backend_hint;
    summary.interrupted = interrupted;
    if let Some(dir) = &opts.out {
        if opts.format == crate::io::frame::Format::Vtk && !times.is_empty() {
            out_dir::write_collection(dir, &times, phyxels, opts.mesh).map_err(|e| {
                SceneError(format!(
                    "writing {} to {}: {e}",
                    out_dir::COLLECTION,
                    dir.display()
                ))
            })?;
            written.push(out_dir::COLLECTION.into());
        }
        let manifest = out_dir::Manifest {
            scene: &scene.name,
            steps: ran,
            every,
            dt: world.dt,
            interrupted,
            finite: summary.finite,
            format: if opts.usd {
                "usd"
            } else {
                opts.format.extension()
            },
            surfels: match kind {
                output::Surface::Render => "render",
                output::Surface::Fixed => "fixed",
            },
            times: &times,
            frames: &written,
        };
        out_dir::write_manifest(dir, &manifest)
            .map_err(|e| SceneError(format!("writing the manifest to {}: {e}", dir.display())))?;
    }
    Ok((world, summary))
}

/// Adds `world`'s frame to the USD stage: each object's output mesh (a point cloud's
/// points; an object without one, its surfels), and with `kind` [`output::Surface::Fixed`]
/// every object's surfels, with `phyxels` its phyxels (widths: the cube root of their
/// volume).
fn stage_frame(
    stage: &mut UsdSeries,
    world: &World,
    kind: output::Surface,
    phyxels: bool,
) -> std::io::Result<()> {
    stage.begin_frame(world.time);
    for o in &world.objects {
        let s = &o.surfels;
        let surfels = |stage: &mut UsdSeries| {
            let pos: Vec<glam::Vec3> = (0..s.len()).map(|i| s.pos.get(i)).collect();
            let widths: Vec<f32> = s.radius[..s.len()].iter().map(|r| 2.0 * r).collect();
            stage.points(o.id, &o.name, PrimKind::Surfels, &pos, &widths)
        };
        match &o.mesh {
            Some(m) if m.triangles.is_empty() => {
                let pos = m.positions();
                let widths = vec![o.surfel_spacing; pos.len()];
                stage.points(o.id, &o.name, PrimKind::Cloud, &pos, &widths)?;
            }
            Some(m) => stage.mesh(o.id, &o.name, &m.positions(), &m.triangles)?,
            None if kind != output::Surface::Fixed => surfels(stage)?,
            None => {}
        }
        if kind == output::Surface::Fixed {
            surfels(stage)?;
        }
        if phyxels {
            let p = &o.phyxels;
            let pos: Vec<glam::Vec3> = (0..p.len()).map(|i| p.pos.get(i)).collect();
            let widths: Vec<f32> = p.volume[..p.len()].iter().map(|v| v.cbrt()).collect();
            stage.points(o.id, &o.name, PrimKind::Phyxels, &pos, &widths)?;
        }
    }
    Ok(())
}

/// The warning of [`RunSummary::energy_warning`]: the gain `E₁ − E₀` against the scale
/// `max(K₀ + U₀ + C₀, K₁ + U₁ + C₁, |P₁ − P₀|)` (kinetic, elastic, contact,
/// potential).
fn energy_warning(
    world: &World,
    e0: crate::world::Energy,
    e1: crate::world::Energy,
) -> Option<String> {
    if world.objects.iter().any(|o| o.load != glam::Vec3::ZERO) {
        return None;
    }
    // Energy a kinematic body's prescribed motion put in is a load's, not a gain.
    let supplied: f64 = world
        .objects
        .iter()
        .filter_map(|o| o.dynamics_as::<crate::dynamics::kinematic::Kinematic>())
        .map(|k| k.supplied())
        .sum();
    let scale = (e0.kinetic + e0.elastic + e0.contact)
        .max(e1.kinetic + e1.elastic + e1.contact)
        .max((e1.potential - e0.potential).abs())
        .max(supplied.abs());
    let gain = e1.total() - e0.total() - supplied;
    // Rounding: the sums are of f32 states, so a gain within a few hundred f32 epsilons of
    // the energies' magnitudes is not one (at dt = 1e-30 s nothing moves and the scale
    // is ~0, yet rounding leaves a "gain" of 8e-56 J).
    let magnitude = [e0, e1]
        .iter()
        .map(|e| e.kinetic + e.elastic + e.contact + e.potential.abs())
        .sum::<f64>();
    let noise = 256.0 * f32::EPSILON as f64 * magnitude;
    (gain > (ENERGY_GAIN_WARNING * scale).max(noise)).then(|| {
        format!(
            "the energy grew from {:.4e} to {:.4e} J (kinetic {:.4e} → {:.4e} J) with no \
             load to supply it: a numerical failure; try a smaller --dt, a finer spacing or a \
             higher contact_stiffness (docs/SCENES.md, \"Limits\")",
            e0.total(),
            e1.total(),
            e0.kinetic,
            e1.kinetic
        )
    })
}

/// The summary of `world` after `steps` steps that took `wall` seconds.
pub fn summarize(
    world: &World,
    scene: &Scene,
    steps: u64,
    wall: f64,
    (momentum_initial, energy_initial): ([f64; 3], crate::world::Energy),
    frames: u64,
) -> RunSummary {
    let mut backends: Vec<&str> = world
        .objects
        .iter()
        .filter(|o| !o.is_static())
        .map(|o| o.dynamics.name())
        .collect();
    backends.dedup();
    let backend = match backends.as_slice() {
        [] => "static".to_string(),
        [one] => one.to_string(),
        _ => "mixed".to_string(),
    };
    let bodies: Vec<BodySummary> = world
        .objects
        .iter()
        .map(|o| {
            let m = o.phyxels.total_mass();
            let p = o.phyxels.momentum();
            let d = o.dynamics.diagnostics(&o.phyxels, &o.material);
            BodySummary {
                id: o.id,
                name: o.name.clone(),
                backend: o.dynamics.name().to_string(),
                phyxels: o.phyxels.len(),
                surfels: o.surfels.len(),
                mass: m,
                com: o.phyxels.centre_of_mass(),
                velocity: if m > 0.0 { p.map(|c| c / m) } else { [0.0; 3] },
                max_strain: d.max_strain,
                max_plastic_strain: d.max_plastic_strain,
                elastic_energy: d.elastic_energy,
                solver: d.solver,
                asleep: o.is_asleep(),
            }
        })
        .collect();
    let momentum_final = world.momentum();
    let energy_final = world.energy();
    // (Static objects have none: the moving objects' sum is the whole.)
    let kinetic_energy = energy_final.kinetic;
    // Finite state whose sums overflow is no result either.
    let finite = world.non_finite.is_none()
        && world.all_finite()
        && kinetic_energy.is_finite()
        && momentum_final.iter().all(|p| p.is_finite())
        && bodies.iter().all(|b| {
            b.elastic_energy.is_none_or(f64::is_finite) && b.max_strain.is_none_or(f32::is_finite)
        });
    RunSummary {
        scene: scene.name.clone(),
        backend,
        preset: world.preset.name().to_string(),
        steps,
        interrupted: false,
        dt: world.dt,
        backend_hint: None,
        time: world.time,
        dt_changes: world.record.dt_changes.clone(),
        stable_dt: world.stable_dt().0,
        objects: world.objects.len(),
        surfels: world.objects.iter().map(|o| o.surfels.len()).sum(),
        phyxels: world.objects.iter().map(|o| o.phyxels.len()).sum(),
        wall_seconds: wall,
        steps_per_second: if wall > 0.0 { steps as f64 / wall } else { 0.0 },
        phase_seconds: Phase::ALL
            .iter()
            .map(|&p| (p.name().to_string(), world.record.times.seconds(p)))
            .collect(),
        phase_work: Phase::ALL
            .iter()
            .map(|&p| (p.name().to_string(), world.record.times.work(p)))
            .collect(),
        finite,
        non_finite: world.non_finite.as_ref().map(|e| e.to_string()),
        momentum_initial,
        energy_initial,
        energy_final,
        energy_warning: energy_warning(world, energy_initial, energy_final),
        warnings: world
            .record
            .warnings
            .iter()
            .cloned()
            .chain(bodies.iter().filter_map(solver_warning))
            .collect(),
        momentum_final,
        kinetic_energy,
        max_penetration: world.record.max_penetration,
        frames_written: frames,
        fractures: world.record.splits.len(),
        bodies,
        contacts: world.record.contacts.pairs(),
    }
}
