//! Sets `cfg(armv7em)` on Armv7E-M targets (Cortex-M4/M7: `thumbv7em-*`),
//! whose DSP extension [`sad`](src/sad.rs) uses, as the `cortex-m` crate's
//! build script does: stable Rust exposes no Arm target features to `cfg`.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(armv7em)");
    println!("cargo::rerun-if-changed=build.rs");
    if std::env::var("TARGET").is_ok_and(|t| t.starts_with("thumbv7em-")) {
        println!("cargo::rustc-cfg=armv7em");
    }
}
