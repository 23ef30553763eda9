//! Non-negative least squares on the normal equations: minimise `‖A x − y‖²_W` subject to
//! `x ≥ 0`, given `G = Aᵀ W A` and `h = Aᵀ W y` (Lawson & Hanson's active-set method in the
//! normal-equation form of Bro & de Jong, 1997). The problems here are small (luminaires and
//! emitter groups: tens of unknowns) and are formed from thousands of rows, so the Gram form is
//! the cheap one.

/// The solution of a non-negative least-squares problem in Gram form, `x ≥ 0`: zeros when `G` is
/// empty; a bounded number of active-set changes (`4 n + 10`), so it always ends.
pub fn nnls_gram(g: &[f64], h: &[f64], n: usize) -> Vec<f64> {
    let mut x = vec![0.0; n];
    if n == 0 || g.len() != n * n || h.len() != n {
        return x;
    }
    let scale = (0..n).map(|i| g[i * n + i]).fold(0.0f64, f64::max);
    if !(scale.is_finite() && scale > 0.0) {
        return x;
    }
    let tol = 1e-12 * scale * (1.0 + h.iter().map(|v| v.abs()).fold(0.0, f64::max));
    let mut passive = vec![false; n];
    let gradient = |x: &[f64]| -> Vec<f64> {
        (0..n)
            .map(|i| h[i] - (0..n).map(|j| g[i * n + j] * x[j]).sum::<f64>())
            .collect()
    };
    let mut budget = 4 * n + 10;
    loop {
        let w = gradient(&x);
        let next = (0..n)
            .filter(|&j| !passive[j] && g[j * n + j] > 0.0)
            .max_by(|&a, &b| w[a].total_cmp(&w[b]));
        let Some(j) = next.filter(|&j| w[j] > tol) else {
            break;
        };
        passive[j] = true;
        loop {
            if budget == 0 {
                return clean(x);
            }
            budget -= 1;
            let s = solve_passive(g, h, n, &passive);
            if (0..n).all(|i| !passive[i] || s[i] > 0.0) {
                x = s;
                break;
            }
            let mut alpha = 1.0f64;
            for i in 0..n {
                if passive[i] && s[i] <= 0.0 {
                    let d = x[i] - s[i];
                    if d > 0.0 {
                        alpha = alpha.min(x[i] / d);
                    }
                }
            }
            for i in 0..n {
                x[i] += alpha * (s[i] - x[i]);
                if passive[i] && x[i] <= 1e-15 * scale.max(1.0) {
                    passive[i] = false;
                    x[i] = 0.0;
                }
            }
            if !passive.iter().any(|&p| p) {
                break;
            }
        }
    }
    clean(x)
}

fn clean(mut x: Vec<f64>) -> Vec<f64> {
    for v in &mut x {
        if !(v.is_finite() && *v > 0.0) {
            *v = 0.0;
        }
    }
    x
}

/// Unconstrained least squares over the passive set (Cholesky with a tiny ridge), zeros
/// elsewhere.
fn solve_passive(g: &[f64], h: &[f64], n: usize, passive: &[bool]) -> Vec<f64> {
    let idx: Vec<usize> = (0..n).filter(|&i| passive[i]).collect();
    let m = idx.len();
    let mut a = vec![0.0; m * m];
    let mut b = vec![0.0; m];
    let mut trace = 0.0;
    for (r, &i) in idx.iter().enumerate() {
        for (c, &j) in idx.iter().enumerate() {
            a[r * m + c] = g[i * n + j];
        }
        b[r] = h[i];
        trace += g[i * n + i];
    }
    let ridge = 1e-12 * trace / m.max(1) as f64;
    for r in 0..m {
        a[r * m + r] += ridge;
    }
    // Cholesky, in place (lower triangle)
    for c in 0..m {
        let mut d = a[c * m + c];
        for k in 0..c {
            d -= a[c * m + k] * a[c * m + k];
        }
        let d = if d > 0.0 { d.sqrt() } else { 1e-300 };
        a[c * m + c] = d;
        for r in c + 1..m {
            let mut v = a[r * m + c];
            for k in 0..c {
                v -= a[r * m + k] * a[c * m + k];
            }
            a[r * m + c] = v / d;
        }
    }
    let mut y = b;
    for r in 0..m {
        for k in 0..r {
            y[r] -= a[r * m + k] * y[k];
        }
        y[r] /= a[r * m + r];
    }
    for r in (0..m).rev() {
        for k in r + 1..m {
            y[r] -= a[k * m + r] * y[k];
        }
        y[r] /= a[r * m + r];
    }
    let mut out = vec![0.0; n];
    for (r, &i) in idx.iter().enumerate() {
        out[i] = y[r];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gram(a: &[Vec<f64>], y: &[f64]) -> (Vec<f64>, Vec<f64>, usize) {
        let n = a[0].len();
        let mut g = vec![0.0; n * n];
        let mut h = vec![0.0; n];
        for (row, &yi) in a.iter().zip(y) {
            for i in 0..n {
                h[i] += row[i] * yi;
                for j in 0..n {
                    g[i * n + j] += row[i] * row[j];
                }
            }
        }
        (g, h, n)
    }

    #[test]
    fn recovers_a_non_negative_truth_and_clips_a_negative_one() {
        // y = 2 a0 + 0.5 a2 exactly: recovered
        let a: Vec<Vec<f64>> = (0..30)
            .map(|k| {
                let t = f64::from(k) / 29.0;
                vec![1.0, t, t * t]
            })
            .collect();
        let y: Vec<f64> = a.iter().map(|r| 2.0 * r[0] + 0.5 * r[2]).collect();
        let (g, h, n) = gram(&a, &y);
        let x = nnls_gram(&g, &h, n);
        assert!((x[0] - 2.0).abs() < 1e-9 && x[1].abs() < 1e-9 && (x[2] - 0.5).abs() < 1e-9);
        // y = a0 − a1: the constrained optimum has x1 = 0, and is the best fit with a0, a2 ≥ 0
        let y: Vec<f64> = a.iter().map(|r| r[0] - r[1]).collect();
        let (g, h, n) = gram(&a, &y);
        let x = nnls_gram(&g, &h, n);
        assert_eq!(x[1], 0.0);
        assert!(x.iter().all(|v| *v >= 0.0));
        // KKT: the gradient is ≤ 0 where x = 0 and ≈ 0 where x > 0
        for i in 0..n {
            let w: f64 = h[i] - (0..n).map(|j| g[i * n + j] * x[j]).sum::<f64>();
            if x[i] > 0.0 {
                assert!(w.abs() < 1e-8, "{i}: {w}");
            } else {
                assert!(w <= 1e-8, "{i}: {w}");
            }
        }
    }

    #[test]
    fn degenerate_input_gives_zeros_never_nan() {
        assert_eq!(nnls_gram(&[], &[], 0), Vec::<f64>::new());
        assert_eq!(nnls_gram(&[0.0; 4], &[1.0, 1.0], 2), vec![0.0, 0.0]);
        assert_eq!(nnls_gram(&[f64::NAN; 4], &[1.0, 1.0], 2), vec![0.0, 0.0]);
        // two identical columns: a solution, finite
        let x = nnls_gram(&[1.0, 1.0, 1.0, 1.0], &[2.0, 2.0], 2);
        assert!(((x[0] + x[1]) - 2.0).abs() < 1e-6, "{x:?}");
    }
}
