//! A sparse symmetric positive definite matrix in envelope (skyline) form and its
//! Cholesky factor, with the nodes ordered by reverse Cuthill–McKee (George & Liu 1981,
//! "Computer Solution of Large Sparse Positive Definite Systems", ch. 4). The factor
//! has no fill outside the envelope, and an MLS body's envelope is narrow: its stiffness
//! couples only phyxels two influence radii apart, so in RCM order each row reaches
//! back a few layers of phyxels.
//!
//! The implicit backend factors its rest-state system once and applies the factor as
//! the preconditioner of its conjugate gradients.

use wide::bytemuck::cast;
use wide::{f32x8, f64x4, i32x8, u16x8};

/// Reverse Cuthill–McKee order of a graph given by adjacency lists: `order[k]` is the
/// node placed at position k. Each connected part starts from a pseudo-peripheral node
/// (the far end of a breadth-first search from a node of least degree), neighbours
/// are visited by increasing degree.
pub fn rcm_order(adjacency: &[Vec<u32>]) -> Vec<u32> {
    let n = adjacency.len();
    let mut placed = vec![false; n];
    let mut order = Vec::with_capacity(n);
    let degree = |v: usize| adjacency[v].len();
    let mut by_degree: Vec<usize> = (0..n).collect();
    by_degree.sort_by_key(|&v| (degree(v), v));
    let mut level = vec![u32::MAX; n];
    for &seed in &by_degree {
        if placed[seed] {
            continue;
        }
        // The last node reached from the seed is far from it: start there.
        let start = last_reached(adjacency, seed, &mut level, &placed);
        let from = order.len();
        order.push(start as u32);
        placed[start] = true;
        let mut head = from;
        while head < order.len() {
            let v = order[head] as usize;
            head += 1;
            let mut next: Vec<u32> = adjacency[v]
                .iter()
                .copied()
                .filter(|&w| !placed[w as usize])
                .collect();
            next.sort_by_key(|&w| (degree(w as usize), w));
            for w in next {
                placed[w as usize] = true;
                order.push(w);
            }
        }
    }
    order.reverse();
    order
}

/// The node a breadth-first search from `seed` reaches last (among unplaced nodes).
fn last_reached(adjacency: &[Vec<u32>], seed: usize, level: &mut [u32], placed: &[bool]) -> usize {
    let mut queue = vec![seed];
    level[seed] = 0;
    let mut head = 0;
    while head < queue.len() {
        let v = queue[head];
        head += 1;
        for &w in &adjacency[v] {
            let w = w as usize;
            if !placed[w] && level[w] == u32::MAX {
                level[w] = level[v] + 1;
                queue.push(w);
            }
        }
    }
    for &v in &queue {
        level[v] = u32::MAX;
    }
    *queue.last().unwrap_or(&seed)
}

/// A float the factor is computed in: f64, or f32 where the factor is rounded to
/// bfloat16 afterwards (f32's rounding is a hundredth of bfloat16's).
trait Real: Copy {
    /// A vector of [`Real::WIDTH`] of them.
    type Lanes: Copy;
    const WIDTH: usize;
    const ZERO: Self::Lanes;
    /// The first [`Real::WIDTH`] entries of `x`.
    fn lanes(x: &[Self]) -> Self::Lanes;
    /// `x` (shorter than [`Real::WIDTH`]) followed by zeros.
    fn padded(x: &[Self]) -> Self::Lanes;
    /// `a b + c`, lane by lane.
    fn fma(a: Self::Lanes, b: Self::Lanes, c: Self::Lanes) -> Self::Lanes;
    fn total(v: Self::Lanes) -> f64;
    fn wide(self) -> f64;
    fn narrow(x: f64) -> Self;
}

impl Real for f64 {
    type Lanes = f64x4;
    const WIDTH: usize = 4;
    const ZERO: f64x4 = f64x4::ZERO;
    #[inline]
    fn lanes(x: &[f64]) -> f64x4 {
        f64x4::new(x[..4].try_into().expect("four entries"))
    }
    #[inline]
    fn padded(x: &[f64]) -> f64x4 {
        let mut v = [0.0; 4];
        v[..x.len()].copy_from_slice(x);
        f64x4::new(v)
    }
    #[inline]
    fn fma(a: f64x4, b: f64x4, c: f64x4) -> f64x4 {
        a.mul_add(b, c)
    }
    #[inline]
    fn total(v: f64x4) -> f64 {
        v.reduce_add()
    }
    #[inline]
    fn wide(self) -> f64 {
        self
    }
    #[inline]
    fn narrow(x: f64) -> f64 {
        x
    }
}

