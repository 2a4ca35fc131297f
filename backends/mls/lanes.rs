//! The MLS force kernel in lanes: eight phyxels per `f32x8`.
//!
//! Both sums of the method are sparse: the gradient `∇u_i = Σ_j (u_j − u_i) d_ijᵀ` over
//! row i of the stencil, and the force `f_j = P_j d_j + Σ_i P_i d_ij` over the rows that
//! name j. Each is stored as a [`Sliced`] table (the "sliced ELLPACK" layout of sparse
//! SIMD kernels): eight consecutive phyxels form a group, slot `s` of a group holds
//! entry `s` of each of the eight at `8 s + lane`, and shorter lists are padded with
//! entries that weigh zero.
//!
//! The stress pass gathers the state `[u, v]` of a slot's eight neighbours (eight
//! aligned row loads and one lane transpose), accumulates eight gradients with lane
//! multiply-adds, and evaluates the constitutive law on eight 3×3 matrices at once
//! ([`M3`]). The force pass gathers the eight `P_i` of a slot the same way and adds
//! `P_i d_ij`, own term first and then the rows in increasing order: the scalar
//! reference's order, so the sums are deterministic and need no atomics.
//! The scalar reference is `MlsDynamics::compute_forces_reference`.

use super::Law;
use glam::Mat3;
use phyxel::columns::{LANES, Vec3s, load8, store8};
use phyxel::dynamics::gradient::MlsStencil;
use phyxel::par;
use phyxel::spatial::gather::Rows;
use wide::f32x8;

/// Groups handled serially by one rayon task: a pass splits only into halves of at least
/// [`par::point_task`] phyxels, and whole windows.
fn group_grain() -> usize {
    (2 * par::point_task() / LANES).max(2 * WINDOW_GROUPS)
}

/// Stress `P` of a phyxel as 16 floats (9 used): two aligned lane rows.
pub type StressRow = [f32; 16];

/// Phyxels per window: within a window, a table's lanes take the phyxels in order of
/// list length, so the eight lists of a group have nearly equal lengths and the group
/// pads little (its slot count is its longest list). Windows are whole groups, and the
/// parallel split never cuts one, so a task writes only its own phyxels.
const WINDOW: usize = 64;
const WINDOW_GROUPS: usize = WINDOW / LANES;
const _: () = assert!(WINDOW.is_multiple_of(LANES));

/// A sparse table in lane layout: per group of eight lanes, a few slots of eight
/// (index, weight) entries. Lane position `p` (group `p / 8`, lane `p % 8`) holds the
/// list of phyxel `order[p]`.
#[derive(Clone, Debug, Default)]
struct Sliced {
    /// Slots of group g: `slot_off[g]..slot_off[g + 1]`.
    slot_off: Vec<u32>,
    /// Index per slot lane (`pad(order[p])` in padding entries).
    index: Vec<u32>,
    /// Weight vector per slot lane, one column per axis (zero in padding entries).
    w: [Vec<f32>; 3],
    /// The phyxel of each lane position, padded to whole groups (`order[p] = p` past the
    /// last phyxel); a permutation of its window.
    order: Vec<u32>,
}

impl Sliced {
    /// The table of `lists(i)` for phyxels `0..n`; padding entries get the index
    /// `pad(i)` of their lane's phyxel `i` (and weight zero).
    fn new<I: Iterator<Item = (u32, glam::Vec3)>>(
        n: usize,
        lists: impl Fn(usize) -> I,
        pad: impl Fn(usize) -> u32,
    ) -> Self {
        let groups = n.div_ceil(LANES);
        let len: Vec<usize> = (0..n).map(|i| lists(i).count()).collect();
        let mut order: Vec<u32> = (0..(groups * LANES) as u32).collect();
        for window in order[..n].chunks_mut(WINDOW) {
            window.sort_by_key(|&i| len[i as usize]);
        }
        let mut slot_off = Vec::with_capacity(groups + 1);
        slot_off.push(0u32);
        for g in 0..groups {
            let longest = order[g * LANES..(g + 1) * LANES]
                .iter()
                .filter(|&&i| (i as usize) < n)
                .map(|&i| len[i as usize])
                .max()
                .unwrap_or(0);
            slot_off.push(slot_off[g] + longest as u32);
        }
        let entries = *slot_off.last().unwrap_or(&0) as usize * LANES;
        let mut index = vec![0u32; entries];
        let mut w = [
            vec![0.0f32; entries],
            vec![0.0f32; entries],
            vec![0.0f32; entries],
        ];
        for g in 0..groups {
            let slots = slot_off[g] as usize..slot_off[g + 1] as usize;
            for lane in 0..LANES {
                let i = order[g * LANES + lane] as usize;
                let own = if i < n { pad(i) } else { i as u32 };
                for s in slots.clone() {
                    index[s * LANES + lane] = own;
                }
                if i >= n {
                    continue;
                }
                for (s, (j, wj)) in slots.clone().zip(lists(i)) {
                    let at = s * LANES + lane;
                    index[at] = j;
                    (w[0][at], w[1][at], w[2][at]) = (wj.x, wj.y, wj.z);
                }
            }
        }
        Self {
            slot_off,
            index,
            w,
            order,
        }
    }

