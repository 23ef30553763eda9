//! `luxnode bench control`: the least-power optimiser's time and optimality at room sizes up to
//! 64 luminaires × 100 desks. Instances are office-like (each desk lit mostly by the luminaires
//! near it, seeded), half with targets every state can meet, half with some desks out of reach.
//! Optimality: the continuous optimum against the independent `microlp` solver, and the DALI
//! plan against that optimum (a lower bound of any plan).

use std::time::{Duration, Instant};

use microlp::{ComparisonOp, OptimizationDirection, Problem, SolveOutcome};

use crate::control::{Demand, LuminairePower, PlanOut, Plant, optimise, scratch_len};
use crate::dali::{ArcLevel, DimmingCurve};
use crate::rng::SplitMix64;

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
    /// Worst time.
    pub worst: Duration,
    /// Worst |ours − microlp| / microlp of the continuous optimum.
    pub lp_rel_diff: f64,
    /// Worst excess of the DALI plan's power over the continuous optimum.
    pub dali_excess: f64,
    /// Instances with some desk out of reach.
    pub infeasible: usize,
}

/// An office-like room: luminaires on a grid, desks on a grid, lux falling with distance.
fn room(l: usize, kd: usize, rng: &mut SplitMix64) -> (Vec<f64>, Vec<LuminairePower>) {
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
            let c0 = crate::host::thread_cpu_time();
            let t0 = Instant::now();
            let rep = optimise(
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
            );
            times.push(t0.elapsed());
            if let (Some(c0), Some(c1)) = (c0, crate::host::thread_cpu_time()) {
                cpu.push(c1 - c0);
            }
            let Ok(rep) = rep else { continue };
            infeasible += usize::from(rep.short > 0);
            // the same programme for microlp: shortfall priced as the optimiser prices it
            let total: f64 = power.iter().map(|p| p.slope_w()).sum();
            let price = 1e4 * (total + 1.0);
            if rep.short == 0
                && let Some(reference) = microlp_power(kd, l, &r, &power, &target, price)
            {
                // every desk reachable: no shortfall in either answer, both are power
                lp_rel = lp_rel.max((rep.lp_power_w - reference).abs() / reference);
                excess = excess.max(rep.power_w / rep.lp_power_w - 1.0);
            }
        }
        times.sort();
        cpu.sort();
        rows.push(ControlRow {
            luminaires: l,
            desks: kd,
            instances,
            median: times[times.len() / 2],
            median_cpu: cpu.get(cpu.len() / 2).copied().unwrap_or_default(),
            worst: times[times.len() - 1],
            lp_rel_diff: lp_rel,
            dali_excess: excess,
            infeasible,
        });
    }
    rows
}
