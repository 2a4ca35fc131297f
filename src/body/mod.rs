//! What an object is (Keiser et al. 2004, §3): a point-based object `Γ = (S, P)` of
//! surfels and phyxels in SoA columns ([`crate::columns`]), its material and shape, how its surfels
//! follow its phyxels, and how its topology changes (fracture, self-collision).

pub mod advect;
pub mod connectivity;
pub mod fracture;
pub mod mesh;
pub mod object;
pub mod output_mesh;
pub mod self_collision;
pub mod shape;

/// Moved to [`crate::material`].
pub mod material {
    #[deprecated(note = "use phyxel::material::Material")]
    pub type Material = crate::material::Material;
    #[deprecated(note = "use phyxel::material::StrainForm")]
    pub type StrainForm = crate::material::StrainForm;
}

/// Moved to [`crate::points::phyxels`].
pub mod phyxels {
    #[deprecated(note = "use phyxel::points::phyxels::Phyxels")]
    pub type Phyxels = crate::points::phyxels::Phyxels;
}

/// Moved to [`crate::points::surfels`].
pub mod surfels {
    #[deprecated(note = "use phyxel::points::surfels::Surfels")]
    pub type Surfels = crate::points::surfels::Surfels;
}
