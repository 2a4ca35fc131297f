//! A sparse symmetric positive definite matrix in envelope (skyline) form and its
//! Cholesky factor, with the nodes ordered by reverse Cuthill–McKee (George & Liu 1981,
//! "Computer Solution of Large Sparse Positive Definite Systems", ch. 4). The factor
//! has no fill outside the envelope, and an MLS body's envelope is narrow: its stiffness
//! couples only phyxels two influence radii apart, so in RCM order each row reaches
//! back a few layers of phyxels.
//!
//! The implicit backend factors its rest-state system once and applies the factor as
//! the preconditioner of its conjugate gradients.

use wide::{f32x8, f64x4};

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

/// `Σ aᵢ bᵢ` in eight-lane f32 vectors, two running sums ([`Skyline::solve_f32`]'s
/// inner loop).
#[inline]
fn dot32(a: &[f32], b: &[f32]) -> f32 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let load = |x: &[f32]| f32x8::new(x[..8].try_into().expect("a chunk of 8"));
    let mut acc = [f32x8::ZERO; 2];
    let (ca, cb) = (a.chunks_exact(16), b.chunks_exact(16));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        acc[0] = load(x).mul_add(load(y), acc[0]);
        acc[1] = load(&x[8..]).mul_add(load(&y[8..]), acc[1]);
    }
    let (qa, qb) = (ra.chunks_exact(8), rb.chunks_exact(8));
    let (ta, tb) = (qa.remainder(), qb.remainder());
    for (x, y) in qa.zip(qb) {
        acc[0] = load(x).mul_add(load(y), acc[0]);
    }
    (acc[0] + acc[1]).reduce_add() + ta.iter().zip(tb).map(|(x, y)| x * y).sum::<f32>()
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
    /// The factor rounded to f32 (empty until [`Skyline::factor`] succeeds): what
    /// [`Skyline::solve_f32`] reads, half the bytes of `values`.
    lower: Vec<f32>,
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
        Self {
            first,
            start,
            values: vec![0.0; len],
            lower: Vec::new(),
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

    /// Replaces the matrix by its Cholesky factor `L` (`A = L Lᵀ`); `Err` with the row
    /// whose pivot is not positive (the matrix is not positive definite).
    pub fn factor(&mut self) -> Result<(), usize> {
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
        self.lower.clear();
        self.lower.extend(self.values.iter().map(|&v| v as f32));
        Ok(())
    }

    /// Solves `L̃ L̃ᵀ x = b` in place in f32, with `L̃` the factor rounded to f32 (after
    /// [`Skyline::factor`]). `L̃ L̃ᵀ` is symmetric positive definite whatever the
    /// rounding, so as a preconditioner it is as valid as the f64 factor; the
    /// triangular solves read memory-bound rows, and f32 halves their bytes.
    pub fn solve_f32(&self, b: &mut [f32]) {
        let n = self.len();
        let lower = &self.lower;
        for r in 0..n {
            let (fr, sr) = (self.first[r], self.start[r]);
            let row = &lower[sr..sr + r - fr];
            b[r] = (b[r] - dot32(row, &b[fr..r])) / lower[sr + r - fr];
        }
        for r in (0..n).rev() {
            let (fr, sr) = (self.first[r], self.start[r]);
            b[r] /= lower[sr + r - fr];
            let x = b[r];
            let row = &lower[sr..sr + r - fr];
            for (y, a) in b[fr..r].iter_mut().zip(row) {
                *y -= a * x;
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

    /// The factor solves a banded SPD system to round-off (1e-10 relative), against
    /// the product of the dense matrix with the solution (independent of the factor).
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
        let mut m = Skyline::new(first);
        for r in 0..n {
            for c in r.saturating_sub(3)..=r {
                m.add(r, c, entry(r, c));
            }
        }
        m.factor().expect("SPD");
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
        let mut x = b.clone();
        m.solve(&mut x);
        for (r, &br) in b.iter().enumerate() {
            let ax: f64 = (0..n).map(|c| entry(r.max(c), r.min(c)) * x[c]).sum();
            assert!((ax - br).abs() < 1e-10, "row {r}: {ax} against {br}");
        }
        // The f32 solve: the same solution to f32's rounding (|x| ≈ 0.1 here; rows of
        // up to 8 products: 1e-6 of |b| is about twenty ulps).
        let mut x32: Vec<f32> = b.iter().map(|&v| v as f32).collect();
        m.solve_f32(&mut x32);
        for (r, (&a, &e)) in x32.iter().zip(&x).enumerate() {
            assert!((a as f64 - e).abs() < 1e-6, "row {r}: {a} against {e}");
        }
    }

    /// The f32 solve on an irregular envelope (rows reaching 0 to 24 columns back, the
    /// dot products' vector chunks and tails all taken) agrees with the f64 solve to
    /// f32's rounding (1e-5 of the solution's largest entry: rows of up to 25 products).
    #[test]
    fn f32_solve_matches_on_an_irregular_envelope() {
        let n: usize = 43;
        let reach = |r: usize| [24, 1, 7, 0, 13, 2, 19, 5][r % 8];
        let first: Vec<usize> = (0..n).map(|r| r.saturating_sub(reach(r))).collect();
        let mut m = Skyline::new(first.clone());
        for (r, &fr) in first.iter().enumerate() {
            for c in fr..r {
                m.add(r, c, -1.0 / (2.0 + (r * 7 + c * 3) as f64 % 11.0));
            }
            m.add(r, r, 30.0 + r as f64 * 0.1);
        }
        m.factor().expect("diagonally dominant");
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).cos()).collect();
        let mut x = b.clone();
        m.solve(&mut x);
        let mut x32: Vec<f32> = b.iter().map(|&v| v as f32).collect();
        m.solve_f32(&mut x32);
        let scale = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        for (r, (&a, &e)) in x32.iter().zip(&x).enumerate() {
            assert!(
                (a as f64 - e).abs() < 1e-5 * scale,
                "row {r}: {a} against {e}"
            );
        }
    }

    /// A matrix that is not positive definite names its failing row.
    #[test]
    fn indefinite_matrix_is_refused() {
        let mut m = Skyline::new(vec![0, 0]);
        m.add(0, 0, 1.0);
        m.add(1, 0, 2.0);
        m.add(1, 1, 1.0);
        assert_eq!(m.factor(), Err(1));
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
