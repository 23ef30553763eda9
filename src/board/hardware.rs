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
    let depth: Box<dyn DepthCamera> = match tof {
        TofBoard::A010 {
            device,
            baud,
            options,
            calibration,
        } => {
            let camera = crate::scene::load_camera_file(calibration).map_err(|e| {
                CameraError::Config(format!("ToF calibration {}: {e}", calibration.display()))
            })?;
            Box::new(A010::open_serial(device, *baud, camera, options.clone())?)
        }
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
    Ok(Box::new(crate::camera::v4l2::V4l2Camera::open(
        device,
        options.clone(),
    )?))
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
