//! Surfel advection: surfels follow the phyxels' MLS displacement field (Müller et al.
//! 2004, §5): `u(s) = Σ w_i (u_i + ∇u_i (s₀ − x₀ᵢ)) / Σ w_i`, normals `n ∝ J⁻ᵀ n₀`
//! with `J = I + Σ w_i ∇u_i / Σ w_i`. Weights use rest positions, so they are fixed
//! and precomputed once.
//!
//! The fast path ([`SurfelBinding::advect`]) rewrites the sum as
//! `u(s) = Σ w_i c_i + (Σ w_i ∇u_i)(s₀ − o)` with the per-phyxel affine term
//! `c_i = u_i − ∇u_i (x₀ᵢ − o)`, tabulated once per step: a binding entry is then just
//! (phyxel, weight), and each surfel sums one 64-byte table row per entry. The reference
//! point `o` is the phyxels' rest centroid, so `c_i` stays small (no f32 cancellation) for
//! objects far from the origin.

use crate::columns::{LANES, load8, store8};
use crate::math::kernel::poly6_shape;
use crate::math::linalg::cofactor;
use crate::par::SURFEL_TASK;
use crate::points::phyxels::Phyxels;
use crate::points::surfels::Surfels;
use crate::spatial::broad_phase::{Aabb, BLOCK};
use crate::spatial::gather::{RowBuffer, Rows};
use crate::spatial::grid::Grid;
use glam::{Mat3, Vec3};
use rayon::prelude::*;
use wide::f32x8;

/// Number of nearest phyxels a surfel binds to when too few lie within its reach.
pub const MIN_BINDING: usize = 4;

/// A surfel binds to the phyxels within `BINDING_FRACTION · h_i` of it at rest.
/// The first-order term `∇u_i (s₀ − x₀ᵢ)` makes the field exact for affine motion with
/// any neighbours, so a reach of about 1.5 phyxel spacings suffices and costs a tenth
/// of the full influence radius (docs/ARCHITECTURE.md).
pub const BINDING_FRACTION: f32 = 0.5;

/// Surfels advected per parallel task: large enough to amortise rayon's scheduling,
/// small enough to balance two objects on two cores. A task is a block of the broad
/// phase, whose box it takes while it writes the positions ([`SurfelBinding::block_boxes`]).
const CHUNK: usize = BLOCK;

/// Relative slack of a stale block's box ([`SurfelBinding::prepare`]) over the exact
/// image of its rest box: covers the f32 rounding of the advected positions (a few
/// units in the last place, 6e-8 each) with room to spare.
const BOUND_SLACK: f32 = 1.0e-5;

/// One phyxel's advection terms for this step, `[c_i, ∇u_i (columns), v_i, 0]`, as two
/// 8-lane rows so a weighted sum over a row is two multiply-adds per entry (plain `f32`
/// arrays, so that a zeroed table is allocated without writing it: `crate::spatial::gather`).
type AffineRow = [[f32; 8]; 2];

/// Fixed binding of each surfel to nearby phyxels, with normalised weights, in lane
/// layout: eight consecutive surfels form a group, and slot `s` of a group holds entry
/// `s` of each of the eight at `8 s + lane` (rows in ascending phyxel order; shorter
/// rows padded with weight 0 on their own last phyxel). The advection sums a group's
/// eight rows side by side, eight independent chains with one trip count per group,
/// instead of one surfel's short loop after another (whose exit, at 4, 5 or 6 entries,
/// the branch predictor keeps missing).
#[derive(Clone, Debug, Default)]
pub struct SurfelBinding {
    /// Slots of group g: `slot_off[g]..slot_off[g + 1]`.
    slot_off: Vec<u32>,
    /// Bound phyxel per slot lane.
    index: Vec<u32>,
    /// Its normalised weight (0 in padding).
    weight: Vec<f32>,
    /// Reference point `o` of the affine table (rest centroid of the phyxels).
    origin: Vec3,
    /// Per-phyxel [`AffineRow`]s of the current step, kept between steps so the step
    /// does not allocate; a [`RowBuffer`], so that the sums' gathers need no bounds
    /// checks (`crate::spatial::gather`).
    table: RowBuffer<AffineRow>,
    /// Surfel and phyxel counts of the rest shape it was built from.
    surfels: usize,
    phyxels: usize,
    /// Per block of [`BLOCK`] surfels, a box holding its positions: their box as the
    /// last advection (or the build) wrote them, or, while the block is stale, the box
    /// they will have when it is advected ([`Self::prepare`]).
    block_boxes: Vec<Aabb>,
    /// Per block, whether its positions are behind the current table
    /// ([`Self::prepare`] marks every block; advecting it clears the mark).
    stale: Vec<bool>,
    /// Blocks still stale.
    stale_blocks: usize,
    /// Per block, the centre and half extent of its surfels' rest box.
    rest_box: Vec<(Vec3, Vec3)>,
    /// Per block `b`, the distinct phyxels its surfels bind to:
    /// `block_phyxels[block_off[b]..block_off[b + 1]]`.
    block_off: Vec<u32>,
    block_phyxels: Vec<u32>,
}

