//! Power-safe storage of the image in two slots (A/B) of a flash device. `no_std`.
//!
//! The device is split in two halves. Writing a new image:
//!
//! 1. pick the slot that does not hold the current image (the other one keeps the last good image
//!    through everything that follows);
//! 2. erase it, write the payload, sync;
//! 3. write the header last (it carries the payload CRC and the generation: a slot with a
//!    torn or missing header is simply invalid), sync;
//! 4. read the slot back and verify it.
//!
//! At boot both slots are inspected (header CRC, version, streaming payload CRC) and the valid
//! one with the highest generation wins; [`BootStatus`] says which and why. A power cut at any
//! point of a write leaves the previous image bootable. CRCs are not the whole story: the node
//! boots the newest image that passes its whole load path and falls back to the other one
//! ([`Slots::candidates`], `store::file::read_bootable`), and writes keep the image it runs
//! ([`Slots::write_image_keeping`]). Generations never wrap.

use core::fmt;

use super::{Crc32, HEADER_LEN, Header, ImageError};

/// A flash device (or a file standing in for one). Offsets are bytes from its start.
pub trait FlashDevice {
    /// The device's error.
    type Error: fmt::Debug;
    /// Size, bytes.
    fn capacity(&self) -> usize;
    /// Reads `buf.len()` bytes at `offset`.
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), Self::Error>;
    /// Erases `len` bytes at `offset` (to 0xFF).
    fn erase(&mut self, offset: usize, len: usize) -> Result<(), Self::Error>;
    /// Writes `data` at `offset` (into erased space).
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), Self::Error>;
    /// Makes every write so far durable.
    fn sync(&mut self) -> Result<(), Self::Error>;
}

/// One of the two slots.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Slot {
    /// The first half of the device.
    A,
    /// The second half.
    B,
}

impl fmt::Display for Slot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Slot::A => "A",
            Slot::B => "B",
        })
    }
}

/// What a slot holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlotState {
    /// A complete image with intact checksums.
    Valid {
        /// Its generation.
        generation: u64,
        /// Its length, bytes.
        len: usize,
    },
    /// No usable image, and why.
    Invalid(ImageError),
    /// The device could not be read.
    Unreadable,
}

impl fmt::Display for SlotState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SlotState::Valid { generation, len } => {
                write!(f, "valid, generation {generation}, {len} bytes")
            }
            SlotState::Invalid(e) => write!(f, "invalid: {e}"),
            SlotState::Unreadable => f.write_str("unreadable"),
        }
    }
}

/// The outcome of a boot: both slots and the choice.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BootStatus {
    /// Slot A.
    pub a: SlotState,
    /// Slot B.
    pub b: SlotState,
    /// The slot to run from (none: not commissioned).
    pub chosen: Option<Slot>,
}

impl BootStatus {
    /// The chosen slot's generation.
    pub fn generation(&self) -> Option<u64> {
        match (self.chosen?, self.a, self.b) {
            (Slot::A, SlotState::Valid { generation, .. }, _)
            | (Slot::B, _, SlotState::Valid { generation, .. }) => Some(generation),
            _ => None,
        }
    }
}

impl fmt::Display for BootStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "slot A: {}; slot B: {}; ", self.a, self.b)?;
        match self.chosen {
            Some(s) => write!(f, "running from slot {s} (newest valid)"),
            None => f.write_str("no valid image: not commissioned"),
        }
    }
}

/// Why a write failed. The previous image is untouched in every case.
#[derive(Debug, Clone, PartialEq)]
pub enum WriteError<E> {
    /// The bytes are not a valid image.
    NotAnImage(ImageError),
    /// The image does not fit a slot.
    TooLarge {
        /// Image length, bytes.
        len: usize,
        /// Slot length, bytes.
        slot_len: usize,
    },
    /// The device failed.
    Device(E),
    /// The written slot does not read back as the image.
    Verify(SlotState),
}

