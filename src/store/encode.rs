//! Encoding the payload's values and sparse rows (std: the image is built on the host; the
//! node reads it in place through [`super::values`]).

use super::values::{Bytes, Precision, Sparse, Values};
use crate::solver::Csr;

/// Encodes real values at `precision`, the scaled precisions with one scale per row
/// (`row_bounds`: the rows' starts and the end): (scales, data).
pub fn encode(values: &[f64], row_bounds: &[usize], precision: Precision) -> (Vec<u8>, Vec<u8>) {
    let mut scales = Vec::new();
    let mut data = Vec::with_capacity(values.len() * precision.width());
    match precision {
        Precision::F64 => values
            .iter()
            .for_each(|v| data.extend_from_slice(&v.to_le_bytes())),
        Precision::F32 => values
            .iter()
            .for_each(|v| data.extend_from_slice(&(*v as f32).to_le_bytes())),
        Precision::F16 => values
            .iter()
            .for_each(|v| data.extend_from_slice(&half::f16::from_f64(*v).to_bits().to_le_bytes())),
        Precision::U16 | Precision::U8 => {
            let levels = if precision == Precision::U16 {
                65535.0
            } else {
                255.0
            };
            for w in row_bounds.windows(2) {
                let row = &values[w[0]..w[1]];
                let max = row.iter().copied().fold(0.0f64, f64::max) as f32;
                scales.extend_from_slice(&max.to_le_bytes());
                let scale = f64::from(max);
                for v in row {
                    let q = if scale > 0.0 {
                        (v / scale * levels).round().clamp(0.0, levels)
                    } else {
                        0.0
                    };
                    if precision == Precision::U16 {
                        data.extend_from_slice(&(q as u16).to_le_bytes());
                    } else {
                        data.push(q as u8);
                    }
                }
            }
        }
    }
    (scales, data)
}

/// Sparse rows as stored, owned: row starts, columns, and value bytes ([`Sparse`] is its
/// borrowed form, read in place from flash).
#[derive(Debug, Clone)]
pub struct SparseBuf {
    rows: u32,
    row_ptr: Vec<u8>,
    col_width: u8,
    col: Vec<u8>,
    scales: Vec<u8>,
    data: Vec<u8>,
    precision: Precision,
}

impl SparseBuf {
    /// Encodes `m` (of `cols` columns) at `precision`, dropping entries below `prune_below`
    /// (each row rescaled to keep its sum, its energy).
    pub fn new(m: &Csr, cols: usize, precision: Precision, prune_below: f64) -> Self {
        let mut row_ptr = Vec::with_capacity(4 * (m.rows() + 1));
        let mut kept_cols: Vec<u32> = Vec::with_capacity(m.nnz());
        let mut kept_vals: Vec<f64> = Vec::with_capacity(m.nnz());
        let mut bounds = vec![0usize];
        row_ptr.extend_from_slice(&0u32.to_le_bytes());
        for i in 0..m.rows() {
            let sum: f64 = m.row(i).map(|(_, v)| v).sum();
            let start = kept_vals.len();
            for (c, v) in m.row(i) {
                if v > 0.0 && v >= prune_below {
                    kept_cols.push(c);
                    kept_vals.push(v);
                }
            }
            // keep each row's sum (its energy) when entries were dropped
            let kept: f64 = kept_vals[start..].iter().sum();
            if kept > 0.0 && (kept - sum).abs() > 0.0 {
                let s = sum / kept;
                kept_vals[start..].iter_mut().for_each(|v| *v *= s);
            }
            bounds.push(kept_vals.len());
            row_ptr.extend_from_slice(&(kept_vals.len() as u32).to_le_bytes());
        }
        let col_width: u8 = if cols <= 1 << 16 { 2 } else { 4 };
        let mut col = Vec::with_capacity(kept_cols.len() * usize::from(col_width));
        for c in kept_cols {
            if col_width == 2 {
                col.extend_from_slice(&(c as u16).to_le_bytes());
            } else {
                col.extend_from_slice(&c.to_le_bytes());
            }
        }
        let (scales, data) = encode(&kept_vals, &bounds, precision);
        Self {
            rows: m.rows() as u32,
            row_ptr,
            col_width,
            col,
            scales,
            data,
            precision,
        }
    }

    /// The borrowed form, as the payload holds it.
    pub fn view(&self) -> Sparse<'_> {
        Sparse {
            rows: self.rows,
            row_ptr: Bytes(&self.row_ptr),
            col_width: self.col_width,
            col: Bytes(&self.col),
            values: Values {
                precision: self.precision as u8,
                scales: Bytes(&self.scales),
                data: Bytes(&self.data),
            },
        }
    }
}
