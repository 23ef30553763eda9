//! The radiosity solve, `no_std` and allocation-free: the run-time core runs it over form
//! factors borrowed from the flash image, commissioning over its own.
//!
//! | symbol | meaning | unit | here |
//! |---|---|---|---|
//! | B_i | luminous exitance of patch i (radiosity) | lm/m² | `b_lm_per_m2[i]` |
//! | E^dir_i | direct illuminance on patch i from the luminaires | lx | `e_direct_lx[i]` |
//! | ρ_i | diffuse reflectance, in [0, 1) | 1 | [`RadiositySystem::rho`] |
//! | F_ij | form factor patch i → patch j | 1 | [`RadiositySystem::gather`] |
//!
//! The system is `B_i = ρ_i (E^dir_i + Σ_j F_ij B_j)` (physics.md §3.6: emission enters as
//! illuminance, there is no factor π anywhere). The incident illuminance of a patch is
//! `E_i = E^dir_i + Σ_j F_ij B_j`.
//!
//! Gauss-Seidel sweeps, f64 accumulation, stop when the relative residual
//! `max_i |B_i − ρ_i (E^dir_i + Σ_j F_ij B_j)| / max_i |B_i|` is below the tolerance. With
//! ρ < 1 and row sums ≤ 1 the iteration contracts; anything else (ρ ≥ 1, non-finite input, a
//! residual that stops falling) is an error, and a NaN never leaves the solver.

/// The linear system, as the solver sees it: reflectances and sparse form-factor rows.
pub trait RadiositySystem {
    /// Number of patches.
    fn len(&self) -> usize;
    /// Reflectance ρ_i.
    fn rho(&self, i: usize) -> f64;
    /// `Σ_j F_ij x_j` (f64 accumulation).
    fn gather(&self, i: usize, x: &[f64]) -> f64;
    /// True when there are no patches.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A form-factor value type that the sparse rows may be stored in.
pub trait FormFactorValue: Copy {
    /// As f64.
    fn to_f64(self) -> f64;
}

impl FormFactorValue for f64 {
    fn to_f64(self) -> f64 {
        self
    }
}

impl FormFactorValue for f32 {
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}

/// Compressed sparse rows over borrowed slices (CSR).
#[derive(Debug, Clone, Copy)]
pub struct CsrView<'a, V> {
    /// Row `i` is `col[row_ptr[i]..row_ptr[i + 1]]`; length n + 1.
    pub row_ptr: &'a [u32],
    /// Column indices.
    pub col: &'a [u32],
    /// Values.
    pub val: &'a [V],
}

impl<V: FormFactorValue> CsrView<'_, V> {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.row_ptr.len().saturating_sub(1)
    }

    /// `Σ_j A_ij x_j` for row `i`.
    pub fn row_dot(&self, i: usize, x: &[f64]) -> f64 {
        let (a, b) = (self.row_ptr[i] as usize, self.row_ptr[i + 1] as usize);
        let mut s = 0.0;
        for k in a..b {
            s += self.val[k].to_f64() * x[self.col[k] as usize];
        }
        s
    }

    /// Checks the structure: monotone row pointers, columns below `n_cols`, finite values.
    pub fn validate(&self, n_cols: usize) -> Result<(), SolveError> {
        if self.row_ptr.first().copied().unwrap_or(1) != 0 {
            return Err(SolveError::Malformed);
        }
        if self.row_ptr.windows(2).any(|w| w[1] < w[0]) {
            return Err(SolveError::Malformed);
        }
        let nnz = *self.row_ptr.last().unwrap_or(&0) as usize;
        if nnz != self.col.len() || nnz != self.val.len() {
            return Err(SolveError::Malformed);
        }
        if self.col.iter().any(|&c| c as usize >= n_cols) {
            return Err(SolveError::Malformed);
        }
        if self
            .val
            .iter()
            .any(|v| !v.to_f64().is_finite() || v.to_f64() < 0.0)
        {
            return Err(SolveError::NonFiniteInput);
        }
        Ok(())
    }
}

/// A system from a CSR view and a reflectance slice.
#[derive(Debug, Clone, Copy)]
pub struct CsrSystem<'a, V> {
    /// Form factors.
    pub f: CsrView<'a, V>,
    /// Reflectances.
    pub rho: &'a [f64],
}

impl<V: FormFactorValue> RadiositySystem for CsrSystem<'_, V> {
    fn len(&self) -> usize {
        self.rho.len()
    }
    fn rho(&self, i: usize) -> f64 {
        self.rho[i]
    }
    fn gather(&self, i: usize, x: &[f64]) -> f64 {
        self.f.row_dot(i, x)
    }
}

/// When to stop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveOptions {
    /// Relative residual to reach.
    pub tolerance: f64,
    /// Sweeps before giving up.
    pub max_iterations: u32,
}