    /// The phyxels of group `g`'s lanes.
    #[inline(always)]
    fn phyxels(&self, g: usize) -> [u32; LANES] {
        self.order[g * LANES..(g + 1) * LANES]
            .try_into()
            .expect("whole groups")
    }

    fn slots(&self, g: usize) -> std::ops::Range<usize> {
        self.slot_off[g] as usize..self.slot_off[g + 1] as usize
    }

    #[inline(always)]
    fn weight(&self, s: usize) -> [f32x8; 3] {
        let at = s * LANES;
        [
            load8(&self.w[0], at),
            load8(&self.w[1], at),
            load8(&self.w[2], at),
        ]
    }

    #[inline(always)]
    fn indices(&self, s: usize) -> &[u32] {
        &self.index[s * LANES..(s + 1) * LANES]
    }
}

/// The stencil in lane layout: rows for the gradients, transposed lists for the forces.
#[derive(Clone, Debug, Default)]
pub struct LaneStencil {
    /// Number of phyxels.
    n: usize,
    /// Row i: neighbours j and `d_ij`.
    rows: Sliced,
    /// Phyxel j: `(j, d_j)` first, then the rows i that name j with `d_ij`.
    targets: Sliced,
}

impl LaneStencil {
    /// The lane layout of `st`; `incoming` lists `(i, k)` per phyxel j as
    /// `MlsDynamics` keeps them (rows in increasing order).
    pub fn new(st: &MlsStencil, in_off: &[u32], incoming: &[(u32, u32)]) -> Self {
        let n = st.len();
        let rows = Sliced::new(
            n,
            |i| st.row(i).map(|k| (st.neighbours[k], st.d[k])),
            |i| i as u32,
        );
        // The stress pass writes `P` at its lane positions: the force lists name those.
        let mut position = vec![0u32; rows.order.len()];
        for (p, &i) in rows.order.iter().enumerate() {
            position[i as usize] = p as u32;
        }
        let targets = Sliced::new(
            n,
            |j| {
                let own = std::iter::once((position[j], st.d_self[j]));
                own.chain(
                    incoming[in_off[j] as usize..in_off[j + 1] as usize]
                        .iter()
                        .map(|&(i, k)| (position[i as usize], st.d[k as usize])),
                )
            },
            |j| position[j],
        );
        Self { n, rows, targets }
    }

    /// Phyxels rounded up to whole groups: the rows of the state and stress buffers the
    /// kernel writes and reads (the buffers themselves have `gather::fixed_rows` of it).
    pub fn padded(&self) -> usize {
        self.n.div_ceil(LANES) * LANES
    }

    fn groups(&self) -> usize {
        self.rows.slot_off.len() - 1
    }
}

/// Eight 3×3 matrices, column-major like glam (`c[3 col + row]`).
#[derive(Clone, Copy)]
pub struct M3 {
    c: [f32x8; 9],
}

impl M3 {
    const ZERO: Self = Self {
        c: [f32x8::ZERO; 9],
    };

    #[inline(always)]
    fn at(&self, row: usize, col: usize) -> f32x8 {
        self.c[3 * col + row]
    }

    #[inline(always)]
    fn identity_plus(mut self) -> Self {
        for k in 0..3 {
            self.c[4 * k] += f32x8::ONE;
        }
        self
    }

    #[inline(always)]
    fn add(mut self, o: &Self) -> Self {
        (0..9).for_each(|k| self.c[k] += o.c[k]);
        self
    }

    #[inline(always)]
    fn sub(mut self, o: &Self) -> Self {
        (0..9).for_each(|k| self.c[k] -= o.c[k]);
        self
    }