impl Real for f32 {
    type Lanes = f32x8;
    const WIDTH: usize = 8;
    const ZERO: f32x8 = f32x8::ZERO;
    #[inline]
    fn lanes(x: &[f32]) -> f32x8 {
        load(x)
    }
    #[inline]
    fn padded(x: &[f32]) -> f32x8 {
        let mut v = [0.0; 8];
        v[..x.len()].copy_from_slice(x);
        f32x8::new(v)
    }
    #[inline]
    fn fma(a: f32x8, b: f32x8, c: f32x8) -> f32x8 {
        a.mul_add(b, c)
    }
    #[inline]
    fn total(v: f32x8) -> f64 {
        v.reduce_add() as f64
    }
    #[inline]
    fn wide(self) -> f64 {
        self as f64
    }
    #[inline]
    fn narrow(x: f64) -> f32 {
        x as f32
    }
}

/// The nine products `rows[a] · cols[b]` (all of one length) in vectors, one running
/// sum each.
#[inline]
fn dot9<T: Real>(rows: [&[T]; 3], cols: [&[T]; 3]) -> [[f64; 3]; 3] {
    let n = rows[0].len();
    let whole = n - n % T::WIDTH;
    let mut acc = [T::ZERO; 9];
    let add = |acc: &mut [T::Lanes; 9], r: [T::Lanes; 3], c: [T::Lanes; 3]| {
        for a in 0..3 {
            for b in 0..3 {
                acc[3 * a + b] = T::fma(r[a], c[b], acc[3 * a + b]);
            }
        }
    };
    // Whole vectors (exact chunks: no bounds test or tail test in the loop), then the
    // tail as one vector padded with zeros.
    let [r0, r1, r2] = rows.map(|x| x[..whole].chunks_exact(T::WIDTH));
    let [c0, c1, c2] = cols.map(|x| x[..whole].chunks_exact(T::WIDTH));
    for (((r0, r1), r2), ((c0, c1), c2)) in r0.zip(r1).zip(r2).zip(c0.zip(c1).zip(c2)) {
        let r = [T::lanes(r0), T::lanes(r1), T::lanes(r2)];
        add(&mut acc, r, [T::lanes(c0), T::lanes(c1), T::lanes(c2)]);
    }
    if whole < n {
        let tail = |x: &[T]| T::padded(&x[whole..n]);
        let r = [tail(rows[0]), tail(rows[1]), tail(rows[2])];
        add(&mut acc, r, [tail(cols[0]), tail(cols[1]), tail(cols[2])]);
    }
    let mut out = [[0.0; 3]; 3];
    for a in 0..3 {
        for b in 0..3 {
            out[a][b] = T::total(acc[3 * a + b]);
        }
    }
    out
}

/// The Cholesky factor of a skyline matrix whose rows come in node triples
/// ([`Skyline::by_node`]), in place in `values`, a node against a node at a time: the
/// nine dot products of a 3 × 3 block read each row segment once for three products
/// instead of one, then the block's own columns are finished in order. `Err` with the
/// row whose pivot is not positive.
fn factor_by_node<T: Real>(
    values: &mut [T],
    first: &[usize],
    start: &[usize],
    inverse: &mut Vec<f64>,
) -> Result<(), usize> {
    // 1 / L[c][c] of the finished pivots: a product per entry rather than a division.
    inverse.clear();
    inverse.resize(first.len(), 0.0);
    for p in 0..first.len() / 3 {
        for q in first[3 * p] / 3..=p {
            factor_block(values, first, start, inverse, p, q)?;
        }
    }
    Ok(())
}

/// Finishes the 3 × 3 block of node rows `p` against node `q ≤ p` (see
/// [`factor_by_node`]): rows `q` and row p's blocks before it are done.
#[inline]
fn factor_block<T: Real>(
    values: &mut [T],
    first: &[usize],
    start: &[usize],
    inverse: &mut [f64],
    p: usize,
    q: usize,
) -> Result<(), usize> {
    let index = |r: usize, c: usize| start[r] + c - first[r];
    let r0 = 3 * p;
    let c0 = 3 * q;
    let k0 = first[r0].max(first[c0]);
    let segment = |r: usize| &values[index(r, k0)..index(r, c0)];
    let sums = dot9(
        [0, 1, 2].map(|a| segment(r0 + a)),
        [0, 1, 2].map(|b| segment(c0 + b)),
    );
    for (a, sums) in sums.iter().enumerate() {
        let last = if q == p { a } else { 2 };
        for (b, &sum) in sums.iter().enumerate().take(last + 1) {
            let (r, c) = (r0 + a, c0 + b);
            let within: f64 = (c0..c)
                .map(|k| values[index(r, k)].wide() * values[index(c, k)].wide())
                .sum();
            let value = values[index(r, c)].wide() - sum - within;
            values[index(r, c)] = T::narrow(if c < r {
                value * inverse[c]
            } else if value > 0.0 && value.is_finite() {
                let pivot = T::narrow(value.sqrt());
                inverse[r] = 1.0 / pivot.wide();
                pivot.wide()
            } else {
                return Err(r);
            });
        }
    }
    Ok(())
}

