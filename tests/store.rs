//! The flash image and the power-safe store: the image answers like the model, superposition
//! equals the run-time re-solve at every precision, corruption is always detected, and a power
//! cut at any point of a write, bit flips or stuck pages never boot anything but a good image.

mod common;

use std::path::Path;

use common::small_image;
use luxnode::engine::{self, Model, Settings};
use luxnode::image_build::{ImageOptions, build_image};
use luxnode::runtime::{Runtime, RuntimeError};
use luxnode::scene::{LoadOptions, Scene, read_states, read_truth};
use luxnode::store::devices::{Faults, FaultyFlash, FileFlash, MemFlash};
use luxnode::store::slots::{FlashDevice, Slot, SlotState, Slots, WriteError};
use luxnode::store::{HEADER_LEN, Image, ImageError, Precision};

fn office_a_dir() -> std::path::PathBuf {
    common::office_a()
}

fn office_a_model() -> Model {
    let s = Scene::load(&office_a_dir(), &LoadOptions::default()).unwrap();
    engine::compute_model(&s, &Settings::default()).unwrap()
}

fn lux(image: &Image<'_>, levels: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; image.sensors()];
    Runtime::new(image).sensor_lux(levels, &mut out).unwrap();
    out
}

#[test]
fn image_answers_like_the_model() {
    let model = office_a_model();
    let bytes = build_image(&model, &ImageOptions::default()).unwrap();
    let image = Image::parse(&bytes).unwrap();
    assert_eq!(image.patches(), model.patches.len());
    let states = read_states(&office_a_dir().join("states.csv")).unwrap();
    for s in &states {
        let levels: Vec<f64> = model
            .luminaire_ids
            .iter()
            .map(|id| if s.on.contains(id) { 1.0 } else { 0.0 })
            .collect();
        let a = model.sensor_lux(&levels).unwrap();
        let b = lux(&image, &levels);
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() <= 1e-5 * x.abs().max(1.0), "{x} vs {y}");
        }
    }
}

#[test]
fn superposition_equals_resolve_at_every_precision() {
    let model = office_a_model();
    let truth = read_truth(&office_a_dir().join("truth.csv")).unwrap();
    let states = read_states(&office_a_dir().join("states.csv")).unwrap();
    let mut last_size = usize::MAX;
    for precision in [
        Precision::F32,
        Precision::U16,
        Precision::F16,
        Precision::U8,
    ] {
        let bytes = build_image(
            &model,
            &ImageOptions {
                precision,
                ..ImageOptions::default()
            },
        )
        .unwrap();
        let image = Image::parse(&bytes).unwrap();
        let rt = Runtime::new(&image);
        let n = image.patches();
        let (mut e, mut b, mut full) = (vec![0.0; n], vec![0.0; n], vec![0.0; 8]);
        for levels in [
            vec![1.0; 8],
            vec![0.001, 0.032, 0.505, 1.0, 0.25, 0.0, 0.75, 0.1],
        ] {
            let sup = lux(&image, &levels);
            rt.resolve(&levels, &mut e, &mut b, &mut full).unwrap();
            for (x, y) in sup.iter().zip(&full) {
                assert!(
                    (x - y).abs() <= 1e-6 * y.abs(),
                    "{}: {x} vs {y}",
                    precision.name()
                );
            }
        }
        // and the stored model stays accurate
        let mut computed = Vec::new();
        for s in &states {
            let levels: Vec<f64> = (0..8)
                .map(|j| {
                    if s.on.contains(&image.luminaire_id(j)) {
                        1.0
                    } else {
                        0.0
                    }
                })
                .collect();
            for (k, v) in lux(&image, &levels).iter().enumerate() {
                computed.push(luxnode::evaluate::Computed {
                    scenario: s.id.clone(),
                    sensor: image.sensor_id(k),
                    lux: *v,
                });
            }
        }
        let acc = luxnode::evaluate::compare(&computed, &truth).unwrap();
        println!(
            "{}: {} bytes, error {:.3} %",
            precision.name(),
            bytes.len(),
            100.0 * acc.error
        );
        assert!(acc.error < 0.01, "{}", acc.error);
        assert!(bytes.len() <= last_size);
        last_size = bytes.len();
        assert!(
            bytes.len() as u64 <= luxnode::layout::FORMFACTORS_LEN_BYTES,
            "fits FORMFACTORS"
        );
    }
}

