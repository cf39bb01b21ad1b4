//! Built without the crate feature `gpu` (`cargo test --no-default-features --test no_gpu`),
//! every method with a GPU half refuses `Backend::Gpu` with `Error::Unavailable`, whose message
//! says how to get it, and still runs on the CPU.
#![cfg(not(feature = "gpu"))]

mod common;

use common::{ground_and_cloud, ground_grid, rect_light_above};
use softshadows_core::backend::Backend;
use softshadows_core::geometry::bvh::SceneBvh;
use softshadows_core::light::sampling::{light_samples, Pattern, SampleSet};
use softshadows_core::methods::alias_free::{alias_free, AliasFreeOptions};
use softshadows_core::methods::cssm::{cssm, CssmOptions};
use softshadows_core::methods::mvr::{mvr, MultiViewOptions};
use softshadows_core::methods::pcss::{pcss, PcssOptions};
use softshadows_core::methods::shadow_map::{shadow_map, ShadowMapOptions};
use softshadows_core::methods::vwss::{vwss, VwssOptions};
use softshadows_core::{Error, Result, Stats};
use std::sync::OnceLock;

fn refuses_then_runs_on_the_cpu(name: &str, run: impl Fn(Backend) -> Result<(Vec<f32>, Stats)>) {
    match run(Backend::Gpu) {
        Err(Error::Unavailable(message)) => {
            assert!(message.contains("rebuild with it"), "{name}: {message}")
        }
        other => panic!("{name}: expected Error::Unavailable, got {other:?}"),
    }
    let (vis, _) = run(Backend::Cpu).unwrap_or_else(|e| panic!("{name} on the CPU: {e}"));
    assert!(
        vis.iter().any(|&v| v > 0.0),
        "{name}: nothing lit on the CPU"
    );
}

#[test]
fn every_gpu_method_refuses_the_gpu_cleanly_and_runs_on_the_cpu() {
    let (scene, light, rx) = (ground_and_cloud(), rect_light_above(), ground_grid(16));
    let samples =
        SampleSet::explicit(light_samples(&light, 8, Pattern::Poisson, 0, 0), None).unwrap();
    let multiview = |backend| MultiViewOptions {
        resolution: 64,
        backend,
        ..Default::default()
    };
    refuses_then_runs_on_the_cpu("shadow_map", |backend| {
        let opts = ShadowMapOptions {
            resolution: 64,
            backend,
            ..Default::default()
        };
        shadow_map(&scene, &light, &rx, &opts)
    });
    refuses_then_runs_on_the_cpu("pcss", |backend| {
        let opts = PcssOptions {
            resolution: 64,
            backend,
            ..Default::default()
        };
        pcss(&scene, &light, &rx, &opts)
    });
    refuses_then_runs_on_the_cpu("cssm", |backend| {
        let opts = CssmOptions {
            resolution: 64,
            backend,
            ..Default::default()
        };
        cssm(&scene, &light, &rx, &opts)
    });
    refuses_then_runs_on_the_cpu("alias_free", |backend| {
        let opts = AliasFreeOptions {
            resolution: 64,
            backend,
            ..Default::default()
        };
        let bvh = OnceLock::new();
        alias_free(&scene, SceneBvh::Cached(&bvh), &light, &rx, &samples, &opts)
    });
    refuses_then_runs_on_the_cpu("mvr", |backend| {
        mvr(&scene, &light, &rx, &samples, &multiview(backend))
    });
    refuses_then_runs_on_the_cpu("vwss", |backend| {
        let opts = VwssOptions {
            multiview: multiview(backend),
            ..Default::default()
        };
        vwss(&scene, &light, &rx, &samples, &opts)
    });
}
