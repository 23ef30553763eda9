//! The A/B slots on the two new flash backends: any `embedded-storage` NOR flash (through
//! `store::nor::Nor`, on a strict simulated NOR: aligned erases and writes, programming clears
//! bits only) and a raw Linux MTD partition (through `store::mtd::MtdFlash`, on a file with MTD
//! semantics: no real `/dev/mtdN` exists here, and `mtdram`/`nandsim` cannot be loaded in a
//! container). Each: images written and booted, newest wins, a power cut at every point of a
//! write keeps the last good image, geometry it cannot use is refused with the reason.

mod common;

use common::small_image;
use luxnode::store::HEADER_LEN;
use luxnode::store::devices::{DeviceError, Faults, FaultyFlash, SimNor, SimNorError};
use luxnode::store::mtd::{MTD_NANDFLASH, MTD_NORFLASH, MTD_WRITEABLE, MtdFlash, MtdInfo, SimMtd};
use luxnode::store::nor::{Nor, NorError};
use luxnode::store::slots::{FlashDevice, Slot, SlotState, Slots, WriteError};

fn generation(s: SlotState) -> Option<u64> {
    match s {
        SlotState::Valid { generation, .. } => Some(generation),
        _ => None,
    }
}

#[test]
fn slots_on_an_embedded_storage_nor_flash() {
    let img1 = small_image(1.0);
    let img2 = small_image(2.0);
    // 64 KiB + 1 KiB: the adapter uses whole erase blocks per slot (2 × 32 KiB)
    let nor = SimNor::new(65 * 1024);
    let mut slots = Slots::new(Nor::new(nor).unwrap());
    assert_eq!(slots.slot_len(), 32 * 1024);
    assert_eq!(slots.boot().chosen, None);
    let r1 = slots.write_image(&img1).unwrap();
    assert_eq!((r1.slot, r1.generation), (Slot::A, 1));
    let r2 = slots.write_image(&img2).unwrap();
    assert_eq!((r2.slot, r2.generation), (Slot::B, 2));
    let st = slots.boot();
    assert_eq!((st.chosen, st.generation()), (Some(Slot::B), Some(2)));
    let mut buf = vec![0u8; slots.slot_len()];
    let n = slots.read_image(Slot::B, &mut buf).unwrap();
    // the payload as written; the header carries the stamped generation
    assert_eq!(&buf[HEADER_LEN..n], &img2[HEADER_LEN..]);
    // odd lengths and offsets read through the 4-byte READ_SIZE
    let dev = slots.device();
    let mut odd = [0u8; 7];
    dev.read(32 * 1024 + HEADER_LEN + 3, &mut odd).unwrap();
    assert_eq!(&odd, &img2[HEADER_LEN + 3..HEADER_LEN + 10]);
    // a misaligned erase never reaches the driver
    assert!(matches!(dev.erase(100, 4096), Err(NorError::Geometry(_))));
}

#[test]
fn power_cut_at_every_point_of_a_nor_write_keeps_the_last_good_image() {
    let img1 = small_image(1.0);
    let img2 = small_image(2.0);
    let mut base = Slots::new(Nor::new(SimNor::new(64 * 1024)).unwrap());
    base.write_image(&img1).unwrap();
    let base = base.into_inner().into_inner();
    // the second write erases 32 KiB, then programs payload and header: cut every 997 bytes
    let total = 32 * 1024 + img2.len();
    let mut cuts = 0;
    for cut in (0..total + 997).step_by(997) {
        let mut nor = base.clone();
        nor.cut_after_bytes = Some(cut);
        let mut slots = Slots::new(Nor::new(nor).unwrap());
        let r = slots.write_image(&img2);
        let mut nor = slots.into_inner().into_inner();
        nor.cut_after_bytes = None;
        let mut after = Slots::new(Nor::new(nor).unwrap());
        let st = after.boot();
        match r {
            Err(WriteError::Device(NorError::Flash(SimNorError::PowerCut))) => {
                cuts += 1;
                assert_eq!(st.generation(), Some(1), "cut at {cut}: {st}");
            }
            Ok(_) => assert_eq!(st.generation(), Some(2), "cut at {cut}: {st}"),
            Err(e) => panic!("cut at {cut}: {e}"),
        }
    }
    assert!(cuts > 30, "{cuts}");
}

#[test]
fn the_nor_adapter_refuses_geometry_it_cannot_use() {
    // less than two erase blocks
    assert!(matches!(
        Nor::new(SimNor::new(4096)),
        Err(NorError::Geometry(_))
    ));
}

fn sim_mtd(dir: &std::path::Path, size: u64, erase: u32) -> SimMtd {
    SimMtd::create(&dir.join("mtd0.bin"), size, erase).unwrap()
}

