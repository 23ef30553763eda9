//! Who may change what, and how each client reads: the one place that decides.
//!
//! * **Writes.** The node is read-only by default. A write (function 0x06 or 0x10, over TCP,
//!   TLS or RTU, broadcast included) is executed only when its [`Source`] matches a rule of the
//!   allowlist ([`AccessPolicy::writers`], `[modbus] write_allow` in the board file); any other
//!   write is refused with exception 0x01 (the function is not allowed for this client) and
//!   counted. Every register that is writable, today's (arc levels, word order, dimming curve)
//!   and any later one, goes through [`AccessPolicy::may_write`]: a new writable block asks it
//!   and needs nothing else.
//! * **Float word order per client.** The order of the two words of a float (ABCD, BADC, CDAB,
//!   DCBA) is a property of the reading client, never global: resolved per request from the
//!   client's own setting (written by it at holding 2000, persisted), then the board's
//!   per-client table, then the board's per-unit-id table (a client that cannot be configured
//!   picks an order by the unit id it addresses), then the board's default.
//! * **Persisted settings.** What clients write that outlives a request (the dimming curve,
//!   their word orders) is saved to a small JSON file (written whole, then renamed) and read back
//!   at start ([`Settings`]).
//!
//! Rules of the allowlist (strings in the board file):
//!
//! | rule | matches |
//! |---|---|
//! | `"192.168.1.20"`, `"::1"` | a TCP or TLS client at that address |
//! | `"10.0.0.0/24"`, `"fd00::/64"` | a TCP or TLS client in that network |
//! | `"rtu"` | the RTU line (its master: a serial bus has no addresses) |
//! | `"tls"` | any TLS client with a certificate of the configured CA |
//! | `"role:NAME"` | a TLS client whose certificate carries the Modbus/TCP Security role NAME |

use std::collections::BTreeMap;
use std::net::{IpAddr, SocketAddr};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::pdu::function;
use super::regmap::WordOrder;
use crate::dali::DimmingCurve;

/// Where a request comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// A Modbus TCP client.
    Tcp(SocketAddr),
    /// A Modbus/TCP Security (TLS) client: its address and, if its certificate has one, its
    /// role (the ModbusRole extension, OID 1.3.6.1.4.1.50316.802.1).
    Tls {
        /// Peer address.
        peer: SocketAddr,
        /// Role from the client certificate.
        role: Option<String>,
    },
    /// The master on an RTU line (the serial device).
    Rtu(String),
    /// A BACnet/IP client (its UDP address; the same allowlist rules as a TCP client).
    Bacnet(SocketAddr),
    /// The node itself (the DALI gateway link, tests): always allowed.
    Internal,
}

impl Source {
    /// The client's IP address, for TCP and TLS.
    pub fn ip(&self) -> Option<IpAddr> {
        match self {
            Source::Tcp(a) | Source::Tls { peer: a, .. } | Source::Bacnet(a) => Some(a.ip()),
            _ => None,
        }
    }

    /// The key of the client's own settings: its IP address, or `rtu`.
    pub fn client_key(&self) -> String {
        match self {
            Source::Tcp(a) | Source::Tls { peer: a, .. } | Source::Bacnet(a) => a.ip().to_string(),
            Source::Rtu(_) => "rtu".into(),
            Source::Internal => "internal".into(),
        }
    }
}

impl std::fmt::Display for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Source::Tcp(a) => write!(f, "tcp {a}"),
            Source::Tls {
                peer,
                role: Some(r),
            } => write!(f, "tls {peer} (role {r})"),
            Source::Tls { peer, role: None } => write!(f, "tls {peer}"),
            Source::Rtu(d) => write!(f, "rtu {d}"),
            Source::Bacnet(a) => write!(f, "bacnet {a}"),
            Source::Internal => f.write_str("internal"),
        }
    }
}

/// One rule of the write allowlist.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum WriteRule {
    /// A network (an address is a /32 or /128).
    Net {
        /// Network address.
        addr: IpAddr,
        /// Prefix length.
        prefix: u8,
    },
    /// The RTU line.
    Rtu,
    /// Any authenticated TLS client.
    AnyTls,
    /// A TLS client with this role.
    Role(String),
}

/// A rule that does not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct AccessError(pub String);

