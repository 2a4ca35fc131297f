//! `phyxel.World` and its bodies: stepping with the GIL released, NumPy arrays of the
//! phyxel and surfel columns, the contact patches, the run summary, frames and pictures;
//! and the module's `run`, `compare` and `validate`.

use super::errors::{error, scene_error};
use super::scene::{PyScene, json_to_py};
use crate::app::render::{RenderOptions, render};
use crate::app::summary::{RunSummary, summarize};
use crate::app::validate as suite;
use crate::body::object::Object;
use crate::columns::Vec3s;
use crate::contact::ContactSurfel;
use crate::io::frame::Format;
use crate::scene::Scene;
use crate::world::{Energy, World, output};
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArray3, PyArrayLike2, PyArrayMethods};
use pyo3::exceptions::{PyIndexError, PyKeyError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard};
use std::time::Instant;

pyo3::create_exception!(
    phyxel,
    NonFiniteError,
    super::errors::Error,
    "The state became non-finite (a NaN or infinity) during a step: the message names the \
     step, the object, its backend and the first bad value. The world stays readable."
);

/// A simulation: the objects of a built scene and the state of the run.
///
/// `step(n)` advances it (the GIL is released while it steps; Ctrl-C is answered between
/// steps). Arrays read from it are copies (read-only); write through the setters of a
/// `Body`, between steps.
#[pyclass(name = "World", module = "phyxel", frozen)]
pub struct PyWorld {
    state: Mutex<State>,
}

/// What a `World` holds. The world is taken out while a step runs (with the GIL
/// released), so the lock is never held across a step and another thread that uses the
/// world meanwhile gets an error, not a deadlock.
struct State {
    world: Option<World>,
    scene: Scene,
    momentum_initial: [f64; 3],
    energy_initial: Energy,
    /// Wall time (s) spent in `step`.
    wall: f64,
    /// Set when a step panicked: the state may be inconsistent, so nothing more runs.
    poisoned: Option<String>,
}

impl State {
    fn world(&self) -> PyResult<&World> {
        self.usable()?;
        self.world.as_ref().ok_or_else(busy)
    }

    fn world_mut(&mut self) -> PyResult<&mut World> {
        self.usable()?;
        self.world.as_mut().ok_or_else(busy)
    }

    fn usable(&self) -> PyResult<()> {
        match &self.poisoned {
            Some(why) => Err(error(format!(
                "this world stopped working after an internal error ({why}); build it again"
            ))),
            None => Ok(()),
        }
    }

    /// The summary of the run so far, as `phyxel run --json` prints it.
    fn run_summary(&self) -> PyResult<RunSummary> {
        let start = (self.momentum_initial, self.energy_initial);
        let w = self.world()?;
        Ok(summarize(w, &self.scene, w.steps, self.wall, start, 0))
    }
}

fn busy() -> PyErr {
    error("the world is being stepped by another thread")
}

/// The index of the object with id `id` in `w`.
fn object_index(w: &World, id: u32) -> PyResult<usize> {
    w.objects.iter().position(|o| o.id == id).ok_or_else(|| {
        error(format!(
            "object id {id} is no longer in the world (it broke into pieces or was removed)"
        ))
    })
}

impl PyWorld {
    pub fn new(world: World, scene: Scene) -> Self {
        Self {
            state: Mutex::new(State {
                momentum_initial: world.momentum(),
                energy_initial: world.energy(),
                world: Some(world),
                scene,
                wall: 0.0,
                poisoned: None,
            }),
        }
    }

    /// The state, locked. A panic while it was held (caught by
    /// [`shield`](super::errors::shield)) leaves the lock poisoned: the state is then
    /// marked unusable, so later calls say why instead of failing on the lock.
    fn lock(&self) -> PyResult<MutexGuard<'_, State>> {
        Ok(self.state.lock().unwrap_or_else(|poisoned| {
            self.state.clear_poison();
            let mut s = poisoned.into_inner();
            s.poisoned
                .get_or_insert_with(|| "a panic while the world was in use".to_string());
            s
        }))
    }

    /// One step with the GIL released; a panic becomes `phyxel.Error` and poisons the
    /// world. With `sync`, every surfel is brought current after it (the world
    /// advects lazily, `World::lazy_advection`: Python reads surfels between calls).
    fn step_once(&self, py: Python<'_>, sync: bool) -> PyResult<()> {
        let mut world = {
            let mut s = self.lock()?;
            s.usable()?;
            s.world.take().ok_or_else(busy)?
        };
        let t0 = Instant::now();
        let result = py.detach(|| {
            // On a pool thread, as `phyxel run` steps: the steps' parallel loops then
            // push their jobs to local deques (no allocation per step).
            catch_unwind(AssertUnwindSafe(|| {
                rayon::scope(|_| {
                    world.step();
                    if sync {
                        world.sync_surfels();
                    }
                })
            }))
        });
        let mut s = self.lock()?;
        s.wall += t0.elapsed().as_secs_f64();
        if let Err(panic) = result {
            let why = super::errors::panic_message(panic.as_ref());
            s.poisoned = Some(why.clone());
            s.world = Some(world);
            return Err(error(why));
        }
        if world.steps == 1 {
            // As `phyxel run`: contact energy exists once a contact phase has run.
            s.energy_initial.contact = world.contact_energy();
        }
        s.world = Some(world);
        Ok(())
    }
}

