//! Gathers of rows by index without a bounds check per load, in safe code.
//!
//! The lane kernels read per-phyxel rows by index (the MLS stencil's neighbours, the
//! advection's affine table), eight per slot. Indexing a slice checks every load; in
//! those loops the checks were about a tenth of the instructions. A buffer of exactly
//! [`FIXED_ROWS`] rows (a power of two known at compile time), indexed with the index
//! masked to it, needs no check: the compiler can see every index is in bounds. So such
//! buffers get [`fixed_rows`] rows, and [`with_rows!`](crate::with_rows) hands a kernel
//! a [`FixedRows`] view of them, or the plain slice (checked) for bodies of more rows.
//! Every index a kernel uses is below the buffer's used length, so the mask changes
//! none. A mask taken at run time (`i & (len − 1)`) does not do it: the compiler keeps
//! the check and adds the `and`; a smaller fixed length (1,024) masks with an `and`
//! per load and gained nothing (measured with `cargo bench --bench kernels`).

/// Rows of a buffer whose gathers need no bounds checks: 65,536, so that the masked
/// index is the low half of the `u32` (one zero-extending load).
pub const FIXED_ROWS: usize = 1 << 16;

/// The length to give a gathered buffer that uses `n` rows: [`FIXED_ROWS`] when they
/// fit, else `n` (checked gathers). Allocate it zeroed (`vec![zero; len]` of a type
/// whose zero is all-zero bytes, such as `f32` arrays): the pages of the rows past `n`
/// are then never touched, so a small body's buffer costs address space, not memory.
pub fn fixed_rows(n: usize) -> usize {
    if n <= FIXED_ROWS { FIXED_ROWS } else { n }
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
}
