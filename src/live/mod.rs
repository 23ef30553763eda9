//! Live light: the cameras at run time. A luminance frame (and a depth frame) every few seconds
//! becomes measured desk lux with the daylight in it, split into the luminaires' part and the
//! extraneous part, with flags for covered desks, ageing luminaires and a changed room. No image
//! leaves the node: frames are used and dropped; only per-desk aggregates are published.
//!
//! ## Method
//!
//! At commissioning ([`crate::live_section`]) the image gets a live section ([`crate::store::live`]): camera
//! pixels (every `stride`-th, and all around each in-view desk sensor) with the patch each sees,
//! the commissioned depth, and the irradiance there from each luminaire at 100 % (`E_l`, from the
//! one-luminaire frames less the all-off frame, or from the engine on a CAD model).
//!
//! At run time ([`estimator`]), for each sample p of a frame (gain g, luminance L):
//!
//! ```text
//! measured   M(p) = π g L(p) / ρ(p)              (a Lambertian surface: L = ρ E / π)
//! artificial A(p) = Σ_l x_l a_l E_l(p)            (x_l the dimming level, a_l the ageing factor)
//! extraneous D(p) = M(p) − A(p)                   (daylight, any light the model does not know)
//! ```
//!
//! A sample is dropped where the depth frame disagrees with the commissioned depth (by more than
//! 5 cm and 3 %: a person, a box), or where it is saturated.
//!
//! * **A desk the camera sees** (its window has samples): `D̂` = the weighted median of `D` over
//!   the window (Gaussian weights of twice the fit's σ: 5 cm in the open); artificial
//!   `Â = Σ_l x_l a_l R_l` with `R_l` the desk's commissioned response, which at an in-view desk
//!   is the model calibrated by the camera's row `Ẽ_l` (the plane fit of `E_l` over the window
//!   at the sensor, with σ chosen per desk by [`window::window_sigma_m`]: 2.5 cm in the open,
//!   narrower at a shade's edge; [`desk_scale`] weighs the two); **total = Â + D̂**
//!   (*measured*). `Ẽ_l` itself stays in the image: its disagreement with `R_l` widens the
//!   desk's stated uncertainty. Daylight = max(D̂, 0); a negative
//!   residual (the luminaires give less than the model says) counts against the artificial part.
//! * **A desk the camera does not see**, or a covered one with nothing measured before:
//!   artificial = the radiosity model `Σ_l x_l a_l R_l`; daylight **inferred**:
//!   1. per seen patch, the median `D̄_i`; its exitance `ρ_i D̄_i` is *measured*;
//!   2. the unseen patches reflect it: `b_u = ρ_u Σ_j F_uj b_j` (Gauss-Seidel over the stored
//!      form factors, the seen patches held at their measured exitance);
//!   3. what that leaves unexplained on the seen surfaces, `D̄_i − (F b)_i`, is fitted by
//!      *unknown emitters* (groups of unseen patches: windows in walls, any unmodelled light, each
//!      of unknown exitance `w_k ≥ 0`) by weighted non-negative least squares ([`nnls`]) with a
//!      small ridge (an emitter the seen surfaces hardly see is not estimable from them), twice:
//!      the second time without the outliers of the first. Seen patches in direct sun (more than
//!      8 times the median unexplained light) are left out from the start: they are measured
//!      and their reflection propagates in step 2, but no diffuse emitter explains them
//!      (against Radiance under a clear sky, fitting them put 19 klx on a 1.7 klx desk);
//!   4. the desk reads `gather_s · (b + Σ_k w_k β_k)` (its stored gather row over the exitance;
//!      `β_k` the emitters' exitance with their interreflections); its stated uncertainty
//!      carries how well the seen surfaces place the emitters ([`emitters::placement_lx`]), and
//!      a value whose uncertainty exceeds it is published as its artificial part alone, the
//!      total and daylight not available ([`flags::DAYLIGHT_UNKNOWN`]).
//!
//! With a room plan's daylight coefficients and the frame's time, step 3 fits a CIE sky through
//! the plan's windows instead ([`sky_fit`]); a window the camera sees is held at zero exitance
//! there (the camera sees the ground through it, not the sky it lets in). With the sun's beam in
//! the section (version 3), the sun's strength is then fitted to the seen patches in its beam
//! ([`sun_fit`]), and the desks in the beam get their share of it, or, when the camera can only
//! bound it or cannot see the beam, are not available.
//!
//! **Held values.** A covered desk, a saturated window, a bad or stale frame: the desk keeps its
//! last good daylight and gets the artificial part at the current dimming state (so with the
//! dimming unchanged the value is exactly the last good one), flagged, with the age of the frame
//! it comes from. A desk covered for longer than [`LiveSettings::stale_after_s`] (a box left on
//! it, the desk moved away) gets the inferred daylight instead, like a desk out of view, still
//! flagged occluded. A saturated window is at least as bright as its saturated samples at the
//! saturation level say (a desk in the sun: tens of klx); a held or inferred daylight below that
//! contradicts the camera, and the desk's total and daylight are not available instead
//! ([`flags::DAYLIGHT_UNKNOWN`], with [`flags::SATURATED`]), its artificial part kept.
//!
//! **Ageing.** A frame is *night* when two non-negative fits give the unknown emitters less than
//! [`LiveSettings::night_fraction`] (0.5 %) of the measured light on the seen surfaces: a joint
//! fit of one factor per luminaire and the emitters, and the emitters' fit at the current
//! factors (the joint fit alone takes a window's light for brighter luminaires near it).
//! Night frames accumulate the luminaires' least-squares fit; after enough of them, the first day
//! frame sets each luminaire's ageing factor `a_l` (measured / commissioned light), which scales
//! its column of the response matrix everywhere (live values, the core desk-lux block, the
//! control plant).
//!
//! **Geometry.** A sample whose depth disagrees for [`LiveSettings::geometry_frames`] frames in a
//! row has changed (a moved desk, not a person passing); a desk whose window has mostly changed is
//! flagged and recommissioning advised; so it is when more than
//! [`LiveSettings::geometry_area_fraction`] of the samples changed.
//!
//! ## For the lighting control (`crate::control`)
//!
//! [`Live::daylight_for_control`] gives the daylight per desk (`None` when stale: the regulator
//! then plans without daylight, the safe side); [`Live::ageing`] the factor per luminaire, which
//! [`aged_response`] applies to the response matrix of the control plant.

