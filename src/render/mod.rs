//! Pictures and reports for people: the plan view (`simulate --map`, the report), the camera
//! view of dense lux, reflectance and mesh, benchmark plots, and the commissioning report
//! (`report.html`, `results.json`). Plots and charts are drawn by plotters; everything shares
//! one small RGB canvas, a perceptual colour map and the embedded DejaVu Sans ([`text`]).

pub mod camera_view;
pub mod daylight_factor;
pub mod daylight_year;
pub mod energy;
pub mod glare;
pub mod map;
pub mod near_gather;
pub mod placement;
pub mod plot;
pub mod report;
pub mod requirements;
pub mod room_surfaces;
pub mod task_points;
pub mod text;
pub mod ugr;
pub mod ugr_table;

use std::path::Path;

use image::{Rgb, RgbImage};

/// RGB colour.
pub type Colour = [u8; 3];

/// White.
pub const WHITE: Colour = [255, 255, 255];
/// Black.
pub const BLACK: Colour = [0, 0, 0];

/// A drawing surface.
pub struct Canvas {
    img: RgbImage,
}

impl Canvas {
    /// A canvas filled with `background`.
    pub fn new(width: u32, height: u32, background: Colour) -> Self {
        Self {
            img: RgbImage::from_pixel(width.max(1), height.max(1), Rgb(background)),
        }
    }

    /// Width, pixels.
    pub fn width(&self) -> u32 {
        self.img.width()
    }

    /// Height, pixels.
    pub fn height(&self) -> u32 {
        self.img.height()
    }

    /// Sets a pixel; outside the canvas is ignored.
    pub fn put(&mut self, x: i64, y: i64, c: Colour) {
        if x >= 0 && y >= 0 && (x as u32) < self.img.width() && (y as u32) < self.img.height() {
            self.img.put_pixel(x as u32, y as u32, Rgb(c));
        }
    }

    /// The colour at a pixel.
    pub fn get(&self, x: u32, y: u32) -> Colour {
        self.img.get_pixel(x, y).0
    }

    /// A filled rectangle.
    pub fn fill(&mut self, x0: i64, y0: i64, w: i64, h: i64, c: Colour) {
        for y in y0..y0 + h {
            for x in x0..x0 + w {
                self.put(x, y, c);
            }
        }
    }

    /// A rectangle outline, `t` pixels thick.
    pub fn frame(&mut self, x0: i64, y0: i64, w: i64, h: i64, t: i64, c: Colour) {
        self.fill(x0, y0, w, t, c);
        self.fill(x0, y0 + h - t, w, t, c);
        self.fill(x0, y0, t, h, c);
        self.fill(x0 + w - t, y0, t, h, c);
    }

    /// Blends `c` over a pixel with opacity `alpha` in [0, 1].
    pub fn blend(&mut self, x: i64, y: i64, c: Colour, alpha: f32) {
        if x >= 0 && y >= 0 && (x as u32) < self.img.width() && (y as u32) < self.img.height() {
            let p = self.img.get_pixel_mut(x as u32, y as u32);
            let a = alpha.clamp(0.0, 1.0);
            for (v, c) in p.0.iter_mut().zip(c) {
                *v = (f32::from(*v) * (1.0 - a) + f32::from(c) * a).round() as u8;
            }
        }
    }

    /// Text (DejaVu Sans, `size` pixels per em) with the top of its line at y, left edge at x.
    pub fn text(&mut self, text: &str, x: i64, y: i64, size: f32, c: Colour) {
        text::draw(
            text,
            x as f32,
            y as f32,
            size,
            text::Weight::Regular,
            &mut |px, py, a| self.blend(px, py, c, a),
        );
    }

    /// Bold text, as [`Canvas::text`].
    pub fn bold(&mut self, text: &str, x: i64, y: i64, size: f32, c: Colour) {
        text::draw(
            text,
            x as f32,
            y as f32,
            size,
            text::Weight::Bold,
            &mut |px, py, a| self.blend(px, py, c, a),
        );
    }

