//! How arrays sit in the payload: little-endian byte slices borrowed from the image (never
//! copied, no alignment needed), decoded one element at a time.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A byte slice borrowed from the image (postcard: a length, then the bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Bytes<'a>(pub &'a [u8]);

impl Serialize for Bytes<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(self.0)
    }
}

impl<'de: 'a, 'a> Deserialize<'de> for Bytes<'a> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        <&'a [u8]>::deserialize(d).map(Bytes)
    }
}

impl Bytes<'_> {
    /// Number of `width`-byte elements, if the length is a whole multiple.
    pub fn count(&self, width: usize) -> Option<usize> {
        self.0
            .len()
            .is_multiple_of(width)
            .then_some(self.0.len() / width)
    }

    /// Element `i` as u32 LE.
    pub fn u32_at(&self, i: usize) -> u32 {
        let b = &self.0[4 * i..4 * i + 4];
        u32::from_le_bytes([b[0], b[1], b[2], b[3]])
    }

    /// Element `i` as u16 LE.
    pub fn u16_at(&self, i: usize) -> u16 {
        u16::from_le_bytes([self.0[2 * i], self.0[2 * i + 1]])
    }

    /// Element `i` as f32 LE.
    pub fn f32_at(&self, i: usize) -> f32 {
        f32::from_bits(self.u32_at(i))
    }

    /// Element `i` as f64 LE.
    pub fn f64_at(&self, i: usize) -> f64 {
        let b = &self.0[8 * i..8 * i + 8];
        f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]])
    }
}

/// A half-precision value (IEEE binary16 bits) as f64, for finite values: the exponent and
/// mantissa bits moved into single-precision position and re-biased by one multiplication by
/// 2^112 (which also turns subnormals into the right normal numbers). Branch-free and exact for
/// every finite half; images are checked to hold only finite values.
#[inline(always)]
pub fn f16_bits_to_f64(h: u16) -> f64 {
    const REBIAS: f32 = 5.192_297e33; // 2^112
    let sign = u32::from(h & 0x8000) << 16;
    let magnitude = f32::from_bits(u32::from(h & 0x7FFF) << 13) * REBIAS;
    f64::from(f32::from_bits(magnitude.to_bits() | sign))
}

/// Storage precision of real values (form factors, direct illuminance on patches).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum Precision {
    /// 8-byte IEEE double.
    F64 = 0,
    /// 4-byte IEEE single.
    F32 = 1,
    /// 2-byte IEEE half.
    F16 = 2,
    /// 16-bit fraction of a per-row scale (the default: f32's accuracy at half the size).
    #[default]
    U16 = 3,
    /// 8-bit fraction of a per-row scale.
    U8 = 4,
}

impl Precision {
    /// From the stored code.
    pub fn from_code(c: u8) -> Option<Self> {
        Some(match c {
            0 => Self::F64,
            1 => Self::F32,
            2 => Self::F16,
            3 => Self::U16,
            4 => Self::U8,
            _ => return None,
        })
    }

    /// Bytes per value.
    pub fn width(self) -> usize {
        match self {
            Self::F64 => 8,
            Self::F32 => 4,
            Self::F16 | Self::U16 => 2,
            Self::U8 => 1,
        }
    }

    /// True when values are fractions of a per-row scale.
    pub fn scaled(self) -> bool {
        matches!(self, Self::U16 | Self::U8)
    }

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            Self::F64 => "f64",
            Self::F32 => "f32",
            Self::F16 => "f16",
            Self::U16 => "u16",
            Self::U8 => "u8",
        }
    }
}

/// Real values in one precision, with per-row scales for the scaled (integer) precisions.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Values<'a> {
    /// [`Precision`] code.
    pub precision: u8,
    /// f32 per row (scaled precisions only; empty otherwise).
    #[serde(borrow)]
    pub scales: Bytes<'a>,
    /// The values.
    #[serde(borrow)]
    pub data: Bytes<'a>,
}

impl Values<'_> {
    /// The precision (valid after [`super::Image::parse`]).
    pub fn precision(&self) -> Precision {
        Precision::from_code(self.precision).unwrap_or_default()
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        self.data.0.len() / self.precision().width()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Value `i`, in row `row` (for the scale).
    pub fn get(&self, i: usize, row: usize) -> f64 {
        match self.precision() {
            Precision::F64 => self.data.f64_at(i),
            Precision::F32 => f64::from(self.data.f32_at(i)),
            Precision::F16 => f16_bits_to_f64(self.data.u16_at(i)),
            Precision::U16 => {
                f64::from(self.data.u16_at(i)) / 65535.0 * f64::from(self.scales.f32_at(row))
            }
            Precision::U8 => f64::from(self.data.0[i]) / 255.0 * f64::from(self.scales.f32_at(row)),
        }
    }
}

/// A sparse matrix (compressed rows) in the payload.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sparse<'a> {
    /// Rows.
    pub rows: u32,
    /// Row starts, u32 LE, `rows + 1` of them.
    #[serde(borrow)]
    pub row_ptr: Bytes<'a>,
    /// Bytes per column index: 2 (u16) or 4 (u32).
    pub col_width: u8,
    /// Column indices.
    #[serde(borrow)]
    pub col: Bytes<'a>,
    /// Values, one per column index.
    #[serde(borrow)]
    pub values: Values<'a>,
}

