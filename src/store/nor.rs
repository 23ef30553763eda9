//! The A/B slots on any `embedded-storage` NOR flash: [`Nor`] turns a
//! [`NorFlash`] driver (a microcontroller's internal
//! flash, an SPI NOR chip's driver) into the [`FlashDevice`] the slots run on. `no_std`, no
//! heap.
//!
//! * **Capacity**: rounded down to whole erase blocks per slot, so both slots start on an erase
//!   boundary and erasing one never touches the other.
//! * **Writes**: the slots write the 40-byte header and the payload that follows it, each once
//!   into erased flash. A write that does not end on a `WRITE_SIZE` boundary is padded with
//!   0xFF (erased) bytes, which nothing writes again. `WRITE_SIZE` must divide the header's 40
//!   bytes (1, 2, 4, 8: every common NOR and MCU flash), so the header and the payload never
//!   share a write unit: [`Nor::new`] refuses other sizes.
//! * **Reads** at any offset and length, through a small aligned bounce buffer when
//!   `READ_SIZE` > 1.
//! * **Sync**: a `NorFlash` write is complete when it returns; nothing to do.

use embedded_storage::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind};

use super::HEADER_LEN;
use super::slots::FlashDevice;

/// Largest READ_SIZE / WRITE_SIZE the adapter handles.
pub const MAX_UNIT: usize = 64;

/// Errors of the adapter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NorError<E> {
    /// The driver failed.
    Flash(E),
    /// An access beyond the device or the adapter's limits.
    OutOfRange,
    /// The driver's geometry does not suit the slots.
    Geometry(&'static str),
}

impl<E: NorFlashError> NorError<E> {
    /// The `embedded-storage` kind.
    pub fn kind(&self) -> NorFlashErrorKind {
        match self {
            NorError::Flash(e) => e.kind(),
            NorError::OutOfRange => NorFlashErrorKind::OutOfBounds,
            NorError::Geometry(_) => NorFlashErrorKind::NotAligned,
        }
    }
}

/// A NOR flash driver as a slot device.
#[derive(Debug)]
pub struct Nor<F> {
    flash: F,
    capacity: usize,
}

impl<F: NorFlash> Nor<F> {
    /// Wraps a driver; the slots use the whole device (rounded down to an even number of erase
    /// blocks).
    pub fn new(flash: F) -> Result<Self, NorError<F::Error>> {
        let (r, w, e) = (F::READ_SIZE, F::WRITE_SIZE, F::ERASE_SIZE);
        if r == 0 || w == 0 || e == 0 || r > MAX_UNIT || w > MAX_UNIT {
            return Err(NorError::Geometry(
                "READ_SIZE and WRITE_SIZE must be 1..=64 and ERASE_SIZE > 0",
            ));
        }
        if !HEADER_LEN.is_multiple_of(w) || !e.is_multiple_of(w) {
            return Err(NorError::Geometry(
                "WRITE_SIZE must divide the 40-byte image header and the erase size",
            ));
        }
        let capacity = flash.capacity() / (2 * e) * (2 * e);
        if capacity == 0 || u32::try_from(capacity).is_err() {
            return Err(NorError::Geometry(
                "the device holds less than two erase blocks, or more than 4 GiB",
            ));
        }
        Ok(Self { flash, capacity })
    }

    /// The driver back.
    pub fn into_inner(self) -> F {
        self.flash
    }

    /// The driver.
    pub fn flash(&mut self) -> &mut F {
        &mut self.flash
    }

    fn range(&self, offset: usize, len: usize) -> Result<(), NorError<F::Error>> {
        if offset.checked_add(len).is_some_and(|e| e <= self.capacity) {
            Ok(())
        } else {
            Err(NorError::OutOfRange)
        }
    }
}

impl<F: NorFlash> FlashDevice for Nor<F> {
    type Error = NorError<F::Error>;

    fn capacity(&self) -> usize {
        self.capacity
    }

    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), Self::Error> {
        self.range(offset, buf.len())?;
        let r = F::READ_SIZE;
        if r == 1 {
            return self.flash.read(offset as u32, buf).map_err(NorError::Flash);
        }
        let mut unit = [0u8; MAX_UNIT];
        let mut done = 0;
        while done < buf.len() {
            let at = offset + done;
            let start = at - at % r;
            let skip = at - start;
            if skip == 0 && buf.len() - done >= r {
                // the aligned middle in one read
                let n = (buf.len() - done) / r * r;
                self.flash
                    .read(at as u32, &mut buf[done..done + n])
                    .map_err(NorError::Flash)?;
                done += n;
                continue;
            }
            self.flash
                .read(start as u32, &mut unit[..r])
                .map_err(NorError::Flash)?;
            let n = (r - skip).min(buf.len() - done);
            buf[done..done + n].copy_from_slice(&unit[skip..skip + n]);
            done += n;
        }
        Ok(())
    }

    fn erase(&mut self, offset: usize, len: usize) -> Result<(), Self::Error> {
        self.range(offset, len)?;
        let e = F::ERASE_SIZE;
        if !offset.is_multiple_of(e) || !len.is_multiple_of(e) {
            return Err(NorError::Geometry("erase not on erase-block boundaries"));
        }
        self.flash
            .erase(offset as u32, (offset + len) as u32)
            .map_err(NorError::Flash)
    }

    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), Self::Error> {
        self.range(offset, data.len())?;
        let w = F::WRITE_SIZE;
        if !offset.is_multiple_of(w) {
            return Err(NorError::Geometry("write not on a WRITE_SIZE boundary"));
        }
        let whole = data.len() / w * w;
        if whole > 0 {
            self.flash
                .write(offset as u32, &data[..whole])
                .map_err(NorError::Flash)?;
        }
        let rest = data.len() - whole;
        if rest > 0 {
            let end = offset + whole + w;
            if end > self.capacity {
                return Err(NorError::OutOfRange);
            }
            let mut unit = [0xFFu8; MAX_UNIT];
            unit[..rest].copy_from_slice(&data[whole..]);
            self.flash
                .write((offset + whole) as u32, &unit[..w])
                .map_err(NorError::Flash)?;
        }
        Ok(())
    }

    fn sync(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}
