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

use std::ops::Range;

use glam::DVec3;
use obvhs::ray::Ray;
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

/// One patch's casting result: its row as (column, ray count) in ascending columns, the rays
/// that escaped, the valid rays (not started under a cover), whether rays were cast.
pub(crate) struct CastRow {
    pub(crate) hits: Vec<(u32, u32)>,
    escaped: usize,
    valid: usize,
    cast: bool,
}

/// Patches cast per parallel block: the rows of one block are held as ray counts (8 bytes per
/// entry) until they are appended to the CSR in patch order, so at most one block's rows exist
/// beside the matrix (no per-thread or per-row copy of the whole matrix).
const BLOCK_PATCHES: usize = 512;

/// Casts the rays of every patch and builds the sparse rows.
///
/// Memory: the CSR itself (4 bytes column + 8 bytes value per entry), grown in patch order,
/// plus one block of rows as counts. Values are the same f64 sums as adding `1 / valid` once per
/// hit (bit for bit), in the order the rays were cast.
pub fn compute(patches: &Patches, caster: &RayCaster, rays: &RaySet, seed: u64) -> FormFactors {
    let n = patches.len();
    let nr = rays.len();
    let inv = 1.0 / nr as f64;
    let mut f = Csr {
        row_ptr: Vec::with_capacity(n + 1),
        ..Csr::default()
    };
    f.row_ptr.push(0);
    let mut escaped = Vec::with_capacity(n);
    let mut visible = Vec::with_capacity(n);
    let mut cast = Vec::with_capacity(n);
    for start in (0..n).step_by(BLOCK_PATCHES) {
        let block: Vec<CastRow> = (start..n.min(start + BLOCK_PATCHES))
            .into_par_iter()
            .map_init(
                || vec![0u32; n],
                |counts, i| cast_patch(patches, caster, rays, seed, i, counts),
            )
            .collect();
        for row in block {
            let valid = row.valid;
            let w = if valid == 0 { 0.0 } else { 1.0 / valid as f64 };
            for (j, count) in row.hits {
                f.col.push(j);
                f.val.push(repeated_sum(w, count));
            }
            f.row_ptr.push(f.col.len() as u32);
            escaped.push(row.escaped as f64 * w);
            visible.push(if row.cast { valid as f64 * inv } else { 1.0 });
            cast.push(row.cast);
        }
    }
    FormFactors {
        f,
        escaped,
        visible,
        cast,
        rays_per_patch: nr,
    }
}

/// `w` added `count` times (from `w`): the f64 value a row accumulates ray by ray.
fn repeated_sum(w: f64, count: u32) -> f64 {
    let mut v = w;
    for _ in 1..count {
        v += w;
    }
    v
}

/// The rays of patch `i` (one with an area) in the caster's frame, in cast order.
/// Origins spread over the patch by the R2 sequence, directions the ray set turned by the
/// patch's azimuth.
#[inline]
pub(crate) fn for_each_ray(
    patches: &Patches,
    caster: &RayCaster,
    rays: &RaySet,
    seed: u64,
    i: usize,
    mut f: impl FnMut(&Ray),
) {
    let (shift, azimuth) = patch_jitter(i, seed);
    let normal = patches.normal[i];
    let fr = frame(normal, azimuth);
    for (k, d) in rays.dirs.iter().enumerate() {
        let origin = caster.offset(patch_point(patches, i, k, shift), normal);
        f(&caster.frame_ray(origin, to_world(&fr, *d)));
    }
}

/// A patch's hit tally: ray counts per patch seen, escaped and covered rays.
pub(crate) struct Tally<'a> {
    /// Patch casting.
    i: usize,
    /// Hits per patch (all zero between patches).
    counts: &'a mut [u32],
    /// Patches seen at least once, in first-seen order.
    seen: Vec<u32>,
    escaped: usize,
    covered: usize,
}

impl<'a> Tally<'a> {
    pub(crate) fn new(i: usize, counts: &'a mut [u32]) -> Self {
        Self {
            i,
            counts,
            seen: Vec::new(),
            escaped: 0,
            covered: 0,
        }
    }

    /// Adds one ray's hit: a front face of another patch counts for it, a front face of the
    /// patch itself or a back face means the ray started under a cover, a miss escaped.
    #[inline]
    pub(crate) fn add(&mut self, hit: Hit) {
        match hit {
            Hit::Front { patch, .. } if patch as usize != self.i => {
                let c = &mut self.counts[patch as usize];
                if *c == 0 {
                    self.seen.push(patch);
                }
                *c += 1;
            }
            Hit::Front { .. } | Hit::Back { .. } => self.covered += 1,
            Hit::Miss => self.escaped += 1,
        }
    }

    /// The row (sorted columns with counts; `counts` is left all zero).
    pub(crate) fn finish(mut self, rays: usize) -> CastRow {
        self.seen.sort_unstable();
        let hits = self
            .seen
            .iter()
            .map(|&j| (j, std::mem::take(&mut self.counts[j as usize])))
            .collect();
        CastRow {
            hits,
            escaped: self.escaped,
            valid: rays - self.covered,
            cast: true,
        }
    }
}

