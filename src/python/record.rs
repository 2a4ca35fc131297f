//! `World.run(steps, record=[...], every=1)`: a run that samples chosen quantities every
//! `every` steps in Rust and hands them to Python as NumPy arrays, without a Python call
//! per step.

use crate::dynamics::kinematic::Kinematic;
use crate::world::World;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The quantities `record` may name.
pub const QUANTITIES: [&str; 5] = ["com", "velocity", "energy", "contacts", "tool_force"];

/// What `run` records by default: everything but the energy, whose elastic part costs a
/// strain evaluation of every phyxel per sample.
pub const DEFAULT: [&str; 4] = ["com", "velocity", "contacts", "tool_force"];

/// Samples of a run (see the module doc).
pub struct Recorder {
    com: bool,
    velocity: bool,
    energy: bool,
    contacts: bool,
    tools: bool,
    time: Vec<f64>,
    step: Vec<u64>,
    /// The moving bodies at the start (id, name), and the kinematic ones.
    bodies: Vec<(u32, String)>,
    tool_ids: Vec<(u32, String)>,
    /// Per sample, per body: three values (NaN once the body is gone).
    com_values: Vec<f64>,
    velocity_values: Vec<f64>,
    tool_values: Vec<f64>,
    energy_values: [Vec<f64>; 5],
    /// The pairs met so far (ids and names) and, per pair, one column per quantity
    /// (normal force, area, peak pressure, deepest overlap) over the samples.
    pairs: Vec<(u32, u32, String, String)>,
    pair_values: Vec<[Vec<f64>; 4]>,
}

impl Recorder {
    /// A recorder of `names` for `world`'s bodies; an unknown name is an error naming
    /// the known ones.
    pub fn new(world: &World, names: &[String]) -> PyResult<Self> {
        for n in names {
            if !QUANTITIES.contains(&n.as_str()) {
                return Err(PyValueError::new_err(format!(
                    "record: unknown quantity '{n}' (known: {}; `time` and `step` are \
                     always recorded)",
                    QUANTITIES.join(", ")
                )));
            }
        }
        let has = |q: &str| names.iter().any(|n| n == q);
        let moving = world.objects.iter().filter(|o| !o.is_static());
        Ok(Self {
            com: has("com"),
            velocity: has("velocity"),
            energy: has("energy"),
            contacts: has("contacts"),
            tools: has("tool_force"),
            time: Vec::new(),
            step: Vec::new(),
            bodies: moving.map(|o| (o.id, o.name.clone())).collect(),
            tool_ids: world
                .objects
                .iter()
                .filter(|o| o.dynamics_as::<Kinematic>().is_some())
                .map(|o| (o.id, o.name.clone()))
                .collect(),
            com_values: Vec::new(),
            velocity_values: Vec::new(),
            tool_values: Vec::new(),
            energy_values: Default::default(),
            pairs: Vec::new(),
            pair_values: Vec::new(),
        })
    }

    /// Samples `world` now.
    pub fn sample(&mut self, world: &World) {
        let k = self.time.len();
        self.time.push(world.time);
        self.step.push(world.steps);
        for &(id, _) in &self.bodies {
            let o = world.object(id);
            if self.com {
                let c = o.map_or([f64::NAN; 3], |o| o.phyxels.centre_of_mass());
                self.com_values.extend(c);
            }
            if self.velocity {
                let v = o.map_or([f64::NAN; 3], |o| {
                    let p = &o.phyxels;
                    let m = p.total_mass();
                    p.momentum().map(|q| q / m)
                });
                self.velocity_values.extend(v);
            }
        }
        if self.tools {
            for &(id, _) in &self.tool_ids {
                let f = world
                    .object(id)
                    .and_then(|o| o.dynamics_as::<Kinematic>())
                    .map_or([f64::NAN; 3], |k| k.reaction().as_dvec3().to_array());
                self.tool_values.extend(f);
            }
        }
        if self.energy {
            let e = world.energy();
            let values = [e.kinetic, e.elastic, e.potential, e.contact, e.total()];
            for (column, v) in self.energy_values.iter_mut().zip(values) {
                column.push(v);
            }
        }
        if self.contacts {
            for t in world.contact_totals() {
                let at = match self.pairs.iter().position(|p| (p.0, p.1) == (t.a, t.b)) {
                    Some(at) => at,
                    None => {
                        let name = |id| world.object(id).map_or(String::new(), |o| o.name.clone());
                        self.pairs.push((t.a, t.b, name(t.a), name(t.b)));
                        self.pair_values.push(std::array::from_fn(|_| vec![0.0; k]));
                        self.pairs.len() - 1
                    }
                };
                let values = [t.normal_force, t.area, t.peak_pressure, t.max_penetration];
                for (column, v) in self.pair_values[at].iter_mut().zip(values) {
                    column.resize(k, 0.0);
                    column.push(v);
                }
            }
            // A pair out of contact at this sample reads zero.
            for columns in &mut self.pair_values {
                for column in columns.iter_mut() {
                    column.resize(k + 1, 0.0);
                }
            }
        }
    }

    /// The samples as a dict of NumPy arrays (see `World.run`).
    pub fn into_dict<'py>(self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let k = self.time.len();
        d.set_item("time", PyArray1::from_vec(py, self.time))?;
        d.set_item("step", PyArray1::from_vec(py, self.step))?;
        let names = |list: &[(u32, String)]| -> Vec<String> {
            list.iter().map(|(_, n)| n.clone()).collect()
        };
        let per_body = |values: Vec<f64>, n: usize| {
            PyArray1::from_vec(py, values)
                .reshape([k, n, 3])
                .expect("three values per body and sample")
        };
        d.set_item("bodies", names(&self.bodies))?;
        let nb = self.bodies.len();
        if self.com {
            d.set_item("com", per_body(self.com_values, nb))?;
        }
        if self.velocity {
            d.set_item("velocity", per_body(self.velocity_values, nb))?;
        }
        if self.tools {
            d.set_item("tools", names(&self.tool_ids))?;
            d.set_item(
                "tool_force",
                per_body(self.tool_values, self.tool_ids.len()),
            )?;
        }
        if self.energy {
            let e = PyDict::new(py);
            let keys = ["kinetic", "elastic", "potential", "contact", "total"];
            for (key, column) in keys.iter().zip(self.energy_values) {
                e.set_item(key, PyArray1::from_vec(py, column))?;
            }
            d.set_item("energy", e)?;
        }
        if self.contacts {
            let pairs: Vec<(String, String)> = self
                .pairs
                .iter()
                .map(|p| (p.2.clone(), p.3.clone()))
                .collect();
            d.set_item("pairs", pairs)?;
            let np = self.pairs.len();
            let keys = ["normal_force", "area", "peak_pressure", "max_penetration"];
            for (q, key) in keys.iter().enumerate() {
                // (samples, pairs), sample-major.
                let mut values = vec![0.0f64; k * np];
                for (p, columns) in self.pair_values.iter().enumerate() {
                    for (s, &v) in columns[q].iter().enumerate() {
                        values[s * np + p] = v;
                    }
                }
                let a = PyArray1::from_vec(py, values)
                    .reshape([k, np])
                    .expect("one value per pair and sample");
                d.set_item(key, a)?;
            }
        }
        Ok(d)
    }
}