/// A read-only `(n, 3)` float32 copy of the first `n` rows of `c`.
fn rows3<'py>(py: Python<'py>, c: &Vec3s, n: usize) -> Bound<'py, PyArray2<f32>> {
    read_only(rows_writable(py, c, n))
}

/// A writable `(n, 3)` float32 copy of the first `n` rows of `c`.
pub(super) fn rows_writable<'py>(
    py: Python<'py>,
    c: &Vec3s,
    n: usize,
) -> Bound<'py, PyArray2<f32>> {
    let mut rows = vec![0.0f32; 3 * n];
    for (((r, &x), &y), &z) in rows.chunks_exact_mut(3).zip(&c.x).zip(&c.y).zip(&c.z) {
        r.copy_from_slice(&[x, y, z]);
    }
    PyArray1::from_vec(py, rows)
        .reshape([n, 3])
        .expect("3n values reshape to (n, 3)")
}

/// A read-only float32 copy of `v`.
fn column<'py>(py: Python<'py>, v: &[f32]) -> Bound<'py, PyArray1<f32>> {
    read_only(PyArray1::from_slice(py, v))
}

/// `a` with its writeable flag cleared: an in-place write into a copy would otherwise be
/// lost without a word.
fn read_only<T>(a: Bound<'_, T>) -> Bound<'_, T> {
    // Clearing the flag of an array we own cannot fail; if it did, the copy stays
    // writable, which loses nothing.
    let _ = a.as_any().call_method1("setflags", (false,));
    a
}

/// `a` as a float32 array, if it holds real numbers: NumPy's casts would store a
/// datetime as its count of seconds, keep a complex number's real part, a masked
/// array's masked values, and parse strings. Floating and integer dtypes only; the
/// error names `what`.
pub(super) fn real_rows<'py>(
    a: &Bound<'py, PyAny>,
    what: &str,
) -> PyResult<PyArrayLike2<'py, f32, AllowTypeChange>> {
    let np = a.py().import("numpy")?;
    if a.is_instance(&np.getattr("ma")?.getattr("MaskedArray")?)? {
        return Err(PyTypeError::new_err(format!(
            "{what}: a masked array: its masked entries would be stored as they are; \
             give a plain array (e.g. `a.filled(...)`)"
        )));
    }
    let arr = np
        .call_method1("asarray", (a,))
        .map_err(|e| PyValueError::new_err(format!("{what}: not an array of numbers: {e}")))?;
    let dtype = arr.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    if !matches!(kind.as_str(), "f" | "i" | "u") {
        return Err(PyTypeError::new_err(format!(
            "{what}: dtype {}: must be real numbers (a floating or integer dtype)",
            dtype.str()?
        )));
    }
    arr.extract()
        .map_err(|e| PyValueError::new_err(format!("{what}: must be an (n, 3) array: {e}")))
}

/// Checks an `(n, 3)` array of finite values; the error names `what`.
pub(super) fn finite_rows(
    a: &PyArrayLike2<'_, f32, AllowTypeChange>,
    n: usize,
    what: &str,
) -> PyResult<()> {
    let v = a.as_array();
    if v.shape() != [n, 3] {
        let shape: Vec<String> = v.shape().iter().map(|d| d.to_string()).collect();
        return Err(PyValueError::new_err(format!(
            "{what}: shape ({}): must be ({n}, 3)",
            shape.join(", ")
        )));
    }
    if let Some(((i, j), x)) = v.indexed_iter().find(|(_, x)| !x.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{what}[{i}, {j}] = {x}: must be finite"
        )));
    }
    Ok(())
}

/// Writes rows `a` into the columns `c`, adding them when `add`.
pub(super) fn write_rows(c: &mut Vec3s, a: &PyArrayLike2<'_, f32, AllowTypeChange>, add: bool) {
    let v = a.as_array();
    for (i, row) in v.outer_iter().enumerate() {
        let (x, y, z) = (row[0], row[1], row[2]);
        if add {
            c.x[i] += x;
            c.y[i] += y;
            c.z[i] += z;
        } else {
            (c.x[i], c.y[i], c.z[i]) = (x, y, z);
        }
    }
}