#[test]
fn every_corruption_is_detected() {
    let bytes = small_image(1.0);
    assert!(Image::parse(&bytes).is_ok());
    // every bit of the header, and every bit of the payload at a stride
    let bits = bytes.len() * 8;
    for bit in (0..HEADER_LEN * 8).chain((HEADER_LEN * 8..bits).step_by(7)) {
        let mut b = bytes.clone();
        b[bit / 8] ^= 1 << (bit % 8);
        assert!(Image::parse(&b).is_err(), "bit {bit} of {bits}");
    }
    for len in (0..bytes.len()).step_by(13) {
        assert!(Image::parse(&bytes[..len]).is_err(), "truncated to {len}");
    }
    // another format version: a clear error, never a misread
    let mut v2 = bytes.clone();
    v2[4] = 2;
    let crc = luxnode::store::crc32(&v2[..36]);
    v2[36..40].copy_from_slice(&crc.to_le_bytes());
    assert_eq!(
        Image::parse(&v2).unwrap_err(),
        ImageError::UnsupportedVersion {
            found: 2,
            supported: 1
        }
    );
    assert_eq!(Image::parse(&[0xFF; 100]).unwrap_err(), ImageError::Erased);
}

#[test]
fn slots_keep_the_newest_valid_image() {
    let a = small_image(1.0);
    let b = small_image(2.0);
    let mut slots = Slots::new(MemFlash::new(2 * (a.len().max(b.len()) + 1024)));
    assert_eq!(slots.boot().chosen, None);
    let w1 = slots.write_image(&a).unwrap();
    assert_eq!((w1.slot, w1.generation), (Slot::A, 1));
    let w2 = slots.write_image(&b).unwrap();
    assert_eq!((w2.slot, w2.generation), (Slot::B, 2));
    let w3 = slots.write_image(&a).unwrap();
    assert_eq!((w3.slot, w3.generation), (Slot::A, 3));
    let status = slots.boot();
    assert_eq!(status.chosen, Some(Slot::A));
    assert_eq!(status.generation(), Some(3));
    assert!(
        status.to_string().contains("running from slot A"),
        "{status}"
    );
    // a corrupt newer slot falls back to the older valid one
    let off = slots.offset(Slot::A) + HEADER_LEN + 10;
    slots.device().flip_bit(off, 3);
    let status = slots.boot();
    assert_eq!(status.chosen, Some(Slot::B));
    assert!(
        matches!(status.a, SlotState::Invalid(ImageError::PayloadCrc { .. })),
        "{status}"
    );
    // too large and not-an-image writes are refused before anything is touched
    let mut small = Slots::new(MemFlash::new(a.len()));
    assert!(matches!(
        small.write_image(&a),
        Err(WriteError::TooLarge { .. })
    ));
    assert!(matches!(
        small.write_image(&[0u8; 64]),
        Err(WriteError::NotAnImage(_))
    ));
}

