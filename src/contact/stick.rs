//! The friction anchors of the contact springs, carried from step to step: each contact
//! surfel's tangential spring elongation ξ (the Cundall–Strack law of discrete-element
//! codes, Cundall and Strack 1979), kept under a key that names the contact by its pair
//! and its colliding surfel. A contact that sticks holds ξ = F_t / k_t with no creep; one
//! that slides keeps ξ on Coulomb's cone, `k_t |ξ| = μ N`: in the pipeline's forces
//! ([`super::forces`]) and in the implicit solve ([`crate::solver::active`]), each with
//! its own memory.
//!
//! A key names the pair by its objects' serials ([`Object::serial`]), so a fractured or
//! replaced object starts its contacts afresh; a contact that is not in this step's
//! patches (or solve) is forgotten, and starts again from ξ = 0, as does a force on
//! resampled Φ (`World::resampled_forces`: its surfels have no colliding surfel).
//!
//! [`Object::serial`]: crate::body::object::Object::serial

use super::{ContactSurfel, NO_SURFEL};
use glam::Vec3;

/// A contact across steps: the serials of its patch's objects a and b, whether its
/// colliding surfel is b's, and that surfel's index.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct StickKey {
    pub a: u64,
    pub b: u64,
    pub from_b: bool,
    pub surfel: u32,
}

impl StickKey {
    /// The key of contact surfel `c` of a patch whose objects a and b have the serials
    /// `a` and `b` and b the index `patch_b` ([`ContactPatch::b`](super::ContactPatch::b)); `None` for a surfel
    /// with no colliding surfel.
    pub fn of(a: u64, b: u64, patch_b: usize, c: &ContactSurfel) -> Option<Self> {
        (c.surfel != NO_SURFEL).then_some(Self {
            a,
            b,
            from_b: c.object == patch_b,
            surfel: c.surfel,
        })
    }
}

/// The elongations of the last step's contacts, sorted by key.
#[derive(Clone, Debug, Default)]
pub struct StickMemory {
    entries: Vec<(StickKey, Vec3)>,
    /// The next memory, filled by [`StickMemory::push`] (kept for its buffer).
    next: Vec<(StickKey, Vec3)>,
}

impl StickMemory {
    /// The elongation (m) kept under `key`, or zero.
    pub fn get(&self, key: &StickKey) -> Vec3 {
        match self.entries.binary_search_by(|e| e.0.cmp(key)) {
            Ok(i) => self.entries[i].1,
            Err(_) => Vec3::ZERO,
        }
    }

    /// Records an elongation for the next memory.
    pub fn push(&mut self, key: StickKey, stick: Vec3) {
        self.next.push((key, stick));
    }

    /// Makes the pushed elongations the memory. Each contact is pushed once; a key
    /// pushed twice keeps one of its values. (An unstable sort: it sorts in place, so
    /// the steady step does not allocate.)
    pub fn commit(&mut self) {
        std::mem::swap(&mut self.entries, &mut self.next);
        self.next.clear();
        self.entries.sort_unstable_by_key(|e| e.0);
        self.entries.dedup_by_key(|e| e.0);
    }

    /// Contacts remembered.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    pub fn clear(&mut self) {
        self.entries.clear();
        self.next.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(surfel: u32) -> StickKey {
        StickKey {
            a: 1,
            b: 2,
            from_b: false,
            surfel,
        }
    }

    /// What is committed is found by key, and what is not pushed again is forgotten at
    /// the next commit.
    #[test]
    fn memory_keeps_the_last_commit_only() {
        let mut m = StickMemory::default();
        m.push(key(7), Vec3::Z);
        m.push(key(3), Vec3::Y);
        m.commit();
        assert_eq!(
            (m.get(&key(7)), m.get(&key(3)), m.len()),
            (Vec3::Z, Vec3::Y, 2)
        );
        assert_eq!(m.get(&key(5)), Vec3::ZERO);
        m.push(key(3), Vec3::X);
        m.commit();
        assert_eq!((m.get(&key(7)), m.get(&key(3))), (Vec3::ZERO, Vec3::X));
    }
}
