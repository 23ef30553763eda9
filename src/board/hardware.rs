//! Opening a board's real cameras ([`CameraBoard::Hardware`]): the ToF camera with its
//! calibration file, the colour camera, and the colour-to-ToF registration the capture sequence
//! needs.
//!
//! ```ignore
//! let (depth, colour) = board::hardware::open(&board.camera)?;
//! let sequence = SequenceOptions {
//!     registration: board.camera.registration().cloned(),
//!     ..SequenceOptions::default()
//! };
//! ```

use crate::board::camera::{CameraBoard, ColourBoard, TofBoard};
use crate::camera::a010::A010;
use crate::camera::{CameraError, DepthCamera, LuminanceCamera};

/// A board's opened cameras: (depth, colour).
pub type Cameras = (Box<dyn DepthCamera>, Box<dyn LuminanceCamera>);

/// What the node checks of a hardware board before it opens a device: the ToF calibration
/// loads, and the ToF camera reaches the floor.
#[derive(Debug, Clone)]
pub struct Preflight {
    /// The ToF camera's intrinsics and pose.
    pub tof_camera: crate::scene::Camera,
    /// The farthest floor point it sees, along its axis, mm.
    pub floor_mm: f64,
    /// The A010's quantisation unit for that distance (A010 only).
    pub a010_unit_mm: Option<u8>,
}

/// Loads the ToF calibration and checks the ToF camera's range against the floor it must see:
/// a board whose floor is beyond the sensor's range is refused with the reason and the remedy.
pub fn preflight(board: &CameraBoard) -> Result<Preflight, CameraError> {
    let CameraBoard::Hardware { tof, .. } = board else {
        return Err(CameraError::Config(
            "board::hardware::preflight: the board's camera source is not \"hardware\"".into(),
        ));
    };
    match tof {
        TofBoard::A010 {
            options,
            unit_given,
            calibration,
            ..
        } => {
            let camera = crate::scene::load_camera_file(calibration).map_err(|e| {
                CameraError::Config(format!("ToF calibration {}: {e}", calibration.display()))
            })?;
            let floor_mm = crate::camera::a010::floor_distance_mm(&camera).ok_or_else(|| {
                CameraError::Config(format!(
                    "ToF calibration {}: the camera does not look at the floor (z = 0)",
                    calibration.display()
                ))
            })?;
            let unit = if *unit_given {
                crate::camera::a010::check_unit(options.unit_mm, floor_mm)?;
                options.unit_mm
            } else {
                crate::camera::a010::unit_for_distance(floor_mm)?
            };
            Ok(Preflight {
                tof_camera: camera,
                floor_mm,
                a010_unit_mm: Some(unit),
            })
        }
        TofBoard::V4l2 {
            width,
            height,
            max_range_m,
            calibration,
            device,
            ..
        } => {
            let camera = crate::scene::load_camera_file(calibration).map_err(|e| {
                CameraError::Config(format!("ToF calibration {}: {e}", calibration.display()))
            })?;
            if (camera.width, camera.height) != (*width, *height) {
                return Err(CameraError::Config(format!(
                    "ToF calibration {} is {}x{}, camera.tof is {width}x{height}",
                    calibration.display(),
                    camera.width,
                    camera.height
                )));
            }
            let floor_mm = crate::camera::a010::floor_distance_mm(&camera).ok_or_else(|| {
                CameraError::Config(format!(
                    "ToF calibration {}: the camera does not look at the floor (z = 0)",
                    calibration.display()
                ))
            })?;
            if floor_mm * crate::camera::a010::RANGE_MARGIN > max_range_m * 1000.0 {
                return Err(CameraError::Config(format!(
                    "the floor is {:.2} m from the ToF camera {device} and it reaches {max_range_m:.2} m \
                     (camera.tof.max_range_m): it cannot see the floor",
                    floor_mm / 1000.0
                )));
            }
            Ok(Preflight {
                tof_camera: camera,
                floor_mm,
                a010_unit_mm: None,
            })
        }
    }
}

/// Opens the ToF and colour cameras of a hardware board. The ToF camera's intrinsics and pose
/// come from its calibration file (the capture format's `camera.json`); registration of the
/// colour frames is separate ([`CameraBoard::registration`] into
/// [`crate::camera::SequenceOptions::registration`]). A board that is not `Hardware` is a
/// configuration error.
pub fn open(board: &CameraBoard) -> Result<Cameras, CameraError> {
    let CameraBoard::Hardware { tof, colour } = board else {
        return Err(CameraError::Config(
            "board::hardware::open: the board's camera source is not \"hardware\"".into(),
        ));
    };
    let pre = preflight(board)?;
    let depth: Box<dyn DepthCamera> = match tof {
        TofBoard::A010 {
            device,
            baud,
            options,
            ..
        } => {
            let options = crate::camera::a010::A010Options {
                unit_mm: pre.a010_unit_mm.unwrap_or(options.unit_mm),
                ..options.clone()
            };
            tracing::info!(
                "ToF: A010 on {device}, floor at {:.2} m, AT+UNIT={} ({} mm steps, {:.2} m range)",
                pre.floor_mm / 1000.0,
                options.unit_mm,
                options.unit_mm,
                crate::camera::a010::unit_range_mm(options.unit_mm) / 1000.0
            );
            Box::new(A010::open_serial(device, *baud, pre.tof_camera, options)?)
        }
        TofBoard::V4l2 {
            device,
            width,
            height,
            depth_unit_mm,
            timeout,
            ..
        } => open_v4l2_depth(
            device,
            *width,
            *height,
            *depth_unit_mm,
            *timeout,
            pre.tof_camera,
        )?,
    };
    let colour: Box<dyn LuminanceCamera> = match colour {
        ColourBoard::V4l2 {
            device, options, ..
        } => open_v4l2(device, options)?,
    };
    Ok((depth, colour))
}

#[cfg(target_os = "linux")]
fn open_v4l2(
    device: &str,
    options: &crate::camera::v4l2::V4l2Options,
) -> Result<Box<dyn LuminanceCamera>, CameraError> {
    Ok(Box::new(crate::camera::v4l2::open(
        device,
        options.clone(),
    )?))
}

#[cfg(target_os = "linux")]
fn open_v4l2_depth(
    device: &str,
    width: u32,
    height: u32,
    unit_mm: f64,
    timeout: std::time::Duration,
    camera: crate::scene::Camera,
) -> Result<Box<dyn DepthCamera>, CameraError> {
    use crate::camera::stream::{DepthStream, StreamCamera, StreamKind};
    let stream = StreamCamera::new(
        crate::camera::v4l2::MmapDevice::open(device)?,
        device,
        StreamKind::Depth {
            width,
            height,
            unit_mm,
            timeout,
        },
    )?;
    Ok(Box::new(DepthStream { stream, camera }))
}

#[cfg(not(target_os = "linux"))]
fn open_v4l2_depth(
    device: &str,
    _width: u32,
    _height: u32,
    _unit_mm: f64,
    _timeout: std::time::Duration,
    _camera: crate::scene::Camera,
) -> Result<Box<dyn DepthCamera>, CameraError> {
    Err(CameraError::Config(format!(
        "{device}: V4L2 cameras need Linux"
    )))
}

#[cfg(not(target_os = "linux"))]
fn open_v4l2(
    device: &str,
    _options: &crate::camera::v4l2::V4l2Options,
) -> Result<Box<dyn LuminanceCamera>, CameraError> {
    Err(CameraError::Config(format!(
        "{device}: V4L2 cameras need Linux"
    )))
}
