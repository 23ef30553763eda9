//! The radiosity solve for many right-hand sides at once (one per luminaire at 100 %), split
//! into one block per thread, each block solved by the run-time core's one iteration
//! ([`crate::solver::solve`]).
//!
//! Solving luminaire by luminaire reads the whole sparse matrix once per sweep *per luminaire*:
//! on a 60-luminaire floor with 4 M entries that is 60 × 50 MB per sweep, and the solve is
//! bound by memory traffic. The solver stores a block's exitances patch-major (`b[i·L + l]`),
//! so a sweep streams the matrix once for the block. Each right-hand side follows the
//! iteration of [`crate::solver::gauss_seidel`] and stops on its own (the same test, the same
//! values).

use rayon::prelude::*;

use super::formfactor::Csr;
use crate::solver::{self, CsrSystem, RhsState, Rows, SolveError, SolveOptions, SolveReport};

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
        .map(|chunk| solve_block(&system, chunk, options))
        .collect();
    let mut out = Vec::with_capacity(e_direct_lx.len());
    for b in blocks {
        out.extend(b?);
    }
    Ok(out)
}

/// One block of right-hand sides through the solver, patch-major in and out.
fn solve_block(
    system: &CsrSystem<'_, f64>,
    e: &[Vec<f64>],
    options: SolveOptions,
) -> Result<Vec<Solved>, SolveError> {
    let n = system.rho.len();
    let l = e.len();
    let mut e_pm = vec![0.0; n * l];
    for (k, ek) in e.iter().enumerate() {
        for i in 0..n {
            e_pm[i * l + k] = ek[i];
        }
    }
    let mut b = vec![0.0; n * l];
    let mut acc = vec![0.0; l];
    let mut state = vec![RhsState::default(); l];
    let work = solver::Workspace {
        acc: &mut acc,
        state: &mut state,
    };
    solver::solve(
        system,
        Rows::All,
        solver::Source::Irradiance(&e_pm),
        &mut b,
        work,
        options,
    )?;
    (0..l)
        .map(|k| {
            let report = state[k].done.ok_or(SolveError::Malformed)?;
            Ok(((0..n).map(|i| b[i * l + k]).collect(), report))
        })
        .collect()
}
