//! Patch-to-patch form factors by ray casting (Malley's method with an Isocell set).
//!
//! From each patch i (black ones too: they reflect nothing, but their incident illuminance is
//! still asked for), `N` rays leave with cosine-distributed directions (the ray set,
//! turned by a per-patch azimuth to decorrelate patches) from origins spread evenly over the
//! patch (an R2 low-discrepancy sequence mapped to the triangle), so the estimate is the
//! area-to-area factor, not a centroid's: `F_ij = (rays from i reaching the front of j) / N`.
//! Rays that leave the scene give the escaped fraction `F_sp,i` (open scenes).
//!
//! Covered surface: a ray that meets a back face started from a point that another object
//! covers (wall behind a window pane 2 mm in front of it, ceiling above a luminaire, floor under
//! a cabinet): every direction from such a point meets the inside of the cover. Those samples
//! are dropped, so each patch's row describes its *visible* part, whose area is
//! `A_i × visible_i`. Without this, a partly covered patch's exitance is diluted by its dark
//! hidden part while everything that looks at it sees only the lit part: a systematic
//! underestimate. Rows are sparse (CSR), f64.
//!
//! Rectification (physics.md §4): see [`rectify`]. Pairs that no ray connected stay exactly zero.

use glam::DVec3;
use rayon::prelude::*;

use super::patches::Patches;
use super::raycast::{Hit, RayCaster};
use super::rayset::{RaySet, frame, to_world};
use crate::rng::hash64;

/// Sparse rows, f64 values: the solver's one sparse matrix.
pub use crate::solver::Csr;

/// Form factors of a scene.
#[derive(Debug, Clone)]
pub struct FormFactors {
    /// F_ij.
    pub f: Csr,
    /// Escaped fraction per patch (of its visible rays, those that left the scene).
    pub escaped: Vec<f64>,
    /// Visible fraction of each patch's area (rays that did not start under a cover).
    pub visible: Vec<f64>,
    /// Whether rays were cast from the patch (every patch with an area).
    pub cast: Vec<bool>,
    /// Rays per patch.
    pub rays_per_patch: usize,
}

/// The R2 low-discrepancy sequence (Roberts 2018) point `k` with a per-patch shift.
fn r2(k: usize, shift: (f64, f64)) -> (f64, f64) {
    const A1: f64 = 0.754_877_666_246_692_7; // 1/φ₂
    const A2: f64 = 0.569_840_290_998_053_3; // 1/φ₂²
    let k = k as f64;
    ((shift.0 + A1 * k).fract(), (shift.1 + A2 * k).fract())
}

