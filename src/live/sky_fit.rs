//! Daylight through the room plan's windows at run time: the image's daylight
//! coefficients ([`crate::store::daylight`]) and the frame's time give, for each CIE standard
//! sky at the frame's sun, one *sky basis*: its light on the seen surfaces and at the desks per
//! unit zenith luminance. The live estimator fits each basis's scale to the daylight the camera
//! sees (the same robust fit as its unknown emitters) and keeps the sky that explains it best;
//! the desks the camera does not see get that sky's daylight.
//!
//! The 15 skies of ISO 15469 and the 1942 overcast sky differ in how the light is spread over
//! the vault, which the seen surfaces tell apart only partly: the desks' spread over the skies
//! that fit nearly as well as the best is part of their stated uncertainty.

use crate::sky::{SkyFrame, SkyModel, SunGrid, UnixTime, patches, sun_position};
use crate::store::Image;
use crate::store::daylight::COLUMNS;

/// The sun must be at least this high for the sky fit, rad (below: civil twilight, the
/// emitter fit handles whatever light there is).
pub const MIN_SUN_ALTITUDE_RAD: f64 = 0.0;

/// The sky types fitted: ISO 15469's 1..=15 and the 1942 overcast sky (16).
pub const SKY_TYPES: core::ops::RangeInclusive<u8> = 1..=16;

/// The stored coefficients, decoded at boot in the live estimator's seen order.
#[derive(Debug, Clone)]
pub struct SkyCoefficients {
    latitude_deg: f64,
    longitude_deg: f64,
    ground_rho: f64,
    /// `[seen row of the estimator][COLUMNS]`.
    seen: Vec<f64>,
    /// Whether the image stores seen row r's coefficients (a subset is stored; the fit uses
    /// only those rows).
    stored: Vec<bool>,
    /// `[sensor][COLUMNS]`.
    sensor: Vec<f64>,
    /// Whether seen row r is glazing (a window the camera sees: its light is in the
    /// coefficients, its measured luminance is the ground's through the glass).
    glazing: Vec<bool>,
    /// The sun's beam per grid position (a version-3 section; `None` before).
    sun: Option<SunCoefficients>,
}

/// The sun's stored coefficients, decoded at boot.
#[derive(Debug, Clone)]
struct SunCoefficients {
    grid: SunGrid,
    /// (estimator seen row, stored row) of every stored seen row the estimator has.
    rows: Vec<(usize, usize)>,
    /// Stored seen rows.
    stored: usize,
    /// `[position][stored row]`, lx per lx of direct normal illuminance.
    seen: Vec<f32>,
    /// `[position][sensor]`.
    sensor: Vec<f32>,
}

/// The sun's beam at one instant, blended from the grid's four positions around it (lx per lx
/// of direct normal illuminance), with the least and most of those positions: where they
/// differ, a sun patch's edge lies between them.
#[derive(Debug, Clone, PartialEq)]
pub struct SunBasis {
    /// At each seen row (the estimator's order; 0 where the image stores none).
    pub seen_lx: Vec<f64>,
    /// The least of the four positions at each seen row.
    pub seen_min_lx: Vec<f64>,
    /// At each sensor.
    pub sensor_lx: Vec<f64>,
    /// The least of the four positions at each sensor.
    pub sensor_min_lx: Vec<f64>,
    /// The most of the four positions at each sensor.
    pub sensor_max_lx: Vec<f64>,
}

/// One candidate sky: its basis at the seen patches and the sensors, per cd/m² of zenith
/// luminance.
#[derive(Debug, Clone)]
pub struct SkyBasis {
    /// The sky type (1..=16).
    pub sky_type: u8,
    /// At each seen patch (the estimator's order), lx.
    pub seen_lx: Vec<f64>,
    /// At each sensor, lx.
    pub sensor_lx: Vec<f64>,
}

