//! Fuzz target: `methods::mvr::mvr` on a decoded scene (see `rust/fuzz/src/lib.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;
use softshadows_core::methods::mvr::mvr;
use softshadows_fuzz::{check_visibility, init, FuzzMultiViewOptions, FuzzScene};

fuzz_target!(|input: (FuzzScene, FuzzMultiViewOptions)| {
    init();
    let (fuzz, options) = input;
    let Ok(x) = fuzz.build() else { return };
    let Ok(samples) = fuzz.sample_set(&x.light) else { return };
    if let Ok((vis, _)) = mvr(&x.scene, &x.light, &x.receivers, &samples, &options.build()) {
        check_visibility("mvr", &vis, &x.receivers);
    }
});