/// A per-patch pseudo-random shift and azimuth, from the patch id and a seed.
pub(crate) fn patch_jitter(i: usize, seed: u64) -> ((f64, f64), f64) {
    let h = hash64(seed ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let u = (h >> 11) as f64 / (1u64 << 53) as f64;
    let h2 = hash64(h);
    let v = (h2 >> 11) as f64 / (1u64 << 53) as f64;
    let a = hash64(h2) as f64 / u64::MAX as f64 * std::f64::consts::TAU;
    ((u, v), a)
}

/// Sample point `k` of patch `i` (area-uniform, stratified along the sequence).
pub(crate) fn patch_point(patches: &Patches, i: usize, k: usize, shift: (f64, f64)) -> DVec3 {
    let (u, v) = r2(k, shift);
    patches.point_m(i, u, v)
}

/// One patch's casting result: its row, escaped fraction, visible fraction, whether cast.
type CastRow = (Vec<(u32, f64)>, f64, f64, bool);

/// Casts the rays of every patch and builds the sparse rows.
pub fn compute(patches: &Patches, caster: &RayCaster, rays: &RaySet, seed: u64) -> FormFactors {
    let n = patches.len();
    let nr = rays.len();
    let inv = 1.0 / nr as f64;
    let rows: Vec<CastRow> = (0..n)
        .into_par_iter()
        .map_init(Vec::<u32>::new, |hits, i| {
            if patches.area_m2[i] <= 0.0 {
                return (Vec::new(), 0.0, 1.0, false);
            }
            let (shift, azimuth) = patch_jitter(i, seed);
            let fr = frame(patches.normal[i], azimuth);
            let mut escaped = 0usize;
            let mut covered = 0usize;
            hits.clear();
            for (k, d) in rays.dirs.iter().enumerate() {
                let origin = caster.offset(patch_point(patches, i, k, shift), patches.normal[i]);
                match caster.closest(origin, to_world(&fr, *d)) {
                    Hit::Front { patch, .. } if patch as usize != i => hits.push(patch),
                    Hit::Front { .. } | Hit::Back { .. } => covered += 1,
                    Hit::Miss => escaped += 1,
                }
            }
            let valid = nr - covered;
            if valid == 0 {
                return (Vec::new(), 0.0, 0.0, true);
            }
            let w = 1.0 / valid as f64;
            hits.sort_unstable();
            let mut row: Vec<(u32, f64)> = Vec::new();
            for &j in hits.iter() {
                match row.last_mut() {
                    Some((c, v)) if *c == j => *v += w,
                    _ => row.push((j, w)),
                }
            }
            (row, escaped as f64 * w, valid as f64 * inv, true)
        })
        .collect();
    let mut escaped = Vec::with_capacity(n);
    let mut visible = Vec::with_capacity(n);
    let mut cast = Vec::with_capacity(n);
    let mut csr_rows = Vec::with_capacity(n);
    for (row, e, l, c) in rows {
        csr_rows.push(row);
        escaped.push(e);
        visible.push(l);
        cast.push(c);
    }
    FormFactors {
        f: Csr::from_rows(csr_rows),
        escaped,
        visible,
        cast,
        rays_per_patch: nr,
    }
}

/// Outcome of a rectification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RectifyReport {
    /// Closure passes done.
    pub iterations: u32,
    /// Largest relative reciprocity error `|A_i F_ij − A_j F_ji| / (A_i F_ij + A_j F_ji)` at the end.
    pub reciprocity_error: f64,
    /// Largest closure error `|Σ_j F_ij − (1 − F_sp,i)|` at the end.
    pub closure_error: f64,
    /// Rows the symmetric scaling could not close (no consistent solution: say two nearly
    /// covered slivers that see only each other; or too slow to reach), scaled to their target
    /// alone, so that no row sum exceeds it; their reciprocity is given up.
    pub rows_capped: usize,
    /// Patches left out of reciprocity because too few of their rays were valid (see
    /// [`MIN_VISIBLE_FRACTION`]); their rows are closed alone.
    pub sparse_patches: usize,
}

/// Patches with fewer valid rays than this fraction (the rest started under a cover: a desk's
/// side face pressed against the next desk) take no part in reciprocity: a handful of hits
/// is no estimate of an exchange area, and pairs of such slivers that see only each other have
/// no reciprocal closure at all.
pub const MIN_VISIBLE_FRACTION: f64 = 0.05;

/// The maximum-likelihood common exchange area of a pair for binomial ray counts (Masset):
/// the smaller root of `2 n η² − b η + c = 0`, with
/// `b = A_i n (F_ij + 1) + A_j n (F_ji + 1)` and `c = A_i A_j n (F_ij + F_ji)`.
pub fn ml_exchange_area(a_i: f64, a_j: f64, f_ij: f64, f_ji: f64, n_rays: f64) -> f64 {
    let b = a_i * n_rays * (f_ij + 1.0) + a_j * n_rays * (f_ji + 1.0);
    let c = a_i * a_j * n_rays * (f_ij + f_ji);
    let disc = (b * b - 8.0 * n_rays * c).max(0.0);
    // the smaller root, written to avoid cancellation
    let q = 0.5 * (b + disc.sqrt());
    if q > 0.0 { c / q } else { 0.0 }
}

