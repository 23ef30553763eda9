//! Line/scatter plots for benchmark figures (time against error, Pareto fronts): axes with
//! ticks, optional log scale on x, one colour per series, a legend.

use super::{BLACK, Canvas, Colour, WHITE, text_width};

/// One series: a name and its points (x, y), drawn joined in the given order.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Points.
    pub points: Vec<(f64, f64)>,
}

/// A plot's axes and labels.
#[derive(Debug, Clone)]
pub struct Plot {
    /// Title.
    pub title: String,
    /// x-axis label.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Series.
    pub series: Vec<Series>,
}

const PALETTE: [Colour; 8] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
];

fn ticks(lo: f64, hi: f64, log: bool) -> Vec<f64> {
    if log {
        let mut t = Vec::new();
        let mut p = 10f64.powf(lo.log10().floor());
        while p <= hi * 1.0001 {
            for m in [1.0, 2.0, 5.0] {
                let v = m * p;
                if v >= lo * 0.9999 && v <= hi * 1.0001 {
                    t.push(v);
                }
            }
            p *= 10.0;
        }
        t
    } else {
        let span = (hi - lo).max(1e-12);
        let raw = span / 5.0;
        let p = 10f64.powf(raw.log10().floor());
        let step = [1.0, 2.0, 2.5, 5.0, 10.0]
            .iter()
            .map(|m| m * p)
            .find(|s| *s >= raw)
            .unwrap_or(10.0 * p);
        let mut v = (lo / step).ceil() * step;
        let mut t = Vec::new();
        while v <= hi + 1e-9 * span {
            t.push(v);
            v += step;
        }
        t
    }
}

fn label(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 100.0 {
        format!("{v:.0}")
    } else if v.abs() >= 1.0 {
        let s = format!("{v:.1}");
        s.trim_end_matches(".0").to_owned()
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    }
}

impl Plot {
    /// Draws the plot on a `width × height` canvas.
    pub fn draw(&self, width: u32, height: u32) -> Canvas {
        let mut c = Canvas::new(width, height, WHITE);
        let (left, right, top, bottom) = (70i64, 190i64, 60i64, 50i64);
        let pw = i64::from(width) - left - right;
        let ph = i64::from(height) - top - bottom;
        let pts: Vec<(f64, f64)> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|(x, y)| {
                x.is_finite()
                    && y.is_finite()
                    && (!self.log_x || *x > 0.0)
                    && (!self.log_y || *y > 0.0)
            })
            .collect();
        c.text(&self.title, left, 12, 2, BLACK);
        if pts.is_empty() || pw < 50 || ph < 50 {
            return c;
        }
        let fold = |f: fn(f64, f64) -> f64, init: f64, get: fn(&(f64, f64)) -> f64| {
            pts.iter().map(get).fold(init, f)
        };
        let (mut x0, mut x1) = (
            fold(f64::min, f64::INFINITY, |p| p.0),
            fold(f64::max, f64::NEG_INFINITY, |p| p.0),
        );
        let (mut y0, mut y1) = (
            fold(f64::min, f64::INFINITY, |p| p.1),
            fold(f64::max, f64::NEG_INFINITY, |p| p.1),
        );
        if self.log_x {
            x0 = 10f64.powf(x0.log10().floor());
            x1 = 10f64.powf(x1.log10().ceil());
        } else if x1 <= x0 {
            x1 = x0 + 1.0;
        }
        if self.log_y {
            y0 = 10f64.powf(y0.log10().floor());
            y1 = 10f64.powf(y1.log10().ceil());
        } else {
            y0 = y0.min(0.0);
            y1 = if y1 > y0 { y1 * 1.05 } else { y0 + 1.0 };
        }
        let map = |v: f64, lo: f64, hi: f64, log: bool| -> f64 {
            if log {
                (v.log10() - lo.log10()) / (hi.log10() - lo.log10())
            } else {
                (v - lo) / (hi - lo)
            }
        };
        let to_px = |x: f64, y: f64| -> (i64, i64) {
            (
                left + (map(x, x0, x1, self.log_x) * pw as f64).round() as i64,
                top + ph - (map(y, y0, y1, self.log_y) * ph as f64).round() as i64,
            )
        };
        for t in ticks(x0, x1, self.log_x) {
            let (px, _) = to_px(t, y0);
            c.fill(px, top, 1, ph, [225, 225, 225]);
            c.fill(px, top + ph, 1, 5, BLACK);
            let l = label(t);
            c.text(
                &l,
                px - i64::from(text_width(&l, 1)) / 2,
                top + ph + 9,
                1,
                BLACK,
            );
        }
        for t in ticks(y0, y1, self.log_y) {
            let (_, py) = to_px(x0, t);
            c.fill(left, py, pw, 1, [225, 225, 225]);
            c.fill(left - 5, py, 5, 1, BLACK);
            let l = label(t);
            c.text(
                &l,
                left - 8 - i64::from(text_width(&l, 1)),
                py - 3,
                1,
                BLACK,
            );
        }
        c.frame(left, top, pw + 1, ph + 1, 1, BLACK);
        c.text(
            &self.x_label,
            left + pw / 2 - i64::from(text_width(&self.x_label, 1)) / 2,
            top + ph + 28,
            1,
            BLACK,
        );
        c.text(&self.y_label, 8, top - 16, 1, BLACK);
        for (k, s) in self.series.iter().enumerate() {
            let col = PALETTE[k % PALETTE.len()];
            let visible: Vec<(i64, i64)> = s
                .points
                .iter()
                .filter(|(x, y)| {
                    x.is_finite()
                        && y.is_finite()
                        && (!self.log_x || *x > 0.0)
                        && (!self.log_y || *y > 0.0)
                })
                .map(|&(x, y)| to_px(x, y))
                .collect();
            for w in visible.windows(2) {
                line(&mut c, w[0], w[1], col);
            }
            for &(px, py) in &visible {
                c.fill(px - 3, py - 3, 7, 7, col);
            }
            let ly = top + 10 + 16 * k as i64;
            c.fill(left + pw + 15, ly, 14, 7, col);
            c.text(&s.name, left + pw + 34, ly, 1, BLACK);
        }
        c
    }
}

/// A 2-pixel line (Bresenham).
fn line(c: &mut Canvas, a: (i64, i64), b: (i64, i64), col: Colour) {
    let (mut x, mut y) = a;
    let dx = (b.0 - a.0).abs();
    let dy = -(b.1 - a.1).abs();
    let sx = if a.0 < b.0 { 1 } else { -1 };
    let sy = if a.1 < b.1 { 1 } else { -1 };
    let mut err = dx + dy;
    loop {
        c.fill(x, y, 2, 2, col);
        if x == b.0 && y == b.1 {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_cover_the_range() {
        assert_eq!(
            ticks(0.1, 10.0, true),
            vec![0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0]
        );
        let t = ticks(0.0, 2.3, false);
        assert_eq!(t.first(), Some(&0.0));
        assert!(t.last().copied().unwrap() <= 2.3);
    }

    #[test]
    fn draws_points_in_their_colours() {
        let p = Plot {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            log_x: true,
            log_y: false,
            series: vec![Series {
                name: "a".into(),
                points: vec![(0.5, 1.0), (5.0, 2.0)],
            }],
        };
        let c = p.draw(400, 300);
        let mut coloured = 0;
        for y in 0..c.height() {
            for x in 0..c.width() {
                if c.get(x, y) == PALETTE[0] {
                    coloured += 1;
                }
            }
        }
        assert!(coloured > 50);
    }
}