/// `Σ aᵢ bᵢ` in four-lane vectors (the factor's inner loop; a plain sequential sum
/// does not vectorise), four running sums of them: one would wait on each fused
/// multiply-add's latency.
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let load = |x: &[f64]| f64x4::new([x[0], x[1], x[2], x[3]]);
    let mut acc = [f64x4::ZERO; 4];
    let (ca, cb) = (a.chunks_exact(16), b.chunks_exact(16));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] = load(&x[4 * k..]).mul_add(load(&y[4 * k..]), acc[k]);
        }
    }
    let (qa, qb) = (ra.chunks_exact(4), rb.chunks_exact(4));
    let (ta, tb) = (qa.remainder(), qb.remainder());
    for (x, y) in qa.zip(qb) {
        acc[0] = load(x).mul_add(load(y), acc[0]);
    }
    let sum = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    sum.reduce_add() + ta.iter().zip(tb).map(|(x, y)| x * y).sum::<f64>()
}

/// How [`Skyline::factor`] rounds the factor that [`Skyline::solve_rounded`] reads.
/// The triangular solves stream the factor once each, so its bytes are their time; the
/// rounding perturbs `L Lᵀ` by about the unit roundoff times its diagonal, which must
/// stay small against the matrix's smallest eigenvalues.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rounding {
    /// f32: 24 significant bits.
    F32,
    /// bfloat16, the upper half of an f32's bits: f32's range, 8 significant bits, half
    /// the bytes of f32.
    Bf16,
}

impl Rounding {
    /// The unit roundoff: a value is rounded to within this fraction of itself.
    pub fn unit_roundoff(self) -> f64 {
        match self {
            Rounding::F32 => f64::from(f32::EPSILON) / 2.0,
            Rounding::Bf16 => 2f64.powi(-8) / 2.0,
        }
    }
}

/// An entry of the rounded factor, widened to f32 for the solves.
trait Entry: Copy {
    /// The entry as an f32 (exact).
    fn widen(self) -> f32;
    /// The first eight entries of `h` as f32 lanes.
    fn widen8(h: &[Self]) -> f32x8;
}

impl Entry for f32 {
    #[inline]
    fn widen(self) -> f32 {
        self
    }
    #[inline]
    fn widen8(h: &[Self]) -> f32x8 {
        load(h)
    }
}

/// A bfloat16 by its bits.
#[derive(Clone, Copy, Debug)]
struct Bf16(u16);

impl Bf16 {
    /// `x` rounded to nearest, ties to even (the f32 first: a double rounding, within
    /// bfloat16's own unit roundoff and an f32 one).
    #[inline]
    fn new(x: f64) -> Self {
        let b = (x as f32).to_bits();
        Bf16(((b + 0x7fff + ((b >> 16) & 1)) >> 16) as u16)
    }
}

impl Entry for Bf16 {
    #[inline]
    fn widen(self) -> f32 {
        f32::from_bits((self.0 as u32) << 16)
    }
    #[inline]
    fn widen8(h: &[Self]) -> f32x8 {
        let h = u16x8::new(std::array::from_fn(|k| h[k].0));
        cast::<i32x8, f32x8>(i32x8::from_u16x8(h) << 16)
    }
}

/// The first eight entries of `x` as lanes.
#[inline]
fn load(x: &[f32]) -> f32x8 {
    f32x8::new(x[..8].try_into().expect("a chunk of 8"))
}

/// `Σ aᵢ bᵢ` in eight-lane f32 vectors, four running sums (the rounded solve's inner
/// loop, a row at a time).
#[inline]
fn dot_rounded<T: Entry>(a: &[T], b: &[f32]) -> f32 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [f32x8::ZERO; 4];
    let (ca, cb) = (a.chunks_exact(32), b.chunks_exact(32));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] = T::widen8(&x[8 * k..]).mul_add(load(&y[8 * k..]), acc[k]);
        }
    }
    let (qa, qb) = (ra.chunks_exact(8), rb.chunks_exact(8));
    let (ta, tb) = (qa.remainder(), qb.remainder());
    for (x, y) in qa.zip(qb) {
        acc[0] = T::widen8(x).mul_add(load(y), acc[0]);
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])).reduce_add()
        + ta.iter().zip(tb).map(|(&x, y)| x.widen() * y).sum::<f32>()
}

