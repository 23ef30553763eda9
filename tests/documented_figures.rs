//! The figures README.md publishes, measured again and compared with what it says: the office_a
//! accuracy table, the preset table, and the ablation figures beside them. Accuracy, patch
//! counts and image sizes are deterministic (fixed seed): their tolerance is the printed
//! rounding plus a tenth of the value, so a regression (or a README left behind by a change)
//! fails. Times are guarded at three times the published value (the machine may be another),
//! scaled by how much busier than idle the machine is: `.config/nextest.toml` runs this file
//! alone, so no other test shares the cores.

mod common;
use common::office_a;

use std::time::Instant;

use luxnode::engine::{self, DirectModel, Model, Settings};
use luxnode::evaluate::{Accuracy, compare, readings};
use luxnode::image_build::{ImageOptions, build_image};
use luxnode::preset::Preset;
use luxnode::runtime::Runtime;
use luxnode::scene::{LoadOptions, Scenario, Scene, TruthRow, read_states, read_truth};
use luxnode::store::Image;

fn readme() -> String {
    std::fs::read_to_string(common::manifest().join("README.md")).expect("README.md")
}

/// The cells of the README table row whose first cell starts with `first`.
fn row(readme: &str, first: &str) -> Vec<String> {
    let line = readme
        .lines()
        .find(|l| l.starts_with('|') && l.trim_start_matches('|').trim_start().starts_with(first))
        .unwrap_or_else(|| panic!("README.md has no table row starting with {first:?}"));
    line.trim()
        .trim_matches('|')
        .split('|')
        .map(|c| c.trim().to_owned())
        .collect()
}

/// A printed number and the half unit of its last digit: "0.27 %" -> (0.27, 0.005).
fn number(cell: &str) -> (f64, f64) {
    let s: String = cell
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.')
        .collect();
    let v: f64 = s
        .parse()
        .unwrap_or_else(|_| panic!("no number in {cell:?}"));
    let decimals = s.split_once('.').map_or(0, |(_, d)| d.len());
    (v, 0.5 * 10f64.powi(-(decimals as i32)))
}

/// Bytes of a printed size ("98 kB", "1.98 MB"; decimal units) and its rounding, bytes.
fn bytes(cell: &str) -> (f64, f64) {
    let (v, half) = number(cell);
    let unit = if cell.contains("MB") {
        1e6
    } else if cell.contains("kB") {
        1e3
    } else {
        panic!("no kB or MB in {cell:?}")
    };
    (v * unit, half * unit)
}

/// An accuracy figure (percent) that must be reproduced: within its rounding plus 10 %.
fn check_pct(what: &str, measured: f64, printed: &str) {
    let (v, half) = number(printed);
    let got = 100.0 * measured;
    assert!(
        (got - v).abs() <= half + 0.1 * v,
        "{what}: measured {got:.3} %, README says {printed}"
    );
}

/// How much busier than idle this machine is: the one-minute load average over the cores, at
/// least 1 (CI runs this file alone on its own machine: 1; a developer's shared machine can be
/// several times busier, and then every time is that much longer).
fn busy_factor() -> f64 {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get()) as f64;
    let load = luxnode::host::load_average()
        .and_then(|s| s.parse::<f64>().ok())
        .unwrap_or(0.0);
    (load / cores).max(1.0)
}

/// A time that must not be more than 3 times the published one (plus a little slack for
/// very short ones), times how much busier the machine is than idle.
fn check_time(what: &str, measured_s: f64, printed: &str, slack_s: f64) {
    let (v, _) = number(printed);
    let unit = if printed.contains("ms") {
        1e-3
    } else if printed.contains("ns") {
        1e-9
    } else if printed.contains("µs") {
        1e-6
    } else if printed.contains(" s") {
        1.0
    } else {
        panic!("no time unit in {printed:?}")
    };
    let published = v * unit;
    let busy = busy_factor();
    assert!(
        measured_s <= (3.0 * published + slack_s) * busy,
        "{what}: measured {measured_s:.3e} s, README says {printed} (machine {busy:.1} x busier than idle)"
    );
    eprintln!("{what}: measured {measured_s:.3e} s, README {printed}, busy x{busy:.1}");
}

fn truth() -> (Scene, Vec<Scenario>, Vec<TruthRow>) {
    let scene = Scene::load(&office_a(), &LoadOptions::default()).unwrap();
    let states = read_states(&office_a().join("states.csv")).unwrap();
    let truth = read_truth(&office_a().join("truth.csv")).unwrap();
    (scene, states, truth)
}

