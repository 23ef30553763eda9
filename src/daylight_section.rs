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
use crate::sky::{SkyFrame, SunGrid};
use crate::solver::{self, CsrSystem, RhsState, Rows, Workspace};
use crate::store::daylight::{
    DAYLIGHT_MAGIC, DAYLIGHT_VERSION, DAYLIGHT_VERSION_WITHOUT_SUN, DaylightCoefficients,
    MAX_COEFFICIENT, SUN_SEEN_MIN,
};
use crate::store::{Bytes, Image};

/// Ground reflectance outside (CIE's and `gensky`'s default, 0.2).
pub const GROUND_RHO: f64 = 0.2;

/// Most seen patches stored: an even subset of them (every k-th in patch order). The sky fit
/// has one unknown per sky; 256 patches spread over what the camera sees determine it, at
/// 75 kB instead of 290 kB for office_a's 484 (and room for it in images near the flash
/// region's size).
pub const MAX_SEEN_ROWS: usize = 256;

/// The boundary solve's stop: the coefficients are stored as f16 (3 significant digits, a
/// relative step of 5e-4), so a relative change of 1e-4 is below what is kept (1e-6 until stop
/// 49: room_07's section 0.15 s slower, its desks' values the same to 0.01 lx).
const BOUNDARY_SOLVE: crate::solver::SolveOptions = crate::solver::SolveOptions {
    tolerance: 1e-4,
    max_iterations: 10_000,
};

/// The sun columns' stop: their coefficients find the seen patches and desks in the beam and
/// carry the beam's reflections off unseen surfaces, a few hundredths of it, so three digits
/// are more than they need (room_07 of the generalization bench, one node, 141 of its 231
/// positions in the beam of a window: at stop 49 the section took 0.95 s, 1.37 s with the sun
/// at the sky's stop of 1e-6).
const SUN_SOLVE: crate::solver::SolveOptions = crate::solver::SolveOptions {
    tolerance: 1e-3,
    max_iterations: 10_000,
};

/// Right-hand sides per solve: a chunk's unknowns (patches × 16 × 8 bytes, 0.45 MB at room_07's
/// 3548 patches) stay in a core's cache while a sweep reads them once per form factor, and the
/// chunks run on every core (room_07 on 2 cores: the two solves in 0.24 s instead of 0.61 s
/// as one solve each; chunks of 8 to 32 within 10 % of each other, 48 slower).
const SOLVE_CHUNK: usize = 16;

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
    /// The sun's positions over the year at the site.
    pub sun_grid: SunGrid,
    /// `[position][seen]`, lx per lx of direct normal illuminance.
    pub sun_seen_lx: Vec<f32>,
    /// `[position][sensor]`, lx per lx of direct normal illuminance.
    pub sun_sensor_lx: Vec<f32>,
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
    let clock = std::time::Instant::now();
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
    // the sun at every grid position above the horizon: more columns of the same solve
    let grid = SunGrid::for_latitude(site.latitude_deg);
    let active = sun_positions_in(&room_dc, &grid, site.latitude_deg);
    let direct_sky_at = clock.elapsed();
    let sun = direct_sun_grid(&room_dc, &active, settings, &wanted)?;
    let direct_sun_at = clock.elapsed();
    let sky = (&direct.patch.values[..], &direct.sensor.values[..]);
    let (seen_lx, sensor_lx) = boundary(c, &all_seen, &seen_patch, sky, COLUMNS, BOUNDARY_SOLVE)?;
    let sky_solve_at = clock.elapsed();
    let (sun_seen, sun_sensor) = if active.is_empty() {
        (Vec::new(), Vec::new())
    } else {
        let sun = (&sun.0[..], &sun.1[..]);
        boundary(c, &all_seen, &seen_patch, sun, active.len(), SUN_SOLVE)?
    };
    tracing::debug!(
        "daylight section: the direct sky in {direct_sky_at:?}, the direct sun at {} positions \
         in {:?}, the sky's solve in {:?}, the sun's in {:?}",
        active.len(),
        direct_sun_at - direct_sky_at,
        sky_solve_at - direct_sun_at,
        clock.elapsed() - sky_solve_at
    );
    let sun_seen_lx = by_position(&sun_seen, &active, grid.positions());
    let sun_sensor_lx = by_position(&sun_sensor, &active, grid.positions());
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
        sun_grid: grid,
        sun_seen_lx,
        sun_sensor_lx,
    })
}

