//! EULUMDAT (`.ldt`) reader, field by field as in the format description (physics.md §5.1).
//!
//! The header (lines 1–26 and the lamp sets) is read line by line, because its text fields may
//! hold spaces or be empty. From the direct ratios on, the file is read as a stream of numbers,
//! so writers that put several numbers on a line are accepted too. Decimal commas are accepted.
//!
//! Intensities are stored in cd/klm; absolute cd = value × conversion factor × flux of the
//! selected lamp set / 1000. A negative lamp count marks absolute photometry (the set's flux is
//! then the luminaire flux). Lamp sets are alternatives: the first is used, never their sum.

use super::text::{Token, parse_number, split_lines, tokens};
use super::{
    ErrorKind, Format, IntensityDistribution, LampSet, Metadata, Opening, PhotometryError,
    StoredPlane, Symmetry,
};

/// Line-indexed access to the header with typed field readers.
struct Header<'a> {
    lines: Vec<&'a str>,
}

impl<'a> Header<'a> {
    fn text(&self, line: usize) -> Result<&'a str, PhotometryError> {
        self.lines.get(line - 1).map(|s| s.trim()).ok_or_else(|| {
            PhotometryError::at(
                line,
                ErrorKind::Truncated {
                    expected: format!("{} header lines", line),
                    found: self.lines.len(),
                },
            )
        })
    }

    fn number(&self, line: usize, field: &str) -> Result<f64, PhotometryError> {
        let t = self.text(line)?;
        parse_number(t, true).ok_or_else(|| {
            PhotometryError::at(
                line,
                ErrorKind::Syntax(format!("{field}: expected a number, found {t:?}")),
            )
        })
    }

    /// A number that may be absent in sloppy files (an empty line): `default` then.
    fn number_or(&self, line: usize, default: f64) -> Result<f64, PhotometryError> {
        let t = self.text(line)?;
        if t.is_empty() {
            return Ok(default);
        }
        Ok(parse_number(t, true).unwrap_or(default))
    }

    fn integer(&self, line: usize, field: &str) -> Result<i64, PhotometryError> {
        let v = self.number(line, field)?;
        if v.fract() != 0.0 || v.abs() > 1e9 {
            return Err(PhotometryError::at(
                line,
                ErrorKind::Syntax(format!("{field}: expected an integer, found {v}")),
            ));
        }
        Ok(v as i64)
    }
}

/// Reads numbers from the token stream, counting what was found for truncation errors.
struct Numbers<'a> {
    toks: Vec<Token<'a>>,
    pos: usize,
    last_line: usize,
}

impl Numbers<'_> {
    fn take(&mut self, n: usize, what: &str) -> Result<Vec<f64>, PhotometryError> {
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let Some(t) = self.toks.get(self.pos) else {
                return Err(PhotometryError::at(
                    self.last_line,
                    ErrorKind::Truncated {
                        expected: format!("{n} {what}"),
                        found: i,
                    },
                ));
            };
            let v = parse_number(t.text, true).ok_or_else(|| {
                PhotometryError::at(
                    t.line,
                    ErrorKind::Syntax(format!("{what}: expected a number, found {:?}", t.text)),
                )
            })?;
            self.last_line = t.line;
            self.pos += 1;
            out.push(v);
        }
        Ok(out)
    }
}

