//! Time: RFC 3339 timestamps into seconds since the Unix epoch, and the proleptic Gregorian
//! calendar both ways (Howard Hinnant's `days_from_civil` / `civil_from_days`, restated).
//!
//! Unix time ignores leap seconds (every day has 86 400 s), which is what the sun position
//! needs: the NOAA algorithm takes UTC and its error budget (~0.01°) is far above the 1 s
//! of a leap second (0.004° of hour angle).

/// Seconds since 1970-01-01T00:00:00Z (leap seconds not counted) plus a fraction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct UnixTime {
    /// Whole seconds since the epoch (negative before 1970).
    pub seconds: i64,
    /// The fraction of the second, in nanoseconds (0..1_000_000_000).
    pub nanoseconds: u32,
}

impl UnixTime {
    /// A whole number of seconds since the epoch.
    pub const fn from_seconds(seconds: i64) -> Self {
        Self {
            seconds,
            nanoseconds: 0,
        }
    }

    /// Seconds since the epoch as `f64` (exact to ~1 µs for the years 0..9999).
    pub fn as_seconds_f64(self) -> f64 {
        self.seconds as f64 + f64::from(self.nanoseconds) * 1e-9
    }

    /// The Julian date (days since −4712-01-01T12:00 UT): `seconds / 86400 + 2440587.5`.
    pub fn julian_date(self) -> f64 {
        // days and the rest apart, so that the fraction keeps its precision
        let days = self.seconds.div_euclid(86_400);
        let rest_s = self.seconds.rem_euclid(86_400) as f64 + f64::from(self.nanoseconds) * 1e-9;
        (days as f64 + 2_440_587.5) + rest_s / 86_400.0
    }
}

/// Why a timestamp is not an RFC 3339 date-time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TimeError {
    /// The text does not have the shape `YYYY-MM-DDTHH:MM:SS[.f](Z|±hh:mm)`.
    #[error("not an RFC 3339 date-time (YYYY-MM-DDTHH:MM:SS[.fff](Z|+hh:mm)) at byte {at}")]
    Syntax {
        /// Byte offset of the first character that does not fit.
        at: usize,
    },
    /// The month is not 1..=12.
    #[error("month {0} is not 1..=12")]
    Month(u32),
    /// The day does not exist in that month of that year.
    #[error("day {day} does not exist in {year:04}-{month:02}")]
    Day {
        /// The year.
        year: i64,
        /// The month (1..=12).
        month: u32,
        /// The day that was given.
        day: u32,
    },
    /// The hour, minute or second is out of range (hour 0..=23, minute 0..=59, second 0..=60).
    #[error("time of day {hour:02}:{minute:02}:{second:02} is out of range")]
    TimeOfDay {
        /// The hour.
        hour: u32,
        /// The minute.
        minute: u32,
        /// The second (60 is a leap second).
        second: u32,
    },
    /// The offset is out of range (hours 0..=23, minutes 0..=59).
    #[error("UTC offset {hours:02}:{minutes:02} is out of range")]
    Offset {
        /// The offset's hours.
        hours: u32,
        /// The offset's minutes.
        minutes: u32,
    },
}

/// Days since 1970-01-01 of a date of the proleptic Gregorian calendar (Hinnant's
/// `days_from_civil`: years counted from March, so that the leap day ends the year).
/// `month` is 1..=12, `day` 1..=31; the date is not checked (see [`days_in_month`]).
pub const fn days_from_civil(year: i64, month: u32, day: u32) -> i64 {
    let y = if month <= 2 { year - 1 } else { year };
    let era = y.div_euclid(400);
    let year_of_era = y - era * 400; // 0..=399
    let m = month as i64;
    let month_from_march = if m > 2 { m - 3 } else { m + 9 }; // 0..=11
    let day_of_year = (153 * month_from_march + 2) / 5 + day as i64 - 1; // 0..=365
    let day_of_era = year_of_era * 365 + year_of_era / 4 - year_of_era / 100 + day_of_year;
    era * 146_097 + day_of_era - 719_468
}

/// The date `(year, month 1..=12, day 1..=31)` of a day counted from 1970-01-01, the inverse
/// of [`days_from_civil`] (Hinnant's `civil_from_days`).
pub const fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let day_of_era = z - era * 146_097; // 0..=146096
    let year_of_era =
        (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let mp = (5 * day_of_year + 2) / 153; // 0..=11, from March
    let day = (day_of_year - (153 * mp + 2) / 5 + 1) as u32;
    let month = (if mp < 10 { mp + 3 } else { mp - 9 }) as u32;
    let year = year_of_era + era * 400 + if month <= 2 { 1 } else { 0 };
    (year, month, day)
}

/// Whether `year` is a leap year of the Gregorian calendar.
pub const fn is_leap_year(year: i64) -> bool {
    year % 4 == 0 && (year % 100 != 0 || year % 400 == 0)
}