impl<E: fmt::Debug> fmt::Display for WriteError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WriteError::NotAnImage(e) => write!(f, "not a valid image: {e}"),
            WriteError::TooLarge { len, slot_len } => {
                write!(
                    f,
                    "image of {len} bytes does not fit a slot of {slot_len} bytes"
                )
            }
            WriteError::Device(e) => write!(f, "flash device: {e:?}"),
            WriteError::Verify(s) => write!(f, "read-back verification failed: slot {s}"),
        }
    }
}

/// A successful write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriteReport {
    /// The slot written.
    pub slot: Slot,
    /// The generation stamped on the image.
    pub generation: u64,
}

/// Two image slots on a device.
#[derive(Debug)]
pub struct Slots<F> {
    dev: F,
}

const CHUNK: usize = 512;

impl<F: FlashDevice> Slots<F> {
    /// Slots on a device (each takes half of it).
    pub fn new(dev: F) -> Self {
        Self { dev }
    }

    /// The device back.
    pub fn into_inner(self) -> F {
        self.dev
    }

    /// The device.
    pub fn device(&mut self) -> &mut F {
        &mut self.dev
    }

    /// Bytes per slot.
    pub fn slot_len(&self) -> usize {
        self.dev.capacity() / 2
    }

    /// Offset of a slot.
    pub fn offset(&self, slot: Slot) -> usize {
        match slot {
            Slot::A => 0,
            Slot::B => self.slot_len(),
        }
    }

    /// Checks a slot: header, version, and the payload CRC read in chunks (no heap).
    pub fn inspect(&mut self, slot: Slot) -> SlotState {
        let off = self.offset(slot);
        let mut h = [0u8; HEADER_LEN];
        if self.dev.read(off, &mut h).is_err() {
            return SlotState::Unreadable;
        }
        let header = match Header::parse(&h) {
            Ok(h) => h,
            Err(e) => return SlotState::Invalid(e),
        };
        // checked: on a 32-bit target a crafted length must not wrap
        let Some(total) = usize::try_from(header.payload_len)
            .ok()
            .and_then(|len| len.checked_add(HEADER_LEN))
        else {
            return SlotState::Invalid(ImageError::Inconsistent("payload length"));
        };
        let len = total - HEADER_LEN;
        if total > self.slot_len() {
            return SlotState::Invalid(ImageError::Truncated {
                needed: total,
                available: self.slot_len(),
            });
        }
        let mut crc = Crc32::new();
        let mut buf = [0u8; CHUNK];
        let mut done = 0;
        while done < len {
            let n = CHUNK.min(len - done);
            if self
                .dev
                .read(off + HEADER_LEN + done, &mut buf[..n])
                .is_err()
            {
                return SlotState::Unreadable;
            }
            crc.update(&buf[..n]);
            done += n;
        }
        let actual = crc.finish();
        if actual != header.payload_crc32 {
            return SlotState::Invalid(ImageError::PayloadCrc {
                stored: header.payload_crc32,
                actual,
            });
        }
        SlotState::Valid {
            generation: header.generation,
            len: total,
        }
    }

    /// The slots holding an image with intact checksums, newest first: the boot order. The
    /// caller tries each through its whole load path (decode, validation, the register map)
    /// and runs the first that passes, so a newest image that checks out by CRC but does not
    /// load falls back to the last known good one ([`super::file::read_bootable`]).
    pub fn candidates(&mut self) -> ([Option<(Slot, u64)>; 2], BootStatus) {
        let status = self.boot();
        let valid = |slot: Slot, s: SlotState| match s {
            SlotState::Valid { generation, .. } => Some((slot, generation)),
            _ => None,
        };
        let (a, b) = (valid(Slot::A, status.a), valid(Slot::B, status.b));
        let order = match (a, b) {
            (Some(x), Some(y)) if y.1 > x.1 => [b, a],
            (Some(_), _) => [a, b],
            (None, _) => [b, None],
        };
        (order, status)
    }