/// Enforces reciprocity and closure among the patches rays were cast from, in place
/// (physics.md §4):
///
/// 1. **Reciprocity**, Masset's modified Van Leersum step: every pair of patches that either saw
///    the other gets one exchange area `G_ij = G_ji`, the maximum-likelihood estimate from both
///    ray counts ([`ml_exchange_area`]); `A_i F_ij = G_ij` then holds exactly. Areas are the
///    visible areas `A_i × visible_i`.
/// 2. **Closure** by symmetric diagonal scaling (View3D's NormAF idea): find `x_i > 0` with
///    `Σ_j x_i G_ij x_j / A_i = 1 − F_sp,i` and set `F_ij = x_i G_ij x_j / A_i`. The scaled matrix
///    stays exactly reciprocal at every pass, the closure error is spread over rows *and*
///    columns in proportion to the entries (Van Leersum's row scaling, made symmetric), and
///    entries no ray found stay exactly zero.
/// 3. **A guard**: a row still off its target after the passes (the scaling has no solution
///    for it, or crawls toward one) is scaled alone, so every row sum is at most its target and
///    the radiosity iteration contracts whatever the input.
///
/// Entries toward patches that take no part (black patches, fully covered ones, those with
/// fewer than [`MIN_VISIBLE_FRACTION`] valid rays) have no partner; they scale with their row
/// only.
///
/// Cost: building the symmetric pattern is a transpose by counting sort and a merge per row,
/// O(nnz); partners are found by binary search, O(nnz log(row length)); each closure pass is
/// O(nnz). Memory: the pattern, the exchange areas and the partner index, 16 bytes per entry
/// beyond the CSR itself.
pub fn rectify(
    ff: &mut FormFactors,
    patch_area_m2: &[f64],
    tolerance: f64,
    max_iterations: u32,
) -> RectifyReport {
    let n = ff.f.rows();
    let area: Vec<f64> = patch_area_m2
        .iter()
        .zip(&ff.visible)
        .map(|(a, v)| a * v)
        .collect();
    // Only patches with enough of a visible part take part.
    let takes_part: Vec<bool> = (0..n)
        .map(|i| ff.cast[i] && area[i] > 0.0 && ff.visible[i] >= MIN_VISIBLE_FRACTION)
        .collect();
    let sparse_patches = (0..n)
        .filter(|&i| ff.cast[i] && area[i] > 0.0 && !takes_part[i])
        .count();

    // 1. Symmetric pattern among taking-part patches: (j, i) exists wherever (i, j) does. The
    //    transpose's columns, by counting sort (rows visited in order, so each list is sorted).
    let mut t_count = vec![0u32; n + 1];
    for i in 0..n {
        if !takes_part[i] {
            continue;
        }
        for (j, _) in ff.f.row(i) {
            if takes_part[j as usize] {
                t_count[j as usize + 1] += 1;
            }
        }
    }
    for k in 0..n {
        t_count[k + 1] += t_count[k];
    }
    let mut t_col = vec![0u32; t_count[n] as usize];
    let mut fill = t_count.clone();
    for i in 0..n {
        if !takes_part[i] {
            continue;
        }
        for (j, _) in ff.f.row(i) {
            let j = j as usize;
            if takes_part[j] {
                t_col[fill[j] as usize] = i as u32;
                fill[j] += 1;
            }
        }
    }
    drop(fill);
    // Merge each row's own sorted columns with its transpose's (new entries start at 0).
    let merged: Vec<Vec<(u32, f64)>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let own = ff.f.row(i);
            if !takes_part[i] {
                return own.collect();
            }
            let tr = &t_col[t_count[i] as usize..t_count[i + 1] as usize];
            let mut out = Vec::with_capacity(
                tr.len().max(1) + (ff.f.row_ptr[i + 1] - ff.f.row_ptr[i]) as usize,
            );
            let mut own = own.peekable();
            let mut k = 0;
            loop {
                match (own.peek().copied(), tr.get(k).copied()) {
                    (Some((c, v)), Some(t)) => {
                        if c < t {
                            out.push((c, v));
                            own.next();
                        } else if t < c {
                            out.push((t, 0.0));
                            k += 1;
                        } else {
                            out.push((c, v));
                            own.next();
                            k += 1;
                        }
                    }
                    (Some(e), None) => {
                        out.push(e);
                        own.next();
                    }
                    (None, Some(t)) => {
                        out.push((t, 0.0));
                        k += 1;
                    }
                    (None, None) => break,
                }
            }
            out
        })
        .collect();
    drop(t_col);
    drop(t_count);
    ff.f = Csr::from_rows(merged);
    let nnz = ff.f.nnz();
    let row_of: Vec<u32> = (0..n)
        .flat_map(|i| {
            std::iter::repeat_n(i as u32, (ff.f.row_ptr[i + 1] - ff.f.row_ptr[i]) as usize)
        })
        .collect();
    // Partners without searching: rows are visited in order, so the entries (j, i) that row j
    // holds for its partners i are met in increasing i, i.e. in the order of row j's sorted
    // columns; one cursor per row walks them. O(nnz) with one step into row j per entry (a
    // binary search per entry costs log(row length) cache misses once the matrix outgrows
    // the cache: the superlinear part of the old rectification).
    let mut partner = vec![u32::MAX; nnz];
    let mut cursor: Vec<u32> = ff.f.row_ptr[..n].to_vec();
    for i in 0..n {
        if !takes_part[i] {
            continue;
        }
        let (a, b) = (ff.f.row_ptr[i] as usize, ff.f.row_ptr[i + 1] as usize);
        for (p, &j) in partner[a..b].iter_mut().zip(&ff.f.col[a..b]) {
            let j = j as usize;
            if !takes_part[j] {
                continue;
            }
            let end = ff.f.row_ptr[j + 1] as usize;
            let mut q = cursor[j] as usize;
            while q < end && (ff.f.col[q] as usize) < i {
                q += 1;
            }
            cursor[j] = q as u32;
            if q < end && ff.f.col[q] as usize == i {
                *p = q as u32;
            }
        }
    }
    drop(cursor);

    // 2. Exchange areas: ML common value for partnered pairs, A_i F_ij for one-sided entries.
    let n_rays = ff.rays_per_patch as f64;
    let mut g = vec![0.0; nnz];
    {
        let old = &ff.f.val;
        g.par_iter_mut().enumerate().for_each(|(k, gk)| {
            let i = row_of[k] as usize;
            let j = ff.f.col[k] as usize;
            *gk = match partner[k] {
                u32::MAX => area[i] * old[k],
                p => ml_exchange_area(area[i], area[j], old[k], old[p as usize], n_rays),
            };
        });
    }

    // 3. Symmetric scaling to closure (Gauss-Seidel over rows: each pass O(nnz)).
    let target: Vec<f64> = ff.escaped.iter().map(|e| 1.0 - e).collect();
    let mut x = vec![1.0f64; n];
    let row_sum = |i: usize, x: &[f64], g: &[f64]| -> f64 {
        let (a, b) = (ff.f.row_ptr[i] as usize, ff.f.row_ptr[i + 1] as usize);
        let mut s = 0.0;
        for k in a..b {
            let xj = if partner[k] == u32::MAX {
                1.0
            } else {
                x[ff.f.col[k] as usize]
            };
            s += g[k] * xj;
        }
        x[i] * s / area[i]
    };
    let mut report = RectifyReport {
        iterations: 0,
        reciprocity_error: 0.0,
        closure_error: 0.0,
        rows_capped: 0,
        sparse_patches,
    };
    let rows_in_play = |i: usize| ff.cast[i] && area[i] > 0.0;
    // Stop early when the worst row has not improved by 10 % in 25 passes (converging rows
    // gain a factor of ten in that many): it has no reciprocal closure, or crawls toward one
    // (a few slivers on a 22 000-patch floor), and the guard below closes it alone.
    let (mut best, mut since_best) = (f64::INFINITY, 0u32);
    for it in 1..=max_iterations.max(1) {
        let mut worst: f64 = 0.0;
        for i in 0..n {
            if !rows_in_play(i) {
                continue;
            }
            let s = row_sum(i, &x, &g);
            if s > 0.0 {
                worst = worst.max((s - target[i]).abs());
                x[i] *= target[i] / s;
            }
        }
        report.iterations = it;
        if worst < tolerance {
            break;
        }
        if worst < 0.9 * best {
            best = worst;
            since_best = 0;
        } else {
            since_best += 1;
            if since_best >= 25 {
                break;
            }
        }
    }
    let x = &x;
    let area = &area;
    ff.f.val.par_iter_mut().enumerate().for_each(|(k, v)| {
        let i = row_of[k] as usize;
        if !(ff.cast[i] && area[i] > 0.0) {
            return;
        }
        let xj = if partner[k] == u32::MAX {
            1.0
        } else {
            x[ff.f.col[k] as usize]
        };
        *v = x[i] * g[k] * xj / area[i];
    });
    // 4. The guard: a row still off its target by more than the tolerance is scaled alone.
    let capped: Vec<usize> = (0..n)
        .into_par_iter()
        .filter(|&i| {
            let s = ff.f.row_sum(i);
            rows_in_play(i) && s > 0.0 && (s - target[i]).abs() > tolerance.max(1e-12)
        })
        .collect();
    for &i in &capped {
        let s = ff.f.row_sum(i);
        let (a, b) = (ff.f.row_ptr[i] as usize, ff.f.row_ptr[i + 1] as usize);
        for v in &mut ff.f.val[a..b] {
            *v *= target[i] / s;
        }
    }
    report.rows_capped = capped.len();
    let mut is_capped = vec![false; n];
    for &i in &capped {
        is_capped[i] = true;
    }
    report.reciprocity_error = reciprocity_error(&ff.f, &partner, area, &is_capped);
    report.closure_error = (0..n)
        .filter(|&i| rows_in_play(i) && ff.f.row_sum(i) > 0.0)
        .map(|i| (ff.f.row_sum(i) - target[i]).abs())
        .fold(0.0, f64::max);
    report
}

