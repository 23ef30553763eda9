//! The radiosity solve, `no_std` and allocation-free: the run-time core runs it over form
//! factors borrowed from the flash image, commissioning over its own, live light over the
//! unseen part of the room. It is the one radiosity iteration of the crate: every caller goes
//! through [`solve`] (or [`gauss_seidel`], its one-right-hand-side form) and handles its
//! [`SolveReport`] or [`SolveError`].
//!
//! | symbol | meaning | unit | here |
//! |---|---|---|---|
//! | B_i | luminous exitance of patch i (radiosity) | lm/m² | `b_lm_per_m2[i]` |
//! | E^dir_i | direct illuminance on patch i from the luminaires | lx | [`Source::Irradiance`] |
//! | M_i | exitance a patch emits itself (an unknown emitter) | lm/m² | [`Source::Exitance`] |
//! | ρ_i | diffuse reflectance, in [0, 1) | 1 | [`RadiositySystem::rho`] |
//! | F_ij | form factor patch i → patch j | 1 | [`RadiositySystem::gather`] |
//!
//! The system is `B_i = ρ_i (E^dir_i + Σ_j F_ij B_j)` (physics.md §3.6: emission enters as
//! illuminance, there is no factor π anywhere), or `B_i = M_i + ρ_i Σ_j F_ij B_j` when the
//! source is an exitance. The incident illuminance of a patch is `E_i = E^dir_i + Σ_j F_ij B_j`.
//!
//! Gauss-Seidel sweeps with f64 accumulation, over every row or a listed subset (the other
//! rows' exitance is held as given: a boundary condition), for `k` right-hand sides at once.
//! They are stored patch-major (`b[i·k + q]`), so a sweep reads each form factor once for all
//! of them. Each right-hand side stops on its own, when its relative change
//! `max_i |ΔB_i| / max_i |B_i|` and then its relative residual
//! `max_i |B_i − ρ_i (E^dir_i + Σ_j F_ij B_j)| / max_i |B_i|` are at most the tolerance (maxima
//! over the solved rows); its values are then frozen. With ρ < 1 and row sums ≤ 1 the
//! iteration contracts; anything else (ρ ≥ 1, non-finite input, a change that stops falling,
//! the sweep cap) is an error, and a NaN never leaves the solver.

/// The linear system, as the solver sees it: reflectances and sparse form-factor rows.
pub trait RadiositySystem {
    /// Number of patches.
    fn len(&self) -> usize;
    /// Reflectance ρ_i.
    fn rho(&self, i: usize) -> f64;
    /// `Σ_j F_ij x_j` (f64 accumulation, entries in stored order).
    fn gather(&self, i: usize, x: &[f64]) -> f64;
    /// `acc[q] += Σ_j F_ij x[j·k + q]` for the `k = acc.len()` right-hand sides, entries in
    /// stored order (each `q` sums exactly as [`RadiositySystem::gather`] does).
    fn gather_k(&self, i: usize, x: &[f64], acc: &mut [f64]);
    /// `Σ_j F_ij x[j·k + q]`: right-hand side `q` of `k` alone, in the same order.
    fn gather_column(&self, i: usize, x: &[f64], k: usize, q: usize) -> f64;
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

/// Compressed sparse rows over borrowed slices (CSR): the borrowed form of `Csr`, and the
/// form the solver reads.
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

    /// The entry range of row `i`.
    fn range(&self, i: usize) -> core::ops::Range<usize> {
        self.row_ptr[i] as usize..self.row_ptr[i + 1] as usize
    }

    /// `Σ_j A_ij x_j` for row `i`.
    pub fn row_dot(&self, i: usize, x: &[f64]) -> f64 {
        self.row_dot_column(i, x, 1, 0)
    }

    /// `Σ_j A_ij x[j·k + q]` for row `i`.
    pub fn row_dot_column(&self, i: usize, x: &[f64], k: usize, q: usize) -> f64 {
        let mut s = 0.0;
        for e in self.range(i) {
            s += self.val[e].to_f64() * x[self.col[e] as usize * k + q];
        }
        s
    }

