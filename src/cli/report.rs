//! `luxnode report --image IMAGE --out DIR [--states FILE]`: the commissioning report of an
//! image (feature `report`).

use std::path::PathBuf;

use anyhow::{Context, Result};
use luxnode::render::report::{self, NamedState, ReportOptions};
use luxnode::scene::read_states;
use luxnode::store::Image;
use luxnode::store::file::read_image_file;

/// `luxnode report`.
#[derive(clap::Args)]
pub struct Args {
    /// The image: an image file, or a flash file with A/B slots (its newest valid image).
    #[arg(long, value_name = "FILE")]
    image: PathBuf,
    /// The directory to write report.html and results.json into.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Dimming states to report (`scenario_id,luminaires_on` with ids separated by `;`, the
    /// format of states.csv); the first is the design state of the EN 12464-1 check [if absent:
    /// all on, then each luminaire alone].
    #[arg(long, value_name = "FILE")]
    states: Option<PathBuf>,
    /// Overrides the maintenance factor recorded in the image.
    #[arg(long, value_name = "MF")]
    maintenance_factor: Option<f64>,
    /// The EN 12464-1:2021 context modifiers that apply (§5.3.3: critical visual work, costly
    /// errors, small details or low contrast, long duration, low visual capacity...): each
    /// raises the task area's Ēm one step on the illuminance scale, up to the modified Ēm
    /// (offices: 500 → 750 → 1000 lx).
    #[arg(long, value_name = "N", default_value_t = 0)]
    context_modifiers: u32,
}

/// Runs `luxnode report`.
pub fn run(a: &Args) -> Result<()> {
    let bytes = read_image_file(&a.image)?;
    let image = Image::parse(&bytes)
        .with_context(|| format!("{} is not a valid image", a.image.display()))?;
    let ids: Vec<u32> = (0..image.luminaires())
        .map(|j| image.luminaire_id(j))
        .collect();
    let states = match &a.states {
        Some(p) => {
            let sc = read_states(p)?;
            for s in &sc {
                if let Some(bad) = s.on.iter().find(|id| !ids.contains(id)) {
                    anyhow::bail!(
                        "{}: scenario {}: luminaire {bad} is not in the image (it has {:?})",
                        p.display(),
                        s.id,
                        ids
                    );
                }
            }
            sc.iter()
                .map(|s| NamedState {
                    name: s.id.clone(),
                    levels: s.levels(&ids),
                })
                .collect()
        }
        None => std::iter::once(NamedState {
            name: "all on".into(),
            levels: vec![1.0; ids.len()],
        })
        .chain(ids.iter().enumerate().map(|(j, id)| {
            NamedState {
                name: format!("luminaire {id} alone"),
                levels: (0..ids.len())
                    .map(|k| if k == j { 1.0 } else { 0.0 })
                    .collect(),
            }
        }))
        .collect(),
    };
    let opts = ReportOptions {
        states,
        maintenance_factor: a.maintenance_factor,
        requirement: luxnode::en12464::OFFICE_WRITING_READING
            .with_context_modifiers(a.context_modifiers),
        ..ReportOptions::default()
    };
    let r = report::compute(&image, &opts)?;
    report::write(&r, &a.out)?;
    let x = &r.results;
    println!(
        "{}: report.html, results.json ({} desks, {} states, {} pictures) in {:.2} s",
        a.out.display(),
        x.desks.len(),
        x.states.len(),
        r.pictures.len(),
        x.seconds
    );
    println!("| desk | Ēm (lx) | Emin (lx) | U0 | surrounding Ēm (lx) | EN 12464-1 |");
    println!("|---:|---:|---:|---:|---:|---|");
    for d in &x.desks {
        println!(
            "| {} | {:.0} | {:.0} | {:.2} | {} | {} |",
            d.id,
            d.task.maintained.e_mean_lx,
            d.task.maintained.e_min_lx,
            d.task.maintained.u0,
            d.surrounding
                .as_ref()
                .map_or("–".into(), |s| format!("{:.0}", s.maintained.e_mean_lx)),
            if d.pass { "pass" } else { "fail" }
        );
    }
    print_ugr_and_verdict(x);
    Ok(())
}

/// UGR per desk observer and the overall verdict with its reasons.
fn print_ugr_and_verdict(x: &report::Results) {
    for o in &x.ugr.observers {
        let v = match (&o.ugr, &o.not_computed) {
            (Some(u), _) => format!("{u:.1}"),
            (None, Some(why)) => format!("not computed: {why}"),
            (None, None) => "no luminaire in view".into(),
        };
        println!(
            "UGR desk {}: {v} (eye {:.2}, {:.2}, {:.2} m, L_b {:.1} cd/m²)",
            o.desk, o.eye_m[0], o.eye_m[1], o.eye_m[2], o.l_b_cd_per_m2
        );
    }
    if x.pass {
        println!("EN 12464-1:2021: pass");
    } else {
        println!(
            "EN 12464-1:2021: fail because {}",
            x.fails_because.join("; ")
        );
    }
}
