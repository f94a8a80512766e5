//! Updatable orthogonal (QR) factorisation of a tall matrix fed by rows.
//!
//! The accumulator keeps the `p × p` upper-triangular factor `R` of all rows
//! seen so far, together with a buffer of up to `block` pending rows, in one
//! column-major work array:
//!
//! ```text
//!   rows 0 .. p          R (upper triangle; zeros below)
//!   rows p .. p+filled   pending rows
//! ```
//!
//! When the buffer is full, faer's blocked Householder QR factorises the
//! stacked `[R; block]` in place and the new triangle replaces `R`. Because
//! `[R; block]` has the same Gram matrix as all rows so far, the final `R` is
//! (up to row signs) the `R` factor of the whole matrix, computed by
//! orthogonal transformations only — memory is `O((p + block) · p)`,
//! independent of the number of rows.
//!
//! The callers put the response `y` in the last column, so with
//! `p = n_basis + 1` the last diagonal entry satisfies
//! `R[p-1, p-1]² = min ‖A a − y‖²` (the residual sum of squares) and
//! `R[..p-1, p-1] = Qᵀy` for the least-squares solve.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::qr::no_pivoting::factor::{qr_in_place, qr_in_place_scratch};
use faer::{Mat, MatMut, Par};

/// Default number of buffered rows per block update.
pub(crate) const DEFAULT_BLOCK_ROWS: usize = 2048;

pub(crate) struct QrAccumulator {
    p: usize,
    block: usize,
    /// Leading dimension (column stride) of `work`: `p + block`.
    ld: usize,
    work: Vec<f64>,
    filled: usize,
    householder: Mat<f64>,
    mem: MemBuffer,
}

impl std::fmt::Debug for QrAccumulator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("QrAccumulator")
            .field("p", &self.p)
            .field("block", &self.block)
            .field("filled", &self.filled)
            .finish_non_exhaustive()
    }
}

impl Clone for QrAccumulator {
    fn clone(&self) -> Self {
        let mut c = QrAccumulator::new(self.p, self.block);
        c.work.copy_from_slice(&self.work);
        c.filled = self.filled;
        c
    }
}

impl QrAccumulator {
    /// A new accumulator for rows of length `p`, buffering `block` rows.
    pub fn new(p: usize, block: usize) -> Self {
        let block = block.max(1);
        let ld = p + block;
        // Unblocked Householder (one reflector at a time, Householder factor
        // block size 1): for a matrix only d + 2 columns wide the compact-WY
        // blocked variant spends more forming its triangular factors than it
        // saves (measured ~1.7× slower at degree 5).
        let params = Default::default();
        let mem = MemBuffer::new(qr_in_place_scratch::<f64>(ld, p, 1, Par::Seq, params));
        QrAccumulator {
            p,
            block,
            ld,
            work: vec![0.0; ld * p],
            filled: 0,
            householder: Mat::zeros(1, p),
            mem,
        }
    }

    /// Number of free rows left in the pending block.
    #[inline]
    pub fn free_rows(&self) -> usize {
        self.block - self.filled
    }

    /// Gives the caller the next `n` pending rows to fill, as `p` column
    /// slices of length `n` (column `k` of those rows is `cols[k]`), then
    /// marks them as filled. `n` must not exceed [`free_rows`](Self::free_rows).
    /// Flushes automatically when the block becomes full.
    pub fn fill_rows(&mut self, n: usize, fill: impl FnOnce(&mut [&mut [f64]])) {
        debug_assert!(n <= self.free_rows());
        let start = self.p + self.filled;
        let mut cols: Vec<&mut [f64]> = self
            .work
            .chunks_exact_mut(self.ld)
            .map(|col| &mut col[start..start + n])
            .collect();
        fill(&mut cols);
        self.filled += n;
        if self.filled == self.block {
            self.flush();
        }
    }

    /// Factorises the pending rows into `R`.
    pub fn flush(&mut self) {
        if self.filled == 0 {
            return;
        }
        let p = self.p;
        let nrows = p + self.filled;
        let ld = self.ld;
        {
            let a: MatMut<'_, f64> =
                MatMut::from_column_major_slice_with_stride_mut(&mut self.work, nrows, p, ld);
            let h = self.householder.as_mut();
            qr_in_place(
                a,
                h,
                Par::Seq,
                MemStack::new(&mut self.mem),
                Default::default(),
            );
        }
        // Keep the upper triangle, clear the Householder vectors below it
        // (the pending rows below `p` are overwritten by the next fill).
        for (j, col) in self.work.chunks_exact_mut(ld).enumerate() {
            col[j + 1..p].fill(0.0);
        }
        self.filled = 0;
    }

