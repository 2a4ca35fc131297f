//! A point-based object `Γ = (S, P)`: surfels, phyxels, a material and a backend.

use crate::advect::SurfelBinding;
use crate::dynamics::Dynamics;
use crate::material::Material;
use crate::mls::MlsStencil;
use crate::phyxels::Phyxels;
use crate::surfels::Surfels;
use glam::Mat3;

/// One simulated object.
pub struct Object {
    /// Stable id (index at creation; fragments get new ids).
    pub id: u32,
    pub name: String,
    pub surfels: Surfels,
    pub phyxels: Phyxels,
    pub material: Material,
    pub dynamics: Box<dyn Dynamics>,
    pub(crate) binding: SurfelBinding,
    /// Core MLS gradient estimate for backends that provide none (built on first use).
    pub(crate) estimate: Option<(MlsStencil, Vec<Mat3>)>,
}

impl Object {
    /// Assembles an object and binds its surfels to its phyxels.
    pub fn new(
        id: u32,
        name: impl Into<String>,
        surfels: Surfels,
        phyxels: Phyxels,
        material: Material,
        dynamics: Box<dyn Dynamics>,
    ) -> Self {
        let binding = SurfelBinding::build(&surfels, &phyxels);
        Self {
            id,
            name: name.into(),
            surfels,
            phyxels,
            material,
            dynamics,
            binding,
            estimate: None,
        }
    }

    /// True for objects whose backend never moves them.
    pub fn is_static(&self) -> bool {
        self.dynamics.is_static()
    }

    /// Moves the surfels with the phyxels (uses the backend's gradient, or the core's
    /// MLS estimate when the backend has none).
    pub fn advect_surfels(&mut self) {
        let grad: &[Mat3] = match self.dynamics.displacement_gradient() {
            Some(g) => g,
            None => {
                let (stencil, grad) = self.estimate.get_or_insert_with(|| {
                    (
                        MlsStencil::build(&self.phyxels),
                        vec![Mat3::ZERO; self.phyxels.len()],
                    )
                });
                stencil.displacement_gradients(&self.phyxels.pos, &self.phyxels.rest, grad);
                grad
            }
        };
        self.binding.advect(&mut self.surfels, &self.phyxels, grad);
    }
}
