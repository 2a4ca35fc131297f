//! `phyxel.Scene`: a scene read from a built-in name, a TOML file, TOML text or a dict,
//! and built into a `phyxel.World`.

use super::errors::{error, scene_error};
use super::world::PyWorld;
use crate::scene::{BUILTIN, BuildOptions, Scene, SceneError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// A simulation scene (docs/SCENES.md): objects with shapes, materials, backends and
/// placements, gravity, dt and the step count. Immutable; change one through its dict
/// (`Scene.from_dict(d)` after editing `scene.to_dict()`).
#[pyclass(name = "Scene", module = "phyxel", frozen)]
#[derive(Clone)]
pub struct PyScene {
    pub scene: Scene,
}

/// A Python value as a TOML value for a scene (`None`: the key is left out, meaning the
/// default); NumPy arrays and scalars as their lists and numbers. `budget` is what is
/// left of the bytes a scene file may hold ([`crate::io::SCENE_FILE_LIMIT`]), counted
/// about as the TOML text would: a dict of a million entries is refused in its walk,
/// not after building it. The error names the key path.
fn py_to_toml(
    obj: &Bound<'_, PyAny>,
    path: &str,
    budget: &mut usize,
) -> Result<Option<toml::Value>, String> {
    use pyo3::types::{PyBool, PyFloat, PyInt, PyList, PyString, PyTuple};
    let at = if path.is_empty() { "the scene" } else { path };
    fn spend(budget: &mut usize, n: usize, at: &str) -> Result<(), String> {
        *budget = budget.checked_sub(n).ok_or_else(|| {
            format!(
                "{at}: the scene is larger than the {} bytes a scene file may hold",
                crate::io::SCENE_FILE_LIMIT
            )
        })?;
        Ok(())
    }
    spend(budget, 8, at)?;
    if obj.is_none() {
        return Ok(None);
    }
    if let Ok(b) = obj.cast::<PyBool>() {
        return Ok(Some(toml::Value::Boolean(b.is_true())));
    }
    if obj.cast::<PyInt>().is_ok() {
        let i: i64 = obj
            .extract()
            .map_err(|_| format!("{at} = {obj}: an integer beyond 64 bits"))?;
        return Ok(Some(toml::Value::Integer(i)));
    }
    if let Ok(f) = obj.cast::<PyFloat>() {
        return Ok(Some(toml::Value::Float(f.value())));
    }
    if let Ok(s) = obj.cast::<PyString>() {
        let s = s.to_string();
        spend(budget, s.len(), at)?;
        return Ok(Some(toml::Value::String(s)));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut table = toml::map::Map::new();
        for (k, v) in d.iter() {
            let key: String = k
                .extract()
                .map_err(|_| format!("{at}: key {k}: keys must be strings"))?;
            spend(budget, key.len(), at)?;
            let inner = if path.is_empty() {
                key.clone()
            } else {
                format!("{path}.{key}")
            };
            if let Some(v) = py_to_toml(&v, &inner, budget)? {
                table.insert(key, v);
            }
        }
        return Ok(Some(toml::Value::Table(table)));
    }
    if obj.cast::<PyList>().is_ok() || obj.cast::<PyTuple>().is_ok() {
        let mut items = Vec::new();
        for (i, v) in obj.try_iter().map_err(|e| e.to_string())?.enumerate() {
            let v = v.map_err(|e| e.to_string())?;
            match py_to_toml(&v, &format!("{path}[{i}]"), budget)? {
                Some(v) => items.push(v),
                None => return Err(format!("{path}[{i}] = None: a list holds values only")),
            }
        }
        return Ok(Some(toml::Value::Array(items)));
    }
    // NumPy arrays and scalars (and anything else with `tolist`): their Python values.
    if obj.hasattr("tolist").unwrap_or(false)
        && let Ok(list) = obj.call_method0("tolist")
        && !list.is(obj)
    {
        return py_to_toml(&list, path, budget);
    }
    let kind = obj
        .get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_default();
    Err(format!(
        "{at}: a {kind} is not a scene value (numbers, strings, booleans, lists and dicts)"
    ))
}

/// A JSON string as a Python object (through the standard `json` module).
pub fn json_to_py<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

#[pymethods]
impl PyScene {
    /// The built-in scene `name` (`phyxel.scenes()` lists them).
    #[staticmethod]
    fn builtin(py: Python<'_>, name: &str) -> PyResult<Self> {
        super::errors::shield(|| {
            Scene::builtin(name)
                .map(|scene| Self { scene })
                .ok_or_else(|| {
                    let names: Vec<&str> = BUILTIN.iter().map(|(n, _)| *n).collect();
                    let e = SceneError(format!(
                        "{name}: not a built-in scene (built-in: {})",
                        names.join(", ")
                    ));
                    scene_error(py, &e)
                })
        })
    }

    /// Reads a scene file (TOML); mesh paths are relative to it.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        super::errors::shield(|| {
            Scene::load(&path)
                .map(|scene| Self { scene })
                .map_err(|e| scene_error(py, &e))
        })
    }

    /// Parses scene TOML; `origin` names it in errors.
    #[staticmethod]
    #[pyo3(signature = (text, origin = "scene"))]
    fn from_toml(py: Python<'_>, text: &str, origin: &str) -> PyResult<Self> {
        super::errors::shield(|| {
            let limit = crate::io::SCENE_FILE_LIMIT;
            if text.len() as u64 > limit {
                let e = SceneError(format!(
                    "{origin}: {} bytes, more than the limit of {limit} bytes for a scene",
                    text.len()
                ));
                return Err(scene_error(py, &e));
            }
            Scene::parse(text, origin)
                .map(|scene| Self { scene })
                .map_err(|e| scene_error(py, &e))
        })
    }

    /// A scene from a dict with the keys of a scene file (`None` values mean the
    /// default); checked exactly as a file is.
    #[staticmethod]
    #[pyo3(signature = (d, origin = "scene"))]
    fn from_dict(py: Python<'_>, d: &Bound<'_, PyDict>, origin: &str) -> PyResult<Self> {
        super::errors::shield(|| {
            let fail = |m: String| scene_error(py, &SceneError(format!("{origin}: {m}")));
            let mut budget = crate::io::SCENE_FILE_LIMIT as usize;
            let value = py_to_toml(d.as_any(), "", &mut budget)
                .map_err(fail)?
                .unwrap_or_else(|| toml::Value::Table(Default::default()));
            let text = toml::to_string(&value).map_err(|e| fail(e.to_string()))?;
            // A value of the wrong type is named by the key and value the user gave,
            // not by a line and column of this internal TOML text.
            if let Err(e) = toml::from_str::<Scene>(&text) {
                let line = e
                    .span()
                    .map(|s| {
                        let start = text[..s.start].rfind('\n').map_or(0, |i| i + 1);
                        let end = text[s.start..]
                            .find('\n')
                            .map_or(text.len(), |i| s.start + i);
                        let table = text[..start]
                            .lines()
                            .rev()
                            .find(|l| l.starts_with('['))
                            .map(|t| format!("{t} "))
                            .unwrap_or_default();
                        format!("{table}{}: ", text[start..end].trim())
                    })
                    .unwrap_or_default();
                // A control character in the value is echoed by the parser: not raw.
                let shown: String = format!("{line}{}", e.message().trim())
                    .chars()
                    .map(|c| if c.is_control() { '\u{fffd}' } else { c })
                    .collect();
                return Err(fail(shown));
            }
            Self::from_toml(py, &text, origin)
        })
    }

    /// The scene as TOML text (what `phyxel scenes --show` prints).
    fn to_toml(&self) -> String {
        self.scene.to_toml()
    }

    /// The scene as a dict with the keys of a scene file.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        super::errors::shield(|| {
            let json = serde_json::to_string(&self.scene).map_err(|e| error(e.to_string()))?;
            json_to_py(py, &json)
        })
    }

    /// The scene's name.
    #[getter]
    fn name(&self) -> String {
        self.scene.name.clone()
    }

    /// The number of steps `run` takes by default.
    #[getter]
    fn steps(&self) -> u64 {
        self.scene.steps
    }

    /// The names of the scene's objects, in order.
    #[getter]
    fn object_names(&self) -> Vec<String> {
        (0..self.scene.objects.len())
            .map(|k| match self.scene.objects[k].name.as_str() {
                "" => format!("object{k}"),
                name => name.to_string(),
            })
            .collect()
    }

    /// Samples every object and builds a world. `backend` replaces every deformable
    /// object's backend: a name (`phyxel.BACKENDS`) or a Python class (docs/PYTHON.md,
    /// "Backends in Python"); `surfels` and `phyxels` set the sample counts per
    /// deformable object; `dt` the time step (default: 90% of the stable bound, at most
    /// 1 ms); `allow_unstable` accepts a dt above the bound; `preset` (`"default"` or
    /// `"paper"`) overrides the scene's; `max_memory` (bytes) is the memory the scene may
    /// need, estimated before building (default: 80% of what the system has available).
    #[pyo3(signature = (backend = None, surfels = None, phyxels = None, dt = None, allow_unstable = false, preset = None, max_memory = None))]
    #[allow(clippy::too_many_arguments)] // the keyword arguments of one Python method
    pub fn build(
        &self,
        py: Python<'_>,
        backend: Option<&Bound<'_, PyAny>>,
        surfels: Option<u32>,
        phyxels: Option<u32>,
        dt: Option<f32>,
        allow_unstable: bool,
        preset: Option<&str>,
        max_memory: Option<u64>,
    ) -> PyResult<PyWorld> {
        super::errors::shield(|| {
            let preset = preset
                .map(crate::scene::Preset::parse)
                .transpose()
                .map_err(pyo3::exceptions::PyValueError::new_err)?;
            let (name, class) = match backend {
                None => (None, None),
                Some(b) => match b.extract::<String>() {
                    Ok(name) => (Some(name), None),
                    Err(_) if b.is_callable() => (None, Some(b)),
                    Err(_) => {
                        return Err(pyo3::exceptions::PyTypeError::new_err(
                            "backend: a backend name (str) or a Python backend class",
                        ));
                    }
                },
            };
            let opts = BuildOptions {
                dt,
                backend: name,
                // A Python backend's bound is checked once it is installed.
                allow_unstable: allow_unstable || class.is_some(),
                surfels,
                phyxels,
                preset,
                max_memory,
                meshes: false,
            };
            let scene = self.scene.clone();
            let mut world = py
                .detach(|| scene.build(&opts))
                .map_err(|e| scene_error(py, &e))?;
            // As `phyxel run` (the same summaries): `World.step` syncs before returning.
            world.lazy_advection = true;
            if let Some(class) = class {
                super::backend::install(py, &mut world, class)?;
                world.keep_stable = !allow_unstable;
                world.dt = python_backend_dt(&world, &scene, dt, allow_unstable)
                    .map_err(|e| scene_error(py, &e))?;
            }
            Ok(PyWorld::new(world, scene))
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene(name={:?}, objects={}, steps={})",
            self.scene.name,
            self.scene.objects.len(),
            self.scene.steps
        )
    }
}

