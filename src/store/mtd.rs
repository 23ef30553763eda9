//! The Linux MTD backend: the A/B slots on a raw flash partition, `/dev/mtdN` (SPI NOR), through
//! the MTD character device: `MEMGETINFO` for the geometry, `MEMERASE` for whole erase blocks,
//! `pread`/`pwrite` for the data (the kernel's `mtdchar` interface, `mtd/mtd-abi.h`).
//!
//! * Only NOR-like devices (write size 1: NOR, DataFlash, `mtdram`) are used raw. NAND needs bad
//!   block handling and ECC: put UBI and UBIFS on it and use a flash file (`kind = "file"`).
//! * Erases are on erase-block boundaries (the slots are: the capacity is rounded down to an
//!   even number of erase blocks); a misaligned erase is refused before the kernel sees it.
//! * NOR programming only clears bits: the slots write only into erased blocks and verify by
//!   reading back, so a failed cell is caught, not trusted.
//!
//! [`MtdOps`] is the device interface; [`MtdDevice`] is the real one (ioctls through `nix`), and
//! [`SimMtd`] (feature `sim`) a file with MTD semantics (aligned erases to 0xFF, writes that AND
//! into the cells) for the tests: the `mtdram`/`nandsim` kernel modules that would give a real
//! `/dev/mtdN` cannot be loaded in a container.

use std::path::{Path, PathBuf};

use super::devices::DeviceError;
use super::slots::FlashDevice;

/// `MTD_RAM`.
pub const MTD_RAM: u8 = 1;
/// `MTD_ROM`.
pub const MTD_ROM: u8 = 2;
/// `MTD_NORFLASH`.
pub const MTD_NORFLASH: u8 = 3;
/// `MTD_NANDFLASH`.
pub const MTD_NANDFLASH: u8 = 4;
/// `MTD_DATAFLASH`.
pub const MTD_DATAFLASH: u8 = 6;
/// `MTD_UBIVOLUME`.
pub const MTD_UBIVOLUME: u8 = 7;
/// `MTD_MLCNANDFLASH`.
pub const MTD_MLCNANDFLASH: u8 = 8;
/// `MTD_WRITEABLE` flag.
pub const MTD_WRITEABLE: u32 = 0x400;

/// The geometry `MEMGETINFO` reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MtdInfo {
    /// `MTD_NORFLASH`, `MTD_NANDFLASH`, ...
    pub kind: u8,
    /// `MTD_WRITEABLE`, ...
    pub flags: u32,
    /// Size, bytes.
    pub size: u64,
    /// Erase block, bytes.
    pub erase_size: u32,
    /// Minimal write unit, bytes (1 on NOR).
    pub write_size: u32,
}

/// An MTD device's operations.
pub trait MtdOps {
    /// Geometry.
    fn info(&self) -> MtdInfo;
    /// Erases `[start, start + len)` (erase-block aligned).
    fn erase(&mut self, start: u64, len: u64) -> std::io::Result<()>;
    /// Reads at `offset`.
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()>;
    /// Programs at `offset`.
    fn write_at(&mut self, offset: u64, data: &[u8]) -> std::io::Result<()>;
}

/// The A/B slots' device on an MTD partition.
#[derive(Debug)]
pub struct MtdFlash<D> {
    dev: D,
    path: PathBuf,
    info: MtdInfo,
    capacity: usize,
}

impl<D: MtdOps> MtdFlash<D> {
    /// Checks the geometry and wraps the device (`path` for messages).
    pub fn new(dev: D, path: &Path) -> Result<Self, DeviceError> {
        let info = dev.info();
        let bad = |why: String| DeviceError::Unsupported {
            path: path.to_owned(),
            why,
        };
        match info.kind {
            MTD_NORFLASH | MTD_DATAFLASH | MTD_RAM => {}
            MTD_NANDFLASH | MTD_MLCNANDFLASH => {
                return Err(bad(
                    "a NAND partition: raw NAND needs bad-block handling; put UBI + UBIFS on it \
                     and use a flash file (kind = \"file\")"
                        .into(),
                ));
            }
            k => return Err(bad(format!("MTD type {k} is not NOR flash"))),
        }
        if info.flags & MTD_WRITEABLE == 0 {
            return Err(bad("the partition is read-only".into()));
        }
        if info.write_size != 1 {
            return Err(bad(format!(
                "write size {} (only byte-writable NOR is used raw)",
                info.write_size
            )));
        }
        let e = u64::from(info.erase_size);
        if e == 0 || e > 16 << 20 {
            return Err(bad(format!("erase size {e} bytes")));
        }
        let capacity = info.size / (2 * e) * (2 * e);
        // the slots address bytes with usize and erase with 32-bit MEMERASE
        let capacity = usize::try_from(capacity)
            .ok()
            .filter(|&c| c > 0 && c <= u32::MAX as usize)
            .ok_or_else(|| {
                bad(format!(
                    "size {} bytes with {e}-byte erase blocks",
                    info.size
                ))
            })?;
        Ok(Self {
            dev,
            path: path.to_owned(),
            info,
            capacity,
        })
    }

