//! The point sets of an object (Keiser et al. 2004, §3): phyxels sample its volume and
//! surfels its surface, each stored as SoA columns padded to the SIMD width
//! ([`crate::columns`]). Plain data: what moves them is [`crate::dynamics`] and
//! [`crate::body`].

pub mod phyxels;
pub mod surfels;
