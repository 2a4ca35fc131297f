//! The backend hint (`app::hint`): given where the measured trade says another
//! backend is faster at the same accuracy, and nowhere else.
//!
//! Reference: the rule's inputs (all bodies on `mls`, at rest at the start, `dt` under
//! 1/100 of the frame-rate step), checked on scenes on both sides of each.

use crate::common;

use phyxel::app::hint::backend_hint;
use phyxel::scene::Scene;

/// The cantilever (E = 1e8 Pa, at rest, `mls` dt about 2e-5 s) gets the hint, naming
/// `mls-implicit` and the step ratio; on `mls-implicit` it gets none; `two-spheres`
/// (bodies flying at each other: an impact to resolve) and `sphere-on-plane` (dt 4e-4
/// s) get none.
#[test]
fn the_hint_names_the_implicit_backend_for_a_stiff_body_at_rest_only() {
    let cantilever = Scene::builtin("cantilever").unwrap();
    let hint = backend_hint(&common::build(&cantilever, Some("mls"))).expect("a hint");
    assert!(hint.contains("--backend mls-implicit"), "{hint}");
    assert!(backend_hint(&common::build(&cantilever, Some("mls-implicit"))).is_none());
    for name in ["two-spheres", "sphere-on-plane"] {
        let w = common::build(&Scene::builtin(name).unwrap(), Some("mls"));
        assert!(backend_hint(&w).is_none(), "{name} (dt {})", w.dt);
    }
}