    /// Inspects both slots and picks the newest valid one.
    pub fn boot(&mut self) -> BootStatus {
        let a = self.inspect(Slot::A);
        let b = self.inspect(Slot::B);
        let chosen = match (a, b) {
            (SlotState::Valid { generation: ga, .. }, SlotState::Valid { generation: gb, .. }) => {
                Some(if gb > ga { Slot::B } else { Slot::A })
            }
            (SlotState::Valid { .. }, _) => Some(Slot::A),
            (_, SlotState::Valid { .. }) => Some(Slot::B),
            _ => None,
        };
        BootStatus { a, b, chosen }
    }

    /// Reads the image of a slot into `buf` (at least its length); returns the length.
    pub fn read_image(
        &mut self,
        slot: Slot,
        buf: &mut [u8],
    ) -> Result<usize, WriteError<F::Error>> {
        match self.inspect(slot) {
            SlotState::Valid { len, .. } => {
                if buf.len() < len {
                    return Err(WriteError::TooLarge {
                        len,
                        slot_len: buf.len(),
                    });
                }
                let off = self.offset(slot);
                self.dev
                    .read(off, &mut buf[..len])
                    .map_err(WriteError::Device)?;
                Ok(len)
            }
            other => Err(WriteError::Verify(other)),
        }
    }

    /// Writes an image into the slot that is not current (the newest by CRC), stamped with the
    /// next generation.
    pub fn write_image(&mut self, image: &[u8]) -> Result<WriteReport, WriteError<F::Error>> {
        let keep = self.boot().chosen;
        self.write_image_keeping(image, keep)
    }

    /// Writes an image into the slot other than `keep` (the image the node runs: its last
    /// known good one, which may be the older slot when the newest did not load), stamped with
    /// `keep`'s generation + 1 so that it wins at the next boot.
    ///
    /// The generation never wraps: when `keep` holds `u64::MAX` the new image is stamped 1 and,
    /// once it is verified, `keep` is erased (a power cut before that erase boots the old
    /// image, as if this write had not happened; after it, the new one).
    pub fn write_image_keeping(
        &mut self,
        image: &[u8],
        keep: Option<Slot>,
    ) -> Result<WriteReport, WriteError<F::Error>> {
        let mut header = Header::parse(image).map_err(WriteError::NotAnImage)?;
        let len = usize::try_from(header.payload_len)
            .ok()
            .and_then(|p| p.checked_add(HEADER_LEN))
            .ok_or(WriteError::NotAnImage(ImageError::Inconsistent(
                "payload length",
            )))?;
        if image.len() < len {
            return Err(WriteError::NotAnImage(ImageError::Truncated {
                needed: len,
                available: image.len(),
            }));
        }
        if len > self.slot_len() {
            return Err(WriteError::TooLarge {
                len,
                slot_len: self.slot_len(),
            });
        }
        let target = match keep {
            Some(Slot::A) => Slot::B,
            _ => Slot::A,
        };
        let kept_generation = keep.and_then(|k| match self.inspect(k) {
            SlotState::Valid { generation, .. } => Some(generation),
            _ => None,
        });
        let (generation, renumber) = match kept_generation {
            None => (1, false),
            Some(g) => match g.checked_add(1) {
                Some(next) => (next, false),
                None => (1, true),
            },
        };
        header.generation = generation;
        let off = self.offset(target);
        let slot_len = self.slot_len();
        let dev = &mut self.dev;
        dev.erase(off, slot_len).map_err(WriteError::Device)?;
        dev.write(off + HEADER_LEN, &image[HEADER_LEN..len])
            .map_err(WriteError::Device)?;
        dev.sync().map_err(WriteError::Device)?;
        dev.write(off, &header.emit()).map_err(WriteError::Device)?;
        dev.sync().map_err(WriteError::Device)?;
        match self.inspect(target) {
            SlotState::Valid { generation, .. } if generation == header.generation => {}
            other => return Err(WriteError::Verify(other)),
        }
        if renumber && let Some(k) = keep {
            let koff = self.offset(k);
            self.dev.erase(koff, slot_len).map_err(WriteError::Device)?;
            self.dev.sync().map_err(WriteError::Device)?;
        }
        Ok(WriteReport {
            slot: target,
            generation: header.generation,
        })
    }
}