#[pymethods]
impl PyWorld {
    /// Advances the world by `n` steps. The GIL is released while a step runs, and
    /// Ctrl-C (any pending signal) is answered between steps. Raises `NonFiniteError`
    /// when the state stops being finite (after that step; the world stays readable).
    #[pyo3(signature = (n = 1))]
    fn step(&self, py: Python<'_>, n: u64) -> PyResult<()> {
        super::errors::shield(|| {
            for k in 0..n {
                self.step_once(py, k + 1 == n)?;
                let stop = match &self.lock()?.world()?.non_finite {
                    Some(e) => Err(NonFiniteError::new_err(e.to_string())),
                    None => py.check_signals(),
                };
                if let Err(e) = stop {
                    // Stopped before the last step: the surfels current for the reader.
                    self.lock()?.world_mut()?.sync_surfels();
                    return Err(e);
                }
            }
            Ok(())
        })
    }

    /// Advances the world by `steps` steps and records, at the start and every `every`
    /// steps after it (and after the last), the quantities named in `record` (a name or
    /// a list; default: `com`, `velocity`, `contacts`, `tool_force`; also `energy`),
    /// sampled in Rust: a
    /// dict of NumPy arrays with `time` (s) and `step` (samples), `bodies` (the moving
    /// bodies' names), `com` and `velocity` (samples × bodies × 3, centre of mass and
    /// mean velocity; NaN once a body has broken), `tools` and `tool_force` (the
    /// kinematic bodies' reaction, N), `energy` (a dict of kinetic, elastic, potential,
    /// contact and total, J), `pairs` (the touching pairs' names, in order of first
    /// contact) and per pair `normal_force` (N), `area` (m²), `peak_pressure` (Pa),
    /// `max_penetration` (m), samples × pairs, zero out of contact. `phyxel.to_pandas`
    /// turns it into a DataFrame, one row per sample. Stops, as `step`, on Ctrl-C or a
    /// non-finite state (raising), the samples so far then lost.
    #[pyo3(signature = (steps, record = None, every = 1))]
    fn run<'py>(
        &self,
        py: Python<'py>,
        steps: u64,
        record: Option<Bound<'py, PyAny>>,
        every: u64,
    ) -> PyResult<Bound<'py, PyDict>> {
        super::errors::shield(|| {
            if every == 0 {
                return Err(PyValueError::new_err("every = 0: must be at least 1"));
            }
            // One name or a list of them.
            let names: Vec<String> = match &record {
                None => super::record::DEFAULT
                    .iter()
                    .map(|s| s.to_string())
                    .collect(),
                Some(r) => match r.extract::<String>() {
                    Ok(one) => vec![one],
                    Err(_) => r.extract().map_err(|_| {
                        PyTypeError::new_err(format!(
                            "record = {}: a quantity's name or a list of them ({})",
                            r.repr().map_or_else(|_| "?".into(), |s| s.to_string()),
                            super::record::QUANTITIES.join(", ")
                        ))
                    })?,
                },
            };
            let mut recorder = super::record::Recorder::new(self.lock()?.world()?, &names)?;
            recorder.sample(self.lock()?.world()?);
            let ran = (|| {
                for k in 1..=steps {
                    self.step_once(py, false)?;
                    let s = self.lock()?;
                    let world = s.world()?;
                    if let Some(e) = &world.non_finite {
                        return Err(NonFiniteError::new_err(e.to_string()));
                    }
                    if k % every == 0 || k == steps {
                        recorder.sample(world);
                    }
                    drop(s);
                    py.check_signals()?;
                }
                Ok(())
            })();
            // The surfels current for the reader, however the run ended.
            self.lock()?.world_mut()?.sync_surfels();
            ran?;
            recorder.into_dict(py)
        })
    }

    /// Time step (s). Setting it checks only that it is a finite number > 0: see
    /// `stable_dt` for the explicit bound.
    #[getter]
    fn dt(&self) -> PyResult<f32> {
        super::errors::shield(|| Ok(self.lock()?.world()?.dt))
    }

    /// Setting it checks what `Scene.build(dt=...)` checks: a finite number within
    /// f32's normal range, at most the stable bound (else `UnstableError`) unless the
    /// world was built with `allow_unstable=True`; see `set_dt` to go past it.
    #[setter]
    fn set_dt(&self, py: Python<'_>, dt: f64) -> PyResult<()> {
        self.set_dt_checked(py, dt, false)
    }

    /// Sets the time step (s) as assigning `dt` does; `allow_unstable=True` accepts a dt
    /// above the stable bound (explicit integration then blows up).
    #[pyo3(name = "set_dt", signature = (dt, allow_unstable = false))]
    fn set_dt_checked(&self, py: Python<'_>, dt: f64, allow_unstable: bool) -> PyResult<()> {
        super::errors::shield(|| {
            if !(dt.is_finite() && dt > 0.0) {
                return Err(PyValueError::new_err(format!(
                    "dt = {dt}: must be a finite number > 0"
                )));
            }
            if !crate::scene::fits_f32(dt) {
                return Err(PyValueError::new_err(format!(
                    "dt = {dt:e}: outside the range of f32 numbers ({:e} to {:e})",
                    f32::MIN_POSITIVE,
                    f32::MAX
                )));
            }
            let dt = dt as f32;
            let mut s = self.lock()?;
            let w = s.world_mut()?;
            let (stable, limiter) = w.stable_dt();
            // A world built with `allow_unstable=True` keeps that choice.
            if dt > stable && !allow_unstable && w.keep_stable {
                let limiter = limiter
                    .and_then(|id| w.object(id))
                    .map_or("?", |o| o.name.as_str());
                let suggest = crate::world::DT_FRACTION * stable;
                let e = crate::scene::SceneError(format!(
                    "world: dt = {dt} s exceeds the stable bound {stable} s of object \
                     '{limiter}' (explicit integration would blow up); use dt = {suggest:.3e} \
                     (90% of the bound) or smaller, or set_dt(dt, allow_unstable=True)"
                ));
                return Err(super::errors::scene_error(py, &e));
            }
            w.dt = dt;
            Ok(())
        })
    }

    /// Simulated time (s).
    #[getter]
    fn time(&self) -> PyResult<f64> {
        super::errors::shield(|| Ok(self.lock()?.world()?.time))
    }

    /// Steps taken.
    #[getter]
    fn steps(&self) -> PyResult<u64> {
        super::errors::shield(|| Ok(self.lock()?.world()?.steps))
    }

    /// Largest stable time step (s) over the objects and their contacts.
    #[getter]
    fn stable_dt(&self) -> PyResult<f32> {
        super::errors::shield(|| Ok(self.lock()?.world()?.stable_dt().0))
    }

    /// Gravitational acceleration (m/s²).
    #[getter]
    fn gravity(&self) -> PyResult<[f32; 3]> {
        super::errors::shield(|| Ok(self.lock()?.world()?.gravity.to_array()))
    }

    #[setter]
    fn set_gravity(&self, g: [f32; 3]) -> PyResult<()> {
        super::errors::shield(|| {
            if g.iter().any(|c| !c.is_finite()) {
                return Err(PyValueError::new_err(format!(
                    "gravity = {g:?}: must be finite"
                )));
            }
            self.lock()?.world_mut()?.gravity = g.into();
            Ok(())
        })
    }

    /// Largest penetration depth of a contact over the run (m).
    #[getter]
    fn max_penetration(&self) -> PyResult<f32> {
        super::errors::shield(|| Ok(self.lock()?.world()?.record.max_penetration))
    }

    /// Where the state first became non-finite (`None`: finite so far).
    #[getter]
    fn non_finite(&self) -> PyResult<Option<String>> {
        super::errors::shield(|| {
            Ok(self
                .lock()?
                .world()?
                .non_finite
                .as_ref()
                .map(|e| e.to_string()))
        })
    }

    /// Mechanical energy of the moving objects (J): kinetic, elastic, potential, contact
    /// and their total.
    fn energy<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        super::errors::shield(|| {
            let e = self.lock()?.world()?.energy();
            let d = PyDict::new(py);
            d.set_item("kinetic", e.kinetic)?;
            d.set_item("elastic", e.elastic)?;
            d.set_item("potential", e.potential)?;
            d.set_item("contact", e.contact)?;
            d.set_item("total", e.total())?;
            Ok(d)
        })
    }

    /// Total linear momentum of the moving objects (kg·m/s), a float64 array of 3.
    fn momentum<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        super::errors::shield(|| {
            let p = self.lock()?.world()?.momentum();
            Ok(PyArray1::from_slice(py, &p))
        })
    }

    /// The run so far as `phyxel run --json` prints it (a dict with the same keys;
    /// `wall_seconds` counts the time spent in `step`).
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        super::errors::shield(|| {
            let summary = self.lock()?.run_summary()?;
            let json = serde_json::to_string(&summary).map_err(|e| error(e.to_string()))?;
            json_to_py(py, &json)
        })
    }

    /// The bodies, in the world's order (a fracture appends pieces).
    #[getter]
    fn objects(slf: &Bound<'_, Self>) -> PyResult<Vec<PyBody>> {
        super::errors::shield(|| {
            let ids: Vec<u32> = slf
                .get()
                .lock()?
                .world()?
                .objects
                .iter()
                .map(|o| o.id)
                .collect();
            Ok(ids
                .into_iter()
                .map(|id| PyBody {
                    world: slf.clone().unbind(),
                    id,
                })
                .collect())
        })
    }

    fn __len__(&self) -> PyResult<usize> {
        super::errors::shield(|| Ok(self.lock()?.world()?.objects.len()))
    }

    /// `world[k]` (index) or `world["name"]`.
    fn __getitem__(slf: &Bound<'_, Self>, key: &Bound<'_, PyAny>) -> PyResult<PyBody> {
        super::errors::shield(|| {
            let id = {
                let s = slf.get().lock()?;
                let objects = &s.world()?.objects;
                if let Ok(k) = key.extract::<isize>() {
                    let n = objects.len() as isize;
                    let at = if k < 0 { k + n } else { k };
                    if !(0..n).contains(&at) {
                        return Err(PyIndexError::new_err(format!(
                            "object index {k} out of range ({n} objects)"
                        )));
                    }
                    objects[at as usize].id
                } else if let Ok(name) = key.extract::<String>() {
                    match objects.iter().find(|o| o.name == name) {
                        Some(o) => o.id,
                        None => {
                            let names: Vec<&str> =
                                objects.iter().map(|o| o.name.as_str()).collect();
                            return Err(PyKeyError::new_err(format!(
                                "no object named '{name}' (objects: {})",
                                names.join(", ")
                            )));
                        }
                    }
                } else {
                    return Err(PyTypeError::new_err(
                        "world[key]: key must be an index (int) or a name (str)",
                    ));
                }
            };
            Ok(PyBody {
                world: slf.clone().unbind(),
                id,
            })
        })
    }

    /// The body with id `id`.
    fn object(slf: &Bound<'_, Self>, id: u32) -> PyResult<PyBody> {
        super::errors::shield(|| {
            object_index(slf.get().lock()?.world()?, id)?;
            Ok(PyBody {
                world: slf.clone().unbind(),
                id,
            })
        })
    }

    /// The contact patches of the last step, one dict per touching pair: the two
    /// objects' ids (`a`, `b`), and per contact surfel (rows of `(m, 3)` / `(m,)` float32
    /// arrays) `positions`, `normals` (from a into b), `areas` (m²), `forces` (N, on a;
    /// b receives the opposite) and `velocities` (of a relative to b, m/s).
    fn patches<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        super::errors::shield(|| {
            let s = self.lock()?;
            let w = s.world()?;
            let mut out = Vec::with_capacity(w.contact.patches.len());
            for p in &w.contact.patches {
                let d = PyDict::new(py);
                d.set_item("a", w.objects.get(p.a).map(|o| o.id))?;
                d.set_item("b", w.objects.get(p.b).map(|o| o.id))?;
                let m = p.surfels.len();
                let rows = |f: &dyn Fn(&ContactSurfel) -> glam::Vec3| {
                    let mut c = Vec3s::zeros(m);
                    for (i, s) in p.surfels.iter().enumerate() {
                        c.set(i, f(s));
                    }
                    rows3(py, &c, m)
                };
                d.set_item("positions", rows(&|s| s.pos))?;
                d.set_item("normals", rows(&|s| s.normal))?;
                d.set_item("forces", rows(&|s| s.force))?;
                d.set_item("velocities", rows(&|s| s.velocity))?;
                let areas: Vec<f32> = p.surfels.iter().map(|s| s.area).collect();
                d.set_item("areas", column(py, &areas))?;
                out.push(d);
            }
            Ok(out)
        })
    }

    /// Each touching pair's contact totals at the last step, as `phyxel run --contacts`
    /// writes them per step: one dict per pair with `a`, `b` (ids), `a_name`, `b_name`,
    /// `contact_surfels`, `force`, `normal_force`, `friction_force`, `centre`, `torque`,
    /// `area`, `centroid`, `peak_pressure`, `max_penetration`; vectors as float64 arrays
    /// of 3 (`centroid` None for a patch with no area).
    fn contact_totals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        super::errors::shield(|| {
            let s = self.lock()?;
            let w = s.world()?;
            let json = serde_json::to_string(&crate::app::summary::contact_pairs(w))
                .map_err(|e| error(e.to_string()))?;
            let pairs = json_to_py(py, &json)?;
            let np = py.import("numpy")?;
            for pair in pairs.try_iter()? {
                let pair = pair?;
                for key in ["force", "friction_force", "centre", "torque", "centroid"] {
                    let v = pair.get_item(key)?;
                    if !v.is_none() {
                        pair.set_item(key, np.call_method1("asarray", (v, "float64"))?)?;
                    }
                }
            }
            Ok(pairs)
        })
    }

    /// Writes the render surface (surfels, contact surfels marked) to `path` as binary
    /// PLY (`format="ply"`) or VTK XML PolyData (`"vtk"`, `.vtp`); with `phyxels=True`
    /// the phyxels instead, with displacement, strain and stress; with `contacts=True`
    /// the contact surfels carrying force, with their area, penetration, forces and slip
    /// (the `contacts_NNNNN` frames of `phyxel run --out`); with `fixed_points=True` every body's own surfels in a fixed
    /// order instead of the render surface (`phyxel run --fixed-points`).
    #[pyo3(signature = (path, format = "ply", phyxels = false, contacts = false, fixed_points = false))]
    fn write_frame(
        &self,
        path: PathBuf,
        format: &str,
        phyxels: bool,
        contacts: bool,
        fixed_points: bool,
    ) -> PyResult<()> {
        super::errors::shield(|| {
            let format = Format::parse(format).map_err(PyValueError::new_err)?;
            if [phyxels, contacts, fixed_points]
                .iter()
                .filter(|&&b| b)
                .count()
                > 1
            {
                return Err(PyValueError::new_err(
                    "write_frame: phyxels, contacts and fixed_points are three kinds of frame: \
                     one per call",
                ));
            }
            let s = self.lock()?;
            let w = s.world()?;
            let written = if phyxels {
                output::phyxel_frame(w).write(&path, format)
            } else if contacts {
                output::contact_frame(w).write(&path, format)
            } else if fixed_points {
                output::fixed_frame(w).write(&path, format)
            } else {
                output::surface_frame(w).write(&path, format)
            };
            written.map_err(|e| error(format!("{}: cannot write the frame: {e}", path.display())))
        })
    }

    /// The render surface drawn by the software splat renderer, as an `(h, w, 3)` uint8
    /// array; the camera is the scene's, else fitted to the objects.
    #[pyo3(signature = (size = (800, 600)))]
    fn render<'py>(&self, py: Python<'py>, size: (u32, u32)) -> PyResult<Bound<'py, PyArray3<u8>>> {
        super::errors::shield(|| {
            let (w, h) = size;
            if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
                return Err(PyValueError::new_err(format!(
                    "size = ({w}, {h}): each side must be 1..16384 pixels"
                )));
            }
            let (frame, camera) = {
                let s = self.lock()?;
                (output::surface_frame(s.world()?), s.scene.camera)
            };
            let opts = RenderOptions {
                width: w,
                height: h,
                camera,
                ..RenderOptions::default()
            };
            let image = py.detach(|| render(&frame, &opts));
            let a = PyArray1::from_vec(py, image.rgb);
            a.reshape([h as usize, w as usize, 3])
        })
    }

    fn __repr__(&self) -> String {
        match self.lock().and_then(|s| {
            let w = s.world()?;
            Ok(format!(
                "World(scene={:?}, objects={}, steps={}, time={:.6} s, dt={:e} s)",
                s.scene.name,
                w.objects.len(),
                w.steps,
                w.time,
                w.dt
            ))
        }) {
            Ok(text) => text,
            Err(_) => "World(unavailable)".into(),
        }
    }
}