impl Default for SolveOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-10,
            max_iterations: 100_000,
        }
    }
}

/// How a solve went.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveReport {
    /// Sweeps done.
    pub iterations: u32,
    /// Final relative residual.
    pub residual: f64,
}

/// Why a solve failed. No partial result is returned with an error.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// A reflectance outside [0, 1).
    #[error("patch {patch}: reflectance {rho} is outside [0, 1)")]
    BadReflectance {
        /// The patch.
        patch: usize,
        /// Its reflectance.
        rho: f64,
    },
    /// A NaN, an infinity or a negative value in the input.
    #[error("non-finite or negative input (direct illuminance or form factor)")]
    NonFiniteInput,
    /// Slice lengths disagree or the sparse structure is broken.
    #[error("malformed system: lengths or sparse structure inconsistent")]
    Malformed,
    /// The residual did not fall below the tolerance.
    #[error("not converged after {iterations} iterations (residual {residual:e})")]
    NotConverged {
        /// Sweeps done.
        iterations: u32,
        /// Residual reached.
        residual: f64,
    },
    /// The iteration produced a non-finite value (diverging system).
    #[error("the iteration diverged (non-finite exitance)")]
    Diverged,
}

/// Checks the inputs once: reflectances in [0, 1), finite non-negative direct illuminance.
pub fn check_inputs<S: RadiositySystem>(sys: &S, e_direct_lx: &[f64]) -> Result<(), SolveError> {
    if e_direct_lx.len() != sys.len() {
        return Err(SolveError::Malformed);
    }
    for (i, &e) in e_direct_lx.iter().enumerate() {
        let rho = sys.rho(i);
        if !(rho.is_finite() && (0.0..1.0).contains(&rho)) {
            return Err(SolveError::BadReflectance { patch: i, rho });
        }
        if !(e.is_finite() && e >= 0.0) {
            return Err(SolveError::NonFiniteInput);
        }
    }
    Ok(())
}

/// The relative residual of `b`: `max |B − ρ (E + F B)| / max |B|` (0 for an all-dark room).
pub fn residual<S: RadiositySystem>(sys: &S, e_direct_lx: &[f64], b: &[f64]) -> f64 {
    let mut num: f64 = 0.0;
    let mut den: f64 = 0.0;
    for i in 0..sys.len() {
        let r = b[i] - sys.rho(i) * (e_direct_lx[i] + sys.gather(i, b));
        if !r.is_finite() {
            return f64::INFINITY;
        }
        num = num.max(r.abs());
        den = den.max(b[i].abs());
    }
    if den > 0.0 { num / den } else { num }
}

/// Solves `B = ρ (E^dir + F B)` by Gauss-Seidel into `b_lm_per_m2` (its content is the start
/// value; zeros are fine). On error `b_lm_per_m2` is zeroed.
pub fn gauss_seidel<S: RadiositySystem>(
    sys: &S,
    e_direct_lx: &[f64],
    b_lm_per_m2: &mut [f64],
    options: SolveOptions,
) -> Result<SolveReport, SolveError> {
    let result = gauss_seidel_inner(sys, e_direct_lx, b_lm_per_m2, options);
    if result.is_err() {
        b_lm_per_m2.iter_mut().for_each(|x| *x = 0.0);
    }
    result
}

