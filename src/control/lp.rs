//! The covering linear programme of least-energy dimming, solved exactly by a dense
//! bounded-variable simplex on its dual. `no_std`, no allocation: the tableau lives in scratch
//! the caller owns ([`scratch_len`]).
//!
//! ## The programme
//!
//! ```text
//! (P)  minimise   Σ_j c_j x_j + Σ_k m_k s_k
//!      subject to Σ_j a_kj x_j + s_k ≥ b_k      for every row k (a desk's target, a uniformity row)
//!                 0 ≤ x_j ≤ 1,  s_k ≥ 0
//! ```
//!
//! `x_j` is luminaire j's light output (a fraction of full), `c_j ≥ 0` its power per unit of
//! output, `s_k` the shortfall of row k and `m_k > 0` its price, chosen so large that any
//! shortfall costs more than all the power there is: when every target can be met none is
//! short, and when some cannot, the answer is the closest feasible state (least priced
//! shortfall), then the least power.
//!
//! ## Why the dual
//!
//! ```text
//! (D)  maximise   Σ_k b_k y_k − Σ_j z_j
//!      subject to Σ_k a_kj y_k − z_j ≤ c_j      for every luminaire j
//!                 0 ≤ y_k ≤ m_k,  z_j ≥ 0
//! ```
//!
//! (D) has one row per luminaire (fewer than desks in an office), its slack basis is feasible at
//! once (c ≥ 0: no phase 1), and the bounds `y_k ≤ m_k` are kept as bounds, not rows. At the
//! optimum the luminaires' outputs are the dual prices of (D)'s rows, read off the objective row
//! under the slack columns: `x_j = −d(w_j)`.
//!
//! Pricing is Dantzig's largest reduced cost; after a run of degenerate pivots it switches to
//! Bland's rule, which cannot cycle. Iterations are capped ([`Lp::max_iterations`]).

use core::fmt;

/// Why no optimum was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LpError {
    /// The scratch is shorter than [`scratch_len`] says.
    Scratch {
        /// Needed, f64s.
        needed: usize,
        /// Given, f64s.
        given: usize,
    },
    /// A shape does not match (rows × luminaires of `a`, lengths of b, c, m, x).
    Shape,
    /// A coefficient is not finite, a cost is negative or a price not positive.
    Input,
    /// The iteration cap was reached (a bug or a pathological input).
    Iterations(u32),
}

impl fmt::Display for LpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LpError::Scratch { needed, given } => {
                write!(f, "LP scratch of {given} values, {needed} needed")
            }
            LpError::Shape => f.write_str("LP shapes do not match"),
            LpError::Input => f.write_str(
                "LP input not finite, a negative cost or a non-positive shortfall price",
            ),
            LpError::Iterations(n) => write!(f, "LP did not converge in {n} iterations"),
        }
    }
}

impl core::error::Error for LpError {}

/// The programme (P), borrowed.
#[derive(Debug, Clone, Copy)]
pub struct Lp<'a> {
    /// Rows.
    pub rows: usize,
    /// Luminaires (columns).
    pub luminaires: usize,
    /// `a_kj`, row-major (`a[k * luminaires + j]`).
    pub a: &'a [f64],
    /// `b_k`.
    pub b: &'a [f64],
    /// `c_j ≥ 0`.
    pub c: &'a [f64],
    /// `m_k > 0`.
    pub m: &'a [f64],
    /// Iteration cap.
    pub max_iterations: u32,
}

/// What the solve did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LpReport {
    /// Simplex iterations (pivots and bound flips).
    pub iterations: u32,
    /// The optimum of (P) (= of (D)).
    pub objective: f64,
}

/// Scratch f64s a problem of `rows` × `luminaires` needs.
pub const fn scratch_len(rows: usize, luminaires: usize) -> usize {
    let n = rows + 2 * luminaires; // y, z, w
    // tableau (L rows + objective) × (n columns + rhs), basis, bounds, states, basic values
    (luminaires + 1) * (n + 1) + luminaires + 2 * n + luminaires
}