/// Writes `new` over a device holding `old` with the power cut after `cut` bytes; boots what is
/// left and checks that it is `old` or (if the write completed) `new`, never anything else.
fn cut_and_boot(
    base: &MemFlash,
    new: &[u8],
    cut: usize,
    old_lux: &[f64],
    new_lux: &[f64],
    levels: &[f64],
) -> bool {
    let faulty = FaultyFlash::new(
        base.clone(),
        Faults {
            cut_after_bytes: Some(cut),
            ..Faults::default()
        },
    );
    let mut slots = Slots::new(faulty);
    let completed = slots.write_image(new).is_ok();
    let mut slots = Slots::new(slots.into_inner().into_inner());
    let status = slots.boot();
    let slot = status.chosen.expect("the old image always boots");
    let mut buf = vec![0u8; slots.slot_len()];
    let len = slots.read_image(slot, &mut buf).unwrap();
    let image = Image::parse(&buf[..len]).expect("a booted image always parses");
    let got = lux(&image, levels);
    let expected = if status.generation() == Some(2) {
        new_lux
    } else {
        old_lux
    };
    assert!(
        !completed || status.generation() == Some(2),
        "a completed write boots"
    );
    assert_eq!(got, expected, "cut at {cut}");
    completed
}

#[test]
fn power_cut_at_every_byte_of_a_write() {
    let old = small_image(1.0);
    let new = small_image(3.0);
    let old_img = Image::parse(&old).unwrap();
    let new_img = Image::parse(&new).unwrap();
    let levels = [1.0, 0.5];
    let (old_lux, new_lux) = (lux(&old_img, &levels), lux(&new_img, &levels));
    assert_ne!(old_lux, new_lux);
    let mut slots = Slots::new(MemFlash::new(2 * (new.len() + 64)));
    slots.write_image(&old).unwrap();
    let base = slots.into_inner();
    // the write touches the erased slot, then the payload, then the header
    let total = base.capacity() / 2 + new.len();
    let mut cuts = 0;
    let mut completed_at = None;
    for cut in 0..=total {
        cuts += 1;
        if cut_and_boot(&base, &new, cut, &old_lux, &new_lux, &levels) && completed_at.is_none() {
            completed_at = Some(cut);
        }
    }
    println!(
        "power cuts tried: {cuts} (every byte of a {} byte write)",
        total
    );
    assert_eq!(completed_at, Some(total));
}

#[test]
fn power_cut_at_every_sector_of_an_office_image_write() {
    let model = office_a_model();
    let old = build_image(
        &model,
        &ImageOptions {
            precision: Precision::F16,
            ..ImageOptions::default()
        },
    )
    .unwrap();
    let new = build_image(
        &model,
        &ImageOptions {
            precision: Precision::U8,
            ..ImageOptions::default()
        },
    )
    .unwrap();
    let levels = [1.0, 0.5, 0.0, 1.0, 0.25, 1.0, 0.0, 0.7];
    let old_lux = lux(&Image::parse(&old).unwrap(), &levels);
    let new_lux = lux(&Image::parse(&new).unwrap(), &levels);
    let mut slots = Slots::new(MemFlash::new(2 * (old.len().max(new.len()) + 4096)));
    slots.write_image(&old).unwrap();
    let base = slots.into_inner();
    let total = base.capacity() / 2 + new.len();
    let sector = 4096;
    let mut cuts = 0;
    // every 4 KiB erase sector, plus every byte of the header write at the end
    let points: Vec<usize> = (0..=total)
        .step_by(sector)
        .chain(total - HEADER_LEN..=total)
        .collect();
    for cut in points {
        cuts += 1;
        cut_and_boot(&base, &new, cut, &old_lux, &new_lux, &levels);
    }
    println!(
        "power cuts tried: {cuts} (every 4 KiB of a {total} byte write, every byte of its header)"
    );
}

