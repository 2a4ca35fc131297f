//! The backend hint (`app::hint`): given where the measured trade says another
//! backend is faster at the same accuracy, and nowhere else.
//!
//! Reference: the rules' inputs (all bodies on `mls`, at rest at the start, `dt` under
//! 1/100 of the frame-rate step; or all on `mls-implicit` with `mls`'s stable step at
//! least half of `dt`), checked on scenes on both sides of each.

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

/// The other way: `plastic-fracture` (its dt 3e-4 s, `mls` stable at about 1.6e-3 s)
/// on `mls-implicit` gets the hint naming `--backend mls`; on `mls` it gets none; the
/// frame-rate scenes (`falling-sphere`, `sphere-on-plane`, the cantilever: 12, 19 and
/// 370 `mls` steps per implicit step) get none on `mls-implicit`.
#[test]
fn the_hint_names_the_explicit_backend_where_its_step_is_as_long() {
    let scene = Scene::builtin("plastic-fracture").unwrap();
    let hint = backend_hint(&common::build(&scene, Some("mls-implicit"))).expect("a hint");
    assert!(hint.contains("`--backend mls`"), "{hint}");
    assert!(backend_hint(&common::build(&scene, Some("mls"))).is_none());
    for name in ["falling-sphere", "sphere-on-plane", "cantilever"] {
        let w = common::build(&Scene::builtin(name).unwrap(), Some("mls-implicit"));
        assert!(backend_hint(&w).is_none(), "{name} (dt {})", w.dt);
    }
}