/// The three sums `Σ aₖᵢ bᵢ` (k = 0, 1, 2) of three rows against one vector, in one
/// pass over it.
#[inline]
fn dot3_rounded<T: Entry>(a: [&[T]; 3], b: &[f32]) -> [f32; 3] {
    let n = b.len();
    // Two running sums per row: one would wait on each fused multiply-add's latency.
    let mut acc = [[f32x8::ZERO; 3]; 2];
    let pairs = n - n % 16;
    for i in (0..pairs).step_by(16) {
        for (h, acc) in acc.iter_mut().enumerate() {
            let y = load(&b[i + 8 * h..]);
            for k in 0..3 {
                acc[k] = T::widen8(&a[k][i + 8 * h..]).mul_add(y, acc[k]);
            }
        }
    }
    let body = n - n % 8;
    if body > pairs {
        let y = load(&b[pairs..]);
        for k in 0..3 {
            acc[0][k] = T::widen8(&a[k][pairs..]).mul_add(y, acc[0][k]);
        }
    }
    let mut out = [0, 1, 2].map(|k| (acc[0][k] + acc[1][k]).reduce_add());
    for i in body..n {
        for k in 0..3 {
            out[k] += a[k][i].widen() * b[i];
        }
    }
    out
}

/// A symmetric matrix stored by rows from each row's first nonzero column to the
/// diagonal, and after [`Skyline::factor`] its Cholesky factor `L` in the same place.
#[derive(Clone, Debug)]
pub struct Skyline {
    /// First column of each row.
    first: Vec<usize>,
    /// Start of each row in `values` (row r holds columns first[r]..=r).
    start: Vec<usize>,
    values: Vec<f64>,
    /// The factor rounded as `rounding` says (the other one empty; both empty until
    /// [`Skyline::factor`] succeeds): what [`Skyline::solve_rounded`] reads.
    lower_f32: Vec<f32>,
    lower_bf16: Vec<Bf16>,
    rounding: Rounding,
    /// The matrix in f32 while a factor to be rounded to bfloat16 is computed (kept for
    /// its buffer).
    work: Vec<f32>,
    /// The pivots' reciprocals while the factor is computed (kept for its buffer).
    inverse: Vec<f64>,
    /// The rows come in triples that start at the same column, a multiple of three (the
    /// three coordinates of a node): [`Skyline::solve_rounded`] takes a node at a time.
    by_node: bool,
}

impl Skyline {
    /// An all-zero matrix of `n` rows whose row r may hold columns `first[r]..=r`.
    pub fn new(first: Vec<usize>) -> Self {
        let mut start = Vec::with_capacity(first.len() + 1);
        let mut len = 0;
        for (r, &f) in first.iter().enumerate() {
            start.push(len);
            len += r + 1 - f;
        }
        start.push(len);
        let by_node = first.len().is_multiple_of(3)
            && first
                .chunks_exact(3)
                .all(|f| f[0].is_multiple_of(3) && f[1] == f[0] && f[2] == f[0]);
        Self {
            first,
            start,
            values: vec![0.0; len],
            lower_f32: Vec::new(),
            lower_bf16: Vec::new(),
            rounding: Rounding::F32,
            work: Vec::new(),
            inverse: Vec::new(),
            by_node,
        }
    }

    /// The matrix's order (rows).
    pub fn len(&self) -> usize {
        self.first.len()
    }

    /// A matrix of no rows.
    pub fn is_empty(&self) -> bool {
        self.first.is_empty()
    }

    /// Copies the values of `other`, a matrix of the same envelope (no allocation).
    pub fn copy_from(&mut self, other: &Skyline) {
        debug_assert_eq!(self.first, other.first);
        self.values.copy_from_slice(&other.values);
    }

    /// The entry (r, r).
    pub fn diagonal(&self, r: usize) -> f64 {
        self.values[self.start[r] + r - self.first[r]]
    }

    /// Adds `v` at (r, c) of the lower triangle (`c ≤ r`, inside the envelope).
    #[inline]
    pub fn add(&mut self, r: usize, c: usize, v: f64) {
        debug_assert!(c <= r && c >= self.first[r]);
        self.values[self.start[r] + c - self.first[r]] += v;
    }

    /// Adds `v` at (r, c..c + v.len()) of the lower triangle (inside the envelope).
    #[inline]
    pub fn add_row(&mut self, r: usize, c: usize, v: &[f64]) {
        debug_assert!(c + v.len() <= r + 1 && c >= self.first[r]);
        let at = self.start[r] + c - self.first[r];
        for (x, &y) in self.values[at..at + v.len()].iter_mut().zip(v) {
            *x += y;
        }
    }