    #[inline(always)]
    fn scale(mut self, s: f32x8) -> Self {
        (0..9).for_each(|k| self.c[k] *= s);
        self
    }

    #[inline(always)]
    fn transpose(&self) -> Self {
        Self {
            c: std::array::from_fn(|k| self.at(k / 3, k % 3)),
        }
    }

    /// `self · o`.
    #[inline(always)]
    fn mul(&self, o: &Self) -> Self {
        Self {
            c: std::array::from_fn(|k| {
                let (row, col) = (k % 3, k / 3);
                let s = self.at(row, 0) * o.at(0, col);
                let s = self.at(row, 1).mul_add(o.at(1, col), s);
                self.at(row, 2).mul_add(o.at(2, col), s)
            }),
        }
    }

    /// `selfᵀ · o`.
    #[inline(always)]
    fn tr_mul(&self, o: &Self) -> Self {
        Self {
            c: std::array::from_fn(|k| {
                let (row, col) = (k % 3, k / 3);
                let s = self.at(0, row) * o.at(0, col);
                let s = self.at(1, row).mul_add(o.at(1, col), s);
                self.at(2, row).mul_add(o.at(2, col), s)
            }),
        }
    }

    /// `self += a bᵀ`.
    #[inline(always)]
    fn add_outer(&mut self, a: [f32x8; 3], b: [f32x8; 3]) {
        for (col, bc) in b.into_iter().enumerate() {
            for (row, ar) in a.into_iter().enumerate() {
                self.c[3 * col + row] = ar.mul_add(bc, self.c[3 * col + row]);
            }
        }
    }

    #[inline(always)]
    fn trace(&self) -> f32x8 {
        self.c[0] + self.c[4] + self.c[8]
    }

    #[inline(always)]
    fn frobenius(&self) -> f32x8 {
        let mut s = f32x8::ZERO;
        for v in self.c {
            s += v * v;
        }
        s.sqrt()
    }

    #[inline(always)]
    fn col(&self, col: usize) -> [f32x8; 3] {
        [self.c[3 * col], self.c[3 * col + 1], self.c[3 * col + 2]]
    }

    /// Cofactor matrix, columns `[J₂×J₃, J₃×J₁, J₁×J₂]` (as [`phyxel::math::linalg::cofactor`]).
    #[inline(always)]
    fn cofactor(&self) -> Self {
        let cross = |a: [f32x8; 3], b: [f32x8; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let (x, y, z) = (self.col(0), self.col(1), self.col(2));
        let (c0, c1, c2) = (cross(y, z), cross(z, x), cross(x, y));
        Self {
            c: [
                c0[0], c0[1], c0[2], c1[0], c1[1], c1[2], c2[0], c2[1], c2[2],
            ],
        }
    }

    /// `det(I + self) − 1 = tr + I₂ + det` (as `law::det_minus_one`).
    #[inline(always)]
    fn det_minus_one(&self) -> f32x8 {
        let a = |r: usize, c: usize| self.at(r, c);
        let i2 = (a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0))
            + (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
            + (a(0, 0) * a(2, 2) - a(0, 2) * a(2, 0));
        self.trace() + i2 + self.determinant()
    }

    /// `det = x · (y × z)` over the columns.
    #[inline(always)]
    fn determinant(&self) -> f32x8 {
        let (x, y, z) = (self.col(0), self.col(1), self.col(2));
        x[0] * (y[1] * z[2] - y[2] * z[1])
            + x[1] * (y[2] * z[0] - y[0] * z[2])
            + x[2] * (y[0] * z[1] - y[1] * z[0])
    }

    /// Lanes from the matrices `ms[at[l]]` of the lanes `l < count` (the others zero).
    fn load(ms: &[Mat3], at: &[usize; LANES], count: usize) -> Self {
        let mut a = [[0.0f32; 8]; 9];
        for (lane, &i) in at.iter().enumerate().take(count) {
            for (k, v) in ms[i].to_cols_array().into_iter().enumerate() {
                a[k][lane] = v;
            }
        }
        Self {
            c: a.map(f32x8::from),
        }
    }

    /// Writes lane `l` to `out[at[l]]`, for the lanes `l < count`.
    fn store(&self, out: &mut [Mat3], at: &[usize; LANES], count: usize) {
        let a = self.c.map(|v| v.to_array());
        for (lane, &i) in at.iter().enumerate().take(count) {
            out[i] = Mat3::from_cols_array(&std::array::from_fn(|k| a[k][lane]));
        }
    }
}

/// The constitutive law on eight phyxels: the formulas of the scalar `Law` methods.
impl Law {
    #[inline(always)]
    fn lane_hooke(&self, e: &M3) -> M3 {
        let diag = f32x8::splat(self.lambda) * e.trace();
        let mut s = e.scale(f32x8::splat(2.0 * self.mu));
        for k in 0..3 {
            s.c[4 * k] += diag;
        }
        s
    }