/// The time step of a world whose backends were replaced after the build: `dt` checked
/// against the new stable bound (as `Scene::build` checks it), else the default.
fn python_backend_dt(
    world: &crate::world::World,
    scene: &Scene,
    dt: Option<f32>,
    allow_unstable: bool,
) -> Result<f32, SceneError> {
    let (stable, limiter) = world.stable_dt();
    let origin = if scene.name.is_empty() {
        "scene"
    } else {
        &scene.name
    };
    let limiter = limiter
        .and_then(|id| world.object(id))
        .map(|o| o.name.clone())
        .unwrap_or_default();
    if stable.is_nan() || stable <= 0.0 {
        return Err(SceneError(format!(
            "{origin}: object '{limiter}': the Python backend's stable_dt gave {stable}: it \
             must be a number > 0 (or float('inf'))"
        )));
    }
    match dt.or(scene.dt) {
        Some(dt) if dt > stable && !allow_unstable => Err(SceneError(format!(
            "{origin}: dt = {dt} s exceeds the stable bound {stable} s of object '{limiter}' \
             (explicit integration would blow up); use a smaller dt or allow_unstable=True"
        ))),
        Some(dt) => Ok(dt),
        None => Ok(world.default_dt(stable)),
    }
}

/// The names of the built-in scenes with their one-line descriptions.
#[pyfunction]
pub fn scenes() -> Vec<(String, String)> {
    BUILTIN
        .iter()
        .map(|(name, _)| {
            let s = Scene::builtin(name).expect("built-in scenes parse");
            (name.to_string(), s.description)
        })
        .collect()
}