    /// Text centred on (cx, cy) on a filled box with a 3-pixel margin.
    pub fn label(&mut self, text: &str, cx: i64, cy: i64, size: f32, fg: Colour, bg: Colour) {
        let w = i64::from(text_width(text, size));
        let h = (size * 1.17).round() as i64;
        self.fill(cx - w / 2 - 3, cy - h / 2 - 2, w + 6, h + 4, bg);
        self.text(text, cx - w / 2, cy - h / 2, size, fg);
    }

    /// A line, `t` pixels thick (anti-aliasing left to plotters).
    pub fn line(&mut self, a: (f64, f64), b: (f64, f64), t: i64, col: Colour) {
        let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as i64).max(1);
        for k in 0..=n {
            let f = k as f64 / n as f64;
            let (x, y) = (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1));
            self.fill(
                x.round() as i64 - t / 2,
                y.round() as i64 - t / 2,
                t,
                t,
                col,
            );
        }
    }

    /// The canvas from an RGB buffer of `width × height` pixels (as plotters draws).
    pub fn from_rgb(width: u32, height: u32, rgb: Vec<u8>) -> Option<Self> {
        RgbImage::from_raw(width, height, rgb).map(|img| Self { img })
    }

    /// Pastes another canvas with its top-left corner at (x, y).
    pub fn paste(&mut self, other: &Canvas, x: i64, y: i64) {
        for py in 0..other.height() {
            for px in 0..other.width() {
                self.put(x + i64::from(px), y + i64::from(py), other.get(px, py));
            }
        }
    }

    /// The PNG bytes.
    pub fn png_bytes(&self) -> Result<Vec<u8>, image::ImageError> {
        let mut out = std::io::Cursor::new(Vec::new());
        self.img.write_to(&mut out, image::ImageFormat::Png)?;
        Ok(out.into_inner())
    }

    /// Writes a PNG.
    pub fn save_png(&self, path: &Path) -> Result<(), image::ImageError> {
        self.img.save_with_format(path, image::ImageFormat::Png)
    }
}

/// Text width in pixels at a size (pixels per em).
pub fn text_width(text: &str, size: f32) -> u32 {
    text::width(text, size, text::Weight::Regular).ceil() as u32
}

/// Where a label's anchor point lies on its text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Anchor {
    /// Left (or top) edge.
    Start,
    /// Centre.
    Middle,
    /// Right (or bottom) edge.
    End,
}

/// A text to draw on a picture, in pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Label {
    /// Text.
    pub text: String,
    /// Anchor point, pixels.
    pub at: (f64, f64),
    /// Size, pixels per em.
    pub size: f32,
    /// Colour.
    pub colour: Colour,
    /// Bold.
    pub bold: bool,
    /// Horizontal and vertical anchor.
    pub anchor: (Anchor, Anchor),
    /// A one-pixel outline of this colour (legible over a colour map).
    pub halo: Option<Colour>,
}

impl Label {
    /// A black label, regular weight, anchored at its top-left corner.
    pub fn new(text: impl Into<String>, at: (f64, f64), size: f32) -> Label {
        Label {
            text: text.into(),
            at,
            size,
            colour: BLACK,
            bold: false,
            anchor: (Anchor::Start, Anchor::Start),
            halo: None,
        }
    }

    /// Anchored as given.
    pub fn anchored(mut self, h: Anchor, v: Anchor) -> Label {
        self.anchor = (h, v);
        self
    }

    /// In a colour.
    pub fn colour(mut self, c: Colour) -> Label {
        self.colour = c;
        self
    }

    /// Bold.
    pub fn bold(mut self) -> Label {
        self.bold = true;
        self
    }

    /// With an outline.
    pub fn halo(mut self, c: Colour) -> Label {
        self.halo = Some(c);
        self
    }

    fn weight(&self) -> text::Weight {
        if self.bold {
            text::Weight::Bold
        } else {
            text::Weight::Regular
        }
    }

    /// The box its text covers, pixels: x0, y0, x1, y1.
    pub fn bbox(&self) -> [f64; 4] {
        let w = f64::from(text::width(&self.text, self.size, self.weight()));
        let h = f64::from(self.size) * 1.17;
        let x = match self.anchor.0 {
            Anchor::Start => self.at.0,
            Anchor::Middle => self.at.0 - w / 2.0,
            Anchor::End => self.at.0 - w,
        };
        let y = match self.anchor.1 {
            Anchor::Start => self.at.1,
            Anchor::Middle => self.at.1 - h / 2.0,
            Anchor::End => self.at.1 - h,
        };
        [x, y, x + w, y + h]
    }