    /// The strain of displacement gradient `g`: `g + gᵀ + gᵀg` (= `JᵀJ − I`, without
    /// forming `J`: see `Law::strain`).
    #[inline(always)]
    fn lane_strain(&self, g: &M3) -> M3 {
        let c = g.add(&g.transpose()).add(&g.tr_mul(g));
        if self.paper {
            c
        } else {
            c.scale(f32x8::splat(0.5))
        }
    }

    /// `P` of eight phyxels and their strain norms; updates `plastic` when given.
    #[inline(always)]
    fn lane_stress_force(
        &self,
        grad: &M3,
        vel_grad: Option<&M3>,
        plastic: Option<&mut M3>,
        volume: f32x8,
    ) -> (M3, f32x8) {
        let j = grad.identity_plus();
        let strain = self.lane_strain(grad);
        let mut elastic = strain;
        if let Some(ep) = plastic {
            let e = strain.sub(ep);
            let flows = e.frobenius().simd_gt(f32x8::splat(self.plastic_yield));
            let creep = flows.select(f32x8::splat(self.plastic_creep_dt), f32x8::ZERO);
            *ep = ep.add(&e.scale(creep));
            let norm = ep.frobenius();
            let max = f32x8::splat(self.plastic_max);
            let capped = norm.simd_gt(max).select(max / norm, f32x8::ONE);
            *ep = ep.scale(capped);
            elastic = strain.sub(ep);
        }
        let mut sigma = self.lane_hooke(&elastic);
        if let Some(jd) = vel_grad {
            let half = j.tr_mul(jd);
            let mut rate = half.add(&half.transpose());
            if !self.paper {
                rate = rate.scale(f32x8::splat(0.5));
            }
            sigma = sigma.add(&self.lane_hooke(&rate).scale(f32x8::splat(self.tau)));
        }
        let s = if self.paper { 2.0 } else { 1.0 };
        let mut p = j.mul(&sigma).scale(-volume * f32x8::splat(s));
        if self.kv > 0.0 {
            let k = volume * f32x8::splat(self.kv) * grad.det_minus_one();
            p = p.sub(&j.cofactor().scale(k));
        }
        (p, strain.frobenius())
    }
}

/// Packs the stress pass's state rows `[u, v, 0, 0]` of every phyxel, eight at a time
/// (lane loads of the columns, one lane transpose): `u = (pos − rest) + carry` (`pos −
/// rest` is exact, the two being close; `carry` is the motion the compensated position
/// sum could not store in `pos`, `Phyxels::pos_carry`: without it a stiff body far from
/// the origin strains by its positions' rounding), and `v = vel` when `vel` is given
/// (zero otherwise). `state` has [`LaneStencil::padded`] rows; the columns' zero padding
/// gives zero rows past the last phyxel.
pub fn pack_state(
    pos: &Vec3s,
    rest: &Vec3s,
    carry: &Vec3s,
    vel: Option<&Vec3s>,
    state: &mut [[f32; 8]],
) {
    use rayon::prelude::*;
    state
        .par_chunks_mut(LANES)
        .enumerate()
        .with_min_len(group_grain())
        .for_each(|(g, rows)| {
            let at = g * LANES;
            let u = |c: &[f32], r: &[f32], k: &[f32]| (load8(c, at) - load8(r, at)) + load8(k, at);
            let v = |axis: fn(&Vec3s) -> &[f32]| vel.map_or(f32x8::ZERO, |v| load8(axis(v), at));
            let z = f32x8::ZERO;
            let t = f32x8::transpose([
                u(&pos.x, &rest.x, &carry.x),
                u(&pos.y, &rest.y, &carry.y),
                u(&pos.z, &rest.z, &carry.z),
                v(|v| &v.x),
                v(|v| &v.y),
                v(|v| &v.z),
                z,
                z,
            ]);
            for (row, t) in rows.iter_mut().zip(t) {
                *row = t.to_array();
            }
        });
}

/// Per-step inputs of the stress pass.
pub struct LaneInputs<'a> {
    pub law: Law,
    /// Per phyxel `[u, v, 0, 0]`: displacement (m) and velocity (m/s, read only when
    /// `law.tau > 0`), one 32-byte row so a neighbour is one lane load; zero rows up to
    /// [`LaneStencil::padded`], and `gather::fixed_rows` of that in all so that the
    /// gathers need no bounds checks.
    pub state: &'a [[f32; 8]],
    /// Rest volume per phyxel, padded (m³).
    pub volume: &'a [f32],
}