/// Casts patch `i`'s rays. `counts` (one per patch, all zero on entry and on return) tallies the
/// hits per patch; its touched entries come out as the sorted row.
pub(crate) fn cast_patch(
    patches: &Patches,
    caster: &RayCaster,
    rays: &RaySet,
    seed: u64,
    i: usize,
    counts: &mut [u32],
) -> CastRow {
    if patches.area_m2[i] <= 0.0 {
        return CastRow {
            hits: Vec::new(),
            escaped: 0,
            valid: 0,
            cast: false,
        };
    }
    let mut tally = Tally::new(i, counts);
    for_each_ray(patches, caster, rays, seed, i, |ray| {
        tally.add(caster.hit(caster.trace(ray), ray));
    });
    tally.finish(rays.len())
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
/// Cost: every step is O(nnz): one walk over the pairs (on two threads) finds the missing
/// transposed entries and each entry's partner by one cursor per row (rows visited in order meet
/// their partners in row order) and sets the exchange areas, the pattern grows in place by a
/// backward merge per row, each closure pass is one sweep, and one pass over rows (on two
/// threads) applies the scaling and the guard and measures the errors.
/// Memory: in place. The pattern's new entries (12 bytes each, plus 12 while they are
/// placed) and a few bytes per patch beyond the CSR: the exchange areas replace the form factors
/// in their own array, and an entry has a partner exactly when both of its patches take part
/// (the pattern is symmetric among them), so no partner index is stored.
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
    let in_play: Vec<bool> = (0..n).map(|i| ff.cast[i] && area[i] > 0.0).collect();

    // 1. Symmetric pattern among taking-part patches; exchange areas in place of F (rows in
    // play: ML common value for partnered pairs, A_i F_ij for one-sided entries).
    let n_rays = ff.rays_per_patch as f64;
    symmetric_exchange_areas(&mut ff.f, &area, &takes_part, &in_play, n_rays);

    // 2. Symmetric scaling to closure.
    let target: Vec<f64> = ff.escaped.iter().map(|e| 1.0 - e).collect();
    let closure = Closure {
        f: &ff.f,
        takes_part: &takes_part,
        area_m2: &area,
        target: &target,
        in_play: &in_play,
    };
    let (x, iterations) = closure.scale(tolerance, max_iterations);
    // 3. The scaling applied, and the guard: a row still off its target by more than the
    // tolerance is scaled alone.
    let rows = Rows {
        x: &x,
        area: &area,
        target: &target,
        takes_part: &takes_part,
        in_play: &in_play,
    };
    let (rows_capped, reciprocity_error, closure_error) = rows.finish(&mut ff.f, tolerance);
    RectifyReport {
        iterations,
        reciprocity_error,
        closure_error,
        rows_capped,
        sparse_patches,
    }
}

/// Visits every entry `k` = (i, j) whose patches both take part, with the index `p` of the
/// entry (j, i) when row j holds it (`None`: it does not). (The tests' whole-matrix walk.)
#[cfg(test)]
fn for_each_pair(
    row_ptr: &[u32],
    col: &[u32],
    takes_part: &[bool],
    pair: impl FnMut(usize, usize, usize, Option<usize>),
) {
    let n = row_ptr.len().saturating_sub(1);
    walk_pairs(row_ptr, col, takes_part, (0..n, 0..n), pair);
}

/// Visits the entries `k` = (i, j) of rows i in `rows` with columns j in `cols` whose patches
/// both take part, with the index `p` of the entry (j, i) when row j holds it (`None`: it does
/// not).
///
/// Without searching: rows are visited in order, so the entries (j, i) that row j holds for
/// its partners i are met in increasing i, i.e. in the order of row j's sorted columns; one
/// cursor per row walks them. O(nnz) with one step into row j per entry (a binary search per
/// entry costs log(row length) cache misses once the matrix outgrows the cache).
fn walk_pairs(
    row_ptr: &[u32],
    col: &[u32],
    takes_part: &[bool],
    (rows, cols): (Range<usize>, Range<usize>),
    mut pair: impl FnMut(usize, usize, usize, Option<usize>),
) {
    // the first entry of row r with a column ≥ c
    let first_at_least = |r: usize, c: usize| -> usize {
        let (a, b) = (row_ptr[r] as usize, row_ptr[r + 1] as usize);
        a + col[a..b].partition_point(|&x| (x as usize) < c)
    };
    let mut cursor: Vec<u32> = cols
        .clone()
        .map(|j| first_at_least(j, rows.start) as u32)
        .collect();
    for i in rows.filter(|&i| takes_part[i]) {
        for k in first_at_least(i, cols.start)..first_at_least(i, cols.end) {
            let j = col[k] as usize;
            if !takes_part[j] {
                continue;
            }
            let end = row_ptr[j + 1] as usize;
            let c = &mut cursor[j - cols.start];
            let mut q = *c as usize;
            while q < end && (col[q] as usize) < i {
                q += 1;
            }
            *c = q as u32;
            pair(i, j, k, (q < end && col[q] as usize == i).then_some(q));
        }
    }
}

/// Two disjoint runs of the values (rows of two row ranges), addressed by entry index.
struct Vals<'a> {
    lo: &'a mut [f64],
    /// Entry index of `lo[0]`.
    lo_at: usize,
    hi: &'a mut [f64],
    /// Entry index of `hi[0]` (every entry of `lo` is below it).
    hi_at: usize,
}

impl Vals<'_> {
    #[inline]
    fn at(&mut self, k: usize) -> &mut f64 {
        if k >= self.hi_at {
            &mut self.hi[k - self.hi_at]
        } else {
            &mut self.lo[k - self.lo_at]
        }
    }
}

/// The pairs between patches of row ranges `a` and `b` (`a` below `b`, or the same range: the
/// pairs within it), whose values `vals` holds: the ML exchange area of each pair in place
/// (from the pair's lower row), and for an entry whose partner is missing, its own with 0 rays
/// for the partner. Returns the missing entries as (row, column).
fn exchange_block(
    f: (&[u32], &[u32]),
    takes_part: &[bool],
    (area, n_rays): (&[f64], f64),
    (a, b): (Range<usize>, Range<usize>),
    mut vals: Vals<'_>,
) -> Vec<(u32, u32)> {
    let (row_ptr, col) = f;
    let mut missing = Vec::new();
    let mut pair = |i: usize, j: usize, k: usize, p: Option<usize>| match p {
        Some(p) if j > i => {
            let (f_ij, f_ji) = (*vals.at(k), *vals.at(p));
            *vals.at(k) = ml_exchange_area(area[i], area[j], f_ij, f_ji, n_rays);
            *vals.at(p) = ml_exchange_area(area[j], area[i], f_ji, f_ij, n_rays);
        }
        Some(_) => {}
        None => {
            let v = vals.at(k);
            *v = ml_exchange_area(area[i], area[j], *v, 0.0, n_rays);
            missing.push((j as u32, i as u32));
        }
    };
    walk_pairs(row_ptr, col, takes_part, (a.clone(), b.clone()), &mut pair);
    if a != b {
        walk_pairs(row_ptr, col, takes_part, (b, a), &mut pair);
    }
    missing
}

