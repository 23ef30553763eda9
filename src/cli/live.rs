//! `luxnode live --image IMAGE --frame FRAME.png --arc A1,A2,...`: live light from one frame, for
//! scripts and checks: the image's live-light section, a luminance frame in the capture set's
//! 16-bit encoding (the camera and its gain are those stored in the image), the luminaires'
//! DALI arc levels while it was taken, and optionally a depth frame (mm along the optical axis)
//! for the covering check and occupancy. Prints per desk sensor the total, artificial and
//! daylight lux, where the value comes from (measured on the desk top, or inferred), the flags
//! and whether its desk is occupied (`1`, `0`, empty for unknown or without a depth frame;
//! docs/occupancy.md).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use luxnode::camera::capture::read_frame16;
use luxnode::dali::{ArcLevel, DimmingCurve};
use luxnode::live::{Live, LiveFrame, LiveModel, LiveSettings, Source, flags};
use luxnode::live_section::occupancy_map;
use luxnode::occupancy::{Occupancy, OccupancySettings, Occupied};
use luxnode::store::Image;
use luxnode::store::file::read_image_file;

use super::OutputFormat;

/// `luxnode live`.
#[derive(clap::Args)]
pub struct Args {
    /// The commissioned image (with its live-light section).
    #[arg(long, value_name = "FILE")]
    image: PathBuf,
    /// A luminance frame: 16-bit greyscale PNG, value × the image's camera gain = cd/m²,
    /// 65535 saturated, 0 no data.
    #[arg(long, value_name = "FILE")]
    frame: PathBuf,
    /// One DALI arc level per luminaire while the frame was taken (0 off, 1..=254), in the
    /// image's luminaire order.
    #[arg(long, value_name = "LEVEL,...", value_delimiter = ',', required = true)]
    arc: Vec<String>,
    /// The depth frame taken with it: 16-bit PNG, mm along the optical axis, 0 no return.
    #[arg(long, value_name = "FILE")]
    depth: Option<PathBuf>,
    /// The luminaires' dimming curve.
    #[arg(long, value_enum, default_value_t = Curve::Logarithmic)]
    curve: Curve,
    /// When the frame was taken, RFC 3339 (`2026-03-21T12:00:00Z`, or with an offset): the
    /// sun's position for the sky fit through the room plan's windows the camera does not see.
    /// Required when the image has daylight coefficients; a time in the future is refused.
    #[arg(long, value_name = "RFC3339")]
    pub time: Option<String>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutputFormat::Csv)]
    format: OutputFormat,
    /// Time this many more updates with the same frame and print the cost of one (the live
    /// update's time on this image, sky fit included; docs/live.md).
    #[arg(long, value_name = "N", default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=10_000))]
    repeat: u32,
}

/// `--curve`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Curve {
    /// IEC 62386-102 logarithmic.
    Logarithmic,
    /// IEC 62386-207 linear.
    Linear,
}

/// Runs `luxnode live`.
pub fn run(a: &Args) -> Result<()> {
    let bytes = read_image_file(&a.image)?;
    let image = Image::parse(&bytes).with_context(|| format!("image {}", a.image.display()))?;
    let model = LiveModel::new(&image).with_context(|| {
        format!(
            "image {}: no live light (an image commissioned without a camera, or by a build \
             before live light)",
            a.image.display()
        )
    })?;
    let curve = match a.curve {
        Curve::Logarithmic => DimmingCurve::Logarithmic,
        Curve::Linear => DimmingCurve::Linear,
    };
    let n = image.luminaires();
    if a.arc.len() != n {
        bail!(
            "--arc: {} levels given, the image has {n} luminaires",
            a.arc.len()
        );
    }
    let mut levels = Vec::with_capacity(n);
    for s in &a.arc {
        let arc: u8 = s
            .trim()
            .parse()
            .ok()
            .filter(|&x| x <= 254)
            .with_context(|| format!("--arc {s:?}: an arc level is 0..=254"))?;
        levels.push(ArcLevel(arc).fraction(curve).unwrap_or(0.0));
    }
    let (w, h) = model.frame_size();
    let frame = read_frame16(&a.frame)?;
    if (frame.width, frame.height) != (w, h) {
        bail!(
            "frame {}: {}x{} pixels, the image's camera takes {w}x{h}",
            a.frame.display(),
            frame.width,
            frame.height
        );
    }
    let depth = match &a.depth {
        None => None,
        Some(p) => {
            let d = read_frame16(p)?;
            if (d.width, d.height) != (w, h) {
                bail!(
                    "depth {}: {}x{} pixels, the image's camera takes {w}x{h}",
                    p.display(),
                    d.width,
                    d.height
                );
            }
            Some(d)
        }
    };
    let gain = model.gain();
    if !(gain.is_finite() && gain > 0.0) {
        bail!(
            "image {}: its camera has no luminance calibration (gain), so a frame cannot be read",
            a.image.display()
        );
    }
    let mut live = Live::new(model, LiveSettings::default())?;
    live.set_time(frame_time(a.time.as_deref(), live.has_sky())?);
    let f = LiveFrame {
        width: w,
        height: h,
        luminance: &frame.data,
        cd_m2_per_unit: gain,
        depth_mm: depth.as_ref().map(|d| &d.data[..]),
        taken_s: 0.0,
    };
    let desks = live.update(&f, &levels, 0.0)?.to_vec();
    time_updates(&mut live, &f, &levels, a.repeat)?;
    if live.sky_type() > 0 {
        tracing::info!(
            "live: the daylight through the unseen windows is fitted by CIE sky type {}",
            live.sky_type()
        );
    }
    let occupied = occupancy(&image, w, h, depth.as_ref().map(|d| &d.data[..]));
    let occupied_csv = |k: usize| {
        occupied
            .get(k)
            .copied()
            .flatten()
            .map_or("", |o| o.as_csv())
    };
    let source = |s: Source| match s {
        Source::Model => "model",
        Source::Measured => "measured",
        Source::Inferred => "inferred",
    };
    match a.format {
        OutputFormat::Csv => {
            // the table in one write: no log line can land between its rows
            let mut table = String::from(
                "sensor_id,lux_total,lux_artificial,lux_daylight,source,flags,uncertainty_lx,occupied\n",
            );
            for (k, d) in desks.iter().enumerate() {
                table.push_str(&format!(
                    "{},{},{},{},{},{},{},{}\n",
                    d.id,
                    csv_lx(d.total_lx),
                    csv_lx(d.artificial_lx),
                    csv_lx(d.daylight_lx),
                    source(d.source),
                    flags::describe(d.flags),
                    csv_lx(d.uncertainty_lx),
                    occupied_csv(k)
                ));
            }
            print!("{table}");
        }
        OutputFormat::Json => {
            let v: Vec<serde_json::Value> = desks
                .iter()
                .enumerate()
                .map(|(k, d)| {
                    let occ = occupied_csv(k);
                    serde_json::json!({
                        "sensor_id": d.id,
                        "lux_total": d.total_lx,
                        "lux_artificial": d.artificial_lx,
                        "lux_daylight": d.daylight_lx,
                        "uncertainty_lx": d.uncertainty_lx,
                        "source": source(d.source),
                        "flags": flags::describe(d.flags),
                        "occupied": occ.parse::<u8>().ok(),
                    })
                })
                .collect();
            println!("{}", serde_json::to_string_pretty(&v)?);
        }
    }
    Ok(())
}