    /// Replaces the matrix by its Cholesky factor `L` (`A = L Lᵀ`), and keeps `L`
    /// rounded as `rounding` says for [`Skyline::solve_rounded`]; `Err` with the row
    /// whose pivot is not positive (the matrix is not positive definite).
    pub fn factor(&mut self, rounding: Rounding) -> Result<(), usize> {
        if self.by_node && rounding == Rounding::Bf16 {
            self.work.clear();
            self.work.extend(self.values.iter().map(|&v| v as f32));
            match factor_by_node(&mut self.work, &self.first, &self.start, &mut self.inverse) {
                Ok(()) => {
                    for (v, &w) in self.values.iter_mut().zip(&self.work) {
                        *v = w as f64;
                    }
                }
                // A pivot lost in f32: the f64 factor decides.
                Err(_) => factor_by_node(
                    &mut self.values,
                    &self.first,
                    &self.start,
                    &mut self.inverse,
                )?,
            }
        } else if self.by_node {
            factor_by_node(
                &mut self.values,
                &self.first,
                &self.start,
                &mut self.inverse,
            )?;
        } else {
            self.factor_by_row()?;
        }
        self.rounding = rounding;
        self.lower_f32.clear();
        self.lower_bf16.clear();
        match rounding {
            Rounding::F32 => self.lower_f32.extend(self.values.iter().map(|&v| v as f32)),
            Rounding::Bf16 => self
                .lower_bf16
                .extend(self.values.iter().map(|&v| Bf16::new(v))),
        }
        Ok(())
    }

    /// The up-looking Cholesky factor, a row at a time: `L[r][c]` from the dot
    /// product of rows r and c over their common columns.
    fn factor_by_row(&mut self) -> Result<(), usize> {
        for r in 0..self.len() {
            let (fr, sr) = (self.first[r], self.start[r]);
            for c in fr..r {
                let (fc, sc) = (self.first[c], self.start[c]);
                let k0 = fr.max(fc);
                let row_r = &self.values[sr + k0 - fr..sr + c - fr];
                let row_c = &self.values[sc + k0 - fc..sc + c - fc];
                let dot = dot(row_r, row_c);
                let diag = self.values[sc + c - fc];
                self.values[sr + c - fr] = (self.values[sr + c - fr] - dot) / diag;
            }
            let row = &self.values[sr..sr + r - fr];
            let pivot = self.values[sr + r - fr] - dot(row, row);
            if !(pivot > 0.0 && pivot.is_finite()) {
                return Err(r);
            }
            self.values[sr + r - fr] = pivot.sqrt();
        }
        Ok(())
    }

    /// Solves `L̃ L̃ᵀ x = b` in place in f32, with `L̃` the factor rounded as
    /// [`Skyline::factor`] was told. `L̃ L̃ᵀ` is symmetric positive definite whatever the
    /// rounding, so as a preconditioner it is as valid as the f64 factor.
    pub fn solve_rounded(&self, b: &mut [f32]) {
        match (self.rounding, self.by_node) {
            (Rounding::F32, false) => self.solve_by_row(&self.lower_f32, b),
            (Rounding::F32, true) => self.solve_by_node(&self.lower_f32, b),
            (Rounding::Bf16, false) => self.solve_by_row(&self.lower_bf16, b),
            (Rounding::Bf16, true) => self.solve_by_node(&self.lower_bf16, b),
        }
    }

    /// [`Skyline::solve_rounded`] a row at a time.
    fn solve_by_row<T: Entry>(&self, lower: &[T], b: &mut [f32]) {
        let n = self.len();
        for r in 0..n {
            let (fr, sr) = (self.first[r], self.start[r]);
            let row = &lower[sr..sr + r - fr];
            b[r] = (b[r] - dot_rounded(row, &b[fr..r])) / lower[sr + r - fr].widen();
        }
        for r in (0..n).rev() {
            let (fr, sr) = (self.first[r], self.start[r]);
            b[r] /= lower[sr + r - fr].widen();
            let x = b[r];
            let row = &lower[sr..sr + r - fr];
            for (y, &a) in b[fr..r].iter_mut().zip(row) {
                *y -= a.widen() * x;
            }
        }
    }

