//! A desk sensor's window: the Gaussian-weighted plane fit of the irradiance around the sensor
//! and the choice of its width (Lepski's rule). Commissioning fits each desk's camera-calibrated
//! response with it; live light recomputes the width at boot for the run-time residual's weights.

/// Value at the origin of a weighted least-squares plane `a + b x + c y` through the points
/// (Gaussian weights of σ = `sigma_m`). The fit is taken in the points' principal axes about
/// their weighted centroid; along an axis where reaching the origin would extrapolate beyond
/// [`MAX_LEVERAGE`] (a window of pixels on a line, seen at a grazing angle) the plane keeps no
/// slope. Points that span no plane give their weighted mean.
pub fn plane_at_origin(points: &[(f64, f64, f64)], sigma_m: f64) -> Option<f64> {
    let w: Vec<f64> = points
        .iter()
        .map(|&(x, y, _)| (-(x * x + y * y) / (2.0 * sigma_m * sigma_m)).exp())
        .collect();
    let sw: f64 = w.iter().sum();
    if sw.is_nan() || sw <= 0.0 {
        return None;
    }
    // weighted mean of f over the points
    let avg = |f: &dyn Fn(f64, f64, f64) -> f64| {
        let s: f64 = points
            .iter()
            .zip(&w)
            .map(|(&(x, y, v), wi)| wi * f(x, y, v))
            .sum();
        s / sw
    };
    let (cx, cy, mean) = (avg(&|x, _, _| x), avg(&|_, y, _| y), avg(&|_, _, v| v));
    // the centred spread and the value's covariance with the position
    let sxx = avg(&|x, _, _| (x - cx) * (x - cx));
    let sxy = avg(&|x, y, _| (x - cx) * (y - cy));
    let syy = avg(&|_, y, _| (y - cy) * (y - cy));
    let q = (
        avg(&|x, _, v| (x - cx) * (v - mean)),
        avg(&|_, y, v| (y - cy) * (v - mean)),
    );
    let mut value = mean;
    for (lambda, (ex, ey)) in principal_axes(sxx, sxy, syy) {
        let reach = -(ex * cx + ey * cy);
        if lambda > 0.0 && reach * reach <= MAX_LEVERAGE * lambda {
            value += (ex * q.0 + ey * q.1) / lambda * reach;
        }
    }
    Some(if value.is_finite() { value } else { mean })
}

/// A plane's slope along one of its points' principal axes is used to reach the origin only
/// when the origin lies within this many variances of the points' spread along it (squared
/// distance over variance: two standard deviations). A half-disc window beside a shade reaches
/// 1.75 (a half-Gaussian's); four pixels in one image column, seen 67° off a fisheye's axis
/// (seed 29's room_03 desk 7), far more.
pub const MAX_LEVERAGE: f64 = 4.0;

/// Eigenvalues (largest first) and unit eigenvectors of the symmetric 2 × 2 `[[sxx, sxy], [sxy,
/// syy]]`; an isotropic spread gives the coordinate axes.
fn principal_axes(sxx: f64, sxy: f64, syy: f64) -> [(f64, (f64, f64)); 2] {
    let half_tr = 0.5 * (sxx + syy);
    let root = (0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy).sqrt();
    let (l1, l2) = (half_tr + root, half_tr - root);
    // eigenvector of l1: (sxy, l1 − sxx) or (l1 − syy, sxy), whichever is longer
    let (a, b) = (sxy, l1 - sxx);
    let (c, d) = (l1 - syy, sxy);
    let (ex, ey) = if a.hypot(b) >= c.hypot(d) {
        (a, b)
    } else {
        (c, d)
    };
    let n = ex.hypot(ey);
    let (ex, ey) = if n > 0.0 {
        (ex / n, ey / n)
    } else {
        (1.0, 0.0)
    };
    [(l1, (ex, ey)), (l2, (-ey, ex))]
}

/// A window's radius as its pixels give it: the farthest pixel's in-plane distance from the
/// sensor, m (0 for no pixels). Commissioning and live light read a widened window's width
/// from it.
pub fn farthest_m(offsets_m: impl IntoIterator<Item = (f64, f64)>) -> f64 {
    offsets_m
        .into_iter()
        .map(|(dx, dy)| dx.hypot(dy))
        .fold(0.0, f64::max)
}

/// Gaussian σ of a window's plane fit, as fractions of the window radius, widest first.
pub const SIGMA_LADDER: [f64; 4] = [0.5, 0.35, 0.25, 0.175];
/// Two widths whose fits at the sensor differ by more than this (relative) disagree: the
/// irradiance is not a plane over the wider one. Well above the noise of a few pixels' mean
/// (a camera's shot noise of about 1 % per pixel).
pub const SIGMA_AGREE: f64 = 0.02;
/// Narrowest σ, in pixel pitches at the sensor (narrower is one pixel's value).
pub const MIN_SIGMA_PITCH: f64 = 0.7;