    /// `acc[q] += Σ_j A_ij x[j·k + q]` for `k = acc.len()` right-hand sides.
    pub fn row_dot_k(&self, i: usize, x: &[f64], acc: &mut [f64]) {
        let k = acc.len();
        for e in self.range(i) {
            let v = self.val[e].to_f64();
            let j = self.col[e] as usize;
            for (a, xj) in acc.iter_mut().zip(&x[j * k..j * k + k]) {
                *a += v * xj;
            }
        }
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

#[cfg(feature = "std")]
mod owned;
#[cfg(feature = "std")]
pub use owned::Csr;

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
    fn gather_k(&self, i: usize, x: &[f64], acc: &mut [f64]) {
        self.f.row_dot_k(i, x, acc)
    }
    fn gather_column(&self, i: usize, x: &[f64], k: usize, q: usize) -> f64 {
        self.f.row_dot_column(i, x, k, q)
    }
}

/// When to stop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveOptions {
    /// Relative change and relative residual to reach.
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

/// How a solve went (over several right-hand sides: the most sweeps, the largest residual).
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
    #[error("non-finite or negative input (direct illuminance, exitance or form factor)")]
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

/// What drives the system, patch-major (`[i·k + q]` for right-hand side `q`).
#[derive(Debug, Clone, Copy)]
pub enum Source<'a> {
    /// Incident direct illuminance `E^dir`, lx: `B_i = ρ_i (E^dir_i + Σ_j F_ij B_j)`.
    Irradiance(&'a [f64]),
    /// Emitted exitance `M`, lm/m²: `B_i = M_i + ρ_i Σ_j F_ij B_j`.
    Exitance(&'a [f64]),
}

impl Source<'_> {
    fn values(&self) -> &[f64] {
        match self {
            Source::Irradiance(v) | Source::Exitance(v) => v,
        }
    }

    /// The new exitance of entry `at` from its gathered light `g` and the reflectance `rho`.
    #[inline]
    fn exitance(&self, at: usize, rho: f64, g: f64) -> f64 {
        match self {
            Source::Irradiance(e) => rho * (e[at] + g),
            Source::Exitance(m) => m[at] + rho * g,
        }
    }
}

/// Which rows the sweeps update (the others' exitance is held as given).
#[derive(Debug, Clone, Copy)]
pub enum Rows<'a> {
    /// Every patch.
    All,
    /// These patches, in this order.
    Listed(&'a [u32]),
}

impl Rows<'_> {
    /// How many rows are solved in a system of `n`.
    fn count(&self, n: usize) -> usize {
        match self {
            Rows::All => n,
            Rows::Listed(r) => r.len(),
        }
    }

    /// The patch of solved row `r`.
    #[inline]
    fn at(&self, r: usize) -> usize {
        match self {
            Rows::All => r,
            Rows::Listed(rows) => rows[r] as usize,
        }
    }
}

/// What a solve works on: the system, the rows it updates and what drives it.
struct Problem<'p, S> {
    sys: &'p S,
    rows: Rows<'p>,
    source: Source<'p>,
}

/// One right-hand side's stop state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RhsState {
    previous: f64,
    stalled: u32,
    max_change: f64,
    max_b: f64,
    /// The largest exitance present when the solve began (held rows and the start value): the
    /// floor of the relative tests, so a warm start that decays toward a far smaller (or zero)
    /// answer stops once what is left is below the tolerance of that scale.
    scale: f64,
    /// The relative residual after this sweep when it was computed with the other right-hand
    /// sides' in one pass ([`residuals_k`]).
    residual: Option<f64>,
    /// `Some` once this right-hand side has stopped: its own report.
    pub done: Option<SolveReport>,
}

impl Default for RhsState {
    fn default() -> Self {
        Self {
            previous: f64::INFINITY,
            stalled: 0,
            max_change: 0.0,
            max_b: 0.0,
            scale: 0.0,
            residual: None,
            done: None,
        }
    }
}

/// Scratch for `k` right-hand sides, lent by the caller (the solver allocates nothing):
/// `acc` and `state` both of length `k`.
#[derive(Debug)]
pub struct Workspace<'w> {
    /// Gathered light of one row, per right-hand side.
    pub acc: &'w mut [f64],
    /// Stop state per right-hand side; after [`solve`], `state[q].done` is `q`'s report.
    pub state: &'w mut [RhsState],
}

/// Checks the inputs once: reflectances in [0, 1), finite non-negative direct illuminance.
pub fn check_inputs<S: RadiositySystem>(sys: &S, e_direct_lx: &[f64]) -> Result<(), SolveError> {
    if e_direct_lx.len() != sys.len() {
        return Err(SolveError::Malformed);
    }
    check_rows(sys, Rows::All)?;
    check_values(e_direct_lx)
}

