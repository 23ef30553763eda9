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

/// The newest valid image of a device with A/B slots and its generation; `None` when neither
/// slot holds one.
pub fn read_newest<F: FlashDevice>(
    slots: &mut Slots<F>,
) -> Result<Option<(Vec<u8>, u64)>, FileError>
where
    WriteError<F::Error>: std::fmt::Display,
{
    let status = slots.boot();
    let (Some(slot), Some(generation)) = (status.chosen, status.generation()) else {
        return Ok(None);
    };
    let mut buf = vec![0u8; slots.slot_len()];
    let n = slots
        .read_image(slot, &mut buf)
        .map_err(|e| FileError::Slot {
            slot,
            reason: e.to_string(),
        })?;
    buf.truncate(n);
    Ok(Some((buf, generation)))
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
