//! What an object is (Keiser et al. 2004, §3): a point-based object `Γ = (S, P)` of
//! surfels and phyxels in SoA columns ([`crate::columns`]), its material and shape, how its surfels
//! follow its phyxels, and how its topology changes (fracture, self-collision).

pub mod advect;
pub mod connectivity;
pub mod fracture;
pub mod material;
pub mod mesh;
pub mod object;
pub mod phyxels;
pub mod self_collision;
pub mod shape;
pub mod surfels;