/// One object of a world, by id (it follows the object when others are added or
/// removed; an object that broke apart is gone, and its pieces are new bodies).
///
/// Reading an array gives a read-only copy; assigning one writes the engine's columns,
/// which the next step uses (positions and velocities of deformable bodies; forces are
/// added with `apply_forces`).
#[pyclass(name = "Body", module = "phyxel", frozen)]
pub struct PyBody {
    world: Py<PyWorld>,
    id: u32,
}

impl PyBody {
    fn with<R>(&self, f: impl FnOnce(&Object) -> R) -> PyResult<R> {
        let s = self.world.get().lock()?;
        let w = s.world()?;
        Ok(f(&w.objects[object_index(w, self.id)?]))
    }

    fn with_mut<R>(&self, f: impl FnOnce(&mut Object) -> PyResult<R>) -> PyResult<R> {
        let mut s = self.world.get().lock()?;
        let w = s.world_mut()?;
        let k = object_index(w, self.id)?;
        let o = &mut w.objects[k];
        if o.is_static() {
            return Err(error(format!(
                "object '{}' is static: its box and grids are computed once, so it cannot \
                 be moved or pushed (build a scene with it elsewhere instead)",
                o.name
            )));
        }
        // What is written to a sleeping body takes effect: it moves again.
        o.wake();
        f(o)
    }
}

