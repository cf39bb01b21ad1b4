//! Fuzz target: `methods::alias_free::alias_free` on a decoded scene (see `rust/fuzz/src/lib.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;
use softshadows_core::geometry::bvh::SceneBvh;
use softshadows_core::methods::alias_free::alias_free;
use softshadows_fuzz::{check_visibility, init, FuzzAliasFreeOptions, FuzzScene};
use std::sync::OnceLock;

fuzz_target!(|input: (FuzzScene, FuzzAliasFreeOptions)| {
    init();
    let (fuzz, options) = input;
    let Ok(x) = fuzz.build() else { return };
    let Ok(samples) = fuzz.sample_set(&x.light) else { return };
    let bvh = OnceLock::new();
    let scene_bvh = SceneBvh::Cached(&bvh);
    if let Ok((vis, _)) =
        alias_free(&x.scene, scene_bvh, &x.light, &x.receivers, &samples, &options.build())
    {
        check_visibility("alias_free", &vis, &x.receivers);
    }
});
