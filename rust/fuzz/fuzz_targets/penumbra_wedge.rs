//! Fuzz target: `methods::penumbra_wedge::penumbra_wedge` on a decoded scene (see `rust/fuzz/src/lib.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;
use softshadows_core::geometry::bvh::Bvh;
use softshadows_core::methods::penumbra_wedge::penumbra_wedge;
use softshadows_fuzz::{check_visibility, init, FuzzObjectOptions, FuzzScene};

fuzz_target!(|input: (FuzzScene, FuzzObjectOptions)| {
    init();
    let (fuzz, options) = input;
    let Ok(x) = fuzz.build() else { return };
    let Ok(samples) = fuzz.sample_set(&x.light) else { return };
    let Ok(bvh) = Bvh::build(&x.scene) else { return };
    if let Ok((vis, _)) = penumbra_wedge(&x.scene, &bvh, &x.light, &x.receivers, &samples, &options.build(&x.scene)) {
        check_visibility("penumbra_wedge", &vis, &x.receivers);
    }
});