impl SkyCoefficients {
    /// From an image's daylight section, with the estimator's seen patches (ascending patch
    /// ids); `None` without a section.
    pub fn from_image(image: &Image<'_>, seen: &[u32]) -> Option<Self> {
        let d = image.daylight.as_ref()?;
        // the columns are in the sky frame already: north only checks the section
        SkyFrame::new(d.north)?;
        let stored: Vec<usize> = (0..d.seen()).map(|r| d.seen_patch(r)).collect();
        let mut seen_rows = vec![0.0; seen.len() * COLUMNS];
        let mut has = vec![false; seen.len()];
        for (r, &p) in seen.iter().enumerate() {
            if let Ok(q) = stored.binary_search(&(p as usize)) {
                has[r] = true;
                for j in 0..COLUMNS {
                    seen_rows[r * COLUMNS + j] = d.seen_lx(q, j);
                }
            }
        }
        let glazing = seen.iter().map(|&p| d.is_glazing(p)).collect();
        let sensors = image.sensors();
        let sensor = (0..sensors * COLUMNS)
            .map(|k| d.sensor_lx(k / COLUMNS, k % COLUMNS))
            .collect();
        let sun = d.sun_grid().map(|grid| {
            let p = grid.positions();
            let rows: Vec<(usize, usize)> = seen
                .iter()
                .enumerate()
                .filter_map(|(r, &q)| stored.binary_search(&(q as usize)).ok().map(|k| (r, k)))
                .collect();
            let n = stored.len();
            let mut seen_sun = vec![0.0f32; p * n];
            d.for_each_sun_seen(|k, r, x| {
                if let Some(o) = seen_sun.get_mut(k * n + r) {
                    *o = x as f32;
                }
            });
            SunCoefficients {
                grid,
                rows,
                stored: n,
                seen: seen_sun,
                sensor: (0..p * sensors)
                    .map(|i| {
                        d.sun_sensor_lx(i / sensors.max(1), i % sensors.max(1), sensors) as f32
                    })
                    .collect(),
            }
        });
        Some(Self {
            sun,
            latitude_deg: d.latitude_deg,
            longitude_deg: d.longitude_deg,
            ground_rho: d.ground_rho,
            seen: seen_rows,
            stored: has,
            sensor,
            glazing,
        })
    }

    /// The relative luminance per column of sky `sky_type` with the sun at `sun_sky`: the
    /// Tregenza patches' centre luminance over the zenith's, and the ground's from the sky's
    /// horizontal illuminance (`ρ_g E_h / π`, sun excluded).
    fn columns(&self, model: &SkyModel, sun_sky: [f64; 3]) -> [f64; COLUMNS] {
        let mut out = [0.0; COLUMNS];
        let mut e_h = 0.0;
        for (o, p) in out.iter_mut().zip(patches()) {
            *o = model.relative_luminance(p.centre(), sun_sky);
            e_h += *o * p.projected_solid_angle_sr;
        }
        out[COLUMNS - 1] = self.ground_rho * e_h / core::f64::consts::PI;
        out
    }

    /// The candidate skies at time `t`, or `None` when the sun is below
    /// [`MIN_SUN_ALTITUDE_RAD`] there.
    pub fn bases(&self, t: UnixTime) -> Option<Vec<SkyBasis>> {
        let sun = sun_position(t, self.latitude_deg, self.longitude_deg);
        if sun.apparent_altitude_rad() < MIN_SUN_ALTITUDE_RAD {
            return None;
        }
        let sun_sky = crate::sky::sky_direction(sun.apparent_altitude_rad(), sun.azimuth_rad);
        let dot = |rows: &[f64], stored: Option<&[bool]>, f: &[f64; COLUMNS]| -> Vec<f64> {
            rows.chunks_exact(COLUMNS)
                .enumerate()
                .map(|(r, row)| match stored.and_then(|m| m.get(r)) {
                    // a seen row the image does not store is out of the fit: no work per frame
                    Some(false) => 0.0,
                    _ => row.iter().zip(f).map(|(a, b)| a * b).sum(),
                })
                .collect()
        };
        Some(
            SKY_TYPES
                .filter_map(|t| {
                    let model = SkyModel::cie_standard(t)?;
                    let f = self.columns(&model, sun_sky);
                    Some(SkyBasis {
                        sky_type: t,
                        seen_lx: dot(&self.seen, Some(&self.stored), &f),
                        sensor_lx: dot(&self.sensor, None, &f),
                    })
                })
                .collect(),
        )
    }