    /// [`Skyline::solve_rounded`] a node (three rows of one envelope) at a time: the
    /// three rows' products with the solution so far share one pass over it, and the
    /// rows wait on each other only inside their 3×3 diagonal block (a row at a time,
    /// each row's division waits on the last row's sum).
    fn solve_by_node<T: Entry>(&self, lower: &[T], b: &mut [f32]) {
        let l = |i: usize| lower[i].widen();
        for r0 in (0..self.len()).step_by(3) {
            let f = self.first[r0];
            let m = r0 - f;
            let s = [self.start[r0], self.start[r0 + 1], self.start[r0 + 2]];
            let sums = dot3_rounded(
                [
                    &lower[s[0]..s[0] + m],
                    &lower[s[1]..s[1] + m],
                    &lower[s[2]..s[2] + m],
                ],
                &b[f..r0],
            );
            let x0 = (b[r0] - sums[0]) / l(s[0] + m);
            let x1 = (b[r0 + 1] - sums[1] - l(s[1] + m) * x0) / l(s[1] + m + 1);
            let x2 =
                (b[r0 + 2] - sums[2] - l(s[2] + m) * x0 - l(s[2] + m + 1) * x1) / l(s[2] + m + 2);
            b[r0..r0 + 3].copy_from_slice(&[x0, x1, x2]);
        }
        for r0 in (0..self.len()).step_by(3).rev() {
            let f = self.first[r0];
            let m = r0 - f;
            let s = [self.start[r0], self.start[r0 + 1], self.start[r0 + 2]];
            let x2 = b[r0 + 2] / l(s[2] + m + 2);
            let x1 = (b[r0 + 1] - l(s[2] + m + 1) * x2) / l(s[1] + m + 1);
            let x0 = (b[r0] - l(s[2] + m) * x2 - l(s[1] + m) * x1) / l(s[0] + m);
            b[r0..r0 + 3].copy_from_slice(&[x0, x1, x2]);
            let (a0, a1, a2) = (
                &lower[s[0]..s[0] + m],
                &lower[s[1]..s[1] + m],
                &lower[s[2]..s[2] + m],
            );
            for (k, y) in b[f..r0].iter_mut().enumerate() {
                *y -= a0[k].widen() * x0 + a1[k].widen() * x1 + a2[k].widen() * x2;
            }
        }
    }