/// The grid positions whose sun can shine in: above the horizon and on the outside of at least
/// one window (its position and world direction). The others have no beam: zero coefficients,
/// without a ray or a column of the solve.
fn sun_positions_in(
    room: &DaylightRoom<'_>,
    grid: &SunGrid,
    latitude_deg: f64,
) -> Vec<(usize, DVec3)> {
    (0..grid.positions())
        .filter_map(|k| {
            let sun = DVec3::from(room.frame.to_world(grid.direction_sky(k, latitude_deg)?));
            room.windows
                .iter()
                .any(|w| -w.inward.dot(sun) > 1e-12)
                .then_some((k, sun))
        })
        .collect()
}

/// The sun's direct light (lx per lx of direct normal illuminance) at the `wanted` patches
/// and every sensor for each of the `active` positions, row-major `[patch][active]` and
/// `[sensor][active]`.
fn direct_sun_grid(
    room: &DaylightRoom<'_>,
    active: &[(usize, DVec3)],
    settings: &DaylightSettings,
    wanted: &(impl Fn(usize) -> bool + Sync),
) -> Result<(Vec<f32>, Vec<f32>), String> {
    let p = active.len();
    let (n, s) = (room.patches.len(), room.sensors.len());
    let (mut patch, mut sensor) = (vec![0.0f32; n * p], vec![0.0f32; s * p]);
    for (q, (_, sun)) in active.iter().enumerate() {
        let d = room
            .direct_sun_where(*sun, settings, wanted)
            .map_err(|e| e.to_string())?;
        for (i, x) in d.patch_lx.iter().enumerate() {
            patch[i * p + q] = *x as f32;
        }
        for (i, x) in d.sensor_lx.iter().enumerate() {
            sensor[i * p + q] = *x as f32;
        }
    }
    Ok((patch, sensor))
}

/// `[row][active]` as `[position][row]` over all `positions` of the grid (zero at the
/// positions not active).
fn by_position(rows_by_active: &[f32], active: &[(usize, DVec3)], positions: usize) -> Vec<f32> {
    let p = active.len();
    let rows = rows_by_active.len() / p.max(1);
    let mut out = vec![0.0f32; positions * rows];
    for (q, (pos, _)) in active.iter().enumerate() {
        for r in 0..rows {
            out[pos * rows + r] = rows_by_active[r * p + q];
        }
    }
    out
}

