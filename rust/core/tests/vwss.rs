//! Integration tests of view-warped soft shadows: the atomic-minimum point pass against a serial
//! computation, buffered against unbuffered warping, and every traversal schedule giving the
//! same visibility.

mod common;

use common::{ground_and_cloud, ground_grid, rect_light_above};
use softshadows_core::light::sampling::{light_samples, Pattern, SampleSet};
use softshadows_core::methods::vwss::{
    generate_points, source_view, vwss, warp_fragments, warp_points, Mode, Parallel, Points,
    VwssOptions,
};
use softshadows_core::raster::multiview::ViewSet;

fn views(resolution: usize) -> ViewSet {
    let rx = ground_grid(8);
    let eyes = light_samples(&rect_light_above(), 6, Pattern::Poisson, 3, 0);
    ViewSet::fit(&rect_light_above(), &eyes, rx.bounds().unwrap(), resolution)
        .unwrap()
        .unwrap()
}

#[test]
fn every_warped_texel_is_the_minimum_of_the_points_that_land_in_it() {
    let scene = ground_and_cloud();
    let opts = VwssOptions::default();
    let views = views(96);
    let source = source_view(&scene, &rect_light_above(), &views, &opts).unwrap();
    let points = generate_points(&scene, &source, &opts).unwrap();
    let Points::Float32(world) = &points else {
        panic!("float32 points expected")
    };
    assert!(world.len() > 10_000, "{} points", world.len());
    let maps = warp_points(&points, &views.views).unwrap();
    let mut landed = 0usize;
    for (view, map) in views.views.iter().zip(&maps) {
        let mut serial = vec![f32::INFINITY; view.width * view.height];
        for p in world {
            if let Some((x, y, depth)) = view.texel_of(*p) {
                let t = &mut serial[y * view.width + x];
                *t = t.min(depth);
                landed += 1;
            }
        }
        assert_eq!(map.depth, serial);
    }
    assert!(landed > world.len(), "points must land in several maps");
}

#[test]
fn unbuffered_warping_writes_the_same_maps_as_the_buffer() {
    let scene = ground_and_cloud();
    let opts = VwssOptions::default();
    let views = views(64);
    let source = source_view(&scene, &rect_light_above(), &views, &opts).unwrap();
    let buffered = warp_points(
        &generate_points(&scene, &source, &opts).unwrap(),
        &views.views,
    )
    .unwrap();
    let (streamed, fragments) = warp_fragments(&scene, &source, &opts, &views.views).unwrap();
    assert_eq!(
        fragments,
        generate_points(&scene, &source, &opts).unwrap().len()
    );
    assert_eq!(buffered, streamed);
}

#[test]
fn the_source_view_contains_every_sample_view() {
    let scene = ground_and_cloud();
    let views = views(64);
    let source = source_view(&scene, &rect_light_above(), &views, &VwssOptions::default()).unwrap();
    for v in &views.views {
        let o = source.to_view(v.eye);
        assert!(
            o.x.abs() <= source.tan_half_x * o.z * 1.0001
                && o.y.abs() <= source.tan_half_y * o.z * 1.0001,
            "{o}"
        );
    }
    assert!(
        source.width > 64,
        "eq. 3 scales the source resolution up, got {}",
        source.width
    );
}

#[test]
fn every_schedule_gives_the_same_visibility() {
    let scene = ground_and_cloud();
    let rx = ground_grid(24);
    let samples =
        SampleSet::generate(&rect_light_above(), 10, Pattern::Poisson, 5, 1, false, 0).unwrap();
    let run = |mode, parallel, views_per_pass| {
        let mut opts = VwssOptions {
            mode,
            parallel,
            views_per_pass,
            ..VwssOptions::default()
        };
        opts.multiview.resolution = 128;
        vwss(&scene, &rect_light_above(), &rx, &samples, &opts).unwrap()
    };
    let (reference, stats) = run(Mode::Buffered, Parallel::Partial, 4);
    assert_eq!(stats.get("traversals"), Some(3.0));
    assert!(reference.iter().any(|&v| v < 0.5) && reference.iter().any(|&v| v > 0.99));
    for (mode, parallel, k) in [
        (Mode::Buffered, Parallel::Serial, 4),
        (Mode::Buffered, Parallel::Full, 4),
        (Mode::Unbuffered, Parallel::Partial, 3),
        (Mode::Unbuffered, Parallel::Full, 1),
    ] {
        let (vis, stats) = run(mode, parallel, k);
        assert_eq!(vis, reference, "{mode:?} {parallel:?} {k}");
        let expected = match parallel {
            Parallel::Serial => 10.0,
            Parallel::Partial => 4.0,
            Parallel::Full => 1.0,
        };
        assert_eq!(stats.get("traversals"), Some(expected));
    }
}

#[test]
fn rotated_samples_are_refused() {
    let samples =
        SampleSet::generate(&rect_light_above(), 4, Pattern::Poisson, 5, 1, true, 0).unwrap();
    let err = vwss(
        &ground_and_cloud(),
        &rect_light_above(),
        &ground_grid(4),
        &samples,
        &VwssOptions::default(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("views"), "{err}");
}
