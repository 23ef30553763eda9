//! `luxnode bench control`: the least-power optimiser's time and optimality at room sizes up to
//! 64 luminaires × 100 desks. Instances are office-like (each desk lit mostly by the luminaires
//! near it, seeded), half with targets every state can meet, half with some desks out of reach.
//! Optimality: the continuous optimum against the independent `microlp` solver, and the DALI
//! plan against that optimum (a lower bound of any plan). Times: each instance is solved once
//! to warm the caches and the scratch (untimed), then [`TIMED_RUNS`] times; the medians are
//! over every timed run.
//!
//! [`exhaustive`]: the DALI plan against the true DALI optimum found by trying every
//! combination of levels, for rooms of two to four luminaires.

use std::time::{Duration, Instant};

use microlp::{ComparisonOp, OptimizationDirection, Problem, SolveOutcome};

use crate::control::{Demand, LuminairePower, Plan, PlanOut, Plant, optimise, plan, scratch_len};
use crate::dali::{ArcLevel, DimmingCurve};
use crate::rng::SplitMix64;

/// The (luminaires, desks) sizes of `luxnode bench control`'s first table.
pub const SIZES: [(usize, usize); 5] = [(8, 8), (16, 24), (32, 50), (64, 100), (128, 200)];
/// The sizes of its exhaustive comparison.
pub const EXHAUSTIVE_SIZES: [(usize, usize); 3] = [(2, 3), (3, 4), (4, 6)];

/// Timed optimisations per instance (after one untimed warm-up).
pub const TIMED_RUNS: usize = 3;

/// One row of the table.
#[derive(Debug, Clone)]
pub struct ControlRow {
    /// Luminaires.
    pub luminaires: usize,
    /// Desks.
    pub desks: usize,
    /// Instances.
    pub instances: usize,
    /// Median time of one optimisation (LP, rounding, exchange).
    pub median: Duration,
    /// Median CPU time of one optimisation (unaffected by other processes).
    pub median_cpu: Duration,
    /// Worst CPU time.
    pub worst_cpu: Duration,
    /// Median simplex iterations.
    pub iterations: u32,
    /// Median wall time of `microlp` on the same programme (continuous only: no DALI levels).
    pub microlp_median: Duration,
    /// Worst |ours − microlp| / microlp of the continuous optimum.
    pub lp_rel_diff: f64,
    /// Worst excess of the DALI plan's power over the continuous optimum.
    pub dali_excess: f64,
    /// Instances with some desk out of reach.
    pub infeasible: usize,
}

/// An office-like room: luminaires on a grid, desks on a grid, lux falling with distance; the
/// response matrix (row-major, desk × luminaire) and the luminaires' power (30-60 W, 0.3 W
/// standby, minimum level 85).
pub fn room(l: usize, kd: usize, rng: &mut SplitMix64) -> (Vec<f64>, Vec<LuminairePower>) {
    let side = |n: usize| (n as f64).sqrt().ceil() as usize;
    let (sl, sd) = (side(l), side(kd));
    let pos = |i: usize, s: usize| ((i % s) as f64 / s as f64, (i / s) as f64 / s as f64);
    let mut r = vec![0.0; kd * l];
    for k in 0..kd {
        let (dx, dy) = pos(k, sd);
        for j in 0..l {
            let (lx, ly) = pos(j, sl);
            let d2 = ((dx - lx).powi(2) + (dy - ly).powi(2)) * 100.0;
            r[k * l + j] = 900.0 / (1.0 + d2).powf(1.5) * (0.8 + 0.4 * rng.next_f64());
        }
    }
    let power = (0..l)
        .map(|_| LuminairePower {
            full_w: 30.0 + 30.0 * rng.next_f64(),
            standby_w: 0.3,
            min_arc: 85,
        })
        .collect();
    (r, power)
}

fn microlp_power(
    kd: usize,
    l: usize,
    r: &[f64],
    power: &[LuminairePower],
    target: &[f64],
    price: f64,
) -> Option<f64> {
    let mut p = Problem::new(OptimizationDirection::Minimize);
    let x: Vec<_> = power
        .iter()
        .map(|w| p.add_var(w.slope_w(), (0.0, 1.0)))
        .collect();
    let s: Vec<_> = target
        .iter()
        .map(|t| p.add_var(price / t.max(1.0), (0.0, f64::INFINITY)))
        .collect();
    for k in 0..kd {
        let mut terms: Vec<(microlp::Variable, f64)> =
            (0..l).map(|j| (x[j], r[k * l + j])).collect();
        terms.push((s[k], 1.0));
        p.add_constraint(&terms[..], ComparisonOp::Ge, target[k]);
    }
    match p.solve() {
        Ok(SolveOutcome::Solution(sol)) => Some(
            (0..l)
                .map(|j| power[j].standby_w + power[j].slope_w() * sol[x[j]])
                .sum::<f64>()
                + (0..kd)
                    .map(|k| sol[s[k]] * price / target[k].max(1.0))
                    .sum::<f64>(),
        ),
        _ => None,
    }
}