/// The boundary coefficients: the direct light of each of `k` columns on the unseen patches
/// reflected over them (seen patches held at 0), at the seen patches and the sensors, every
/// column in one solve.
fn boundary(
    c: &Commissioned,
    seen: &[u32],
    stored: &[u32],
    (patch_direct, sensor_direct): (&[f32], &[f32]),
    k: usize,
    stop: crate::solver::SolveOptions,
) -> Result<(Vec<f32>, Vec<f32>), String> {
    let m = &c.model;
    let n = m.patches.len();
    // every patch the camera sees is held at zero, stored or not
    let mut is_seen = vec![false; n];
    for &p in seen {
        is_seen[p as usize] = true;
    }
    let unseen: Vec<u32> = (0..n as u32).filter(|&p| !is_seen[p as usize]).collect();
    let b = solve_in_chunks(c, (&unseen, &is_seen), patch_direct, k, stop)?;
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

/// The boundary solve of `k` columns over the `unseen` rows (the seen ones held at zero),
/// `[patch][k]`. The columns are independent (each stops on its own, its values then frozen),
/// so they are solved in chunks side by side, each chunk's unknowns small enough to stay in a
/// core's cache: the same values as one solve of all of them.
fn solve_in_chunks(
    c: &Commissioned,
    (unseen, is_seen): (&[u32], &[bool]),
    patch_direct: &[f32],
    k: usize,
    stop: crate::solver::SolveOptions,
) -> Result<Vec<f64>, String> {
    let m = &c.model;
    let n = m.patches.len();
    let sys = CsrSystem {
        f: m.ff.f.view(),
        rho: &m.patches.rho,
    };
    let chunks: Vec<(usize, usize)> = (0..k)
        .step_by(SOLVE_CHUNK)
        .map(|c0| (c0, (c0 + SOLVE_CHUNK).min(k)))
        .collect();
    let solved: Vec<Vec<f64>> = chunks
        .par_iter()
        .map(|&(c0, c1)| {
            let kc = c1 - c0;
            let e: Vec<f64> = (0..n * kc)
                .map(|at| {
                    let (i, q) = (at / kc, at % kc);
                    if is_seen[i] {
                        0.0
                    } else {
                        f64::from(patch_direct.get(i * k + c0 + q).copied().unwrap_or(0.0))
                    }
                })
                .collect();
            let mut b = vec![0.0; n * kc];
            let (mut acc, mut state) = (vec![0.0; kc], vec![RhsState::default(); kc]);
            let work = Workspace {
                acc: &mut acc,
                state: &mut state,
            };
            solver::solve(
                &sys,
                Rows::Listed(unseen),
                solver::Source::Irradiance(&e),
                &mut b,
                work,
                stop,
            )
            .map_err(|e| format!("daylight boundary solve: {e}"))?;
            Ok(b)
        })
        .collect::<Result<_, String>>()?;
    let mut b = vec![0.0; n * k];
    for (&(c0, c1), bc) in chunks.iter().zip(&solved) {
        let kc = c1 - c0;
        for i in 0..n {
            b[i * k + c0..i * k + c1].copy_from_slice(&bc[i * kc..i * kc + kc]);
        }
    }
    Ok(b)
}

/// The postcard body of the section, at [`DAYLIGHT_VERSION`] with the sun's beam, or at
/// [`DAYLIGHT_VERSION_WITHOUT_SUN`] without it (an image with no room for it).
pub fn encode(d: &DaylightSectionData, with_sun: bool) -> Result<Vec<u8>, String> {
    let le = |v: &[f32]| -> Vec<u8> {
        v.iter()
            .flat_map(|x| half::f16::from_f32(*x).to_bits().to_le_bytes())
            .collect()
    };
    let seen: Vec<u8> = d.seen_patch.iter().flat_map(|p| p.to_le_bytes()).collect();
    let (seen_lx, sensor_lx) = (le(&d.seen_lx), le(&d.sensor_lx));
    let sun_seen = sparse_sun_seen(&d.sun_seen_lx, d.seen_patch.len())?;
    let sun_sensor = le(&d.sun_sensor_lx);
    let glazing: Vec<u8> = d
        .glazing_seen
        .iter()
        .flat_map(|p| p.to_le_bytes())
        .collect();
    let s = DaylightCoefficients {
        version: section_version(with_sun),
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
        sun_grid: with_sun.then_some(d.sun_grid),
        sun_seen_lx: Bytes(&sun_seen),
        sun_sensor_lx: Bytes(&sun_sensor),
    };
    s.encode().map_err(|e| e.to_string())
}

/// The seen sun coefficients `[position][seen]` in the section's sparse form: per position a
/// count, then (row, f16) for each coefficient of at least [`SUN_SEEN_MIN`].
fn sparse_sun_seen(dense: &[f32], rows: usize) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    for position in dense.chunks(rows.max(1)) {
        let kept: Vec<(u16, f32)> = position
            .iter()
            .enumerate()
            .filter(|(_, x)| **x >= SUN_SEEN_MIN)
            .map(|(r, x)| u16::try_from(r).map(|r| (r, *x)))
            .collect::<Result<_, _>>()
            .map_err(|_| "too many seen rows")?;
        let count = u16::try_from(kept.len()).map_err(|_| "too many seen rows")?;
        out.extend(count.to_le_bytes());
        for (r, x) in kept {
            out.extend(r.to_le_bytes());
            out.extend(half::f16::from_f32(x).to_bits().to_le_bytes());
        }
    }
    Ok(out)
}