#[pymethods]
impl PyBody {
    /// The object's id (unique in the world).
    #[getter]
    fn id(&self) -> u32 {
        self.id
    }

    /// The object's name.
    #[getter]
    fn name(&self) -> PyResult<String> {
        super::errors::shield(|| self.with(|o| o.name.clone()))
    }

    /// The name of the object's dynamics backend (`"static"` for fixed obstacles).
    #[getter]
    fn backend(&self) -> PyResult<String> {
        super::errors::shield(|| self.with(|o| o.dynamics.name().to_string()))
    }

    /// True for an object that never moves.
    #[getter]
    fn is_static(&self) -> PyResult<bool> {
        super::errors::shield(|| self.with(|o| o.is_static()))
    }

    /// True while the body sleeps (scene key `sleep`): nothing steps it
    /// until something moving touches it; writing its phyxels wakes it.
    #[getter]
    fn asleep(&self) -> PyResult<bool> {
        super::errors::shield(|| self.with(|o| o.is_asleep()))
    }

    /// Total mass (kg).
    #[getter]
    fn mass(&self) -> PyResult<f64> {
        super::errors::shield(|| self.with(|o| o.phyxels.total_mass()))
    }

    /// Phyxel positions `(n, 3)` (m). Assign an `(n, 3)` array to move the phyxels; the
    /// surfels follow at the next step.
    #[getter]
    fn phyxel_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        super::errors::shield(|| self.with(|o| rows3(py, &o.phyxels.pos, o.phyxels.len())))
    }

    #[setter]
    fn set_phyxel_positions(&self, a: &Bound<'_, PyAny>) -> PyResult<()> {
        super::errors::shield(|| {
            let a = real_rows(a, "phyxel_positions")?;
            self.with_mut(|o| {
                finite_rows(&a, o.phyxels.len(), "phyxel_positions")?;
                write_rows(&mut o.phyxels.pos, &a, false);
                // The compensated sums' carries belong to the old positions.
                o.phyxels.pos_carry.fill_zero();
                Ok(())
            })
        })
    }

    /// Phyxel velocities `(n, 3)` (m/s). Assign an `(n, 3)` array to set them.
    #[getter]
    fn phyxel_velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        super::errors::shield(|| self.with(|o| rows3(py, &o.phyxels.vel, o.phyxels.len())))
    }

    #[setter]
    fn set_phyxel_velocities(&self, a: &Bound<'_, PyAny>) -> PyResult<()> {
        super::errors::shield(|| {
            let a = real_rows(a, "phyxel_velocities")?;
            self.with_mut(|o| {
                finite_rows(&a, o.phyxels.len(), "phyxel_velocities")?;
                write_rows(&mut o.phyxels.vel, &a, false);
                Ok(())
            })
        })
    }

    /// Forces on the phyxels for the next step `(n, 3)` (N): the contact forces the last
    /// step distributed, plus any applied since.
    #[getter]
    fn phyxel_forces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        super::errors::shield(|| self.with(|o| rows3(py, &o.phyxels.force, o.phyxels.len())))
    }

    /// Adds external forces `(n, 3)` (N) to the phyxels, for the next step only.
    fn apply_forces(&self, forces: &Bound<'_, PyAny>) -> PyResult<()> {
        super::errors::shield(|| {
            let forces = real_rows(forces, "forces")?;
            self.with_mut(|o| {
                finite_rows(&forces, o.phyxels.len(), "forces")?;
                write_rows(&mut o.phyxels.force, &forces, true);
                Ok(())
            })
        })
    }

    /// Phyxel masses `(n,)` (kg).
    #[getter]
    fn phyxel_masses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f32>>> {
        super::errors::shield(|| self.with(|o| column(py, &o.phyxels.mass[..o.phyxels.len()])))
    }

    /// Surfel positions `(m, 3)` (m).
    #[getter]
    fn surfel_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        super::errors::shield(|| self.with(|o| rows3(py, &o.surfels.pos, o.surfels.len())))
    }

    /// Surfel unit normals `(m, 3)`.
    #[getter]
    fn surfel_normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        super::errors::shield(|| self.with(|o| rows3(py, &o.surfels.normal, o.surfels.len())))
    }

    /// Surfel disc radii `(m,)` (m).
    #[getter]
    fn surfel_radii<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f32>>> {
        super::errors::shield(|| self.with(|o| column(py, &o.surfels.radius[..o.surfels.len()])))
    }

    fn __repr__(&self) -> String {
        self.with(|o| {
            format!(
                "Body(id={}, name={:?}, backend={:?}, phyxels={}, surfels={})",
                o.id,
                o.name,
                o.dynamics.name(),
                o.phyxels.len(),
                o.surfels.len()
            )
        })
        .unwrap_or_else(|e| format!("Body(id={}, unavailable: {e})", self.id))
    }
}

