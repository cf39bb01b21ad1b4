//! Shadow-ray throughput of the ray-traced oracle on a ~70k-triangle procedural scene:
//! a finely tessellated sphere over a tessellated ground, 256 x 256 G-buffer receivers, 64
//! stratified samples of a rectangle light (rotated per receiver).
//!
//! `cargo run --release -p softshadows-core --example bench_rays [threads...]`
//! prints, per thread count, the BVH build time, the G-buffer time and the shadow rays per second.

use glam::Vec3;
use softshadows_core::geometry::bvh::Bvh;
use softshadows_core::geometry::camera::Camera;
use softshadows_core::geometry::gbuffer::gbuffer;
use softshadows_core::geometry::mesh::{Mesh, Scene};
use softshadows_core::light::lights::Light;
use softshadows_core::light::sampling::{Pattern, SampleSet};
use softshadows_core::methods::ray_traced::{ray_traced, RayTracedOptions};
use std::f32::consts::PI;
use std::time::Instant;

/// A latitude-longitude sphere of `2 n m` triangles.
fn sphere(center: Vec3, radius: f32, n: u32, m: u32) -> Mesh {
    let mut pos = Vec::new();
    for i in 0..=m {
        let theta = PI * i as f32 / m as f32;
        for j in 0..=n {
            let phi = 2.0 * PI * (j % n) as f32 / n as f32;
            pos.push(
                center
                    + radius
                        * Vec3::new(
                            theta.sin() * phi.cos(),
                            theta.cos(),
                            theta.sin() * phi.sin(),
                        ),
            );
        }
    }
    let faces = (0..m)
        .flat_map(|i| (0..n).map(move |j| (i, j)))
        .flat_map(|(i, j)| {
            let a = i * (n + 1) + j;
            [[a, a + n + 1, a + 1], [a + 1, a + n + 1, a + n + 2]]
        })
        .collect();
    Mesh::new(pos, faces, None, None, true).expect("valid sphere")
}

/// The square |x|, |z| <= s at height 0 as a `k x k` grid.
fn ground(s: f32, k: u32) -> Mesh {
    let pos = (0..=k)
        .flat_map(|i| {
            (0..=k).map(move |j| {
                Vec3::new(
                    -s + 2.0 * s * j as f32 / k as f32,
                    0.0,
                    -s + 2.0 * s * i as f32 / k as f32,
                )
            })
        })
        .collect();
    let faces = (0..k)
        .flat_map(|i| (0..k).map(move |j| i * (k + 1) + j))
        .flat_map(|a| [[a, a + k + 1, a + 1], [a + 1, a + k + 1, a + k + 2]])
        .collect();
    Mesh::new(pos, faces, None, None, false).expect("valid ground")
}

fn main() {
    let threads: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let threads = if threads.is_empty() {
        vec![1, 2]
    } else {
        threads
    };
    let scene = Scene::new(vec![
        ground(4.0, 64),
        sphere(Vec3::new(0.0, 1.2, 0.0), 1.0, 240, 128),
    ])
    .expect("scene");
    let light =
        Light::rect(Vec3::new(1.0, 5.0, 0.5), Vec3::X * 0.75, Vec3::Z * 0.75).expect("light");
    let cam = Camera::look_at(
        Vec3::new(0.0, 5.0, 6.0),
        Vec3::new(0.0, 0.6, 0.0),
        Vec3::Y,
        55.0,
        256,
        256,
    )
    .expect("camera");
    let shared =
        SampleSet::generate(&light, 64, Pattern::Stratified, 1, 1, false, 0).expect("samples");
    let rotated =
        SampleSet::generate(&light, 64, Pattern::Stratified, 1, 1, true, 0).expect("samples");
    println!("triangles: {}", scene.num_faces());
    for t in threads {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .expect("pool");
        pool.install(|| {
            let start = Instant::now();
            let bvh = Bvh::build(&scene).expect("bvh");
            let build = start.elapsed().as_secs_f64();
            let mut gbuf = f64::INFINITY;
            let mut gb = None;
            for _ in 0..3 {
                let start = Instant::now();
                gb = Some(gbuffer(&scene, &bvh, &cam, 1).expect("gbuffer"));
                gbuf = gbuf.min(start.elapsed().as_secs_f64());
            }
            let gb = gb.expect("ran three times");
            let rx = gb.receivers().expect("receivers");
            let opts = RayTracedOptions::for_scene(&scene);
            println!(
                "threads {t}: build {:.1} ms ({} nodes, {} leaves, depth {}, {:.1} MB), gbuffer {:.1} ms ({:.2} Mrays/s)",
                build * 1e3,
                bvh.node_count(),
                bvh.leaf_count(),
                bvh.depth(),
                bvh.memory_bytes() as f64 / 1e6,
                gbuf * 1e3,
                (256.0 * 256.0) / gbuf / 1e6,
            );
            for (name, samples) in [("shared samples", &shared), ("rotated per receiver", &rotated)] {
                let mut best = f64::INFINITY;
                let mut rays = 0.0;
                let mut mean = 0.0;
                for _ in 0..5 {
                    let (vis, stats) = ray_traced(&scene, &bvh, &light, &rx, samples, &opts).expect("ray_traced");
                    best = best.min(stats.get("trace_seconds").unwrap_or(f64::NAN));
                    rays = stats.get("rays").unwrap_or(0.0);
                    mean = vis.iter().sum::<f32>() / vis.len() as f32;
                }
                println!(
                    "  {name}: {:.2e} shadow rays in {:.1} ms = {:.2} Mrays/s (mean V {mean:.4})",
                    rays,
                    best * 1e3,
                    rays / best / 1e6
                );
            }
        });
    }
}
