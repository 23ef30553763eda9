//! IES LM-63 reader (1986, 1991, 1995, 2002, 2019), photometric type C.
//!
//! Layout: an optional version line, keyword lines (`[KEY] value`, `[MORE]` continues the
//! previous one; free text lines in 1986 files), the `TILT=` line (and with `TILT=INCLUDE` the
//! tilt table), then numbers separated by blanks, commas or line breaks:
//! lamps, lumens/lamp, candela multiplier, #vertical, #horizontal, photometric type, units,
//! width, length, height; ballast factor, ballast-lamp factor (file generation type in 2019),
//! input watts; vertical angles; horizontal angles; candela per horizontal angle.
//!
//! Absolute cd = value × candela multiplier × ballast factor (× ballast-lamp photometric factor
//! before 2019), each applied exactly once. Lumens/lamp = −1 marks absolute photometry.

use super::text::{Token, parse_number, split_lines, tokens};
use super::{
    ErrorKind, Format, IesVersion, IntensityDistribution, Metadata, Opening, PhotometryError,
    StoredPlane, Symmetry, TiltTable,
};

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
            let v = parse_number(t.text, false).ok_or_else(|| {
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

    fn one(&mut self, what: &str) -> Result<f64, PhotometryError> {
        Ok(self.take(1, what)?[0])
    }

    fn count(&mut self, what: &str, max: usize) -> Result<usize, PhotometryError> {
        let line = self.toks.get(self.pos).map_or(self.last_line, |t| t.line);
        let v = self.one(what)?;
        if v.fract() != 0.0 || v < 1.0 || v > max as f64 {
            return Err(PhotometryError::at(
                line,
                ErrorKind::Invalid(format!("{what} must be an integer in 1..{max}, found {v}")),
            ));
        }
        Ok(v as usize)
    }
}

/// The version line: the version and the index of the first line after it (none before
/// LM-63-1991: line 0 is already a keyword line).
fn version_of(lines: &[&str]) -> Result<(IesVersion, usize), PhotometryError> {
    let first = lines.first().map(|l| l.trim()).unwrap_or("");
    let upper = first.to_ascii_uppercase();
    Ok(if upper.starts_with("IES:LM-63-2019") {
        (IesVersion::Lm63_2019, 1)
    } else if upper.starts_with("IESNA:LM-63-2002") {
        (IesVersion::Lm63_2002, 1)
    } else if upper.starts_with("IESNA:LM-63-1995") {
        (IesVersion::Lm63_1995, 1)
    } else if upper.starts_with("IESNA91") {
        (IesVersion::Lm63_1991, 1)
    } else if upper.starts_with("IES") {
        return Err(PhotometryError::at(
            1,
            ErrorKind::Unsupported(format!("unknown IES version line {first:?}")),
        ));
    } else {
        (IesVersion::Lm63_1986, 0)
    })
}

/// Keyword lines from line `i` up to the TILT= line: the keywords (`[MORE]` joined to the one
/// before; a line without a keyword has an empty key) and the TILT= line's index.
#[allow(clippy::type_complexity)]
fn keywords_of(
    lines: &[&str],
    mut i: usize,
) -> Result<(Vec<(String, String)>, usize), PhotometryError> {
    let mut keywords: Vec<(String, String)> = Vec::new();
    loop {
        let Some(line) = lines.get(i) else {
            return Err(PhotometryError::at(
                lines.len(),
                ErrorKind::Syntax("no TILT= line found".into()),
            ));
        };
        let t = line.trim();
        if t.to_ascii_uppercase().starts_with("TILT") {
            return Ok((keywords, i));
        }
        if let Some(rest) = t.strip_prefix('[')
            && let Some(end) = rest.find(']')
        {
            let key = rest[..end].trim().to_ascii_uppercase();
            let value = rest[end + 1..].trim().to_owned();
            if key == "MORE" {
                if let Some(last) = keywords.last_mut() {
                    if !last.1.is_empty() {
                        last.1.push(' ');
                    }
                    last.1.push_str(&value);
                }
            } else {
                keywords.push((key, value));
            }
        } else if !t.is_empty() {
            keywords.push((String::new(), t.to_owned()));
        }
        i += 1;
    }
}

/// The tilt table after the TILT= line `tilt_text` (line index `tilt_line`): none, or
/// included (TILT=INCLUDE); a separate file is not supported.
fn tilt_of(
    tilt_text: &str,
    tilt_line: usize,
    nums: &mut Numbers,
) -> Result<Option<TiltTable>, PhotometryError> {
    let tilt_value = tilt_text
        .split_once('=')
        .map(|(_, v)| v.trim())
        .unwrap_or("");
    match tilt_value.to_ascii_uppercase().as_str() {
        "NONE" => Ok(None),
        "INCLUDE" => {
            let geometry = nums.one("TILT lamp-to-luminaire geometry")?;
            if ![1.0, 2.0, 3.0].contains(&geometry) {
                return Err(PhotometryError::at(
                    nums.last_line,
                    ErrorKind::Invalid(format!(
                        "TILT lamp-to-luminaire geometry must be 1, 2 or 3, found {geometry}"
                    )),
                ));
            }
            let n = nums.count("number of TILT angle/factor pairs", 1000)?;
            let angles_deg = nums.take(n, "TILT angles")?;
            let factors = nums.take(n, "TILT multiplying factors")?;
            if angles_deg.windows(2).any(|w| w[1] <= w[0]) {
                return Err(PhotometryError::at(
                    nums.last_line,
                    ErrorKind::Invalid("TILT angles are not ascending".into()),
                ));
            }
            if factors.iter().any(|&f| f < 0.0) {
                return Err(PhotometryError::at(
                    nums.last_line,
                    ErrorKind::Invalid("a TILT factor is negative".into()),
                ));
            }
            Ok(Some(TiltTable {
                lamp_geometry: geometry as u8,
                angles_deg,
                factors,
            }))
        }
        "" => Err(PhotometryError::at(
            tilt_line + 1,
            ErrorKind::Syntax(format!("malformed TILT line {tilt_text:?}")),
        )),
        _ => Err(PhotometryError::at(
            tilt_line + 1,
            ErrorKind::Unsupported(format!(
                "TILT={tilt_value}: tilt data in a separate file is not supported; \
                 include it in the file with TILT=INCLUDE"
            )),
        )),
    }
}

/// The numbers of the lines after the tilt data, checked.
struct Header {
    lamps: f64,
    lumens_per_lamp: f64,
    multiplier: f64,
    nv: usize,
    nh: usize,
    width: f64,
    length: f64,
    ballast: f64,
    /// The ballast-lamp photometric factor (1 for LM-63-2019, whose field is the file
    /// generation type).
    blpf: f64,
    watts: f64,
    /// Metres per file length unit.
    to_m: f64,
}

/// Reads the header numbers (warnings for values read as something else).
fn header_of(
    nums: &mut Numbers,
    version: IesVersion,
    warnings: &mut Vec<String>,
) -> Result<Header, PhotometryError> {
    let lamps = nums.one("number of lamps")?;
    let lumens_per_lamp = nums.one("lumens per lamp")?;
    let multiplier = nums.one("candela multiplier")?;
    let nv = nums.count("number of vertical angles", 10_000)?;
    let nh = nums.count("number of horizontal angles", 10_000)?;
    let ptype = nums.one("photometric type")?;
    let units = nums.one("units type")?;
    let width = nums.one("luminous width")?;
    let length = nums.one("luminous length")?;
    let _height = nums.one("luminous height")?;
    let ballast = nums.one("ballast factor")?;
    let second = nums.one("ballast-lamp photometric factor / file generation type")?;
    let watts = nums.one("input watts")?;
    let invalid =
        |nums: &Numbers, m: String| Err(PhotometryError::at(nums.last_line, ErrorKind::Invalid(m)));
    match ptype as i64 {
        1 => {}
        2 | 3 => {
            return Err(PhotometryError::at(
                nums.last_line,
                ErrorKind::Unsupported(format!(
                    "photometric type {} ({}); only type C (1) is supported",
                    ptype,
                    if ptype == 2.0 { "B" } else { "A" }
                )),
            ));
        }
        _ => {
            return invalid(
                nums,
                format!("photometric type must be 1, 2 or 3, found {ptype}"),
            );
        }
    }
    if multiplier <= 0.0 {
        return invalid(
            nums,
            format!("candela multiplier must be > 0, found {multiplier}"),
        );
    }
    if ballast <= 0.0 {
        return invalid(nums, format!("ballast factor must be > 0, found {ballast}"));
    }
    let blpf = if version == IesVersion::Lm63_2019 {
        1.0 // the field is the file generation type, not a factor
    } else if second > 0.0 {
        second
    } else {
        warnings.push(format!(
            "ballast-lamp photometric factor {second} read as 1"
        ));
        1.0
    };
    let to_m = match units as i64 {
        1 => 0.3048,
        2 => 1.0,
        _ => {
            return invalid(
                nums,
                format!("units type must be 1 (feet) or 2 (metres), found {units}"),
            );
        }
    };
    Ok(Header {
        lamps,
        lumens_per_lamp,
        multiplier,
        nv,
        nh,
        width,
        length,
        ballast,
        blpf,
        watts,
        to_m,
    })
}

/// Symmetry from the horizontal angle range (LM-63 type C).
fn symmetry_of(
    horizontal: &[f64],
    warnings: &mut Vec<String>,
) -> Result<Symmetry, PhotometryError> {
    let nh = horizontal.len();
    let h0 = horizontal[0];
    let h1 = horizontal[nh - 1];
    let symmetry = if nh == 1 {
        Symmetry::Rotational
    } else if near(h0, 0.0) && near(h1, 90.0) {
        Symmetry::Quadrant
    } else if near(h0, 0.0) && near(h1, 180.0) {
        Symmetry::AboutC0C180
    } else if near(h0, 90.0) && near(h1, 270.0) {
        Symmetry::AboutC90C270
    } else if near(h0, 0.0) && h1 > 180.0 && h1 <= 360.0 + 1e-6 {
        Symmetry::None
    } else {
        return Err(PhotometryError::general(ErrorKind::Unsupported(format!(
            "horizontal angles {h0} .. {h1}: type C files cover 0, 0-90, 0-180, 90-270 or 0-360"
        ))));
    };
    if nh == 1 && !near(h0, 0.0) {
        warnings.push(format!(
            "single horizontal angle {h0} read as rotational symmetry"
        ));
    }
    Ok(symmetry)
}

/// Angles equal within 1e-6°.
fn near(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-6
}

/// The metadata: keywords, lamp flux, opening, tilt, power.
fn metadata_of(
    h: &Header,
    keywords: Vec<(String, String)>,
    tilt: Option<TiltTable>,
    warnings: Vec<String>,
) -> Metadata {
    let absolute = near(h.lumens_per_lamp, -1.0);
    let lamp_flux_lm = (!absolute && h.lumens_per_lamp > 0.0 && h.lamps > 0.0)
        .then_some(h.lamps * h.lumens_per_lamp * h.ballast * h.blpf);
    let (length, width) = (h.length, h.width);
    // Negative width/length encode a shape (circular, ...); the magnitude is the size.
    let opening = (length.abs() > 0.0 || width.abs() > 0.0).then(|| Opening {
        length_m: length.abs() * h.to_m,
        width_m: width.abs() * h.to_m,
        circular: length < 0.0 && width < 0.0 && near(length, width),
    });
    let find = |k: &str| {
        keywords
            .iter()
            .find(|(key, _)| key == k)
            .map(|(_, v)| v.clone())
            .unwrap_or_default()
    };
    Metadata {
        manufacturer: find("MANUFAC"),
        luminaire: {
            let l = find("LUMCAT");
            if l.is_empty() { find("LUMINAIRE") } else { l }
        },
        lamp_flux_lm,
        absolute,
        opening,
        tilt,
        power_w: (h.watts > 0.0).then_some(h.watts),
        warnings,
        keywords,
        ..Metadata::default()
    }
}

/// Parses an IES LM-63 file: version line, keywords, tilt, header, angles, candela values.
pub(super) fn parse(text: &str) -> Result<IntensityDistribution, PhotometryError> {
    let lines = split_lines(text);
    let (version, i) = version_of(&lines)?;
    let (keywords, tilt_line) = keywords_of(&lines, i)?;
    let mut nums = Numbers {
        toks: tokens(&lines, tilt_line + 1, true),
        pos: 0,
        last_line: tilt_line + 1,
    };
    let tilt = tilt_of(lines[tilt_line].trim(), tilt_line, &mut nums)?;
    let mut warnings = Vec::new();
    let h = header_of(&mut nums, version, &mut warnings)?;
    let (nv, nh) = (h.nv, h.nh);
    let vertical = nums.take(nv, "vertical angles")?;
    let horizontal = nums.take(nh, "horizontal angles")?;
    let scale = h.multiplier * h.ballast * h.blpf;
    let mut rows = Vec::with_capacity(nh);
    for _ in 0..nh {
        let v = nums.take(nv, "candela values")?;
        rows.push(v.into_iter().map(|x| x * scale).collect::<Vec<f64>>());
    }
    let trailing = nums.toks.len() - nums.pos;
    if trailing > 0 {
        warnings.push(format!(
            "{trailing} values after the last candela value ignored"
        ));
    }
    if horizontal.windows(2).any(|w| w[1] <= w[0]) {
        return Err(PhotometryError::general(ErrorKind::Invalid(
            "horizontal angles are not strictly ascending".into(),
        )));
    }
    let symmetry = symmetry_of(&horizontal, &mut warnings)?;
    let h1 = horizontal[nh - 1];
    let mut planes: Vec<StoredPlane> = horizontal
        .iter()
        .zip(rows)
        .map(|(&c_deg, cd)| StoredPlane { c_deg, cd })
        .collect();
    // 0–360: the 360 plane is the 0 plane measured again; average the two.
    if symmetry == Symmetry::None
        && near(h1, 360.0)
        && let Some(last) = planes.pop()
    {
        let first = &mut planes[0];
        for (a, b) in first.cd.iter_mut().zip(&last.cd) {
            *a = 0.5 * (*a + b);
        }
    }
    let meta = metadata_of(&h, keywords, tilt, warnings);
    IntensityDistribution::from_stored(Format::Ies(version), symmetry, vertical, planes, meta)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TILTED: &str = "IESNA:LM-63-2002\n[TEST] t\nTILT=INCLUDE\n1\n4\n0 45 90 180\n1 .9 .8 1\n\
                          1 1000 1 3 1 1 2 0.1 0.1 0\n1 1 10\n0 45 90\n0\n100 50 0\n";

    #[test]
    fn tilt_include_is_read_and_applied_by_installed_tilt() {
        let d = parse(TILTED).unwrap();
        let t = d.meta.tilt.as_ref().unwrap();
        assert_eq!(t.factors, vec![1.0, 0.9, 0.8, 1.0]);
        assert_eq!(d.with_installed_tilt(0.0).intensity_cd(0.0, 0.0), 100.0);
        let at45 = d.with_installed_tilt(45f64.to_radians());
        assert!((at45.intensity_cd(0.0, 0.0) - 90.0).abs() < 1e-9);
        let at67 = d.with_installed_tilt(67.5f64.to_radians());
        assert!((at67.intensity_cd(0.0, 0.0) - 85.0).abs() < 1e-9);
    }

    #[test]
    fn tilt_file_is_a_clear_error() {
        let text = TILTED.replace("TILT=INCLUDE", "TILT=lamp.tlt");
        let err = parse(&text).unwrap_err();
        assert!(matches!(err.kind, ErrorKind::Unsupported(_)), "{err}");
        assert!(err.to_string().contains("lamp.tlt"), "{err}");
        assert_eq!(err.location.line, Some(3));
    }

    #[test]
    fn types_a_and_b_are_unsupported() {
        let text = "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 1 2 2 0 0 0\n1 1 1\n0 45 90\n0\n1 1 1\n";
        let err = parse(text).unwrap_err();
        assert!(err.to_string().contains("type 2 (B)"), "{err}");
    }

    #[test]
    fn multipliers_are_applied_once() {
        let text =
            "IESNA:LM-63-2002\nTILT=NONE\n1 -1 0.5 2 1 1 2 0 0 0\n0.8 1 1\n0 90\n0\n100 100\n";
        let d = parse(text).unwrap();
        assert!((d.intensity_cd(0.0, 0.1) - 40.0).abs() < 1e-12);
        assert!(d.meta.absolute);
        // 2019: the second factor is the file generation type, never a multiplier
        let text19 = text
            .replace("IESNA:LM-63-2002", "IES:LM-63-2019")
            .replace("0.8 1 1", "1 1.10000 1");
        let d19 = parse(&text19).unwrap();
        assert!((d19.intensity_cd(0.0, 0.1) - 50.0).abs() < 1e-12);
    }

    #[test]
    fn keywords_with_more_and_latin1_bytes() {
        let bytes = b"IESNA:LM-63-2002\r\n[LUMINAIRE] 120\xb0 lens\r\n[MORE] frosted\r\n\
                      TILT=NONE\r\n1 -1 1 2 1 1 2 0 0 0\r\n1 1 1\r\n0 90\r\n0\r\n5 0\r\n";
        let text = crate::photometry::text::decode_lenient(bytes);
        let d = parse(&text).unwrap();
        assert_eq!(d.meta.keywords[0].0, "LUMINAIRE");
        assert_eq!(d.meta.keywords[0].1, "120\u{b0} lens frosted");
    }

    #[test]
    fn truncated_and_garbage_are_errors() {
        let short =
            "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 2 1 2 0 0 0\n1 1 1\n0 45 90\n0 90\n1 2 3 4\n";
        let err = parse(short).unwrap_err();
        assert!(
            matches!(err.kind, ErrorKind::Truncated { found: 1, .. }),
            "{err}"
        );
        let garbage = short.replace("0 45 90", "0 forty-five 90");
        let err = parse(&garbage).unwrap_err();
        assert_eq!(err.location.line, Some(5), "{err}");
        assert!(parse("IESNA:LM-63-2002\n[TEST] x\n").is_err());
    }

    #[test]
    fn bilateral_90_270_mirrors_about_c90() {
        let text = "IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 3 3 1 2 0 0 0\n1 1 1\n0 45 90\n90 180 270\n\
                    5 10 0 5 20 0 5 30 0\n";
        let d = parse(text).unwrap();
        assert_eq!(d.symmetry(), Symmetry::AboutC90C270);
        // I(0) = I(180) = 20; I(45) = I(135) = 15; I(315) = I(225) = 25
        let at = |c: f64| d.intensity_cd(c.to_radians(), 45f64.to_radians());
        assert!((at(0.0) - 20.0).abs() < 1e-9);
        assert!((at(45.0) - 15.0).abs() < 1e-9);
        assert!((at(315.0) - 25.0).abs() < 1e-9);
        assert!((at(200.0) - 20.0 - 10.0 * 20.0 / 90.0).abs() < 1e-9);
    }
}
