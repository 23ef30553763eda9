//! Flash devices for Linux and for tests: in memory, a file (the Linux backend: a partition
//! image on eMMC/ext4 or UBIFS, every sync an `fdatasync`), and a fault-injecting wrapper (power
//! cut after N bytes, bit flips, stuck pages) in the manner of smoltcp's `FaultInjector`.

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::slots::FlashDevice;

/// Errors of the std devices.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    /// An access beyond the device.
    #[error("access at {offset}+{len} beyond the device's {capacity} bytes")]
    OutOfRange {
        /// Offset.
        offset: usize,
        /// Length.
        len: usize,
        /// Capacity.
        capacity: usize,
    },
    /// The simulated power was cut.
    #[error("power cut")]
    PowerCut,
    /// An erase not on erase-block boundaries (a raw MTD partition).
    #[error("erase at {offset}+{len} is not on {erase_size}-byte erase blocks")]
    Misaligned {
        /// Offset.
        offset: usize,
        /// Length.
        len: usize,
        /// Erase block, bytes.
        erase_size: usize,
    },
    /// The device cannot hold the slots (NAND, read-only, not an MTD device, ...).
    #[error("{}: {why}", path.display())]
    Unsupported {
        /// The device.
        path: PathBuf,
        /// Why.
        why: String,
    },
    /// File I/O.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

fn range(offset: usize, len: usize, capacity: usize) -> Result<(), DeviceError> {
    if offset.checked_add(len).is_some_and(|e| e <= capacity) {
        Ok(())
    } else {
        Err(DeviceError::OutOfRange {
            offset,
            len,
            capacity,
        })
    }
}

/// Flash in memory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MemFlash {
    /// The contents.
    pub data: Vec<u8>,
}

impl MemFlash {
    /// An erased device of `capacity` bytes.
    pub fn new(capacity: usize) -> Self {
        Self {
            data: vec![0xFF; capacity],
        }
    }

    /// Flips one stored bit (a failing cell).
    pub fn flip_bit(&mut self, offset: usize, bit: u8) {
        if let Some(b) = self.data.get_mut(offset) {
            *b ^= 1 << (bit % 8);
        }
    }
}

impl FlashDevice for MemFlash {
    type Error = DeviceError;
    fn capacity(&self) -> usize {
        self.data.len()
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), DeviceError> {
        range(offset, buf.len(), self.data.len())?;
        buf.copy_from_slice(&self.data[offset..offset + buf.len()]);
        Ok(())
    }
    fn erase(&mut self, offset: usize, len: usize) -> Result<(), DeviceError> {
        range(offset, len, self.data.len())?;
        self.data[offset..offset + len].fill(0xFF);
        Ok(())
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), DeviceError> {
        range(offset, data.len(), self.data.len())?;
        self.data[offset..offset + data.len()].copy_from_slice(data);
        Ok(())
    }
    fn sync(&mut self) -> Result<(), DeviceError> {
        Ok(())
    }
}

/// A flash partition as a file: a regular file (created erased if missing, on eMMC/ext4 or
/// UBIFS) or a device node such as `/dev/mtdblock3` (an MTD partition through the kernel's
/// mtdblock layer, which erases and rewrites its blocks itself). Every `sync` is an
/// `fdatasync`, so a write that returned is on the medium. A device node is never padded or
/// resized: it must hold at least `capacity` bytes.
#[derive(Debug)]
pub struct FileFlash {
    file: File,
    path: PathBuf,
    capacity: usize,
}

impl FileFlash {
    /// Opens (or creates, erased) a flash file of `capacity` bytes.
    pub fn open(path: &Path, capacity: usize) -> Result<Self, DeviceError> {
        let io = |source| DeviceError::Io {
            path: path.to_path_buf(),
            source,
        };
        let existed = path.exists();
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(!existed)
            .truncate(false)
            .open(path)
            .map_err(io)?;
        let meta = file.metadata().map_err(io)?;
        if !meta.file_type().is_file() {
            // a block or character device: its size is where a seek to the end lands
            let size = file.seek(SeekFrom::End(0)).map_err(io)? as usize;
            if size < capacity {
                return Err(DeviceError::OutOfRange {
                    offset: 0,
                    len: capacity,
                    capacity: size,
                });
            }
            return Ok(Self {
                file,
                path: path.to_path_buf(),
                capacity,
            });
        }
        let len = meta.len() as usize;
        if !existed || len < capacity {
            file.seek(SeekFrom::Start(len as u64)).map_err(io)?;
            // erased (0xFF) padding in 64 KiB chunks: never the whole size in memory
            let chunk = vec![0xFF; (capacity - len).min(1 << 16)];
            let mut left = capacity - len;
            while left > 0 {
                let n = left.min(chunk.len());
                file.write_all(&chunk[..n]).map_err(io)?;
                left -= n;
            }
            file.sync_all().map_err(io)?;
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                // make the new file's directory entry durable too
                File::open(dir).and_then(|d| d.sync_all()).map_err(io)?;
            }
        }
        Ok(Self {
            file,
            path: path.to_path_buf(),
            capacity,
        })
    }

    fn io(&self, source: std::io::Error) -> DeviceError {
        DeviceError::Io {
            path: self.path.clone(),
            source,
        }
    }
}