/// Ityp, Isym, Mc and Ng, checked: the symmetry, Isym, Mc and Ng.
fn symmetry_of(h: &Header) -> Result<(Symmetry, i64, usize, usize), PhotometryError> {
    let ityp = h.integer(2, "Ityp (type indicator)")?;
    if !(0..=3).contains(&ityp) {
        return Err(PhotometryError::at(
            2,
            ErrorKind::Invalid(format!("Ityp must be 0..3, found {ityp}")),
        ));
    }
    let isym = h.integer(3, "Isym (symmetry indicator)")?;
    let symmetry = match isym {
        0 => Symmetry::None,
        1 => Symmetry::Rotational,
        2 => Symmetry::AboutC0C180,
        3 => Symmetry::AboutC90C270,
        4 => Symmetry::Quadrant,
        _ => {
            return Err(PhotometryError::at(
                3,
                ErrorKind::Invalid(format!("Isym must be 0..4, found {isym}")),
            ));
        }
    };
    let mc = h.integer(4, "Mc (number of C-planes)")?;
    let ng = h.integer(6, "Ng (intensities per C-plane)")?;
    if !(1..=3600).contains(&mc) {
        return Err(PhotometryError::at(
            4,
            ErrorKind::Invalid(format!("Mc must be 1..3600, found {mc}")),
        ));
    }
    if !(1..=3600).contains(&ng) {
        return Err(PhotometryError::at(
            6,
            ErrorKind::Invalid(format!("Ng must be 1..3600, found {ng}")),
        ));
    }
    let (mc, ng) = (mc as usize, ng as usize);
    let needs_multiple = match symmetry {
        Symmetry::AboutC0C180 => 2,
        Symmetry::AboutC90C270 | Symmetry::Quadrant => 4,
        _ => 1,
    };
    if mc % needs_multiple != 0 {
        return Err(PhotometryError::at(
            4,
            ErrorKind::Invalid(format!(
                "Mc = {mc} is not a multiple of {needs_multiple}, as Isym {isym} requires"
            )),
        ));
    }
    Ok((symmetry, isym, mc, ng))
}

/// The lamp sets (lines 26 on); the first must have a flux.
fn lamp_sets_of(h: &Header) -> Result<Vec<LampSet>, PhotometryError> {
    let n_sets = h.integer(26, "number of lamp sets")?;
    if !(1..=50).contains(&n_sets) {
        return Err(PhotometryError::at(
            26,
            ErrorKind::Invalid(format!(
                "number of lamp sets must be 1..50, found {n_sets}: without a lamp set the \
                 cd/klm values cannot be converted to cd"
            )),
        ));
    }
    let mut lamp_sets = Vec::new();
    for s in 0..n_sets as usize {
        let base = 27 + 6 * s;
        let count = h.integer(base, "number of lamps")?;
        let flux_lm = h.number(base + 2, "total luminous flux of lamps")?;
        lamp_sets.push(LampSet {
            count: count.clamp(i32::MIN as i64, i32::MAX as i64) as i32,
            lamp_type: h.text(base + 1)?.to_owned(),
            flux_lm,
            colour: h.text(base + 3)?.to_owned(),
            cri: h.text(base + 4)?.to_owned(),
            power_w: h.number_or(base + 5, f64::NAN)?,
        });
    }
    let set_line = 29;
    if lamp_sets[0].flux_lm.abs() <= 0.0 {
        return Err(PhotometryError::at(
            set_line,
            ErrorKind::Invalid("lamp set flux is 0 lm: cd/klm cannot be converted to cd".into()),
        ));
    }
    Ok(lamp_sets)
}

