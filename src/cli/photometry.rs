//! `luxnode photometry FILE`.

use std::path::PathBuf;

use anyhow::{Context, Result};
use luxnode::photometry::{IntensityDistribution, describe_grid};

/// `luxnode photometry`.
#[derive(clap::Args)]
pub struct Args {
    /// The file (EULUMDAT .ldt or IES .ies).
    file: PathBuf,
    /// Print the summary as one JSON object.
    #[arg(long, conflicts_with = "csv")]
    json: bool,
    /// Print the unfolded intensity table as CSV (c_deg,gamma_deg,intensity_cd).
    #[arg(long)]
    csv: bool,
    /// Also write the distribution as EULUMDAT to this file.
    #[arg(long, value_name = "FILE")]
    to_ldt: Option<PathBuf>,
    /// Also write the distribution as IES LM-63-2002 to this file.
    #[arg(long, value_name = "FILE")]
    to_ies: Option<PathBuf>,
}

/// Runs `luxnode photometry`.
pub fn run(a: &Args) -> Result<()> {
    let d = IntensityDistribution::load(&a.file)?;
    if let Some(out) = &a.to_ldt {
        std::fs::write(out, d.to_ldt()?).with_context(|| format!("writing {}", out.display()))?;
    }
    if let Some(out) = &a.to_ies {
        std::fs::write(out, d.to_ies()).with_context(|| format!("writing {}", out.display()))?;
    }
    if a.csv {
        print!("{}", d.to_csv());
        return Ok(());
    }
    let s = d.summary(&a.file.display().to_string());
    if a.json {
        println!("{}", serde_json::to_string_pretty(&s)?);
        return Ok(());
    }
    println!("file:           {}", s.file);
    println!("format:         {}", s.format);
    if !s.luminaire.is_empty() {
        println!("luminaire:      {}", s.luminaire);
    }
    if !s.manufacturer.is_empty() {
        println!("manufacturer:   {}", s.manufacturer);
    }
    println!("symmetry:       {}", d.symmetry());
    println!(
        "C planes:       {} stored, {} after unfolding to 0..360°",
        describe_grid(d.stored_c_deg()),
        s.c_planes_unfolded
    );
    println!("gamma angles:   {}", describe_grid(d.gamma_grid_deg()));
    if s.absolute_photometry {
        println!("photometry:     absolute");
    } else if let (Some(lamp), Some(lor)) = (s.lamp_flux_lm, s.lor_pct) {
        println!("photometry:     relative, lamp flux {lamp:.1} lm, light output ratio {lor:.1} %");
    }
    println!(
        "total flux:     {:.2} lm (downward {:.2} lm, {:.1} %)",
        s.flux_lm,
        s.downward_flux_lm,
        if s.flux_lm > 0.0 {
            100.0 * s.downward_flux_lm / s.flux_lm
        } else {
            0.0
        }
    );
    println!(
        "max intensity:  {:.2} cd at C {}° gamma {}°",
        s.max_cd, s.max_c_deg, s.max_gamma_deg
    );
    if let Some(t) = &d.meta.tilt
        && let (Some(first), Some(last), Some(last_deg)) =
            (t.factors.first(), t.factors.last(), t.angles_deg.last())
    {
        println!(
            "tilt:           TILT=INCLUDE, {} angles, factor {first:.3} at 0° .. {last:.3} at {last_deg}°",
            t.angles_deg.len(),
        );
    }
    for w in &s.warnings {
        println!("warning:        {w}");
    }
    Ok(())
}