/// Variable layout of (D): `y_0..y_{K-1}`, `z_0..z_{L-1}`, `w_0..w_{L-1}`.
struct Layout {
    k: usize,
    l: usize,
}

impl Layout {
    fn n(&self) -> usize {
        self.k + 2 * self.l
    }
    fn z(&self, j: usize) -> usize {
        self.k + j
    }
    fn w(&self, j: usize) -> usize {
        self.k + self.l + j
    }
}

const EPS: f64 = 1e-11;
const AT_LOWER: f64 = 0.0;
const AT_UPPER: f64 = 1.0;
const BASIC: f64 = 2.0;

impl Lp<'_> {
    fn check(&self, x: &[f64]) -> Result<(), LpError> {
        let (k, l) = (self.rows, self.luminaires);
        if self.a.len() != k.checked_mul(l).ok_or(LpError::Shape)?
            || self.b.len() != k
            || self.m.len() != k
            || self.c.len() != l
            || x.len() != l
        {
            return Err(LpError::Shape);
        }
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(finite(self.a) && finite(self.b) && finite(self.c) && finite(self.m))
            || self.c.iter().any(|&c| c < 0.0)
            || self.m.iter().any(|&m| m <= 0.0)
        {
            return Err(LpError::Input);
        }
        Ok(())
    }

    /// Solves (P): the optimal outputs into `x` (one per luminaire, in [0, 1]).
    pub fn solve(&self, x: &mut [f64], scratch: &mut [f64]) -> Result<LpReport, LpError> {
        self.check(x)?;
        let lay = Layout {
            k: self.rows,
            l: self.luminaires,
        };
        let (l, n) = (lay.l, lay.n());
        let needed = scratch_len(lay.k, l);
        if scratch.len() < needed {
            return Err(LpError::Scratch {
                needed,
                given: scratch.len(),
            });
        }
        let width = n + 1;
        let (tab, rest) = scratch.split_at_mut((l + 1) * width);
        let (basis_f, rest) = rest.split_at_mut(l);
        let (upper, rest) = rest.split_at_mut(n);
        // 0: nonbasic at its lower bound, 1: nonbasic at its upper bound, 2: basic
        let (state, rest) = rest.split_at_mut(n);
        let value = &mut rest[..l]; // values of the basic variables
        // rows 0..l: Σ_k a_kj y_k − z_j + w_j = c_j ; row l: objective (reduced costs, max)
        tab.iter_mut().for_each(|v| *v = 0.0);
        for j in 0..l {
            let row = &mut tab[j * width..(j + 1) * width];
            for (k, v) in row[..lay.k].iter_mut().enumerate() {
                *v = self.a[k * l + j];
            }
            row[lay.z(j)] = -1.0;
            row[lay.w(j)] = 1.0;
            row[n] = self.c[j];
            basis_f[j] = lay.w(j) as f64;
            value[j] = self.c[j];
        }
        {
            let obj = &mut tab[l * width..(l + 1) * width];
            // reduced costs d_j = c̃_j − c_Bᵀ B⁻¹ A_j; basis is w with zero cost
            obj[..lay.k].copy_from_slice(self.b);
            for j in 0..l {
                obj[lay.z(j)] = -1.0;
            }
        }
        for (i, u) in upper.iter_mut().enumerate() {
            *u = if i < lay.k { self.m[i] } else { f64::INFINITY };
        }
        state.iter_mut().for_each(|v| *v = 0.0);
        for j in 0..l {
            state[lay.w(j)] = BASIC;
        }
        let mut iterations = 0u32;
        let mut degenerate_run = 0u32;
        loop {
            if iterations >= self.max_iterations {
                return Err(LpError::Iterations(iterations));
            }
            let obj = &tab[l * width..(l + 1) * width];
            // entering variable: improving reduced cost (increase from lower: d > 0; decrease
            // from upper: d < 0); basic variables have d = 0
            let bland = degenerate_run > 50;
            let mut enter = None;
            let mut best = 0.0;
            for (jv, &d) in obj[..n].iter().enumerate() {
                if state[jv] == BASIC {
                    continue;
                }
                let gain = if state[jv] == AT_UPPER { -d } else { d };
                if gain > EPS * (1.0 + d.abs()) {
                    if bland {
                        enter = Some(jv);
                        break;
                    }
                    if gain > best {
                        best = gain;
                        enter = Some(jv);
                    }
                }
            }
            let Some(e) = enter else {
                break;
            };
            iterations += 1;
            // direction: t ≥ 0 is the change of v_e away from its bound
            let sign = if state[e] == AT_UPPER { -1.0 } else { 1.0 };
            // basic values move by −sign·t·α_i
            let mut t_max = upper[e]; // bound flip
            let mut leave: Option<(usize, bool)> = None; // (row, goes to its upper bound)
            for i in 0..l {
                let alpha = sign * tab[i * width + e];
                let bi = basis_f[i] as usize;
                if alpha > EPS {
                    let t = value[i] / alpha;
                    if t < t_max - EPS || (leave.is_none() && t <= t_max) {
                        t_max = t;
                        leave = Some((i, false));
                    }
                } else if alpha < -EPS && upper[bi].is_finite() {
                    let t = (upper[bi] - value[i]) / -alpha;
                    if t < t_max - EPS || (leave.is_none() && t <= t_max) {
                        t_max = t;
                        leave = Some((i, true));
                    }
                }
            }
            let t = t_max.max(0.0);
            if !t.is_finite() {
                // (D) unbounded cannot happen: every y is bounded, z and w only lose objective
                return Err(LpError::Iterations(iterations));
            }
            degenerate_run = if t <= EPS { degenerate_run + 1 } else { 0 };
            for i in 0..l {
                value[i] -= sign * t * tab[i * width + e];
            }
            match leave {
                None => {
                    // bound flip: v_e goes to its other bound, the basis stays
                    state[e] = if state[e] == AT_UPPER {
                        AT_LOWER
                    } else {
                        AT_UPPER
                    };
                }
                Some((r, to_upper)) => {
                    let out = basis_f[r] as usize;
                    state[out] = if to_upper { AT_UPPER } else { AT_LOWER };
                    let entering_value = if state[e] == AT_UPPER {
                        upper[e] - t
                    } else {
                        t
                    };
                    state[e] = BASIC;
                    pivot(tab, width, l, r, e);
                    basis_f[r] = e as f64;
                    value[r] = entering_value;
                }
            }
        }
        let obj = &tab[l * width..(l + 1) * width];
        for (j, xj) in x.iter_mut().enumerate() {
            *xj = (-obj[lay.w(j)]).clamp(0.0, 1.0);
        }
        let mut objective = 0.0;
        for (j, &xj) in x.iter().enumerate() {
            objective += self.c[j] * xj;
        }
        for k in 0..lay.k {
            let mut lhs = 0.0;
            for (j, &xj) in x.iter().enumerate() {
                lhs += self.a[k * l + j] * xj;
            }
            objective += self.m[k] * (self.b[k] - lhs).max(0.0);
        }
        Ok(LpReport {
            iterations,
            objective,
        })
    }
}

/// Gauss-Jordan pivot on (r, e) over every row, objective included.
fn pivot(tab: &mut [f64], width: usize, l: usize, r: usize, e: usize) {
    let p = tab[r * width + e];
    for v in &mut tab[r * width..(r + 1) * width] {
        *v /= p;
    }
    for i in 0..=l {
        if i == r {
            continue;
        }
        let f = tab[i * width + e];
        if f == 0.0 {
            continue;
        }
        for c in 0..width {
            let pv = tab[r * width + c];
            tab[i * width + c] -= f * pv;
        }
    }
}