/// Weighted sums of the table rows of a group's eight surfels, each in its entry order
/// (padding adds `0 · row`).
#[inline(always)]
fn group_sums(
    table: &impl Rows<AffineRow>,
    index: &[u32],
    weight: &[f32],
    slots: std::ops::Range<usize>,
) -> ([f32x8; LANES], [f32x8; LANES]) {
    let (mut a, mut b) = ([f32x8::ZERO; LANES], [f32x8::ZERO; LANES]);
    for s in slots {
        let at = s * LANES;
        let (index, weight) = (&index[at..at + LANES], &weight[at..at + LANES]);
        for l in 0..LANES {
            let row = table.row(index[l]);
            let w = f32x8::splat(weight[l]);
            a[l] += w * f32x8::from(row[0]);
            b[l] += w * f32x8::from(row[1]);
        }
    }
    (a, b)
}

impl SurfelBinding {
    /// The surfel and phyxel counts it was built for.
    pub fn counts(&self) -> (usize, usize) {
        (self.surfels, self.phyxels)
    }

    /// Binds every surfel to the phyxels within [`BINDING_FRACTION`] of their influence
    /// radius at rest, or to its [`MIN_BINDING`] nearest phyxels when fewer lie there.
    ///
    /// The binding belongs to the rest shape it was built from: renewing the rest
    /// positions of surfels or phyxels needs a new binding.
    pub fn build(surfels: &Surfels, phyxels: &Phyxels) -> Self {
        let mut b = Self {
            surfels: surfels.len(),
            phyxels: phyxels.len(),
            block_boxes: (0..surfels.len().div_ceil(BLOCK))
                .map(|k| {
                    let r = k * BLOCK..((k + 1) * BLOCK).min(surfels.len());
                    let p = &surfels.pos;
                    Aabb::of_columns(&p.x[r.clone()], &p.y[r.clone()], &p.z[r])
                })
                .collect(),
            ..Default::default()
        };
        if phyxels.is_empty() {
            b.slot_off = vec![0; surfels.len().div_ceil(LANES) + 1];
            b.index_blocks(surfels);
            return b;
        }
        let centroid = phyxels
            .rest
            .iter()
            .fold(glam::DVec3::ZERO, |a, x| a + x.as_dvec3())
            / phyxels.len() as f64;
        b.origin = centroid.as_vec3();
        let grid: Grid = phyxels.rest_grid();
        let reach = grid.cell() * BINDING_FRACTION;
        let rows: Vec<Vec<(u32, f32)>> = (0..surfels.len())
            .into_par_iter()
            .map(|s| {
                let x = surfels.rest.get(s);
                let mut row = Vec::new();
                grid.for_each_within(x, reach, |i, d2| {
                    let w = poly6_shape(d2, phyxels.radius[i] * BINDING_FRACTION);
                    if w > 0.0 {
                        row.push((i as u32, w));
                    }
                });
                if row.len() < MIN_BINDING {
                    row.clear();
                    let mut knn = Vec::new();
                    grid.k_nearest(x, MIN_BINDING, &mut knn);
                    let h = knn.last().map_or(1.0, |e| e.1.sqrt()) * 1.5 + 1e-12;
                    for (i, d2) in knn {
                        row.push((i as u32, poly6_shape(d2, h)));
                    }
                }
                row.sort_unstable_by_key(|e| e.0);
                let sum: f32 = row.iter().map(|e| e.1).sum();
                row.iter_mut().for_each(|e| e.1 /= sum);
                row
            })
            .collect();
        b.slot_off.push(0);
        for group in rows.chunks(LANES) {
            let slots = group.iter().map(Vec::len).max().unwrap_or(0);
            for s in 0..slots {
                for l in 0..LANES {
                    let row = group.get(l).map_or(&[][..], |r| &r[..]);
                    let (i, w) = match row.get(s) {
                        Some(&e) => e,
                        None => (row.last().map_or(0, |e| e.0), 0.0),
                    };
                    b.index.push(i);
                    b.weight.push(w);
                }
            }
            b.slot_off
                .push(b.slot_off.last().copied().unwrap_or(0) + slots as u32);
        }
        b.index_blocks(surfels);
        b
    }