impl FlashDevice for FileFlash {
    type Error = DeviceError;
    fn capacity(&self) -> usize {
        self.capacity
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), DeviceError> {
        range(offset, buf.len(), self.capacity)?;
        self.file
            .seek(SeekFrom::Start(offset as u64))
            .map_err(|e| self.io(e))?;
        self.file.read_exact(buf).map_err(|e| self.io(e))
    }
    fn erase(&mut self, offset: usize, len: usize) -> Result<(), DeviceError> {
        range(offset, len, self.capacity)?;
        self.file
            .seek(SeekFrom::Start(offset as u64))
            .map_err(|e| self.io(e))?;
        let chunk = vec![0xFF; len.min(1 << 16)];
        let mut left = len;
        while left > 0 {
            let n = left.min(chunk.len());
            self.file.write_all(&chunk[..n]).map_err(|e| self.io(e))?;
            left -= n;
        }
        Ok(())
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), DeviceError> {
        range(offset, data.len(), self.capacity)?;
        self.file
            .seek(SeekFrom::Start(offset as u64))
            .map_err(|e| self.io(e))?;
        self.file.write_all(data).map_err(|e| self.io(e))
    }
    fn sync(&mut self) -> Result<(), DeviceError> {
        self.file.sync_data().map_err(|e| self.io(e))
    }
}

/// Faults to inject.
#[cfg(feature = "sim")]
#[derive(Debug, Clone, Default)]
pub struct Faults {
    /// Power fails after this many bytes have been erased or written: the operation in progress
    /// stops there and every later operation fails.
    pub cut_after_bytes: Option<usize>,
    /// Writes to these pages do not take (the cells are stuck).
    pub stuck_pages: Vec<usize>,
    /// Page size for `stuck_pages`, bytes.
    pub page_size: usize,
    /// Transient bit flips on reads: (offset, bit) flipped in what a read returns.
    pub read_bit_flips: Vec<(usize, u8)>,
}

/// A device that misbehaves as told.
#[cfg(feature = "sim")]
#[derive(Debug)]
pub struct FaultyFlash<D> {
    inner: D,
    faults: Faults,
    touched: usize,
    dead: bool,
}

#[cfg(feature = "sim")]
impl<D: FlashDevice<Error = DeviceError>> FaultyFlash<D> {
    /// Wraps a device.
    pub fn new(inner: D, faults: Faults) -> Self {
        Self {
            inner,
            faults,
            touched: 0,
            dead: false,
        }
    }

    /// The device as the power cut left it ("reboot").
    pub fn into_inner(self) -> D {
        self.inner
    }

    /// True once the power was cut.
    pub fn power_cut(&self) -> bool {
        self.dead
    }

    /// Bytes the next operation may touch before the cut (all of `len` when no cut is due).
    fn budget(&mut self, len: usize) -> usize {
        match self.faults.cut_after_bytes {
            Some(limit) => limit.saturating_sub(self.touched).min(len),
            None => len,
        }
    }

    fn stuck(&self, offset: usize) -> bool {
        self.faults.page_size > 0
            && self
                .faults
                .stuck_pages
                .contains(&(offset / self.faults.page_size))
    }
}

#[cfg(feature = "sim")]
impl<D: FlashDevice<Error = DeviceError>> FlashDevice for FaultyFlash<D> {
    type Error = DeviceError;
    fn capacity(&self) -> usize {
        self.inner.capacity()
    }
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), DeviceError> {
        if self.dead {
            return Err(DeviceError::PowerCut);
        }
        self.inner.read(offset, buf)?;
        for &(at, bit) in &self.faults.read_bit_flips {
            if (offset..offset + buf.len()).contains(&at) {
                buf[at - offset] ^= 1 << (bit % 8);
            }
        }
        Ok(())
    }
    fn erase(&mut self, offset: usize, len: usize) -> Result<(), DeviceError> {
        if self.dead {
            return Err(DeviceError::PowerCut);
        }
        let n = self.budget(len);
        self.inner.erase(offset, n)?;
        self.touched += n;
        if n < len {
            self.dead = true;
            return Err(DeviceError::PowerCut);
        }
        Ok(())
    }
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), DeviceError> {
        if self.dead {
            return Err(DeviceError::PowerCut);
        }
        let n = self.budget(data.len());
        // byte by byte only where pages are stuck; otherwise one write
        if self.faults.stuck_pages.is_empty() {
            self.inner.write(offset, &data[..n])?;
        } else {
            for (k, b) in data[..n].iter().enumerate() {
                if !self.stuck(offset + k) {
                    self.inner.write(offset + k, std::slice::from_ref(b))?;
                }
            }
        }
        self.touched += n;
        if n < data.len() {
            self.dead = true;
            return Err(DeviceError::PowerCut);
        }
        Ok(())
    }
    fn sync(&mut self) -> Result<(), DeviceError> {
        if self.dead {
            return Err(DeviceError::PowerCut);
        }
        self.inner.sync()
    }
}

