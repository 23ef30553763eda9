//! The unknown emitters of live light ([`crate::live`], step 3 of the method): the robust
//! non-negative fit of the seen surfaces' unexplained light by groups of unseen patches
//! (windows nobody declared, any unmodelled light), and how well that fit tells each desk's
//! daylight ([`placement_lx`]: the emitters' placement is known only as well as the seen
//! surfaces tell them apart).

use super::estimator::median;
use super::nnls::nnls_gram;

/// Ridge weight of the unknown-emitter fit, relative to the mean diagonal of its normal matrix.
pub const RIDGE: f64 = 0.01;

/// The robust non-negative fit of `y ≈ V x` (V: rows × k, row-major) with weights `w`, twice:
/// the second time without the outliers of the first (their weight set to 0). A small ridge:
/// a column the seen surfaces hardly see cannot be estimated from them (unregularised, one
/// emitter group reached 2e7 lm/m² and put 27 klx on a desk).
pub fn robust_fit(v: &[f64], k: usize, y: &[f64], w_use: &mut [f64]) -> RobustFit {
    let n_seen = y.len();
    let mut x = vec![0.0; k];
    let mut resid = vec![0.0; n_seen];
    let mut gram = vec![0.0; k * k];
    for pass in 0..2 {
        if k > 0 {
            let mut g = vec![0.0; k * k];
            let mut h = vec![0.0; k];
            for r in 0..n_seen {
                let wr = w_use[r];
                if wr <= 0.0 {
                    continue;
                }
                let v = &v[r * k..(r + 1) * k];
                for a in 0..k {
                    h[a] += wr * v[a] * y[r];
                    for bb in 0..k {
                        g[a * k + bb] += wr * v[a] * v[bb];
                    }
                }
            }
            // ridge: an emitter the seen surfaces hardly see cannot be estimated from them
            // (unregularised, one such group reached 2e7 lm/m² and put 27 klx on a desk)
            let mean_diag = (0..k).map(|a| g[a * k + a]).sum::<f64>() / k as f64;
            let ridge = RIDGE * mean_diag;
            gram.clone_from(&g);
            for a in 0..k {
                g[a * k + a] += ridge;
            }
            x = nnls_gram(&g, &h, k);
        }
        for r in 0..n_seen {
            let fit: f64 = (0..k).map(|q| v[r * k + q] * x[q]).sum();
            resid[r] = y[r] - fit;
        }
        if pass == 0 {
            let mut a: Vec<f64> = (0..n_seen)
                .filter(|&r| w_use[r] > 0.0)
                .map(|r| resid[r].abs())
                .collect();
            let mad = median(&mut a).unwrap_or(0.0) * 1.4826;
            for r in 0..n_seen {
                if resid[r].abs() > 3.0 * mad + 5.0 {
                    w_use[r] = 0.0;
                }
            }
        }
    }
    RobustFit { x, resid, gram }
}

/// What [`robust_fit`] found.
pub struct RobustFit {
    /// The non-negative scales, one per column.
    pub x: Vec<f64>,
    /// The residual `y − V x` of every row (the outliers' too).
    pub resid: Vec<f64>,
    /// The last pass's normal matrix `Vᵀ W V` over the rows kept, without the ridge (k × k).
    pub gram: Vec<f64>,
}

/// Per sensor, the standard uncertainty of the emitters' light at it from where the emitters
/// may be: the weighted least-squares covariance of their exitance without the fit's ridge,
/// `σ² (Vᵀ W V)⁻¹` with `σ² = χ²₀ / (n − k)` the residual variance per unit weight over the
/// `n` rows the fit used, carried to the sensor through its row: `σ_s² = g_sᵀ Cov g_s`. The
/// ridge keeps the estimate of an emitter the seen surfaces hardly see near zero, which is
/// where its light is least known: near a desk out of view, a window there gives a wide
/// spread; a room whose seen light the emitters explain with little residual, a narrow one.
pub fn placement_lx(fit: &EmitterFit<'_>, sensors: usize) -> Vec<f64> {
    let (g, k, w) = (fit.g, fit.k, fit.w);
    let zeros = vec![0.0; sensors];
    let used: Vec<usize> = (0..w.len()).filter(|&r| w[r] > 0.0).collect();
    if k == 0 || used.len() <= k || fit.gram.len() != k * k {
        return zeros;
    }
    let mut gram = nalgebra::DMatrix::<f64>::from_row_slice(k, k, fit.gram);
    let chi2: f64 = used.iter().map(|&r| w[r] * fit.resid[r].powi(2)).sum();
    let sigma2 = chi2 / (used.len() - k) as f64;
    // numerical floor only (a column of zeros)
    let floor = 1e-12 * gram.diagonal().max().max(f64::MIN_POSITIVE);
    for a in 0..k {
        gram[(a, a)] += floor;
    }
    let Some(chol) = gram.cholesky() else {
        return zeros;
    };
    (0..sensors)
        .map(|s| {
            let gs = nalgebra::DVector::from_column_slice(&g[s * k..(s + 1) * k]);
            let var = sigma2 * gs.dot(&chol.solve(&gs));
            let u = var.max(0.0).sqrt();
            if u.is_finite() { u } else { 0.0 }
        })
        .collect()
}

