//! Fuzz target: light construction (every kind, emission textures) and light-sample generation:
//! `unit_pattern`, `unit_disk_pattern`, `light_samples`, `SampleSet::generate` / `explicit` and
//! the per-receiver `fill` (rotation, interleaving, emission weights).
#![no_main]
use libfuzzer_sys::fuzz_target;
use softshadows_core::light::lights::Shape;
use softshadows_core::light::sampling::{light_samples, poisson_radius, unit_disk_pattern, unit_pattern};
use softshadows_fuzz::{init, FuzzScene, MAX_SAMPLES, PATTERNS};

fuzz_target!(|input: (FuzzScene, u8, u8, u64, u8, bool)| {
    init();
    let (fuzz, n, pattern, seed, frame, three) = input;
    let (n, pattern, dim) = (n as usize % (MAX_SAMPLES + 1), PATTERNS[pattern as usize % 5], if three { 3 } else { 2 });
    let unit = unit_pattern(pattern, n, dim, seed);
    assert_eq!(unit.len(), n);
    assert!(unit.iter().all(|p| p.iter().take(dim).all(|&c| (0.0..1.0).contains(&c))), "{pattern:?}: {unit:?}");
    assert!(unit_disk_pattern(pattern, n, seed).iter().all(|q| q.length() <= 1.0 + 1e-5));
    assert!(poisson_radius(n, dim) > 0.0);
    let Ok(scene) = fuzz.scene() else { return };
    let Ok(light) = fuzz.light.build(&scene) else { return };
    let (c, extent) = (light.center(), light.extent() as f32);
    // A light far from f32's limits keeps its samples on it (to round-off), rotated and jittered
    // ones too (rectangle parameters and ellipsoid inverses are solved in f64). Known exception
    // (docs/robustness.md): a rectangle with one side over 1e6 times shorter than the other
    // (down to f32's denormals) can still get NaN samples.
    let sides_alike = match light.shape {
        Shape::Rect { u, v, .. } => u.length().min(v.length()) > 1e-6 * u.length().max(v.length()),
        _ => true,
    };
    let tame = sides_alike && c.abs().max_element() < 1e15 && (1e-8..1e8).contains(&extent);
    let near = |y: glam::Vec3| y.is_finite() && (y - c).length() <= extent * 1.001 + 1e-6 * (1.0 + c.abs().max_element());
    let pts = light_samples(&light, n, pattern, seed, frame as u64);
    assert_eq!(pts.len(), n);
    if tame {
        assert!(pts.iter().all(|&y| near(y)), "light_samples off the light {light:?}: {pts:?}");
    }
    let Ok(receivers) = fuzz.receivers.build(&scene, &light) else { return };
    let Ok(samples) = fuzz.sample_set(&light) else { return };
    let _ = samples.bounding_radius(&light);
    let (mut ys, mut ws) = (Vec::new(), Vec::new());
    for i in 0..receivers.len() {
        samples.fill(&light, i, receivers.pixel(i), &mut ys, &mut ws);
        assert_eq!(ys.len(), samples.count());
        assert_eq!(ws.len(), samples.count());
        assert!(ws.iter().all(|w| w.is_finite() && *w >= 0.0), "weights {ws:?}");
        if tame && matches!(fuzz.samples, softshadows_fuzz::FuzzSamples::Generate { .. }) {
            assert!(ys.iter().all(|&y| near(y)), "receiver {i}: samples off the light {light:?}: {ys:?}");
        }
    }
});