/// Every value finite and non-negative.
fn check_values(v: &[f64]) -> Result<(), SolveError> {
    if v.iter().all(|x| x.is_finite() && *x >= 0.0) {
        Ok(())
    } else {
        Err(SolveError::NonFiniteInput)
    }
}

/// Every solved row inside the system, with a reflectance in [0, 1).
fn check_rows<S: RadiositySystem>(sys: &S, rows: Rows<'_>) -> Result<(), SolveError> {
    let n = sys.len();
    for r in 0..rows.count(n) {
        let i = rows.at(r);
        if i >= n {
            return Err(SolveError::Malformed);
        }
        let rho = sys.rho(i);
        if !(rho.is_finite() && (0.0..1.0).contains(&rho)) {
            return Err(SolveError::BadReflectance { patch: i, rho });
        }
    }
    Ok(())
}

/// The relative residual of `b`: `max |B − ρ (E + F B)| / max |B|` (0 for an all-dark room).
pub fn residual<S: RadiositySystem>(sys: &S, e_direct_lx: &[f64], b: &[f64]) -> f64 {
    let problem = Problem {
        sys,
        rows: Rows::All,
        source: Source::Irradiance(e_direct_lx),
    };
    residual_of(&problem, b, 1, 0)
}

/// The relative residual of right-hand side `q` of `k` over the solved rows.
fn residual_of<S: RadiositySystem>(p: &Problem<'_, S>, b: &[f64], k: usize, q: usize) -> f64 {
    residual_over(p, b, (k, q), 0.0)
}

/// [`residual_of`] relative to at least `floor`.
fn residual_over<S: RadiositySystem>(
    p: &Problem<'_, S>,
    b: &[f64],
    (k, q): (usize, usize),
    floor: f64,
) -> f64 {
    let (sys, rows, source) = (p.sys, p.rows, &p.source);
    let mut num: f64 = 0.0;
    let mut den: f64 = 0.0;
    for r in 0..rows.count(sys.len()) {
        let i = rows.at(r);
        let g = if k == 1 {
            sys.gather(i, b)
        } else {
            sys.gather_column(i, b, k, q)
        };
        let at = i * k + q;
        let res = b[at] - source.exitance(at, sys.rho(i), g);
        if !res.is_finite() {
            return f64::INFINITY;
        }
        num = num.max(res.abs());
        den = den.max(b[at].abs());
    }
    let den = den.max(floor);
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
    let (mut acc, mut state) = ([0.0], [RhsState::default()]);
    let work = Workspace {
        acc: &mut acc,
        state: &mut state,
    };
    solve(
        sys,
        Rows::All,
        Source::Irradiance(e_direct_lx),
        b_lm_per_m2,
        work,
        options,
    )
}

/// Solves the system for `k = work.acc.len()` right-hand sides at once, patch-major
/// (`source` and `b` of length patches × k), over `rows`. The content of `b` is the start
/// value at the solved rows and the held value elsewhere. Returns the most sweeps and the
/// largest residual; each right-hand side's own report is in `work.state`. On error the
/// solved rows of `b` are zeroed (no partial result).
pub fn solve<S: RadiositySystem>(
    sys: &S,
    rows: Rows<'_>,
    source: Source<'_>,
    b: &mut [f64],
    work: Workspace<'_>,
    options: SolveOptions,
) -> Result<SolveReport, SolveError> {
    let k = work.acc.len();
    let problem = Problem { sys, rows, source };
    let result =
        start(&problem, b, &mut *work.state, k).and_then(|()| sweeps(&problem, b, work, options));
    if result.is_err() && k > 0 {
        for r in 0..rows.count(sys.len()) {
            let i = rows.at(r);
            if let Some(bi) = b.get_mut(i * k..i * k + k) {
                bi.iter_mut().for_each(|x| *x = 0.0);
            }
        }
    }
    result
}

