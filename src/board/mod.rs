//! Board files: hardware as data (`boards/<name>/board.toml`). Core logic never reads them; the
//! binary turns them into typed settings. Unknown keys are errors so a typo fails loudly.

pub mod bacnet;
pub mod camera;
pub mod control;
pub mod hardware;
pub mod peripherals;

use std::path::{Path, PathBuf};

use serde::Deserialize;

/// Where the room model comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SceneSource {
    /// The built-in demo office (`sim::demo`).
    DemoOffice,
    /// A scene directory (CAD input), relative paths resolved against the board file.
    Directory(PathBuf),
}

/// A validated board description.
#[derive(Debug, Clone)]
pub struct Board {
    /// Board name.
    pub name: String,
    /// One line on what the board is.
    pub description: String,
    /// The room model the node works on.
    pub scene: SceneSource,
    /// Modbus: TCP server, RTU line, DALI gateway.
    pub modbus: ModbusBoard,
    /// BACnet/IP (`[bacnet]`), if the board serves it.
    pub bacnet: Option<crate::fieldbus::bacnet::BacnetOptions>,
    /// Engine and store settings (`[engine] preset = "balanced"`; balanced when absent).
    pub preset: crate::preset::Preset,
    /// The installation's maintenance factor for the commissioning report's maintained values
    /// (`[engine] maintenance_factor`, EN 12464-1; 0.8 when absent).
    pub maintenance_factor: f64,
    /// The EN 12464-1:2021 context modifiers the commissioning report applies to the task
    /// areas' Ēm (`[engine] context_modifiers`; 0 when absent: the table's Ēm).
    pub context_modifiers: u32,
    /// The cameras (`[camera]`; simulated when absent).
    pub camera: crate::board::camera::CameraBoard,
    /// Where the flash image lives (`[flash]`; a file next to the board file when absent).
    pub flash: crate::board::camera::FlashBoard,
    /// The I2C bus of the board's peripherals (`[i2c]`), if any.
    pub i2c: Option<crate::board::camera::I2cBoard>,
    /// How often the sensors are checked while serving (`[health] sensor_check_s`, default
    /// 300 s).
    pub sensor_check: std::time::Duration,
    /// Lighting control (`[control]`).
    pub control: crate::node::ControlOptions,
    /// Live light (`[live]`): the cameras at run time.
    pub live: LiveBoard,
    /// Occupancy's hold (`[occupancy] hold_s`, default 900 s: DALI-2 part 303), s: a desk
    /// stays occupied this long after its person was last seen (`crate::occupancy::Hold`).
    pub occupancy_hold_s: f64,
    /// Motion over frames (`[occupancy] static_after_s`, default 1800 s): a head that has not
    /// moved for this long is a thing, not a person (`crate::occupancy::Motion`), s.
    pub occupancy_static_after_s: f64,
    /// The status LED (`[led]`), if any.
    pub led: Option<crate::board::camera::LedBoard>,
    /// Luxmeter readings with every luminaire at full (`[commissioning] luxmeter_rho =
    /// ["SENSOR_ID:LUX", ...]`): commissioning fits the unseen walls' and ceiling's reflectance
    /// to them (`crate::commission::refit`; with the camera's own gain or a hooded ambient
    /// light sensor's, measured directly).
    pub luxmeter_rho: Vec<crate::commission::refit::Reading>,
    /// `[commissioning] force = true`: the node's own commissioning goes on past the refusals
    /// that `luxnode commission --force` overrides (a reflectance refit at its limits), with the
    /// desks it concerns flagged ESTIMATED; default false.
    pub force: bool,
    /// The room plan (`[room] plan = "room.json"`, relative to the board file), read and
    /// checked with the board: commissioning builds the walls, windows and ceiling the cameras
    /// do not see from it.
    pub room_plan: Option<crate::scene::RoomPlan>,
}

/// `[room]`: the room plan.
///
/// ```toml
/// [room]
/// plan = "room.json"   # luxnode-room-plan/1, relative to this file
/// ```
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RoomToml {
    plan: Option<String>,
}

/// `[live]`: live light, the cameras at run time (`crate::live`).
///
/// ```toml
/// [live]
/// enabled = true   # default: on when the image has a live section
/// period_s = 10.0  # a luminance (and depth) frame every period, 1..=3600 s
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct LiveBoard {
    /// Run live light when the image has a live section.
    pub enabled: bool,
    /// Frame period.
    pub period: std::time::Duration,
}

