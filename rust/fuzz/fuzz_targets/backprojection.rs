//! Fuzz target: `methods::backprojection::backprojection_levels` on a decoded scene (see `rust/fuzz/src/lib.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;
use softshadows_core::methods::backprojection::backprojection_levels;
use softshadows_fuzz::{check_visibility, init, FuzzBackprojectionOptions, FuzzScene};

fuzz_target!(|input: (FuzzScene, FuzzBackprojectionOptions)| {
    init();
    let (fuzz, options) = input;
    let Ok(x) = fuzz.build() else { return };
    if let Ok(out) = backprojection_levels(&x.scene, &x.light, &x.receivers, &options.build(x.receivers.len())) {
        let (vis, levels) = (&out.visibility, &out.levels);
        check_visibility("backprojection", vis, &x.receivers);
        assert_eq!(levels.len(), vis.len(), "backprojection: one level per receiver");
        // NaN where a receiver backprojects nothing, else a non-negative level.
        assert!(levels.iter().all(|l| l.is_nan() || (l.is_finite() && *l >= 0.0)), "backprojection: levels {levels:?}");
    }
});
