//! I2C serial EEPROM of the AT24C32 family (24C32: 4 KiB, 32-byte pages; the same protocol for
//! 24C64 with 8 KiB): page writes and acknowledge polling. `no_std`, against `embedded-hal` 1.0.
//!
//! Source, restated: Microchip AT24C32/64 datasheet (and the 24LC32A's, the same protocol).
//!
//! * Address 0x50 | A2 A1 A0 (0x50..=0x57), two address bytes (high first; 12 bits used).
//! * **Random read**: write the two address bytes, repeated start, read; sequential reads
//!   continue through the array (and wrap at its end).
//! * **Page write**: the two address bytes and 1..=32 data bytes. The page is the 32-byte
//!   block the address falls in: bytes past its end **wrap to its start** (and overwrite what
//!   was sent first), so the driver never sends across a page boundary.
//! * **Write cycle**: after the stop the device programs the page for up to `tWR` = 10 ms and
//!   does not acknowledge its address meanwhile. The driver polls (a two-byte address write,
//!   harmless) every millisecond until the device answers, at most [`POLL_LIMIT_MS`].
//! * **Write protect**: with WP high the device acknowledges the data and does not store it:
//!   the driver reads every page back and reports a mismatch as [`Error::Verify`].

use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::{Error as _, ErrorKind, I2c};

/// Base address (A2..A0 = 0).
pub const BASE_ADDRESS: u8 = 0x50;
/// Page size, bytes.
pub const PAGE: usize = 32;
/// Datasheet write-cycle time, ms.
pub const T_WR_MS: u32 = 10;
/// How long the driver polls for the end of a write cycle, ms (twice `tWR`).
pub const POLL_LIMIT_MS: u32 = 2 * T_WR_MS;

/// Why an access failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error<E> {
    /// The bus failed (no acknowledge: absent; timeout: bus stuck).
    Bus(E),
    /// The access does not fit the device.
    OutOfRange {
        /// Offset.
        offset: usize,
        /// Length.
        len: usize,
        /// Device size.
        size: usize,
    },
    /// The device never acknowledged after a page write.
    WriteTimeout {
        /// Page start.
        offset: usize,
    },
    /// A page reads back different from what was written (write-protected, worn out).
    Verify {
        /// First differing byte.
        offset: usize,
    },
}

impl<E: core::fmt::Debug> core::fmt::Display for Error<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::Bus(e) => write!(f, "I2C: {e:?}"),
            Error::OutOfRange { offset, len, size } => {
                write!(f, "{offset}+{len} is beyond the {size}-byte EEPROM")
            }
            Error::WriteTimeout { offset } => write!(
                f,
                "no acknowledge within {POLL_LIMIT_MS} ms after writing the page at {offset}"
            ),
            Error::Verify { offset } => write!(
                f,
                "byte {offset} reads back different from what was written (WP pin high?)"
            ),
        }
    }
}

/// An EEPROM of `size` bytes at `address`.
#[derive(Debug)]
pub struct At24<I> {
    i2c: I,
    address: u8,
    size: usize,
}

impl<I: I2c> At24<I> {
    /// A 24C32 (4096 bytes) at `address`.
    pub fn new_24c32(i2c: I, address: u8) -> Self {
        Self {
            i2c,
            address,
            size: 4096,
        }
    }

    /// Capacity, bytes.
    pub fn size(&self) -> usize {
        self.size
    }

    /// The bus back.
    pub fn release(self) -> I {
        self.i2c
    }

    fn range(&self, offset: usize, len: usize) -> Result<(), Error<I::Error>> {
        if offset.checked_add(len).is_some_and(|e| e <= self.size) {
            Ok(())
        } else {
            Err(Error::OutOfRange {
                offset,
                len,
                size: self.size,
            })
        }
    }

    /// Random + sequential read of `buf.len()` bytes at `offset`.
    pub fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), Error<I::Error>> {
        self.range(offset, buf.len())?;
        if buf.is_empty() {
            return Ok(());
        }
        let a = (offset as u16).to_be_bytes();
        self.i2c
            .write_read(self.address, &a, buf)
            .map_err(Error::Bus)
    }

    /// Writes `data` at `offset`, page by page, each followed by acknowledge polling and a
    /// read-back.
    pub fn write<D: DelayNs + ?Sized>(
        &mut self,
        delay: &mut D,
        offset: usize,
        data: &[u8],
    ) -> Result<(), Error<I::Error>> {
        self.range(offset, data.len())?;
        let mut done = 0;
        while done < data.len() {
            let at = offset + done;
            let n = (PAGE - at % PAGE).min(data.len() - done);
            let mut frame = [0u8; 2 + PAGE];
            frame[..2].copy_from_slice(&(at as u16).to_be_bytes());
            frame[2..2 + n].copy_from_slice(&data[done..done + n]);
            self.i2c
                .write(self.address, &frame[..2 + n])
                .map_err(Error::Bus)?;
            self.poll(delay, at)?;
            let mut back = [0u8; PAGE];
            self.read(at, &mut back[..n])?;
            if let Some(k) = (0..n).find(|&k| back[k] != data[done + k]) {
                return Err(Error::Verify { offset: at + k });
            }
            done += n;
        }
        Ok(())
    }

    /// Acknowledge polling after a page write.
    fn poll<D: DelayNs + ?Sized>(
        &mut self,
        delay: &mut D,
        at: usize,
    ) -> Result<(), Error<I::Error>> {
        let a = (at as u16).to_be_bytes();
        for _ in 0..POLL_LIMIT_MS {
            delay.delay_ms(1);
            match self.i2c.write(self.address, &a) {
                Ok(()) => return Ok(()),
                // busy programming: it does not acknowledge its address
                Err(e) if matches!(e.kind(), ErrorKind::NoAcknowledge(_)) => {}
                // anything else (a stuck bus) is not a write cycle: give up at once
                Err(e) => return Err(Error::Bus(e)),
            }
        }
        Err(Error::WriteTimeout { offset: at })
    }
}