/// Every pair's exchange area in place, on two threads: the rows are cut in four quarters of
/// about equal entries, Q0 to Q3, and the pairs walked in three rounds of two blocks that share
/// no row (within Q0 ∪ Q1 beside within Q2 ∪ Q3, Q0 × Q2 beside Q1 × Q3, Q0 × Q3 beside Q1 ×
/// Q2), each pair in the one block that holds both its rows, so the values are those of one walk
/// over the whole matrix. Returns the missing entries (row, column) and the quarters' first rows.
fn exchange_pairs(
    f: &mut Csr,
    takes_part: &[bool],
    area: &[f64],
    n_rays: f64,
) -> (Vec<Vec<(u32, u32)>>, [usize; 5]) {
    let n = f.rows();
    let nnz = f.nnz();
    let Csr { row_ptr, col, val } = f;
    let cut = |t: usize| {
        row_ptr
            .partition_point(|&r| (r as usize) < t * nnz / 4)
            .min(n)
    };
    let q = [0, cut(1), cut(2), cut(3), n];
    let e = q.map(|r| row_ptr[r] as usize);
    let ctx = ((&row_ptr[..], &col[..]), takes_part, (area, n_rays));
    let block = |a: Range<usize>, b: Range<usize>, vals: Vals<'_>| {
        exchange_block(ctx.0, ctx.1, ctx.2, (a, b), vals)
    };
    let mut missing = Vec::with_capacity(6);
    {
        let (v01, v23) = val.split_at_mut(e[2]);
        let (m0, m1) = rayon::join(
            || {
                block(
                    q[0]..q[2],
                    q[0]..q[2],
                    Vals {
                        lo: v01,
                        lo_at: 0,
                        hi: &mut [],
                        hi_at: e[2],
                    },
                )
            },
            || {
                block(
                    q[2]..q[4],
                    q[2]..q[4],
                    Vals {
                        lo: v23,
                        lo_at: e[2],
                        hi: &mut [],
                        hi_at: e[4],
                    },
                )
            },
        );
        missing.extend([m0, m1]);
    }
    for round in 0..2 {
        let (v0, rest) = val.split_at_mut(e[1]);
        let (v1, rest) = rest.split_at_mut(e[2] - e[1]);
        let (v2, v3) = rest.split_at_mut(e[3] - e[2]);
        // Q0 pairs with Q2 then Q3, Q1 with Q3 then Q2
        let ((x, vx), (y, vy)) = if round == 0 {
            ((2, v2), (3, v3))
        } else {
            ((3, v3), (2, v2))
        };
        let (m0, m1) = rayon::join(
            || {
                block(
                    q[0]..q[1],
                    q[x]..q[x + 1],
                    Vals {
                        lo: v0,
                        lo_at: 0,
                        hi: vx,
                        hi_at: e[x],
                    },
                )
            },
            || {
                block(
                    q[1]..q[2],
                    q[y]..q[y + 1],
                    Vals {
                        lo: v1,
                        lo_at: e[1],
                        hi: vy,
                        hi_at: e[y],
                    },
                )
            },
        );
        missing.extend([m0, m1]);
    }
    (missing, q)
}

/// Makes the pattern of `f` symmetric among taking-part patches and replaces the values of rows
/// in play by exchange areas, m², in place and in one walk over the pairs (on two threads:
/// [`exchange_pairs`]): the ML common value
/// of each pair ([`ml_exchange_area`] from the pair's two ray counts; a pair one of whose
/// entries is missing counts 0 rays for it, and the entry is added with the same value),
/// `A_i F_ij` for one-sided entries (toward a patch that takes no part). Rows not in play keep
/// their values.
///
/// The ML value is symmetric in its two sides bit for bit (its sums and products only change
/// operand order), so a missing entry (j, i) takes the value just written at (i, j). The
/// missing entries are bucketed by row (counting sort, stable: each row's list comes out sorted,
/// see below; 12 bytes per missing entry while they are placed); the arrays
/// then grow by their number and each row, from the last back, is merged with its list from its
/// end, so no entry is overwritten before it is read (a row only moves toward the end), each new
/// entry's value read from its partner by a cursor per row ([`merge_back`]).
fn symmetric_exchange_areas(
    f: &mut Csr,
    area: &[f64],
    takes_part: &[bool],
    in_play: &[bool],
    n_rays: f64,
) {
    let n = f.rows();
    let (missing, q) = exchange_pairs(f, takes_part, area, n_rays);
    one_sided_exchange_areas(f, area, takes_part, in_play);
    // counting sort on (row, quarter of the column): within one such bucket the entries come
    // from one block, in increasing column, so each row's list comes out sorted
    let key = |j: u32, i: u32| {
        let i = i as usize;
        4 * j as usize + usize::from(i >= q[1]) + usize::from(i >= q[2]) + usize::from(i >= q[3])
    };
    let mut start = vec![0u32; 4 * n + 1];
    for &(j, i) in missing.iter().flatten() {
        start[key(j, i) + 1] += 1;
    }
    for k in 0..4 * n {
        start[k + 1] += start[k];
    }
    let mut extra = vec![0u32; start[4 * n] as usize];
    let mut fill = start[..4 * n].to_vec();
    for (j, i) in missing.into_iter().flatten() {
        let b = &mut fill[key(j, i)];
        extra[*b as usize] = i;
        *b += 1;
    }
    drop(fill);
    let start: Vec<u32> = start.into_iter().step_by(4).collect();
    let nnz = f.nnz() + extra.len();
    f.col.resize(nnz, 0);
    f.val.resize(nnz, 0.0);
    // each row's partner cursor (exclusive end): its old end until it is merged, then its new end
    let mut cursor: Vec<u32> = f.row_ptr[1..].to_vec();
    for j in (0..n).rev() {
        let (s0, s1) = (start[j] as usize, start[j + 1] as usize);
        merge_back(f, j, s0, &extra[s0..s1], &mut cursor);
        cursor[j] = f.row_ptr[j + 1] + start[j + 1];
    }
    for (r, s) in f.row_ptr.iter_mut().zip(&start) {
        *r += s;
    }
}