    /// The current triangular factor (after flushing pending rows), row-major
    /// `p × p` with zeros below the diagonal, each row's sign normalised so
    /// the diagonal is non-negative.
    pub fn triangle(&mut self) -> Vec<f64> {
        self.flush();
        let p = self.p;
        let mut r = vec![0.0; p * p];
        for i in 0..p {
            let sign = if self.work[i * self.ld + i] < 0.0 {
                -1.0
            } else {
                1.0
            };
            for j in i..p {
                r[i * p + j] = sign * self.work[j * self.ld + i];
            }
        }
        r
    }
}

/// Solves `R x = b` for upper-triangular row-major `R` (`p × p`).
pub(crate) fn solve_upper(r: &[f64], p: usize, b: &[f64]) -> Vec<f64> {
    let mut x = b.to_vec();
    for i in (0..p).rev() {
        let s: f64 = (i + 1..p).map(|j| r[i * p + j] * x[j]).sum();
        x[i] = (x[i] - s) / r[i * p + i];
    }
    x
}

/// Solves `Rᵀ x = b` for upper-triangular row-major `R` (`p × p`).
pub(crate) fn solve_upper_transposed(r: &[f64], p: usize, b: &[f64]) -> Vec<f64> {
    let mut x = b.to_vec();
    for i in 0..p {
        let s: f64 = (0..i).map(|j| r[j * p + i] * x[j]).sum();
        x[i] = (x[i] - s) / r[i * p + i];
    }
    x
}

/// The leading `p × p` block of a row-major `(p+1) × (p+1)` augmented
/// triangle, and its last column (`Qᵀy`).
pub(crate) fn split_augmented(r_aug: &[f64], p: usize) -> (Vec<f64>, Vec<f64>, f64) {
    let q = p + 1;
    let mut r = vec![0.0; p * p];
    for i in 0..p {
        r[i * p..i * p + p].copy_from_slice(&r_aug[i * q..i * q + p]);
    }
    let qty = (0..p).map(|i| r_aug[i * q + p]).collect();
    (r, qty, r_aug[p * q + p])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `RᵀR` must equal `AᵀA` for a small matrix pushed in uneven pieces.
    #[test]
    fn gram_matrix_is_preserved_across_blocks() {
        let p = 3;
        let rows: Vec<[f64; 3]> = (0..23)
            .map(|i| {
                let t = i as f64 * 0.37 - 2.0;
                [1.0, t, (t * 1.3).sin()]
            })
            .collect();
        let mut acc = QrAccumulator::new(p, 5);
        let mut next = 0;
        while next < rows.len() {
            let n = acc.free_rows().min(rows.len() - next).min(3);
            acc.fill_rows(n, |cols| {
                for (k, col) in cols.iter_mut().enumerate() {
                    for (i, v) in col.iter_mut().enumerate() {
                        *v = rows[next + i][k];
                    }
                }
            });
            next += n;
        }
        let r = acc.triangle();
        for a in 0..p {
            for b in 0..p {
                let gram: f64 = rows.iter().map(|row| row[a] * row[b]).sum();
                let rtr: f64 = (0..p).map(|k| r[k * p + a] * r[k * p + b]).sum();
                assert!(
                    (gram - rtr).abs() < 1e-12 * gram.abs().max(1.0),
                    "{a},{b}: {gram} vs {rtr}"
                );
            }
        }
        for i in 0..p {
            assert!(r[i * p + i] >= 0.0);
            for j in 0..i {
                assert_eq!(r[i * p + j], 0.0);
            }
        }
    }

    #[test]
    fn triangular_solves_invert_each_other() {
        let r = [2.0, 1.0, -1.0, 0.0, 3.0, 0.5, 0.0, 0.0, 4.0];
        let b = [1.0, 2.0, 3.0];
        let x = solve_upper(&r, 3, &b);
        for i in 0..3 {
            let rx: f64 = (0..3).map(|j| r[i * 3 + j] * x[j]).sum();
            assert!((rx - b[i]).abs() < 1e-15);
        }
        let y = solve_upper_transposed(&r, 3, &b);
        for i in 0..3 {
            let rty: f64 = (0..3).map(|j| r[j * 3 + i] * y[j]).sum();
            assert!((rty - b[i]).abs() < 1e-15);
        }
    }
}