pub mod desk_scale;
pub mod emitters;
pub mod estimator;
pub mod nnls;
pub mod sky_fit;
pub mod sun_fit;
pub mod window;

pub use estimator::{
    DISAGREEMENT_TO_SIGMA, DeskLive, FrameReport, Live, LiveFrame, LiveModel, LiveSettings,
    MIN_UNCERTAINTY_LX, Source, Verdict, model_camera_disagreement, stated_uncertainty_lx,
};

/// Why live light cannot run.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// The image has no live section (commissioned before live light, or without a camera).
    #[error(
        "the image has no live-light section: commission again (with the cameras) to enable live light"
    )]
    NoSection,
    /// A setting or an input is unusable.
    #[error("{0}")]
    Input(String),
    /// The stored radiosity system does not solve (checked at boot).
    #[error("live light: the stored radiosity system: {0}")]
    Solve(crate::solver::SolveError),
}

/// Flag bits of a desk's live value (`DeskLive::flags`, Modbus input 4100 + k): the register
/// map's own bits ([`crate::modbus::regmap::live_flags`]).
pub mod flags {
    pub use crate::modbus::regmap::live_flags::*;

    /// The flags as words, for logs and the CLI.
    pub fn describe(f: u16) -> String {
        let names = [
            (OCCLUDED, "occluded"),
            (HELD, "held"),
            (STALE, "stale"),
            (BAD_FRAME, "bad_frame"),
            (SATURATED, "saturated"),
            (AGEING, "ageing"),
            (GEOMETRY_CHANGED, "geometry_changed"),
            (NO_DEPTH, "no_depth"),
            (NOT_ESTIMATED, "not_estimated"),
            (DAYLIGHT_UNKNOWN, "daylight_unknown"),
            (SUN_MAY_REACH, "sun_may_reach"),
        ];
        let v: Vec<&str> = names
            .iter()
            .filter(|(b, _)| f & b != 0)
            .map(|(_, n)| *n)
            .collect();
        v.join("|")
    }
}

/// The response matrix `R_kj` (desks × luminaires, row-major) with each luminaire's column scaled
/// by its ageing factor: the plant of the lighting control once ageing is measured.
pub fn aged_response(response_lx: &[f64], ageing: &[f64], out: &mut [f64]) {
    let l = ageing.len().max(1);
    for (k, (o, r)) in out.iter_mut().zip(response_lx).enumerate() {
        *o = r * ageing.get(k % l).copied().unwrap_or(1.0);
    }
}