/// Room for the section and its framing beyond the dense rows: the seen patches' list, the sun's
/// sparse entries at the seen patches (a few thousand), the glazing list, bytes.
const RESERVE_SLACK_BYTES: usize = 16 * 1024;

/// The flash a room plan's daylight section may take in the image of a room of `sensors` desk
/// sensors, bytes: what commissioning keeps free for it when it shrinks the model and lays out
/// the live section (0 without a plan, a site or a window: no section then).
pub fn reserve_bytes(plan: Option<&RoomPlan>, sensors: usize) -> usize {
    let Some((plan, site)) = plan.and_then(|p| Some((p, p.site.as_ref()?))) else {
        return 0;
    };
    let windows = plan
        .openings
        .iter()
        .any(|o| matches!(o.kind, OpeningKind::Window { .. }));
    if !windows {
        return 0;
    }
    let sky = (MAX_SEEN_ROWS + sensors) * COLUMNS * 2;
    let sun = sensors * SunGrid::for_latitude(site.latitude_deg).positions() * 2;
    sky + sun + RESERVE_SLACK_BYTES
}

/// The section's version with or without the sun's beam.
fn section_version(with_sun: bool) -> u16 {
    if with_sun {
        DAYLIGHT_VERSION
    } else {
        DAYLIGHT_VERSION_WITHOUT_SUN
    }
}

/// The image with the daylight section of a commissioning with a plan added, within the
/// formfactors flash region: with the sun's beam, or, when that does not fit, the sky alone
/// (logged); the image as it is (logged) when there is nothing to add or no room for either.
pub fn with_daylight_section(image: Vec<u8>, c: &Commissioned, plan: Option<&RoomPlan>) -> Vec<u8> {
    let Some(plan) = plan else {
        return image;
    };
    let t0 = std::time::Instant::now();
    let data = Image::parse(&image)
        .map_err(|e| e.to_string())
        .and_then(|img| build(c, plan, &img, &DaylightSettings::default()));
    let data = match data {
        Ok(d) => d,
        Err(why) => {
            tracing::info!("commission: no daylight coefficients: {why}");
            return image;
        }
    };
    let mut tried = Vec::new();
    for with_sun in [true, false] {
        let built = encode(&data, with_sun).and_then(|body| {
            let v = section_version(with_sun);
            crate::image_build::with_section(&image, DAYLIGHT_MAGIC, v, Some(&body))
                .map_err(|e| e.to_string())
        });
        match built {
            Ok(bytes) if bytes.len() <= crate::image_build::formfactors_region_bytes() => {
                tracing::info!(
                    "commission: daylight coefficients of {} bytes added (the plan's windows; \
                     {}) in {:.0} ms",
                    bytes.len() - image.len(),
                    if with_sun {
                        "sky and sun"
                    } else {
                        "the sky alone: no room for the sun's beam"
                    },
                    t0.elapsed().as_secs_f64() * 1e3
                );
                return bytes;
            }
            Ok(bytes) => tried.push(bytes.len() - image.len()),
            Err(why) => {
                tracing::info!("commission: no daylight coefficients: {why}");
                return image;
            }
        }
    }
    tracing::warn!(
        "commission: no room for the daylight coefficients ({tried:?} bytes with and without \
         the sun) in the flash region; daylight through the plan's windows is fitted by emitters"
    );
    image
}