/// The table for these (luminaires, desks) sizes.
pub fn run(sizes: &[(usize, usize)], instances: usize, seed: u64) -> Vec<ControlRow> {
    let mut rng = SplitMix64::new(seed);
    let mut rows = Vec::new();
    for &(l, kd) in sizes {
        let mut times = Vec::new();
        let mut cpu = Vec::new();
        let mut iterations = Vec::new();
        let mut microlp_times = Vec::new();
        let (mut lp_rel, mut excess, mut infeasible) = (0.0f64, 0.0f64, 0);
        for i in 0..instances {
            let (r, power) = room(l, kd, &mut rng);
            // half the instances reachable everywhere, half asking too much of some desks
            let reach: Vec<f64> = (0..kd)
                .map(|k| r[k * l..(k + 1) * l].iter().sum())
                .collect();
            let target: Vec<f64> = (0..kd)
                .map(|k| {
                    let f = if i % 2 == 0 { 0.6 } else { 1.1 };
                    (f * reach[k] * (0.5 + 0.5 * rng.next_f64())).clamp(1.0, 1500.0)
                })
                .collect();
            let daylight = vec![0.0; kd];
            let plant = Plant {
                desks: kd,
                luminaires: l,
                response_lx: &r,
                power: &power,
                curve: DimmingCurve::Logarithmic,
            };
            let (mut arc, mut lux, mut met) =
                (vec![ArcLevel::OFF; l], vec![0.0; kd], vec![false; kd]);
            let mut scratch = vec![0.0; scratch_len(kd, l, false)];
            let mut rep = None;
            for run in 0..=TIMED_RUNS {
                let c0 = crate::host::thread_cpu_time();
                let t0 = Instant::now();
                rep = Some(optimise(
                    &plant,
                    &Demand {
                        target_lx: &target,
                        daylight_lx: &daylight,
                        uniformity: None,
                    },
                    PlanOut {
                        arc: &mut arc,
                        lux: &mut lux,
                        met: &mut met,
                    },
                    &mut scratch,
                ));
                let wall = t0.elapsed();
                if run == 0 {
                    continue; // the warm-up
                }
                times.push(wall);
                if let (Some(c0), Some(c1)) = (c0, crate::host::thread_cpu_time()) {
                    cpu.push(c1 - c0);
                }
            }
            let Some(Ok(rep)) = rep else { continue };
            iterations.push(rep.iterations);
            infeasible += usize::from(rep.short > 0);
            // the same programme for microlp: shortfall priced as the optimiser prices it
            let total: f64 = power.iter().map(|p| p.slope_w()).sum();
            let price = 1e4 * (total + 1.0);
            let t0 = Instant::now();
            let reference = microlp_power(kd, l, &r, &power, &target, price);
            microlp_times.push(t0.elapsed());
            if rep.short == 0
                && let Some(reference) = reference
            {
                // every desk reachable: no shortfall in either answer, both are power
                lp_rel = lp_rel.max((rep.lp_power_w - reference).abs() / reference);
                excess = excess.max(rep.power_w / rep.lp_power_w - 1.0);
            }
        }
        iterations.sort_unstable();
        microlp_times.sort();
        times.sort();
        cpu.sort();
        rows.push(ControlRow {
            luminaires: l,
            desks: kd,
            instances,
            median: times[times.len() / 2],
            median_cpu: cpu.get(cpu.len() / 2).copied().unwrap_or_default(),
            worst_cpu: cpu.last().copied().unwrap_or_default(),
            iterations: iterations.get(iterations.len() / 2).copied().unwrap_or(0),
            microlp_median: microlp_times
                .get(microlp_times.len() / 2)
                .copied()
                .unwrap_or_default(),
            lp_rel_diff: lp_rel,
            dali_excess: excess,
            infeasible,
        });
    }
    rows
}

/// One row of the exhaustive comparison.
#[derive(Debug, Clone)]
pub struct ExhaustiveRow {
    /// Luminaires.
    pub luminaires: usize,
    /// Desks.
    pub desks: usize,
    /// Instances whose targets some combination of levels meets (the others are skipped).
    pub feasible: usize,
    /// Instances where the plan's power equals the optimum's (within 1e-9 relative).
    pub optimal: usize,
    /// Mean excess of the plan's power over the optimum's.
    pub mean_excess: f64,
    /// Worst excess.
    pub worst_excess: f64,
    /// Combinations tried per instance.
    pub combinations: u64,
}

