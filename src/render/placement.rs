//! Labels placed, not stacked: a greedy placement that tries candidate positions around each
//! label's anchor, in order, and keeps the first whose box lies inside the picture's area and
//! overlaps no earlier label or symbol. A label with no free candidate is left out.

use super::{Anchor, Label, boxes_overlap};

/// What has been placed so far, in pixels.
#[derive(Debug, Clone)]
pub struct Placer {
    /// Where labels may go: x0, y0, x1, y1.
    area: [f64; 4],
    /// Symbols' boxes.
    symbols: Vec<[f64; 4]>,
    /// The placed labels.
    labels: Vec<Label>,
}

impl Placer {
    /// Nothing placed in `area` (x0, y0, x1, y1).
    pub fn new(area: [f64; 4]) -> Placer {
        Placer {
            area,
            symbols: Vec::new(),
            labels: Vec::new(),
        }
    }

    /// A symbol no label may cover.
    pub fn symbol(&mut self, b: [f64; 4]) {
        self.symbols.push(b);
    }

    /// The box lies in the area and covers no symbol or placed label.
    pub fn fits(&self, b: &[f64; 4]) -> bool {
        let a = &self.area;
        b[0] >= a[0]
            && b[1] >= a[1]
            && b[2] <= a[2]
            && b[3] <= a[3]
            && !self.symbols.iter().any(|s| boxes_overlap(s, b))
            && !self.labels.iter().any(|l| boxes_overlap(&l.bbox(), b))
    }

    /// Places the first candidate that fits; false when none does.
    pub fn place(&mut self, candidates: impl IntoIterator<Item = Label>) -> bool {
        for l in candidates {
            if self.fits(&l.bbox()) {
                self.labels.push(l);
                return true;
            }
        }
        false
    }

    /// Places a block of labels (lines) together at the first offset where all fit.
    pub fn place_block(&mut self, lines: &[Label], offsets: &[(f64, f64)]) -> bool {
        for (dx, dy) in offsets {
            let moved: Vec<Label> = lines
                .iter()
                .map(|l| {
                    let mut l = l.clone();
                    l.at = (l.at.0 + dx, l.at.1 + dy);
                    l
                })
                .collect();
            let boxes: Vec<[f64; 4]> = moved.iter().map(Label::bbox).collect();
            if boxes.iter().all(|b| self.fits(b)) {
                self.labels.extend(moved);
                return true;
            }
        }
        false
    }

    /// The placed labels.
    pub fn labels(self) -> Vec<Label> {
        self.labels
    }
}

/// Candidates for `label` around a symbol's box (x0, y0, x1, y1), `gap` pixels off it: right,
/// left, below, above, then the four corners.
pub fn around(label: &Label, sym: [f64; 4], gap: f64) -> Vec<Label> {
    let (cx, cy) = (0.5 * (sym[0] + sym[2]), 0.5 * (sym[1] + sym[3]));
    let (l, r, t, b) = (sym[0] - gap, sym[2] + gap, sym[1] - gap, sym[3] + gap);
    use Anchor::{End, Middle, Start};
    [
        ((r, cy), (Start, Middle)),
        ((l, cy), (End, Middle)),
        ((cx, b), (Middle, Start)),
        ((cx, t), (Middle, End)),
        ((r, t), (Start, End)),
        ((r, b), (Start, Start)),
        ((l, t), (End, End)),
        ((l, b), (End, Start)),
    ]
    .into_iter()
    .map(|(at, (h, v))| {
        let mut c = label.clone().anchored(h, v);
        c.at = at;
        c
    })
    .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn render_placement_moves_a_label_off_an_earlier_one_and_off_symbols() {
        let mut p = Placer::new([0.0, 0.0, 400.0, 400.0]);
        let sym = [100.0, 100.0, 120.0, 120.0];
        p.symbol(sym);
        let l = Label::new("L1", (0.0, 0.0), 12.0);
        assert!(p.place(around(&l, sym, 3.0)));
        // the same label again cannot take the right: it goes left
        assert!(p.place(around(&l, sym, 3.0)));
        let placed = p.clone().labels();
        assert!(placed[0].bbox()[0] >= 123.0 - 1e-9);
        assert!(placed[1].bbox()[2] <= 97.0 + 1e-9);
        assert!(!boxes_overlap(&placed[0].bbox(), &placed[1].bbox()));
        // a box outside the area never fits
        assert!(!p.fits(&[390.0, 0.0, 410.0, 10.0]));
    }
}