impl std::str::FromStr for WriteRule {
    type Err = AccessError;
    fn from_str(s: &str) -> Result<Self, AccessError> {
        let bad = |why: &str| AccessError(format!("write_allow entry {s:?}: {why}"));
        match s {
            "rtu" => return Ok(WriteRule::Rtu),
            "tls" => return Ok(WriteRule::AnyTls),
            _ => {}
        }
        if let Some(role) = s.strip_prefix("role:") {
            if role.is_empty() || role.len() > 64 {
                return Err(bad("a role is 1 to 64 characters"));
            }
            return Ok(WriteRule::Role(role.to_owned()));
        }
        let (a, prefix) = match s.split_once('/') {
            Some((a, p)) => (a, Some(p)),
            None => (s, None),
        };
        let addr: IpAddr = a.parse().map_err(|_| {
            bad("expected an IP address, a network (ADDR/PREFIX), \"rtu\", \"tls\" or \"role:NAME\"")
        })?;
        let max = if addr.is_ipv4() { 32 } else { 128 };
        let prefix = match prefix {
            None => max,
            Some(p) => p
                .parse::<u8>()
                .ok()
                .filter(|p| *p <= max)
                .ok_or_else(|| bad(&format!("prefix must be 0..={max}")))?,
        };
        Ok(WriteRule::Net { addr, prefix })
    }
}

fn in_net(ip: IpAddr, net: IpAddr, prefix: u8) -> bool {
    // an IPv4 client seen through an IPv6 socket (::ffff:a.b.c.d) matches IPv4 rules
    let ip = match ip {
        IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or(ip, IpAddr::V4),
        v4 => v4,
    };
    match (ip, net) {
        (IpAddr::V4(a), IpAddr::V4(n)) => {
            let mask = u32::MAX.checked_shl(32 - u32::from(prefix)).unwrap_or(0);
            u32::from(a) & mask == u32::from(n) & mask
        }
        (IpAddr::V6(a), IpAddr::V6(n)) => {
            let mask = u128::MAX.checked_shl(128 - u32::from(prefix)).unwrap_or(0);
            u128::from(a) & mask == u128::from(n) & mask
        }
        _ => false,
    }
}

impl WriteRule {
    /// True when the rule admits `source`.
    pub fn matches(&self, source: &Source) -> bool {
        match (self, source) {
            (_, Source::Internal) => true,
            (WriteRule::Net { addr, prefix }, s) => {
                s.ip().is_some_and(|ip| in_net(ip, *addr, *prefix))
            }
            (WriteRule::Rtu, Source::Rtu(_)) => true,
            (WriteRule::AnyTls, Source::Tls { .. }) => true,
            (WriteRule::Role(r), Source::Tls { role: Some(x), .. }) => r == x,
            _ => false,
        }
    }
}

/// Word orders set in the board file.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct WordOrders {
    /// For everyone else.
    pub default: WordOrder,
    /// Per client key (IP address, or `rtu`).
    pub clients: BTreeMap<String, WordOrder>,
    /// Per unit id addressed.
    pub units: BTreeMap<u8, WordOrder>,
}

/// The board's access settings.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct AccessPolicy {
    /// Who may write (empty: nobody; the default).
    pub writers: Vec<WriteRule>,
    /// Float word orders.
    pub word_orders: WordOrders,
}

/// Is this PDU a write, and which registers does it touch: (first address, count).
pub fn write_span(pdu: &[u8]) -> Option<(u16, u16)> {
    let at =
        |i: usize| -> Option<u16> { Some(u16::from_be_bytes([*pdu.get(i)?, *pdu.get(i + 1)?])) };
    match *pdu.first()? {
        function::WRITE_SINGLE => Some((at(1).unwrap_or(0), 1)),
        function::WRITE_MULTIPLE => Some((at(1).unwrap_or(0), at(3).unwrap_or(0))),
        _ => None,
    }
}

impl AccessPolicy {
    /// Parses the allowlist's strings.
    pub fn with_writers(mut self, rules: &[String]) -> Result<Self, AccessError> {
        self.writers = rules.iter().map(|r| r.parse()).collect::<Result<_, _>>()?;
        Ok(self)
    }

    /// The one decision: may `source` write `count` registers from `address`? Today every
    /// writable register needs the source in the allowlist; a register that any client may
    /// write (none yet) would be admitted here and nowhere else.
    pub fn may_write(&self, source: &Source, address: u16, count: u16) -> bool {
        let _ = (address, count);
        matches!(source, Source::Internal) || self.writers.iter().any(|r| r.matches(source))
    }

    /// True when some source may write.
    pub fn writable(&self) -> bool {
        !self.writers.is_empty()
    }

    /// The allowlist entry that admits every network address (`0.0.0.0/0`, `::/0`), if any:
    /// legal, but an open door that the node says so at start (issue 34).
    pub fn admits_everyone(&self) -> Option<String> {
        self.writers.iter().find_map(|r| match r {
            WriteRule::Net { addr, prefix: 0 } => Some(format!("{addr}/0")),
            _ => None,
        })
    }