fn model_accuracy(model: &Model, states: &[Scenario], truth: &[TruthRow]) -> Accuracy {
    let c = readings(states, &model.luminaire_ids, &model.sensor_ids, |l| {
        model.sensor_lux(l)
    })
    .unwrap();
    compare(&c, truth).unwrap()
}

/// Signed error of the interreflected part (reading − direct reading) against Radiance's
/// `lux − lux_direct`, over every (scenario, sensor) pair, as a fraction of its sum.
fn interreflected_bias(model: &Model, states: &[Scenario], truth: &[TruthRow]) -> f64 {
    let (mut signed, mut total) = (0.0, 0.0);
    for st in states {
        let on: Vec<f64> = model
            .luminaire_ids
            .iter()
            .map(|id| if st.on.contains(id) { 1.0 } else { 0.0 })
            .collect();
        let lux = model.sensor_lux(&on).unwrap();
        for (k, id) in model.sensor_ids.iter().enumerate() {
            let t = truth
                .iter()
                .find(|r| r.scenario == st.id && r.sensor == *id)
                .expect("truth row");
            let direct: f64 = model.direct_sensor_lx[k]
                .iter()
                .zip(&on)
                .map(|(d, x)| d * x)
                .sum();
            let true_ind = t.lux - t.lux_direct.expect("lux_direct in truth.csv");
            signed += (lux[k] - direct) - true_ind;
            total += true_ind;
        }
    }
    signed / total
}

#[test]
fn the_office_a_table_and_the_ablation_figures_hold() {
    let text = readme();
    let (scene, states, truth) = truth();
    let t0 = Instant::now();
    let model = engine::compute_model(&scene, &Settings::default()).unwrap();
    let commissioning_s = t0.elapsed().as_secs_f64();
    let a = model_accuracy(&model, &states, &truth);
    assert_eq!(a.pairs, 31 * 8);
    check_pct("error", a.error, &row(&text, "error over 31 scenarios")[1]);
    check_pct(
        "worst sensor",
        a.worst_sensor,
        &row(&text, "worst sensor")[1],
    );
    check_time(
        "commissioning",
        commissioning_s,
        &row(&text, "commissioning (")[1],
        0.2,
    );
    let per_state = luxnode::bench::time_state(&model, 200_000).unwrap();
    check_time(
        "one dimming state",
        per_state.as_secs_f64(),
        &row(&text, "one dimming state")[1],
        50e-9,
    );
    // "The paper's formulation ... scores 11.3 % on the same table; direct light alone, 23.6 %."
    let sentence = text
        .split("The paper's formulation")
        .nth(1)
        .expect("README: the paper's formulation sentence");
    let mut pcts = sentence.split(" %").map(|s| {
        s.rsplit(' ')
            .next()
            .unwrap_or_default()
            .trim_start_matches(',')
            .to_owned()
    });
    let paper_pct = pcts.next().expect("paper figure");
    let direct_pct = pcts.next().expect("direct-only figure");
    let paper = engine::compute_model(
        &scene,
        &Settings {
            direct: DirectModel::Paper,
            ..Settings::default()
        },
    )
    .unwrap();
    check_pct(
        "paper formulation",
        model_accuracy(&paper, &states, &truth).error,
        &format!("{paper_pct} %"),
    );
    let direct_only = readings(&states, &model.luminaire_ids, &model.sensor_ids, |l| {
        Ok::<_, ()>(
            model
                .direct_sensor_lx
                .iter()
                .map(|row| row.iter().zip(l).map(|(d, x)| d * x).sum())
                .collect(),
        )
    })
    .unwrap();
    check_pct(
        "direct light alone",
        compare(&direct_only, &truth).unwrap().error,
        &format!("{direct_pct} %"),
    );
}

