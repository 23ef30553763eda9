//! Pictures for people: the top-view illuminance map (`simulate --map`), later the
//! commissioning report. A small RGB canvas with lines, boxes and labels, a perceptual colour
//! map, PNG output.

pub mod camera_view;
mod font;
pub mod map;
pub mod plot;

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

    /// Text with its top-left corner at (x, y).
    pub fn text(&mut self, text: &str, x: i64, y: i64, scale: u32, c: Colour) {
        font::draw(text, x, y, scale, &mut |px, py| self.put(px, py, c));
    }

    /// Text centred on (cx, cy) on a filled box with a 3-pixel margin.
    pub fn label(&mut self, text: &str, cx: i64, cy: i64, scale: u32, fg: Colour, bg: Colour) {
        let w = i64::from(font::text_width(text, scale));
        let h = i64::from(font::text_height(scale));
        self.fill(cx - w / 2 - 3, cy - h / 2 - 3, w + 6, h + 6, bg);
        self.text(text, cx - w / 2, cy - h / 2, scale, fg);
    }

    /// Writes a PNG.
    pub fn save_png(&self, path: &Path) -> Result<(), image::ImageError> {
        self.img.save_with_format(path, image::ImageFormat::Png)
    }
}

/// Text width in pixels at a scale.
pub fn text_width(text: &str, scale: u32) -> u32 {
    font::text_width(text, scale)
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
