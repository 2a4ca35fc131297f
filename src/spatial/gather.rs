//! Gathers of rows by index without a bounds check per load, in safe code.
//!
//! The lane kernels read per-phyxel rows by index (the MLS stencil's neighbours, the
//! advection's affine table), eight per slot. Indexing a slice checks every load; in
//! those loops the checks are about a tenth of the instructions. A buffer of exactly
//! [`FIXED_ROWS`] rows (a power of two known at compile time), indexed with the index
//! masked to it, needs no check: the compiler can see every index is in bounds. So such
//! buffers get [`fixed_rows`] rows, and [`with_rows!`](crate::with_rows) hands a kernel
//! a [`FixedRows`] view of them, or the plain slice (checked) for bodies of more rows.
//! Every index a kernel uses is below the buffer's used length, so the mask changes
//! none. A mask taken at run time (`i & (len − 1)`) does not do it: the compiler keeps
//! the check and adds the `and`; a smaller fixed length (1,024) masks with an `and`
//! per load and gains nothing (measured with `cargo bench --bench kernels`).

/// Rows of a buffer whose gathers need no bounds checks: 65,536, so that the masked
/// index is the low half of the `u32` (one zero-extending load).
pub const FIXED_ROWS: usize = 1 << 16;

use std::sync::atomic::{AtomicUsize, Ordering};

/// The length to give a gathered buffer that uses `n` rows: [`FIXED_ROWS`] when they
/// fit, else `n` (checked gathers). Allocate it zeroed (`vec![zero; len]` of a type
/// whose zero is all-zero bytes, such as `f32` arrays): the pages of the rows past `n`
/// are then never touched, so a small body's buffer costs address space, not memory.
pub fn fixed_rows(n: usize) -> usize {
    if n <= FIXED_ROWS { FIXED_ROWS } else { n }
}

/// Bytes of address space the padded [`RowBuffer`]s of the process may hold at once.
/// A padded buffer costs address space, not memory, but a small body has about 6 MB of
/// them (the MLS force pass's two and the advection's table), so 2,000 small bodies
/// reserve 12 GB, which a `ulimit -v` or strict overcommit refuses. Past the budget a
/// buffer gets just its used rows: checked gathers, the same results.
pub const FIXED_ROWS_BUDGET: usize = 1 << 30;

/// Bytes the live padded [`RowBuffer`]s hold.
static RESERVED: AtomicUsize = AtomicUsize::new(0);

/// A zeroed buffer of rows for gathers: [`FIXED_ROWS`] rows (unchecked gathers) when the
/// used rows fit and the process's padded buffers stay within [`FIXED_ROWS_BUDGET`],
/// else exactly the used rows. Dereferences to the whole buffer.
pub struct RowBuffer<T> {
    rows: Vec<T>,
    used: usize,
    /// Bytes counted in the budget (0 unless padded).
    reserved: usize,
}

impl<T: Copy + Default> RowBuffer<T> {
    /// A zeroed buffer for `used` rows (`T::default()` must be all-zero bytes, as for
    /// `f32` arrays, so that the padding's pages are never touched).
    pub fn zeroed(used: usize) -> Self {
        let bytes = FIXED_ROWS * std::mem::size_of::<T>();
        let padded = used <= FIXED_ROWS
            && RESERVED
                .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |r| {
                    (r + bytes <= FIXED_ROWS_BUDGET).then_some(r + bytes)
                })
                .is_ok();
        let len = if padded { FIXED_ROWS } else { used };
        Self {
            rows: vec![T::default(); len],
            used,
            reserved: if padded { bytes } else { 0 },
        }
    }

    /// Whether the buffer was made for `used` rows.
    pub fn serves(&self, used: usize) -> bool {
        self.used == used
    }
}

impl<T> std::ops::Deref for RowBuffer<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.rows
    }
}

impl<T> std::ops::DerefMut for RowBuffer<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.rows
    }
}

impl<T> Drop for RowBuffer<T> {
    fn drop(&mut self) {
        RESERVED.fetch_sub(self.reserved, Ordering::Relaxed);
    }
}

impl<T: Copy + Default> Clone for RowBuffer<T> {
    fn clone(&self) -> Self {
        let mut c = Self::zeroed(self.used);
        c.rows[..self.used].copy_from_slice(&self.rows[..self.used]);
        c
    }
}

