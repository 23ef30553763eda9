//! Line/scatter plots for benchmark figures (time against error, Pareto fronts), drawn by
//! plotters: axes with numbered ticks, optional log scales, one colour per series, a legend,
//! every text in DejaVu Sans (units in lower case: ms, lx, %, MB).

use plotters::prelude::*;

use super::{Anchor, Axis, Canvas, Label, draw_axes, with_plotters};

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
    /// x-axis label (with its unit).
    pub x_label: String,
    /// y-axis label (with its unit).
    pub y_label: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Series.
    pub series: Vec<Series>,
}

/// The series colours (matplotlib's tab10).
pub const PALETTE: [[u8; 3]; 8] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
];

/// A number for an axis label: no trailing zeros, no exponent for everyday magnitudes.
pub fn label(v: f64) -> String {
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

fn range(points: &[(f64, f64)], log: bool, get: fn(&(f64, f64)) -> f64) -> (f64, f64) {
    let (mut lo, mut hi) = points
        .iter()
        .map(get)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if log {
        lo = 10f64.powf(lo.log10().floor());
        hi = 10f64.powf(hi.log10().ceil());
        if hi <= lo {
            hi = lo * 10.0;
        }
    } else {
        lo = lo.min(0.0);
        hi = if hi > lo { hi * 1.05 } else { lo + 1.0 };
    }
    (lo, hi)
}

impl Plot {
    /// Draws the plot on a `width × height` canvas.
    pub fn draw(&self, width: u32, height: u32) -> Canvas {
        let (w, h) = (width.max(200), height.max(150));
        with_plotters(w, h, &mut |root, labels| {
            root.fill(&WHITE)?;
            labels.push(Label::new(self.title.clone(), (14.0, 10.0), 19.0).bold());
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
            if pts.is_empty() {
                return Ok(());
            }
            let (x0, x1) = range(&pts, self.log_x, |p| p.0);
            let (y0, y1) = range(&pts, self.log_y, |p| p.1);
            let (left, top, right, bottom) = (72.0, 62.0, 200.0, 58.0);
            let (pw, ph) = (f64::from(w) - left - right, f64::from(h) - top - bottom);
            let t = |v: f64, lo: f64, hi: f64, log: bool| {
                if log {
                    (v.log10() - lo.log10()) / (hi.log10() - lo.log10())
                } else {
                    (v - lo) / (hi - lo)
                }
            };
            let map = |x: f64, y: f64| -> (i32, i32) {
                (
                    (left + t(x, x0, x1, self.log_x) * pw).round() as i32,
                    (top + ph - t(y, y0, y1, self.log_y) * ph).round() as i32,
                )
            };
            let xa = Axis {
                lo: x0,
                hi: x1,
                log: self.log_x,
                desc: self.x_label.clone(),
            };
            let ya = Axis {
                lo: y0,
                hi: y1,
                log: self.log_y,
                desc: self.y_label.clone(),
            };
            draw_axes(root, &map, &xa, &ya, true, labels)?;
            for (k, s) in self.series.iter().enumerate() {
                let [r, g, b] = PALETTE[k % PALETTE.len()];
                let col = RGBColor(r, g, b);
                let visible: Vec<(i32, i32)> = s
                    .points
                    .iter()
                    .filter(|p| pts.contains(p))
                    .map(|&(x, y)| map(x, y))
                    .collect();
                root.draw(&PathElement::new(visible.clone(), col.stroke_width(2)))?;
                for p in &visible {
                    root.draw(&Circle::new(*p, 4, col.filled()))?;
                }
                let ly = top as i32 + 8 + 20 * k as i32;
                let lx = (left + pw) as i32 + 18;
                root.draw(&Rectangle::new(
                    [(lx, ly - 5), (lx + 18, ly + 5)],
                    col.filled(),
                ))?;
                labels.push(
                    Label::new(s.name.clone(), (f64::from(lx + 24), f64::from(ly)), 13.0)
                        .anchored(Anchor::Start, Anchor::Middle),
                );
            }
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_points_in_their_colours_with_text() {
        let p = Plot {
            title: "time against error".into(),
            x_label: "commissioning time (s)".into(),
            y_label: "error (%)".into(),
            log_x: true,
            log_y: false,
            series: vec![Series {
                name: "rays".into(),
                points: vec![(0.5, 1.0), (5.0, 2.0)],
            }],
        };
        let c = p.draw(600, 400);
        let (mut coloured, mut dark) = (0, 0);
        for y in 0..c.height() {
            for x in 0..c.width() {
                let px = c.get(x, y);
                if px == PALETTE[0] {
                    coloured += 1;
                }
                if px[0] < 60 && px[1] < 60 && px[2] < 60 {
                    dark += 1;
                }
            }
        }
        assert!(coloured > 50, "{coloured}");
        // axes, tick numbers, title and legend text
        assert!(dark > 1500, "{dark}");
    }

    #[test]
    fn labels_drop_trailing_zeros() {
        assert_eq!(label(2.0), "2");
        assert_eq!(label(0.25), "0.25");
        assert_eq!(label(1500.0), "1500");
    }
}
