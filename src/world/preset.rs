//! The method's configuration a world was built in.

use serde::{Deserialize, Serialize};

/// The method's configuration: this engine's defaults, or the choices of the papers
/// (docs/ACCURACY.md, "The paper's configuration").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Preset {
    /// Green strain, influence radius 2 r, contact forces on the contact surfels placed
    /// from the colliding ones, spread over one influence radius.
    #[default]
    Default,
    /// Müller et al. 2004 and Keiser et al. 2004 as written: the strain `JᵀJ − I`
    /// (`strain = "paper"`), influence radius 3 r, contact forces on the resampled
    /// contact surface, spread over two influence radii, pairs handled in order.
    Paper,
}

impl Preset {
    /// Parses `default` or `paper`.
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "default" => Ok(Preset::Default),
            "paper" => Ok(Preset::Paper),
            _ => Err(format!("unknown preset '{s}' (available: default, paper)")),
        }
    }

    /// The name as written in scenes.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Default => "default",
            Preset::Paper => "paper",
        }
    }

    /// The label of a run of `backend` in the preset named `preset`: the backend, with
    /// the preset after a slash where it is not the default (`mls/paper`), as `compare`
    /// and `validate` show runs side by side.
    pub fn series(backend: &str, preset: &str) -> String {
        if preset == Preset::Default.name() {
            backend.to_string()
        } else {
            format!("{backend}/{preset}")
        }
    }
}