    /// Solves `L Lᵀ x = b` in place (after [`Skyline::factor`]).
    pub fn solve(&self, b: &mut [f64]) {
        let n = self.len();
        for r in 0..n {
            let (fr, sr) = (self.first[r], self.start[r]);
            let row = &self.values[sr..sr + r - fr];
            b[r] = (b[r] - dot(row, &b[fr..r])) / self.values[sr + r - fr];
        }
        for r in (0..n).rev() {
            let (fr, sr) = (self.first[r], self.start[r]);
            b[r] /= self.values[sr + r - fr];
            let x = b[r];
            let row = &self.values[sr..sr + r - fr];
            for (y, a) in b[fr..r].iter_mut().zip(row) {
                *y -= a * x;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both roundings.
    const ROUNDINGS: [Rounding; 2] = [Rounding::F32, Rounding::Bf16];

    /// The factor solves a banded SPD system to round-off (1e-10 relative), against
    /// the product of the dense matrix with the solution (independent of the factor);
    /// the rounded solves as [`assert_rounded_solve`] says.
    #[test]
    fn factor_solves_a_banded_spd_system() {
        let n = 40;
        let first: Vec<usize> = (0..n).map(|r: usize| r.saturating_sub(3)).collect();
        let entry = |r: usize, c: usize| -> f64 {
            if r == c {
                10.0 + r as f64 * 0.1
            } else if r.abs_diff(c) <= 3 {
                -1.0 / (1.0 + (r + c) as f64 * 0.05)
            } else {
                0.0
            }
        };
        for rounding in ROUNDINGS {
            let mut m = Skyline::new(first.clone());
            for r in 0..n {
                for c in r.saturating_sub(3)..=r {
                    m.add(r, c, entry(r, c));
                }
            }
            m.factor(rounding).expect("SPD");
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
            let mut x = b.clone();
            m.solve(&mut x);
            for (r, &br) in b.iter().enumerate() {
                let ax: f64 = (0..n).map(|c| entry(r.max(c), r.min(c)) * x[c]).sum();
                assert!((ax - br).abs() < 1e-10, "row {r}: {ax} against {br}");
            }
            assert_rounded_solve(&m, &b, &x);
        }
    }

    /// `L̃ (L̃ᵀ x)` in f64, with `L̃` the rounded factor.
    fn rounded_product(m: &Skyline, x: &[f32]) -> Vec<f64> {
        let n = m.len();
        let entry = |r: usize, c: usize| {
            let i = m.start[r] + c - m.first[r];
            f64::from(match m.rounding {
                Rounding::F32 => m.lower_f32[i],
                Rounding::Bf16 => m.lower_bf16[i].widen(),
            })
        };
        let mut y = vec![0.0f64; n];
        for (r, &xr) in x.iter().enumerate() {
            for (c, yc) in y.iter_mut().enumerate().take(r + 1).skip(m.first[r]) {
                *yc += entry(r, c) * xr as f64;
            }
        }
        (0..n)
            .map(|r| (m.first[r]..=r).map(|c| entry(r, c) * y[c]).sum())
            .collect()
    }

    /// [`Skyline::solve_rounded`] of `b` solves the rounded factor's own system to f32's
    /// rounding (its product with the rounded factor, summed in f64, gives back `b` to
    /// 1e-5 of its largest entry: rows of a few dozen f32 products), and lies within ten
    /// unit roundoffs of the factor (at least 1e-5) of the f64 solution `x`, relative to
    /// its largest entry (each factor entry is within one of itself; on these diagonally
    /// dominant matrices the solution moves by a few).
    fn assert_rounded_solve(m: &Skyline, b: &[f64], x: &[f64]) {
        let mut x32: Vec<f32> = b.iter().map(|&v| v as f32).collect();
        m.solve_rounded(&mut x32);
        let back = rounded_product(m, &x32);
        let b_scale = b.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        for (r, (&a, &e)) in back.iter().zip(b).enumerate() {
            assert!(
                (a - e).abs() < 1e-5 * b_scale,
                "row {r}: L̃L̃ᵀx̃ {a} against b {e}"
            );
        }
        let scale = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let tolerance = (10.0 * m.rounding.unit_roundoff()).max(1e-5);
        for (r, (&a, &e)) in x32.iter().zip(x).enumerate() {
            assert!(
                (a as f64 - e).abs() < tolerance * scale,
                "{:?} row {r}: {a} against {e}",
                m.rounding
            );
        }
    }

    /// The rounded solves on an irregular envelope (rows reaching 0 to 24 columns back,
    /// the dot products' vector chunks and tails all taken): see
    /// [`assert_rounded_solve`].
    #[test]
    fn rounded_solve_on_an_irregular_envelope() {
        let n: usize = 43;
        let reach = |r: usize| [24, 1, 7, 0, 13, 2, 19, 5][r % 8];
        let first: Vec<usize> = (0..n).map(|r| r.saturating_sub(reach(r))).collect();
        for rounding in ROUNDINGS {
            let mut m = Skyline::new(first.clone());
            for (r, &fr) in first.iter().enumerate() {
                for c in fr..r {
                    m.add(r, c, -1.0 / (2.0 + (r * 7 + c * 3) as f64 % 11.0));
                }
                m.add(r, r, 30.0 + r as f64 * 0.1);
            }
            assert!(!m.by_node);
            m.factor(rounding).expect("diagonally dominant");
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).cos()).collect();
            let mut x = b.clone();
            m.solve(&mut x);
            assert_rounded_solve(&m, &b, &x);
        }
    }

    /// The rounded solves a node at a time (rows in triples of one envelope, reaching 0
    /// to 29 nodes back: the paired, single and scalar tails of the three-row products
    /// all taken) against the f64 solve ([`assert_rounded_solve`]), and against the same
    /// factor solved a row at a time (the same sums in another order: 1e-5 of the
    /// solution's largest entry).
    #[test]
    fn rounded_solve_by_node_matches_by_row() {
        let nodes: usize = 41;
        let reach = |p: usize| [29, 1, 7, 0, 13, 2, 19, 5, 3][p % 9];
        let first: Vec<usize> = (0..3 * nodes)
            .map(|r| 3 * (r / 3).saturating_sub(reach(r / 3)))
            .collect();
        for rounding in ROUNDINGS {
            let mut m = Skyline::new(first.clone());
            for (r, &fr) in first.iter().enumerate() {
                for c in fr..r {
                    m.add(r, c, -1.0 / (4.0 + (r * 7 + c * 3) as f64 % 13.0));
                }
                m.add(r, r, 40.0 + r as f64 * 0.1);
            }
            assert!(m.by_node);
            m.factor(rounding).expect("diagonally dominant");
            let b: Vec<f64> = (0..3 * nodes).map(|i| (i as f64 * 0.37).cos()).collect();
            let mut x = b.clone();
            m.solve(&mut x);
            assert_rounded_solve(&m, &b, &x);
            let b32: Vec<f32> = b.iter().map(|&v| v as f32).collect();
            let mut by_node = b32.clone();
            m.solve_rounded(&mut by_node);
            let mut by_row = b32;
            m.by_node = false;
            m.solve_rounded(&mut by_row);
            let scale = by_row.iter().fold(0.0f32, |a, v| a.max(v.abs()));
            for (r, (&a, &e)) in by_node.iter().zip(&by_row).enumerate() {
                assert!((a - e).abs() < 1e-5 * scale, "row {r}: {a} against {e}");
            }
        }
    }

    /// Factored a node at a time, a matrix of rows in triples (reaching 0 to 29 nodes
    /// back, so that the nine-product kernel's vector body and tails are all taken)
    /// solves its system to round-off against the matrix's own product (1e-10
    /// relative), and its factor is the row-at-a-time one's within 1e-12 (f64), or
    /// 1e-5 where it is computed in f32 (to be rounded to bfloat16).
    #[test]
    fn factor_by_node_solves_the_system() {
        let nodes: usize = 41;
        let reach = |p: usize| [29, 1, 7, 0, 13, 2, 19, 5, 3][p % 9];
        let first: Vec<usize> = (0..3 * nodes)
            .map(|r| 3 * (r / 3).saturating_sub(reach(r / 3)))
            .collect();
        let entry = |r: usize, c: usize| -> f64 {
            let (r, c) = (r.max(c), r.min(c));
            if c < first[r] {
                0.0
            } else if r == c {
                40.0 + r as f64 * 0.1
            } else {
                -1.0 / (4.0 + (r * 7 + c * 3) as f64 % 13.0)
            }
        };
        let build = || {
            let mut m = Skyline::new(first.clone());
            for (r, &fr) in first.iter().enumerate() {
                for c in fr..=r {
                    m.add(r, c, entry(r, c));
                }
            }
            m
        };
        let mut by_node = build();
        assert!(by_node.by_node);
        by_node.factor(Rounding::F32).expect("diagonally dominant");
        let mut by_row = build();
        by_row.by_node = false;
        by_row.factor(Rounding::F32).expect("diagonally dominant");
        for (i, (&a, &e)) in by_node.values.iter().zip(&by_row.values).enumerate() {
            assert!(
                (a - e).abs() < 1e-12 * e.abs().max(1.0),
                "entry {i}: {a} against {e}"
            );
        }
        // Rounded to bfloat16 afterwards, the factor is computed in f32: within f32's
        // rounding of the f64 one.
        let mut in_f32 = build();
        in_f32.factor(Rounding::Bf16).expect("diagonally dominant");
        for (i, (&a, &e)) in in_f32.values.iter().zip(&by_row.values).enumerate() {
            assert!(
                (a - e).abs() < 1e-5 * e.abs().max(1.0),
                "entry {i}: {a} against {e}"
            );
        }
        assert!(
            in_f32
                .values
                .iter()
                .zip(&by_row.values)
                .any(|(a, e)| a != e)
        );
        let n = 3 * nodes;
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).cos()).collect();
        let mut x = b.clone();
        by_node.solve(&mut x);
        for (r, &br) in b.iter().enumerate() {
            let ax: f64 = (0..n).map(|c| entry(r, c) * x[c]).sum();
            assert!((ax - br).abs() < 1e-10, "row {r}: {ax} against {br}");
        }
    }

    /// A node matrix positive definite only beyond f32's rounding (an eigenvalue of
    /// 2e-9) is factored in f64 when f32 loses its pivot, and still solves its system.
    #[test]
    fn a_pivot_lost_in_f32_is_factored_in_f64() {
        let mut m = Skyline::new(vec![0; 6]);
        for r in 0..6 {
            m.add(r, r, 1.0);
        }
        m.add(3, 0, 1.0 - 1e-9);
        m.factor(Rounding::Bf16).expect("positive definite in f64");
        let b = [1.0, 0.0, 0.0, -1.0, 0.0, 0.0];
        let mut x = b;
        m.solve(&mut x);
        let ax0 = x[0] + (1.0 - 1e-9) * x[3];
        assert!((ax0 - b[0]).abs() < 1e-6 && (x[3] + (1.0 - 1e-9) * x[0] - b[3]).abs() < 1e-6);
    }

    /// A matrix that is not positive definite names its failing row.
    #[test]
    fn indefinite_matrix_is_refused() {
        let mut m = Skyline::new(vec![0, 0]);
        m.add(0, 0, 1.0);
        m.add(1, 0, 2.0);
        m.add(1, 1, 1.0);
        assert_eq!(m.factor(Rounding::F32), Err(1));
    }

    /// RCM on a path graph numbered badly gives a bandwidth of 1.
    #[test]
    fn rcm_orders_a_path_with_bandwidth_one() {
        let n = 9;
        // Path 0-8-1-7-2-6-3-5-4.
        let path = [0u32, 8, 1, 7, 2, 6, 3, 5, 4];
        let mut adjacency = vec![Vec::new(); n];
        for w in path.windows(2) {
            adjacency[w[0] as usize].push(w[1]);
            adjacency[w[1] as usize].push(w[0]);
        }
        let order = rcm_order(&adjacency);
        let mut position = vec![0; n];
        for (k, &v) in order.iter().enumerate() {
            position[v as usize] = k as i64;
        }
        for w in path.windows(2) {
            assert_eq!((position[w[0] as usize] - position[w[1] as usize]).abs(), 1);
        }
    }
}