/// Accepts a `Scene` or a name/path.
fn scene_of(py: Python<'_>, scene: &Bound<'_, PyAny>) -> PyResult<Scene> {
    if let Ok(s) = scene.extract::<PyRef<'_, PyScene>>() {
        return Ok(s.scene.clone());
    }
    let arg: String = scene.extract().map_err(|_| {
        PyTypeError::new_err("scene: a phyxel.Scene, a built-in scene name or a path")
    })?;
    Scene::resolve(&arg).map_err(|e| scene_error(py, &e))
}

/// Runs `scene` (a `Scene`, a built-in name or a path) for `steps` (default: the
/// scene's) and returns the summary dict of `phyxel run --json`. Stops at a non-finite
/// state as `run` does (the summary says where). `max_memory` as in `Scene.build`.
#[pyfunction]
#[pyo3(signature = (scene, steps = None, backend = None, surfels = None, phyxels = None, dt = None, allow_unstable = false, preset = None, max_memory = None))]
#[allow(clippy::too_many_arguments)] // the keyword arguments of the Python function
pub fn run<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyAny>,
    steps: Option<u64>,
    backend: Option<&Bound<'py, PyAny>>,
    surfels: Option<u32>,
    phyxels: Option<u32>,
    dt: Option<f32>,
    allow_unstable: bool,
    preset: Option<&str>,
    max_memory: Option<u64>,
) -> PyResult<Bound<'py, PyAny>> {
    super::errors::shield(|| {
        let scene = PyScene {
            scene: scene_of(py, scene)?,
        };
        let world = scene.build(
            py,
            backend,
            surfels,
            phyxels,
            dt,
            allow_unstable,
            preset,
            max_memory,
        )?;
        let n = steps.unwrap_or(scene.scene.steps);
        match world.step(py, n) {
            Ok(()) => {}
            Err(e) if e.is_instance_of::<NonFiniteError>(py) => {}
            Err(e) => return Err(e),
        }
        world.summary(py)
    })
}