/// Per sensor (the image's order), the occupancy of its desk from the depth frame (issue 29):
/// `None` without a depth frame, for a sensor on no desk, or an image without desks.
fn occupancy(image: &Image<'_>, w: u32, h: u32, depth_mm: Option<&[u16]>) -> Vec<Option<Occupied>> {
    let none = vec![None; image.sensors()];
    let Some(depth_mm) = depth_mm else {
        return none;
    };
    let (map, sensor_desk) = match occupancy_map(image, OccupancySettings::default()) {
        Ok(m) => m,
        Err(e) => {
            tracing::warn!("live: no occupancy: {e}");
            return none;
        }
    };
    let mut occupancy = Occupancy::new(map);
    let report = occupancy.update(w, h, Some(depth_mm));
    if report.status != 0 {
        tracing::warn!(
            "live: occupancy unknown: the depth frame is unusable (status {:#x})",
            report.status
        );
    }
    sensor_desk
        .iter()
        .map(|k| k.and_then(|k| report.desks.get(k)).map(|d| d.state))
        .collect()
}

/// Most a frame's time may lie ahead of this machine's clock (clock skew), s.
const FUTURE_TOLERANCE_S: f64 = 300.0;

/// The frame's time from `--time`: parsed, not in the future; required when the image has
/// daylight coefficients (the sun's position decides the sky's shape).
fn frame_time(text: Option<&str>, required: bool) -> Result<Option<luxnode::sky::UnixTime>> {
    let Some(text) = text else {
        if required {
            bail!(
                "--time RFC3339 is required: the image has daylight coefficients (a room plan \
                 with windows the camera does not see), and the sky fit needs the sun's \
                 position when the frame was taken (e.g. --time 2026-03-21T12:00:00Z)"
            );
        }
        return Ok(None);
    };
    let t = luxnode::sky::parse_rfc3339(text).map_err(|e| {
        anyhow::anyhow!("--time {text:?}: {e} (RFC 3339, e.g. 2026-03-21T12:00:00Z)")
    })?;
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0);
    if t.as_seconds_f64() > now + FUTURE_TOLERANCE_S {
        bail!(
            "--time {text}: in the future (this machine's clock reads {:.0} s earlier); a frame \
             is live light of a moment that has been",
            t.as_seconds_f64() - now
        );
    }
    Ok(Some(t))
}

/// `--repeat`: `n` more updates of the same frame, a second apart; their cost on stderr.
fn time_updates(live: &mut Live, f: &LiveFrame<'_>, levels: &[f64], n: u32) -> Result<()> {
    if n == 0 {
        return Ok(());
    }
    let mut ms = Vec::with_capacity(n as usize);
    for i in 1..=n {
        let frame = LiveFrame {
            taken_s: f64::from(i),
            ..*f
        };
        let t = std::time::Instant::now();
        live.update(&frame, levels, f64::from(i))?;
        ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    ms.sort_by(f64::total_cmp);
    eprintln!(
        "live update: {n} updates, median {:.2} ms, max {:.2} ms (sky fit {})",
        ms[ms.len() / 2],
        ms[ms.len() - 1],
        if live.sky_type() > 0 { "on" } else { "off" }
    );
    Ok(())
}

/// A lux value for the CSV: two decimals, or an empty field when the node cannot estimate it
/// (NaN, flagged `not_estimated`): unknown is never printed as a number (issue 31).
fn csv_lx(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.2}")
    } else {
        String::new()
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn an_unknown_value_is_an_empty_csv_field() {
        assert_eq!(super::csv_lx(512.345), "512.35");
        assert_eq!(super::csv_lx(0.0), "0.00");
        assert_eq!(super::csv_lx(f64::NAN), "");
        assert_eq!(super::csv_lx(f64::INFINITY), "");
    }
}
