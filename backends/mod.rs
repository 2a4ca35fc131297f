//! The built-in dynamics backends (`mls`, `mls-implicit`, `sph`, `lj`, and the
//! prescribed-motion `kinematic` and `static`), and the registry that creates them by
//! name. Each backend is written against phyxel's public API only, as an outside crate
//! would be (CI refuses paths from the crate root here).

pub mod lj;
pub mod mls;
pub mod sph;

use phyxel::dynamics::kinematic::Kinematic;
use phyxel::dynamics::{Dynamics, StaticDynamics};
use phyxel::material::Material;
use phyxel::points::phyxels::Phyxels;

/// The prescribed-motion backend (`backend = "kinematic"`): a rigid body the caller
/// moves, such as a tool ([`phyxel::dynamics::kinematic`]). Not in [`NAMES`]: it is no
/// dynamics to compare, and `--backend` leaves such objects as they are.
pub const KINEMATIC: &str = phyxel::dynamics::kinematic::NAME;

/// Names accepted by `backend = "..."` in scenes and `--backend`.
pub const NAMES: &[&str] = &[mls::NAME, mls::implicit::NAME, sph::NAME, lj::NAME];

/// The backends that model plastic flow (`plastic_yield`, `plastic_creep`,
/// `plastic_max`); the others treat a plastic material as elastic.
pub const PLASTIC: &[&str] = &[mls::NAME, mls::implicit::NAME];

/// The backends that take a graded cloud (`refine` zones: phyxels of several spacings);
/// SPH's kernel and LJ's bonds are defined on one lattice spacing. A `kinematic` tool
/// moves rigidly, whatever its sampling.
pub const GRADED: &[&str] = &[mls::NAME, mls::implicit::NAME, KINEMATIC];

/// Creates backend `name` for `phyxels`, or explains which names exist.
pub fn create(
    name: &str,
    phyxels: &Phyxels,
    material: &Material,
) -> Result<Box<dyn Dynamics>, String> {
    match name {
        mls::NAME => Ok(Box::new(mls::MlsDynamics::new(phyxels, material))),
        mls::implicit::NAME => Ok(Box::new(mls::MlsImplicit::new(phyxels, material))),
        sph::NAME => Ok(Box::new(sph::SphDynamics::new(phyxels, material))),
        lj::NAME => Ok(Box::new(lj::LjDynamics::new(phyxels, material))),
        "static" => Ok(Box::new(StaticDynamics)),
        KINEMATIC => Ok(Box::new(Kinematic::new(phyxels))),
        other => Err(format!(
            "unknown backend '{other}' (available: {})",
            NAMES.join(", ")
        )),
    }
}
