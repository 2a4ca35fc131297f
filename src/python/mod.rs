//! The Python package `phyxel` (feature `python`; built by maturin from
//! `pyproject.toml`, docs/PYTHON.md): a thin layer of conversions and error mapping over
//! the library. No engine logic lives here; no panic crosses into Python.
//!
//! The compiled module is `phyxel._phyxel`; the package `src/python/phyxel/` re-exports
//! it and adds what is easier in Python (pandas conversion).

mod backend;
mod errors;
mod record;
mod scene;
mod world;

use pyo3::prelude::*;

/// The compiled part of the `phyxel` package.
#[pymodule]
fn _phyxel(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    world::register(m)?;
    m.add_class::<scene::PyScene>()?;
    m.add_class::<world::PyWorld>()?;
    m.add_class::<world::PyBody>()?;
    m.add_function(wrap_pyfunction!(scene::scenes, m)?)?;
    m.add_function(wrap_pyfunction!(world::run, m)?)?;
    m.add_function(wrap_pyfunction!(world::compare, m)?)?;
    m.add_function(wrap_pyfunction!(world::validate, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("BACKENDS", crate::backends::NAMES.to_vec())?;
    Ok(())
}