/// Per-step outputs of the stress pass (buffers kept by the backend).
pub struct LaneOutputs<'a> {
    /// Displacement gradient per phyxel.
    pub grad: &'a mut [Mat3],
    /// Plastic strain per phyxel (empty for elastic materials).
    pub plastic: &'a mut [Mat3],
    /// `P` per phyxel, padded to [`LaneStencil::padded`] (N per unit `d`).
    pub stress: &'a mut [StressRow],
}

/// Gradients and stresses `P` of every phyxel; returns the largest strain norm.
pub fn stress_pass(st: &LaneStencil, input: &LaneInputs<'_>, out: LaneOutputs<'_>) -> f32 {
    phyxel::with_rows!(input.state, |state| groups_pass(
        st,
        input,
        &state,
        0..st.groups(),
        out
    ))
}

/// Splits the outputs at window boundaries and runs the groups in parallel tasks.
/// `out.grad` and `out.plastic` start at the first phyxel of `groups`; `out.stress` at
/// its first lane position.
fn groups_pass(
    st: &LaneStencil,
    input: &LaneInputs<'_>,
    state: &impl Rows<[f32; 8]>,
    groups: std::ops::Range<usize>,
    out: LaneOutputs<'_>,
) -> f32 {
    if groups.len() <= group_grain() {
        let base = groups.start * LANES;
        let LaneOutputs {
            grad,
            plastic,
            mut stress,
        } = out;
        let mut max = 0.0f32;
        for g in groups {
            let (p, rest) = stress.split_at_mut(LANES);
            stress = rest;
            let plastic = (!plastic.is_empty()).then_some(&mut *plastic);
            max = max.max(group(st, input, state, g, base, &mut *grad, plastic, p));
        }
        return max;
    }
    // Whole windows on each side: a window's phyxels are its lanes' phyxels.
    let mid = groups.start + groups.len() / 2 / WINDOW_GROUPS * WINDOW_GROUPS;
    let rows = (mid - groups.start) * LANES;
    let (g0, g1) = out.grad.split_at_mut(rows);
    let (p0, p1) = if out.plastic.is_empty() {
        (&mut [][..], &mut [][..])
    } else {
        out.plastic.split_at_mut(rows)
    };
    let (s0, s1) = out.stress.split_at_mut(rows);
    let (a, b) = rayon::join(
        || {
            let out = LaneOutputs {
                grad: g0,
                plastic: p0,
                stress: s0,
            };
            groups_pass(st, input, state, groups.start..mid, out)
        },
        || {
            let out = LaneOutputs {
                grad: g1,
                plastic: p1,
                stress: s1,
            };
            groups_pass(st, input, state, mid..groups.end, out)
        },
    );
    a.max(b)
}

/// Eight rows of eight floats transposed to lanes.
#[inline(always)]
fn gather<const W: usize>(rows: &impl Rows<[f32; W]>, idx: &[u32], half: usize) -> [f32x8; 8] {
    f32x8::transpose(std::array::from_fn(|lane| {
        let r = rows.row(idx[lane]);
        let a: [f32; 8] = r[8 * half..8 * half + 8].try_into().expect("8 of W");
        f32x8::from(a)
    }))
}

/// `∇u` and `∇v` of a group's eight rows: `Σ_j (u_j − u_i) d_ijᵀ` (`∇v` only with
/// `velocity`).
///
/// `VELOCITY` is a constant so that each case gets its own loop: a run-time flag inside
/// the slot loop costs the elastic case its register allocation.
#[inline(always)]
fn lane_gradients<const VELOCITY: bool>(
    st: &LaneStencil,
    state: &impl Rows<[f32; 8]>,
    g: usize,
) -> (M3, M3) {
    let own = gather(state, &st.rows.phyxels(g), 0);
    let (mut gu, mut gv) = (M3::ZERO, M3::ZERO);
    for s in st.rows.slots(g) {
        let nb = gather(state, st.rows.indices(s), 0);
        let d = st.rows.weight(s);
        let du: [f32x8; 3] = std::array::from_fn(|r| nb[r] - own[r]);
        gu.add_outer(du, d);
        if VELOCITY {
            gv.add_outer(std::array::from_fn(|r| nb[3 + r] - own[3 + r]), d);
        }
    }
    (gu, gv)
}