#[test]
fn the_preset_table_holds() {
    let text = readme();
    let (scene, states, truth) = truth();
    // docs/accuracy.md, "office_a's interreflected light, preset by preset": the bias of the
    // interreflected part per preset (−1.44, −0.33, +0.00 %), guarded within 0.15 points (a
    // third of Radiance's standard error on one reading's interreflected part); 0.3 for fast
    // (12 rays per patch, 8-bit form factors: a coarser estimate, guarded more loosely)
    let mut errors = Vec::new();
    for (preset, first, bias_pct, bias_tol) in [
        (Preset::Fast, "fast", -1.44, 0.3),
        (Preset::Balanced, "balanced", -0.33, 0.15),
        (Preset::Accurate, "accurate", 0.0, 0.15),
    ] {
        let cells = row(&text, first);
        // | preset | patches | commissioning | image | one state | re-solve | error | worst |
        let t0 = Instant::now();
        let model = engine::compute_model(&scene, &preset.engine()).unwrap();
        let commissioning_s = t0.elapsed().as_secs_f64();
        let ib = 100.0 * interreflected_bias(&model, &states, &truth);
        eprintln!("{first}: interreflected part {ib:+.2} % against Radiance");
        assert!(
            (ib - bias_pct).abs() <= bias_tol,
            "{first}: interreflected part {ib:+.2} % against Radiance, docs/accuracy.md says {bias_pct:+.2} %"
        );
        let store = preset.store();
        let bytes_built = build_image(
            &model,
            &ImageOptions {
                precision: store.precision,
                prune_below: store.prune_below,
                scene_name: scene.name.clone(),
                sensor_flags: Vec::new(),
                // as `luxnode image build` writes it: with the geometry section for reports
                geometry: Some(luxnode::image_geometry::section_of(
                    &scene,
                    &model,
                    &luxnode::image_geometry::CommissionRecord {
                        preset: preset.name().into(),
                        maintenance_factor: 0.8,
                        ..Default::default()
                    },
                )),
            },
        )
        .unwrap();
        let image = Image::parse(&bytes_built).unwrap();
        assert_eq!(image.patches().to_string(), cells[1], "{first}: patches");
        let (size, half) = bytes(&cells[3]);
        let got = bytes_built.len() as f64;
        assert!(
            (got - size).abs() <= half + 0.01 * size,
            "{first}: image of {got} bytes, README says {}",
            cells[3]
        );
        assert!(
            cells[3].contains(store.precision.name()),
            "{first}: precision {} not in {}",
            store.precision.name(),
            cells[3]
        );
        // the error is that of the flash image (superposition over the stored response)
        let rt = Runtime::new(&image);
        let ids: Vec<u32> = (0..image.luminaires())
            .map(|j| image.luminaire_id(j))
            .collect();
        let sensors: Vec<u32> = (0..image.sensors()).map(|k| image.sensor_id(k)).collect();
        let c = readings(&states, &ids, &sensors, |l| {
            let mut out = vec![0.0; sensors.len()];
            rt.sensor_lux(l, &mut out).map(|()| out)
        })
        .unwrap();
        let a = compare(&c, &truth).unwrap();
        check_pct(&format!("{first}: error"), a.error, &cells[6]);
        errors.push(a.error);
        check_pct(&format!("{first}: worst sensor"), a.worst_sensor, &cells[7]);
        check_time(
            &format!("{first}: commissioning"),
            commissioning_s,
            &cells[2],
            0.2,
        );
        let (per_state, resolve, _) = luxnode::bench::time_runtime(&image, 200_000, 5).unwrap();
        check_time(
            &format!("{first}: one state"),
            per_state.as_secs_f64(),
            &cells[4],
            50e-9,
        );
        check_time(
            &format!("{first}: re-solve"),
            resolve.as_secs_f64(),
            &cells[5],
            2e-3,
        );
    }
    // refinement must not increase the error: each preset more accurate than the one before
    assert!(
        errors[0] > errors[1] && errors[1] > errors[2],
        "errors fast, balanced, accurate: {errors:?}"
    );
}

#[test]
fn the_readers_of_the_tables_read_what_they_must() {
    let t = "| | a | b |\n|---|---:|---:|\n| worst sensor | 0.53 % | ≤ 6 % |\n| fast | 524 | 98 kB (u8) |";
    assert_eq!(row(t, "worst")[1], "0.53 %");
    assert_eq!(number("0.53 %"), (0.53, 0.005));
    assert_eq!(number("524"), (524.0, 0.5));
    assert_eq!(bytes("98 kB (u8)"), (98e3, 500.0));
    let (b, h) = bytes("1.98 MB (u16)");
    assert!((b - 1.98e6).abs() < 1e-6 && (h - 5e3).abs() < 1e-9);
}

