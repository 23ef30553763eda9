//! The sky, for daylight coefficients (issue 28): time, the sun's position, the Tregenza
//! subdivision of the sky vault and the CIE standard general sky. No std, no allocation,
//! `f64`, trigonometry from `libm`: it runs on the node.
//!
//! * [`time`]: RFC 3339 timestamps to Unix time, the civil calendar both ways.
//! * [`sun`]: the sun's altitude and azimuth (NOAA), the room's [`SkyFrame`] (its `north`)
//!   that turns sky directions into world directions.
//! * [`sun_grid`]: the sun's positions over a year at a site (declination × hour angle).
//! * [`tregenza`]: the 145 patches, their ranges and solid angles, [`patch_of`].
//! * [`cie`]: the 15 CIE standard skies (ISO 15469) and the 1942 overcast sky, their
//!   relative luminance and diffuse horizontal illuminance.
//!
//! Two frames: the *sky frame* (x east, y north, z up, as Radiance's `gensky`) in which
//! altitude and azimuth are defined, and the room's *world frame* (right-handed, z up), from
//! the room plan's `site.north` (`SkyFrame::new`). Azimuths are measured from geographic
//! north, clockwise seen from above (east = π/2). Angles in radians; degrees only in the
//! arguments that say so (`latitude_deg`, `longitude_deg`).

pub mod cie;
pub mod sun;
pub mod sun_grid;
pub mod time;
pub mod tregenza;

pub use cie::{
    GeneralSky, STANDARD_SKIES, SkyModel, horizontal_illuminance_quadrature_lx,
    horizontal_illuminance_tregenza_lx, patch_luminances_cd_m2,
};
pub use sun::{SkyFrame, SunPosition, altitude_azimuth, sky_direction, sun_position};
pub use sun_grid::SunGrid;
pub use time::{
    TimeError, UnixTime, civil_from_days, days_from_civil, days_in_month, parse_rfc3339,
};
pub use tregenza::{PATCH_COUNT, Patch, patch, patch_of, patches};