/// The largest relative reciprocity error over partnered pairs, leaving out capped rows.
fn reciprocity_error(f: &Csr, partner: &[u32], area_m2: &[f64], capped: &[bool]) -> f64 {
    let mut worst: f64 = 0.0;
    for i in 0..f.rows() {
        if capped[i] {
            continue;
        }
        let range = f.row_ptr[i] as usize..f.row_ptr[i + 1] as usize;
        for (k, &p) in range.clone().zip(&partner[range]) {
            if p == u32::MAX {
                continue;
            }
            let j = f.col[k] as usize;
            if capped[j] {
                continue;
            }
            let a = area_m2[i] * f.val[k];
            let b = area_m2[j] * f.val[p as usize];
            if a + b > 0.0 {
                worst = worst.max((a - b).abs() / (a + b));
            }
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ml_reciprocity_example() {
        // physics.md §10 C1
        let eta = ml_exchange_area(1.0, 2.0, 0.3, 0.16, 1000.0);
        assert!((eta - 0.3058131).abs() < 1e-7, "{eta}");
        assert!((eta / 2.0 - 0.1529065).abs() < 1e-7);
    }

    #[test]
    fn ml_keeps_a_consistent_pair() {
        // A_i F_ij = A_j F_ji already: η is that exchange area (idempotence)
        let eta = ml_exchange_area(1.0, 2.0, 0.3, 0.15, 1000.0);
        assert!((eta - 0.3).abs() < 1e-12, "{eta}");
    }

    #[test]
    fn csr_rows() {
        let m = Csr::from_rows(vec![vec![(1, 0.5), (3, 0.25)], vec![], vec![(0, 1.0)]]);
        assert_eq!(m.rows(), 3);
        assert_eq!(m.get(0, 3), 0.25);
        assert_eq!(m.get(0, 2), 0.0);
        assert_eq!(m.get(1, 0), 0.0);
        assert_eq!(m.row_sum(0), 0.75);
    }
}