impl Sparse<'_> {
    /// The entry range of row `i`.
    pub fn row_range(&self, i: usize) -> core::ops::Range<usize> {
        self.row_ptr.u32_at(i) as usize..self.row_ptr.u32_at(i + 1) as usize
    }

    /// Column of entry `k`.
    pub fn col_at(&self, k: usize) -> usize {
        if self.col_width == 2 {
            usize::from(self.col.u16_at(k))
        } else {
            self.col.u32_at(k) as usize
        }
    }

    /// `Σ_j A_ij x_j` for row `i`, f64 accumulation. The encoding is dispatched once per row,
    /// so each case is a tight loop over exact-size chunks (the solver's inner loop).
    pub fn row_dot(&self, i: usize, x: &[f64]) -> f64 {
        let r = self.row_range(i);
        let p = self.values.precision();
        let vw = p.width();
        let cw = usize::from(self.col_width);
        let cols = &self.col.0[cw * r.start..cw * r.end];
        let vals = &self.values.data.0[vw * r.start..vw * r.end];
        let scale = |levels: f64| {
            if p.scaled() {
                f64::from(self.values.scales.f32_at(i)) / levels
            } else {
                1.0
            }
        };
        macro_rules! dot {
            ($cw:literal, $vw:literal, $col:expr, $val:expr) => {{
                let mut s = 0.0;
                for (c, v) in cols.chunks_exact($cw).zip(vals.chunks_exact($vw)) {
                    s += $val(v) * x[$col(c)];
                }
                s
            }};
        }
        let c16 = |c: &[u8]| usize::from(u16::from_le_bytes([c[0], c[1]]));
        let c32 = |c: &[u8]| u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as usize;
        let f64v = |v: &[u8]| f64::from_le_bytes([v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]]);
        let f32v = |v: &[u8]| f64::from(f32::from_le_bytes([v[0], v[1], v[2], v[3]]));
        let f16v = |v: &[u8]| f16_bits_to_f64(u16::from_le_bytes([v[0], v[1]]));
        let u16v = |v: &[u8]| f64::from(u16::from_le_bytes([v[0], v[1]]));
        let u8v = |v: &[u8]| f64::from(v[0]);
        match (cw, p) {
            (2, Precision::F64) => dot!(2, 8, c16, f64v),
            (2, Precision::F32) => dot!(2, 4, c16, f32v),
            (2, Precision::F16) => dot!(2, 2, c16, f16v),
            (2, Precision::U16) => dot!(2, 2, c16, u16v) * scale(65535.0),
            (2, Precision::U8) => dot!(2, 1, c16, u8v) * scale(255.0),
            (_, Precision::F64) => dot!(4, 8, c32, f64v),
            (_, Precision::F32) => dot!(4, 4, c32, f32v),
            (_, Precision::F16) => dot!(4, 2, c32, f16v),
            (_, Precision::U16) => dot!(4, 2, c32, u16v) * scale(65535.0),
            (_, Precision::U8) => dot!(4, 1, c32, u8v) * scale(255.0),
        }
    }

    /// `acc[q] += Σ_j A_ij x[j·k + q]` for `k = acc.len()` right-hand sides (entry by entry:
    /// for the rare solves of several right-hand sides straight from the image).
    pub fn row_dot_k(&self, i: usize, x: &[f64], acc: &mut [f64]) {
        let k = acc.len();
        for e in self.row_range(i) {
            let (v, j) = (self.values.get(e, i), self.col_at(e));
            for (a, xj) in acc.iter_mut().zip(&x[j * k..j * k + k]) {
                *a += v * xj;
            }
        }
    }

    /// `Σ_j A_ij x[j·k + q]` for row `i`: one right-hand side of `k`.
    pub fn row_dot_column(&self, i: usize, x: &[f64], k: usize, q: usize) -> f64 {
        if k == 1 {
            return self.row_dot(i, x);
        }
        let mut s = 0.0;
        for e in self.row_range(i) {
            s += self.values.get(e, i) * x[self.col_at(e) * k + q];
        }
        s
    }

    /// Number of entries.
    pub fn nnz(&self) -> usize {
        if self.rows == 0 {
            0
        } else {
            self.row_ptr.u32_at(self.rows as usize) as usize
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_half_conversion_is_exact_for_every_finite_half() {
        for bits in 0..=u16::MAX {
            let h = half::f16::from_bits(bits);
            if h.is_finite() {
                assert_eq!(f16_bits_to_f64(bits), h.to_f64(), "{bits:#06x}");
            }
        }
    }

    #[test]
    fn decodes_each_precision() {
        let f64s = 0.3f64.to_le_bytes();
        let v = Values {
            precision: 0,
            scales: Bytes(&[]),
            data: Bytes(&f64s),
        };
        assert_eq!(v.get(0, 0), 0.3);
        let f32s = 0.3f32.to_le_bytes();
        let v = Values {
            precision: 1,
            scales: Bytes(&[]),
            data: Bytes(&f32s),
        };
        assert_eq!(v.get(0, 0), f64::from(0.3f32));
        let h = half::f16::from_f64(0.3).to_bits().to_le_bytes();
        let v = Values {
            precision: 2,
            scales: Bytes(&[]),
            data: Bytes(&h),
        };
        assert!((v.get(0, 0) - 0.3).abs() < 2e-4);
        let scale = 0.6f32.to_le_bytes();
        let q = 32768u16.to_le_bytes();
        let v = Values {
            precision: 3,
            scales: Bytes(&scale),
            data: Bytes(&q),
        };
        assert!((v.get(0, 0) - 0.6 * 32768.0 / 65535.0).abs() < 1e-7);
        let v = Values {
            precision: 4,
            scales: Bytes(&scale),
            data: Bytes(&[255]),
        };
        assert!((v.get(0, 0) - f64::from(0.6f32)).abs() < 1e-12);
    }
}