/// A NOR flash with strict semantics behind the `embedded-storage` traits (feature `sim`):
/// `WRITE_SIZE` 4, `ERASE_SIZE` 4 KiB, `READ_SIZE` 4 (an MCU's internal flash, say); erases
/// and writes must be aligned, programming only clears bits, and the power can be cut after
/// a number of programmed or erased bytes.
#[cfg(feature = "sim")]
#[derive(Debug, Clone)]
pub struct SimNor {
    /// The cells.
    pub data: Vec<u8>,
    /// Power fails after this many bytes erased or programmed.
    pub cut_after_bytes: Option<usize>,
    touched: usize,
}

/// Errors of [`SimNor`].
#[cfg(feature = "sim")]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimNorError {
    /// Misaligned.
    NotAligned,
    /// Out of bounds.
    OutOfBounds,
    /// The power was cut.
    PowerCut,
}

#[cfg(feature = "sim")]
impl embedded_storage::nor_flash::NorFlashError for SimNorError {
    fn kind(&self) -> embedded_storage::nor_flash::NorFlashErrorKind {
        use embedded_storage::nor_flash::NorFlashErrorKind as K;
        match self {
            SimNorError::NotAligned => K::NotAligned,
            SimNorError::OutOfBounds => K::OutOfBounds,
            SimNorError::PowerCut => K::Other,
        }
    }
}

#[cfg(feature = "sim")]
impl SimNor {
    /// An erased device of `capacity` bytes.
    pub fn new(capacity: usize) -> Self {
        Self {
            data: vec![0xFF; capacity],
            cut_after_bytes: None,
            touched: 0,
        }
    }

    fn spend(&mut self, n: usize) -> Result<usize, SimNorError> {
        let allowed = match self.cut_after_bytes {
            Some(limit) => limit.saturating_sub(self.touched).min(n),
            None => n,
        };
        if allowed == 0 && n > 0 {
            return Err(SimNorError::PowerCut);
        }
        self.touched += allowed;
        Ok(allowed)
    }
}

#[cfg(feature = "sim")]
impl embedded_storage::nor_flash::ErrorType for SimNor {
    type Error = SimNorError;
}

#[cfg(feature = "sim")]
impl embedded_storage::nor_flash::ReadNorFlash for SimNor {
    const READ_SIZE: usize = 4;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), SimNorError> {
        let o = offset as usize;
        if !o.is_multiple_of(4) || !bytes.len().is_multiple_of(4) {
            return Err(SimNorError::NotAligned);
        }
        let src = self
            .data
            .get(o..o + bytes.len())
            .ok_or(SimNorError::OutOfBounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }
    fn capacity(&self) -> usize {
        self.data.len()
    }
}

#[cfg(feature = "sim")]
impl embedded_storage::nor_flash::NorFlash for SimNor {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = 4096;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), SimNorError> {
        let (f, t) = (from as usize, to as usize);
        if !f.is_multiple_of(4096) || !t.is_multiple_of(4096) || t < f {
            return Err(SimNorError::NotAligned);
        }
        if t > self.data.len() {
            return Err(SimNorError::OutOfBounds);
        }
        let n = self.spend(t - f)?;
        self.data[f..f + n].fill(0xFF);
        if n < t - f {
            return Err(SimNorError::PowerCut);
        }
        Ok(())
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), SimNorError> {
        let o = offset as usize;
        if !o.is_multiple_of(4) || !bytes.len().is_multiple_of(4) {
            return Err(SimNorError::NotAligned);
        }
        if o + bytes.len() > self.data.len() {
            return Err(SimNorError::OutOfBounds);
        }
        let n = self.spend(bytes.len())?;
        for (c, b) in self.data[o..o + n].iter_mut().zip(bytes) {
            *c &= *b;
        }
        if n < bytes.len() {
            return Err(SimNorError::PowerCut);
        }
        Ok(())
    }
}