/// The number of days in `month` (1..=12) of `year`; 0 for a month out of range.
pub const fn days_in_month(year: i64, month: u32) -> u32 {
    match month {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        2 if is_leap_year(year) => 29,
        2 => 28,
        _ => 0,
    }
}

/// A cursor over the bytes of a timestamp.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Cursor<'_> {
    fn syntax(&self) -> TimeError {
        TimeError::Syntax { at: self.at }
    }

    /// Exactly `n` ASCII digits as a number.
    fn digits(&mut self, n: usize) -> Result<u32, TimeError> {
        let mut value = 0u32;
        for _ in 0..n {
            match self.bytes.get(self.at) {
                Some(b) if b.is_ascii_digit() => {
                    value = value * 10 + u32::from(b - b'0');
                    self.at += 1;
                }
                _ => return Err(self.syntax()),
            }
        }
        Ok(value)
    }

    /// One byte out of `allowed`, returned.
    fn one_of(&mut self, allowed: &[u8]) -> Result<u8, TimeError> {
        match self.bytes.get(self.at) {
            Some(b) if allowed.contains(b) => {
                self.at += 1;
                Ok(*b)
            }
            _ => Err(self.syntax()),
        }
    }

    /// An optional `.fff…` (at least one digit; digits past the ninth are dropped).
    fn fraction_ns(&mut self) -> Result<u32, TimeError> {
        if self.bytes.get(self.at) != Some(&b'.') {
            return Ok(0);
        }
        self.at += 1;
        let start = self.at;
        let mut ns = 0u32;
        let mut scale = 100_000_000u32;
        while let Some(b) = self.bytes.get(self.at).filter(|b| b.is_ascii_digit()) {
            ns += u32::from(b - b'0') * scale;
            scale /= 10;
            self.at += 1;
        }
        if self.at == start {
            return Err(self.syntax());
        }
        Ok(ns)
    }

    /// `Z`/`z` (0) or `±hh:mm`, as seconds east of UTC.
    fn offset_s(&mut self) -> Result<i64, TimeError> {
        let sign = match self.one_of(b"Zz+-")? {
            b'Z' | b'z' => return Ok(0),
            b'+' => 1,
            _ => -1,
        };
        let hours = self.digits(2)?;
        self.one_of(b":")?;
        let minutes = self.digits(2)?;
        if hours > 23 || minutes > 59 {
            return Err(TimeError::Offset { hours, minutes });
        }
        Ok(sign * i64::from(hours * 3600 + minutes * 60))
    }
}

