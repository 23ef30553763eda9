//! Building the daylight-coefficient section at commissioning ([`crate::store::daylight`]; the
//! run-time side is [`crate::live`]): the room plan's windows, the sky's light through them on
//! the seen patches and at the desk sensors.
//!
//! ```text
//! plan windows ─► direct sky per patch and sensor (engine::daylight)
//!   ─► boundary solve: unseen patches reflect it, seen patches held at 0 ─► seen × 146, sensors × 146
//! ```
//!
//! The seen patches are held at zero exitance because at run time their exitance is what the
//! camera measures, and the live estimator propagates it itself; the coefficients add what the
//! camera cannot see: the sky through the windows and its reflections off unseen surfaces.
//! A window the camera sees goes through the coefficients too: the camera on the ceiling sees
//! its glass looking down and out, at the ground's luminance, while the light it lets into the
//! room comes from the sky above (on the generalization bench, desks by a seen window got a
//! third to a seventh of their daylight from the glass's measured exitance). Its seen patches
//! are listed in the section ([`DaylightSectionData::glazing_seen`]); the live estimator holds
//! them at zero exitance and leaves them out of the fit when it fits the sky.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::commission::{Commissioned, RoomBox};
use crate::engine::daylight::{COLUMNS, DaylightRoom, DaylightSettings, Glazing, Window};
use crate::engine::raycast::RayCaster;
use crate::scene::plan::{OpeningKind, RoomPlan};
use crate::sky::SkyFrame;
use crate::solver::{self, CsrSystem, RhsState, Rows, Workspace};
use crate::store::daylight::{
    DAYLIGHT_MAGIC, DAYLIGHT_VERSION, DaylightCoefficients, MAX_COEFFICIENT,
};
use crate::store::{Bytes, Image};

/// Ground reflectance outside (CIE's and `gensky`'s default, 0.2).
pub const GROUND_RHO: f64 = 0.2;

/// Most seen patches stored: an even subset of them (every k-th in patch order). The sky fit
/// has one unknown per sky; 256 patches spread over what the camera sees determine it, at
/// 75 kB instead of 290 kB for office_a's 484 (and room for it in images near the flash
/// region's size).
pub const MAX_SEEN_ROWS: usize = 256;

/// The boundary solve's stop: the coefficients are stored as f16 (3 significant digits), so a
/// relative change of 1e-6 is far below what is kept.
const BOUNDARY_SOLVE: crate::solver::SolveOptions = crate::solver::SolveOptions {
    tolerance: 1e-6,
    max_iterations: 10_000,
};

/// The section's data, owned.
#[derive(Debug, Clone, PartialEq)]
pub struct DaylightSectionData {
    /// Site latitude, longitude (degrees) and north.
    pub site: (f64, f64, [f64; 2]),
    /// Windows used and their glazed area, m².
    pub windows: usize,
    /// Glazed area, m².
    pub window_area_m2: f64,
    /// Seen patches, ascending.
    pub seen_patch: Vec<u32>,
    /// `[seen][COLUMNS]`, lx per cd/m².
    pub seen_lx: Vec<f32>,
    /// `[sensor][COLUMNS]`, lx per cd/m².
    pub sensor_lx: Vec<f32>,
    /// The seen patches that are glazing, ascending.
    pub glazing_seen: Vec<u32>,
}

/// The plan's windows on the commissioned room's walls (which may stand behind the plan's where
/// the cameras saw them), as the engine's glazed rectangles.
pub fn plan_windows(room: &RoomBox) -> Vec<Window> {
    let Some(outline) = room.outline_m.as_ref() else {
        return Vec::new();
    };
    let n = outline.len();
    room.openings
        .iter()
        .filter_map(|o| {
            let OpeningKind::Window { transmittance } = o.kind else {
                return None;
            };
            let (a, b) = (*outline.get(o.wall)?, outline[(o.wall + 1) % n]);
            let dir = (b - a).normalize_or_zero();
            let inward = DVec2::new(-dir.y, dir.x);
            let z0 = o.z_m[0].max(room.floor_z_m);
            let z1 = o.z_m[1].min(room.ceiling_z_m);
            let p0 = a + dir * o.along_m[0];
            let w = Window {
                corner_m: DVec3::new(p0.x, p0.y, z0),
                edge_u_m: (dir * (o.along_m[1] - o.along_m[0])).extend(0.0),
                edge_v_m: DVec3::new(0.0, 0.0, z1 - z0),
                inward: inward.extend(0.0),
                transmittance,
                glazing: Glazing::ClearGlass,
            };
            w.check().is_ok().then_some(w)
        })
        .collect()
}

