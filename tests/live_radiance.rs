//! Live light against Radiance with daylight in the room (issue 12's yardstick):
//! `scenes/office_a_daylight`, office_a with its north window glazed and gensky skies outside,
//! built by `bench/radiance/daylight.py` (method in its docstring). The node is commissioned
//! from the capture set taken in daylight (the all-off frame subtracted); each live frame is
//! Radiance's rendered components summed at a dimming state under a sky (light is additive),
//! quantised at an auto-exposed gain as a camera would; the truth is Radiance's `rtrace -I` at
//! the sensors for the same sum (`live/truth.csv`). Printed: the tables of docs/live.md.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use luxnode::camera::capture::{Capture, read_frame16};
use luxnode::commission::refit::Reading;
use luxnode::commission::{self, CommissionOptions};
use luxnode::image_build::{ImageOptions, build_image};
use luxnode::live::{Live, LiveFrame, LiveModel, LiveSettings, Source};
use luxnode::scene::{LoadOptions, load_desks_file, load_luminaires_file, load_sensors_file};
use luxnode::store::Image;

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office_a_daylight")
}

struct Rig {
    image: Vec<u8>,
    /// Component name → luminance, cd/m² (row-major, the camera's grid).
    components: HashMap<String, Vec<f64>>,
    depth_mm: Vec<u16>,
    /// (component, sensor id) → lux.
    truth: HashMap<(String, u32), f64>,
    luminaire_ids: Vec<u32>,
    sensor_ids: Vec<u32>,
}

/// How the office is commissioned from its daylight capture set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Commissioning {
    /// The capture set as it is, cameras only.
    Plain,
    /// With one luxmeter reading at sensor 7 with every luminaire at full (Radiance's, the
    /// luminaires alone: at night, or a reading with the lights on less one with them off).
    Luxmeter,
    /// Without the closing all-off frame: the first off frame alone is subtracted, the
    /// daylight's drift during the capture stays in the luminaires' frames.
    FirstOffFrameOnly,
}

fn rig(c: Commissioning) -> &'static Rig {
    static PLAIN: OnceLock<Rig> = OnceLock::new();
    static READ: OnceLock<Rig> = OnceLock::new();
    static FIRST: OnceLock<Rig> = OnceLock::new();
    match c {
        Commissioning::Plain => &PLAIN,
        Commissioning::Luxmeter => &READ,
        Commissioning::FirstOffFrameOnly => &FIRST,
    }
    .get_or_init(|| build_rig(c))
}

fn build_rig(c: Commissioning) -> Rig {
    let luxmeter = c == Commissioning::Luxmeter;
    {
        let s = scene();
        let load = LoadOptions::default();
        let (lums, _) = load_luminaires_file(&s.join("luminaires.json"), &load).unwrap();
        let (sensors, _) = load_sensors_file(&s.join("sensors.json"), &load).unwrap();
        let desks = load_desks_file(&s.join("desks.json"), &load).unwrap();
        let luminaire_ids: Vec<u32> = lums.iter().map(|l| l.id).collect();
        let sensor_ids: Vec<u32> = sensors.iter().map(|x| x.id).collect();
        let mut cap = Capture::load(&s.join("capture"), &luminaire_ids).unwrap();
        assert!(cap.off.is_some(), "the capture set has its all-off frame");
        assert!(cap.off_end.is_some(), "and its closing one");
        if c == Commissioning::FirstOffFrameOnly {
            cap.off_end = None;
        }
        let mut o = CommissionOptions::default();
        if luxmeter {
            let text = std::fs::read_to_string(s.join("live/truth.csv")).unwrap();
            let lux_lx = text
                .lines()
                .skip(1)
                .map(|l| l.split(',').collect::<Vec<_>>())
                .filter(|f| f[0].starts_with('L') && f[1] == "7")
                .map(|f| f[2].parse::<f64>().unwrap())
                .sum();
            o.readings = vec![Reading {
                sensor_id: 7,
                lux_lx,
            }];
        }
        let c = commission::from_capture(&cap, lums, sensors, Some(desks), &o).unwrap();
        if luxmeter {
            assert!(c.report.reflectance_fit.is_some());
        }
        let img = build_image(
            &c.model,
            &ImageOptions {
                sensor_flags: c.sensor_flags.clone(),
                ..ImageOptions::default()
            },
        )
        .unwrap();
        let image = luxnode::live_section::with_capture_section(img, &c, &cap, 0);
        assert!(Image::parse(&image).unwrap().live.is_some());
        let live = s.join("live");
        let mut components = HashMap::new();
        let text = std::fs::read_to_string(live.join("components.csv")).unwrap();
        for line in text.lines().skip(1) {
            let f: Vec<&str> = line.split(',').collect();
            let gain: f64 = f[2].parse().unwrap();
            let frame = read_frame16(&live.join(f[1])).unwrap();
            let lum = frame.data.iter().map(|&v| f64::from(v) * gain).collect();
            components.insert(f[0].to_string(), lum);
        }
        let depth_mm = read_frame16(&live.join("depth.png")).unwrap().data;
        let mut truth = HashMap::new();
        let text = std::fs::read_to_string(live.join("truth.csv")).unwrap();
        for line in text.lines().skip(1) {
            let f: Vec<&str> = line.split(',').collect();
            truth.insert(
                (f[0].to_string(), f[1].parse().unwrap()),
                f[2].parse().unwrap(),
            );
        }
        Rig {
            image,
            components,
            depth_mm,
            truth,
            luminaire_ids,
            sensor_ids,
        }
    }
}

