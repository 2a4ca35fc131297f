//! The connectivity graph of an object that may break (Keiser et al. 2004, §4): edges
//! join phyxels closer than the influence radius `h` of either end, and the object
//! breaks when the graph falls into several connected components.
//!
//! The check runs after every step, and almost every time the answer is "still one
//! piece". [`Connectivity`] keeps a *spanning tree* of the graph from its last full
//! count: while each of the tree's `n − 1` edges is still an edge, the tree proves the
//! graph connected, at the cost of `n − 1` distances and no neighbour search. Only when
//! a tree edge stretches past its radius is the graph searched again (over a grid the
//! struct keeps, so a step allocates nothing), which also gives a new tree. The answer
//! is the full count's in every step: the tree only skips searches whose result it
//! already proves.

use crate::columns::Vec3s;
use crate::spatial::grid::Grid;

/// Connected components of a phyxel set: `label[i]` in `0..count`, numbered in the order
/// of their first phyxel (phyxel 0 is always in component 0).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Components {
    pub label: Vec<u32>,
    pub count: usize,
}

/// Components of the graph joining points `i`, `j` with `|x_i − x_j| < max(h_i, h_j)`
/// (`pos` and `radius` = `h`, as in [`crate::points::phyxels::Phyxels`]): one full count.
pub fn components(pos: &Vec3s, radius: &[f32]) -> Components {
    let mut c = Connectivity::default();
    c.count_components(pos, radius);
    c.components()
}

/// The per-object state of the fracture check: the spanning tree of the last full count
/// and the scratch of the next one, reused from step to step.
#[derive(Clone, Debug, Default)]
pub struct Connectivity {
    /// Edges `(i, j)` of a spanning forest of the last full count (`n − count` edges).
    tree: Vec<[u32; 2]>,
    /// Components found by the last full count, and each phyxel's label (one per point
    /// counted: the tree is valid only for this many points).
    count: usize,
    label: Vec<u32>,
    /// Scratch: union-find parents and the label of each root.
    parent: Vec<u32>,
    root_label: Vec<u32>,
    grid: Grid,
    /// Full counts run so far (the tree did not prove the graph connected).
    searches: u64,
}

impl Connectivity {
    /// The number of connected components of the graph over `pos` and `radius` (see
    /// [`components`]): 1 without a search while the last tree holds, else a full count
    /// (whose labels [`Connectivity::components`] then gives).
    pub fn update(&mut self, pos: &Vec3s, radius: &[f32]) -> usize {
        if self.tree_holds(pos, radius) {
            return 1;
        }
        self.count_components(pos, radius)
    }

    /// True when the last full count found one component over the same number of points
    /// and every edge of its tree is still an edge.
    fn tree_holds(&self, pos: &Vec3s, radius: &[f32]) -> bool {
        let n = pos.len();
        if self.count != 1 || self.label.len() != n || self.tree.len() + 1 != n {
            return false;
        }
        let (x, y, z) = (&pos.x[..n], &pos.y[..n], &pos.z[..n]);
        let h = &radius[..n];
        self.tree.iter().all(|&[i, j]| {
            let (i, j) = (i as usize, j as usize);
            let r = h[i].max(h[j]);
            distance2([x[j], y[j], z[j]], [x[i], y[i], z[i]]) < r * r
        })
    }

    /// Counts the components from scratch (grid search and union-find) and keeps a
    /// spanning forest of the graph as the new tree.
    fn count_components(&mut self, pos: &Vec3s, radius: &[f32]) -> usize {
        let n = pos.len();
        self.searches += 1;
        self.tree.clear();
        self.parent.clear();
        self.parent.extend(0..n as u32);
        self.label.clear();
        self.label.resize(n, 0);
        self.count = 0;
        if n == 0 {
            return 0;
        }
        let h = &radius[..n];
        let h_max = h.iter().fold(0.0f32, |a, &b| a.max(b));
        self.grid
            .rebuild_columns(pos, if h_max > 0.0 { h_max } else { 1.0 });
        // Two passes over the same graph: the edges shorter than TREE_SLACK · h first,
        // then the rest, so that the tree is made of short edges where it can be (they
        // take the most stretch before the tree needs a new search). The components do
        // not depend on the order in which union-find sees the edges.
        let (parent, tree) = (&mut self.parent, &mut self.tree);
        for slack in [TREE_SLACK, 1.0] {
            if tree.len() + 1 == n {
                break; // already connected
            }
            for (i, &hi) in h.iter().enumerate() {
                let r = slack * hi;
                let r2 = r * r;
                // Each end queries with its own radius: the edge exists when either sees
                // the other.
                self.grid.for_each_within(pos.get(i), r, |j, d2| {
                    if j != i && d2 < r2 {
                        let (a, b) = (find(parent, i as u32), find(parent, j as u32));
                        if a != b {
                            parent[a.max(b) as usize] = a.min(b);
                            tree.push([i as u32, j as u32]);
                        }
                    }
                });
            }
        }
        self.root_label.clear();
        self.root_label.resize(n, u32::MAX);
        for i in 0..n {
            let r = find(&mut self.parent, i as u32) as usize;
            if self.root_label[r] == u32::MAX {
                self.root_label[r] = self.count as u32;
                self.count += 1;
            }
            self.label[i] = self.root_label[r];
        }
        self.count
    }

    /// The components of the last full count (a copy: taken only when an object splits).
    pub fn components(&self) -> Components {
        Components {
            label: self.label.clone(),
            count: self.count,
        }
    }

    /// Components found by the last [`Connectivity::update`] (0 before the first).
    pub fn count(&self) -> usize {
        self.count
    }

    /// Full counts (neighbour searches) run so far; the other updates were proved
    /// connected by the tree alone.
    pub fn searches(&self) -> u64 {
        self.searches
    }
}

/// Fraction of the influence radius below which edges are preferred for the tree.
const TREE_SLACK: f32 = 0.7;

/// `|a − b|²`, with the grid query's order of operations ([`Grid::for_each_within`]
/// reports this value bit for bit), so that the tree keeps an edge exactly when a
/// search would find it.
#[inline(always)]
fn distance2(a: [f32; 3], b: [f32; 3]) -> f32 {
    let (dx, dy, dz) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    dx * dx + dy * dy + dz * dz
}

/// Union-find root of `i`, halving the path on the way.
fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let p = parent[parent[i as usize] as usize];
        parent[i as usize] = p;
        i = p;
    }
    i
}
