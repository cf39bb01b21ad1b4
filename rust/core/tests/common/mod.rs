//! Scene builders shared by the integration tests (each test crate uses some of them).
#![allow(dead_code)]

use glam::Vec3;
use softshadows_core::geometry::mesh::{Mesh, Scene};
use softshadows_core::geometry::receivers::Receivers;
use softshadows_core::light::lights::Light;
use softshadows_core::light::sampling::Rng;

/// An open mesh without uvs or alpha.
pub fn mesh(positions: Vec<Vec3>, faces: Vec<[u32; 3]>) -> Mesh {
    Mesh::new(positions, faces, None, None, false).unwrap()
}

/// A quad with corners a, b, c, d (in order) as two triangles.
pub fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> Mesh {
    mesh(vec![a, b, c, d], vec![[0, 1, 2], [0, 2, 3]])
}

/// The square |x|, |z| <= s at height y.
pub fn plane(y: f32, s: f32) -> Mesh {
    quad(
        Vec3::new(-s, y, -s),
        Vec3::new(s, y, -s),
        Vec3::new(s, y, s),
        Vec3::new(-s, y, s),
    )
}

/// A latitude-longitude sphere with `2 * n * m` triangles (see `Mesh::uv_sphere`; their normals
/// `(b - a) x (c - a)` point inwards); `closed` declares it closed for the methods that cull by it.
pub fn uv_sphere(center: Vec3, radius: f32, n: u32, m: u32, closed: bool) -> Mesh {
    Mesh::uv_sphere(center, radius, n, m, closed).unwrap()
}

/// A ground quad (|x|, |z| <= 3 at y = 0) and a cloud of 300 random triangles above it.
pub fn ground_and_cloud() -> Scene {
    let ground = mesh(
        vec![
            Vec3::new(-3.0, 0.0, -3.0),
            Vec3::new(3.0, 0.0, -3.0),
            Vec3::new(3.0, 0.0, 3.0),
            Vec3::new(-3.0, 0.0, 3.0),
        ],
        vec![[0, 2, 1], [0, 3, 2]],
    );
    let mut rng = Rng::new(11);
    let mut pos = Vec::new();
    for _ in 0..300 {
        let c = Vec3::new(
            4.0 * rng.next_f32() - 2.0,
            0.5 + 1.5 * rng.next_f32(),
            4.0 * rng.next_f32() - 2.0,
        );
        pos.extend(
            (0..3).map(|_| {
                c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 0.6
            }),
        );
    }
    let faces = (0..300u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
    Scene::new(vec![ground, mesh(pos, faces)]).unwrap()
}

/// The rect light at y = 4 over [`ground_and_cloud`].
pub fn rect_light_above() -> Light {
    Light::rect(
        Vec3::new(0.2, 4.0, 0.1),
        Vec3::new(0.5, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -0.5),
    )
    .unwrap()
}

/// An `n × n` grid of upward receivers on the ground, |x|, |z| < 2.5.
pub fn ground_grid(n: usize) -> Receivers {
    let points = (0..n * n)
        .map(|i| {
            Vec3::new(
                -2.5 + 5.0 * (i % n) as f32 / n as f32,
                0.0,
                -2.5 + 5.0 * (i / n) as f32 / n as f32,
            )
        })
        .collect();
    Receivers::new(points, vec![Vec3::Y; n * n], vec![true; n * n], n, n).unwrap()
}
