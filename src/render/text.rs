//! Text for the pictures: DejaVu Sans (a subset, `assets/fonts/`, Bitstream Vera licence with
//! the DejaVu changes in the public domain: `assets/fonts/LICENSE`) embedded in the binary and
//! drawn with ab_glyph, anti-aliased, in upper and lower case, with the symbols the pictures need
//! (µ, ², ≤, ρ, Ē...). Charts drawn by plotters get their text from here too ([`super::Label`]),
//! so no picture needs a system font (`scripts/subset-font.sh` makes the subset).

use std::sync::OnceLock;

use ab_glyph::{Font, FontRef, PxScale, ScaleFont};

/// The regular face.
pub static REGULAR_TTF: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-subset.ttf");
/// The bold face.
pub static BOLD_TTF: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-Bold-subset.ttf");

/// Regular or bold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Weight {
    /// Regular.
    Regular,
    /// Bold.
    Bold,
}

fn face(weight: Weight) -> Option<&'static FontRef<'static>> {
    static FACES: OnceLock<Option<(FontRef<'static>, FontRef<'static>)>> = OnceLock::new();
    FACES
        .get_or_init(|| {
            let r = FontRef::try_from_slice(REGULAR_TTF).ok()?;
            let b = FontRef::try_from_slice(BOLD_TTF).ok()?;
            Some((r, b))
        })
        .as_ref()
        .map(|(r, b)| if weight == Weight::Bold { b } else { r })
}

/// Width of `text` at a size (pixels per em), pixels.
pub fn width(text: &str, size_px: f32, weight: Weight) -> f32 {
    let Some(f) = face(weight) else {
        return 0.0;
    };
    let sf = f.as_scaled(PxScale::from(size_px));
    // no kerning: with it, gaps opened inside some words ("Camer a")
    text.chars().map(|c| sf.h_advance(sf.glyph_id(c))).sum()
}

/// Ascent (above the baseline) at a size, pixels.
pub fn ascent(size_px: f32, weight: Weight) -> f32 {
    face(weight).map_or(size_px * 0.76, |f| {
        f.as_scaled(PxScale::from(size_px)).ascent()
    })
}

/// Draws `text` with the top of its line box at `y` and its left edge at `x`; `plot(x, y,
/// coverage)` is called for every covered pixel (coverage in (0, 1]).
pub fn draw(
    text: &str,
    x: f32,
    y: f32,
    size_px: f32,
    weight: Weight,
    plot: &mut dyn FnMut(i64, i64, f32),
) {
    let Some(f) = face(weight) else {
        return;
    };
    let sf = f.as_scaled(PxScale::from(size_px));
    let baseline = y + sf.ascent();
    let mut pen = x;
    for c in text.chars() {
        let id = sf.glyph_id(c);
        let glyph =
            id.with_scale_and_position(PxScale::from(size_px), ab_glyph::point(pen, baseline));
        if let Some(outline) = f.outline_glyph(glyph) {
            let b = outline.px_bounds();
            outline.draw(|gx, gy, cov| {
                if cov > 0.0 {
                    plot(
                        b.min.x as i64 + i64::from(gx),
                        b.min.y as i64 + i64::from(gy),
                        cov.min(1.0),
                    );
                }
            });
        }
        pen += sf.h_advance(id);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_font_has_the_symbols_the_pictures_use() {
        let f = face(Weight::Regular).expect("the embedded font parses");
        assert!(face(Weight::Bold).is_some());
        for c in "aAzZ09 lx m² µs ≤ ≥ ρ Ē Φ γ θ ± ° – ×".chars() {
            if c != ' ' {
                assert_ne!(f.glyph_id(c).0, 0, "no glyph for {c:?}");
            }
        }
        // lower case is narrower than upper case
        assert!(width("lx", 16.0, Weight::Regular) < width("LX", 16.0, Weight::Regular));
        let mut ink = 0.0;
        draw(
            "Ē 500 lx",
            0.0,
            0.0,
            16.0,
            Weight::Regular,
            &mut |_, _, c| ink += c,
        );
        assert!(ink > 20.0, "{ink}");
    }
}