/// Runs `scene` once per backend of `backends` (names or Python backend classes;
/// default: the built-in ones) and returns their summaries (`phyxel compare --json`).
#[pyfunction]
#[pyo3(signature = (scene, backends = None, steps = None, dt = None, allow_unstable = false))]
pub fn compare<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyAny>,
    backends: Option<Vec<Bound<'py, PyAny>>>,
    steps: Option<u64>,
    dt: Option<f32>,
    allow_unstable: bool,
) -> PyResult<Vec<Bound<'py, PyAny>>> {
    super::errors::shield(|| {
        let backends = match backends {
            Some(b) if b.is_empty() => {
                return Err(PyValueError::new_err(
                    "backends = []: give at least one backend (or leave it out for all)",
                ));
            }
            Some(b) => {
                // Checked before any runs, as `phyxel compare --backends` does.
                let mut seen: Vec<String> = Vec::new();
                for name in b.iter().filter_map(|x| x.extract::<String>().ok()) {
                    if seen.contains(&name) {
                        return Err(PyValueError::new_err(format!(
                            "backends: {name:?} is given twice: each backend runs once"
                        )));
                    }
                    if !crate::backends::NAMES.contains(&name.as_str()) {
                        return Err(PyValueError::new_err(format!(
                            "backends: {name:?}: unknown backend (available: {})",
                            crate::backends::NAMES.join(", ")
                        )));
                    }
                    seen.push(name);
                }
                b
            }
            None => crate::backends::NAMES
                .iter()
                .map(|n| pyo3::types::PyString::new(py, n).into_any())
                .collect(),
        };
        backends
            .iter()
            .map(|b| {
                run(
                    py,
                    scene,
                    steps,
                    Some(b),
                    None,
                    None,
                    dt,
                    allow_unstable,
                    None,
                    None,
                )
            })
            .collect()
    })
}

