//! Image files and flash files on a host: an image file is exactly one image (header +
//! payload); a flash file holds the two slots of [`super::slots`], and reading one yields its
//! newest valid image.

use std::path::{Path, PathBuf};

use super::devices::{DeviceError, FileFlash};
use super::slots::{FlashDevice, Slot, Slots, WriteError};
use super::{HEADER_LEN, Header};

/// Why an image or flash file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// Reading the file failed.
    #[error("reading {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Writing the file failed.
    #[error("writing {}: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The flash file as a device failed.
    #[error("flash {}: {source}", path.display())]
    Device {
        /// The file.
        path: PathBuf,
        /// Why.
        source: DeviceError,
    },
    /// A slot chosen to boot could not be read back.
    #[error("flash: reading slot {slot}: {reason}")]
    Slot {
        /// The slot.
        slot: Slot,
        /// Why.
        reason: String,
    },
}

/// The newest image of a device with A/B slots that decodes and validates, and its generation;
/// `None` when neither slot holds one ([`read_bootable`] without further checks).
pub fn read_newest<F: FlashDevice>(
    slots: &mut Slots<F>,
) -> Result<Option<(Vec<u8>, u64)>, FileError>
where
    WriteError<F::Error>: std::fmt::Display,
{
    Ok(read_bootable(slots, |_, _| Ok(()))
        .image
        .map(|(bytes, _, generation)| (bytes, generation)))
}

/// What [`read_bootable`] found: the image to run, and why newer slots were passed over.
#[derive(Debug, Clone)]
pub struct Bootable {
    /// The image's bytes, its slot and generation; `None`: no slot loads.
    pub image: Option<(Vec<u8>, Slot, u64)>,
    /// Slots with intact CRCs that were refused by the load path, and why (newest first).
    pub refused: Vec<(Slot, u64, String)>,
    /// The slots as the CRCs see them.
    pub status: super::slots::BootStatus,
}

/// The newest image that passes the whole load path: read, [`super::Image::parse`] (decode
/// and validation), then `accept` (the caller's remaining checks: the register map takes it).
/// A newer slot that fails any step is passed over (and listed in [`Bootable::refused`]), so
/// the node falls back to its last known good image instead of stopping for good.
pub fn read_bootable<F: FlashDevice>(
    slots: &mut Slots<F>,
    mut accept: impl FnMut(&super::Image<'_>, u64) -> Result<(), String>,
) -> Bootable
where
    WriteError<F::Error>: std::fmt::Display,
{
    let (order, status) = slots.candidates();
    let mut refused = Vec::new();
    let mut buf = vec![0u8; slots.slot_len()];
    for (slot, generation) in order.into_iter().flatten() {
        let why = match slots.read_image(slot, &mut buf) {
            Err(e) => e.to_string(),
            Ok(n) => match super::Image::parse(&buf[..n]) {
                Err(e) => e.to_string(),
                Ok(image) => match accept(&image, generation) {
                    Err(e) => e,
                    Ok(()) => {
                        buf.truncate(n);
                        return Bootable {
                            image: Some((buf, slot, generation)),
                            refused,
                            status,
                        };
                    }
                },
            },
        };
        tracing::warn!(
            %slot,
            generation,
            "store: slot {slot} (generation {generation}) does not load: {why}; trying the other slot"
        );
        refused.push((slot, generation, why));
    }
    Bootable {
        image: None,
        refused,
        status,
    }
}

/// The newest valid image of a flash file (A/B slots), without changing the file.
pub fn read_flash_image(path: &Path) -> Result<Option<(Vec<u8>, u64)>, FileError> {
    let read = |source| FileError::Read {
        path: path.to_owned(),
        source,
    };
    let len = std::fs::metadata(path).map_err(read)?.len();
    let len = usize::try_from(len).map_err(|_| {
        read(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "larger than the address space",
        ))
    })?;
    let dev = FileFlash::open(path, len).map_err(|source| FileError::Device {
        path: path.to_owned(),
        source,
    })?;
    read_newest(&mut Slots::new(dev))
}

/// An image file, or a flash file with A/B slots (its newest valid image). Anything else is
/// returned as read, for the caller's [`super::Image::parse`] to say what is wrong with it.
pub fn read_image_file(path: &Path) -> Result<Vec<u8>, FileError> {
    let bytes = std::fs::read(path).map_err(|source| FileError::Read {
        path: path.to_owned(),
        source,
    })?;
    // an image file is exactly header + payload; a flash device is longer (two slots)
    let exact = Header::parse(&bytes).is_ok_and(|h| {
        usize::try_from(h.payload_len)
            .ok()
            .and_then(|p| p.checked_add(HEADER_LEN))
            == Some(bytes.len())
    });
    if exact {
        return Ok(bytes);
    }
    if let Ok(Some((image, generation))) = read_flash_image(path) {
        tracing::info!(
            path = %path.display(),
            generation,
            "flash with A/B slots: using its newest valid image"
        );
        return Ok(image);
    }
    Ok(bytes)
}

/// Writes an image file (whole, then renamed into place, so a reader never sees half of one).
pub fn write_image_file(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    let write = |source| FileError::Write {
        path: path.to_owned(),
        source,
    };
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".partial");
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, bytes).map_err(write)?;
    std::fs::rename(&tmp, path).map_err(write)
}