/// The section for a commissioned room with a plan, or why there is none (no site, no window,
/// no live section); the image must already hold its live section (its samples name the seen
/// patches).
pub fn build(
    c: &Commissioned,
    plan: &RoomPlan,
    image: &Image<'_>,
    settings: &DaylightSettings,
) -> Result<DaylightSectionData, String> {
    let site = plan.site.as_ref().ok_or("the room plan has no site")?;
    let room = c.report.room.as_ref().ok_or("no room")?;
    let live = image.live.as_ref().ok_or("no live-light section")?;
    let caster = RayCaster::new(&c.model.patches);
    let windows = plan_windows(room);
    if windows.is_empty() {
        return Err("the room plan has no window".into());
    }
    let frame = SkyFrame::new([site.north.x, site.north.y]).ok_or("site north")?;
    let sensors: Vec<(DVec3, DVec3)> = c
        .scene
        .sensors
        .iter()
        .map(|s| (s.position_m, s.normal))
        .collect();
    let mut all_seen: Vec<u32> = (0..live.samples()).map(|i| live.patch(i) as u32).collect();
    all_seen.sort_unstable();
    all_seen.dedup();
    let step = all_seen.len().div_ceil(MAX_SEEN_ROWS).max(1);
    let seen_patch: Vec<u32> = all_seen.iter().copied().step_by(step).collect();
    // the direct sky where it is used: the unseen patches (the boundary solve's source) and
    // the stored seen ones; the other seen patches are held at zero
    let room_dc = DaylightRoom::of_model(&c.model, &caster, &sensors, &windows, frame);
    let wanted = |i: usize| {
        let p = i as u32;
        all_seen.binary_search(&p).is_err() || seen_patch.binary_search(&p).is_ok()
    };
    let direct = room_dc
        .direct_sky_where(settings, wanted)
        .map_err(|e| e.to_string())?;
    let direct = (&direct.patch.values[..], &direct.sensor.values[..]);
    let (seen_lx, sensor_lx) = boundary(c, &all_seen, &seen_patch, direct)?;
    // the seen patches on the plan's windows: the live estimator holds them at zero
    let glazing = crate::commission::glazing_patches(c).unwrap_or_default();
    let glazing_seen: Vec<u32> = all_seen
        .iter()
        .copied()
        .filter(|&p| glazing.get(p as usize).copied().unwrap_or(false))
        .collect();
    Ok(DaylightSectionData {
        site: (
            site.latitude_deg,
            site.longitude_deg,
            [site.north.x, site.north.y],
        ),
        windows: windows.len(),
        window_area_m2: windows.iter().map(Window::area_m2).sum(),
        seen_patch,
        seen_lx,
        sensor_lx,
        glazing_seen,
    })
}