/// One group: gradients and the law; returns the largest strain. `grad` and
/// `plastic` start at phyxel `base`; `stress` is the group's eight lane positions.
#[allow(clippy::too_many_arguments)]
fn group(
    st: &LaneStencil,
    input: &LaneInputs<'_>,
    state: &impl Rows<[f32; 8]>,
    g: usize,
    base: usize,
    grad: &mut [Mat3],
    plastic: Option<&mut [Mat3]>,
    stress: &mut [StressRow],
) -> f32 {
    let velocity = input.law.tau > 0.0;
    let (gu, gv) = if velocity {
        lane_gradients::<true>(st, state, g)
    } else {
        lane_gradients::<false>(st, state, g)
    };
    let phyxels = st.rows.phyxels(g);
    // Lanes past the last phyxel come last in a group (the order pads with `p = i`).
    let count = (st.n - g * LANES).min(LANES);
    let at = phyxels.map(|i| (i as usize).wrapping_sub(base));
    gu.store(grad, &at, count);
    let gv = velocity.then_some(gv);
    let volume = f32x8::from(phyxels.map(|i| input.volume[i as usize]));
    let (p, strain) = match plastic {
        Some(pl) => {
            let mut ep = M3::load(pl, &at, count);
            let r = input
                .law
                .lane_stress_force(&gu, gv.as_ref(), Some(&mut ep), volume);
            ep.store(pl, &at, count);
            r
        }
        None => input.law.lane_stress_force(&gu, gv.as_ref(), None, volume),
    };
    let z = f32x8::ZERO;
    let lo = f32x8::transpose(std::array::from_fn(|k| p.c[k]));
    let hi = f32x8::transpose([p.c[8], z, z, z, z, z, z, z]);
    for (l, row) in stress.iter_mut().enumerate() {
        store8(row, 0, lo[l]);
        store8(row, 8, hi[l]);
    }
    strain.to_array()[..count]
        .iter()
        .fold(0.0f32, |a, &b| a.max(b))
}

/// `f_j = P_j d_j + Σ_i P_i d_ij` of every phyxel into the padded force columns (N);
/// `stress` is the stress pass's buffer, of `gather::fixed_rows` rows.
pub fn force_pass(
    st: &LaneStencil,
    stress: &[StressRow],
    fx: &mut [f32],
    fy: &mut [f32],
    fz: &mut [f32],
) {
    phyxel::with_rows!(stress, |stress| force_rows(st, &stress, fx, fy, fz))
}

fn force_rows(
    st: &LaneStencil,
    stress: &impl Rows<StressRow>,
    fx: &mut [f32],
    fy: &mut [f32],
    fz: &mut [f32],
) {
    use rayon::prelude::*;
    let groups = st.groups();
    fx.par_chunks_mut(WINDOW)
        .zip(fy.par_chunks_mut(WINDOW))
        .zip(fz.par_chunks_mut(WINDOW))
        .enumerate()
        .with_min_len(group_grain() / WINDOW_GROUPS)
        .for_each(|(w, ((x, y), z))| {
            let base = w * WINDOW;
            for g in w * WINDOW_GROUPS..((w + 1) * WINDOW_GROUPS).min(groups) {
                let mut f = [f32x8::ZERO; 3];
                for s in st.targets.slots(g) {
                    let idx = st.targets.indices(s);
                    let lo = gather(stress, idx, 0);
                    let p8 =
                        f32x8::from(std::array::from_fn::<f32, 8, _>(|l| stress.row(idx[l])[8]));
                    let p = |k: usize| if k < 8 { lo[k] } else { p8 };
                    let d = st.targets.weight(s);
                    for (row, fr) in f.iter_mut().enumerate() {
                        let s = p(row).mul_add(d[0], *fr);
                        let s = p(3 + row).mul_add(d[1], s);
                        *fr = p(6 + row).mul_add(d[2], s);
                    }
                }
                let f = f.map(|v| v.to_array());
                for (l, &j) in st.targets.phyxels(g).iter().enumerate() {
                    let j = j as usize - base;
                    (x[j], y[j], z[j]) = (f[0][l], f[1][l], f[2][l]);
                }
            }
        });
}