    /// Each block's rest box and the distinct phyxels its surfels bind to: what
    /// [`Self::prepare`] bounds the block's positions by.
    fn index_blocks(&mut self, surfels: &Surfels) {
        let n = surfels.len();
        let blocks = n.div_ceil(BLOCK);
        self.stale = vec![false; blocks];
        self.stale_blocks = 0;
        self.rest_box = (0..blocks)
            .map(|k| {
                let r = k * BLOCK..((k + 1) * BLOCK).min(n);
                let p = &surfels.rest;
                let b = Aabb::of_columns(&p.x[r.clone()], &p.y[r.clone()], &p.z[r]);
                ((b.min + b.max) * 0.5, (b.max - b.min) * 0.5)
            })
            .collect();
        self.block_off = vec![0];
        self.block_phyxels.clear();
        let mut list = Vec::new();
        for k in 0..blocks {
            let groups = k * BLOCK / LANES..((k + 1) * BLOCK).min(n).div_ceil(LANES);
            let slots = self.slot_off[groups.start] as usize..self.slot_off[groups.end] as usize;
            list.clear();
            // Padding repeats a row's own phyxel with weight 0: no phyxel beyond the rows'.
            list.extend_from_slice(&self.index[slots.start * LANES..slots.end * LANES]);
            list.sort_unstable();
            list.dedup();
            self.block_phyxels.extend_from_slice(&list);
            self.block_off.push(self.block_phyxels.len() as u32);
        }
    }

    /// The box of each block of [`BLOCK`] surfels (block `k` holds surfels
    /// `k·BLOCK..`) as the last [`Self::advect`] wrote their positions, or as they were
    /// when the binding was built: the broad phase's object boxes and scans use them
    /// instead of reading every position again, while the positions are unchanged.
    pub fn block_boxes(&self) -> &[Aabb] {
        &self.block_boxes
    }

    /// The union of the boxes of the blocks that are not stale (exact boxes).
    pub fn current_box(&self) -> Aabb {
        self.block_boxes
            .iter()
            .zip(&self.stale)
            .filter(|(_, s)| !**s)
            .fold(Aabb::EMPTY, |a, (b, _)| a.union(b))
    }

    /// True when no block is stale: every surfel is where the last table puts it.
    pub fn is_current(&self) -> bool {
        self.stale_blocks == 0
    }

