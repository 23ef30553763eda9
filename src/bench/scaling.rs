//! How commissioning scales with patches × rays (`luxnode bench scaling`): per-stage wall time,
//! form-factor entries and memory at several patch sizes and ray counts, on Greg Ward's grey
//! room (built in code, [`ward_room`]) or on any scene directory.
//!
//! Memory: the process's peak resident set (`VmHWM`), reset before each run through
//! `/proc/self/clear_refs` (Linux), so each row's peak is its own; and the bytes of the form
//! factors as stored (CSR: 4 bytes column + 8 bytes value per entry).
//!
//! Per ray: [`profile_table`] gives, for each row, the form-factor stage's sub-stages on one
//! thread (`engine::ffprofile`) beside the BVH's own rate on the same rays.

use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::Arc;
use std::time::Duration;

use glam::DVec3;

use crate::engine::ffprofile::RayProfile;
use crate::engine::{self, EngineError, Model, PatchSettings, Settings};
use crate::lsc::AngularResponse;
use crate::photometry::IntensityDistribution;
use crate::scene::{Luminaire, MeshBuilder, ObjReport, Scene, Sensor};

/// Greg Ward's 1990 empty grey room: 10 × 6 × 3 m, a 0.5 × 0.5 m Lambertian source of exitance
/// 31.416 W/m² (7.854 W, written as lumens) at the centre of the ceiling, ceiling ρ 0.7, walls
/// 0.5, floor 0.3, and the 60 ceiling points of one quarter (0.25 + 0.5 k) as downward sensors.
pub fn ward_room() -> Scene {
    let p = DVec3::new;
    let mut b = MeshBuilder::new();
    // the reflectances are constants inside (0, 1): these cannot fail
    let mat = |b: &mut MeshBuilder, name: &str, rho: f64| {
        b.material(name, rho)
            .unwrap_or_else(|e| unreachable!("{name}: {e}"))
    };
    let ceiling = mat(&mut b, "ceiling", 0.7);
    let wall = mat(&mut b, "wall", 0.5);
    let floor = mat(&mut b, "floor", 0.3);
    let black = mat(&mut b, "source", 0.0);
    let (lx, ly, lz) = (10.0, 6.0, 3.0);
    b.quad(
        [p(0., 0., 0.), p(lx, 0., 0.), p(lx, ly, 0.), p(0., ly, 0.)],
        "floor",
        floor,
    );
    b.quad(
        [p(0., 0., 0.), p(0., 0., lz), p(lx, 0., lz), p(lx, 0., 0.)],
        "wall_s",
        wall,
    );
    b.quad(
        [p(lx, ly, 0.), p(lx, ly, lz), p(0., ly, lz), p(0., ly, 0.)],
        "wall_n",
        wall,
    );
    b.quad(
        [p(0., ly, 0.), p(0., ly, lz), p(0., 0., lz), p(0., 0., 0.)],
        "wall_w",
        wall,
    );
    b.quad(
        [p(lx, 0., 0.), p(lx, 0., lz), p(lx, ly, lz), p(lx, ly, 0.)],
        "wall_e",
        wall,
    );
    let (x0, x1, y0, y1) = (4.75, 5.25, 2.75, 3.25);
    let down =
        |a: f64, b: f64, c: f64, d: f64| [p(a, d, lz), p(b, d, lz), p(b, c, lz), p(a, c, lz)];
    b.quad(down(0., x0, 0., ly), "ceiling", ceiling);
    b.quad(down(x1, lx, 0., ly), "ceiling", ceiling);
    b.quad(down(x0, x1, 0., y0), "ceiling", ceiling);
    b.quad(down(x0, x1, y1, ly), "ceiling", ceiling);
    b.quad(down(x0, x1, y0, y1), "luminaire_1", black);
    let i0_cd = 31.416 / PI * 0.25;
    let d = IntensityDistribution::from_gamma_fn(0.25, "Ward's Lambertian source", |g| {
        if g < FRAC_PI_2 { i0_cd * g.cos() } else { 0.0 }
    });
    let flux = d.flux_lm();
    let l = Luminaire {
        id: 1,
        name: "luminaire_1".into(),
        position_m: p(5.0, 3.0, lz),
        aim: DVec3::NEG_Z,
        c0: DVec3::X,
        c90: DVec3::Y,
        flux_lm: flux,
        opening_m: [0.5, 0.5],
        opening_circular: false,
        photometry: Arc::new(d),
        photometry_path: "ward".into(),
        file_flux_lm: flux,
    };
    let mut sensors = Vec::new();
    for i in 0..10 {
        for j in 0..6 {
            sensors.push(Sensor {
                id: (i * 6 + j + 1) as u32,
                position_m: p(0.25 + 0.5 * i as f64, 0.25 + 0.5 * j as f64, lz),
                normal: DVec3::NEG_Z,
                note: String::new(),
                response: AngularResponse::Cosine,
            });
        }
    }
    Scene {
        name: "ward_grey_room".into(),
        mesh: b.build(),
        luminaires: vec![l],
        sensors,
        desks: None,
        camera: None,
        obj_report: ObjReport::default(),
        warnings: Vec::new(),
    }
}