/// The Gaussian σ of a sensor's window fit, m: the widest of [`SIGMA_LADDER`] (times the window
/// radius) whose value at the sensor agrees with every narrower one's (Lepski's rule; no
/// narrower than [`MIN_SIGMA_PITCH`] pixels). A sensor by a monitor's shade is fitted over the
/// few centimetres where its irradiance is still a plane, one in the open over the whole
/// window. `points`: (x, y, irradiance) of the window's pixels with every luminaire on.
pub fn window_sigma_m(points: &[(f64, f64, f64)], window_px: usize, radius_m: f64) -> f64 {
    let widest = SIGMA_LADDER[0] * radius_m;
    if points.len() < 4 || window_px == 0 {
        return widest;
    }
    // pixel pitch at the sensor: the window's disc over its pixel count
    let pitch_m = radius_m * (std::f64::consts::PI / window_px as f64).sqrt();
    let fits: Vec<(f64, f64)> = SIGMA_LADDER
        .iter()
        .map(|f| f * radius_m)
        .filter(|&s| s == widest || s >= MIN_SIGMA_PITCH * pitch_m)
        .filter_map(|s| plane_at_origin(points, s).map(|v| (s, v)))
        .collect();
    for (i, &(s, v)) in fits.iter().enumerate() {
        let agrees = fits[i + 1..]
            .iter()
            .all(|&(_, vn)| (v - vn).abs() <= SIGMA_AGREE * vn.abs());
        if agrees {
            return s;
        }
    }
    fits.last().map_or(widest, |f| f.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_window_narrows_by_a_shade_and_stays_wide_in_the_open() {
        // pixels 1.4 cm apart within 5 cm of the sensor (office_a's camera at a desk)
        let radius = 0.05;
        let grid: Vec<(f64, f64)> = (-4..=4)
            .flat_map(|i| (-4..=4).map(move |j| (0.014 * f64::from(i), 0.014 * f64::from(j))))
            .filter(|(x, y)| x.hypot(*y) <= radius)
            .collect();
        let n = grid.len();
        // in the open: a plane, the widest fit, exact
        let open: Vec<(f64, f64, f64)> = grid
            .iter()
            .map(|&(x, y)| (x, y, 1000.0 + 800.0 * x - 300.0 * y))
            .collect();
        assert_eq!(window_sigma_m(&open, n, radius), SIGMA_LADDER[0] * radius);
        // 2 cm in front of a monitor: its shade deepens toward it (+x) from 1 cm on
        let shade = |x: f64| 1000.0 * (1.0 - 0.5 * (((x - 0.01) / 0.02).clamp(0.0, 1.0)));
        let shaded: Vec<(f64, f64, f64)> = grid.iter().map(|&(x, y)| (x, y, shade(x))).collect();
        let s = window_sigma_m(&shaded, n, radius);
        assert!(s < SIGMA_LADDER[0] * radius, "{s}");
        let wide = plane_at_origin(&shaded, SIGMA_LADDER[0] * radius).unwrap();
        let chosen = plane_at_origin(&shaded, s).unwrap();
        assert!(
            (chosen - 1000.0).abs() < 0.5 * (wide - 1000.0).abs(),
            "{chosen} vs {wide}"
        );
        // never narrower than the pixels allow, and no points: the widest
        assert!(s >= MIN_SIGMA_PITCH * radius * (std::f64::consts::PI / n as f64).sqrt());
        assert_eq!(window_sigma_m(&[], 0, radius), SIGMA_LADDER[0] * radius);
    }

    #[test]
    fn plane_fit_is_exact_for_planes_and_asymmetric_windows() {
        // a plane 100 + 30 x − 50 y sampled only on one side of the origin
        let pts: Vec<(f64, f64, f64)> = (0..20)
            .flat_map(|i| (0..5).map(move |j| (0.01 * f64::from(i), 0.01 * f64::from(j) - 0.02)))
            .map(|(x, y)| (x, y, 100.0 + 30.0 * x - 50.0 * y))
            .collect();
        let v = plane_at_origin(&pts, 0.05).unwrap();
        assert!((v - 100.0).abs() < 1e-9, "{v}");
        // four pixels in one image column seen at a grazing angle (seed 29's room_03 desk 7):
        // 3 cm from the sensor, 1 cm apart along y, 0.1 mm of scatter across it that the
        // pixels' noise (±10 lx) turns into a slope of 10⁵ lx/m. The full plane reaches the
        // sensor along that slope (−2000 lx off); the fit keeps only the slope along the line.
        let column: Vec<(f64, f64, f64)> = [(-1.5, 1.0), (-0.5, -1.0), (0.5, 1.0), (1.5, -1.0)]
            .iter()
            .map(|&(j, s)| (0.03 + 1e-4 * s, 0.01 * j, 1000.0 + 40.0 * j + 10.0 * s))
            .collect();
        let v = plane_at_origin(&column, 0.05).unwrap();
        assert!((v - 1000.0).abs() < 1.0, "{v}");
        // points on a line: the weighted mean
        let line = [(0.0, 0.0, 1.0), (0.0, 0.0, 3.0)];
        assert_eq!(plane_at_origin(&line, 0.05), Some(2.0));
        assert_eq!(plane_at_origin(&[], 0.05), None);
    }
}
