//! The GPU backend against the CPU on the same inputs (skipped, with a note, where no adapter
//! exists): `vwss` depth maps texel for texel and visibility, also with the dispatch limits
//! forced low so that points and maps are split across many dispatches and bindings.
#![cfg(feature = "gpu")]

mod common;

use common::{ground_and_cloud, ground_grid, rect_light_above};
use softshadows_core::backend::Backend;
use softshadows_core::gpu::{context, force_limits, DispatchLimits};
use softshadows_core::light::sampling::{light_samples, Pattern, SampleSet};
use softshadows_core::methods::cssm::{cssm, CssmOptions};
use softshadows_core::methods::mvr::{mvr, MultiViewOptions};
use softshadows_core::methods::pcss::{pcss, PcssOptions};
use softshadows_core::methods::shadow_map::{shadow_map, ShadowMapOptions};
use softshadows_core::methods::vwss::gpu::Warper;
use softshadows_core::methods::vwss::{
    generate_points, source_view, vwss, warp_points, Precision, VwssOptions,
};
use softshadows_core::raster::depth::{rasterize_depth, RasterOptions};
use softshadows_core::raster::multiview::ViewSet;
use std::sync::Mutex;

/// The forced limits are global: tests that set them run one at a time.
static LIMITS: Mutex<()> = Mutex::new(());

fn have_gpu() -> bool {
    match context() {
        Ok(_) => true,
        Err(e) => {
            eprintln!("skipped: {e}");
            false
        }
    }
}

fn maps_agree(limits: Option<DispatchLimits>, precision: Precision) {
    let _serial = LIMITS.lock().unwrap_or_else(|p| p.into_inner());
    let (scene, light) = (ground_and_cloud(), rect_light_above());
    let eyes = light_samples(&light, 6, Pattern::Poisson, 3, 0);
    let views = ViewSet::fit(&light, &eyes, ground_grid(8).bounds().unwrap(), 96)
        .unwrap()
        .unwrap();
    let opts = VwssOptions {
        precision,
        ..Default::default()
    };
    let source = source_view(&scene, &light, &views, &opts).unwrap();
    let points = generate_points(&scene, &source, &opts).unwrap();
    let cpu = warp_points(&points, &views.views).unwrap();
    force_limits(limits).unwrap();
    let gpu = Warper::new(points.iter()).and_then(|w| w.warp(&views.views));
    force_limits(None).unwrap();
    let gpu = gpu.unwrap();
    assert_eq!(cpu.len(), gpu.len());
    for (k, (c, g)) in cpu.iter().zip(&gpu).enumerate() {
        let differ = c
            .depth
            .iter()
            .zip(&g.depth)
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        assert_eq!(
            differ,
            0,
            "view {k}: {differ} of {} texels differ",
            c.depth.len()
        );
        assert!(
            c.drawn_texels() > 1000,
            "view {k} holds {} texels",
            c.drawn_texels()
        );
    }
}

#[test]
fn gpu_warped_maps_equal_the_cpu_maps_texel_for_texel() {
    if have_gpu() {
        maps_agree(None, Precision::Float32);
        maps_agree(None, Precision::Float16);
    }
}

#[test]
fn splitting_within_forced_low_limits_changes_nothing() {
    // 2 workgroups (128 points) per dispatch and bindings of two 96x96 maps: hundreds of
    // dispatches over three batches of views.
    if have_gpu() {
        maps_agree(
            Some(DispatchLimits {
                workgroups: 2,
                binding_bytes: 2 * 96 * 96 * 4,
            }),
            Precision::Float32,
        );
    }
}