    /// Draws it.
    pub fn draw(&self, c: &mut Canvas) {
        let weight = self.weight();
        let [x, y, _, _] = self.bbox();
        if let Some(halo) = self.halo {
            for (dx, dy) in [(-1.0, 0.0), (1.0, 0.0), (0.0, -1.0), (0.0, 1.0)] {
                text::draw(
                    &self.text,
                    (x + dx) as f32,
                    (y + dy) as f32,
                    self.size,
                    weight,
                    &mut |px, py, a| c.blend(px, py, halo, a * 0.8),
                );
            }
        }
        let col = self.colour;
        text::draw(
            &self.text,
            x as f32,
            y as f32,
            self.size,
            weight,
            &mut |px, py, a| c.blend(px, py, col, a),
        );
    }
}

/// Two boxes (x0, y0, x1, y1) share some area.
pub fn boxes_overlap(a: &[f64; 4], b: &[f64; 4]) -> bool {
    a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
}

/// Round tick values over [lo, hi]: 1, 2, 5 × 10^k on a log axis, about five steps of 1, 2,
/// 2.5 or 5 × 10^k on a linear one.
pub fn ticks(lo: f64, hi: f64, log: bool) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return Vec::new();
    }
    if log {
        let mut t = Vec::new();
        if lo <= 0.0 {
            return t;
        }
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
        let span = hi - lo;
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
            t.push(if v.abs() < 1e-12 * span { 0.0 } else { v });
            v += step;
        }
        t
    }
}

/// A plotters drawing: the whole picture's area and the labels to draw after it.
pub type Drawing<'f> = dyn for<'a> FnMut(
        &plotters::drawing::DrawingArea<
            plotters::backend::BitMapBackend<'a>,
            plotters::coord::Shift,
        >,
        &mut Vec<Label>,
    ) -> Result<(), Box<dyn std::error::Error + 'a>>
    + 'f;

/// Draws with plotters into a `width × height` RGB picture, then the labels the drawing asked
/// for (plotters draws no text: every text is DejaVu Sans through [`Label`]).
pub fn with_plotters(width: u32, height: u32, f: &mut Drawing<'_>) -> Canvas {
    use plotters::prelude::IntoDrawingArea;
    let (w, h) = (width.max(16), height.max(16));
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let mut labels = Vec::new();
    {
        let root =
            plotters::backend::BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        if let Err(e) = f(&root, &mut labels) {
            tracing::warn!("drawing a picture: {e}");
        }
        let _ = root.present();
    }
    let mut c = Canvas::from_rgb(w, h, buf).unwrap_or_else(|| Canvas::new(w, h, WHITE));
    for l in &labels {
        l.draw(&mut c);
    }
    c
}

/// One axis of a chart: its range, scale and description.
#[derive(Debug, Clone)]
pub struct Axis {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
    /// Logarithmic.
    pub log: bool,
    /// Description with its unit ("x (m)").
    pub desc: String,
}

type Root<'a> =
    plotters::drawing::DrawingArea<plotters::backend::BitMapBackend<'a>, plotters::coord::Shift>;