#[test]
fn bit_flips_never_boot_a_corrupt_image() {
    let a = small_image(1.0);
    let b = small_image(2.0);
    let mut slots = Slots::new(MemFlash::new(2 * (a.len() + 256)));
    slots.write_image(&a).unwrap();
    slots.write_image(&b).unwrap();
    let base = slots.into_inner();
    let lux_a = lux(&Image::parse(&a).unwrap(), &[1.0, 1.0]);
    let lux_b = lux(&Image::parse(&b).unwrap(), &[1.0, 1.0]);
    let mut rng = luxnode::rng::SplitMix64::new(42);
    let mut fallbacks = 0;
    for _ in 0..2000 {
        let mut dev = base.clone();
        for _ in 0..1 + rng.next_u64() % 4 {
            let off = (rng.next_u64() as usize) % dev.capacity();
            dev.flip_bit(off, (rng.next_u64() % 8) as u8);
        }
        let mut slots = Slots::new(dev);
        let status = slots.boot();
        let Some(slot) = status.chosen else { continue };
        let mut buf = vec![0u8; slots.slot_len()];
        let len = slots.read_image(slot, &mut buf).unwrap();
        let image = Image::parse(&buf[..len]).expect("a booted image parses");
        let got = lux(&image, &[1.0, 1.0]);
        assert!(got == lux_a || got == lux_b);
        if got == lux_a {
            fallbacks += 1;
        }
    }
    println!("{fallbacks} of 2000 corrupted devices fell back to the older image");
    assert!(fallbacks > 0);
}

#[test]
fn stuck_pages_fail_the_write_and_keep_the_old_image() {
    let a = small_image(1.0);
    let b = small_image(2.0);
    let mut slots = Slots::new(MemFlash::new(2 * (a.len() + 256)));
    slots.write_image(&a).unwrap();
    let base = slots.into_inner();
    let page = 256;
    let slot_b_page = (base.capacity() / 2 + HEADER_LEN + 100) / page;
    let faulty = FaultyFlash::new(
        base,
        Faults {
            stuck_pages: vec![slot_b_page],
            page_size: page,
            ..Faults::default()
        },
    );
    let mut slots = Slots::new(faulty);
    assert!(matches!(slots.write_image(&b), Err(WriteError::Verify(_))));
    let status = slots.boot();
    assert_eq!(
        (status.chosen, status.generation()),
        (Some(Slot::A), Some(1))
    );
}

#[test]
fn transient_read_flips_are_caught_at_boot() {
    let a = small_image(1.0);
    let b = small_image(2.0);
    let mut slots = Slots::new(MemFlash::new(2 * (a.len() + 256)));
    slots.write_image(&a).unwrap();
    slots.write_image(&b).unwrap();
    let base = slots.into_inner();
    let slot_b = base.capacity() / 2;
    for at in [slot_b + 3, slot_b + HEADER_LEN + 1, slot_b + b.len() - 1] {
        let faulty = FaultyFlash::new(
            base.clone(),
            Faults {
                read_bit_flips: vec![(at, 5)],
                ..Faults::default()
            },
        );
        let status = Slots::new(faulty).boot();
        assert_eq!(
            (status.chosen, status.generation()),
            (Some(Slot::A), Some(1)),
            "flip at {at}"
        );
    }
}

#[test]
fn file_flash_on_a_device_node_is_never_padded() {
    // /dev/zero is a character device of no size: opening it as flash is refused, not written
    let e = FileFlash::open(Path::new("/dev/zero"), 4096).unwrap_err();
    assert!(e.to_string().contains("beyond"), "{e}");
}

#[test]
fn file_flash_survives_reopening() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("formfactors.bin");
    let a = small_image(1.0);
    let cap = 2 * (a.len() + 4096);
    {
        let mut slots = Slots::new(FileFlash::open(&path, cap).unwrap());
        assert_eq!(slots.boot().chosen, None);
        slots.write_image(&a).unwrap();
    }
    let mut slots = Slots::new(FileFlash::open(&path, cap).unwrap());
    let status = slots.boot();
    assert_eq!(
        (status.chosen, status.generation()),
        (Some(Slot::A), Some(1))
    );
    let mut buf = vec![0u8; slots.slot_len()];
    let len = slots.read_image(Slot::A, &mut buf).unwrap();
    assert_eq!(len, a.len());
    // the payload is byte for byte the one written; the header carries the stamped generation
    assert_eq!(&buf[HEADER_LEN..len], &a[HEADER_LEN..]);
    let stored = Image::parse(&buf[..len]).unwrap();
    assert_eq!(stored.header.generation, 1);
    assert_eq!(
        lux(&stored, &[1.0, 0.5]),
        lux(&Image::parse(&a).unwrap(), &[1.0, 0.5])
    );
}

