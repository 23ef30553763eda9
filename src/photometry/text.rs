//! Lenient text handling shared by the EULUMDAT and IES readers: byte decoding that never fails,
//! line splitting for CR, LF and CRLF, and a numeric tokenizer that remembers line numbers.

/// Decodes photometric file bytes. UTF-8 when valid, otherwise ISO-8859-1 (every byte is a
/// character), so a keyword line with a stray `°` in Windows-1252 never aborts parsing.
pub(crate) fn decode_lenient(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(s) => s.strip_prefix('\u{feff}').unwrap_or(s).to_owned(),
        Err(_) => bytes.iter().map(|&b| char::from(b)).collect(),
    }
}

/// Splits into lines on LF, CRLF or a lone CR, without the terminators. A final empty line
/// after the last terminator is dropped.
pub(crate) fn split_lines(text: &str) -> Vec<&str> {
    let mut lines = Vec::new();
    let bytes = text.as_bytes();
    let mut start = 0;
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'\n' => {
                lines.push(&text[start..i]);
                start = i + 1;
            }
            b'\r' => {
                lines.push(&text[start..i]);
                if i + 1 < bytes.len() && bytes[i + 1] == b'\n' {
                    i += 1;
                }
                start = i + 1;
            }
            _ => {}
        }
        i += 1;
    }
    if start < bytes.len() {
        lines.push(&text[start..]);
    }
    lines
}

/// Parses a finite number. `decimal_comma` accepts `12,5` for `12.5` (EULUMDAT files written
/// with a German locale). `nan`, `inf` and friends are rejected: they are never valid photometry.
pub(crate) fn parse_number(token: &str, decimal_comma: bool) -> Option<f64> {
    let t = token.trim();
    if t.is_empty() {
        return None;
    }
    // Only digits, sign, dot, exponent (and comma when allowed): keeps "inf"/"nan" out.
    let ok = t.chars().all(|c| {
        c.is_ascii_digit()
            || matches!(c, '+' | '-' | '.' | 'e' | 'E')
            || (decimal_comma && c == ',')
    });
    if !ok {
        return None;
    }
    let v = if decimal_comma && t.contains(',') {
        t.replace(',', ".").parse::<f64>().ok()?
    } else {
        t.parse::<f64>().ok()?
    };
    v.is_finite().then_some(v)
}

/// One token with the 1-based line it came from.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Token<'a> {
    pub text: &'a str,
    pub line: usize,
}

/// Tokens of `lines[from..]`, separated by whitespace (and by commas when `comma_separates`).
pub(crate) fn tokens<'a>(lines: &[&'a str], from: usize, comma_separates: bool) -> Vec<Token<'a>> {
    let mut out = Vec::new();
    for (offset, line) in lines.iter().enumerate().skip(from) {
        let split = line.split(|c: char| c.is_whitespace() || (comma_separates && c == ','));
        for text in split.filter(|t| !t.is_empty()) {
            out.push(Token {
                text,
                line: offset + 1,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_for_every_terminator() {
        assert_eq!(split_lines("a\r\nb\nc\rd"), vec!["a", "b", "c", "d"]);
        assert_eq!(split_lines("a\r\n\r\nb\r\n"), vec!["a", "", "b"]);
    }

    #[test]
    fn latin1_fallback_keeps_every_byte() {
        let bytes = b"[LUMINAIRE] 120\xb0 beam";
        assert_eq!(decode_lenient(bytes), "[LUMINAIRE] 120\u{b0} beam");
    }

    #[test]
    fn numbers() {
        assert_eq!(parse_number("12,5", true), Some(12.5));
        assert_eq!(parse_number("12,5", false), None);
        assert_eq!(parse_number(".21", false), Some(0.21));
        assert_eq!(parse_number("1.", false), Some(1.0));
        assert_eq!(parse_number("-1", false), Some(-1.0));
        assert_eq!(parse_number("1e3", false), Some(1000.0));
        assert_eq!(parse_number("nan", false), None);
        assert_eq!(parse_number("inf", false), None);
        assert_eq!(parse_number("1e999", false), None);
        assert_eq!(parse_number("", false), None);
    }
}
