//! Fuzz target: `methods::ray_traced::ray_traced` on a decoded scene (see `rust/fuzz/src/lib.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;
use softshadows_core::geometry::bvh::Bvh;
use softshadows_core::methods::ray_traced::ray_traced;
use softshadows_fuzz::{check_visibility, init, FuzzRayTracedOptions, FuzzScene};

fuzz_target!(|input: (FuzzScene, FuzzRayTracedOptions)| {
    init();
    let (fuzz, options) = input;
    let Ok(x) = fuzz.build() else { return };
    let Ok(samples) = fuzz.sample_set(&x.light) else { return };
    let Ok(bvh) = Bvh::build(&x.scene) else { return };
    if let Ok((vis, _)) = ray_traced(&x.scene, &bvh, &x.light, &x.receivers, &samples, &options.build(&x.scene)) {
        check_visibility("ray_traced", &vis, &x.receivers);
    }
});