/// The emitters' fit as [`placement_lx`] reads it: its normal matrix (from [`robust_fit`]),
/// the emitters' light at the sensors (`g`), and the rows' residuals and weights.
pub struct EmitterFit<'a> {
    /// The fit's normal matrix without the ridge, k × k ([`RobustFit::gram`]).
    pub gram: &'a [f64],
    /// Each emitter's light at each sensor at unit exitance, sensors × k, lx.
    pub g: &'a [f64],
    /// Emitters.
    pub k: usize,
    /// The residual per seen row after the fit, lx.
    pub resid: &'a [f64],
    /// The rows' weights after the fit (0: not used).
    pub w: &'a [f64],
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two emitters seen on `n` rows with patterns `a(r)` and `b(r)`; the desk sees only the
    /// second (`g = [0, 1]`); the seen light is `y = 2 a + noise(r)`.
    fn spread(n: usize, b_of: impl Fn(f64) -> f64, noise: impl Fn(usize) -> f64) -> (f64, f64) {
        let k = 2;
        let mut v = Vec::new();
        for r in 0..n {
            let t = r as f64 / n as f64;
            v.push(1.0 + t);
            v.push(b_of(t));
        }
        let y: Vec<f64> = (0..n).map(|r| 2.0 * v[r * k] + noise(r)).collect();
        let mut w = vec![1.0; n];
        let f = robust_fit(&v, k, &y, &mut w);
        let g = [0.0, 1.0];
        let fit = EmitterFit {
            gram: &f.gram,
            g: &g,
            k,
            resid: &f.resid,
            w: &w,
        };
        (f.x[1], placement_lx(&fit, 1)[0])
    }

    #[test]
    fn an_exact_fit_of_distinct_emitters_places_them_exactly() {
        let (x1, u) = spread(64, |t| (3.0 * t).sin().abs() + 0.1, |_| 0.0);
        // the fit's ridge (1 % of the normal matrix's mean diagonal) shrinks the present
        // emitter and lends 0.14 to the absent one; the residual that bias leaves gives the
        // spread: both small against the present emitter's exitance of 2
        assert!(x1.abs() < 0.2, "{x1}");
        assert!(u < 0.2, "{u}");
    }

    #[test]
    fn emitters_the_seen_rows_hardly_tell_apart_leave_the_desk_uncertain() {
        // the same noise, one time with a second emitter of its own pattern, one time with one
        // almost collinear with the first: the desk that sees only the second gets a spread
        // many times wider in the second case
        let noise = |r: usize| 0.05 * (((r * 7919) % 13) as f64 - 6.0) / 6.0;
        let (_, distinct) = spread(64, |t| (3.0 * t).sin().abs() + 0.1, noise);
        let (_, collinear) = spread(64, |t| 1.0 + t + 0.01 * (9.0 * t).sin(), noise);
        assert!(distinct > 0.0 && distinct.is_finite(), "{distinct}");
        assert!(collinear > 20.0 * distinct, "{collinear} vs {distinct}");
    }

    #[test]
    fn too_few_rows_or_no_emitter_give_no_spread_never_nan() {
        let fit = EmitterFit {
            gram: &[1.0, 2.0, 2.0, 4.0],
            g: &[1.0, 1.0],
            k: 2,
            resid: &[0.5],
            w: &[1.0],
        };
        assert_eq!(placement_lx(&fit, 1), vec![0.0]);
        let none = EmitterFit {
            gram: &[],
            g: &[],
            k: 0,
            resid: &[1.0, 2.0],
            w: &[1.0, 1.0],
        };
        assert_eq!(placement_lx(&none, 2), vec![0.0, 0.0]);
    }
}