    /// The geometry.
    pub fn info(&self) -> MtdInfo {
        self.info
    }

    /// The device back.
    pub fn into_inner(self) -> D {
        self.dev
    }

    fn io(&self, source: std::io::Error) -> DeviceError {
        DeviceError::Io {
            path: self.path.clone(),
            source,
        }
    }

    fn range(&self, offset: usize, len: usize) -> Result<(), DeviceError> {
        if offset.checked_add(len).is_some_and(|e| e <= self.capacity) {
            Ok(())
        } else {
            Err(DeviceError::OutOfRange {
                offset,
                len,
                capacity: self.capacity,
            })
        }
    }
}

impl<D: MtdOps> FlashDevice for MtdFlash<D> {
    type Error = DeviceError;

    fn capacity(&self) -> usize {
        self.capacity
    }

    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), DeviceError> {
        self.range(offset, buf.len())?;
        self.dev.read_at(offset as u64, buf).map_err(|e| self.io(e))
    }

    fn erase(&mut self, offset: usize, len: usize) -> Result<(), DeviceError> {
        self.range(offset, len)?;
        let e = self.info.erase_size as usize;
        if !offset.is_multiple_of(e) || !len.is_multiple_of(e) {
            return Err(DeviceError::Misaligned {
                offset,
                len,
                erase_size: e,
            });
        }
        self.dev
            .erase(offset as u64, len as u64)
            .map_err(|e| self.io(e))
    }

    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), DeviceError> {
        self.range(offset, data.len())?;
        self.dev
            .write_at(offset as u64, data)
            .map_err(|e| self.io(e))
    }

    fn sync(&mut self) -> Result<(), DeviceError> {
        // mtdchar writes go to the chip before pwrite returns
        Ok(())
    }
}

#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
mod sys {
    //! `mtd/mtd-abi.h`: the two structures and ioctls used.

    /// `struct mtd_info_user`.
    #[repr(C)]
    #[derive(Default, Clone, Copy)]
    pub struct MtdInfoUser {
        pub type_: u8,
        pub flags: u32,
        pub size: u32,
        pub erasesize: u32,
        pub writesize: u32,
        pub oobsize: u32,
        pub padding: u64,
    }

    /// `struct erase_info_user`.
    #[repr(C)]
    pub struct EraseInfoUser {
        pub start: u32,
        pub length: u32,
    }

    const _: () = assert!(std::mem::size_of::<MtdInfoUser>() == 32);
    const _: () = assert!(std::mem::size_of::<EraseInfoUser>() == 8);

    nix::ioctl_read!(memgetinfo, b'M', 1, MtdInfoUser);
    nix::ioctl_write_ptr!(memerase, b'M', 2, EraseInfoUser);
}

/// A real MTD character device.
#[cfg(target_os = "linux")]
#[derive(Debug)]
pub struct MtdDevice {
    file: std::fs::File,
    info: MtdInfo,
}

#[cfg(target_os = "linux")]
impl MtdDevice {
    /// Opens `/dev/mtdN` and reads its geometry.
    #[allow(unsafe_code)]
    pub fn open(path: &Path) -> Result<Self, DeviceError> {
        use std::os::fd::AsRawFd;
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .map_err(|source| DeviceError::Io {
                path: path.to_owned(),
                source,
            })?;
        let mut raw = sys::MtdInfoUser::default();
        // SAFETY: `file` is open and `raw` a writable, correctly sized `mtd_info_user`.
        unsafe { sys::memgetinfo(file.as_raw_fd(), &mut raw) }.map_err(|e| {
            DeviceError::Unsupported {
                path: path.to_owned(),
                why: format!("MEMGETINFO failed ({e}): not an MTD character device"),
            }
        })?;
        Ok(Self {
            file,
            info: MtdInfo {
                kind: raw.type_,
                flags: raw.flags,
                size: u64::from(raw.size),
                erase_size: raw.erasesize,
                write_size: raw.writesize,
            },
        })
    }
}