#[test]
fn gpu_visibility_equals_the_cpu_visibility() {
    if !have_gpu() {
        return;
    }
    let _serial = LIMITS.lock().unwrap_or_else(|p| p.into_inner());
    let (scene, light, rx) = (ground_and_cloud(), rect_light_above(), ground_grid(96));
    let samples = SampleSet::generate(&light, 12, Pattern::Poisson, 5, 1, false, 0).unwrap();
    let mut opts = VwssOptions::default();
    opts.multiview.resolution = 128;
    let cpu = vwss(&scene, &light, &rx, &samples, &opts).unwrap().0;
    assert!(
        cpu.iter().any(|&v| v > 0.0 && v < 1.0),
        "the test scene must have penumbrae"
    );
    // The adapter's limits; then bindings of two 128x128 maps (batches of two views, receivers
    // in three chunks) and 5 workgroups per dispatch.
    for limits in [
        None,
        Some(DispatchLimits {
            workgroups: 5,
            binding_bytes: 2 * 128 * 128 * 4,
        }),
    ] {
        force_limits(limits).unwrap();
        let mut on_gpu = opts;
        on_gpu.multiview.backend = Backend::Gpu;
        let gpu = vwss(&scene, &light, &rx, &samples, &on_gpu);
        force_limits(None).unwrap();
        let gpu = gpu.unwrap().0;
        let worst = cpu
            .iter()
            .zip(&gpu)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(worst <= 1e-6, "{limits:?}: largest difference {worst}");
    }
}

/// cssm on the GPU against the CPU, with the adapter's limits or `limits` forced.
fn cssm_agrees(limits: Option<DispatchLimits>, order: usize, n: usize) {
    let _serial = LIMITS.lock().unwrap_or_else(|p| p.into_inner());
    let (scene, light, rx) = (ground_and_cloud(), rect_light_above(), ground_grid(n));
    let opts = CssmOptions {
        resolution: 64,
        order,
        ..Default::default()
    };
    let cpu = cssm(&scene, &light, &rx, &opts).unwrap().0;
    force_limits(limits).unwrap();
    let gpu = cssm(
        &scene,
        &light,
        &rx,
        &CssmOptions {
            backend: Backend::Gpu,
            ..opts
        },
    );
    force_limits(None).unwrap();
    let gpu = gpu.unwrap().0;
    let worst = cpu
        .iter()
        .zip(&gpu)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst <= 1e-3, "largest difference {worst}");
    assert!(
        cpu.iter().any(|&v| v > 0.05 && v < 0.95),
        "the test scene must have penumbrae"
    );
}

#[test]
fn gpu_cssm_is_within_1e3_of_the_cpu() {
    if have_gpu() {
        cssm_agrees(None, 4, 48);
        cssm_agrees(None, 16, 48);
    }
}

#[test]
fn gpu_cssm_splits_tables_receivers_and_dispatches_within_forced_low_limits() {
    // One table channel of a 64x64 map is 65 * 65 * 8 bytes. Bindings of 9 channels: groups of
    // two coefficients, the z image joining the last; of 8: the z image alone. 96^2 receivers
    // (48 bytes each) take two chunks; 3 workgroups per dispatch.
    if have_gpu() {
        let channel = 65 * 65 * 8;
        for channels in [9, 8] {
            cssm_agrees(
                Some(DispatchLimits {
                    workgroups: 3,
                    binding_bytes: channels * channel,
                }),
                4,
                96,
            );
        }
    }
}

