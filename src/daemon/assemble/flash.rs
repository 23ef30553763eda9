//! The node's flash, from its board file: a file of a given size, a raw MTD partition, or (HIL)
//! the file behind a simulated power cut; and the files the node keeps beside its image.

use std::path::{Path, PathBuf};

use super::AssembleError;
use crate::board::Board;
use crate::board::camera::FlashBoard;
use crate::store::devices::{DeviceError, FileFlash};
use crate::store::slots::FlashDevice;

/// Where the image's flash is: a file of a given size, or a raw MTD partition (its size is the
/// partition's).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FlashTarget {
    /// A file and its size, bytes.
    File(PathBuf, usize),
    /// A raw MTD partition (`/dev/mtdN`).
    Mtd(PathBuf),
}

/// The size of one image slot, bytes (the `FORMFACTORS` region).
fn region_bytes() -> usize {
    usize::try_from(crate::layout::FORMFACTORS_LEN_BYTES).unwrap_or(usize::MAX)
}

impl FlashTarget {
    /// The board's flash, or `flash` instead (a file of two slots).
    pub fn of(board: &Board, flash: Option<&Path>) -> Result<Self, AssembleError> {
        let region = region_bytes();
        let (path, capacity) = match (flash, &board.flash) {
            (Some(p), _) => (p.to_path_buf(), 2 * region),
            (None, FlashBoard::File { path, size_bytes }) => (path.clone(), *size_bytes),
            (None, FlashBoard::Mtd { device }) => return Ok(Self::Mtd(PathBuf::from(device))),
        };
        if capacity < 2 * region {
            return Err(AssembleError::Config(format!(
                "board {}: flash of {capacity} bytes is smaller than two {region}-byte image \
                 slots",
                board.name
            )));
        }
        Ok(Self::File(path, capacity))
    }

    /// The flash file or device.
    pub fn path(&self) -> &Path {
        match self {
            Self::File(p, _) | Self::Mtd(p) => p,
        }
    }

    /// Where the node keeps files beside its image (the commissioning report, the ambient
    /// light check's reference, the persisted settings): the flash file's directory, or for a
    /// raw MTD partition `/var/lib/luxnode`.
    pub fn state_dir(&self) -> PathBuf {
        match self {
            Self::File(p, _) => p
                .parent()
                .map(Path::to_path_buf)
                .unwrap_or_else(|| PathBuf::from(".")),
            Self::Mtd(_) => PathBuf::from("/var/lib/luxnode"),
        }
    }

    /// A file beside the image: `<flash file>.<ext>` (`flash.settings.json`), or for a raw MTD
    /// partition `/var/lib/luxnode/mtdN.<ext>`.
    pub fn beside_image(&self, ext: &str) -> PathBuf {
        match self {
            Self::File(p, _) => p.with_extension(ext),
            Self::Mtd(p) => {
                let name = p.file_name().map_or_else(
                    || std::ffi::OsString::from("flash"),
                    std::ffi::OsStr::to_os_string,
                );
                PathBuf::from("/var/lib/luxnode")
                    .join(name)
                    .with_extension(ext)
            }
        }
    }

    /// Opens the flash; `power_cut_after_bytes` (HIL, feature `sim`) puts a file behind a
    /// simulated power cut after that many bytes of the image write.
    pub fn open(
        &self,
        board: &Board,
        power_cut_after_bytes: Option<usize>,
    ) -> Result<Flash, AssembleError> {
        let (path, capacity) = match self {
            Self::File(p, c) => (p, *c),
            Self::Mtd(p) => return open_mtd(p, board),
        };
        let dev = super::super::open_flash_file(path, capacity)?;
        match power_cut_after_bytes {
            None => Ok(Flash::File(dev)),
            #[cfg(feature = "sim")]
            Some(n) => {
                use crate::store::devices::{Faults, FaultyFlash};
                let faults = Faults {
                    cut_after_bytes: Some(n),
                    ..Faults::default()
                };
                Ok(Flash::Faulty(FaultyFlash::new(dev, faults)))
            }
            #[cfg(not(feature = "sim"))]
            Some(_) => Err(AssembleError::Config(
                "a simulated power cut needs the `sim` feature".into(),
            )),
        }
    }
}

/// A raw MTD partition (`/dev/mtdN`, SPI NOR) for the A/B slots.
#[cfg(target_os = "linux")]
fn open_mtd(path: &Path, board: &Board) -> Result<Flash, AssembleError> {
    let region = region_bytes();
    let dev = crate::store::mtd::open(path).map_err(|e| {
        AssembleError::Config(format!("board {}: flash kind \"mtd\": {e}", board.name))
    })?;
    let info = dev.info();
    if dev.capacity() < 2 * region {
        return Err(AssembleError::Config(format!(
            "board {}: MTD partition {} holds {} bytes ({} KiB erase blocks): smaller than two \
             {region}-byte image slots",
            board.name,
            path.display(),
            info.size,
            info.erase_size / 1024
        )));
    }
    tracing::info!(
        "flash: MTD partition {}: {} bytes, {} KiB erase blocks",
        path.display(),
        info.size,
        info.erase_size / 1024
    );
    Ok(Flash::Mtd(dev))
}

#[cfg(not(target_os = "linux"))]
fn open_mtd(path: &Path, board: &Board) -> Result<Flash, AssembleError> {
    Err(AssembleError::Config(format!(
        "board {}: flash kind \"mtd\" ({}) needs Linux",
        board.name,
        path.display()
    )))
}

/// The node's flash: the file, an MTD partition, or (HIL) the file behind a fault injector.
#[derive(Debug)]
pub enum Flash {
    /// A flash file.
    File(FileFlash),
    /// A raw MTD partition.
    #[cfg(target_os = "linux")]
    Mtd(crate::store::mtd::MtdFlash<crate::store::mtd::MtdDevice>),
    /// A flash file behind a simulated power cut.
    #[cfg(feature = "sim")]
    Faulty(crate::store::devices::FaultyFlash<FileFlash>),
}

macro_rules! each_flash {
    ($self:expr, $d:ident => $e:expr) => {
        match $self {
            Flash::File($d) => $e,
            #[cfg(target_os = "linux")]
            Flash::Mtd($d) => $e,
            #[cfg(feature = "sim")]
            Flash::Faulty($d) => $e,
        }
    };
}

impl FlashDevice for Flash {
    type Error = DeviceError;
    fn capacity(&self) -> usize {
        each_flash!(self, d => d.capacity())
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), DeviceError> {
        each_flash!(self, d => d.read(offset, buf))
    }
    fn erase(&mut self, offset: usize, len: usize) -> Result<(), DeviceError> {
        each_flash!(self, d => d.erase(offset, len))
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), DeviceError> {
        each_flash!(self, d => d.write(offset, data))
    }
    fn sync(&mut self) -> Result<(), DeviceError> {
        each_flash!(self, d => d.sync())
    }
}