impl Default for LiveBoard {
    fn default() -> Self {
        Self {
            enabled: true,
            period: std::time::Duration::from_secs(10),
        }
    }
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct LiveToml {
    #[serde(default)]
    enabled: Option<bool>,
    #[serde(default)]
    period_s: Option<f64>,
}

/// `[occupancy]`: people at desks from the depth camera (`crate::occupancy`).
///
/// ```toml
/// [occupancy]
/// hold_s = 900.0   # a desk stays occupied this long after its person was last seen, 0..=86400 s
/// static_after_s = 1800.0   # a head still this long is a thing, not a person, 1..=86400 s
/// ```
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct OccupancyToml {
    #[serde(default)]
    hold_s: Option<f64>,
    #[serde(default)]
    static_after_s: Option<f64>,
}

/// `[commissioning]`: what the engineer measured on site.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct CommissioningToml {
    #[serde(default)]
    luxmeter_rho: Vec<String>,
    #[serde(default)]
    force: bool,
}

/// `[engine]`: which preset commissioning uses.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct EngineToml {
    #[serde(default)]
    preset: Option<String>,
    #[serde(default)]
    maintenance_factor: Option<f64>,
    #[serde(default)]
    context_modifiers: u32,
}

/// The board's Modbus settings (`[modbus]`, `[modbus.rtu]`, `[modbus.tls]`,
/// `[modbus.word_order]`, `[gateway]`).
///
/// ```toml
/// [modbus]
/// bind = "0.0.0.0:502"
/// max_connections = 128          # in all (default 128: a BMS with 50 pollers and more)
/// max_per_source = 64            # from one address (default 64)
/// idle_timeout_s = 60
/// write_allow = ["10.0.0.0/24", "rtu", "role:operator"]   # default: nobody (read-only)
/// [modbus.word_order]            # float word order: abcd (default), cdab, badc, dcba
/// default = "abcd"
/// clients = { "10.0.0.7" = "cdab" }
/// units = { "2" = "cdab", "3" = "dcba" }
/// [modbus.tls]                   # Modbus/TCP Security, mutual TLS
/// bind = "0.0.0.0:802"
/// cert = "node.pem"
/// key = "node.key"
/// client_ca = "clients-ca.pem"
/// ```
#[derive(Debug, Clone)]
pub struct ModbusBoard {
    /// TCP address.
    pub bind: std::net::SocketAddr,
    /// TCP connection cap.
    pub max_connections: usize,
    /// TCP connection cap per source address.
    pub max_per_source: usize,
    /// Who may write; word orders.
    pub access: crate::modbus::access::AccessPolicy,
    /// Modbus/TCP Security: address and PEM files.
    pub tls: Option<(std::net::SocketAddr, crate::fieldbus::tls::TlsFiles)>,
    /// TCP idle timeout.
    pub idle_timeout: std::time::Duration,
    /// RTU: device and line settings.
    pub rtu: Option<(String, crate::fieldbus::rtu::RtuOptions)>,
    /// DALI gateway link.
    pub gateway: Option<crate::fieldbus::gateway::GatewayConfig>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ModbusToml {
    #[serde(default = "default_bind")]
    bind: String,
    #[serde(default = "default_max_connections")]
    max_connections: usize,
    #[serde(default)]
    max_per_source: Option<usize>,
    #[serde(default = "default_idle_timeout_s")]
    idle_timeout_s: f64,
    #[serde(default)]
    write_allow: Vec<String>,
    #[serde(default)]
    word_order: Option<WordOrderToml>,
    #[serde(default)]
    tls: Option<TlsToml>,
    #[serde(default)]
    rtu: Option<RtuToml>,
}

impl Default for ModbusToml {
    fn default() -> Self {
        Self {
            bind: default_bind(),
            max_connections: default_max_connections(),
            max_per_source: None,
            idle_timeout_s: default_idle_timeout_s(),
            write_allow: Vec::new(),
            word_order: None,
            tls: None,
            rtu: None,
        }
    }
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct WordOrderToml {
    #[serde(default)]
    default: Option<String>,
    #[serde(default)]
    clients: std::collections::BTreeMap<String, String>,
    #[serde(default)]
    units: std::collections::BTreeMap<String, String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TlsToml {
    #[serde(default = "default_tls_bind")]
    bind: String,
    cert: String,
    key: String,
    client_ca: String,
}

fn default_tls_bind() -> String {
    "0.0.0.0:802".into()
}

/// `[health]`: how often the sensors are checked while the node serves.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct HealthToml {
    #[serde(default)]
    sensor_check_s: Option<f64>,
}

fn word_order(what: &str, name: &str) -> Result<crate::modbus::regmap::WordOrder, String> {
    crate::modbus::regmap::WordOrder::from_name(name)
        .ok_or_else(|| format!("{what} {name:?}: use \"abcd\", \"cdab\", \"badc\" or \"dcba\""))
}

/// The access policy of `[modbus]`: the write allowlist and the word orders.
fn access(m: &ModbusToml) -> Result<crate::modbus::access::AccessPolicy, String> {
    use crate::modbus::access::AccessPolicy;
    let mut p = AccessPolicy::default()
        .with_writers(&m.write_allow)
        .map_err(|e| format!("modbus.{e}"))?;
    if let Some(entry) = p.admits_everyone() {
        tracing::warn!(
            "modbus.write_allow {entry:?} lets every network address write levels, targets and \
             settings; name the BMS and gateway addresses instead"
        );
    }
    if let Some(w) = &m.word_order {
        if let Some(d) = &w.default {
            p.word_orders.default = word_order("modbus.word_order.default", d)?;
        }
        for (client, order) in &w.clients {
            let key = if client == "rtu" {
                client.clone()
            } else {
                client
                    .parse::<std::net::IpAddr>()
                    .map_err(|_| {
                        format!(
                            "modbus.word_order.clients: {client:?} is not an IP address or \"rtu\""
                        )
                    })?
                    .to_string()
            };
            p.word_orders
                .clients
                .insert(key, word_order("modbus.word_order.clients", order)?);
        }
        for (unit, order) in &w.units {
            let u: u8 = unit.parse().map_err(|_| {
                format!("modbus.word_order.units: {unit:?} is not a unit id 0..=255")
            })?;
            p.word_orders
                .units
                .insert(u, word_order("modbus.word_order.units", order)?);
        }
    }
    Ok(p)
}

fn default_bind() -> String {
    crate::serve::DEFAULT_BIND.into()
}
fn default_max_connections() -> usize {
    crate::fieldbus::tcp::DEFAULT_MAX_CONNECTIONS
}
fn default_idle_timeout_s() -> f64 {
    60.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RtuToml {
    device: String,
    #[serde(default = "default_baud")]
    baud: u32,
    #[serde(default)]
    parity: crate::fieldbus::rtu::Parity,
    #[serde(default)]
    stop_bits: Option<u8>,
    unit_id: u8,
}

fn default_baud() -> u32 {
    19200
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BoardToml {
    name: String,
    #[serde(default)]
    description: String,
    scene: SceneToml,
    #[serde(default)]
    modbus: ModbusToml,
    #[serde(default)]
    gateway: Option<crate::fieldbus::gateway::GatewayConfig>,
    #[serde(default)]
    engine: EngineToml,
    #[serde(default)]
    camera: Option<crate::board::camera::CameraToml>,
    #[serde(default)]
    flash: Option<crate::board::camera::FlashToml>,
    #[serde(default)]
    i2c: Option<crate::board::camera::I2cBoard>,
    #[serde(default)]
    health: HealthToml,
    #[serde(default)]
    control: Option<crate::board::control::ControlToml>,
    #[serde(default)]
    live: LiveToml,
    #[serde(default)]
    occupancy: OccupancyToml,
    #[serde(default)]
    led: Option<crate::board::camera::LedBoard>,
    #[serde(default)]
    commissioning: CommissioningToml,
    #[serde(default)]
    room: RoomToml,
    #[serde(default)]
    bacnet: Option<crate::board::bacnet::BacnetToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneToml {
    /// `"demo-office"` or a directory.
    source: String,
}

/// Why a board file was rejected.
#[derive(Debug, thiserror::Error)]
pub enum BoardError {
    /// Unreadable.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not valid TOML or not the expected keys.
    #[error("{}: {message}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// What the TOML reader said (with line and column).
        message: String,
    },
}

impl Board {
    /// Reads and validates a board file.
    pub fn load(path: &Path) -> Result<Board, BoardError> {
        let text = std::fs::read_to_string(path).map_err(|source| BoardError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parses board TOML; `path` names the file in errors and anchors relative paths.
    pub fn parse(text: &str, path: &Path) -> Result<Board, BoardError> {
        let t: BoardToml = toml::from_str(text).map_err(|e| BoardError::Format {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        let scene = match t.scene.source.as_str() {
            "demo-office" => SceneSource::DemoOffice,
            "" => {
                return Err(BoardError::Format {
                    path: path.to_path_buf(),
                    message: "scene.source is empty: use \"demo-office\" or a scene directory"
                        .into(),
                });
            }
            dir => SceneSource::Directory(path.parent().unwrap_or(Path::new(".")).join(dir)),
        };
        let bad = |message: String| BoardError::Format {
            path: path.to_path_buf(),
            message,
        };
        let modbus = modbus_board(
            &t.modbus,
            path.parent().unwrap_or(Path::new(".")),
            t.gateway,
        )
        .map_err(bad)?;
        let sensor_check = match t.health.sensor_check_s {
            None => std::time::Duration::from_secs(300),
            Some(s) if s.is_finite() && (0.1..=86_400.0).contains(&s) => {
                std::time::Duration::from_secs_f64(s)
            }
            Some(s) => {
                return Err(bad(format!(
                    "health.sensor_check_s {s} is outside 0.1..=86400 s"
                )));
            }
        };
        let preset = match &t.engine.preset {
            None => crate::preset::Preset::default(),
            Some(name) => name
                .parse()
                .map_err(|e| bad(format!("engine.preset: {e}")))?,
        };
        let maintenance_factor = crate::en12464::check_maintenance_factor(
            t.engine
                .maintenance_factor
                .unwrap_or(crate::en12464::DEFAULT_MAINTENANCE_FACTOR),
        )
        .map_err(|e| bad(format!("engine.maintenance_factor: {e}")))?;
        let base = path.parent().unwrap_or(Path::new("."));
        let camera = crate::board::camera::camera(t.camera, base).map_err(|e| bad(e.0))?;
        let flash = crate::board::camera::flash(t.flash, base).map_err(|e| bad(e.0))?;
        if let Some(i) = &t.i2c {
            i.validate().map_err(|e| bad(e.0))?;
        }
        let control = crate::board::control::control(t.control).map_err(|e| bad(e.0))?;
        let live = LiveBoard {
            enabled: t.live.enabled.unwrap_or(true),
            period: match t.live.period_s {
                None => LiveBoard::default().period,
                Some(s) if s.is_finite() && (1.0..=3600.0).contains(&s) => {
                    std::time::Duration::from_secs_f64(s)
                }
                Some(s) => {
                    return Err(bad(format!("live.period_s {s} is outside 1..=3600 s")));
                }
            },
        };
        if let Some(l) = &t.led {
            l.validate().map_err(|e| bad(e.0))?;
        }
        let occupancy_hold_s = t
            .occupancy
            .hold_s
            .unwrap_or(crate::occupancy::DEFAULT_HOLD_S);
        crate::occupancy::Hold::new(0, occupancy_hold_s)
            .map_err(|e| bad(format!("occupancy.hold_s: {e}")))?;
        let motion = crate::occupancy::MotionSettings::default();
        let occupancy_static_after_s = t.occupancy.static_after_s.unwrap_or(motion.static_after_s);
        crate::occupancy::Motion::new(crate::occupancy::MotionSettings {
            static_after_s: occupancy_static_after_s,
            ..motion
        })
        .map_err(|_| {
            bad(format!(
                "occupancy.static_after_s {occupancy_static_after_s}: 1..=86400 s"
            ))
        })?;
        let luxmeter_rho = t
            .commissioning
            .luxmeter_rho
            .iter()
            .map(|s| crate::commission::refit::parse_reading(s))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| bad(format!("commissioning.luxmeter_rho: {e}")))?;
        // the sensors are the scene's, checked when it is loaded; here the values and repeats
        let ids: Vec<u32> = luxmeter_rho.iter().map(|r| r.sensor_id).collect();
        crate::commission::refit::check(&luxmeter_rho, &ids)
            .map_err(|e| bad(format!("commissioning.luxmeter_rho: {e}")))?;
        let room_plan = match t.room.plan.as_deref() {
            None => None,
            Some(file) => {
                let (plan, warnings) = crate::scene::RoomPlan::load(&base.join(file))
                    .map_err(|e| bad(format!("room.plan: {e}")))?;
                for w in warnings {
                    tracing::warn!("{w}");
                }
                Some(plan)
            }
        };
        let bacnet = t
            .bacnet
            .as_ref()
            .map(|b| crate::board::bacnet::bacnet_options(b, &t.name))
            .transpose()
            .map_err(bad)?;
        if t.commissioning.force {
            tracing::warn!(
                "board {}: [commissioning] force = true: a reflectance refit at its limits is \
                 accepted (its desks flagged ESTIMATED) instead of refused",
                t.name
            );
        }
        Ok(Board {
            bacnet,
            room_plan,
            force: t.commissioning.force,
            luxmeter_rho,
            control,
            live,
            occupancy_hold_s,
            occupancy_static_after_s,
            preset,
            maintenance_factor,
            context_modifiers: t.engine.context_modifiers,
            name: t.name,
            description: t.description,
            scene,
            sensor_check,
            modbus,
            camera,
            flash,
            i2c: t.i2c,
            led: t.led,
        })
    }
}

/// `[modbus]` and `[gateway]`: the servers' addresses and caps, the access policy, TLS, the
/// RTU line, the gateway link (`dir`: the board file's directory).
fn modbus_board(
    m: &ModbusToml,
    dir: &Path,
    gateway: Option<crate::fieldbus::gateway::GatewayConfig>,
) -> Result<ModbusBoard, String> {
    let bind = m
        .bind
        .parse()
        .map_err(|e| format!("modbus.bind {:?}: {e} (expected ADDR:PORT)", m.bind))?;
    if m.max_connections == 0 || m.max_connections > 1024 {
        return Err(format!(
            "modbus.max_connections {} is outside 1..=1024",
            m.max_connections
        ));
    }
    let max_per_source = m
        .max_per_source
        .unwrap_or(crate::fieldbus::tcp::DEFAULT_MAX_PER_SOURCE.min(m.max_connections));
    if max_per_source == 0 || max_per_source > m.max_connections {
        return Err(format!(
            "modbus.max_per_source {max_per_source} is outside 1..=max_connections ({})",
            m.max_connections
        ));
    }
    let policy = access(m)?;
    let tls = match &m.tls {
        None => None,
        Some(t) => {
            let addr = t
                .bind
                .parse()
                .map_err(|e| format!("modbus.tls.bind {:?}: {e} (expected ADDR:PORT)", t.bind))?;
            Some((
                addr,
                crate::fieldbus::tls::TlsFiles {
                    cert: dir.join(&t.cert),
                    key: dir.join(&t.key),
                    client_ca: dir.join(&t.client_ca),
                },
            ))
        }
    };
    if !(m.idle_timeout_s.is_finite() && m.idle_timeout_s > 0.0 && m.idle_timeout_s < 1e6) {
        return Err(format!(
            "modbus.idle_timeout_s {} must be a positive number of seconds",
            m.idle_timeout_s
        ));
    }
    let rtu = match &m.rtu {
        None => None,
        Some(r) => {
            let options = crate::fieldbus::rtu::RtuOptions {
                unit_id: r.unit_id,
                baud: r.baud,
                parity: r.parity,
                stop_bits: r.stop_bits.unwrap_or(
                    if r.parity == crate::fieldbus::rtu::Parity::None {
                        2
                    } else {
                        1
                    },
                ),
            };
            options.validate().map_err(|e| format!("modbus.rtu: {e}"))?;
            Some((r.device.clone(), options))
        }
    };
    if let Some(g) = &gateway {
        g.validate().map_err(|e| format!("gateway: {e}"))?;
    }
    Ok(ModbusBoard {
        bind,
        max_connections: m.max_connections,
        max_per_source,
        access: policy,
        tls,
        idle_timeout: std::time::Duration::from_secs_f64(m.idle_timeout_s),
        rtu,
        gateway,
    })
}

#[cfg(all(test, feature = "sim"))]
mod tests {
    use super::*;

    #[test]
    fn sim_board_file_parses() {
        let b = Board::load(Path::new("boards/sim/board.toml")).unwrap();
        assert_eq!(b.name, "sim");
        assert_eq!(b.scene, SceneSource::DemoOffice);
        assert_eq!(b.modbus.bind.to_string(), "127.0.0.1:1502");
        assert!(b.modbus.rtu.is_none());
    }

    #[test]
    fn modbus_settings_are_checked() {
        let base = "name = \"x\"\n[scene]\nsource = \"demo-office\"\n";
        let ok = format!(
            "{base}[modbus]\nbind = \"0.0.0.0:502\"\n[modbus.rtu]\ndevice = \"/dev/ttyAMA0\"\nunit_id = 7\nparity = \"none\"\n[gateway]\naddress = \"10.0.0.9:502\"\n[gateway.levels]\nbase = 0\n"
        );
        let b = Board::parse(&ok, Path::new("b.toml")).unwrap();
        let (dev, line) = b.modbus.rtu.unwrap();
        assert_eq!(
            (dev.as_str(), line.unit_id, line.stop_bits),
            ("/dev/ttyAMA0", 7, 2)
        );
        assert!(b.modbus.gateway.is_some());
        for (bad, says) in [
            ("[modbus]\nbind = \"localhost\"\n", "modbus.bind"),
            ("[modbus]\nmax_connections = 0\n", "max_connections"),
            ("[modbus]\nidle_timeout_s = -1\n", "idle_timeout_s"),
            (
                "[modbus.rtu]\ndevice = \"/dev/x\"\nunit_id = 0\n",
                "unit id",
            ),
            (
                "[modbus.rtu]\ndevice = \"/dev/x\"\nunit_id = 1\nbaud = 7\n",
                "baud",
            ),
            (
                "[gateway]\naddress = \"nowhere\"\n[gateway.levels]\nbase = 0\n",
                "gateway",
            ),
        ] {
            let e = Board::parse(&format!("{base}{bad}"), Path::new("b.toml")).unwrap_err();
            assert!(e.to_string().contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn engine_preset_is_chosen_and_checked() {
        use crate::preset::Preset;
        let base = "name = \"x\"\n[scene]\nsource = \"demo-office\"\n";
        let b = Board::parse(base, Path::new("b.toml")).unwrap();
        assert_eq!(b.preset, Preset::Balanced);
        let b = Board::parse(
            &format!("{base}[engine]\npreset = \"fast\"\n"),
            Path::new("b.toml"),
        )
        .unwrap();
        assert_eq!(b.preset, Preset::Fast);
        let e = Board::parse(
            &format!("{base}[engine]\npreset = \"quick\"\n"),
            Path::new("b.toml"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("engine.preset"), "{e}");
        assert!(e.to_string().contains("\"accurate\""), "{e}");
        let e =
            Board::parse(&format!("{base}[engine]\nrays = 10\n"), Path::new("b.toml")).unwrap_err();
        assert!(e.to_string().contains("rays"), "{e}");
    }

    /// `[engine] context_modifiers` reaches the board (0 when absent), and the report's
    /// requirement raised from it: one modifier, the office's 500 lx becomes 750 lx.
    #[test]
    fn engine_context_modifiers_are_read() {
        let base = "name = \"x\"\n[scene]\nsource = \"demo-office\"\n";
        let b = Board::parse(base, Path::new("b.toml")).unwrap();
        assert_eq!(b.context_modifiers, 0);
        let b = Board::parse(
            &format!("{base}[engine]\ncontext_modifiers = 1\n"),
            Path::new("b.toml"),
        )
        .unwrap();
        assert_eq!(b.context_modifiers, 1);
        let req =
            crate::en12464::OFFICE_WRITING_READING.with_context_modifiers(b.context_modifiers);
        assert_eq!(req.task_e_m_lx(), 750.0);
        assert!(
            Board::parse(
                &format!("{base}[engine]\ncontext_modifiers = -1\n"),
                Path::new("b.toml")
            )
            .is_err()
        );
    }

    #[test]
    fn typos_are_errors() {
        let e = Board::parse(
            "name = \"x\"\n[scene]\nsourse = \"demo-office\"\n",
            Path::new("b.toml"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("sourse"), "{e}");
        let e = Board::parse(
            "name = \"x\"\n[scene]\nsource = \"\"\n",
            Path::new("b.toml"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("empty"), "{e}");
        let b = Board::parse(
            "name = \"x\"\n[scene]\nsource = \"../rooms/a\"\n",
            Path::new("/etc/luxnode/board.toml"),
        )
        .unwrap();
        assert_eq!(
            b.scene,
            SceneSource::Directory(PathBuf::from("/etc/luxnode/../rooms/a"))
        );
    }
}

#[cfg(all(test, feature = "sim"))]
mod camera_section_tests {
    use super::*;
    use crate::board::camera::{CameraBoard, ColourBoard, FlashBoard, TofBoard};

    #[test]
    fn every_board_file_parses_and_validates() {
        let mut n = 0;
        for e in std::fs::read_dir("boards").unwrap() {
            let dir = e.unwrap().path();
            let file = dir.join("board.toml");
            if !file.exists() {
                continue;
            }
            let b = Board::load(&file).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(
                Some(b.name.as_str()),
                dir.file_name().and_then(|n| n.to_str())
            );
            assert!(
                dir.join("wiring.md").exists(),
                "{}: no wiring.md",
                dir.display()
            );
            n += 1;
        }
        assert!(n >= 3, "{n} boards");
        let rpi = Board::load(Path::new("boards/rpi4/board.toml")).unwrap();
        match &rpi.camera {
            CameraBoard::Hardware {
                tof: TofBoard::A010 {
                    device, options, ..
                },
                colour: ColourBoard::V4l2 { device: video, .. },
            } => {
                assert_eq!(
                    (device.as_str(), video.as_str()),
                    ("/dev/ttyUSB0", "/dev/video0")
                );
                assert_eq!(options.unit_mm, 10);
            }
            other => panic!("{other:?}"),
        }
        let sim = Board::load(Path::new("boards/sim/board.toml")).unwrap();
        assert!(matches!(sim.camera, CameraBoard::Sim { faults: None, .. }));
        assert!(matches!(sim.flash, FlashBoard::File { .. }));
    }

    /// No board file carries a setting the node then refuses: every hardware board passes the
    /// node's pre-flight (its ToF calibration loads and its ToF camera reaches the floor; the
    /// A010's frame rate fits its link, checked at parse).
    #[test]
    fn every_board_passes_the_nodes_checks() {
        use crate::board::camera::TofBoard;
        for name in ["rpi4", "rock5b"] {
            let b = Board::load(&Path::new("boards").join(name).join("board.toml")).unwrap();
            let pre = crate::board::hardware::preflight(&b.camera)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            match &b.camera {
                CameraBoard::Hardware {
                    tof: TofBoard::A010 { .. },
                    ..
                } => {
                    // 2.45 m: the finest unit reaching 2.45 m × 1.02 is 10 mm
                    assert_eq!(pre.a010_unit_mm, Some(10), "{name}");
                    assert!((pre.floor_mm - 2450.0).abs() < 1.0, "{name}");
                }
                CameraBoard::Hardware {
                    tof: TofBoard::V4l2 { max_range_m, .. },
                    ..
                } => assert!(pre.floor_mm < max_range_m * 1000.0, "{name}"),
                other => panic!("{name}: {other:?}"),
            }
        }
        let rock = Board::load(Path::new("boards/rock5b/board.toml")).unwrap();
        assert_eq!(
            rock.flash,
            FlashBoard::Mtd {
                device: "/dev/mtd2".into()
            }
        );
    }

    /// The A010 on a 2.8 m ceiling (the demo office, camera flush at 2.78 m) is refused with the
    /// reason and the remedy; a unit too fine for the floor too; the UART's frame budget.
    #[test]
    fn a_tof_that_does_not_reach_the_floor_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let cal = |z: f64| {
            format!(
                "{{\"position\": [4.0, 3.0, {z}], \"R_world_from_camera\": [[0,1,0],[1,0,0],[0,0,-1]], \"width\": 100, \"height\": 100, \"fx\": 71.4, \"fy\": 86.6, \"cx\": 49.5, \"cy\": 49.5}}"
            )
        };
        let board = |z: f64, extra: &str| {
            std::fs::write(dir.path().join("tof.json"), cal(z)).unwrap();
            let text = format!(
                "name = \"x\"\n[scene]\nsource = \"demo-office\"\n[camera]\nsource = \"hardware\"\n[camera.tof]\ndriver = \"a010\"\ndevice = \"/dev/ttyS4\"\nbaud = 921600\ndisp = 4\nfps = 9\ncalibration = \"tof.json\"\n{extra}[camera.colour]\ndriver = \"v4l2\"\ndevice = \"/dev/video0\"\nwidth = 640\nheight = 480\nformat = \"yuyv\"\nexposure_s = 0.01\ncalibration_cd_m2_s = 10\n"
            );
            Board::parse(&text, &dir.path().join("board.toml"))
        };
        let b = board(2.78, "").unwrap();
        let e = crate::board::hardware::preflight(&b.camera)
            .unwrap_err()
            .to_string();
        assert!(e.contains("2.78 m") && e.contains("2.50 m"), "{e}");
        assert!(e.contains("v4l2"), "{e}");
        // 1.60 m: unit 7 (1.778 m) is the finest that reaches 1.632 m
        let b = board(1.6, "").unwrap();
        let pre = crate::board::hardware::preflight(&b.camera).unwrap();
        assert_eq!(pre.a010_unit_mm, Some(7));
        let b = board(2.4, "unit_mm = 5\n").unwrap();
        let e = crate::board::hardware::preflight(&b.camera)
            .unwrap_err()
            .to_string();
        assert!(e.contains("unit_mm 5") && e.contains("unit_mm = 10"), "{e}");
        // 921 600 baud carries 9.2 frames/s: 15 is refused at parse
        let e = board(2.4, "").map(|_| ()).and_then(|_| {
            Board::parse(
                &std::fs::read_to_string("boards/rpi4/board.toml")
                    .unwrap()
                    .replace("disp = 2 ", "disp = 4 ")
                    .replace("baud = 115200 ", "baud = 921600 ")
                    .replace("fps = 10 ", "fps = 15 "),
                Path::new("boards/rpi4/board.toml"),
            )
            .map(|_| ())
        });
        let e = e.unwrap_err().to_string();
        assert!(
            e.contains("at most 9.2 frames/s") && e.contains("fps <= 9"),
            "{e}"
        );
    }

    #[test]
    fn camera_flash_and_i2c_sections_are_checked() {
        let base = "name = \"x\"\n[scene]\nsource = \"demo-office\"\n";
        let hw = "[camera]\nsource = \"hardware\"\n[camera.tof]\ndriver = \"a010\"\ndevice = \"/dev/ttyUSB0\"\ncalibration = \"c.json\"\n[camera.colour]\ndriver = \"v4l2\"\ndevice = \"/dev/video0\"\nwidth = 640\nheight = 480\nformat = \"yuyv\"\nexposure_s = 0.01\ncalibration_cd_m2_s = 10\n";
        let b = Board::parse(&format!("{base}{hw}"), Path::new("/etc/luxnode/board.toml")).unwrap();
        match b.camera {
            CameraBoard::Hardware {
                tof: TofBoard::A010 {
                    calibration, baud, ..
                },
                ..
            } => {
                assert_eq!(calibration, PathBuf::from("/etc/luxnode/c.json"));
                assert_eq!(baud, 115_200);
            }
            other => panic!("{other:?}"),
        }
        // no [camera]: simulated; no [flash]: a file next to the board file
        let b = Board::parse(base, Path::new("/etc/luxnode/board.toml")).unwrap();
        assert!(matches!(b.camera, CameraBoard::Sim { .. }));
        assert!(
            matches!(b.flash, FlashBoard::File { ref path, .. } if path == Path::new("/etc/luxnode/flash.img"))
        );
        for (bad, says) in [
            ("[camera]\nsource = \"usb\"\n", "camera.source"),
            (
                "[camera]\nsource = \"sim\"\n[camera.sim]\nrange_noise = 0.01\n",
                "range_noise",
            ),
            (
                "[camera]\nsource = \"sim\"\n[camera.sim]\ndropout_chance = 2\n",
                "dropout_chance",
            ),
            (
                "[camera]\nsource = \"sim\"\n[camera.sim.faults]\ntimeout_chance = -1\n",
                "timeout_chance",
            ),
            (
                "[camera]\nsource = \"sim\"\n[camera.sim]\nscenario = \"no-such-day.toml\"\n",
                "camera.sim.scenario",
            ),
            ("[camera]\nsource = \"replay\"\n", "camera.replay"),
            (
                "[camera]\nsource = \"sim\"\n[camera.replay]\ndir = \"x\"\n",
                "camera.replay is given",
            ),
            ("[camera]\nsource = \"hardware\"\n", "camera.tof"),
            (&hw.replace("a010", "vl53l5"), "vl53l5"),
            (&hw.replace("/dev/ttyUSB0", "COM3"), "camera.tof.device"),
            (
                &hw.replace("driver = \"a010\"", "driver = \"a010\"\nfps = 40"),
                "fps",
            ),
            (
                &hw.replace("driver = \"a010\"", "driver = \"a010\"\nbaud = 1234"),
                "baud",
            ),
            (&hw.replace("yuyv", "mjpeg"), "mjpeg"),
            (
                &hw.replace("exposure_s = 0.01", "exposure_s = 0"),
                "exposure_s",
            ),
            ("[flash]\nkind = \"nand\"\n", "flash.kind"),
            ("[flash]\nkind = \"file\"\n", "flash.path"),
            (
                "[flash]\nkind = \"file\"\npath = \"f\"\nsize_bytes = 1000\n",
                "size_bytes",
            ),
            ("[flash]\nkind = \"mtd\"\ndevice = \"/dev/sda\"\n", "MTD"),
            (
                "[flash]\nkind = \"mtd\"\ndevice = \"/dev/mtd0\"\npath = \"x\"\n",
                "only flash.device",
            ),
            ("[i2c]\nbus = \"i2c-1\"\n", "i2c.bus"),
            ("[i2c]\nbus = \"/dev/i2c-1\"\nclock_hz = 5\n", "clock_hz"),
            ("[i2c]\nbus = \"/dev/i2c-1\"\nspeed = 5\n", "speed"),
        ] {
            let e = Board::parse(&format!("{base}{bad}"), Path::new("b.toml")).unwrap_err();
            assert!(e.to_string().contains(says), "{bad}: {e}");
        }
        let b = Board::parse(
            &format!("{base}[flash]\nkind = \"mtd\"\ndevice = \"/dev/mtd2\"\n"),
            Path::new("b.toml"),
        )
        .unwrap();
        assert_eq!(
            b.flash,
            FlashBoard::Mtd {
                device: "/dev/mtd2".into()
            }
        );
    }
}
