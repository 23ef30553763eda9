//! Writers: a distribution as EULUMDAT or as IES LM-63-2002, keeping its symmetry where the
//! target format can express it (otherwise every plane is written). Both write absolute
//! photometry (EULUMDAT: lamp count −1 and the luminaire flux as the set's flux; IES: lumens
//! −1), so reading the output gives back the same candela values.

use std::fmt::Write as _;

use super::{ErrorKind, IntensityDistribution, PhotometryError, Symmetry, fmt_num};

/// Full-precision decimal of a value (shortest representation that reads back exactly).
fn exact(v: f64) -> String {
    format!("{v}")
}

fn uniform_step(v: &[f64]) -> Option<f64> {
    let step = v.get(1)? - v.first()?;
    v.windows(2)
        .all(|w| ((w[1] - w[0]) - step).abs() < 1e-6)
        .then_some(step)
}

impl IntensityDistribution {
    /// Which C planes (indices into the full grid) a file with `sym` stores, in file order;
    /// `None` when the grid cannot be written with that symmetry.
    fn stored_rows(&self, sym: Symmetry) -> Option<Vec<usize>> {
        let c = &self.c_deg;
        let mc = c.len();
        let find = |a: f64| c.iter().position(|&x| (x - a).abs() < 1e-6);
        match sym {
            Symmetry::Rotational => Some(vec![0]),
            Symmetry::None => Some((0..mc).collect()),
            Symmetry::AboutC0C180 => {
                let end = find(180.0)?;
                (mc.is_multiple_of(2) && end == mc / 2).then(|| (0..=end).collect())
            }
            Symmetry::Quadrant => {
                let end = find(90.0)?;
                (mc.is_multiple_of(4) && end == mc / 4).then(|| (0..=end).collect())
            }
            Symmetry::AboutC90C270 => {
                let start = find(270.0)?;
                (mc.is_multiple_of(4) && start == 3 * mc / 4)
                    .then(|| (0..=mc / 2).map(|r| (start + r) % mc).collect())
            }
        }
    }

    /// The distribution as EULUMDAT text (CRLF line ends, absolute photometry).
    pub fn to_ldt(&self) -> Result<String, PhotometryError> {
        let flux = self.flux_lm();
        if flux <= 0.0 {
            return Err(PhotometryError::general(ErrorKind::Invalid(
                "a distribution without flux cannot be written as cd/klm".into(),
            )));
        }
        let (sym, rows) = match self.stored_rows(self.symmetry) {
            Some(r) => (self.symmetry, r),
            None => (Symmetry::None, (0..self.c_deg.len()).collect()),
        };
        let mc = self.c_deg.len();
        let ng = self.gamma_deg.len();
        let dc = if mc == 1 {
            0.0
        } else {
            uniform_step(&self.c_deg).unwrap_or(0.0)
        };
        let dg = uniform_step(&self.gamma_deg).unwrap_or(0.0);
        let opening = self.meta.opening;
        let (len_mm, wid_mm) = opening.map_or((0.0, 0.0), |o| {
            (
                1000.0 * o.length_m,
                if o.circular { 0.0 } else { 1000.0 * o.width_m },
            )
        });
        let dff = 100.0 * self.zonal_flux_lm(0.0, 90.0) / flux;
        let name = if self.meta.luminaire.is_empty() {
            "luminaire"
        } else {
            &self.meta.luminaire
        };
        let manufacturer = if self.meta.manufacturer.is_empty() {
            "luxnode"
        } else {
            &self.meta.manufacturer
        };

        let mut s = String::new();
        let mut line = |x: &str| {
            s.push_str(x);
            s.push_str("\r\n");
        };
        line(manufacturer);
        line(if sym == Symmetry::Rotational {
            "1"
        } else {
            "3"
        });
        line(&sym.isym().to_string());
        line(&mc.to_string());
        line(&fmt_num(dc));
        line(&ng.to_string());
        line(&fmt_num(dg));
        line("");
        line(name);
        line("");
        line("");
        line("written by luxnode");
        for v in [len_mm, wid_mm, 0.0, len_mm, wid_mm, 0.0, 0.0, 0.0, 0.0] {
            line(&fmt_num(v));
        }
        line(&fmt_num(dff));
        line("100");
        line("1");
        line("0");
        line("1");
        line("-1");
        line("luminaire (absolute photometry)");
        line(&exact(flux));
        line("");
        line("");
        line(&fmt_num(self.meta.power_w.unwrap_or(0.0)));
        for _ in 0..10 {
            line("0");
        }
        for &c in &self.c_deg {
            line(&fmt_num(c));
        }
        for &g in &self.gamma_deg {
            line(&fmt_num(g));
        }
        let per_klm = 1000.0 / flux;
        for r in rows {
            for ig in 0..ng {
                line(&exact(self.cd[r * ng + ig] * per_klm));
            }
        }
        Ok(s)
    }

