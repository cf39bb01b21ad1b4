//! Fuzz target: `methods::envmap::fit_area_lights` on small cube maps (0..=6 texels a side,
//! hot spots, negative / NaN / huge radiance, wrong lengths) with any options.
#![no_main]
use libfuzzer_sys::fuzz_target;
use softshadows_core::light::envmap::fit_area_lights;
use softshadows_fuzz::{init, FuzzEnvmap};

fuzz_target!(|input: FuzzEnvmap| {
    init();
    let (faces, n, opts) = input.build();
    let Ok(lights) = fit_area_lights(&faces, n, &opts) else { return };
    assert!(lights.len() <= opts.max_lights.unwrap_or(usize::MAX), "{} lights for max_lights {:?}", lights.len(), opts.max_lights);
    let total: f64 = faces.iter().map(|&v| f64::from(v)).sum();
    for l in &lights {
        assert!(l.face < 6 && l.i0 < l.i1 && l.i1 <= n && l.j0 < l.j1 && l.j1 <= n, "bad light {l:?} for n = {n}");
        assert!(l.energy.iter().all(|e| e.is_finite() && *e >= -1e-9 * total.max(1.0)), "bad energy {l:?}");
    }
});
