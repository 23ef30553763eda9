//! A desk sensor's window: the Gaussian-weighted plane fit of the irradiance around the sensor
//! and the choice of its width (Lepski's rule). Commissioning fits each desk's camera-calibrated
//! response with it; live light recomputes the width at boot for the run-time residual's weights.

/// Value at the origin of a weighted least-squares plane `a + b x + c y` through the points
/// (Gaussian weights of σ = `sigma_m`); the weighted mean when the points do not span a plane.
pub fn plane_at_origin(points: &[(f64, f64, f64)], sigma_m: f64) -> Option<f64> {
    if points.is_empty() {
        return None;
    }
    let mut m = [[0.0f64; 3]; 3];
    let mut r = [0.0f64; 3];
    let (mut sw, mut swv) = (0.0, 0.0);
    for &(x, y, val) in points {
        let w = (-(x * x + y * y) / (2.0 * sigma_m * sigma_m)).exp();
        let b = [1.0, x, y];
        for a in 0..3 {
            for c in 0..3 {
                m[a][c] += w * b[a] * b[c];
            }
            r[a] += w * b[a] * val;
        }
        sw += w;
        swv += w * val;
    }
    if sw <= 0.0 {
        return None;
    }
    let mean = swv / sw;
    // Cramer's rule for the intercept; a near-singular system (a line of points) falls back
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&m);
    let scale = m[0][0] * m[1][1] * m[2][2];
    if !(d.is_finite() && scale > 0.0 && d.abs() > 1e-9 * scale) {
        return Some(mean);
    }
    let mut m0 = m;
    for a in 0..3 {
        m0[a][0] = r[a];
    }
    let a = det(&m0) / d;
    Some(if a.is_finite() { a } else { mean })
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
        // points on a line: the weighted mean
        let line = [(0.0, 0.0, 1.0), (0.0, 0.0, 3.0)];
        assert_eq!(plane_at_origin(&line, 0.05), Some(2.0));
        assert_eq!(plane_at_origin(&[], 0.05), None);
    }
}