#[test]
fn runtime_rejects_bad_requests_without_writing() {
    let bytes = small_image(1.0);
    let image = Image::parse(&bytes).unwrap();
    let rt = Runtime::new(&image);
    let mut out = [7.0; 2];
    assert!(matches!(
        rt.sensor_lux(&[1.0], &mut out),
        Err(RuntimeError::Length { .. })
    ));
    assert!(matches!(
        rt.sensor_lux(&[1.0, 1.5], &mut out),
        Err(RuntimeError::Level { index: 1, .. })
    ));
    assert!(matches!(
        rt.sensor_lux(&[f64::NAN, 1.0], &mut out),
        Err(RuntimeError::Level { .. })
    ));
    assert!(matches!(
        rt.sensor_lux(&[1.0, 1.0], &mut [0.0; 3]),
        Err(RuntimeError::Length { .. })
    ));
    assert_eq!(out, [7.0; 2]);
    // DALI: MASK keeps the previous level, 0 is off, 254 is full
    use luxnode::dali::{ArcLevel, DimmingCurve};
    let mut levels = [0.3, 0.3];
    rt.apply_arc_levels(
        &[ArcLevel::MASK, ArcLevel(254)],
        DimmingCurve::Logarithmic,
        &mut levels,
    )
    .unwrap();
    assert_eq!(levels, [0.3, 1.0]);
    rt.apply_arc_levels(
        &[ArcLevel(0), ArcLevel::MASK],
        DimmingCurve::Logarithmic,
        &mut levels,
    )
    .unwrap();
    assert_eq!(levels, [0.0, 1.0]);
}

/// An image that does not fit its region is shrunk by storage alone (pruning, then 8-bit form
/// factors), keeping room for the sections after it, and still answers like the model; a region
/// no storage step fits is the error that names the knobs.
#[test]
fn an_image_is_shrunk_to_fit_its_region_by_storage_alone() {
    use luxnode::image_build::{BuildError, build_to_fit};
    let model = office_a_model();
    let o = ImageOptions::default();
    let full = build_image(&model, &o).unwrap().len();
    let reserve = 64 * 1024;
    // room for the image as given: step 0, as build_image makes it
    let f = build_to_fit(&model, &o, full + reserve, reserve).unwrap();
    assert_eq!((f.step, f.bytes.len()), (0, full));
    // a region 10 % short: a smaller step, within the region and its reserve
    let region = full * 9 / 10;
    let f = build_to_fit(&model, &o, region, reserve).unwrap();
    assert!(f.step > 0, "step {}", f.step);
    assert!(f.bytes.len() + reserve <= region, "{} bytes", f.bytes.len());
    assert_eq!(f.first_bytes, None, "the image as given did not fit");
    println!(
        "{full} bytes at u16 -> {} bytes at {} with prune {:e} (step {})",
        f.bytes.len(),
        f.options.precision.name(),
        f.options.prune_below,
        f.step
    );
    let image = Image::parse(&f.bytes).unwrap();
    let all_on = vec![1.0; model.luminaire_ids.len()];
    let want = model.sensor_lux(&all_on).unwrap();
    for (x, y) in want.iter().zip(lux(&image, &all_on)) {
        // docs/tradeoffs.md: u8 and pruning at 1e-4 move office_a's error by < 0.01 points
        assert!((x - y).abs() <= 2e-3 * x, "{x} vs {y}");
    }
    // a region no step fits: the error of the image as given
    match build_to_fit(&model, &o, full / 4, reserve) {
        Err(BuildError::TooLarge(m)) => assert!(m.contains("FORMFACTORS"), "{m}"),
        other => panic!("{:?}", other.map(|f| f.bytes.len())),
    }
}