/// Frame, ticks, tick numbers and descriptions of a chart whose data-to-pixel mapping is `map`;
/// light grid lines with `grid`.
pub fn draw_axes<'a>(
    root: &Root<'a>,
    map: &dyn Fn(f64, f64) -> (i32, i32),
    x: &Axis,
    y: &Axis,
    grid: bool,
    labels: &mut Vec<Label>,
) -> Result<(), Box<dyn std::error::Error + 'a>> {
    use plotters::prelude::*;
    let (l, b) = map(x.lo, y.lo);
    let (r, t) = map(x.hi, y.hi);
    let light = RGBColor(228, 228, 228);
    for v in ticks(x.lo, x.hi, x.log) {
        let (px, _) = map(v, y.lo);
        if grid {
            root.draw(&PathElement::new(vec![(px, t), (px, b)], light))?;
        }
        root.draw(&PathElement::new(vec![(px, b), (px, b + 5)], BLACK))?;
        labels.push(
            Label::new(plot::label(v), (f64::from(px), f64::from(b + 8)), 13.0)
                .anchored(Anchor::Middle, Anchor::Start),
        );
    }
    for v in ticks(y.lo, y.hi, y.log) {
        let (_, py) = map(x.lo, v);
        if grid {
            root.draw(&PathElement::new(vec![(l, py), (r, py)], light))?;
        }
        root.draw(&PathElement::new(vec![(l - 5, py), (l, py)], BLACK))?;
        labels.push(
            Label::new(plot::label(v), (f64::from(l - 8), f64::from(py)), 13.0)
                .anchored(Anchor::End, Anchor::Middle),
        );
    }
    root.draw(&Rectangle::new([(l, t), (r, b)], BLACK.stroke_width(1)))?;
    labels.push(
        Label::new(
            x.desc.clone(),
            (f64::from(l + r) / 2.0, f64::from(b + 28)),
            14.0,
        )
        .anchored(Anchor::Middle, Anchor::Start),
    );
    labels.push(
        Label::new(y.desc.clone(), (f64::from(l), f64::from(t - 8)), 14.0)
            .anchored(Anchor::Start, Anchor::End),
    );
    Ok(())
}

/// A vertical colour bar over the pixel rectangle `(x, top)–(x + width, bottom)` for values 0 to
/// `max`, with ticks and numbers on its right and the unit above.
pub fn draw_colour_bar<'a>(
    root: &Root<'a>,
    (x, top, width, bottom): (i32, i32, i32, i32),
    max: f64,
    unit: &str,
    colour_of: &dyn Fn(f64) -> Colour,
    labels: &mut Vec<Label>,
) -> Result<(), Box<dyn std::error::Error + 'a>> {
    use plotters::prelude::*;
    let h = (bottom - top).max(1);
    for k in 0..h {
        let t = 1.0 - (f64::from(k) + 0.5) / f64::from(h);
        let [r, g, b] = colour_of(t);
        root.draw(&Rectangle::new(
            [(x, top + k), (x + width, top + k + 1)],
            RGBColor(r, g, b).filled(),
        ))?;
    }
    root.draw(&Rectangle::new([(x, top), (x + width, bottom)], BLACK))?;
    for v in ticks(0.0, max, false) {
        let py = bottom - ((v / max) * f64::from(h)).round() as i32;
        root.draw(&PathElement::new(
            vec![(x + width, py), (x + width + 5, py)],
            BLACK,
        ))?;
        labels.push(
            Label::new(
                plot::label(v),
                (f64::from(x + width + 8), f64::from(py)),
                13.0,
            )
            .anchored(Anchor::Start, Anchor::Middle),
        );
    }
    labels.push(
        Label::new(unit, (f64::from(x + width / 2), f64::from(top - 8)), 15.0)
            .anchored(Anchor::Middle, Anchor::End),
    );
    Ok(())
}

/// A perceptually ordered colour map (viridis, interpolated between 9 anchors); `t` in [0, 1].
pub fn viridis(t: f64) -> Colour {
    const ANCHORS: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (ANCHORS.len() - 1) as f64;
    let i = (x.floor() as usize).min(ANCHORS.len() - 2);
    let f = x - i as f64;
    let mut c = [0u8; 3];
    for k in 0..3 {
        c[k] = (ANCHORS[i][k] + f * (ANCHORS[i + 1][k] - ANCHORS[i][k])).round() as u8;
    }
    c
}

/// A "nice" upper bound for a colour scale (1, 2, 2.5 or 5 × 10^k, at or above `v`).
pub fn nice_ceiling(v: f64) -> f64 {
    if !(v.is_finite() && v > 0.0) {
        return 1.0;
    }
    let p = 10f64.powf(v.log10().floor());
    for m in [1.0, 2.0, 2.5, 5.0, 10.0] {
        if m * p >= v {
            return m * p;
        }
    }
    10.0 * p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_map_ends_and_nice_numbers() {
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
        assert_eq!(viridis(f64::NAN), viridis(0.0));
        assert_eq!(nice_ceiling(1234.0), 2000.0);
        assert_eq!(nice_ceiling(2000.0), 2000.0);
        assert_eq!(nice_ceiling(0.31), 0.5);
        assert_eq!(nice_ceiling(0.0), 1.0);
    }
}