    /// The word order in effect for `source` addressing `unit`, given the settings clients
    /// wrote: the client's own, the board's per-client, per-unit, default.
    pub fn word_order(&self, settings: &Settings, source: &Source, unit: u8) -> WordOrder {
        let key = source.client_key();
        settings
            .word_orders
            .get(&key)
            .and_then(|c| WordOrder::from_code(*c))
            .or_else(|| self.word_orders.clients.get(&key).copied())
            .or_else(|| self.word_orders.units.get(&unit).copied())
            .unwrap_or(self.word_orders.default)
    }
}

/// What clients set that persists across restarts.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// Dimming curve code (holding 2001), if written.
    #[serde(default)]
    pub dimming_curve: Option<u16>,
    /// Word order codes (holding 2000) written by clients, by client key.
    #[serde(default)]
    pub word_orders: BTreeMap<String, u16>,
    /// Lighting control mode (holding 2002), if written.
    #[serde(default)]
    pub control_mode: Option<u16>,
    /// Desk targets written (holding 2100 + k), lx, by desk id.
    #[serde(default)]
    pub targets_lx: BTreeMap<u32, u16>,
}

/// Why the settings file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum SettingsError {
    /// I/O.
    #[error("settings {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not the expected JSON.
    #[error("settings {}: {message}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// Most clients with their own word order (a flood of addresses must not grow the file).
pub const MAX_CLIENT_SETTINGS: usize = 256;