fn gauss_seidel_inner<S: RadiositySystem>(
    sys: &S,
    e: &[f64],
    b: &mut [f64],
    options: SolveOptions,
) -> Result<SolveReport, SolveError> {
    if b.len() != sys.len() {
        return Err(SolveError::Malformed);
    }
    check_inputs(sys, e)?;
    if b.iter().any(|x| !x.is_finite()) {
        b.iter_mut().for_each(|x| *x = 0.0);
    }
    let n = sys.len();
    let mut previous = f64::INFINITY;
    let mut stalled = 0u32;
    for it in 1..=options.max_iterations {
        let mut max_change: f64 = 0.0;
        let mut max_b: f64 = 0.0;
        for i in 0..n {
            let new = sys.rho(i) * (e[i] + sys.gather(i, b));
            // f64::max ignores NaN, so test every value explicitly
            if !new.is_finite() {
                return Err(SolveError::Diverged);
            }
            max_change = max_change.max((new - b[i]).abs());
            max_b = max_b.max(new.abs());
            b[i] = new;
        }
        if !(max_change.is_finite() && max_b.is_finite()) {
            return Err(SolveError::Diverged);
        }
        let rel_change = if max_b > 0.0 { max_change / max_b } else { 0.0 };
        if rel_change <= options.tolerance {
            let r = residual(sys, e, b);
            if r <= options.tolerance {
                return Ok(SolveReport {
                    iterations: it,
                    residual: r,
                });
            }
        }
        // A contraction shrinks the change every sweep (slowly when ρ is near 1); a change that
        // stops falling means rounding noise above the tolerance, or no contraction at all.
        if rel_change < previous * (1.0 - 1e-9) {
            stalled = 0;
        } else {
            stalled += 1;
            if stalled > 50 {
                return Err(SolveError::NotConverged {
                    iterations: it,
                    residual: residual(sys, e, b),
                });
            }
        }
        previous = rel_change;
    }
    Err(SolveError::NotConverged {
        iterations: options.max_iterations,
        residual: residual(sys, e, b),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two facing unit squares at distance 1 (physics.md §10 D1).
    fn two_squares(rho: f64) -> ([u32; 3], [u32; 2], [f64; 2], [f64; 2]) {
        let f = 0.199825;
        ([0, 1, 2], [1, 0], [f, f], [rho, rho])
    }

    #[test]
    fn two_facing_squares_closed_form() {
        // e1 = 1 as an emission: with E^dir = e/ρ the system B = e + ρ F B is the same.
        let (rp, col, val, rho) = two_squares(0.5);
        let sys = CsrSystem {
            f: CsrView {
                row_ptr: &rp,
                col: &col,
                val: &val,
            },
            rho: &rho,
        };
        let e = [1.0 / 0.5, 0.0];
        let mut b = [0.0; 2];
        let r = gauss_seidel(&sys, &e, &mut b, SolveOptions::default()).unwrap();
        assert!((b[0] - 1.010083).abs() < 1e-6, "{b:?}");
        assert!((b[1] - 0.100920).abs() < 1e-6, "{b:?}");
        // incident: H1 = F B2, H2 = F B1
        assert!((sys.gather(0, &b) - 0.020166).abs() < 1e-6);
        assert!((sys.gather(1, &b) - 0.201840).abs() < 1e-6);
        assert!(r.residual <= 1e-10);
    }

    #[test]
    fn bad_inputs_are_errors_and_leave_no_nan() {
        let (rp, col, val, _) = two_squares(0.5);
        for (rho, e) in [
            ([1.0, 0.5], [1.0, 0.0]),
            ([0.5, 0.5], [f64::NAN, 0.0]),
            ([-0.1, 0.5], [1.0, 0.0]),
        ] {
            let sys = CsrSystem {
                f: CsrView {
                    row_ptr: &rp,
                    col: &col,
                    val: &val,
                },
                rho: &rho,
            };
            let mut b = [7.0, f64::NAN];
            assert!(gauss_seidel(&sys, &e, &mut b, SolveOptions::default()).is_err());
            assert_eq!(b, [0.0, 0.0]);
        }
    }

    #[test]
    fn nan_form_factor_is_an_error_not_a_result() {
        let (rp, col, _, rho) = two_squares(0.5);
        let val = [f64::NAN, 0.2];
        let sys = CsrSystem {
            f: CsrView {
                row_ptr: &rp,
                col: &col,
                val: &val,
            },
            rho: &rho,
        };
        let mut b = [0.0; 2];
        let err = gauss_seidel(&sys, &[1.0, 1.0], &mut b, SolveOptions::default()).unwrap_err();
        assert_eq!(err, SolveError::Diverged);
        assert_eq!(b, [0.0, 0.0]);
        let inf = [f64::INFINITY, 0.2];
        let sys = CsrSystem {
            f: CsrView {
                row_ptr: &rp,
                col: &col,
                val: &inf,
            },
            rho: &rho,
        };
        assert!(gauss_seidel(&sys, &[1.0, 1.0], &mut b, SolveOptions::default()).is_err());
    }

    #[test]
    fn iteration_cap_is_an_error() {
        let (rp, col, val, rho) = two_squares(0.99);
        let sys = CsrSystem {
            f: CsrView {
                row_ptr: &rp,
                col: &col,
                val: &val,
            },
            rho: &rho,
        };
        let mut b = [0.0; 2];
        let err = gauss_seidel(
            &sys,
            &[1.0, 0.0],
            &mut b,
            SolveOptions {
                tolerance: 1e-12,
                max_iterations: 2,
            },
        )
        .unwrap_err();
        assert!(matches!(
            err,
            SolveError::NotConverged { iterations: 2, .. }
        ));
    }

    #[test]
    fn csr_validation() {
        let v = CsrView::<f32> {
            row_ptr: &[0, 2],
            col: &[0, 5],
            val: &[0.1, 0.2],
        };
        assert_eq!(v.validate(2), Err(SolveError::Malformed));
        let v = CsrView::<f32> {
            row_ptr: &[0, 1],
            col: &[0],
            val: &[f32::NAN],
        };
        assert_eq!(v.validate(1), Err(SolveError::NonFiniteInput));
        let v = CsrView::<f32> {
            row_ptr: &[0, 1],
            col: &[0],
            val: &[0.5],
        };
        assert_eq!(v.validate(1), Ok(()));
    }
}