/// Empty, and holding none of the budget (a padded buffer for no rows would reserve 4 MB).
impl<T> Default for RowBuffer<T> {
    fn default() -> Self {
        Self {
            rows: Vec::new(),
            used: 0,
            reserved: 0,
        }
    }
}

impl<T> std::fmt::Debug for RowBuffer<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "RowBuffer({} of {} rows)", self.used, self.rows.len())
    }
}

/// Rows a gather reads by `u32` index.
pub trait Rows<T>: Sync {
    /// Row `i`; `i` must be below the buffer's used length.
    fn row(&self, i: u32) -> &T;
}

/// A buffer of exactly [`FIXED_ROWS`] rows: the index is masked to it, so the load
/// needs no bounds check.
pub struct FixedRows<'a, T>(pub &'a [T; FIXED_ROWS]);

impl<T: Sync> Rows<T> for FixedRows<'_, T> {
    #[inline(always)]
    fn row(&self, i: u32) -> &T {
        &self.0[i as usize & (FIXED_ROWS - 1)]
    }
}

/// Any other buffer: checked loads.
impl<T: Sync> Rows<T> for &[T] {
    #[inline(always)]
    fn row(&self, i: u32) -> &T {
        &self[i as usize]
    }
}

/// Evaluates `$body` with `$rows` bound to the slice `$buf` as a
/// [`Rows`](crate::spatial::gather::Rows): a [`FixedRows`](crate::spatial::gather::FixedRows) view when
/// it has [`FIXED_ROWS`](crate::spatial::gather::FIXED_ROWS) rows, the slice itself otherwise.
/// `$body` is compiled once for each, so keep it to the kernel.
#[macro_export]
macro_rules! with_rows {
    ($buf:expr, |$rows:ident| $body:expr) => {{
        let buf = $buf;
        match <&[_; $crate::spatial::gather::FIXED_ROWS]>::try_from(buf) {
            Ok(b) => {
                let $rows = $crate::spatial::gather::FixedRows(b);
                $body
            }
            Err(_) => {
                let $rows = buf;
                $body
            }
        }
    }};
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Through the macro, every used row of a buffer of either kind is the row the
    /// checked slice returns, for used lengths past half of the fixed length (where a
    /// wrong mask would wrap) and past it (checked).
    #[test]
    fn fixed_views_read_the_checked_rows() {
        fn read_all(rows: &impl Rows<u64>, n: usize) -> Vec<u64> {
            (0..n as u32).map(|i| *rows.row(i)).collect()
        }
        for n in [3, 40_000, FIXED_ROWS, FIXED_ROWS + 1] {
            let len = fixed_rows(n);
            assert_eq!(len, n.max(FIXED_ROWS), "{n}");
            let mut buf = vec![0u64; len];
            for (i, v) in buf.iter_mut().enumerate().take(n) {
                *v = (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
            }
            let want: Vec<u64> = buf[..n].to_vec();
            let got = crate::with_rows!(&buf[..], |rows| read_all(&rows, n));
            assert_eq!(got, want, "{n} rows in a buffer of {len}");
        }
    }

    /// Padded buffers stop at the budget, and dropping one frees its share: of twenty
    /// 64 MB buffers (rows of 1 KB) at most 16 are padded (1 GiB; other tests may hold
    /// some of it), the others hold exactly their rows, and after they are dropped a
    /// new one is padded again. A clone keeps the used rows.
    #[test]
    fn padded_buffers_stay_within_the_budget() {
        type Row = [[f32; 32]; 8];
        let bufs: Vec<RowBuffer<Row>> = (0..20).map(|_| RowBuffer::zeroed(100)).collect();
        let padded = bufs.iter().filter(|b| b.len() == FIXED_ROWS).count();
        assert!(
            padded <= FIXED_ROWS_BUDGET / (FIXED_ROWS * 1024),
            "{padded}"
        );
        assert!(bufs.iter().all(|b| b.len() == FIXED_ROWS || b.len() == 100));
        assert!(padded < 20);
        drop(bufs);
        let mut b = RowBuffer::<Row>::zeroed(100);
        assert_eq!(b.len(), FIXED_ROWS);
        b[7][3][1] = 2.5;
        let c = b.clone();
        assert_eq!(c[7][3][1], 2.5);
        assert!(c.serves(100) && !c.serves(101));
    }
}