#[test]
fn gpu_shadow_map_lookups_equal_the_cpu_lookups() {
    // Rect light (center), PCF 1 and 5, receiver-plane and constant bias; then bindings of one
    // 256x256 map, so the 96^2 receivers (32 bytes each) split into two chunks, and 2 workgroups
    // per dispatch.
    if !have_gpu() {
        return;
    }
    let _serial = LIMITS.lock().unwrap_or_else(|p| p.into_inner());
    let (scene, light, rx) = (ground_and_cloud(), rect_light_above(), ground_grid(96));
    for (pcf, bias) in [(1, None), (5, None), (3, Some(0.01))] {
        let opts = ShadowMapOptions {
            resolution: 256,
            pcf,
            bias,
            ..Default::default()
        };
        let cpu = shadow_map(&scene, &light, &rx, &opts).unwrap().0;
        assert!(
            cpu.contains(&0.0) && cpu.contains(&1.0),
            "the test scene must have shadows"
        );
        for limits in [
            None,
            Some(DispatchLimits {
                workgroups: 2,
                binding_bytes: 256 * 256 * 4,
            }),
        ] {
            force_limits(limits).unwrap();
            let gpu = shadow_map(
                &scene,
                &light,
                &rx,
                &ShadowMapOptions {
                    backend: Backend::Gpu,
                    ..opts
                },
            );
            force_limits(None).unwrap();
            assert_eq!(cpu, gpu.unwrap().0, "pcf {pcf}, bias {bias:?}, {limits:?}");
        }
    }
}

#[test]
fn gpu_pcss_equals_the_cpu_pcss() {
    // Default and constant bias; then bindings of one 256x256 map (the 96^2 receivers in two
    // chunks) and 3 workgroups per dispatch.
    if !have_gpu() {
        return;
    }
    let _serial = LIMITS.lock().unwrap_or_else(|p| p.into_inner());
    let (scene, light, rx) = (ground_and_cloud(), rect_light_above(), ground_grid(96));
    for bias in [None, Some(0.02)] {
        let opts = PcssOptions {
            resolution: 256,
            bias,
            ..Default::default()
        };
        let (cpu, cpu_stats) = pcss(&scene, &light, &rx, &opts).unwrap();
        assert!(
            cpu.iter().any(|&v| v > 0.0 && v < 1.0),
            "the test scene must have penumbrae"
        );
        for limits in [
            None,
            Some(DispatchLimits {
                workgroups: 3,
                binding_bytes: 256 * 256 * 4,
            }),
        ] {
            force_limits(limits).unwrap();
            let gpu = pcss(
                &scene,
                &light,
                &rx,
                &PcssOptions {
                    backend: Backend::Gpu,
                    ..opts
                },
            );
            force_limits(None).unwrap();
            let (gpu, gpu_stats) = gpu.unwrap();
            assert_eq!(cpu, gpu, "bias {bias:?}, {limits:?}");
            assert_eq!(cpu_stats.get("no_blocker"), gpu_stats.get("no_blocker"));
        }
    }
}

/// mvr's GPU maps against the CPU rasterizer's, with the adapter's limits or `limits` forced.
fn mvr_maps_agree(limits: Option<DispatchLimits>, resolution: usize) {
    let _serial = LIMITS.lock().unwrap_or_else(|p| p.into_inner());
    let (scene, light) = (ground_and_cloud(), rect_light_above());
    let eyes = light_samples(&light, 6, Pattern::Poisson, 3, 0);
    let views = ViewSet::fit(&light, &eyes, ground_grid(8).bounds().unwrap(), resolution)
        .unwrap()
        .unwrap();
    force_limits(limits).unwrap();
    let gpu = softshadows_core::methods::mvr::gpu::GpuRasterizer::new(&scene)
        .and_then(|r| r.maps(&views.views));
    force_limits(None).unwrap();
    let gpu = gpu.unwrap();
    for (k, (view, g)) in views.views.iter().zip(&gpu).enumerate() {
        let c = rasterize_depth(&scene, view, &RasterOptions::default()).unwrap();
        let differ = c
            .depth
            .iter()
            .zip(&g.depth)
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        assert_eq!(
            differ,
            0,
            "view {k}: {differ} of {} texels differ",
            c.depth.len()
        );
        assert_eq!(c.fragments, g.fragments, "view {k}");
        assert!(
            c.drawn_texels() > 1000,
            "view {k} holds {} texels",
            c.drawn_texels()
        );
    }
}