/// The smallest gain of 0.01, 0.02, 0.05, ... 1 cd/m² per unit that keeps 99.5 % of the pixels
/// below saturation (an auto-exposing camera; the script's choice for its components).
fn auto_gain(lum: &[f64]) -> f64 {
    let mut v = lum.to_vec();
    v.sort_by(f64::total_cmp);
    let p = v[((0.995 * (v.len() - 1) as f64) as usize).min(v.len() - 1)];
    [0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0]
        .into_iter()
        .find(|g| p / g < 60_000.0)
        .unwrap_or(1.0)
}

/// One live estimate: the frame at `levels` under `sky` (None: night) through a fresh
/// estimator; (the desks, the truth per sensor, the truth's daylight part per sensor).
fn estimate(
    r: &Rig,
    levels: &[f64],
    sky: Option<&str>,
) -> (Vec<luxnode::live::DeskLive>, Vec<f64>, Vec<f64>) {
    let image = Image::parse(&r.image).unwrap();
    let mut live = Live::new(LiveModel::new(&image).unwrap(), LiveSettings::default()).unwrap();
    let (w, h) = live.model().frame_size();
    let n = (w * h) as usize;
    let mut lum = vec![0.0; n];
    for (k, &x) in levels.iter().enumerate() {
        let c = &r.components[&format!("L{}", r.luminaire_ids[k])];
        for (a, b) in lum.iter_mut().zip(c) {
            *a += x * b;
        }
    }
    if let Some(s) = sky {
        for (a, b) in lum.iter_mut().zip(&r.components[s]) {
            *a += b;
        }
    }
    let gain = auto_gain(&lum);
    let frame: Vec<u16> = lum
        .iter()
        .map(|&l| (l / gain).round().clamp(0.0, 65535.0) as u16)
        .collect();
    let desks = live
        .update(
            &LiveFrame {
                width: w,
                height: h,
                luminance: &frame,
                cd_m2_per_unit: gain,
                depth_mm: Some(&r.depth_mm),
                taken_s: 0.0,
            },
            levels,
            0.0,
        )
        .unwrap()
        .to_vec();
    let mut truth = Vec::new();
    let mut day = Vec::new();
    for &sid in &r.sensor_ids {
        let art: f64 = levels
            .iter()
            .enumerate()
            .map(|(k, x)| x * r.truth[&(format!("L{}", r.luminaire_ids[k]), sid)])
            .sum();
        let d = sky.map_or(0.0, |s| r.truth[&(s.to_string(), sid)]);
        truth.push(art + d);
        day.push(d);
    }
    (desks, truth, day)
}

const SKIES: [&str; 5] = [
    "overcast_10",
    "overcast_12",
    "clear_09",
    "clear_12",
    "clear_15",
];

#[derive(Default)]
struct Acc {
    sum: f64,
    sum_sq: f64,
    n: usize,
    worst: f64,
}

impl Acc {
    fn add(&mut self, e: f64) {
        self.sum += e;
        self.sum_sq += e * e;
        self.n += 1;
        self.worst = self.worst.max(e);
    }
    fn mean(&self) -> f64 {
        self.sum / self.n.max(1) as f64
    }
    fn rms(&self) -> f64 {
        (self.sum_sq / self.n.max(1) as f64).sqrt()
    }
}