/// Checks the inputs and resets the state: a non-finite start value at a solved row starts
/// from 0; a held row must be finite and non-negative.
fn start<S: RadiositySystem>(
    p: &Problem<'_, S>,
    b: &mut [f64],
    state: &mut [RhsState],
    k: usize,
) -> Result<(), SolveError> {
    let (sys, rows, source) = (p.sys, p.rows, &p.source);
    let n = sys.len();
    if k == 0 || state.len() != k || b.len() != n * k || source.values().len() != n * k {
        return Err(SolveError::Malformed);
    }
    check_rows(sys, rows)?;
    check_values(source.values())?;
    state.iter_mut().for_each(|s| *s = RhsState::default());
    match rows {
        Rows::All => {
            if b.iter().any(|x| !x.is_finite()) {
                b.iter_mut().for_each(|x| *x = 0.0);
            }
        }
        Rows::Listed(list) => {
            for &i in list {
                let bi = &mut b[i as usize * k..i as usize * k + k];
                bi.iter_mut()
                    .filter(|x| !x.is_finite())
                    .for_each(|x| *x = 0.0);
            }
            check_values(b)?;
        }
    }
    for (q, s) in state.iter_mut().enumerate() {
        s.scale = b.iter().skip(q).step_by(k).fold(0.0, |m, x| m.max(x.abs()));
    }
    Ok(())
}

/// The sweeps, until every right-hand side has stopped.
fn sweeps<S: RadiositySystem>(
    p: &Problem<'_, S>,
    b: &mut [f64],
    work: Workspace<'_>,
    options: SolveOptions,
) -> Result<SolveReport, SolveError> {
    let (sys, rows, source) = (p.sys, p.rows, &p.source);
    let Workspace { acc, state } = work;
    let k = acc.len();
    let count = rows.count(sys.len());
    for it in 1..=options.max_iterations {
        for s in state.iter_mut() {
            s.max_change = 0.0;
            s.max_b = 0.0;
        }
        for r in 0..count {
            let i = rows.at(r);
            if k == 1 {
                acc[0] = sys.gather(i, b);
            } else {
                acc.iter_mut().for_each(|a| *a = 0.0);
                sys.gather_k(i, b, acc);
            }
            let rho = sys.rho(i);
            for q in 0..k {
                let s = &mut state[q];
                if s.done.is_some() {
                    continue;
                }
                let at = i * k + q;
                let new = source.exitance(at, rho, acc[q]);
                // f64::max ignores NaN, so test every value explicitly
                if !new.is_finite() {
                    return Err(SolveError::Diverged);
                }
                s.max_change = s.max_change.max((new - b[at]).abs());
                s.max_b = s.max_b.max(new.abs());
                b[at] = new;
            }
        }
        residuals_k(p, b, acc, state, options.tolerance);
        for (q, s) in state.iter_mut().enumerate() {
            stop_test(p, b, (k, q), s, it, options)?;
        }
        if state.iter().all(|s| s.done.is_some()) {
            return Ok(summary(state));
        }
    }
    let q = state.iter().position(|s| s.done.is_none()).unwrap_or(0);
    Err(SolveError::NotConverged {
        iterations: options.max_iterations,
        residual: residual_of(p, b, k, q),
    })
}

/// The relative change of a right-hand side in the last sweep (0 for an all-dark one).
fn relative_change(s: &RhsState) -> f64 {
    let scale = s.max_b.max(s.scale);
    if scale > 0.0 {
        s.max_change / scale
    } else {
        0.0
    }
}

/// When several right-hand sides' changes are within the tolerance, their residuals in one
/// pass over the form factors (each as [`residual_over`] gives it, in the same order), kept in
/// their states for [`stop_test`]: one pass reading each form factor once instead of one
/// strided pass per right-hand side.
fn residuals_k<S: RadiositySystem>(
    p: &Problem<'_, S>,
    b: &[f64],
    acc: &mut [f64],
    state: &mut [RhsState],
    tolerance: f64,
) {
    let k = acc.len();
    let wanted = |s: &RhsState| {
        s.done.is_none()
            && s.max_change.is_finite()
            && s.max_b.is_finite()
            && relative_change(s) <= tolerance
    };
    if k < 2 || state.iter().filter(|s| wanted(s)).count() < 2 {
        return;
    }
    // the largest |residual| per right-hand side; the largest |B| over the solved rows is
    // the sweep's `max_b` (each solved row was set once in it)
    for s in state.iter_mut() {
        s.residual = wanted(s).then_some(0.0);
    }
    let (sys, rows, source) = (p.sys, p.rows, &p.source);
    for r in 0..rows.count(sys.len()) {
        let i = rows.at(r);
        acc.iter_mut().for_each(|a| *a = 0.0);
        sys.gather_k(i, b, acc);
        let rho = sys.rho(i);
        for (q, s) in state.iter_mut().enumerate() {
            let Some(num) = s.residual.as_mut() else {
                continue;
            };
            let at = i * k + q;
            let res = b[at] - source.exitance(at, rho, acc[q]);
            *num = if res.is_finite() {
                num.max(res.abs())
            } else {
                f64::INFINITY
            };
        }
    }
    for s in state.iter_mut() {
        if let Some(num) = s.residual.as_mut() {
            let den = s.max_b.max(s.scale);
            if num.is_finite() && den > 0.0 {
                *num /= den;
            }
        }
    }
}

