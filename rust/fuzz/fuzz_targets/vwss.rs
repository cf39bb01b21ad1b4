//! Fuzz target: `methods::vwss::vwss` on a decoded scene (see `rust/fuzz/src/lib.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;
use softshadows_core::methods::vwss::vwss;
use softshadows_fuzz::{check_visibility, init, FuzzVwssOptions, FuzzScene};

fuzz_target!(|input: (FuzzScene, FuzzVwssOptions)| {
    init();
    let (fuzz, options) = input;
    let Ok(x) = fuzz.build() else { return };
    let Ok(samples) = fuzz.sample_set(&x.light) else { return };
    if let Ok((vis, _)) = vwss(&x.scene, &x.light, &x.receivers, &samples, &options.build()) {
        check_visibility("vwss", &vis, &x.receivers);
    }
});