/// The bench's errors: desks in view, all desks overcast and clear, the daylight part, and the
/// share of values within one and two stated uncertainties.
struct Scores {
    view: Acc,
    overcast: Acc,
    clear: Acc,
    day_part: Acc,
    c1: f64,
    c2: f64,
}

/// Prints how each score moved from `a` to `b`.
fn print_change(a: &Scores, b: &Scores) {
    eprintln!(
        "in view {:.2} -> {:.2} % (worst {:.1} -> {:.1} %); overcast {:.2} -> {:.2} %; clear \
         {:.2} -> {:.2} %; daylight part {:.2} -> {:.2} %; within one {:.0} -> {:.0} %, two \
         {:.0} -> {:.0} %",
        100.0 * a.view.mean(),
        100.0 * b.view.mean(),
        100.0 * a.view.worst,
        100.0 * b.view.worst,
        100.0 * a.overcast.mean(),
        100.0 * b.overcast.mean(),
        100.0 * a.clear.mean(),
        100.0 * b.clear.mean(),
        100.0 * a.day_part.mean(),
        100.0 * b.day_part.mean(),
        100.0 * a.c1,
        100.0 * b.c1,
        100.0 * a.c2,
        100.0 * b.c2,
    );
}

/// Every sky × dimming state through live light; prints docs/live.md's table.
fn bench(r: &Rig) -> Scores {
    let n = r.luminaire_ids.len();
    let states: Vec<(&str, Vec<f64>)> = vec![
        ("all on", vec![1.0; n]),
        (
            "mixed",
            (0..n)
                .map(|k| [1.0, 0.5, 0.2, 0.8, 0.0, 1.0, 0.3, 0.6][k % 8])
                .collect(),
        ),
        ("all off", vec![0.0; n]),
    ];
    let image = Image::parse(&r.image).unwrap();
    let model = LiveModel::new(&image).unwrap();
    let in_view: Vec<bool> = (0..r.sensor_ids.len()).map(|s| model.in_view(s)).collect();
    eprintln!("in view: {in_view:?}");
    let (mut view, mut overcast, mut clear, mut day_part) = (
        Acc::default(),
        Acc::default(),
        Acc::default(),
        Acc::default(),
    );
    // the stated uncertainty: how often the truth is within one and two of it
    let (mut within1, mut within2, mut n_all) = (0usize, 0usize, 0usize);
    for sky in std::iter::once(None).chain(SKIES.iter().map(|s| Some(*s))) {
        for (name, levels) in &states {
            if sky.is_none() && *name == "all off" {
                continue;
            }
            let (desks, truth, day) = estimate(r, levels, sky);
            let mut line = format!("| {} | {name} |", sky.unwrap_or("night"));
            for (k, d) in desks.iter().enumerate() {
                assert!(d.total_lx.is_finite());
                let e = (d.total_lx - truth[k]).abs() / truth[k].max(50.0);
                let z = (d.total_lx - truth[k]).abs() / d.uncertainty_lx.max(1e-9);
                within1 += usize::from(z <= 1.0);
                within2 += usize::from(z <= 2.0);
                n_all += 1;
                let ed = (d.daylight_lx - day[k]).abs() / truth[k].max(50.0);
                line += &format!(
                    " {:+.1} % ({}) |",
                    100.0 * (d.total_lx - truth[k]) / truth[k].max(50.0),
                    if d.source == Source::Measured {
                        "m"
                    } else {
                        "i"
                    }
                );
                if in_view[k] {
                    view.add(e);
                }
                match sky {
                    Some(s) if s.starts_with("overcast") => overcast.add(e),
                    Some(_) => clear.add(e),
                    None => {}
                }
                if sky.is_some() {
                    day_part.add(ed);
                }
            }
            eprintln!("{line}");
        }
    }
    eprintln!(
        "desks in view: mean {:.1} % (RMS {:.1} %), worst {:.1} %; overcast, all desks: mean {:.1} %, worst {:.1} %; \
         clear with sun, all desks: mean {:.1} %, worst {:.1} %; daylight part: mean {:.1} %, worst {:.1} % of the total",
        100.0 * view.mean(),
        100.0 * view.rms(),
        100.0 * view.worst,
        100.0 * overcast.mean(),
        100.0 * overcast.worst,
        100.0 * clear.mean(),
        100.0 * clear.worst,
        100.0 * day_part.mean(),
        100.0 * day_part.worst
    );
    let (c1, c2) = (within1 as f64 / n_all as f64, within2 as f64 / n_all as f64);
    eprintln!(
        "the truth within one stated uncertainty: {:.0} %, within two: {:.0} % ({n_all} values)",
        100.0 * c1,
        100.0 * c2
    );
    Scores {
        view,
        overcast,
        clear,
        day_part,
        c1,
        c2,
    }
}

