//! `luxnode points --image IMAGE [--format csv|json|ede] [--board FILE | --bacnet-device-id N]`:
//! the integrator's points list ([`luxnode::fieldbus::points`]): every value the node publishes, with its
//! point's name, unit, Modbus address and type, and BACnet object where the node runs BACnet.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use luxnode::fieldbus::points::{ListOptions, points_list, to_csv, to_ede};
use luxnode::points::points_of;
use luxnode::store::Image;
use luxnode::store::file::read_image_file;

/// The list's format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// One line per value, comma-separated, with a header line.
    Csv,
    /// One JSON object: `points` (name, sensor and desk ids) and `values`.
    Json,
    /// The BACnet objects as an EDE file (BIG-EU Engineering Data Exchange, layout 2); needs
    /// BACnet (`--board` with `[bacnet]`, or `--bacnet-device-id`).
    Ede,
}

/// `luxnode points`.
#[derive(clap::Args)]
pub struct Args {
    /// The image: an image file, or a flash file with A/B slots (its newest valid image).
    #[arg(long, value_name = "FILE")]
    image: PathBuf,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Csv)]
    format: Format,
    /// The board the node runs (its `[bacnet]` device, when it serves BACnet/IP).
    #[arg(long, value_name = "FILE", conflicts_with = "bacnet_device_id")]
    board: Option<PathBuf>,
    /// List the BACnet objects of a node with this Device instance (without a board file).
    #[arg(long, value_name = "N")]
    bacnet_device_id: Option<u32>,
}

/// Runs `luxnode points`.
pub fn run(a: &Args) -> Result<()> {
    let bytes = read_image_file(&a.image)?;
    let image = Image::parse(&bytes)
        .with_context(|| format!("{} is not a valid image", a.image.display()))?;
    let device = match (&a.board, a.bacnet_device_id) {
        (Some(path), _) => {
            let board = luxnode::board::Board::load(path)?;
            board
                .bacnet
                .map(|b| (b.server.device.instance, b.server.device.name))
        }
        (None, Some(id)) => {
            let id = luxnode::board::bacnet::check_device_id(id).map_err(anyhow::Error::msg)?;
            Some((id, format!("luxnode {id}")))
        }
        (None, None) => None,
    };
    let points = points_of(&image);
    let luminaires: Vec<u32> = (0..image.luminaires())
        .map(|j| image.luminaire_id(j))
        .collect();
    let has_desks = points.iter().any(|p| p.desk_id().is_some());
    let o = ListOptions {
        bacnet: device.is_some(),
        occupancy: device.is_some() && has_desks,
    };
    let rows = points_list(&points, &luminaires, o);
    match a.format {
        Format::Csv => print!("{}", to_csv(&rows)),
        Format::Json => {
            let v = serde_json::json!({
                "image": image.payload.scene_name,
                "bacnet_device": device.as_ref().map(|d| serde_json::json!({"instance": d.0, "name": d.1})),
                "points": points,
                "values": rows,
            });
            println!("{}", serde_json::to_string_pretty(&v)?);
        }
        Format::Ede => {
            let Some((id, name)) = &device else {
                bail!(
                    "--format ede lists BACnet objects: give --board (with [bacnet]) or --bacnet-device-id"
                );
            };
            print!("{}", to_ede(&rows, image.payload.scene_name, *id, name));
        }
    }
    Ok(())
}