/// `A_i F_ij` on one-sided entries of rows in play (one of the two patches takes no part).
fn one_sided_exchange_areas(f: &mut Csr, area: &[f64], takes_part: &[bool], in_play: &[bool]) {
    let col = &f.col;
    rows_mut(&f.row_ptr, &mut f.val)
        .into_par_iter()
        .enumerate()
        .for_each(|(i, (a, row))| {
            if !in_play[i] {
                return;
            }
            let cols = &col[a..a + row.len()];
            for (v, &j) in row.iter_mut().zip(cols) {
                if !(takes_part[i] && takes_part[j as usize]) {
                    *v *= area[i];
                }
            }
        });
}

/// The rows of `val` as mutable slices with their first entry index.
fn rows_mut<'a>(row_ptr: &[u32], val: &'a mut [f64]) -> Vec<(usize, &'a mut [f64])> {
    let mut rows = Vec::with_capacity(row_ptr.len());
    let mut rest = val;
    for w in row_ptr.windows(2) {
        let (row, tail) = std::mem::take(&mut rest).split_at_mut((w[1] - w[0]) as usize);
        rows.push((w[0] as usize, row));
        rest = tail;
    }
    rows
}

/// Moves row `j` of `f` (still at its old place) `shift` entries toward the end, merged with the
/// new entries of sorted columns `extra`, walking both from their ends. A new entry (j, i) takes
/// the value of its partner (i, j) (the pair's ML exchange area, the same bits on both sides),
/// found by row i's cursor: rows are merged from the last back, so row i's entries (i, j) are
/// asked for in decreasing j, at row i's old place while row i waits (i < j: rows before j
/// have not moved) and at its new place once it is merged (i > j: rows before j write only
/// below it).
fn merge_back(f: &mut Csr, j: usize, shift: usize, extra: &[u32], cursor: &mut [u32]) {
    let (a, b) = (f.row_ptr[j] as usize, f.row_ptr[j + 1] as usize);
    let (mut o, mut e) = (b, extra.len());
    let mut w = b + shift + extra.len();
    while e > 0 {
        w -= 1;
        if o > a && f.col[o - 1] > extra[e - 1] {
            o -= 1;
            f.col[w] = f.col[o];
            f.val[w] = f.val[o];
        } else {
            e -= 1;
            let i = extra[e] as usize;
            let mut c = cursor[i] as usize;
            while f.col[c - 1] as usize > j {
                c -= 1;
            }
            debug_assert_eq!(f.col[c - 1] as usize, j, "({i}, {j}) has no partner");
            cursor[i] = (c - 1) as u32;
            f.col[w] = i as u32;
            f.val[w] = f.val[c - 1];
        }
    }
    if shift > 0 {
        f.col.copy_within(a..o, a + shift);
        f.val.copy_within(a..o, a + shift);
    }
}

/// The last step of a rectification, over rows in play: the scaling `x` applied
/// (`F_ij = x_i G_ij x_j / A_i`, `x_j` = 1 for one-sided entries, the exchange areas `G_ij`
/// being the values in place), the guard (rows still off their target scaled alone), and the
/// report's errors.
struct Rows<'a> {
    x: &'a [f64],
    /// Visible areas, m².
    area: &'a [f64],
    /// Row targets `1 − F_sp,i`.
    target: &'a [f64],
    takes_part: &'a [bool],
    in_play: &'a [bool],
}

impl Rows<'_> {
    /// Entry (i, j)'s scaled value from its exchange area `g`.
    #[inline]
    fn scaled(&self, i: usize, j: usize, g: f64) -> f64 {
        let xj = if self.takes_part[i] && self.takes_part[j] {
            self.x[j]
        } else {
            1.0
        };
        self.x[i] * g * xj / self.area[i]
    }

    /// Applies the scaling and the guard to `f`, in parallel over rows (each row is read and
    /// written once, its partners' values are not read). Returns the rows capped, the largest
    /// relative reciprocity error over partnered pairs of rows not capped and the largest
    /// closure error over rows in play with a positive sum.
    ///
    /// The reciprocity error needs each entry's partner's final value: `x_j G_ji x_i / A_j`,
    /// computed here from the entry's own `G_ij` (the ML value is the same bits on both sides),
    /// so no pass looks the partners up. First pass: each row's scaled sum (the same sum, in the
    /// same order, as the row's after scaling), which marks the capped rows.
    fn finish(&self, f: &mut Csr, tolerance: f64) -> (usize, f64, f64) {
        let n = f.rows();
        let (row_ptr, col) = (&f.row_ptr, &f.col);
        let sums: Vec<f64> = (0..n)
            .into_par_iter()
            .map(|i| {
                let r = row_ptr[i] as usize..row_ptr[i + 1] as usize;
                if !self.in_play[i] {
                    return 0.0;
                }
                f.val[r.clone()]
                    .iter()
                    .zip(&col[r])
                    .map(|(&g, &j)| self.scaled(i, j as usize, g))
                    .sum()
            })
            .collect();
        let capped: Vec<bool> = (0..n)
            .map(|i| {
                let s = sums[i];
                self.in_play[i] && s > 0.0 && (s - self.target[i]).abs() > tolerance.max(1e-12)
            })
            .collect();
        let col = &f.col;
        let (reciprocity, closure) = rows_mut(&f.row_ptr, &mut f.val)
            .into_par_iter()
            .enumerate()
            .map(|(i, (a, row))| {
                if !self.in_play[i] {
                    return (0.0, 0.0);
                }
                let cols = &col[a..a + row.len()];
                let mut worst: f64 = 0.0;
                for (v, &j) in row.iter_mut().zip(cols) {
                    let j = j as usize;
                    let g = *v;
                    *v = self.scaled(i, j, g);
                    if self.takes_part[i] && self.takes_part[j] && !capped[i] && !capped[j] {
                        let a = self.area[i] * *v;
                        let b = self.area[j] * self.scaled(j, i, g);
                        if a + b > 0.0 {
                            worst = worst.max((a - b).abs() / (a + b));
                        }
                    }
                }
                let mut s = sums[i];
                if capped[i] {
                    let c = self.target[i] / s;
                    for v in row.iter_mut() {
                        *v *= c;
                    }
                    s = row.iter().sum();
                }
                let closure = if s > 0.0 {
                    (s - self.target[i]).abs()
                } else {
                    0.0
                };
                (worst, closure)
            })
            .reduce(|| (0.0, 0.0), |a, b| (a.0.max(b.0), a.1.max(b.1)));
        (capped.iter().filter(|&&c| c).count(), reciprocity, closure)
    }
}

