//! The friction anchors of the contact springs, carried from step to step: each contact
//! surfel's tangential spring elongation ξ (the Cundall–Strack law of discrete-element
//! codes, Cundall and Strack 1979), kept under a key that names the contact by its pair
//! and its colliding surfel. A contact that sticks holds ξ = F_t / k_t with no creep; one
//! that slides keeps ξ on Coulomb's cone, `k_t |ξ| = μ N`: in the pipeline's forces
//! ([`super::forces`]) and in the implicit solve ([`crate::solver::active`]), each with
//! its own memory.
//!
//! A key names the pair by its objects' serials ([`Object::serial`]), so a fractured or
//! replaced object starts its contacts afresh; a contact that has not been in the
//! patches (or solve) for a frame ([`GRACE`]) is forgotten, and starts again from ξ = 0,
//! as does a force on resampled Φ (`World::resampled_forces`: its surfels have no
//! colliding surfel).
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

/// How long (s) a contact's elongation outlives the contact: one frame at 120 Hz, the
/// implicit solve's default step (`solver::DEFAULT_DT`, which a test keeps equal). A
/// contact surfel at the rim of a resting or sliding patch leaves and re-enters the contact set as the bodies vibrate by less
/// than its overlap; forgetting its anchor each time would restart its friction from
/// zero and reload it at `v_t dt` per step, so the shorter the step the weaker the
/// friction. Kept across gaps shorter than a frame, the anchors are what a step of a
/// frame (which cannot see such gaps) has: explicit and implicit stepping agree.
pub const GRACE: f32 = 1.0 / 120.0;

/// One remembered contact: its elongation (m) and how long (s) it has been absent.
#[derive(Clone, Copy, Debug)]
struct Entry {
    key: StickKey,
    stick: Vec3,
    absent: f32,
}

/// The elongations of the recent steps' contacts, sorted by key.
#[derive(Clone, Debug, Default)]
pub struct StickMemory {
    entries: Vec<Entry>,
    /// The next memory, filled by [`StickMemory::push`] (kept for its buffer).
    next: Vec<Entry>,
    /// The merge of the two (kept for its buffer).
    merged: Vec<Entry>,
}

impl StickMemory {
    /// The elongation (m) kept under `key`, or zero.
    pub fn get(&self, key: &StickKey) -> Vec3 {
        match self.entries.binary_search_by(|e| e.key.cmp(key)) {
            Ok(i) => self.entries[i].stick,
            Err(_) => Vec3::ZERO,
        }
    }

    /// Records a present contact's elongation for the next memory (zero: it holds no
    /// anchor, and forgets any it had).
    pub fn push(&mut self, key: StickKey, stick: Vec3) {
        self.next.push(Entry {
            key,
            stick,
            absent: 0.0,
        });
    }

    /// Makes the pushed elongations the memory, after a step of `dt` (s), with the
    /// remembered contacts not pushed again kept while they have been absent for less
    /// than [`GRACE`]. Each contact is pushed once; a key pushed twice keeps one of its
    /// values. (Unstable sorts and kept buffers: the steady step does not allocate.)
    pub fn commit(&mut self, dt: f32) {
        self.next.sort_unstable_by_key(|e| e.key);
        self.next.dedup_by_key(|e| e.key);
        let (old, new, merged) = (&self.entries, &self.next, &mut self.merged);
        merged.clear();
        let carry = |merged: &mut Vec<Entry>, e: &Entry| {
            if e.absent + dt < GRACE {
                merged.push(Entry {
                    absent: e.absent + dt,
                    ..*e
                });
            }
        };
        let (mut i, mut j) = (0, 0);
        while i < old.len() || j < new.len() {
            match (old.get(i), new.get(j)) {
                (Some(o), Some(n)) if o.key == n.key => {
                    merged.push(*n);
                    i += 1;
                    j += 1;
                }
                (Some(o), Some(n)) if o.key < n.key => {
                    carry(merged, o);
                    i += 1;
                }
                (Some(o), None) => {
                    carry(merged, o);
                    i += 1;
                }
                (_, Some(n)) => {
                    merged.push(*n);
                    j += 1;
                }
                (None, None) => break,
            }
        }
        merged.retain(|e| e.stick != Vec3::ZERO);
        std::mem::swap(&mut self.entries, &mut self.merged);
        self.next.clear();
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
        self.merged.clear();
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

    /// What is committed is found by key; what is not pushed again is kept while absent
    /// for less than a frame, then forgotten; a zero pushed forgets at once.
    #[test]
    fn memory_keeps_absent_contacts_for_a_frame() {
        let mut m = StickMemory::default();
        m.push(key(7), Vec3::Z);
        m.push(key(3), Vec3::Y);
        m.commit(1e-3);
        assert_eq!(
            (m.get(&key(7)), m.get(&key(3)), m.len()),
            (Vec3::Z, Vec3::Y, 2)
        );
        assert_eq!(m.get(&key(5)), Vec3::ZERO);
        m.push(key(3), Vec3::X);
        m.commit(1e-3);
        assert_eq!((m.get(&key(7)), m.get(&key(3))), (Vec3::Z, Vec3::X));
        // Key 7 absent since the second commit: gone once absent for GRACE or more.
        let steps = (GRACE / 1e-3).ceil() as usize;
        for _ in 1..steps {
            m.push(key(3), Vec3::X);
            m.commit(1e-3);
        }
        assert_eq!((m.get(&key(7)), m.len()), (Vec3::ZERO, 1));
        m.push(key(3), Vec3::ZERO);
        m.commit(1e-3);
        assert!(m.is_empty());
        // At the frame step itself nothing outlives its contact.
        m.push(key(1), Vec3::X);
        m.commit(GRACE);
        m.commit(GRACE);
        assert!(m.is_empty());
    }
}