/// The boundary coefficients: the direct sky on the unseen patches reflected over them (seen
/// patches held at 0), at the seen patches and the sensors, every column in one solve.
fn boundary(
    c: &Commissioned,
    seen: &[u32],
    stored: &[u32],
    (patch_direct, sensor_direct): (&[f32], &[f32]),
) -> Result<(Vec<f32>, Vec<f32>), String> {
    let m = &c.model;
    let n = m.patches.len();
    let k = COLUMNS;
    // every patch the camera sees is held at zero, stored or not
    let mut is_seen = vec![false; n];
    for &p in seen {
        is_seen[p as usize] = true;
    }
    let unseen: Vec<u32> = (0..n as u32).filter(|&p| !is_seen[p as usize]).collect();
    let e: Vec<f64> = (0..n * k)
        .map(|at| {
            if is_seen[at / k] {
                0.0
            } else {
                f64::from(patch_direct.get(at).copied().unwrap_or(0.0))
            }
        })
        .collect();
    let mut b = vec![0.0; n * k];
    let sys = CsrSystem {
        f: m.ff.f.view(),
        rho: &m.patches.rho,
    };
    let (mut acc, mut state) = (vec![0.0; k], vec![RhsState::default(); k]);
    let work = Workspace {
        acc: &mut acc,
        state: &mut state,
    };
    solver::solve(
        &sys,
        Rows::Listed(&unseen),
        solver::Source::Irradiance(&e),
        &mut b,
        work,
        BOUNDARY_SOLVE,
    )
    .map_err(|e| format!("daylight boundary solve: {e}"))?;
    let gather_row = |csr: &crate::engine::Csr, i: usize, direct: &[f32]| -> Vec<f32> {
        let mut row: Vec<f64> = (0..k)
            .map(|j| f64::from(direct.get(i * k + j).copied().unwrap_or(0.0)))
            .collect();
        for (p, f) in csr.row(i) {
            let bp = &b[p as usize * k..p as usize * k + k];
            for (r, x) in row.iter_mut().zip(bp) {
                *r += f * x;
            }
        }
        row.iter()
            .map(|x| (x.max(0.0) as f32).min(MAX_COEFFICIENT))
            .collect()
    };
    let seen_lx: Vec<f32> = stored
        .par_iter()
        .flat_map_iter(|&p| gather_row(&m.ff.f, p as usize, patch_direct))
        .collect();
    let sensor_lx: Vec<f32> = (0..m.gather.rows())
        .into_par_iter()
        .flat_map_iter(|s| gather_row(&m.gather, s, sensor_direct))
        .collect();
    Ok((seen_lx, sensor_lx))
}

/// The postcard body of the section.
pub fn encode(d: &DaylightSectionData) -> Result<Vec<u8>, String> {
    let le = |v: &[f32]| -> Vec<u8> {
        v.iter()
            .flat_map(|x| half::f16::from_f32(*x).to_bits().to_le_bytes())
            .collect()
    };
    let seen: Vec<u8> = d.seen_patch.iter().flat_map(|p| p.to_le_bytes()).collect();
    let (seen_lx, sensor_lx) = (le(&d.seen_lx), le(&d.sensor_lx));
    let glazing: Vec<u8> = d
        .glazing_seen
        .iter()
        .flat_map(|p| p.to_le_bytes())
        .collect();
    let s = DaylightCoefficients {
        version: DAYLIGHT_VERSION,
        latitude_deg: d.site.0,
        longitude_deg: d.site.1,
        north: d.site.2,
        ground_rho: GROUND_RHO,
        windows: u16::try_from(d.windows).map_err(|_| "too many windows")?,
        window_area_m2: d.window_area_m2,
        seen_patch: Bytes(&seen),
        seen_lx: Bytes(&seen_lx),
        sensor_lx: Bytes(&sensor_lx),
        glazing_seen: Bytes(&glazing),
    };
    s.encode().map_err(|e| e.to_string())
}

/// The image with the daylight section of a commissioning with a plan added, within the
/// formfactors flash region; the image as it is (logged) when there is nothing to add or no
/// room for it.
pub fn with_daylight_section(image: Vec<u8>, c: &Commissioned, plan: Option<&RoomPlan>) -> Vec<u8> {
    let Some(plan) = plan else {
        return image;
    };
    let t0 = std::time::Instant::now();
    let built = Image::parse(&image)
        .map_err(|e| e.to_string())
        .and_then(|img| build(c, plan, &img, &DaylightSettings::default()))
        .and_then(|d| encode(&d))
        .and_then(|body| {
            crate::image_build::with_section(&image, DAYLIGHT_MAGIC, DAYLIGHT_VERSION, Some(&body))
                .map_err(|e| e.to_string())
        });
    match built {
        Ok(bytes) if bytes.len() <= crate::image_build::formfactors_region_bytes() => {
            tracing::info!(
                "commission: daylight coefficients of {} bytes added (the plan's windows) in \
                 {:.0} ms",
                bytes.len() - image.len(),
                t0.elapsed().as_secs_f64() * 1e3
            );
            bytes
        }
        Ok(bytes) => {
            tracing::warn!(
                "commission: no room for the daylight coefficients ({} bytes) in the flash \
                 region; daylight through the plan's windows is fitted by emitters",
                bytes.len() - image.len()
            );
            image
        }
        Err(why) => {
            tracing::info!("commission: no daylight coefficients: {why}");
            image
        }
    }
}