#[cfg(target_os = "linux")]
impl MtdOps for MtdDevice {
    fn info(&self) -> MtdInfo {
        self.info
    }

    #[allow(unsafe_code)]
    fn erase(&mut self, start: u64, len: u64) -> std::io::Result<()> {
        use std::os::fd::AsRawFd;
        let e = sys::EraseInfoUser {
            start: u32::try_from(start).map_err(std::io::Error::other)?,
            length: u32::try_from(len).map_err(std::io::Error::other)?,
        };
        // SAFETY: `e` is a valid `erase_info_user` for the duration of the call.
        unsafe { sys::memerase(self.file.as_raw_fd(), &e) }
            .map(|_| ())
            .map_err(|e| std::io::Error::from_raw_os_error(e as i32))
    }

    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        std::os::unix::fs::FileExt::read_exact_at(&self.file, buf, offset)
    }

    fn write_at(&mut self, offset: u64, data: &[u8]) -> std::io::Result<()> {
        std::os::unix::fs::FileExt::write_all_at(&self.file, data, offset)
    }
}

/// Opens an MTD partition for the slots.
#[cfg(target_os = "linux")]
pub fn open(path: &Path) -> Result<MtdFlash<MtdDevice>, DeviceError> {
    MtdFlash::new(MtdDevice::open(path)?, path)
}

/// A file with MTD semantics (feature `sim`): erases must be whole blocks and set them to 0xFF;
/// programming ANDs into the cells (NOR clears bits only), so writing twice without an erase
/// corrupts as real NOR does.
#[cfg(feature = "sim")]
#[derive(Debug)]
pub struct SimMtd {
    file: std::fs::File,
    info: MtdInfo,
    /// Erase operations so far.
    pub erases: u64,
}

#[cfg(feature = "sim")]
impl SimMtd {
    /// Creates (or reuses) `path` as a NOR partition of `size` bytes in `erase_size` blocks.
    pub fn create(path: &Path, size: u64, erase_size: u32) -> std::io::Result<Self> {
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)?;
        let len = file.metadata()?.len();
        if len < size {
            // erased flash reads 0xFF
            let pad = vec![0xFFu8; 1 << 16];
            let mut at = len;
            while at < size {
                let n = (size - at).min(pad.len() as u64) as usize;
                std::os::unix::fs::FileExt::write_all_at(&file, &pad[..n], at)?;
                at += n as u64;
            }
        }
        Ok(Self {
            file,
            info: MtdInfo {
                kind: MTD_NORFLASH,
                flags: MTD_WRITEABLE,
                size,
                erase_size,
                write_size: 1,
            },
            erases: 0,
        })
    }

    /// Another geometry (to test refusals).
    pub fn with_info(mut self, info: MtdInfo) -> Self {
        self.info = info;
        self
    }
}

#[cfg(feature = "sim")]
impl MtdOps for SimMtd {
    fn info(&self) -> MtdInfo {
        self.info
    }

    fn erase(&mut self, start: u64, len: u64) -> std::io::Result<()> {
        let e = u64::from(self.info.erase_size);
        if !start.is_multiple_of(e) || !len.is_multiple_of(e) || start + len > self.info.size {
            // what mtdchar answers for a misaligned or out-of-range erase
            return Err(std::io::Error::from_raw_os_error(nix::libc::EINVAL));
        }
        let ff = vec![0xFFu8; e as usize];
        let mut at = start;
        while at < start + len {
            std::os::unix::fs::FileExt::write_all_at(&self.file, &ff, at)?;
            at += e;
        }
        self.erases += 1;
        Ok(())
    }

    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> std::io::Result<()> {
        std::os::unix::fs::FileExt::read_exact_at(&self.file, buf, offset)
    }

    fn write_at(&mut self, offset: u64, data: &[u8]) -> std::io::Result<()> {
        if offset + data.len() as u64 > self.info.size {
            return Err(std::io::Error::from_raw_os_error(nix::libc::EINVAL));
        }
        let mut cells = vec![0u8; data.len()];
        std::os::unix::fs::FileExt::read_exact_at(&self.file, &mut cells, offset)?;
        for (c, d) in cells.iter_mut().zip(data) {
            *c &= *d;
        }
        std::os::unix::fs::FileExt::write_all_at(&self.file, &cells, offset)
    }
}