#[test]
fn gpu_rasterized_maps_equal_the_cpu_maps_texel_for_texel() {
    if have_gpu() {
        mvr_maps_agree(None, 256);
        // At 1024^2 the ground's triangles span more texels than one thread draws: one workgroup
        // each.
        mvr_maps_agree(None, 1024);
        // 3 workgroups (192 triangles) per dispatch, bindings of two 128x128 maps.
        mvr_maps_agree(
            Some(DispatchLimits {
                workgroups: 3,
                binding_bytes: 2 * 128 * 128 * 4,
            }),
            128,
        );
        // 2 workgroups per dispatch dimension: the large triangles' indirect dispatch in rows.
        mvr_maps_agree(
            Some(DispatchLimits {
                workgroups: 2,
                binding_bytes: 2 * 1024 * 1024 * 4,
            }),
            1024,
        );
        // At 3072^2 the ground's triangles span about 4.7M texels each, 74k per thread of one
        // workgroup: each is drawn in several workgroups' slots, within llvmpipe's loop limit per
        // invocation (see `mvr.wgsl`; before the slots such triangles were refused).
        mvr_maps_agree(None, 3072);
    }
}

#[test]
fn gpu_mvr_visibility_equals_the_cpu_visibility() {
    if !have_gpu() {
        return;
    }
    let (scene, light, rx) = (ground_and_cloud(), rect_light_above(), ground_grid(64));
    let samples = SampleSet::generate(&light, 12, Pattern::Poisson, 5, 1, false, 0).unwrap();
    let opts = MultiViewOptions {
        resolution: 256,
        ..Default::default()
    };
    let (cpu, cpu_stats) = mvr(&scene, &light, &rx, &samples, &opts).unwrap();
    let (gpu, gpu_stats) = mvr(
        &scene,
        &light,
        &rx,
        &samples,
        &MultiViewOptions {
            backend: Backend::Gpu,
            ..opts
        },
    )
    .unwrap();
    let worst = cpu
        .iter()
        .zip(&gpu)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst <= 1e-6, "largest difference {worst}");
    assert_eq!(cpu_stats.get("fragments"), gpu_stats.get("fragments"));
    assert!(
        cpu.iter().any(|&v| v > 0.0 && v < 1.0),
        "the test scene must have penumbrae"
    );
}

#[test]
fn stage_times_are_the_gpus_own_passes_and_never_exceed_the_wall_clock() {
    if !have_gpu() {
        return;
    }
    // Not while another test forces the limits low.
    let _serial = LIMITS.lock().unwrap_or_else(|p| p.into_inner());
    let gpu = context().unwrap();
    let (scene, light, rx) = (ground_and_cloud(), rect_light_above(), ground_grid(64));
    let opts = CssmOptions {
        resolution: 128,
        order: 8,
        backend: Backend::Gpu,
        ..Default::default()
    };
    cssm(&scene, &light, &rx, &opts).unwrap();
    let start = std::time::Instant::now();
    let (_, stats) = cssm(&scene, &light, &rx, &opts).unwrap();
    let wall = start.elapsed().as_secs_f64();
    let stages: Vec<f64> = ["basis_seconds", "prefilter_seconds", "lookup_seconds"]
        .iter()
        .map(|k| stats.get(k).unwrap())
        .collect();
    eprintln!(
        "timestamp queries: {}; stages {stages:?}, wall {wall}",
        gpu.has_timestamps()
    );
    assert!(stages.iter().all(|&s| s > 0.0), "{stages:?}");
    assert!(stages.iter().sum::<f64>() <= wall, "{stages:?} > {wall}");
    // A scope that records no pass measures nothing on the GPU's clock, the wall clock elsewhere.
    let mut idle = 0.0;
    gpu.timed(&mut idle, || {
        std::thread::sleep(std::time::Duration::from_millis(20));
        Ok(())
    })
    .unwrap();
    if gpu.has_timestamps() {
        assert_eq!(idle, 0.0);
    } else {
        assert!(idle >= 0.02);
    }
}