/// The symmetric scaling to closure: `x_i` with `Σ_j x_i G_ij x_j / A_i = 1 − F_sp,i`.
struct Closure<'a> {
    /// The symmetric pattern, exchange areas per entry (m²) as values.
    f: &'a Csr,
    /// Patches taking part in reciprocity (an entry has a partner when both its patches do).
    takes_part: &'a [bool],
    /// Visible areas, m².
    area_m2: &'a [f64],
    /// Row targets `1 − F_sp,i`.
    target: &'a [f64],
    /// Rows that are scaled (cast, with a visible area).
    in_play: &'a [bool],
}

impl Closure<'_> {
    /// Row `i`'s sum at scaling `x`, `xp` being `x` as a partnered entry sees it (`x_j` for
    /// patches taking part, 1 for the others: `G · 1` is `G`, bit for bit).
    #[inline]
    fn row_sum(&self, i: usize, x: &[f64], xp: &[f64]) -> f64 {
        let (a, b) = (self.f.row_ptr[i] as usize, self.f.row_ptr[i + 1] as usize);
        let (vals, cols) = (&self.f.val[a..b], &self.f.col[a..b]);
        let mut s = 0.0;
        if self.takes_part[i] {
            for (&g, &j) in vals.iter().zip(cols) {
                s += g * xp[j as usize];
            }
        } else {
            for &g in vals {
                s += g;
            }
        }
        x[i] * s / self.area_m2[i]
    }

    /// Gauss-Seidel over rows (each pass O(nnz)): the scaling and the passes it took.
    ///
    /// Stops early when the worst row has not improved by 10 % in 25 passes (converging rows
    /// gain a factor of ten in that many): it has no reciprocal closure, or crawls toward one
    /// (a few slivers on a 22 000-patch floor), and the guard closes it alone.
    fn scale(&self, tolerance: f64, max_iterations: u32) -> (Vec<f64>, u32) {
        let n = self.f.rows();
        let mut x = vec![1.0f64; n];
        let mut xp = vec![1.0f64; n];
        let mut iterations = 0;
        let (mut best, mut since_best) = (f64::INFINITY, 0u32);
        for it in 1..=max_iterations.max(1) {
            let mut worst: f64 = 0.0;
            for i in 0..n {
                if !self.in_play[i] {
                    continue;
                }
                let s = self.row_sum(i, &x, &xp);
                if s > 0.0 {
                    worst = worst.max((s - self.target[i]).abs());
                    x[i] *= self.target[i] / s;
                    if self.takes_part[i] {
                        xp[i] = x[i];
                    }
                }
            }
            iterations = it;
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
        (x, iterations)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rectification as it was before it was fused into one pair walk and one parallel
    /// pass (symmetrize, exchange areas, closure, scaling, guard and reciprocity error each on
    /// their own, the last with a pair walk of its own): the reference the new one must match
    /// bit for bit.
    mod reference {
        use super::super::{
            Csr, FormFactors, MIN_VISIBLE_FRACTION, RectifyReport, for_each_pair, ml_exchange_area,
        };
        use rayon::prelude::*;

        pub(super) fn rectify(
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
            let in_play: Vec<bool> = (0..n).map(|i| ff.cast[i] && area[i] > 0.0).collect();

            // 1. Symmetric pattern among taking-part patches; exchange areas in place of F (rows in
            // play: ML common value for partnered pairs, A_i F_ij for one-sided entries).
            symmetrize(&mut ff.f, &takes_part);
            let n_rays = ff.rays_per_patch as f64;
            exchange_areas(&mut ff.f, &area, &takes_part, &in_play, n_rays);

            // 2. Symmetric scaling to closure.
            let target: Vec<f64> = ff.escaped.iter().map(|e| 1.0 - e).collect();
            let closure = Closure {
                f: &ff.f,
                takes_part: &takes_part,
                area_m2: &area,
                target: &target,
                in_play: &in_play,
            };
            let (x, iterations) = closure.scale(tolerance, max_iterations);
            apply_scaling(&mut ff.f, &x, &area, &takes_part, &in_play);
            // 3. The guard: a row still off its target by more than the tolerance is scaled alone.
            let capped = cap_rows(&mut ff.f, &target, &in_play, tolerance);
            let mut is_capped = vec![false; n];
            for &i in &capped {
                is_capped[i] = true;
            }
            RectifyReport {
                iterations,
                reciprocity_error: reciprocity_error(&ff.f, &takes_part, &area, &is_capped),
                closure_error: (0..n)
                    .filter(|&i| in_play[i] && ff.f.row_sum(i) > 0.0)
                    .map(|i| (ff.f.row_sum(i) - target[i]).abs())
                    .fold(0.0, f64::max),
                rows_capped: capped.len(),
                sparse_patches,
            }
        }

        /// Makes the pattern of `f` symmetric among taking-part patches, in place: (j, i) exists
        /// wherever (i, j) does (new entries 0).
        ///
        /// The missing entries (j, i) are found by [`for_each_pair`] and bucketed by row (counting
        /// sort, stable: each row's list comes out sorted, rows i being visited in order; 12 bytes per
        /// missing entry while they are placed); the arrays then grow by their number and each row,
        /// from the last back, is merged with its list from its end, so no entry is overwritten before
        /// it is read (a row only moves toward the end).
        fn symmetrize(f: &mut Csr, takes_part: &[bool]) {
            let n = f.rows();
            let mut missing: Vec<(u32, u32)> = Vec::new();
            for_each_pair(&f.row_ptr, &f.col, takes_part, |i, j, _, p| {
                if p.is_none() {
                    missing.push((j as u32, i as u32));
                }
            });
            let mut start = vec![0u32; n + 1];
            for &(j, _) in &missing {
                start[j as usize + 1] += 1;
            }
            for k in 0..n {
                start[k + 1] += start[k];
            }
            let mut extra = vec![0u32; missing.len()];
            let mut fill = start[..n].to_vec();
            for (j, i) in missing {
                extra[fill[j as usize] as usize] = i;
                fill[j as usize] += 1;
            }
            drop(fill);
            let nnz = f.nnz() + extra.len();
            f.col.resize(nnz, 0);
            f.val.resize(nnz, 0.0);
            for i in (0..n).rev() {
                let (s0, s1) = (start[i] as usize, start[i + 1] as usize);
                merge_back(f, i, s0, &extra[s0..s1]);
            }
            for (r, s) in f.row_ptr.iter_mut().zip(&start) {
                *r += s;
            }
        }

        /// Moves row `i` of `f` (still at its old place) `shift` entries toward the end, merged with the
        /// sorted new columns `extra` (value 0), walking both from their ends.
        fn merge_back(f: &mut Csr, i: usize, shift: usize, extra: &[u32]) {
            let (a, b) = (f.row_ptr[i] as usize, f.row_ptr[i + 1] as usize);
            let (mut o, mut e) = (b, extra.len());
            let mut w = b + shift + extra.len();
            while e > 0 {
                w -= 1;
                if o > a && f.col[o - 1] > extra[e - 1] {
                    o -= 1;
                    f.col[w] = f.col[o];
                    f.val[w] = f.val[o];
                } else {
                    e -= 1;
                    f.col[w] = extra[e];
                    f.val[w] = 0.0;
                }
            }
            if shift > 0 {
                f.col.copy_within(a..o, a + shift);
                f.val.copy_within(a..o, a + shift);
            }
        }

        /// Replaces the form factors of rows in play by exchange areas, m²: the ML common value of each
        /// partnered pair (both entries from the pair's two ray counts), `A_i F_ij` for one-sided
        /// entries. Rows not in play keep their values.
        fn exchange_areas(
            f: &mut Csr,
            area: &[f64],
            takes_part: &[bool],
            in_play: &[bool],
            n_rays: f64,
        ) {
            let Csr { row_ptr, col, val } = f;
            for_each_pair(row_ptr, col, takes_part, |i, j, k, p| {
                if let Some(p) = p.filter(|_| j > i) {
                    let (f_ij, f_ji) = (val[k], val[p]);
                    val[k] = ml_exchange_area(area[i], area[j], f_ij, f_ji, n_rays);
                    val[p] = ml_exchange_area(area[j], area[i], f_ji, f_ij, n_rays);
                }
            });
            for i in (0..in_play.len()).filter(|&i| in_play[i]) {
                for k in row_ptr[i] as usize..row_ptr[i + 1] as usize {
                    if !(takes_part[i] && takes_part[col[k] as usize]) {
                        val[k] *= area[i];
                    }
                }
            }
        }

        /// Sets `F_ij = x_i G_ij x_j / A_i` on rows in play (`x_j` = 1 for one-sided entries), the
        /// exchange areas `G_ij` being the values in place.
        fn apply_scaling(
            f: &mut Csr,
            x: &[f64],
            area: &[f64],
            takes_part: &[bool],
            in_play: &[bool],
        ) {
            let Csr { row_ptr, col, val } = f;
            let mut rows: Vec<&mut [f64]> = Vec::with_capacity(row_ptr.len());
            let mut rest = val.as_mut_slice();
            for w in row_ptr.windows(2) {
                let (row, tail) = std::mem::take(&mut rest).split_at_mut((w[1] - w[0]) as usize);
                rows.push(row);
                rest = tail;
            }
            let col = &*col;
            let row_ptr = &*row_ptr;
            rows.into_par_iter().enumerate().for_each(|(i, row)| {
                if !in_play[i] {
                    return;
                }
                let cols = &col[row_ptr[i] as usize..row_ptr[i + 1] as usize];
                for (v, &j) in row.iter_mut().zip(cols) {
                    let j = j as usize;
                    let xj = if takes_part[i] && takes_part[j] {
                        x[j]
                    } else {
                        1.0
                    };
                    *v = x[i] * *v * xj / area[i];
                }
            });
        }

        /// The symmetric scaling to closure: `x_i` with `Σ_j x_i G_ij x_j / A_i = 1 − F_sp,i`.
        struct Closure<'a> {
            /// The symmetric pattern, exchange areas per entry (m²) as values.
            f: &'a Csr,
            /// Patches taking part in reciprocity (an entry has a partner when both its patches do).
            takes_part: &'a [bool],
            /// Visible areas, m².
            area_m2: &'a [f64],
            /// Row targets `1 − F_sp,i`.
            target: &'a [f64],
            /// Rows that are scaled (cast, with a visible area).
            in_play: &'a [bool],
        }

        impl Closure<'_> {
            /// Row `i`'s sum at scaling `x`.
            fn row_sum(&self, i: usize, x: &[f64]) -> f64 {
                let (a, b) = (self.f.row_ptr[i] as usize, self.f.row_ptr[i + 1] as usize);
                let mut s = 0.0;
                for (&g, &j) in self.f.val[a..b].iter().zip(&self.f.col[a..b]) {
                    let j = j as usize;
                    let xj = if self.takes_part[i] && self.takes_part[j] {
                        x[j]
                    } else {
                        1.0
                    };
                    s += g * xj;
                }
                x[i] * s / self.area_m2[i]
            }

            /// Gauss-Seidel over rows (each pass O(nnz)): the scaling and the passes it took.
            ///
            /// Stops early when the worst row has not improved by 10 % in 25 passes (converging rows
            /// gain a factor of ten in that many): it has no reciprocal closure, or crawls toward one
            /// (a few slivers on a 22 000-patch floor), and the guard closes it alone.
            fn scale(&self, tolerance: f64, max_iterations: u32) -> (Vec<f64>, u32) {
                let n = self.f.rows();
                let mut x = vec![1.0f64; n];
                let mut iterations = 0;
                let (mut best, mut since_best) = (f64::INFINITY, 0u32);
                for it in 1..=max_iterations.max(1) {
                    let mut worst: f64 = 0.0;
                    for i in 0..n {
                        if !self.in_play[i] {
                            continue;
                        }
                        let s = self.row_sum(i, &x);
                        if s > 0.0 {
                            worst = worst.max((s - self.target[i]).abs());
                            x[i] *= self.target[i] / s;
                        }
                    }
                    iterations = it;
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
                (x, iterations)
            }
        }

        /// The guard: each row in play still off its target by more than the tolerance is scaled
        /// alone to it. Returns those rows.
        fn cap_rows(f: &mut Csr, target: &[f64], in_play: &[bool], tolerance: f64) -> Vec<usize> {
            let capped: Vec<usize> = (0..f.rows())
                .into_par_iter()
                .filter(|&i| {
                    let s = f.row_sum(i);
                    in_play[i] && s > 0.0 && (s - target[i]).abs() > tolerance.max(1e-12)
                })
                .collect();
            for &i in &capped {
                let s = f.row_sum(i);
                let (a, b) = (f.row_ptr[i] as usize, f.row_ptr[i + 1] as usize);
                for v in &mut f.val[a..b] {
                    *v *= target[i] / s;
                }
            }
            capped
        }

        /// The largest relative reciprocity error over partnered pairs, leaving out capped rows.
        fn reciprocity_error(
            f: &Csr,
            takes_part: &[bool],
            area_m2: &[f64],
            capped: &[bool],
        ) -> f64 {
            let mut worst: f64 = 0.0;
            for_each_pair(&f.row_ptr, &f.col, takes_part, |i, j, k, p| {
                let Some(p) = p.filter(|_| !capped[i] && !capped[j]) else {
                    return;
                };
                let a = area_m2[i] * f.val[k];
                let b = area_m2[j] * f.val[p];
                if a + b > 0.0 {
                    worst = worst.max((a - b).abs() / (a + b));
                }
            });
            worst
        }
    }

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

    /// A sparse pseudo-random pattern (rows sorted, no diagonal), values 1 + i + j / 1000.
    fn random_rows(n: usize, seed: u64) -> Vec<Vec<(u32, f64)>> {
        (0..n)
            .map(|i| {
                (0..n)
                    .filter(|&j| j != i && hash64(seed ^ (i * n + j) as u64).is_multiple_of(5))
                    .map(|j| (j as u32, 1.0 + i as f64 + j as f64 / 1000.0))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn symmetrize_in_place_matches_a_dense_reference() {
        let n = 60;
        let rows = random_rows(n, 7);
        let takes_part: Vec<bool> = (0..n).map(|i| i % 7 != 3).collect();
        let mut f = Csr::from_rows(rows.clone());
        let ones = vec![1.0; n];
        symmetric_exchange_areas(&mut f, &ones, &takes_part, &vec![true; n], 300.0);
        // reference: a dense n × n table of the entries, then the transposed ones added
        let mut dense = vec![vec![None; n]; n];
        for (i, row) in rows.iter().enumerate() {
            for &(j, v) in row {
                dense[i][j as usize] = Some(v);
            }
        }
        for i in 0..n {
            for j in 0..n {
                if takes_part[i] && takes_part[j] && dense[i][j].is_some() && dense[j][i].is_none()
                {
                    dense[j][i] = Some(0.0);
                }
            }
        }
        let expected = Csr::from_rows(
            dense
                .iter()
                .map(|r| (0..n).filter_map(|j| r[j].map(|v| (j as u32, v))).collect())
                .collect(),
        );
        assert_eq!((&f.row_ptr, &f.col), (&expected.row_ptr, &expected.col));
        // every entry between taking-part patches has its partner
        let mut pairs = 0;
        for_each_pair(&f.row_ptr, &f.col, &takes_part, |i, j, _, p| {
            let p = p.unwrap_or_else(|| panic!("({i}, {j}) has no partner"));
            assert_eq!(f.col[p] as usize, i);
            pairs += 1;
        });
        let expected_pairs = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .filter(|&(i, j)| takes_part[i] && takes_part[j] && dense[i][j].is_some())
            .count();
        assert_eq!(pairs, expected_pairs);
    }

    /// Form factors of `n` patches with a random pattern and ray counts, some patches cast from
    /// nothing, some mostly covered (no part in reciprocity), some black (no area).
    fn random_form_factors(n: usize, rays: usize, seed: u64) -> (FormFactors, Vec<f64>) {
        let rows: Vec<Vec<(u32, f64)>> = (0..n)
            .map(|i| {
                if i % 11 == 5 {
                    return Vec::new();
                }
                (0..n)
                    .filter(|&j| j != i && hash64(seed ^ (i * n + j) as u64).is_multiple_of(3))
                    .map(|j| {
                        let count = 1 + hash64(seed ^ 77 ^ (i * n + j) as u64) % 9;
                        (j as u32, count as f64 / rays as f64)
                    })
                    .collect()
            })
            .collect();
        let f = Csr::from_rows(rows);
        let escaped = (0..n)
            .map(|i| (1.0 - f.row_sum(i)).max(0.0) * 0.3)
            .collect();
        let visible = (0..n)
            .map(|i| {
                if i % 13 == 4 {
                    0.03
                } else {
                    0.5 + (i % 5) as f64 / 10.0
                }
            })
            .collect();
        let cast = (0..n).map(|i| i % 11 != 5).collect();
        let area = (0..n)
            .map(|i| {
                if i % 17 == 9 {
                    0.0
                } else {
                    0.5 + (i % 7) as f64 / 7.0
                }
            })
            .collect();
        let ff = FormFactors {
            f,
            escaped,
            visible,
            cast,
            rays_per_patch: rays,
        };
        (ff, area)
    }

    /// The fused rectification (one pair walk, a parallel last pass) gives the very bits of the
    /// pass-by-pass one it replaced, on random form factors (patches taking no part, black and
    /// uncast ones, capped rows) and on a closed cube's.
    #[test]
    fn rectify_matches_the_pass_by_pass_reference_bit_for_bit() {
        let mut cases: Vec<(FormFactors, Vec<f64>, f64, u32)> = Vec::new();
        for (n, seed) in [(40, 1), (90, 2), (150, 3)] {
            let (ff, area) = random_form_factors(n, 300, seed);
            cases.push((ff.clone(), area.clone(), 1e-9, 500));
            cases.push((ff, area, 1e-9, 3));
        }
        let patches = closed_cube(6);
        let caster = RayCaster::new(&patches);
        let ff = compute(&patches, &caster, &RaySet::isocell(300), 1);
        cases.push((ff, patches.area_m2.clone(), 1e-9, 500));
        let bits = |f: &Csr| f.val.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        let (mut capped, mut sparse, mut added) = (0, 0, 0);
        for (ff, area, tolerance, passes) in cases {
            let nnz = ff.f.nnz();
            let (mut a, mut b) = (ff.clone(), ff);
            let ra = rectify(&mut a, &area, tolerance, passes);
            let rb = reference::rectify(&mut b, &area, tolerance, passes);
            assert_eq!((&a.f.row_ptr, &a.f.col), (&b.f.row_ptr, &b.f.col));
            assert_eq!(bits(&a.f), bits(&b.f));
            assert_eq!(ra.iterations, rb.iterations);
            assert_eq!(ra.rows_capped, rb.rows_capped);
            assert_eq!(ra.sparse_patches, rb.sparse_patches);
            assert_eq!(
                ra.reciprocity_error.to_bits(),
                rb.reciprocity_error.to_bits()
            );
            assert_eq!(ra.closure_error.to_bits(), rb.closure_error.to_bits());
            capped += ra.rows_capped;
            sparse += ra.sparse_patches;
            added += a.f.nnz() - nnz;
        }
        // the cases reach the guard, the patches taking no part and the added entries
        assert!(
            capped > 0 && sparse > 0 && added > 0,
            "{capped} {sparse} {added}"
        );
    }

    /// A closed cube of side 2 m, each face an `n × n` grid of squares split in two triangles,
    /// normals inward.
    fn closed_cube(n: usize) -> Patches {
        let mut patches = Patches::default();
        let s = 2.0 / n as f64;
        // (origin, u, v) per face, u × v pointing into the cube
        let faces = [
            (DVec3::ZERO, DVec3::X, DVec3::Y),
            (DVec3::new(0.0, 0.0, 2.0), DVec3::Y, DVec3::X),
            (DVec3::ZERO, DVec3::Z, DVec3::X),
            (DVec3::new(0.0, 2.0, 0.0), DVec3::X, DVec3::Z),
            (DVec3::ZERO, DVec3::Y, DVec3::Z),
            (DVec3::new(2.0, 0.0, 0.0), DVec3::Z, DVec3::Y),
        ];
        for (o, u, v) in faces {
            for a in 0..n {
                for b in 0..n {
                    let p = |da: usize, db: usize| {
                        o + u * ((a + da) as f64 * s) + v * ((b + db) as f64 * s)
                    };
                    for t in [[p(0, 0), p(1, 0), p(1, 1)], [p(0, 0), p(1, 1), p(0, 1)]] {
                        let cross = (t[1] - t[0]).cross(t[2] - t[0]);
                        patches.corners_m.push(t);
                        patches.normal.push(cross.normalize());
                        patches.area_m2.push(0.5 * cross.length());
                        patches.rho.push(0.5);
                        patches.group.push(0);
                        patches.source_triangle.push(0);
                    }
                }
            }
        }
        patches
    }

    /// This process's resident-set high-water mark and current size, bytes (Linux).
    fn rss_bytes() -> Option<(u64, u64)> {
        let s = std::fs::read_to_string("/proc/self/status").ok()?;
        let kb = |key: &str| -> Option<u64> {
            let line = s.lines().find(|l| l.starts_with(key))?;
            line.split_whitespace().nth(1)?.parse().ok()
        };
        Some((kb("VmHWM:")? * 1024, kb("VmRSS:")? * 1024))
    }

    /// Memory guard: casting and rectifying hold little beyond the CSR they build (the rows
    /// stream into it; rectification works in place). The peak resident set grows by
    /// `PEAK_OVER_CSR` × the CSR's bytes at most; measured 1.1 on this cube (the rows held per
    /// patch and per thread, then the CSR built beside them, then the merged pattern, used to
    /// take about 4). Measured only in a process of its own (nextest's process-per-test mode:
    /// under `cargo test` other tests allocate beside it) where `/proc/self/clear_refs` can
    /// reset the high-water mark; skipped elsewhere.
    #[test]
    fn form_factors_peak_memory_is_about_the_csr() {
        const PEAK_OVER_CSR: f64 = 1.6;
        if std::env::var("NEXTEST_EXECUTION_MODE").as_deref() != Ok("process-per-test") {
            println!("skipped: not in a process of its own");
            return;
        }
        let patches = closed_cube(24);
        let caster = RayCaster::new(&patches);
        let rays = RaySet::isocell(300);
        // the high-water mark is Linux's /proc (an emulator may not reset it: say so)
        let reset = std::fs::write("/proc/self/clear_refs", "5").is_ok();
        let (Some((_, rss_before)), true) = (rss_bytes(), reset) else {
            println!("skipped: /proc/self cannot reset and read the high-water mark here");
            return;
        };
        let mut ff = compute(&patches, &caster, &rays, 1);
        let r = rectify(&mut ff, &patches.area_m2, 1e-9, 500);
        let Some((peak, _)) = rss_bytes() else {
            println!("skipped: /proc/self/status unreadable");
            return;
        };
        let csr = (ff.f.nnz() * 12 + ff.f.row_ptr.len() * 4) as f64;
        let ratio = peak.saturating_sub(rss_before) as f64 / csr;
        println!(
            "{} entries, CSR {csr:.0} B, peak growth {ratio:.2} × CSR, {r:?}",
            ff.f.nnz()
        );
        assert!(r.closure_error < 1e-6, "{r:?}");
        assert!(ratio <= PEAK_OVER_CSR, "peak grew by {ratio:.2} × the CSR");
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