    /// Surfel `s`'s binding entries (phyxel, normalised weight) in ascending phyxel order.
    fn entries(&self, s: usize) -> impl Iterator<Item = (u32, f32)> + '_ {
        let (g, l) = (s / LANES, s % LANES);
        (self.slot_off[g] as usize..self.slot_off[g + 1] as usize)
            .map(move |k| (self.index[k * LANES + l], self.weight[k * LANES + l]))
            .filter(|e| e.1 != 0.0)
    }

    /// Moves surfels, their normals and velocities with the phyxels, given the
    /// displacement gradient of every phyxel.
    ///
    /// Same field as `crate::testing::advect_reference` up to f32 round-off, computed from a
    /// per-phyxel affine table and written straight into the surfel columns.
    pub fn advect(&mut self, surfels: &mut Surfels, phyxels: &Phyxels, grad: &[Mat3]) {
        self.tabulate(phyxels, grad);
        // Every block is written next: no bound needed.
        self.mark_stale();
        self.advect_blocks(surfels, |_, _| true);
    }

    /// Tabulates this step's field from the phyxels and marks every block stale, its box
    /// now the box its positions will have ([`Self::block_boxes`]): the image of the
    /// block's rest box under each bound phyxel's affine map `s₀ ↦ s₀ + c_i + ∇u_i (s₀ − o)`
    /// holds the block's positions, which are convex combinations of those maps (weights
    /// are non-negative and sum to one). [`Self::advect_blocks`] then moves the blocks a
    /// step needs.
    pub fn prepare(&mut self, phyxels: &Phyxels, grad: &[Mat3]) {
        self.tabulate(phyxels, grad);
        self.bound_blocks();
        self.mark_stale();
    }

    fn mark_stale(&mut self) {
        self.stale.fill(true);
        self.stale_blocks = self.stale.len();
    }

    /// The table of this step's per-phyxel affine terms ([`AffineRow`]).
    fn tabulate(&mut self, phyxels: &Phyxels, grad: &[Mat3]) {
        let o = self.origin;
        if !self.table.serves(phyxels.len()) {
            // Zeroed, not written: the rows past the phyxels' are never touched.
            self.table = RowBuffer::zeroed(phyxels.len());
        }
        self.table[..phyxels.len()]
            .par_chunks_mut(CHUNK)
            // A row costs what a surfel's advection does: tasks of SURFEL_TASK rows.
            .with_min_len(SURFEL_TASK.div_ceil(CHUNK))
            .enumerate()
            .for_each(|(c, rows)| {
                for (k, row) in rows.iter_mut().enumerate() {
                    let i = c * CHUNK + k;
                    let x0 = phyxels.rest.get(i);
                    let g = grad[i];
                    let ci = (phyxels.pos.get(i) - x0) - g * (x0 - o);
                    let v = phyxels.vel.get(i);
                    let (gx, gy, gz) = (g.x_axis, g.y_axis, g.z_axis);
                    *row = [
                        [ci.x, ci.y, ci.z, gx.x, gx.y, gx.z, gy.x, gy.y],
                        [gy.z, gz.x, gz.y, gz.z, v.x, v.y, v.z, 0.0],
                    ];
                }
            });
    }

    /// Each block's box from the table: the union of its rest box's images under the
    /// affine maps of the phyxels it binds to ([`Self::prepare`]).
    fn bound_blocks(&mut self) {
        let o = self.origin;
        let table = &self.table;
        let (offsets, list) = (&self.block_off, &self.block_phyxels);
        self.block_boxes
            .par_iter_mut()
            .zip(self.rest_box.par_iter())
            // Tasks of SURFEL_TASK surfels' blocks, as `advect_blocks`.
            .with_min_len(SURFEL_TASK.div_ceil(BLOCK))
            .enumerate()
            .for_each(|(k, (bound, &(m, e)))| {
                let mut b = Aabb::EMPTY;
                for &i in &list[offsets[k] as usize..offsets[k + 1] as usize] {
                    let [r0, r1] = table[i as usize];
                    let g = Mat3::from_cols_array(&[
                        r0[3], r0[4], r0[5], r0[6], r0[7], r1[0], r1[1], r1[2], r1[3],
                    ]);
                    let centre = m + Vec3::new(r0[0], r0[1], r0[2]) + g * (m - o);
                    let j = Mat3::IDENTITY + g;
                    let half = Mat3::from_cols(j.x_axis.abs(), j.y_axis.abs(), j.z_axis.abs()) * e;
                    b = b.union(&Aabb {
                        min: centre - half,
                        max: centre + half,
                    });
                }
                // The positions are summed in f32: a few units in the last place of the
                // coordinates' size beyond the exact image.
                let size = b.min.abs().max(b.max.abs()).max_element() + e.max_element();
                let slack = Vec3::splat(BOUND_SLACK * size);
                *bound = if b.min.is_finite() && b.max.is_finite() {
                    Aabb {
                        min: b.min - slack,
                        max: b.max + slack,
                    }
                } else if b == Aabb::EMPTY {
                    b
                } else {
                    Aabb::NON_FINITE
                };
            });
    }

    /// Advects the stale blocks for which `pick(block, box)` holds (the box that
    /// [`Self::block_boxes`] gives), writing each one's exact box; returns the surfels
    /// moved.
    pub fn advect_blocks(
        &mut self,
        surfels: &mut Surfels,
        pick: impl Fn(usize, &Aabb) -> bool + Sync,
    ) -> usize {
        if self.stale_blocks == 0 {
            return 0;
        }
        let o = self.origin;
        let surfels_len = surfels.len();
        let Surfels {
            pos,
            rest,
            normal,
            rest_normal,
            vel,
            ..
        } = surfels;
        let (table, index, weight, slot_off) =
            (&self.table, &self.index, &self.weight, &self.slot_off);
        let boxes = &mut self.block_boxes;
        debug_assert_eq!(boxes.len(), surfels_len.div_ceil(CHUNK));
        let done = pos
            .par_chunks_mut(CHUNK)
            .zip(normal.par_chunks_mut(CHUNK))
            .zip(vel.par_chunks_mut(CHUNK))
            .zip(boxes.par_iter_mut())
            .zip(self.stale.par_iter_mut())
            .with_min_len(SURFEL_TASK.div_ceil(CHUNK))
            .enumerate()
            .filter(|(c, ((_, block), stale))| **stale && pick(*c, block))
            .map(|(c, ((((p, n), v), block), stale))| {
                *stale = false;
                let first = c * CHUNK;
                let len = p.0.len();
                let (rx, ry, rz) = (
                    &rest.x[first..first + len],
                    &rest.y[first..first + len],
                    &rest.z[first..first + len],
                );
                let (nx, ny, nz) = (
                    &rest_normal.x[first..first + len],
                    &rest_normal.y[first..first + len],
                    &rest_normal.z[first..first + len],
                );
                // The sums of the eight surfels from `k` on (chunks are whole groups).
                // The table through a view whose gathers need no bounds checks
                // (`crate::spatial::gather`): the chunk's loops are compiled for each kind.
                crate::with_rows!(&table[..], |rows| {
                    let sums = |k: usize| {
                        let g = (first + k) / LANES;
                        let slots = slot_off[g] as usize..slot_off[g + 1] as usize;
                        group_sums(&rows, index, weight, slots)
                    };
                    // Eight surfels at a time: sums per surfel, then the closing
                    // arithmetic (cofactor, normalisation) across lanes, in the scalar
                    // tail's order of operations, so both give the same bits.
                    let groups = len / LANES * LANES;
                    for k in (0..groups).step_by(LANES) {
                        // The eight surfels' sums, transposed to lanes: column j of the
                        // table rows is `lane(j)`.
                        let (first, second) = sums(k);
                        let (first, second) = (f32x8::transpose(first), f32x8::transpose(second));
                        let lane = |j: usize| if j < 8 { first[j] } else { second[j - 8] };
                        let s0 = [load8(rx, k), load8(ry, k), load8(rz, k)];
                        let d = [s0[0] - o.x, s0[1] - o.y, s0[2] - o.z];
                        // g column-major, as Mat3::from_cols_array.
                        let g: [f32x8; 9] = std::array::from_fn(|j| lane(3 + j));
                        let mul = |m: &[f32x8; 9], v: &[f32x8; 3]| -> [f32x8; 3] {
                            std::array::from_fn(|r| m[r] * v[0] + m[3 + r] * v[1] + m[6 + r] * v[2])
                        };
                        let gd = mul(&g, &d);
                        for r in 0..3 {
                            let pos = s0[r] + (lane(r) + gd[r]);
                            store8([&mut *p.0, &mut *p.1, &mut *p.2][r], k, pos);
                            store8([&mut *v.0, &mut *v.1, &mut *v.2][r], k, lane(12 + r));
                        }
                        let j: [f32x8; 9] = std::array::from_fn(|e| {
                            let id = if e % 4 == 0 { f32x8::ONE } else { f32x8::ZERO };
                            id + g[e]
                        });
                        let cross = |a: usize, b: usize| -> [f32x8; 3] {
                            let (a, b) = (&j[3 * a..3 * a + 3], &j[3 * b..3 * b + 3]);
                            [
                                a[1] * b[2] - b[1] * a[2],
                                a[2] * b[0] - b[2] * a[0],
                                a[0] * b[1] - b[0] * a[1],
                            ]
                        };
                        let (c0, c1, c2) = (cross(1, 2), cross(2, 0), cross(0, 1));
                        let cof = [
                            c0[0], c0[1], c0[2], c1[0], c1[1], c1[2], c2[0], c2[1], c2[2],
                        ];
                        let m = mul(&cof, &[load8(nx, k), load8(ny, k), load8(nz, k)]);
                        // Vec3::try_normalize, lane-wise.
                        let rcp = f32x8::ONE / (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
                        let ok = rcp.is_finite() & rcp.simd_gt(f32x8::ZERO);
                        for (r, n) in [&mut *n.0, &mut *n.1, &mut *n.2].into_iter().enumerate() {
                            let old = load8(n, k);
                            store8(n, k, ok.select(m[r] * rcp, old));
                        }
                    }
                    let (tail_a, tail_b) = if groups < len {
                        sums(groups)
                    } else {
                        Default::default()
                    };
                    for k in groups..len {
                        let (a, b) = (tail_a[k - groups].to_array(), tail_b[k - groups].to_array());
                        let g = Mat3::from_cols_array(&[
                            a[3], a[4], a[5], a[6], a[7], b[0], b[1], b[2], b[3],
                        ]);
                        let s0 = Vec3::new(rx[k], ry[k], rz[k]);
                        let u = Vec3::new(a[0], a[1], a[2]) + g * (s0 - o);
                        let p_new = s0 + u;
                        // J⁻ᵀ n₀ ∝ cof(J) n₀ (cofactor avoids dividing by det J; sign kept for det > 0).
                        let cof = cofactor(Mat3::IDENTITY + g);
                        if let Some(n_new) = (cof * Vec3::new(nx[k], ny[k], nz[k])).try_normalize()
                        {
                            (n.0[k], n.1[k], n.2[k]) = (n_new.x, n_new.y, n_new.z);
                        }
                        (p.0[k], p.1[k], p.2[k]) = (p_new.x, p_new.y, p_new.z);
                        (v.0[k], v.1[k], v.2[k]) = (b[4], b[5], b[6]);
                    }
                });
                // The block's box while its positions are still in cache: the broad
                // phase and the scans then need not read them all again.
                *block = Aabb::of_columns(p.0, p.1, p.2);
                (1, len)
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        self.stale_blocks -= done.0;
        done.1
    }

    /// The direct sum of Müller et al. (2004, §5) per surfel and entry, with the rest
    /// offset `s₀ − x₀ᵢ`: the reference for tests and benches of [`Self::advect`]
    /// (it allocates its output).
    pub(crate) fn advect_reference(&self, surfels: &mut Surfels, phyxels: &Phyxels, grad: &[Mat3]) {
        let out: Vec<(Vec3, Vec3, Vec3)> = (0..surfels.len())
            .into_par_iter()
            .map(|s| {
                let s0 = surfels.rest.get(s);
                let (mut u, mut g, mut v) = (Vec3::ZERO, Mat3::ZERO, Vec3::ZERO);
                for (i, w) in self.entries(s) {
                    let i = i as usize;
                    let ui = phyxels.pos.get(i) - phyxels.rest.get(i);
                    u += w * (ui + grad[i] * (s0 - phyxels.rest.get(i)));
                    g += grad[i] * w;
                    v += w * phyxels.vel.get(i);
                }
                let j = Mat3::IDENTITY + g;
                let n0 = surfels.rest_normal.get(s);
                // J⁻ᵀ n₀ ∝ cof(J) n₀ (cofactor avoids dividing by det J; sign kept for det > 0).
                let cof = cofactor(j);
                let n = (cof * n0).try_normalize().unwrap_or(surfels.normal.get(s));
                (s0 + u, n, v)
            })
            .collect();
        surfels.pos.par_set_from(&out, |o| o.0);
        surfels.normal.par_set_from(&out, |o| o.1);
        surfels.vel.par_set_from(&out, |o| o.2);
    }
}