/// The validation suite (`phyxel validate --json`): one dict per row, accuracy cases
/// then hard cases. `quick` uses the short resolutions; `case` keeps the cases whose
/// name starts with it; `backend` picks one backend (default: all); `preset` builds
/// every case in that configuration (`"default"` or `"paper"`; rows say which).
#[pyfunction]
#[pyo3(signature = (quick = true, case = None, backend = None, preset = "default"))]
pub fn validate<'py>(
    py: Python<'py>,
    quick: bool,
    case: Option<String>,
    backend: Option<String>,
    preset: &str,
) -> PyResult<Bound<'py, PyAny>> {
    super::errors::shield(|| {
        let preset = crate::scene::Preset::parse(preset).map_err(PyValueError::new_err)?;
        let backends: Vec<String> = backend.into_iter().collect();
        for b in &backends {
            suite::check_backend(b).map_err(PyValueError::new_err)?;
        }
        let only = case.as_deref();
        if let Some(c) = only {
            suite::check_case(c).map_err(PyValueError::new_err)?;
        }
        let rows = py.detach(|| {
            suite::with_preset(preset, || {
                let mut rows = suite::run_accuracy(&backends, quick, only, |_| {});
                rows.extend(suite::run_stability(&backends, quick, only, |_| {}));
                rows
            })
        });
        let json = serde_json::to_string(&rows).map_err(|e| error(e.to_string()))?;
        json_to_py(py, &json)
    })
}

/// Registers the world's exception.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("NonFiniteError", m.py().get_type::<NonFiniteError>())
}
