//! `luxnode control --image IMAGE`: the least-power dimming state that meets every desk's
//! target, from the image alone (its response matrix and luminaire fluxes).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use luxnode::control::{
    DEFAULT_TARGET_LX, Demand, LuminairePower, PlanOut, Plant, optimise, scratch_len,
};
use luxnode::dali::{ArcLevel, DimmingCurve};
use luxnode::store::Image;
use luxnode::store::file::read_image_file;

use super::OutputFormat;

/// `luxnode control`.
#[derive(clap::Args)]
pub struct Args {
    /// The commissioned image.
    #[arg(long, value_name = "FILE")]
    image: PathBuf,
    /// Target (maintained) illuminance of every desk, lx.
    #[arg(long, value_name = "LUX", default_value_t = DEFAULT_TARGET_LX)]
    target: f64,
    /// A desk's own target, DESK_ID:LUX (repeat the flag or comma-separate for several desks).
    #[arg(long = "target-desk", value_name = "ID:LUX", value_delimiter = ',')]
    target_desk: Vec<String>,
    /// Daylight on a desk, DESK_ID:LUX (repeat the flag or comma-separate for several desks)
    /// [if absent: none].
    #[arg(long, value_delimiter = ',', value_name = "ID:LUX")]
    daylight: Vec<String>,
    /// Every desk at least this fraction of the mean desk illuminance (0..=1).
    #[arg(long, value_name = "FRACTION")]
    uniformity: Option<f64>,
    /// Rated power of every luminaire at full output, W [if absent: the photometry file's
    /// wattage; its flux / 120 lm/W when the file has none].
    #[arg(long, value_name = "W")]
    rated_power_w: Option<f64>,
    /// Standby power of a luminaire that is off, W.
    #[arg(long, value_name = "W", default_value_t = luxnode::control::DEFAULT_STANDBY_W)]
    standby_power_w: f64,
    /// The lowest arc level a luminaire can be on at (DALI physical minimum level, 1..=254).
    #[arg(long, value_name = "LEVEL", default_value_t = luxnode::control::DEFAULT_MIN_ARC)]
    min_arc: u8,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutputFormat::Csv)]
    format: OutputFormat,
}

fn id_lux(s: &str, what: &str) -> Result<(u32, f64)> {
    let (id, lux) = s
        .split_once(':')
        .with_context(|| format!("{what} {s:?}: want ID:LUX"))?;
    let id: u32 = id
        .trim()
        .parse()
        .with_context(|| format!("{what} {s:?}: desk id"))?;
    let lux: f64 = lux
        .trim()
        .parse()
        .with_context(|| format!("{what} {s:?}: lux"))?;
    if !(lux.is_finite() && (0.0..=1e6).contains(&lux)) {
        bail!("{what} {s:?}: lux must be within 0..=1e6");
    }
    Ok((id, lux))
}

