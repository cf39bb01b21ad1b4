//! Fuzz target: `Camera::look_at` and `geometry::gbuffer::gbuffer` (ray-cast G-buffers with
//! MSAA sample depths) on a decoded scene, then the G-buffer's receivers.
#![no_main]
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use softshadows_core::geometry::bvh::Bvh;
use softshadows_core::geometry::camera::Camera;
use softshadows_core::geometry::gbuffer::gbuffer;
use softshadows_fuzz::{init, v3, FuzzScene, Num, Place};

#[derive(Arbitrary, Debug)]
struct FuzzCamera {
    eye: Place,
    target: Place,
    up: [Num; 3],
    fov_y: Num,
    width: u8,
    height: u8,
    msaa: u8,
}

fuzz_target!(|input: (FuzzScene, FuzzCamera)| {
    init();
    let (fuzz, c) = input;
    let Ok(scene) = fuzz.scene() else { return };
    let (w, h) = (c.width as usize % 9, c.height as usize % 9);
    let fov = match c.fov_y {
        Num::Int(k) => k as f32 * 1.5, // degrees, often in (0, 180)
        other => other.get(),
    };
    let Ok(camera) = Camera::look_at(c.eye.resolve(&scene), c.target.resolve(&scene), v3(c.up), fov, w, h) else { return };
    let Ok(bvh) = Bvh::build(&scene) else { return };
    let msaa = c.msaa as usize % 18;
    let Ok(gb) = gbuffer(&scene, &bvh, &camera, msaa) else { return };
    let n = w * h;
    assert!(gb.positions.len() == n && gb.normals.len() == n && gb.mask.len() == n && gb.face_ids.len() == n);
    assert_eq!(gb.sample_depths.len(), if msaa > 1 { n * msaa } else { 0 });
    for i in 0..n {
        assert_eq!(gb.mask[i], gb.face_ids[i] >= 0);
        assert!(gb.face_ids[i] < scene.num_faces() as i64);
        if gb.mask[i] {
            // Unit, except for faces so small that their cross product is subnormal, whose
            // normalized normal loses precision (docs/robustness.md); `receivers()` renormalizes.
            let len = gb.normals[i].length();
            assert!(len.is_finite() && len > 0.5 && len < 1.5, "pixel {i}: normal {} of length {len}", gb.normals[i]);
        }
    }
    // Hit distances lie in (0, inf]; a hit a few ulps from an eye placed on a surface may
    // underflow to 0.
    assert!(gb.sample_depths.iter().all(|&d| d >= 0.0), "sample depths {:?}", gb.sample_depths);
    let _ = gb.receivers();
});