#[test]
fn slots_on_an_mtd_partition() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mtd0.bin");
    let img1 = small_image(1.0);
    let img2 = small_image(2.0);
    // 1 MiB NOR partition in 64 KiB erase blocks
    let mut slots = Slots::new(MtdFlash::new(sim_mtd(dir.path(), 1 << 20, 65536), &path).unwrap());
    assert_eq!(slots.slot_len(), 512 * 1024);
    slots.write_image(&img1).unwrap();
    slots.write_image(&img2).unwrap();
    let mtd = slots.into_inner().into_inner();
    // every slot write erased whole blocks, one erase per slot write
    assert_eq!(mtd.erases, 2);
    // reopened ("reboot"): generation 2 in slot B
    let mut slots = Slots::new(MtdFlash::new(sim_mtd(dir.path(), 1 << 20, 65536), &path).unwrap());
    let st = slots.boot();
    assert_eq!((st.chosen, st.generation()), (Some(Slot::B), Some(2)));
    // an erase not on 64 KiB blocks is refused before the device sees it
    let e = slots.device().erase(4096, 65536).unwrap_err();
    assert!(
        matches!(
            e,
            DeviceError::Misaligned {
                erase_size: 65536,
                ..
            }
        ),
        "{e}"
    );
    // NOR programming only clears bits: writing over a valid slot without an erase corrupts
    // it, and the slot check catches it (nothing trusts a write it has not read back)
    slots.device().write(HEADER_LEN + 100, &[0x00; 64]).unwrap();
    assert!(matches!(slots.inspect(Slot::A), SlotState::Invalid(_)));
    assert_eq!(slots.boot().chosen, Some(Slot::B));
}

#[test]
fn power_cut_during_an_mtd_write_keeps_the_last_good_image() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mtd0.bin");
    let img1 = small_image(1.0);
    let img2 = small_image(2.0);
    {
        let mut slots =
            Slots::new(MtdFlash::new(sim_mtd(dir.path(), 256 * 1024, 65536), &path).unwrap());
        slots.write_image(&img1).unwrap();
    }
    let pristine = std::fs::read(&path).unwrap();
    let total = 128 * 1024 + img2.len();
    // the cut stops an erase after whole blocks (the injector cannot model a half-erased
    // block, which MTD reads as garbage anyway: the slot's CRC fails either way) and a write
    // after any byte
    for cut in [
        0,
        65536,
        128 * 1024,
        128 * 1024 + 1,
        128 * 1024 + 100,
        total - 10,
        total - 1,
    ] {
        std::fs::write(&path, &pristine).unwrap();
        let dev = MtdFlash::new(sim_mtd(dir.path(), 256 * 1024, 65536), &path).unwrap();
        let faulty = FaultyFlash::new(
            dev,
            Faults {
                cut_after_bytes: Some(cut),
                ..Faults::default()
            },
        );
        let mut slots = Slots::new(faulty);
        let r = slots.write_image(&img2);
        assert!(
            matches!(r, Err(WriteError::Device(DeviceError::PowerCut))),
            "cut at {cut}: {r:?}"
        );
        let mut after =
            Slots::new(MtdFlash::new(sim_mtd(dir.path(), 256 * 1024, 65536), &path).unwrap());
        let st = after.boot();
        assert_eq!(generation(st.a), Some(1), "cut at {cut}: {st}");
        assert_eq!(st.generation(), Some(1), "cut at {cut}: {st}");
    }
}

#[test]
fn mtd_partitions_the_slots_cannot_use_are_refused_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mtd0.bin");
    let info = |kind, flags, size, erase_size, write_size| MtdInfo {
        kind,
        flags,
        size,
        erase_size,
        write_size,
    };
    for (i, says) in [
        (
            info(MTD_NANDFLASH, MTD_WRITEABLE, 1 << 20, 131072, 2048),
            "UBI",
        ),
        (info(MTD_NORFLASH, 0, 1 << 20, 65536, 1), "read-only"),
        (info(MTD_NORFLASH, MTD_WRITEABLE, 65536, 65536, 1), "size"),
        (info(9, MTD_WRITEABLE, 1 << 20, 65536, 1), "not NOR"),
    ] {
        let dev = sim_mtd(dir.path(), 1 << 20, 65536).with_info(i);
        let e = MtdFlash::new(dev, &path).unwrap_err();
        assert!(e.to_string().contains(says), "{says}: {e}");
    }
}

#[cfg(target_os = "linux")]
#[test]
fn a_file_that_is_not_an_mtd_device_is_refused() {
    // MEMGETINFO on a regular file fails: the error names the device and the reason
    let f = tempfile::NamedTempFile::new().unwrap();
    let e = luxnode::store::mtd::open(f.path()).unwrap_err();
    assert!(e.to_string().contains("not an MTD character device"), "{e}");
    let e = luxnode::store::mtd::open(std::path::Path::new("/dev/mtd9")).unwrap_err();
    assert!(e.to_string().contains("/dev/mtd9"), "{e}");
}
