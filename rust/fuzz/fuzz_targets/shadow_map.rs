//! Fuzz target: `methods::shadow_map::shadow_map` on a decoded scene (see `rust/fuzz/src/lib.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;
use softshadows_core::methods::shadow_map::shadow_map;
use softshadows_fuzz::{check_visibility, init, FuzzShadowMapOptions, FuzzScene};

fuzz_target!(|input: (FuzzScene, FuzzShadowMapOptions)| {
    init();
    let (fuzz, options) = input;
    let Ok(x) = fuzz.build() else { return };
    if let Ok((vis, _)) = shadow_map(&x.scene, &x.light, &x.receivers, &options.build()) {
        check_visibility("shadow_map", &vis, &x.receivers);
    }
});
