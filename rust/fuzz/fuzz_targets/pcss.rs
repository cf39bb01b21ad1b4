//! Fuzz target: `methods::pcss::pcss` on a decoded scene (see `rust/fuzz/src/lib.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;
use softshadows_core::methods::pcss::pcss;
use softshadows_fuzz::{check_visibility, init, FuzzPcssOptions, FuzzScene};

fuzz_target!(|input: (FuzzScene, FuzzPcssOptions)| {
    init();
    let (fuzz, options) = input;
    let Ok(x) = fuzz.build() else { return };
    if let Ok((vis, _)) = pcss(&x.scene, &x.light, &x.receivers, &options.build()) {
        check_visibility("pcss", &vis, &x.receivers);
    }
});
