//! Engine errors as Python exceptions: `phyxel.Error`, and below it `SceneError` (a scene
//! or its build refused; `origin` and `field` attributes where the message names them)
//! and `UnstableError` (a dt above the stable bound; `bound` in seconds).

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(phyxel, Error, PyException, "Base class of phyxel's errors.");
create_exception!(
    phyxel,
    SceneError,
    Error,
    "A scene that cannot be read or built. `origin` is the file or scene the message \
     names, `field` the key (e.g. `objects[1].spacing`) and `value` the bad value as \
     written, where it names them."
);
create_exception!(
    phyxel,
    UnstableError,
    SceneError,
    "A time step above the stable bound (explicit integration would blow up). `bound` \
     is the stable bound in seconds."
);

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("Error", py.get_type::<Error>())?;
    m.add("SceneError", py.get_type::<SceneError>())?;
    m.add("UnstableError", py.get_type::<UnstableError>())?;
    Ok(())
}

/// A Python exception for `e`: `UnstableError` when the message is the stable-bound
/// refusal, else `SceneError`; with `origin`, `field` and `bound` set from the message
/// ("ORIGIN: FIELD: ...", "... exceeds the stable bound B s ...").
pub fn scene_error(py: Python<'_>, e: &crate::scene::SceneError) -> PyErr {
    let message = e.0.clone();
    let unstable = stable_bound(&message);
    let err = match unstable {
        Some(_) => UnstableError::new_err(message.clone()),
        None => SceneError::new_err(message.clone()),
    };
    let value = err.value(py);
    // "ORIGIN: FIELD: message" or "ORIGIN: message"; a field path has no spaces
    // (`dt`, `objects[1].spacing`).
    let mut parts = message.splitn(3, ": ");
    let (first, second, third) = (parts.next(), parts.next(), parts.next());
    let origin = second.and(first);
    let field = match (second, third) {
        (Some(f), Some(_)) if !f.is_empty() && !f.contains(' ') => Some(f.to_string()),
        _ if unstable.is_some() => Some("dt".to_string()),
        _ => None,
    };
    // Setting attributes on a fresh exception instance cannot fail in practice; an error
    // here would only lose an attribute, never the exception.
    // "FIELD: NAME = VALUE: why" gives the value as written.
    let value_text = third
        .and_then(|t| t.split_once(" = "))
        .and_then(|(_, rest)| rest.split_once(": ").map(|(v, _)| v.to_string()));
    let _ = value.setattr("value", value_text);
    let _ = value.setattr("origin", origin);
    let _ = value.setattr("field", field);
    let _ = value.setattr("bound", unstable);
    err
}

/// The bound `B` of a message "... exceeds the stable bound B s ...".
fn stable_bound(message: &str) -> Option<f64> {
    let rest = message.split_once("exceeds the stable bound ")?.1;
    rest.split_whitespace().next()?.parse().ok()
}

/// A `phyxel.Error` with `message`.
pub fn error(message: impl Into<String>) -> PyErr {
    Error::new_err(message.into())
}

/// Runs the body of a binding's method or function, so that no panic crosses into
/// Python: one becomes `phyxel.Error` naming it (pyo3's `PanicException` is a
/// `BaseException`, which `except Exception` does not catch).
pub fn shield<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|panic| {
        Err(error(format!(
            "internal error: {} (please report it)",
            panic_message(panic.as_ref())
        )))
    })
}

/// The message a panic carried (`panic!` gives a `String` or a `&str`).
pub fn panic_message(panic: &(dyn std::any::Any + Send)) -> String {
    panic
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "a panic".into())
}
