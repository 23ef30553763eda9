//! The owned form of the sparse rows (std): what commissioning computes, what live light
//! decodes from the image once at boot.

use super::{CsrView, FormFactorValue};

/// Compressed sparse rows, owned: the form factors commissioning computes (f64) and the
/// decoded copies live light keeps (f32). [`Csr::view`] lends it to the solver.
#[derive(Debug, Clone, PartialEq)]
pub struct Csr<V = f64> {
    /// Row starts, length rows + 1.
    pub row_ptr: Vec<u32>,
    /// Column indices, ascending within a row.
    pub col: Vec<u32>,
    /// Values.
    pub val: Vec<V>,
}

impl<V> Default for Csr<V> {
    fn default() -> Self {
        Self {
            row_ptr: Vec::new(),
            col: Vec::new(),
            val: Vec::new(),
        }
    }
}

impl<V: FormFactorValue> Csr<V> {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.row_ptr.len().saturating_sub(1)
    }

    /// Entries of row `i` as (column, value).
    pub fn row(&self, i: usize) -> impl Iterator<Item = (u32, f64)> + '_ {
        let (a, b) = (self.row_ptr[i] as usize, self.row_ptr[i + 1] as usize);
        self.col[a..b]
            .iter()
            .copied()
            .zip(self.val[a..b].iter().map(|v| v.to_f64()))
    }

    /// Sum of row `i`.
    pub fn row_sum(&self, i: usize) -> f64 {
        self.row(i).map(|(_, v)| v).sum()
    }

    /// Value at (i, j), 0 when absent.
    pub fn get(&self, i: usize, j: u32) -> f64 {
        let (a, b) = (self.row_ptr[i] as usize, self.row_ptr[i + 1] as usize);
        match self.col[a..b].binary_search(&j) {
            Ok(k) => self.val[a + k].to_f64(),
            Err(_) => 0.0,
        }
    }

    /// A borrowed view for the solver.
    pub fn view(&self) -> CsrView<'_, V> {
        CsrView {
            row_ptr: &self.row_ptr,
            col: &self.col,
            val: &self.val,
        }
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.col.len()
    }

    /// Bytes held by the three arrays.
    pub fn bytes(&self) -> usize {
        4 * (self.row_ptr.len() + self.col.len()) + std::mem::size_of::<V>() * self.val.len()
    }

    /// Builds from per-row sorted (column, value) lists.
    pub fn from_rows(rows: Vec<Vec<(u32, V)>>) -> Self {
        let n = rows.len();
        let mut rows = rows.into_iter();
        Self::from_row_fn(n, |_| rows.next().unwrap_or_default())
    }

    /// Builds `rows` rows, row `i` from `row(i)`: (column, value) in ascending column order.
    pub fn from_row_fn<I, F>(rows: usize, mut row: F) -> Self
    where
        I: IntoIterator<Item = (u32, V)>,
        F: FnMut(usize) -> I,
    {
        let mut out = Csr {
            row_ptr: Vec::with_capacity(rows + 1),
            ..Csr::default()
        };
        out.row_ptr.push(0);
        for i in 0..rows {
            for (c, v) in row(i) {
                out.col.push(c);
                out.val.push(v);
            }
            out.row_ptr.push(out.col.len() as u32);
        }
        out
    }
}
