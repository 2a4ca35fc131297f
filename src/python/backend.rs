//! Dynamics backends written in Python: a class that `Scene.build(backend=Class)` (and
//! `run`, `compare`) instantiates once per deformable body, driven through the same
//! `Dynamics` trait as the built-in backends.
//!
//! The class is called as `Class(phyxels, material)` and its instance must have
//! `step(phyxels, dt, gravity)`, which advances `phyxels.positions` and
//! `phyxels.velocities` in place (`(n, 3)` float32 arrays) under `phyxels.forces` (the
//! contact and applied forces of this step, N) and gravity; it may have
//! `stable_dt(phyxels)` (s; default: no bound) and `name` (default: the class name).
//! `phyxels` also carries `masses` `(n,)`, `rest` `(n, 3)` and `fixed` `(n,)` bool. The
//! engine keeps fixed phyxels in place and clears the forces after the step.

use super::scene::json_to_py;
use super::world::{finite_rows, real_rows, rows_writable};
use crate::dynamics::{Dynamics, StepContext};
use crate::material::Material;
use crate::points::phyxels::Phyxels;
use numpy::PyArray1;
use pyo3::prelude::*;

/// A Python object driving one body's phyxels.
pub struct PyDynamics {
    obj: Py<PyAny>,
    name: String,
}

/// The `phyxels` argument: NumPy copies of the columns a backend reads and writes.
fn phyxel_view<'py>(py: Python<'py>, p: &Phyxels) -> PyResult<Bound<'py, PyAny>> {
    let n = p.len();
    let mut pos = p.pos.clone();
    // With the compensated sums' carries, so the backend sees the exact positions.
    for i in 0..n {
        pos.set(i, pos.get(i) + p.pos_carry.get(i));
    }
    let fixed: Vec<bool> = p.fixed[..n].iter().map(|&f| f != 0).collect();
    let ns = py.import("types")?.getattr("SimpleNamespace")?.call0()?;
    ns.setattr("positions", rows_writable(py, &pos, n))?;
    ns.setattr("velocities", rows_writable(py, &p.vel, n))?;
    ns.setattr("forces", rows_writable(py, &p.force, n))?;
    ns.setattr("rest", rows_writable(py, &p.rest, n))?;
    ns.setattr("masses", PyArray1::from_slice(py, &p.mass[..n]))?;
    ns.setattr("fixed", PyArray1::from_vec(py, fixed))?;
    Ok(ns)
}

/// The material as a dict of its scene keys.
fn material_dict<'py>(py: Python<'py>, m: &Material) -> PyResult<Bound<'py, PyAny>> {
    let json = serde_json::to_string(m)
        .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
    json_to_py(py, &json)
}

impl PyDynamics {
    /// `factory(phyxels, material)`, named by its `name` attribute or its class name.
    pub fn create(
        py: Python<'_>,
        factory: &Bound<'_, PyAny>,
        phyxels: &Phyxels,
        material: &Material,
    ) -> PyResult<Self> {
        let obj = factory.call1((phyxel_view(py, phyxels)?, material_dict(py, material)?))?;
        if !obj.hasattr("step")? {
            return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "backend {}: has no step(phyxels, dt, gravity) method",
                obj.get_type().name()?
            )));
        }
        let name = match obj.getattr("name") {
            Ok(n) => n.extract::<String>()?,
            Err(_) => obj.get_type().name()?.to_string(),
        };
        Ok(Self {
            obj: obj.unbind(),
            name,
        })
    }

    fn try_step(
        &self,
        py: Python<'_>,
        phyxels: &mut Phyxels,
        ctx: &StepContext<'_>,
    ) -> PyResult<()> {
        let n = phyxels.len();
        let view = phyxel_view(py, phyxels)?;
        let g = ctx.gravity.to_array();
        self.obj.bind(py).call_method1("step", (&view, ctx.dt, g))?;
        // Both read and checked before either is written: a bad one changes nothing.
        let pos = real_rows(&view.getattr("positions")?, "positions")?;
        let vel = real_rows(&view.getattr("velocities")?, "velocities")?;
        finite_rows(&pos, n, "positions")?;
        finite_rows(&vel, n, "velocities")?;
        // Fixed phyxels keep their place and velocity, whatever the backend wrote.
        let (pos, vel) = (pos.as_array(), vel.as_array());
        for i in (0..n).filter(|&i| phyxels.fixed[i] == 0) {
            phyxels
                .pos
                .set(i, glam::Vec3::new(pos[[i, 0]], pos[[i, 1]], pos[[i, 2]]));
            phyxels
                .vel
                .set(i, glam::Vec3::new(vel[[i, 0]], vel[[i, 1]], vel[[i, 2]]));
        }
        phyxels.pos_carry.fill_zero();
        phyxels.force.fill_zero();
        Ok(())
    }
}

impl Dynamics for PyDynamics {
    fn name(&self) -> &str {
        &self.name
    }

    /// Calls the object's `step` with the GIL taken; an exception it raises stops the
    /// run as an error naming the backend (the Python world turns it into
    /// `phyxel.Error`).
    fn step(&mut self, phyxels: &mut Phyxels, ctx: &StepContext<'_>) {
        let result = Python::attach(|py| {
            self.try_step(py, phyxels, ctx).map_err(|e| {
                let tb = e
                    .traceback(py)
                    .and_then(|t| t.format().ok())
                    .unwrap_or_default();
                format!("Python backend '{}' failed in step: {e}\n{tb}", self.name)
            })
        });
        if let Err(message) = result {
            // The trait's step cannot fail: unwind to the world's caller, which catches
            // this and raises it. `resume_unwind` skips the panic hook, so nothing is
            // printed (a `panic!` would print a Rust message and backtrace per body).
            std::panic::resume_unwind(Box::new(message));
        }
    }

    /// The object's `stable_dt(phyxels)`, or no bound without one; a failing or
    /// non-number answer is NaN, which the world reports as a broken bound.
    fn stable_dt(&self, phyxels: &Phyxels, _material: &Material) -> f32 {
        Python::attach(|py| {
            let obj = self.obj.bind(py);
            if !obj.hasattr("stable_dt").unwrap_or(false) {
                return f32::INFINITY;
            }
            phyxel_view(py, phyxels)
                .and_then(|v| obj.call_method1("stable_dt", (v,)))
                .and_then(|r| r.extract::<f32>())
                .unwrap_or(f32::NAN)
        })
    }
}

/// Replaces the dynamics of every deformable object of `world` by instances of
/// `factory`.
pub fn install(
    py: Python<'_>,
    world: &mut crate::world::World,
    factory: &Bound<'_, PyAny>,
) -> PyResult<()> {
    for o in world.objects.iter_mut().filter(|o| !o.is_static()) {
        o.set_dynamics(Box::new(PyDynamics::create(
            py,
            factory,
            &o.phyxels,
            &o.material,
        )?));
    }
    Ok(())
}
