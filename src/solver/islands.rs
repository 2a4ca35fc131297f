//! Islands: the implicit bodies that the last step's contact springs join, solved
//! together. Every other moving body — explicit, or implicit and alone — steps by
//! itself.

use super::springs::ContactSprings;
use crate::body::object::Object;

/// Per object, the island it belongs to (union–find over the springs).
#[derive(Clone, Debug, Default)]
pub struct Islands {
    /// Per object, its island's root (an object index), `u32::MAX` outside every island
    /// (a static or explicit object).
    root: Vec<u32>,
    /// Per root, the island's size.
    size: Vec<u32>,
}

impl Islands {
    /// The islands of `objects` joined by `springs`: each moving implicit object
    /// ([`Object::is_implicit`]) starts alone, and a spring between two of them joins
    /// their islands.
    pub fn find(&mut self, objects: &[Object], springs: &ContactSprings) {
        let n = objects.len();
        let island = &mut self.root;
        island.clear();
        island.extend(objects.iter().enumerate().map(|(k, o)| {
            if !o.is_static() && o.is_implicit() {
                k as u32
            } else {
                u32::MAX
            }
        }));
        for sp in &springs.springs {
            if let Some(b) = sp.b {
                let (ra, rb) = (root(island, sp.a.object), root(island, b.object));
                if ra != rb && ra != u32::MAX && rb != u32::MAX {
                    island[ra.max(rb) as usize] = ra.min(rb);
                }
            }
        }
        for k in 0..n {
            if island[k] != u32::MAX {
                island[k] = root(island, k as u32);
            }
        }
        self.size.clear();
        self.size.resize(n, 0);
        for &r in island.iter().filter(|&&r| r != u32::MAX) {
            self.size[r as usize] += 1;
        }
    }

    /// The root of object `k`'s island, `None` outside every island.
    pub fn root(&self, k: usize) -> Option<usize> {
        (self.root[k] != u32::MAX).then_some(self.root[k] as usize)
    }

    /// Object `k` is implicit and alone in its island.
    pub fn alone(&self, k: usize) -> bool {
        self.root(k).is_some_and(|r| self.size[r] == 1)
    }

    /// Object `k` shares its island with other bodies.
    pub fn shared(&self, k: usize) -> bool {
        self.root(k).is_some_and(|r| self.size[r] > 1)
    }

    /// Some island holds several bodies.
    pub fn any_shared(&self) -> bool {
        self.size.iter().any(|&s| s > 1)
    }
}

/// The root of `k`'s island (union–find without path compression: islands are small).
fn root(island: &[u32], k: u32) -> u32 {
    let mut k = k;
    while k != u32::MAX && island[k as usize] != k {
        k = island[k as usize];
    }
    k
}
