//! Fuzz target: `methods::cssm::cssm` on a decoded scene (see `rust/fuzz/src/lib.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;
use softshadows_core::methods::cssm::cssm;
use softshadows_fuzz::{check_visibility, init, FuzzCssmOptions, FuzzScene};

fuzz_target!(|input: (FuzzScene, FuzzCssmOptions)| {
    init();
    let (fuzz, options) = input;
    let Ok(x) = fuzz.build() else { return };
    if let Ok((vis, _)) = cssm(&x.scene, &x.light, &x.receivers, &options.build()) {
        check_visibility("cssm", &vis, &x.receivers);
    }
});