/// One row of the scaling table.
#[derive(Debug, Clone)]
pub struct ScalingRow {
    /// Base patch size, m.
    pub patch_size_m: f64,
    /// Patches.
    pub patches: usize,
    /// Rays per patch (after Isocell rounding).
    pub rays_per_patch: usize,
    /// Non-zero form factors.
    pub nnz: usize,
    /// (stage, time) as the engine reports them.
    pub stages: Vec<(&'static str, Duration)>,
    /// Whole commissioning.
    pub total: Duration,
    /// Peak resident set during the run, bytes (None where /proc is not there).
    pub peak_rss_bytes: Option<u64>,
    /// Bytes of the form factors as stored in the model (CSR).
    pub ff_bytes: usize,
    /// Where the time per ray goes in the form-factor stage (one thread, a sample of patches).
    pub profile: RayProfile,
}

/// Patches the per-ray profile samples (spread evenly over the patch list).
pub const PROFILE_PATCHES: usize = 128;

/// Resets the peak resident set of this process (Linux: `echo 5 > /proc/self/clear_refs`).
fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The peak resident set of this process since the last reset, bytes.
pub fn peak_rss_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Commissions `scene` at each (patch size, rays) with otherwise default settings (uniform
/// patches when `uniform` is set), `runs` times each (the median total is kept, with its
/// stages).
pub fn scaling(
    scene: &Scene,
    patch_sizes_m: &[f64],
    rays: &[usize],
    uniform: bool,
    runs: usize,
) -> Result<Vec<ScalingRow>, EngineError> {
    let mut out = Vec::new();
    for &r in rays {
        for &size in patch_sizes_m {
            let mut settings = Settings {
                rays: r,
                ..Settings::default()
            };
            settings.patches = PatchSettings {
                patch_size_m: size,
                ..settings.patches
            };
            if uniform {
                settings.patches.detail_ratio = 0.0;
                settings.patches.light_ratio = 0.0;
            }
            let mut results: Vec<(Model, Option<u64>)> = Vec::new();
            for _ in 0..runs.max(1) {
                reset_peak_rss();
                let m = engine::compute_model(scene, &settings)?;
                let peak = peak_rss_bytes();
                results.push((m, peak));
            }
            results.sort_by_key(|(m, _)| m.stats.total());
            let (m, peak) = results.swap_remove(results.len() / 2);
            let profile = engine::form_factor_profile(scene, &settings, PROFILE_PATCHES)?;
            out.push(ScalingRow {
                patch_size_m: size,
                patches: m.stats.patches,
                rays_per_patch: m.stats.rays_per_patch,
                nnz: m.stats.nnz,
                stages: m.stats.timings.clone(),
                total: m.stats.total(),
                peak_rss_bytes: peak,
                ff_bytes: m.ff.f.nnz() * 12 + m.ff.f.row_ptr.len() * 4,
                profile,
            });
        }
    }
    Ok(out)
}

/// The table (markdown), with the time per million patch rays.
pub fn table(rows: &[ScalingRow]) -> String {
    let mut stages: Vec<&'static str> = Vec::new();
    for r in rows {
        for (s, _) in &r.stages {
            if !stages.contains(s) {
                stages.push(s);
            }
        }
    }
    let mut s = String::from("| patch size (m) | patches | rays | patches × rays (M) | nnz (M) |");
    for st in &stages {
        s.push_str(&format!(" {st} (s) |"));
    }
    s.push_str(" total (s) | s per M patch rays | peak RSS (MiB) | F (MiB) |\n|");
    for _ in 0..(9 + stages.len()) {
        s.push_str("---:|");
    }
    s.push('\n');
    for r in rows {
        let pr = (r.patches * r.rays_per_patch) as f64 / 1e6;
        s.push_str(&format!(
            "| {} | {} | {} | {:.2} | {:.2} |",
            r.patch_size_m,
            r.patches,
            r.rays_per_patch,
            pr,
            r.nnz as f64 / 1e6
        ));
        for st in &stages {
            let t = r
                .stages
                .iter()
                .filter(|(n, _)| n == st)
                .map(|(_, t)| t.as_secs_f64())
                .sum::<f64>();
            s.push_str(&format!(" {t:.3} |"));
        }
        s.push_str(&format!(
            " {:.2} | {:.2} | {} | {:.1} |\n",
            r.total.as_secs_f64(),
            r.total.as_secs_f64() / pr.max(1e-9),
            r.peak_rss_bytes
                .map_or("-".to_owned(), |b| format!("{:.0}", b as f64 / 1048576.0)),
            r.ff_bytes as f64 / 1048576.0
        ));
    }
    s
}

/// The per-ray table (markdown): each form-factor sub-stage in µs per ray on one thread, the
/// BVH's own rate on the same rays, and the stages as the run measured them (wall time over
/// patches × rays, all threads: compare with the one-thread figures times the threads).
pub fn profile_table(rows: &[ScalingRow]) -> String {
    let mut s = String::from(
        "| patches | rays | sampled rays | generation | BVH traversal | patch lookup | accumulation | \
         sum | stage (one thread) | BVH own (obvhs test) | stage / BVH own | BVH own (M rays/s) | \
         form factors (run, wall) | rectification (run, wall) |\n|",
    );
    for _ in 0..14 {
        s.push_str("---:|");
    }
    s.push('\n');
    for r in rows {
        let p = &r.profile;
        let pr = (r.patches * r.rays_per_patch).max(1) as f64;
        let stage = |name: &str| {
            r.stages
                .iter()
                .filter(|(n, _)| *n == name)
                .map(|(_, t)| t.as_secs_f64())
                .sum::<f64>()
                * 1e6
                / pr
        };
        let sum = p.generation_us + p.traversal_us + p.lookup_us + p.accumulation_us;
        s.push_str(&format!(
            "| {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {:.2} | {:.3} | {:.3} |\n",
            r.patches,
            r.rays_per_patch,
            p.rays,
            p.generation_us,
            p.traversal_us,
            p.lookup_us,
            p.accumulation_us,
            sum,
            p.stage_us,
            p.bvh_own_us,
            p.stage_us / p.bvh_own_us.max(1e-12),
            1.0 / p.bvh_own_us.max(1e-12),
            stage("form factors"),
            stage("rectification"),
        ));
    }
    s
}