/// After sweep `it`: stops right-hand side `q` when its change and then its residual are
/// within the tolerance; fails when its change has stopped falling.
fn stop_test<S: RadiositySystem>(
    p: &Problem<'_, S>,
    b: &[f64],
    (k, q): (usize, usize),
    s: &mut RhsState,
    it: u32,
    options: SolveOptions,
) -> Result<(), SolveError> {
    if s.done.is_some() {
        return Ok(());
    }
    if !(s.max_change.is_finite() && s.max_b.is_finite()) {
        return Err(SolveError::Diverged);
    }
    if relative_change(s) <= options.tolerance {
        let r = s
            .residual
            .take()
            .unwrap_or_else(|| residual_over(p, b, (k, q), s.scale));
        if r <= options.tolerance {
            s.done = Some(SolveReport {
                iterations: it,
                residual: r,
            });
            return Ok(());
        }
    }
    // A contraction shrinks the change every sweep (slowly when ρ is near 1); a change that
    // stops falling means rounding noise above the tolerance, or no contraction at all. The
    // change itself, not relative to the exitance: a warm start decaying toward a smaller
    // answer shrinks both at the same rate.
    if s.max_change < s.previous * (1.0 - 1e-9) {
        s.stalled = 0;
    } else {
        s.stalled += 1;
        if s.stalled > 50 {
            return Err(SolveError::NotConverged {
                iterations: it,
                residual: residual_of(p, b, k, q),
            });
        }
    }
    s.previous = s.max_change;
    Ok(())
}