/// Runs `luxnode control`.
pub fn run(a: &Args) -> Result<()> {
    let bytes = read_image_file(&a.image)?;
    let image = Image::parse(&bytes).with_context(|| format!("image {}", a.image.display()))?;
    let (kd, l) = (image.sensors(), image.luminaires());
    let desk_ids: Vec<u32> = (0..kd).map(|k| image.sensor_id(k)).collect();
    let lum_ids: Vec<u32> = (0..l).map(|j| image.luminaire_id(j)).collect();
    if !(a.target.is_finite() && (0.0..=1e6).contains(&a.target)) {
        bail!("--target {}: lux within 0..=1e6", a.target);
    }
    let index = |id: u32, what: &str| {
        desk_ids
            .iter()
            .position(|&d| d == id)
            .with_context(|| format!("{what}: desk {id} is not in the image ({desk_ids:?})"))
    };
    let mut target = vec![a.target; kd];
    for s in &a.target_desk {
        let (id, lux) = id_lux(s, "--target-desk")?;
        target[index(id, "--target-desk")?] = lux;
    }
    let mut daylight = vec![0.0; kd];
    for s in &a.daylight {
        let (id, lux) = id_lux(s, "--daylight")?;
        daylight[index(id, "--daylight")?] = lux;
    }
    let power = luminaire_power(&image, a);
    if let Some(p) = power.iter().find(|p| {
        !(p.full_w.is_finite()
            && p.full_w >= p.standby_w
            && p.standby_w >= 0.0
            && (1..=254).contains(&p.min_arc))
    }) {
        bail!(
            "luminaire power {} W, standby {} W, minimum level {}: want full >= standby >= 0 and a level in 1..=254",
            p.full_w,
            p.standby_w,
            p.min_arc
        );
    }
    let response = image.response_rows_lx(0..kd);
    let curve = DimmingCurve::Logarithmic;
    let plant = Plant {
        desks: kd,
        luminaires: l,
        response_lx: &response,
        power: &power,
        curve,
    };
    let (mut arc, mut lux, mut met) = (vec![ArcLevel::OFF; l], vec![0.0; kd], vec![false; kd]);
    let mut scratch = vec![0.0; scratch_len(kd, l, a.uniformity.is_some())];
    let t0 = std::time::Instant::now();
    let rep = optimise(
        &plant,
        &Demand {
            target_lx: &target,
            daylight_lx: &daylight,
            uniformity: a.uniformity,
        },
        PlanOut {
            arc: &mut arc,
            lux: &mut lux,
            met: &mut met,
        },
        &mut scratch,
    )?;
    let dt = t0.elapsed();
    let fraction = |a: ArcLevel| a.fraction(curve).unwrap_or(0.0);
    let saved_pct = 100.0 * (1.0 - rep.power_w / rep.all_on_w.max(1e-12));
    match a.format {
        OutputFormat::Csv => {
            println!("luminaire_id,arc_level,light_fraction,power_w");
            for j in 0..l {
                let x = fraction(arc[j]);
                println!(
                    "{},{},{:.6},{:.3}",
                    lum_ids[j],
                    arc[j].0,
                    x,
                    power[j].power_w(x)
                );
            }
            println!();
            println!("sensor_id,lux,target_lx,met");
            for k in 0..kd {
                println!(
                    "{},{:.3},{:.1},{}",
                    desk_ids[k],
                    lux[k],
                    target[k],
                    u8::from(met[k])
                );
            }
            println!();
            println!("power_w,all_on_w,saved_pct,lp_bound_w,desks_short");
            println!(
                "{:.3},{:.3},{saved_pct:.2},{:.3},{}",
                rep.power_w, rep.all_on_w, rep.lp_power_w, rep.short
            );
        }
        OutputFormat::Json => {
            let v = serde_json::json!({
                "luminaires": (0..l).map(|j| serde_json::json!({
                    "luminaire_id": lum_ids[j],
                    "arc_level": arc[j].0,
                    "light_fraction": fraction(arc[j]),
                    "power_w": power[j].power_w(fraction(arc[j])),
                })).collect::<Vec<_>>(),
                "desks": (0..kd).map(|k| serde_json::json!({
                    "sensor_id": desk_ids[k],
                    "lux": lux[k],
                    "target_lx": target[k],
                    "daylight_lx": daylight[k],
                    "met": met[k],
                })).collect::<Vec<_>>(),
                "power_w": rep.power_w,
                "all_on_w": rep.all_on_w,
                "saved_pct": saved_pct,
                "lp_bound_w": rep.lp_power_w,
                "desks_short": rep.short,
            });
            println!("{}", serde_json::to_string_pretty(&v)?);
        }
    }
    eprintln!(
        "plan: {:.1} W of {:.1} W all on ({saved_pct:.1} % saved; the continuous optimum {:.1} W), {} desks short, {} simplex iterations, {:.0} µs",
        rep.power_w,
        rep.all_on_w,
        rep.lp_power_w,
        rep.short,
        rep.iterations,
        dt.as_secs_f64() * 1e6
    );
    Ok(())
}

/// Each luminaire's power model: its rated power ([`luxnode::control::rating`]; a warning when
/// it is the assumed efficacy's guess) unless `--rated-power-w` sets every one, with the
/// standby and minimum level of the arguments.
fn luminaire_power(image: &Image<'_>, a: &Args) -> Vec<LuminairePower> {
    let ratings = luxnode::control::rating::rated_powers(image);
    if a.rated_power_w.is_none() {
        let ids: Vec<u32> = (0..image.luminaires())
            .map(|j| image.luminaire_id(j))
            .collect();
        if let Some(w) = luxnode::control::rating::assumed_warning(&ids, &ratings) {
            eprintln!("warning: {w}");
        }
    }
    ratings
        .iter()
        .map(|&r| {
            let mut p = LuminairePower::rated(r);
            if let Some(w) = a.rated_power_w {
                p.full_w = w;
            }
            p.standby_w = a.standby_power_w;
            p.min_arc = a.min_arc;
            p
        })
        .collect()
}
