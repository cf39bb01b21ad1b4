//! Fuzz target: `methods::stsv::stsv` and `stsv_volumes` on a decoded scene (see `rust/fuzz/src/lib.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;
use softshadows_core::geometry::bvh::Bvh;
use softshadows_core::methods::stsv::{stsv, stsv_volumes};
use softshadows_fuzz::{check_visibility, init, FuzzStsvOptions, FuzzScene};

fuzz_target!(|input: (FuzzScene, FuzzStsvOptions)| {
    init();
    let (fuzz, options) = input;
    let Ok(x) = fuzz.build() else { return };
    let opts = options.build(&x.scene);
    // stsv_volumes as `rust/py` calls it: the valid receivers' points and any hull degree.
    let points: Vec<_> = x.receivers.points.iter().zip(&x.receivers.valid).filter(|(_, &v)| v).map(|(p, _)| *p).collect();
    if let Ok(volumes) = stsv_volumes(&x.scene, &x.light, opts.object.hull_degree, opts.two_sided, &points) {
        for (face, corners) in volumes {
            assert!((face as usize) < x.scene.num_faces(), "stsv_volumes: face {face} out of range");
            assert!(corners.iter().all(|c| c.is_finite()), "stsv_volumes: corners {corners:?}");
        }
    }
    let Ok(samples) = fuzz.sample_set(&x.light) else { return };
    let Ok(bvh) = Bvh::build(&x.scene) else { return };
    if let Ok((vis, _)) = stsv(&x.scene, &bvh, &x.light, &x.receivers, &samples, &opts) {
        check_visibility("stsv", &vis, &x.receivers);
    }
});
