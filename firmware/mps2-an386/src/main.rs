//! luxnode's run-time core on a Cortex-M4F: the commissioned image sits in the FORMFACTORS flash
//! region of the repository's memory.x and is read in place (no copy, no heap). For each demo
//! DALI state it prints the desk lux by superposition and by a full re-solve, in the format of
//! `luxnode image eval --demo-states`, over semihosting, then exits with the result.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use luxnode::dali::{ArcLevel, DimmingCurve};
use luxnode::runtime::{DEMO_STATES, Runtime, demo_arc_level};
use luxnode::store::Image;
use panic_semihosting as _;

include!(concat!(env!("OUT_DIR"), "/image_len.rs"));

/// The image, in FORMFACTORS flash.
#[unsafe(link_section = ".formfactors")]
#[used]
static IMAGE: [u8; IMAGE_LEN] = *include_bytes!(concat!(env!("OUT_DIR"), "/image.bin"));

const MAX_PATCHES: usize = 8192;
const MAX_SENSORS: usize = 64;
const MAX_LUMINAIRES: usize = 64;

/// Exits QEMU through semihosting; on real hardware, where that returns, waits for interrupts.
fn exit(code: debug::ExitStatus) -> ! {
    debug::exit(code);
    loop {
        cortex_m::asm::wfi();
    }
}

fn fail(what: &str) -> ! {
    hprintln!("# error: {}", what);
    exit(debug::EXIT_FAILURE)
}

#[entry]
fn main() -> ! {
    let image = match Image::parse(&IMAGE) {
        Ok(i) => i,
        Err(_) => fail("the image in FORMFACTORS does not parse"),
    };
    let (n, l, s) = (image.patches(), image.luminaires(), image.sensors());
    hprintln!(
        "# luxnode on mps2-an386: image at {:p}, {} bytes, generation {}, {} patches, {} luminaires, {} sensors",
        IMAGE.as_ptr(),
        IMAGE_LEN,
        image.header.generation,
        n,
        l,
        s
    );
    if n > MAX_PATCHES || l > MAX_LUMINAIRES || s > MAX_SENSORS {
        fail("the image is larger than this firmware's buffers");
    }
    let rt = Runtime::new(&image);
    // scratch on the stack (RAM is 512 KiB; two f64 per patch)
    let mut e = [0.0f64; MAX_PATCHES];
    let mut b = [0.0f64; MAX_PATCHES];
    let mut levels = [0.0f64; MAX_LUMINAIRES];
    let mut arc = [ArcLevel::OFF; MAX_LUMINAIRES];
    let mut sup = [0.0f64; MAX_SENSORS];
    let mut full = [0.0f64; MAX_SENSORS];
    hprintln!("state,sensor_id,lux_superposition,lux_resolve");
    for k in 0..DEMO_STATES {
        for (j, a) in arc[..l].iter_mut().enumerate() {
            *a = demo_arc_level(k, j);
        }
        if rt
            .apply_arc_levels(&arc[..l], DimmingCurve::Logarithmic, &mut levels[..l])
            .is_err()
            || rt.sensor_lux(&levels[..l], &mut sup[..s]).is_err()
            || rt
                .resolve(&levels[..l], &mut e[..n], &mut b[..n], &mut full[..s])
                .is_err()
        {
            fail("run-time evaluation failed");
        }
        for i in 0..s {
            hprintln!(
                "{},{},{:.6},{:.6}",
                k + 1,
                image.sensor_id(i),
                sup[i],
                full[i]
            );
        }
    }
    exit(debug::EXIT_SUCCESS)
}