/// Issue 31 item 6: one source per figure. The README's headline times and errors are the
/// preset table's balanced row, and the preset table is docs/tradeoffs.md's (the measured run
/// the docs record), cell for cell.
#[test]
fn the_readme_tables_say_what_docs_tradeoffs_says() {
    let readme = readme();
    let doc = std::fs::read_to_string(common::manifest().join("docs/tradeoffs.md"))
        .expect("docs/tradeoffs.md");
    let balanced = row(&readme, "balanced (default)");
    assert_eq!(row(&readme, "error over")[1], balanced[6], "headline error");
    assert_eq!(
        row(&readme, "worst sensor")[1],
        balanced[7],
        "headline worst sensor"
    );
    assert_eq!(
        row(&readme, "commissioning (patches")[1],
        balanced[2],
        "headline commissioning"
    );
    assert_eq!(
        row(&readme, "one dimming state")[1],
        balanced[4],
        "headline per-state time"
    );
    for preset in ["fast", "balanced", "accurate"] {
        let r = row(&readme, preset);
        // docs/tradeoffs.md's first table row for the preset with numbers: the current run
        let d = doc
            .lines()
            .map(|l| {
                l.trim()
                    .trim_matches('|')
                    .split('|')
                    .map(|c| c.trim().to_owned())
            })
            .map(Vec::from_iter)
            .find(|c: &Vec<String>| c.len() >= 8 && c[0] == preset && c[1].parse::<u32>().is_ok())
            .unwrap_or_else(|| panic!("docs/tradeoffs.md: no measured row for {preset}"));
        // the README rounds; each of its numbers within half its last digit of the doc's
        for (what, i) in [
            ("patches", 1),
            ("commissioning", 2),
            ("per state", 4),
            ("re-solve", 5),
        ] {
            let (printed, half) = number(&r[i]);
            let documented: f64 = d[i].parse().unwrap_or(f64::NAN);
            assert!(
                (printed - documented).abs() <= half + 1e-9,
                "{preset} {what}: README {} vs docs/tradeoffs.md {}",
                r[i],
                d[i]
            );
        }
        assert_eq!(&r[6..8], &d[6..8], "{preset} error and worst sensor");
    }
}

/// The cells of the table row (any markdown table in `text`) whose first cell is `first`.
fn exact_row(text: &str, first: &str) -> Vec<String> {
    text.lines()
        .filter(|l| l.starts_with('|'))
        .map(|l| {
            l.trim()
                .trim_matches('|')
                .split('|')
                .map(|c| c.trim().to_owned())
                .collect::<Vec<_>>()
        })
        .find(|cells| cells.first().map(String::as_str) == Some(first))
        .unwrap_or_else(|| panic!("no table row whose first cell is {first:?}"))
}

/// docs/performance.md's equal-error table (issue 33): luxnode's ladder measured again against
/// the stored Radiance rungs (bench/radiance/results/ad_ladder/sweep.json; no Radiance needed).
#[test]
fn the_equal_error_table_against_radiance_holds() {
    use luxnode::bench::equal_error::{candidates, measure, read_sweep};
    let root = common::manifest();
    let doc = std::fs::read_to_string(root.join("docs/performance.md")).expect("performance.md");
    let sweep = root.join("bench/radiance/results/ad_ladder/sweep.json");
    let rungs = read_sweep(&std::fs::read_to_string(sweep).expect("sweep.json")).unwrap();
    let (scene, states, truth) = truth();
    let mut measured = std::collections::BTreeMap::new();
    for c in candidates() {
        let p = measure(&scene, &states, &truth, &c, 3).unwrap().unwrap();
        let cells = exact_row(&doc, c.label);
        check_pct(c.label, p.error, &cells[3]);
        check_time(c.label, p.cpu_s, &format!("{} s", cells[1]), 0.05);
        measured.insert(c.label, (p, number(&cells[1]).0));
    }
    assert_eq!(rungs.len(), 5, "the -ad ladder 256..4096");
    for r in &rungs {
        let cells = exact_row(&doc, &format!("`{}`", r.options));
        let (pick, printed_cpu) = measured
            .get(cells[5].as_str())
            .unwrap_or_else(|| panic!("{}: no luxnode setting {:?}", r.options, cells[5]));
        assert!(
            pick.error <= r.error,
            "{}: luxnode's {} at {:.3} % is above Radiance's {:.3} %",
            r.options,
            pick.label,
            100.0 * pick.error,
            100.0 * r.error
        );
        let (ratio, half) = number(&cells[8]);
        assert!(
            (ratio - r.cpu_s / printed_cpu).abs() <= half + 0.01 * ratio,
            "{}: printed ratio {ratio}, stored {} / printed {printed_cpu}",
            r.options,
            r.cpu_s
        );
        assert!(ratio >= 10.0, "{}: ratio {ratio} < 10", r.options);
    }
}
