//! The radiosity solve for many right-hand sides at once (one per luminaire at 100 %):
//! Gauss-Seidel sweeps that read each form factor once per sweep for all of them.
//!
//! Solving luminaire by luminaire reads the whole sparse matrix once per sweep *per luminaire*:
//! on a 60-luminaire floor with 4 M entries that is 60 × 50 MB per sweep, and the solve is
//! bound by memory traffic. Here the exitances are stored patch-major (`b[i·L + l]`), so a sweep
//! streams the matrix once and, for each entry `F_ij`, updates the `L` values of row `i` from
//! the `L` contiguous values of patch `j`. Each right-hand side follows exactly the iteration of
//! [`crate::solver::gauss_seidel`] (same order, same values): the stop is the same test per
//! right-hand side (relative change, then relative residual, both ≤ tolerance), and the sweeps
//! continue until every right-hand side has stopped. The right-hand sides are split into one
//! block per thread.

use rayon::prelude::*;

use super::formfactor::Csr;
use crate::solver::{self, CsrSystem, SolveError, SolveOptions, SolveReport};

/// One right-hand side's exitances and how its solve went.
type Solved = (Vec<f64>, SolveReport);

/// Solves `B_l = ρ (E_l + F B_l)` for every `E_l` in `e_direct_lx` (each of the patch count).
/// Returns one `(B_l, report)` per right-hand side, or the first error.
pub fn solve_all(
    f: &Csr,
    rho: &[f64],
    e_direct_lx: &[Vec<f64>],
    options: SolveOptions,
) -> Result<Vec<Solved>, SolveError> {
    let system = CsrSystem { f: f.view(), rho };
    f.view().validate(rho.len())?;
    for e in e_direct_lx {
        solver::check_inputs(&system, e)?;
    }
    if e_direct_lx.is_empty() {
        return Ok(Vec::new());
    }
    let threads = rayon::current_num_threads().max(1);
    let per_block = e_direct_lx.len().div_ceil(threads).max(1);
    let blocks: Vec<Result<Vec<Solved>, SolveError>> = e_direct_lx
        .par_chunks(per_block)
        .map(|chunk| solve_block(f, rho, chunk, options))
        .collect();
    let mut out = Vec::with_capacity(e_direct_lx.len());
    for b in blocks {
        out.extend(b?);
    }
    Ok(out)
}

fn solve_block(
    f: &Csr,
    rho: &[f64],
    e: &[Vec<f64>],
    options: SolveOptions,
) -> Result<Vec<Solved>, SolveError> {
    let n = rho.len();
    let l = e.len();
    // patch-major: e_pm[i·L + k]
    let mut e_pm = vec![0.0; n * l];
    for (k, ek) in e.iter().enumerate() {
        for i in 0..n {
            e_pm[i * l + k] = ek[i];
        }
    }
    let mut b = vec![0.0; n * l];
    let mut acc = vec![0.0; l];
    let mut done: Vec<Option<SolveReport>> = vec![None; l];
    let mut previous = vec![f64::INFINITY; l];
    let mut stalled = vec![0u32; l];
    let mut max_change = vec![0.0f64; l];
    let mut max_b = vec![0.0f64; l];
    for it in 1..=options.max_iterations {
        max_change.iter_mut().for_each(|x| *x = 0.0);
        max_b.iter_mut().for_each(|x| *x = 0.0);
        for i in 0..n {
            acc.copy_from_slice(&e_pm[i * l..(i + 1) * l]);
            let (a, z) = (f.row_ptr[i] as usize, f.row_ptr[i + 1] as usize);
            for (&j, &v) in f.col[a..z].iter().zip(&f.val[a..z]) {
                let bj = &b[j as usize * l..(j as usize + 1) * l];
                for (s, x) in acc.iter_mut().zip(bj) {
                    *s += v * x;
                }
            }
            let r = rho[i];
            let bi = &mut b[i * l..(i + 1) * l];
            for k in 0..l {
                if done[k].is_some() {
                    continue;
                }
                let new = r * acc[k];
                if !new.is_finite() {
                    return Err(SolveError::Diverged);
                }
                max_change[k] = max_change[k].max((new - bi[k]).abs());
                max_b[k] = max_b[k].max(new.abs());
                bi[k] = new;
            }
        }
        for k in 0..l {
            if done[k].is_some() {
                continue;
            }
            if !(max_change[k].is_finite() && max_b[k].is_finite()) {
                return Err(SolveError::Diverged);
            }
            let rel_change = if max_b[k] > 0.0 {
                max_change[k] / max_b[k]
            } else {
                0.0
            };
            if rel_change <= options.tolerance {
                let r = residual(f, rho, &e_pm, &b, l, k);
                if r <= options.tolerance {
                    done[k] = Some(SolveReport {
                        iterations: it,
                        residual: r,
                    });
                    continue;
                }
            }
            if rel_change < previous[k] * (1.0 - 1e-9) {
                stalled[k] = 0;
            } else {
                stalled[k] += 1;
                if stalled[k] > 50 {
                    return Err(SolveError::NotConverged {
                        iterations: it,
                        residual: residual(f, rho, &e_pm, &b, l, k),
                    });
                }
            }
            previous[k] = rel_change;
        }
        if done.iter().all(Option::is_some) {
            break;
        }
    }
    (0..l)
        .map(|k| {
            let report = done[k].ok_or(SolveError::NotConverged {
                iterations: options.max_iterations,
                residual: residual(f, rho, &e_pm, &b, l, k),
            })?;
            Ok(((0..n).map(|i| b[i * l + k]).collect(), report))
        })
        .collect()
}

/// The relative residual of right-hand side `k`: `max |B − ρ (E + F B)| / max |B|`.
fn residual(f: &Csr, rho: &[f64], e_pm: &[f64], b: &[f64], l: usize, k: usize) -> f64 {
    let mut num: f64 = 0.0;
    let mut den: f64 = 0.0;
    for i in 0..rho.len() {
        let g: f64 = f.row(i).map(|(j, v)| v * b[j as usize * l + k]).sum();
        let r = b[i * l + k] - rho[i] * (e_pm[i * l + k] + g);
        if !r.is_finite() {
            return f64::INFINITY;
        }
        num = num.max(r.abs());
        den = den.max(b[i * l + k].abs());
    }
    if den > 0.0 { num / den } else { num }
}