    /// How much of the sun's sky patch each sensor sees through the windows at time t: its
    /// coefficient for the Tregenza patch the sun is in over that patch's projected solid angle
    /// (an upward receiver that sees the whole patch through clear glass: the glazing's
    /// transmittance, about 0.6-0.8; one that does not: the patch's interreflected light alone,
    /// a few hundredths). `None` with the sun below the horizon.
    pub fn sun_views(&self, t: UnixTime) -> Option<Vec<f64>> {
        let sun = sun_position(t, self.latitude_deg, self.longitude_deg);
        if sun.apparent_altitude_rad() < MIN_SUN_ALTITUDE_RAD {
            return None;
        }
        let dir = crate::sky::sky_direction(sun.apparent_altitude_rad(), sun.azimuth_rad);
        let j = crate::sky::patch_of(dir)?;
        let omega = patches().nth(j)?.projected_solid_angle_sr;
        (omega > 0.0).then(|| {
            self.sensor
                .chunks_exact(COLUMNS)
                .map(|row| row[j] / omega)
                .collect()
        })
    }

    /// The sun's beam at time t (see [`SunBasis`]), or `None` without a sun grid in the image
    /// or with the sun below the horizon.
    pub fn sun(&self, t: UnixTime, n_seen: usize) -> Option<SunBasis> {
        let c = self.sun.as_ref()?;
        let pos = sun_position(t, self.latitude_deg, self.longitude_deg);
        if pos.apparent_altitude_rad() < MIN_SUN_ALTITUDE_RAD {
            return None;
        }
        let corners: Vec<(usize, f64)> = c
            .grid
            .weights(pos.declination_rad, pos.hour_angle_rad)
            .into_iter()
            .filter(|(_, w)| *w > 0.0)
            .collect();
        let sensors = self.sensor.len() / COLUMNS;
        // blend, least and most over the corners of one row set
        let blend = |len: usize, at: &dyn Fn(usize, usize) -> f64| -> [Vec<f64>; 3] {
            let [mut mix, mut lo, mut hi] =
                [vec![0.0; len], vec![f64::INFINITY; len], vec![0.0; len]];
            for &(k, w) in &corners {
                let rows = mix.iter_mut().zip(lo.iter_mut()).zip(hi.iter_mut());
                for (i, ((m, l), h)) in rows.enumerate() {
                    let x = at(k, i);
                    *m += w * x;
                    *l = l.min(x);
                    *h = h.max(x);
                }
            }
            lo.iter_mut().for_each(|x| *x = finite_or_zero(*x));
            [mix, lo, hi]
        };
        let seen_at = |k: usize, i: usize| f64::from(c.seen[k * c.stored + i]);
        let [stored_lx, stored_min, _] = blend(c.stored, &seen_at);
        let (mut seen_lx, mut seen_min_lx) = (vec![0.0; n_seen], vec![0.0; n_seen]);
        for &(r, q) in &c.rows {
            if r < n_seen {
                seen_lx[r] = stored_lx[q];
                seen_min_lx[r] = stored_min[q];
            }
        }
        let sensor_at = |k: usize, i: usize| f64::from(c.sensor[k * sensors + i]);
        let [sensor_lx, sensor_min_lx, sensor_max_lx] = blend(sensors, &sensor_at);
        Some(SunBasis {
            seen_lx,
            seen_min_lx,
            sensor_lx,
            sensor_min_lx,
            sensor_max_lx,
        })
    }

    /// Whether seen row r has stored coefficients (the sky fit's rows).
    pub fn stored(&self, r: usize) -> bool {
        self.stored.get(r).copied().unwrap_or(false)
    }

    /// Whether seen row r is a window's glass.
    pub fn glazing(&self, r: usize) -> bool {
        self.glazing.get(r).copied().unwrap_or(false)
    }

    /// Heap bytes.
    pub fn memory_bytes(&self) -> usize {
        (self.seen.len() + self.sensor.len()) * core::mem::size_of::<f64>()
            + self.glazing.len()
            + self.sun.as_ref().map_or(0, |c| {
                (c.seen.len() + c.sensor.len()) * core::mem::size_of::<f32>()
                    + c.rows.len() * 2 * core::mem::size_of::<usize>()
            })
    }
}

fn finite_or_zero(x: f64) -> f64 {
    if x.is_finite() { x } else { 0.0 }
}