impl Settings {
    /// Reads the settings file; a missing file is the defaults.
    pub fn load(path: &Path) -> Result<Self, SettingsError> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Self::default()),
            Err(source) => {
                return Err(SettingsError::Io {
                    path: path.to_owned(),
                    source,
                });
            }
        };
        let s: Settings = serde_json::from_str(&text).map_err(|e| SettingsError::Format {
            path: path.to_owned(),
            message: e.to_string(),
        })?;
        let bad = |message: String| SettingsError::Format {
            path: path.to_owned(),
            message,
        };
        if let Some(c) = s.dimming_curve
            && c > 1
        {
            return Err(bad(format!("dimming_curve {c} is not 0 or 1")));
        }
        if let Some((k, c)) = s.word_orders.iter().find(|(_, c)| **c > 3) {
            return Err(bad(format!("word order {c} of {k} is not 0..=3")));
        }
        if let Some(m) = s.control_mode
            && m > 2
        {
            return Err(bad(format!("control_mode {m} is not 0..=2")));
        }
        if let Some((id, t)) = s
            .targets_lx
            .iter()
            .find(|(_, t)| **t > super::regmap::MAX_TARGET_LX)
        {
            return Err(bad(format!("target {t} lx of desk {id} is over 10000")));
        }
        if s.targets_lx.len() > super::regmap::MAX_DESKS {
            return Err(bad(format!("{} desk targets", s.targets_lx.len())));
        }
        if s.word_orders.len() > MAX_CLIENT_SETTINGS {
            return Err(bad(format!(
                "{} clients with a word order (at most {MAX_CLIENT_SETTINGS})",
                s.word_orders.len()
            )));
        }
        Ok(s)
    }

    /// Writes the settings file whole, then renames it into place (a reader or a power cut
    /// sees the old file or the new one, never half of one).
    pub fn save(&self, path: &Path) -> Result<(), SettingsError> {
        let io = |source| SettingsError::Io {
            path: path.to_owned(),
            source,
        };
        let text = serde_json::to_string_pretty(self).map_err(|e| SettingsError::Format {
            path: path.to_owned(),
            message: e.to_string(),
        })?;
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(".partial");
        let tmp = PathBuf::from(tmp);
        {
            use std::io::Write;
            let mut f = std::fs::File::create(&tmp).map_err(io)?;
            f.write_all(text.as_bytes()).map_err(io)?;
            f.sync_all().map_err(io)?;
        }
        std::fs::rename(&tmp, path).map_err(io)
    }

    /// The dimming curve, if set.
    pub fn curve(&self) -> Option<DimmingCurve> {
        match self.dimming_curve? {
            0 => Some(DimmingCurve::Logarithmic),
            1 => Some(DimmingCurve::Linear),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tcp(a: &str) -> Source {
        Source::Tcp(format!("{a}:40000").parse().unwrap())
    }

    #[test]
    fn an_allowlist_open_to_every_address_is_named() {
        let open = |rules: &[&str]| {
            let rules: Vec<String> = rules.iter().map(|r| (*r).to_owned()).collect();
            AccessPolicy::default()
                .with_writers(&rules)
                .unwrap()
                .admits_everyone()
        };
        assert_eq!(open(&["10.0.0.0/8", "0.0.0.0/0"]), Some("0.0.0.0/0".into()));
        assert_eq!(open(&["::/0"]), Some("::/0".into()));
        assert_eq!(
            open(&["10.0.0.0/8", "192.0.2.7", "rtu", "role:operator"]),
            None
        );
        assert_eq!(open(&[]), None);
    }

    #[test]
    fn the_allowlist_admits_exactly_its_sources() {
        let p = AccessPolicy::default();
        assert!(
            !p.may_write(&tcp("127.0.0.1"), 1000, 1),
            "read-only by default"
        );
        assert!(!p.may_write(&Source::Rtu("/dev/ttyS0".into()), 1000, 1));
        assert!(p.may_write(&Source::Internal, 1000, 1));
        let p = AccessPolicy::default()
            .with_writers(&[
                "10.1.2.0/24".into(),
                "192.168.0.7".into(),
                "rtu".into(),
                "role:operator".into(),
                "fd00::/16".into(),
            ])
            .unwrap();
        assert!(p.may_write(&tcp("10.1.2.200"), 1000, 1));
        assert!(!p.may_write(&tcp("10.1.3.1"), 1000, 1));
        assert!(p.may_write(&tcp("192.168.0.7"), 2000, 1));
        assert!(!p.may_write(&tcp("192.168.0.8"), 2000, 1));
        // IPv4 through an IPv6 socket
        let mapped = Source::Tcp("[::ffff:192.168.0.7]:5".parse().unwrap());
        assert!(p.may_write(&mapped, 1000, 1));
        assert!(p.may_write(&Source::Tcp("[fd00::1]:5".parse().unwrap()), 1000, 1));
        assert!(p.may_write(&Source::Rtu("/dev/ttyS0".into()), 1000, 1));
        let tls = |role: Option<&str>| Source::Tls {
            peer: "172.16.0.1:9".parse().unwrap(),
            role: role.map(str::to_owned),
        };
        assert!(p.may_write(&tls(Some("operator")), 1000, 1));
        assert!(!p.may_write(&tls(Some("viewer")), 1000, 1));
        assert!(!p.may_write(&tls(None), 1000, 1));
        for bad in ["10.0.0.0/33", "localhost", "role:", "::1/129", ""] {
            assert!(bad.parse::<WriteRule>().is_err(), "{bad}");
        }
    }

    #[test]
    fn word_order_resolves_client_then_board_client_unit_default() {
        let mut p = AccessPolicy::default();
        p.word_orders.default = WordOrder::Dcba;
        p.word_orders.units.insert(2, WordOrder::Cdab);
        p.word_orders
            .clients
            .insert("10.0.0.5".into(), WordOrder::Badc);
        let mut s = Settings::default();
        assert_eq!(p.word_order(&s, &tcp("10.0.0.9"), 1), WordOrder::Dcba);
        assert_eq!(p.word_order(&s, &tcp("10.0.0.9"), 2), WordOrder::Cdab);
        assert_eq!(p.word_order(&s, &tcp("10.0.0.5"), 2), WordOrder::Badc);
        s.word_orders.insert("10.0.0.5".into(), 0);
        assert_eq!(p.word_order(&s, &tcp("10.0.0.5"), 2), WordOrder::Abcd);
    }

    #[test]
    fn settings_persist_and_are_checked() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("settings.json");
        assert_eq!(Settings::load(&path).unwrap(), Settings::default());
        let mut s = Settings {
            dimming_curve: Some(1),
            ..Settings::default()
        };
        s.word_orders.insert("10.0.0.5".into(), 3);
        s.save(&path).unwrap();
        assert_eq!(Settings::load(&path).unwrap(), s);
        std::fs::write(&path, "{\"dimming_curve\": 7}").unwrap();
        assert!(
            Settings::load(&path)
                .unwrap_err()
                .to_string()
                .contains("dimming_curve")
        );
        std::fs::write(&path, "{\"curve\": 1}").unwrap();
        assert!(Settings::load(&path).is_err());
    }

    #[test]
    fn write_spans() {
        assert_eq!(write_span(&[6, 0x03, 0xE8, 0, 1]), Some((1000, 1)));
        assert_eq!(
            write_span(&[0x10, 0x07, 0xD0, 0, 2, 4, 0, 0, 0, 0]),
            Some((2000, 2))
        );
        assert_eq!(write_span(&[4, 0, 0, 0, 1]), None);
        assert_eq!(write_span(&[0x10]), Some((0, 0)));
        assert_eq!(write_span(&[]), None);
    }
}