    /// The distribution as IES LM-63-2002 text (absolute photometry, metres).
    pub fn to_ies(&self) -> String {
        let nc = self.c_deg.len();
        let (horizontal, rows): (Vec<f64>, Vec<usize>) = match self.symmetry {
            Symmetry::Rotational => (vec![0.0], vec![0]),
            Symmetry::Quadrant | Symmetry::AboutC0C180 | Symmetry::AboutC90C270 => {
                let (lo, hi) = match self.symmetry {
                    Symmetry::Quadrant => (0.0, 90.0),
                    Symmetry::AboutC0C180 => (0.0, 180.0),
                    _ => (90.0, 270.0),
                };
                let idx: Vec<usize> = (0..nc)
                    .filter(|&i| self.c_deg[i] >= lo - 1e-6 && self.c_deg[i] <= hi + 1e-6)
                    .collect();
                (idx.iter().map(|&i| self.c_deg[i]).collect(), idx)
            }
            Symmetry::None => {
                let mut h = self.c_deg.clone();
                h.push(360.0);
                let mut r: Vec<usize> = (0..nc).collect();
                r.push(0);
                (h, r)
            }
        };
        let ng = self.gamma_deg.len();
        let mut s = String::new();
        s.push_str("IESNA:LM-63-2002\r\n[TEST] luxnode export\r\n[TESTLAB] luxnode\r\n");
        s.push_str("[ISSUEDATE] -\r\n");
        let _ = write!(s, "[MANUFAC] {}\r\n", self.meta.manufacturer);
        let _ = write!(s, "[LUMCAT] {}\r\n", self.meta.luminaire);
        match &self.meta.tilt {
            None => s.push_str("TILT=NONE\r\n"),
            Some(t) => {
                let _ = write!(
                    s,
                    "TILT=INCLUDE\r\n{}\r\n{}\r\n{}\r\n{}\r\n",
                    t.lamp_geometry,
                    t.angles_deg.len(),
                    join(&t.angles_deg, fmt_num),
                    join(&t.factors, exact)
                );
            }
        }
        let (w, l) = self.meta.opening.map_or((0.0, 0.0), |o| {
            if o.circular {
                (-o.length_m, -o.length_m)
            } else {
                (o.width_m, o.length_m)
            }
        });
        let _ = write!(
            s,
            "1 -1 1 {ng} {} 1 2 {} {} 0\r\n1 1 {}\r\n",
            horizontal.len(),
            fmt_num(w),
            fmt_num(l),
            fmt_num(self.meta.power_w.unwrap_or(0.0))
        );
        push_wrapped(&mut s, &self.gamma_deg, fmt_num);
        push_wrapped(&mut s, &horizontal, fmt_num);
        for r in rows {
            push_wrapped(&mut s, &self.cd[r * ng..(r + 1) * ng], exact);
        }
        s
    }
}

fn join(v: &[f64], f: fn(f64) -> String) -> String {
    v.iter().map(|&x| f(x)).collect::<Vec<_>>().join(" ")
}

/// Values ten to a line (IES lines stay well under 256 characters).
fn push_wrapped(s: &mut String, v: &[f64], f: fn(f64) -> String) {
    for chunk in v.chunks(10) {
        s.push_str(&join(chunk, f));
        s.push_str("\r\n");
    }
}