/// The least power of any combination of DALI levels (each luminaire off or at its minimum
/// level or above) meeting every target: every level of the first L − 1 luminaires is tried,
/// and the last one takes the lowest level that closes the remaining gap. `None`: no
/// combination meets the targets.
pub fn exhaustive_optimum(
    plant: &Plant<'_>,
    target_lx: &[f64],
    daylight_lx: &[f64],
) -> (Option<f64>, u64) {
    let (kd, l, r) = (plant.desks, plant.luminaires, plant.response_lx);
    let levels = |j: usize| -> Vec<(f64, f64)> {
        let p = plant.power[j];
        std::iter::once(0u8)
            .chain(p.min_arc..=254)
            .map(|a| {
                let x = ArcLevel(a).fraction(plant.curve).unwrap_or(0.0);
                (x, p.power_w(x))
            })
            .collect()
    };
    let table: Vec<Vec<(f64, f64)>> = (0..l).map(levels).collect();
    let last = l - 1;
    let mut best: Option<f64> = None;
    let mut combinations = 0u64;
    let mut idx = vec![0usize; last];
    let mut lux = vec![0.0; kd];
    loop {
        combinations += 1;
        let mut power = 0.0;
        for (k, e) in lux.iter_mut().enumerate() {
            *e = daylight_lx[k];
        }
        for (j, &n) in idx.iter().enumerate() {
            let (x, p) = table[j][n];
            power += p;
            for (k, e) in lux.iter_mut().enumerate() {
                *e += r[k * l + j] * x;
            }
        }
        // the last luminaire's least output that meets every desk
        let mut need = 0.0f64;
        let mut possible = true;
        for k in 0..kd {
            let gap = target_lx[k] - 1e-6 - lux[k];
            if gap > 0.0 {
                let rk = r[k * l + last];
                if rk <= 0.0 {
                    possible = false;
                    break;
                }
                need = need.max(gap / rk);
            }
        }
        if possible
            && need <= 1.0
            && let Some(&(_, p)) = table[last].iter().find(|(x, _)| *x >= need)
        {
            let total = power + p;
            best = Some(best.map_or(total, |b| b.min(total)));
        }
        // next combination of the first L − 1
        let mut j = 0;
        loop {
            if j == last {
                return (best, combinations);
            }
            idx[j] += 1;
            if idx[j] < table[j].len() {
                break;
            }
            idx[j] = 0;
            j += 1;
        }
    }
}

/// The DALI plan against the exhaustive DALI optimum on office-like rooms of these sizes.
pub fn exhaustive(sizes: &[(usize, usize)], instances: usize, seed: u64) -> Vec<ExhaustiveRow> {
    let mut rng = SplitMix64::new(seed);
    let mut rows = Vec::new();
    for &(l, kd) in sizes {
        let mut row = ExhaustiveRow {
            luminaires: l,
            desks: kd,
            feasible: 0,
            optimal: 0,
            mean_excess: 0.0,
            worst_excess: 0.0,
            combinations: 0,
        };
        for _ in 0..instances {
            let (r, power) = room(l, kd, &mut rng);
            let reach: Vec<f64> = (0..kd)
                .map(|k| r[k * l..(k + 1) * l].iter().sum())
                .collect();
            let target: Vec<f64> = reach
                .iter()
                .map(|&e| (e * (0.3 + 0.6 * rng.next_f64())).max(1.0))
                .collect();
            let daylight: Vec<f64> = reach.iter().map(|&e| 0.2 * e * rng.next_f64()).collect();
            let plant = Plant {
                desks: kd,
                luminaires: l,
                response_lx: &r,
                power: &power,
                curve: DimmingCurve::Logarithmic,
            };
            let Ok(Plan { report: rep, .. }) = plan(
                &plant,
                &Demand {
                    target_lx: &target,
                    daylight_lx: &daylight,
                    uniformity: None,
                },
            ) else {
                continue;
            };
            let (best, n) = exhaustive_optimum(&plant, &target, &daylight);
            row.combinations = n;
            let Some(best) = best else { continue };
            if rep.short > 0 {
                // feasible yet flagged short: report as an infinite excess
                row.worst_excess = f64::INFINITY;
                continue;
            }
            let e = rep.power_w / best - 1.0;
            row.feasible += 1;
            row.optimal += usize::from(e <= 1e-9);
            row.mean_excess += e;
            row.worst_excess = row.worst_excess.max(e);
        }
        row.mean_excess /= row.feasible.max(1) as f64;
        rows.push(row);
    }
    rows
}
