//! `[bacnet]`: the BACnet/IP server of a board.
//!
//! ```toml
//! [bacnet]
//! bind = "0.0.0.0:47808"       # UDP; default 0.0.0.0:47808
//! device_id = 1201             # Device object instance, 0..=4194302 (required)
//! vendor_id = 65535            # Vendor_Identifier (default 65535: none assigned)
//! location = "floor 2, room 12"
//! description = "open-plan zone B"
//! dcc_password = "..."         # DeviceCommunicationControl allowed with it (default: refused)
//! bbmd = "10.1.0.1:47808"      # register as a foreign device with this BBMD
//! bbmd_ttl_s = 300
//! ```
//! Writes (luminaire levels, desk targets, COV_Increment) follow `[modbus] write_allow`.

use serde::Deserialize;

use crate::bacnet::objects::{DEFAULT_VENDOR_ID, DeviceInfo};
use crate::bacnet::wire::ObjectId;
use crate::fieldbus::bacnet::service::ServerConfig;
use crate::fieldbus::bacnet::{BacnetOptions, BbmdConfig};

/// The `[bacnet]` table.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BacnetToml {
    #[serde(default = "default_bind")]
    bind: String,
    device_id: u32,
    #[serde(default)]
    vendor_id: Option<u16>,
    #[serde(default)]
    location: String,
    #[serde(default)]
    description: Option<String>,
    #[serde(default)]
    dcc_password: Option<String>,
    #[serde(default)]
    bbmd: Option<String>,
    #[serde(default = "default_ttl")]
    bbmd_ttl_s: u16,
}

fn default_bind() -> String {
    "0.0.0.0:47808".into()
}

fn default_ttl() -> u16 {
    300
}

/// Checks a device instance (4194303 is the wildcard, not an instance).
pub fn check_device_id(id: u32) -> Result<u32, String> {
    if id >= ObjectId::MAX_INSTANCE {
        return Err(format!(
            "bacnet device id {id} is outside 0..={}",
            ObjectId::MAX_INSTANCE - 1
        ));
    }
    Ok(id)
}

/// The server options of a `[bacnet]` table for board `model`.
pub fn bacnet_options(t: &BacnetToml, model: &str) -> Result<BacnetOptions, String> {
    let bind = t
        .bind
        .parse()
        .map_err(|e| format!("bacnet.bind {:?}: {e} (expected ADDR:PORT)", t.bind))?;
    let mut device = DeviceInfo::new(check_device_id(t.device_id)?, model);
    device.vendor_id = t.vendor_id.unwrap_or(DEFAULT_VENDOR_ID);
    device.location = t.location.clone();
    if let Some(d) = &t.description {
        device.description = d.clone();
    }
    if let Some(p) = &t.dcc_password
        && (p.is_empty() || p.len() > 20)
    {
        return Err("bacnet.dcc_password: 1 to 20 characters".into());
    }
    let bbmd = match &t.bbmd {
        None => None,
        Some(a) => Some(BbmdConfig {
            address: a
                .parse()
                .map_err(|e| format!("bacnet.bbmd {a:?}: {e} (expected ADDR:PORT)"))?,
            ttl_s: t.bbmd_ttl_s.max(30),
        }),
    };
    Ok(BacnetOptions {
        bind,
        server: ServerConfig {
            device,
            dcc_password: t.dcc_password.clone(),
        },
        bbmd,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<BacnetOptions, String> {
        let t: BacnetToml = toml::from_str(text).map_err(|e| e.to_string())?;
        bacnet_options(&t, "rpi4")
    }

    #[test]
    fn a_bacnet_section_parses_and_bad_values_are_refused() {
        let o = parse(
            "device_id = 1201\nlocation = \"room 12\"\nbbmd = \"10.1.0.1:47808\"\nbbmd_ttl_s = 5",
        )
        .unwrap();
        assert_eq!(o.bind, "0.0.0.0:47808".parse().unwrap());
        assert_eq!(o.server.device.instance, 1201);
        assert_eq!(o.server.device.name, "rpi4 1201");
        assert_eq!(o.server.device.vendor_id, DEFAULT_VENDOR_ID);
        assert_eq!(o.server.dcc_password, None);
        assert_eq!(o.bbmd.map(|b| b.ttl_s), Some(30), "at least 30 s");
        for bad in [
            "device_id = 4194303",
            "bind = \"nowhere\"\ndevice_id = 1",
            "device_id = 1\nbbmd = \"10.1.0.1\"",
            "device_id = 1\ndcc_password = \"\"",
            "device_id = 1\nunknown = 3",
            "location = \"no id\"",
        ] {
            assert!(parse(bad).is_err(), "{bad}");
        }
    }
}