/// The C-plane and gamma angles and the stored planes' intensities (times `scale`), checked:
/// C angles ascending in [0, 360), the stored planes spanning the symmetric sector.
fn planes_of(
    nums: &mut Numbers,
    symmetry: Symmetry,
    isym: i64,
    (mc, ng): (usize, usize),
    scale: f64,
) -> Result<(Vec<f64>, Vec<StoredPlane>), PhotometryError> {
    let _direct_ratios = nums.take(10, "direct ratios")?;
    let c_list = nums.take(mc, "C-plane angles")?;
    let gamma_deg = nums.take(ng, "gamma angles")?;

    let (rows, first): (usize, usize) = match symmetry {
        Symmetry::None => (mc, 0),
        Symmetry::Rotational => (1, 0),
        Symmetry::AboutC0C180 => (mc / 2 + 1, 0),
        // spec: Mc1 = 3 Mc / 4 + 1 (1-based): C270 → C360/C0 → C90
        Symmetry::AboutC90C270 => (mc / 2 + 1, 3 * mc / 4),
        Symmetry::Quadrant => (mc / 4 + 1, 0),
    };
    if mc == 1 && symmetry != Symmetry::Rotational {
        return Err(PhotometryError::at(
            4,
            ErrorKind::Invalid(format!("Mc = 1 needs Isym 1, found Isym {isym}")),
        ));
    }
    for w in c_list.windows(2) {
        if w[1] <= w[0] {
            return Err(PhotometryError::at(
                nums.last_line,
                ErrorKind::Invalid(format!(
                    "C-plane angles are not ascending ({} then {})",
                    w[0], w[1]
                )),
            ));
        }
    }
    if c_list.iter().any(|&c| !(0.0..360.0).contains(&c)) {
        return Err(PhotometryError::general(ErrorKind::Invalid(
            "C-plane angles must lie in [0, 360)".into(),
        )));
    }
    let mut planes = Vec::with_capacity(rows);
    for r in 0..rows {
        let c_deg = c_list[(first + r) % mc];
        let values = nums.take(ng, "luminous intensities")?;
        planes.push(StoredPlane {
            c_deg,
            cd: values.iter().map(|v| v * scale).collect(),
        });
    }
    let expected_c = |r: usize| match symmetry {
        Symmetry::AboutC0C180 => Some((r, 180.0 * r as f64 / (rows - 1) as f64)),
        Symmetry::Quadrant => Some((r, 90.0 * r as f64 / (rows - 1) as f64)),
        Symmetry::AboutC90C270 => Some((r, (270.0 + 180.0 * r as f64 / (rows - 1) as f64) % 360.0)),
        _ => None,
    };
    // The stored planes must span exactly the symmetric sector (catches a Mc/C list mismatch).
    for r in [0, rows.saturating_sub(1)] {
        if let Some((r, want)) = expected_c(r) {
            let got = planes[r].c_deg;
            if (got - want).abs() > 1e-6 {
                return Err(PhotometryError::general(ErrorKind::Invalid(format!(
                    "Isym {isym} stores planes C{} .. C{} but plane {} is C{got}",
                    expected_c(0).map_or(0.0, |e| e.1),
                    expected_c(rows - 1).map_or(0.0, |e| e.1),
                    r + 1
                ))));
            }
        }
    }
    Ok((gamma_deg, planes))
}

