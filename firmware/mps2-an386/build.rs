//! Embeds the image named by `LUXNODE_IMAGE` (built on the host with `luxnode image build`):
//! copies it to OUT_DIR and writes its length, so `main.rs` can place it in `.formfactors`.
//! memory.x (the repository's) reaches the linker through luxnode's own build script.

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-env-changed=LUXNODE_IMAGE");
    let Ok(src) = env::var("LUXNODE_IMAGE") else {
        panic!(
            "set LUXNODE_IMAGE to a flash image, e.g. \
             `luxnode image build --scene demo-office --patch-size 2 --rays 100 --out demo.img`"
        );
    };
    println!("cargo:rerun-if-changed={src}");
    let bytes = fs::read(&src).unwrap_or_else(|e| panic!("LUXNODE_IMAGE={src}: {e}"));
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));
    fs::write(out.join("image.bin"), &bytes).expect("write image.bin");
    fs::write(
        out.join("image_len.rs"),
        format!(
            "/// Length of the embedded image, bytes.\npub const IMAGE_LEN: usize = {};\n",
            bytes.len()
        ),
    )
    .expect("write image_len.rs");
}