/// The most sweeps and the largest residual of the right-hand sides.
fn summary(state: &[RhsState]) -> SolveReport {
    state.iter().filter_map(|s| s.done).fold(
        SolveReport {
            iterations: 0,
            residual: 0.0,
        },
        |a, r| SolveReport {
            iterations: a.iterations.max(r.iterations),
            residual: a.residual.max(r.residual),
        },
    )
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

    /// A warm start far above the answer (live light's boundary solve when the daylight
    /// drops from hundreds of lux to nothing between frames) decays to it and stops: the change
    /// relative to the shrinking exitance is constant, so the relative stall test alone refused
    /// it (found by the frame checks' property test, issue 34).
    #[test]
    fn a_warm_start_decays_to_a_far_smaller_answer() {
        let (rp, col, val, rho) = two_squares(0.9);
        let sys = CsrSystem {
            f: CsrView {
                row_ptr: &rp,
                col: &col,
                val: &val,
            },
            rho: &rho,
        };
        let o = SolveOptions::default();
        let mut b = [500.0, 500.0];
        let r = gauss_seidel(&sys, &[0.0, 0.0], &mut b, o).expect("the zero answer");
        assert!(
            b.iter().all(|x| x.abs() <= o.tolerance * 500.0),
            "{b:?} {r:?}"
        );
        // one row held at 1e-3 lm/m², the other started at 500: B2 = ρ F B1 (closed form)
        let (mut acc, mut state) = ([0.0], [RhsState::default()]);
        let work = Workspace {
            acc: &mut acc,
            state: &mut state,
        };
        let mut b = [1e-3, 500.0];
        let zeros = [0.0, 0.0];
        solve(
            &sys,
            Rows::Listed(&[1]),
            Source::Exitance(&zeros),
            &mut b,
            work,
            o,
        )
        .expect("the held row's answer");
        let exact = 0.9 * 0.199825 * 1e-3;
        assert!(
            (b[1] - exact).abs() <= o.tolerance * 500.0,
            "{b:?} vs {exact}"
        );
        assert_eq!(b[0], 1e-3);
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

    fn squares_system(rho: &[f64; 2]) -> CsrSystem<'_, f64> {
        const RP: [u32; 3] = [0, 1, 2];
        const COL: [u32; 2] = [1, 0];
        const VAL: [f64; 2] = [0.199825, 0.199825];
        CsrSystem {
            f: CsrView {
                row_ptr: &RP,
                col: &COL,
                val: &VAL,
            },
            rho,
        }
    }

    #[test]
    fn several_right_hand_sides_equal_their_single_solves_bit_for_bit() {
        let rho = [0.7, 0.4];
        let sys = squares_system(&rho);
        // the fourth is twice the first: they stop at the same sweep, so their residuals are
        // taken in one pass (`residuals_k`), and must equal the single solves' all the same
        let e = [[1.0, 0.0], [0.0, 3.0], [2.0, 5.0], [2.0, 0.0]];
        // patch-major: [i·k + q]
        let mut e_pm = [0.0; 8];
        for (q, eq) in e.iter().enumerate() {
            for i in 0..2 {
                e_pm[i * 4 + q] = eq[i];
            }
        }
        let mut b = [0.0; 8];
        let (mut acc, mut state) = ([0.0; 4], [RhsState::default(); 4]);
        let work = Workspace {
            acc: &mut acc,
            state: &mut state,
        };
        let all = solve(
            &sys,
            Rows::All,
            Source::Irradiance(&e_pm),
            &mut b,
            work,
            SolveOptions::default(),
        )
        .unwrap();
        for (q, eq) in e.iter().enumerate() {
            let mut one = [0.0; 2];
            let r = gauss_seidel(&sys, eq, &mut one, SolveOptions::default()).unwrap();
            assert_eq!([b[q], b[4 + q]], one, "right-hand side {q}");
            assert_eq!(state[q].done, Some(r));
            assert!(all.iterations >= r.iterations && all.residual >= r.residual);
        }
    }

    #[test]
    fn an_exitance_source_over_listed_rows_holds_the_others() {
        // patch 0 held at B0 = 1 (a seen surface), patch 1 solved: B1 = ρ1 F B0
        let rho = [0.7, 0.4];
        let sys = squares_system(&rho);
        let mut b = [1.0, 0.0];
        let (mut acc, mut state) = ([0.0], [RhsState::default()]);
        let work = Workspace {
            acc: &mut acc,
            state: &mut state,
        };
        let r = solve(
            &sys,
            Rows::Listed(&[1]),
            Source::Exitance(&[0.0, 0.0]),
            &mut b,
            work,
            SolveOptions::default(),
        )
        .unwrap();
        assert_eq!(b[0], 1.0);
        assert!((b[1] - 0.4 * 0.199825).abs() < 1e-15, "{b:?}");
        assert!(r.residual <= 1e-10);
        // both rows solved, patch 0 emitting M = 1: the irradiance form with E = M / ρ
        let mut b = [0.0; 2];
        let work = Workspace {
            acc: &mut acc,
            state: &mut state,
        };
        solve(
            &sys,
            Rows::All,
            Source::Exitance(&[1.0, 0.0]),
            &mut b,
            work,
            SolveOptions::default(),
        )
        .unwrap();
        let mut c = [0.0; 2];
        gauss_seidel(&sys, &[1.0 / 0.7, 0.0], &mut c, SolveOptions::default()).unwrap();
        assert!(
            (b[0] - c[0]).abs() < 1e-12 && (b[1] - c[1]).abs() < 1e-12,
            "{b:?} {c:?}"
        );
    }

    #[test]
    fn a_bad_listed_row_or_held_value_is_an_error() {
        let rho = [0.7, 0.4];
        let sys = squares_system(&rho);
        let (mut acc, mut state) = ([0.0], [RhsState::default()]);
        for (rows, held) in [(&[2u32][..], 1.0), (&[1][..], f64::NAN), (&[1][..], -1.0)] {
            let mut b = [held, 5.0];
            let work = Workspace {
                acc: &mut acc,
                state: &mut state,
            };
            let err = solve(
                &sys,
                Rows::Listed(rows),
                Source::Exitance(&[0.0, 0.0]),
                &mut b,
                work,
                SolveOptions::default(),
            );
            assert!(err.is_err(), "{rows:?} {held}");
        }
    }
}