/// Parses a EULUMDAT file: header (symmetry, texts, lamp sets), angles, intensities.
pub(super) fn parse(text: &str) -> Result<IntensityDistribution, PhotometryError> {
    let lines = split_lines(text);
    let h = Header {
        lines: lines.clone(),
    };

    let company = h.text(1)?.to_owned();
    let (symmetry, isym, mc, ng) = symmetry_of(&h)?;
    let luminaire = h.text(9)?.to_owned();
    let mut keywords = vec![
        ("company".to_owned(), company.clone()),
        ("report".to_owned(), h.text(8)?.to_owned()),
        ("luminaire".to_owned(), luminaire.clone()),
        ("luminaire_number".to_owned(), h.text(10)?.to_owned()),
        ("file_name".to_owned(), h.text(11)?.to_owned()),
        ("date_user".to_owned(), h.text(12)?.to_owned()),
    ];
    keywords.retain(|(_, v)| !v.is_empty());

    let area_length_mm = h.number_or(16, 0.0)?;
    let area_width_mm = h.number_or(17, 0.0)?;
    let dff = h.number_or(22, f64::NAN)?;
    let lorl = h.number_or(23, f64::NAN)?;
    let mut conversion = h.number_or(24, 1.0)?;
    let mut warnings = Vec::new();
    if conversion < 0.0 {
        return Err(PhotometryError::at(
            24,
            ErrorKind::Invalid(format!("conversion factor {conversion} is negative")),
        ));
    }
    if conversion == 0.0 {
        warnings.push("conversion factor 0 read as 1".to_owned());
        conversion = 1.0;
    }
    let lamp_sets = lamp_sets_of(&h)?;
    let set = &lamp_sets[0];
    let absolute = set.count < 0;
    let set_flux_lm = set.flux_lm.abs();
    let numbers_from = 27 + 6 * lamp_sets.len() - 1; // 0-based index of the first direct ratio line

    let mut nums = Numbers {
        toks: tokens(&lines, numbers_from, false),
        pos: 0,
        last_line: numbers_from,
    };
    let scale = conversion * set_flux_lm / 1000.0;
    let (gamma_deg, planes) = planes_of(&mut nums, symmetry, isym, (mc, ng), scale)?;
    let trailing = nums.toks.len() - nums.pos;
    if trailing > 0 {
        warnings.push(format!(
            "{trailing} values after the last intensity ignored"
        ));
    }

    let opening = (area_length_mm > 0.0).then(|| Opening {
        length_m: area_length_mm / 1000.0,
        width_m: area_width_mm / 1000.0,
        circular: area_width_mm <= 0.0,
    });
    let power_w = set.power_w;
    let meta = Metadata {
        manufacturer: company,
        luminaire,
        keywords,
        lamp_flux_lm: (!absolute).then_some(set_flux_lm * conversion),
        declared_lor_pct: lorl.is_finite().then_some(lorl),
        declared_dff_pct: dff.is_finite().then_some(dff),
        absolute,
        opening,
        tilt: None,
        power_w: power_w.is_finite().then_some(power_w),
        lamp_sets,
        lamp_set_used: 0,
        warnings,
    };
    IntensityDistribution::from_stored(Format::Eulumdat, symmetry, gamma_deg, planes, meta)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A spec-layout EULUMDAT text with `rows` stored planes, each value = `value(c, gamma)`.
    pub(crate) fn ldt_text(
        isym: u8,
        mc: usize,
        gammas: &[f64],
        stored_c: &[f64],
        value: impl Fn(f64, f64) -> f64,
    ) -> String {
        let dc = 360.0 / mc as f64;
        let mut s = String::new();
        let mut line = |x: String| {
            s.push_str(&x);
            s.push_str("\r\n");
        };
        line("luxnode test".into());
        line("3".into());
        line(isym.to_string());
        line(mc.to_string());
        line(format!("{dc}"));
        line(gammas.len().to_string());
        line("0".into());
        for t in ["rep", "lum", "no", "file", "date"] {
            line(t.into());
        }
        for v in [
            "600", "600", "80", "600", "600", "0", "0", "0", "0", "100", "100", "1", "0",
        ] {
            line(v.into());
        }
        line("1".into());
        line("1".into());
        line("LED".into());
        line("1000".into());
        line("4000".into());
        line("80".into());
        line("50".into());
        for _ in 0..10 {
            line("0.5".into());
        }
        for i in 0..mc {
            line(format!("{}", i as f64 * dc));
        }
        for g in gammas {
            line(format!("{g}"));
        }
        for &c in stored_c {
            for &g in gammas {
                line(format!("{}", value(c, g)));
            }
        }
        s
    }

    #[test]
    fn isym3_spec_layout_table() {
        // physics.md §10 F2: Mc = 24, Dc = 15; stored rows C270..C345, C0..C90, value 1000 + C.
        let stored: Vec<f64> = (0..13).map(|r| ((270 + 15 * r) % 360) as f64).collect();
        let text = ldt_text(3, 24, &[0.0, 45.0, 90.0], &stored, |c, _| 1000.0 + c);
        let d = parse(&text).unwrap();
        let at = |c: f64| d.intensity_cd(c.to_radians(), 45f64.to_radians());
        for (c, want) in [
            (0.0, 1000.0),
            (30.0, 1030.0),
            (90.0, 1090.0),
            (120.0, 1060.0),
            (180.0, 1000.0),
            (210.0, 1330.0),
            (270.0, 1270.0),
            (300.0, 1300.0),
        ] {
            assert!((at(c) - want).abs() < 1e-9, "C{c}: {} != {want}", at(c));
        }
        assert_eq!(d.c_grid_deg().len(), 24);
    }

    #[test]
    fn rows_read_per_isym() {
        // physics.md §10 F1: rows = {0: Mc, 1: 1, 2 and 3: Mc/2+1, 4: Mc/4+1}; a file with one
        // value too few is a truncation error, never a silent misread.
        let mc = 24;
        for (isym, rows, first) in [(0u8, 24, 0), (1, 1, 0), (2, 13, 0), (3, 13, 18), (4, 7, 0)] {
            let stored: Vec<f64> = (0..rows)
                .map(|r| (((first + r) % mc) * 15) as f64)
                .collect();
            let text = ldt_text(isym, mc, &[0.0, 45.0, 90.0], &stored, |_, _| 100.0);
            let d = parse(&text).unwrap_or_else(|e| panic!("Isym {isym}: {e}"));
            assert_eq!(d.stored_c_deg().len(), rows, "Isym {isym}");
            let mut lines: Vec<&str> = text.trim_end().split("\r\n").collect();
            lines.pop();
            let short = lines.join("\r\n");
            let err = parse(&short).unwrap_err();
            assert!(
                matches!(err.kind, ErrorKind::Truncated { .. }),
                "Isym {isym}: {err}"
            );
        }
    }

    #[test]
    fn decimal_commas_and_absolute_lamp_count() {
        let text = ldt_text(1, 1, &[0.0, 90.0], &[0.0], |_, _| 100.0)
            .replace("\r\n1000\r\n", "\r\n2000,0\r\n");
        let d = parse(&text).unwrap();
        // 100 cd/klm × 2000 lm / 1000 = 200 cd
        assert!((d.intensity_cd(0.0, 0.3) - 200.0).abs() < 1e-9);
        assert!(!d.meta.absolute);
    }

    /// The lamp set's colour rendering line (the fixture's `80`, after the colour temperature
    /// `4000`): an index, a CIE group, or nothing stated (never assumed).
    #[test]
    fn the_lamp_sets_colour_rendering_index_is_read() {
        let text = ldt_text(1, 1, &[0.0, 90.0], &[0.0], |_, _| 100.0);
        let ra = |field: &str| {
            let t = text.replace("\r\n4000\r\n80\r\n", &format!("\r\n4000\r\n{field}\r\n"));
            let d = parse(&t).unwrap();
            assert_eq!(d.meta.lamp_sets[0].cri, field.trim());
            d.meta.lamp_sets[0].ra_min()
        };
        assert_eq!(parse(&text).unwrap().meta.lamp_sets[0].ra_min(), Some(80.0));
        for (field, want) in [
            ("1B", Some(80.0)),
            ("1a", Some(90.0)),
            ("2A", Some(70.0)),
            ("Ra 85", Some(85.0)),
            (">= 90", Some(90.0)),
            ("80-89", Some(80.0)),
            ("CRI: 92", Some(92.0)),
            ("", None),
            ("-", None),
            ("high", None),
            ("80%", None),
            ("400", None),
        ] {
            assert_eq!(ra(field), want, "{field:?}");
        }
    }

    #[test]
    fn malformed_fields_name_their_line() {
        let text = ldt_text(1, 1, &[0.0, 90.0], &[0.0], |_, _| 100.0);
        let bad: String = text.replacen("\r\n1\r\n", "\r\nseven\r\n", 1);
        let err = parse(&bad).unwrap_err();
        assert_eq!(err.location.line, Some(3), "{err}");
        let bad_isym = text.replacen("\r\n3\r\n1\r\n", "\r\n3\r\n7\r\n", 1);
        let err = parse(&bad_isym).unwrap_err();
        assert!(err.to_string().contains("Isym"), "{err}");
        assert!(parse("").is_err());
        assert!(parse("just one line").is_err());
    }
}