/// Issue 12's targets against Radiance: desks in view (total, ≤ 3 % mean), all desks under an
/// overcast sky (≤ 10 %) and a clear sky with sun (≤ 15 %), the daylight part (within 10 % of
/// the total).
#[test]
fn live_light_against_radiance_with_daylight() {
    let Scores {
        view,
        overcast,
        clear,
        day_part,
        c1,
        c2,
    } = bench(rig(Commissioning::Plain));
    assert!(view.n > 0 && overcast.n > 0 && clear.n > 0);
    // measured 71 % and 99 % (a normal error: 68 % and 95 %) with the measured desks' relative
    // uncertainty at 4 %, this bench's RMS error in view (3.8 %); at 7 %, before the closing
    // all-off frame and the narrowing window, 91 % and 100 %: the register overstated it
    // (stop 47: 90.4 %, one value of 136 more than before, with the extraneous light of an
    // in-view desk measured as a share of each sample's luminaire light; then 94.9 %, with the
    // unknown emitters' daylight stated at 55 %, measured on the generalization bench's 8
    // rooms: office_a's two out-of-view desks are told better than those rooms' median, and
    // this room is not the one the statement is for)
    assert!((0.55..=0.96).contains(&c1), "within one uncertainty: {c1}");
    assert!(c2 >= 0.95, "within two uncertainties: {c2}");
    // docs/live.md, "Radiance yardstick": measured 3.6 % (worst 9.4 %) in view, 6.4 % overcast,
    // 7.6 % clear with sun, the daylight part 6.1 % of the total; guarded at 1.3-1.4 times
    assert!(view.mean() < 0.049, "in view: mean {}", view.mean());
    assert!(view.worst < 0.147, "in view: worst {}", view.worst);
    assert!(
        overcast.mean() < 0.089,
        "overcast: mean {}",
        overcast.mean()
    );
    assert!(
        clear.mean() < 0.097,
        "clear with sun: mean {}",
        clear.mean()
    );
    assert!(
        day_part.mean() < 0.081,
        "daylight part: mean {}",
        day_part.mean()
    );
}

/// One luxmeter reading at commissioning (sensor 7, the luminaires alone) fits the unseen walls
/// and ceiling; the seen reflectances estimated against that model take the bias out of every
/// measured desk, in daylight too (docs/live.md).
#[test]
fn a_luxmeter_reading_at_commissioning_with_daylight() {
    let plain = bench(rig(Commissioning::Plain));
    let read = bench(rig(Commissioning::Luxmeter));
    print_change(&plain, &read);
    // docs/live.md: measured in view 3.58 -> 2.66 % (issue 12's target: 3 %), overcast 6.38 ->
    // 7.50 %, clear 7.56 -> 6.90 %, the daylight part 6.14 -> 6.69 %, within two stated
    // uncertainties 100 -> 100 %; guarded at about 1.1 times
    assert!(read.view.mean() < 0.029, "in view {}", read.view.mean());
    assert!(read.view.mean() < plain.view.mean() - 0.005);
    assert!(read.overcast.mean() < 0.081 && read.clear.mean() < 0.07);
    assert!(read.day_part.mean() < 0.069);
    assert!(read.c2 >= 0.95, "within two: {}", read.c2);
}

/// The closing all-off frame takes the daylight's drift during the capture out of the
/// luminaires' frames (the bench's sky brightens by 6 % over the capture, faster as it goes, so
/// the linear interpolation is not exact; docs/live.md).
#[test]
fn the_closing_all_off_frame_takes_the_drift_out() {
    let first = bench(rig(Commissioning::FirstOffFrameOnly));
    let both = bench(rig(Commissioning::Plain));
    print_change(&first, &both);
    // docs/live.md: measured in view 5.48 -> 3.49 %
    assert!(both.view.mean() < first.view.mean() - 0.01);
}