/// Parses an RFC 3339 date-time, `YYYY-MM-DDTHH:MM:SS[.fff](Z|±hh:mm)` (`T`, `t` or a space
/// between date and time; `Z` or `z`; any number of fraction digits, nanoseconds kept), into
/// Unix time. The offset is required (a time without one is not an instant). A leap second
/// (`:60`) is accepted and counts as the first second of the next minute, as Unix time has
/// no leap seconds.
///
/// # Errors
///
/// [`TimeError`] on anything else: wrong shape or trailing text, a month or day that does not
/// exist (`2023-02-29`, `2024-04-31`), an hour over 23, a minute over 59, an offset over 23:59.
pub fn parse_rfc3339(text: &str) -> Result<UnixTime, TimeError> {
    let mut c = Cursor {
        bytes: text.as_bytes(),
        at: 0,
    };
    let year = i64::from(c.digits(4)?);
    c.one_of(b"-")?;
    let month = c.digits(2)?;
    c.one_of(b"-")?;
    let day = c.digits(2)?;
    c.one_of(b"Tt ")?;
    let hour = c.digits(2)?;
    c.one_of(b":")?;
    let minute = c.digits(2)?;
    c.one_of(b":")?;
    let second = c.digits(2)?;
    let nanoseconds = c.fraction_ns()?;
    let offset_s = c.offset_s()?;
    if c.at != c.bytes.len() {
        return Err(c.syntax());
    }
    if !(1..=12).contains(&month) {
        return Err(TimeError::Month(month));
    }
    if day == 0 || day > days_in_month(year, month) {
        return Err(TimeError::Day { year, month, day });
    }
    if hour > 23 || minute > 59 || second > 60 {
        return Err(TimeError::TimeOfDay {
            hour,
            minute,
            second,
        });
    }
    let local_s =
        days_from_civil(year, month, day) * 86_400 + i64::from(hour * 3600 + minute * 60 + second);
    Ok(UnixTime {
        seconds: local_s - offset_s,
        nanoseconds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn known_instants() {
        // Reference values: Python's datetime.fromisoformat(...).timestamp()
        let cases: &[(&str, i64, u32)] = &[
            ("1970-01-01T00:00:00Z", 0, 0),
            ("2000-01-01T00:00:00Z", 946_684_800, 0),
            ("2024-02-29T12:00:00+01:00", 1_709_204_400, 0),
            ("2024-06-21 10:30:15.25-04:30", 1_718_982_015, 250_000_000),
            ("1969-12-31T23:59:59.5z", -1, 500_000_000),
            ("1900-03-01t00:00:00Z", -2_203_891_200, 0),
            (
                "2100-12-31T23:59:59.123456789123Z",
                4_133_980_799,
                123_456_789,
            ),
            ("2016-12-31T23:59:60Z", 1_483_228_800, 0),
        ];
        for &(text, seconds, nanoseconds) in cases {
            assert_eq!(
                parse_rfc3339(text),
                Ok(UnixTime {
                    seconds,
                    nanoseconds
                }),
                "{text}"
            );
        }
    }

    #[test]
    fn rejects_what_is_not_a_date_time() {
        let bad = [
            "",
            "garbage",
            "2024-13-01T00:00:00Z",
            "2024-00-10T00:00:00Z",
            "2024-04-31T00:00:00Z",
            "2023-02-29T00:00:00Z",
            "1900-02-29T00:00:00Z",
            "2024-01-00T00:00:00Z",
            "2024-01-01T25:00:00Z",
            "2024-01-01T24:00:00Z",
            "2024-01-01T12:60:00Z",
            "2024-01-01T12:00:61Z",
            "2024-01-01T12:00:00",
            "2024-01-01T12:00:00+1:00",
            "2024-01-01T12:00:00+24:00",
            "2024-01-01T12:00:00+01:60",
            "2024-01-01T12:00:00.Z",
            "2024-01-01T12:00:00Z ",
            "2024-01-01X12:00:00Z",
            "24-01-01T12:00:00Z",
            "2024-1-01T12:00:00Z",
            "2024-01-01T12:00Z",
            "２０２４-01-01T12:00:00Z",
        ];
        for text in bad {
            assert!(parse_rfc3339(text).is_err(), "{text:?} parsed");
        }
        assert_eq!(parse_rfc3339(""), Err(TimeError::Syntax { at: 0 }));
        assert_eq!(
            parse_rfc3339("2023-02-29T00:00:00Z"),
            Err(TimeError::Day {
                year: 2023,
                month: 2,
                day: 29
            })
        );
        assert_eq!(
            parse_rfc3339("2024-01-01T25:00:00Z"),
            Err(TimeError::TimeOfDay {
                hour: 25,
                minute: 0,
                second: 0
            })
        );
    }

    #[test]
    fn calendar_edges() {
        assert_eq!(days_from_civil(1970, 1, 1), 0);
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(-1), (1969, 12, 31));
        // 2000 is a leap year, 1900 and 2100 are not
        assert_eq!(
            civil_from_days(days_from_civil(2000, 2, 28) + 1),
            (2000, 2, 29)
        );
        assert_eq!(
            civil_from_days(days_from_civil(1900, 2, 28) + 1),
            (1900, 3, 1)
        );
        assert_eq!(
            civil_from_days(days_from_civil(2100, 2, 28) + 1),
            (2100, 3, 1)
        );
        // the Julian date of the J2000.0 epoch, 2000-01-01T12:00:00Z
        let j2000 = UnixTime::from_seconds(days_from_civil(2000, 1, 1) * 86_400 + 43_200);
        assert_eq!(j2000.julian_date(), 2_451_545.0);
    }

    proptest! {
        #[test]
        fn civil_round_trip(days in -1_000_000i64..3_000_000) {
            let (y, m, d) = civil_from_days(days);
            prop_assert!((1..=12).contains(&m) && d >= 1 && d <= days_in_month(y, m));
            prop_assert_eq!(days_from_civil(y, m, d), days);
        }

        #[test]
        fn rfc3339_round_trip(
            seconds in -62_135_596_800i64..253_402_300_799,
            nanoseconds in 0u32..1_000_000_000,
            offset_min in -(23 * 60 + 59)..=(23i64 * 60 + 59),
            separator in prop::sample::select(vec!['T', 't', ' ']),
        ) {
            // the local wall clock at that offset, written out, must parse back to the instant
            let local = seconds + offset_min * 60;
            let (y, mo, d) = civil_from_days(local.div_euclid(86_400));
            prop_assume!((0..=9999).contains(&y));
            let sod = local.rem_euclid(86_400);
            let sign = if offset_min < 0 { '-' } else { '+' };
            let text = format!(
                "{y:04}-{mo:02}-{d:02}{separator}{:02}:{:02}:{:02}.{nanoseconds:09}{sign}{:02}:{:02}",
                sod / 3600,
                sod / 60 % 60,
                sod % 60,
                offset_min.abs() / 60,
                offset_min.abs() % 60,
            );
            prop_assert_eq!(parse_rfc3339(&text), Ok(UnixTime { seconds, nanoseconds }), "{}", text);
        }
    }
}
