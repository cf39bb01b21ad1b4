//! Integration tests of the BVH, the ray-traced oracle and the G-buffer: analytic cases,
//! alpha testing, watertightness, brute-force agreement and determinism.

mod common;

use common::{mesh, plane, quad, uv_sphere};
use glam::{Vec2, Vec3};
use softshadows_core::geometry::bvh::{intersect_triangle, Bvh};
use softshadows_core::geometry::camera::Camera;
use softshadows_core::geometry::gbuffer::gbuffer;
use softshadows_core::geometry::mesh::{AlphaTexture, Mesh, Scene};
use softshadows_core::geometry::receivers::Receivers;
use softshadows_core::light::lights::Light;
use softshadows_core::light::sampling::{Pattern, Rng, SampleSet};
use softshadows_core::methods::ray_traced::{auto_epsilon, ray_traced, RayTracedOptions};
use softshadows_core::methods::CasterFaces;
use softshadows_core::Error;

// ---------------------------------------------------------------- scene helpers

fn receivers(points: Vec<Vec3>, normals: Vec<Vec3>) -> Receivers {
    let n = points.len();
    Receivers::new(points, normals, vec![true; n], n, 1).unwrap()
}

fn run(scene: &Scene, light: &Light, rx: &Receivers, samples: &SampleSet) -> Vec<f32> {
    let bvh = Bvh::build(scene).unwrap();
    let opts = RayTracedOptions::for_scene(scene);
    let (vis, stats) = ray_traced(scene, &bvh, light, rx, samples, &opts).unwrap();
    assert!(stats.get("rays").is_some() && stats.get("trace_seconds").is_some());
    assert!(vis.iter().all(|v| (0.0..=1.0).contains(v)));
    vis
}

/// A rectangle light of half-size `s` at height `h`, facing down.
fn ceiling_light(h: f32, s: f32) -> Light {
    Light::rect(Vec3::new(0.0, h, 0.0), Vec3::X * s, Vec3::Z * s).unwrap()
}

fn ground_receivers(xs: &[f32]) -> Receivers {
    receivers(
        xs.iter().map(|&x| Vec3::new(x, 0.0, 0.3 * x)).collect(),
        vec![Vec3::Y; xs.len()],
    )
}

// ---------------------------------------------------------------- analytic cases

#[test]
fn unoccluded_receivers_see_everything() {
    let scene = Scene::new(vec![plane(0.0, 10.0)]).unwrap();
    let light = ceiling_light(5.0, 1.0);
    let samples = SampleSet::generate(&light, 64, Pattern::Stratified, 1, 1, false, 0).unwrap();
    let vis = run(
        &scene,
        &light,
        &ground_receivers(&[-3.0, 0.0, 0.5, 4.0]),
        &samples,
    );
    assert_eq!(vis, vec![1.0; 4]);
}

#[test]
fn receivers_under_a_large_plane_see_nothing() {
    let scene = Scene::new(vec![plane(0.0, 10.0), plane(2.0, 10.0)]).unwrap();
    let light = ceiling_light(5.0, 1.0);
    let samples = SampleSet::generate(&light, 64, Pattern::Stratified, 1, 1, false, 0).unwrap();
    let vis = run(
        &scene,
        &light,
        &ground_receivers(&[-3.0, 0.0, 0.5, 4.0]),
        &samples,
    );
    assert_eq!(vis, vec![0.0; 4]);
}

#[test]
fn samples_behind_the_tangent_plane_and_invalid_receivers_count_zero() {
    let scene = Scene::new(vec![plane(-5.0, 1.0)]).unwrap();
    let light = ceiling_light(5.0, 1.0);
    let samples = SampleSet::generate(&light, 16, Pattern::Stratified, 1, 1, false, 0).unwrap();
    // Facing away from the light; facing it; invalid.
    let rx = Receivers::new(
        vec![Vec3::ZERO; 3],
        vec![-Vec3::Y, Vec3::Y, Vec3::Y],
        vec![true, true, false],
        3,
        1,
    )
    .unwrap();
    assert_eq!(run(&scene, &light, &rx, &samples), vec![0.0, 1.0, 0.0]);
}

/// Area of the intersection of two disks of radii `r1`, `r2` whose centers are `d` apart.
fn lens_area(r1: f64, r2: f64, d: f64) -> f64 {
    if d >= r1 + r2 {
        return 0.0;
    }
    if d <= (r1 - r2).abs() {
        return std::f64::consts::PI * r1.min(r2).powi(2);
    }
    let a1 = ((d * d + r1 * r1 - r2 * r2) / (2.0 * d * r1)).acos();
    let a2 = ((d * d + r2 * r2 - r1 * r1) / (2.0 * d * r2)).acos();
    let k = ((-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2)).sqrt();
    r1 * r1 * a1 + r2 * r2 * a2 - 0.5 * k
}

/// A horizontal disk fan of `n` segments whose area equals that of the radius-`r` disk.
fn disk_fan(center: Vec3, r: f32, n: u32) -> Mesh {
    let step = 2.0 * std::f64::consts::PI / n as f64;
    let rp = (r as f64 * (step / step.sin()).sqrt()) as f32;
    let mut pos = vec![center];
    pos.extend((0..n).map(|k| {
        let a = step * k as f64;
        center + Vec3::new(rp * a.cos() as f32, 0.0, rp * a.sin() as f32)
    }));
    mesh(pos, (0..n).map(|k| [0, 1 + k, 1 + (k + 1) % n]).collect())
}

#[test]
fn disk_light_over_coaxial_disk_matches_the_analytic_penumbra() {
    // Light: disk of radius R at height H facing down. Occluder: disk of radius r at height h.
    // Seen from a receiver p on the ground, the segment p -> y crosses the occluder plane at
    // p + (y - p) h / H, so the occluder hides the light points within r H / h of the point
    // -p_xz (H - h) / h (similar triangles): the hidden fraction is the lens area of two disks
    // (R, r H / h) at distance |p_xz| (H - h) / h over pi R^2. On the axis it is (r H / (h R))^2.
    let (big_h, h, big_r, r) = (4.0f32, 2.0f32, 1.0f32, 0.3f32);
    let scene = Scene::new(vec![disk_fan(Vec3::new(0.0, h, 0.0), r, 1024)]).unwrap();
    let light = Light::disk(Vec3::new(0.0, big_h, 0.0), -Vec3::Y, big_r).unwrap();
    let samples = SampleSet::generate(&light, 4096, Pattern::Sobol, 9, 1, false, 0).unwrap();
    let xs = [0.0f32, 0.25, 0.5, 0.9, 1.2, 1.55, 2.5];
    let rx = receivers(
        xs.iter().map(|&x| Vec3::new(x, 0.0, 0.0)).collect(),
        vec![Vec3::Y; xs.len()],
    );
    let vis = run(&scene, &light, &rx, &samples);
    let rho = (r * big_h / h) as f64;
    for (&x, &v) in xs.iter().zip(&vis) {
        let d = (x * (big_h - h) / h) as f64;
        let expect =
            1.0 - lens_area(big_r as f64, rho, d) / (std::f64::consts::PI * (big_r as f64).powi(2));
        assert!(
            (v as f64 - expect).abs() < 0.01,
            "x = {x}: {v} vs analytic {expect}"
        );
    }
    assert!((vis[0] - 0.64).abs() < 0.01 && vis[6] == 1.0);
}

#[test]
fn tiny_rect_light_equals_the_point_light_exactly() {
    // Half-extents 1e-9: far below the ulp of the center's coordinates, so every sample rounds
    // onto the center. (1e-12 would be refused: |u x v|^2 underflows f32 and reads as zero area.)
    let c = Vec3::new(0.3, 4.0, 0.2);
    let rect = Light::rect(c, Vec3::X * 1e-9, Vec3::Z * 1e-9).unwrap();
    let point = Light::point(c).unwrap();
    let scene = Scene::new(vec![
        plane(0.0, 4.0),
        uv_sphere(Vec3::new(0.0, 1.5, 0.0), 0.7, 24, 12, false),
    ])
    .unwrap();
    let pts: Vec<Vec3> = (0..400)
        .map(|k| {
            Vec3::new(
                (k % 20) as f32 * 0.2 - 2.0,
                0.0,
                (k / 20) as f32 * 0.2 - 2.0,
            )
        })
        .collect();
    let rx = receivers(pts.clone(), vec![Vec3::Y; pts.len()]);
    let a = run(
        &scene,
        &rect,
        &rx,
        &SampleSet::generate(&rect, 16, Pattern::Stratified, 3, 1, false, 0).unwrap(),
    );
    let b = run(
        &scene,
        &point,
        &rx,
        &SampleSet::generate(&point, 16, Pattern::Stratified, 3, 1, false, 0).unwrap(),
    );
    assert_eq!(a, b);
    assert!(a.contains(&0.0) && a.contains(&1.0));
}

// ---------------------------------------------------------------- alpha testing

/// The unit square at height 1 with uv = (x, z) and an 8 x 8 checkerboard: texel (i, j) (row i
/// covers v = z in [i/8, (i+1)/8)) is opaque when i + j is even.
fn checker_scene() -> Scene {
    let alpha: Vec<f32> = (0..64)
        .map(|k| ((k / 8 + k % 8) % 2 == 0) as u8 as f32)
        .collect();
    let pos = vec![
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];
    let uvs = pos.iter().map(|p| Vec2::new(p.x, p.z)).collect();
    let tex = AlphaTexture::new(8, 8, &alpha).unwrap();
    let m = Mesh::new(pos, vec![[0, 1, 2], [0, 2, 3]], Some(uvs), Some(tex), false).unwrap();
    Scene::new(vec![m, plane(-1.0, 2.0)]).unwrap()
}

#[test]
fn perforated_quad_blocks_exactly_the_rays_through_opaque_texels() {
    let scene = checker_scene();
    let bvh = Bvh::build(&scene).unwrap();
    let mut rng = Rng::new(5);
    for _ in 0..4000 {
        let (i, j) = (rng.below(8), rng.below(8));
        // Stay 5% of a texel away from its borders.
        let x = (j as f32 + 0.05 + 0.9 * rng.next_f32()) / 8.0;
        let z = (i as f32 + 0.05 + 0.9 * rng.next_f32()) / 8.0;
        let opaque = (i + j) % 2 == 0;
        let o = Vec3::new(x, 0.0, z);
        // Slightly slanted rays: they cross the quad 0.1 * 1/16 off the vertical.
        let dir = Vec3::new(0.005, 2.0, -0.005);
        assert_eq!(
            bvh.occluded(&scene, o, dir, 1.0),
            opaque,
            "texel ({i}, {j}) at ({x}, {z})"
        );
        let hit = bvh.intersect(&scene, o, dir, f32::INFINITY);
        assert_eq!(hit.is_some(), opaque);
        if let Some(h) = hit {
            assert!((h.t - 0.5).abs() < 1e-6 && h.face < 2);
        }
        // From above, through the hole, the closest hit is the small plane below.
        if !opaque {
            let h = bvh.intersect(&scene, o + Vec3::Y * 2.0, -Vec3::Y, f32::INFINITY);
            assert!(h.is_some_and(|h| h.face >= 2 && (h.t - 3.0).abs() < 1e-5));
        }
    }
    // Through ray_traced: receivers under texel centers and a far point light above.
    let light = Light::point(Vec3::new(0.5, 1000.0, 0.5)).unwrap();
    let pts: Vec<Vec3> = (0..64)
        .map(|k| {
            Vec3::new(
                ((k % 8) as f32 + 0.5) / 8.0,
                0.0,
                ((k / 8) as f32 + 0.5) / 8.0,
            )
        })
        .collect();
    let rx = receivers(pts, vec![Vec3::Y; 64]);
    let vis = run(
        &scene,
        &light,
        &rx,
        &SampleSet::generate(&light, 4, Pattern::Uniform, 1, 1, false, 0).unwrap(),
    );
    let expect: Vec<f32> = (0..64)
        .map(|k| if (k / 8 + k % 8) % 2 == 0 { 0.0 } else { 1.0 })
        .collect();
    assert_eq!(vis, expect);
}

// ---------------------------------------------------------------- watertightness

/// The closed cube [-1, 1]^3 with every face an `n x n` grid (coordinates exact in binary).
fn grid_cube(n: u32) -> Mesh {
    let mut pos = Vec::new();
    let mut faces = Vec::new();
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let base = pos.len() as u32;
            for i in 0..=n {
                for j in 0..=n {
                    let (a, b) = (
                        -1.0 + 2.0 * i as f32 / n as f32,
                        -1.0 + 2.0 * j as f32 / n as f32,
                    );
                    let mut p = [0.0; 3];
                    p[axis] = side;
                    p[(axis + 1) % 3] = a;
                    p[(axis + 2) % 3] = b;
                    pos.push(Vec3::from_array(p));
                }
            }
            for i in 0..n {
                for j in 0..n {
                    let a = base + i * (n + 1) + j;
                    // Alternate the diagonal so both edge orientations occur.
                    if (i + j) % 2 == 0 {
                        faces.extend([[a, a + n + 1, a + n + 2], [a, a + n + 2, a + 1]]);
                    } else {
                        faces.extend([[a, a + n + 1, a + 1], [a + 1, a + n + 1, a + n + 2]]);
                    }
                }
            }
        }
    }
    Mesh::new(pos, faces, None, None, true).unwrap()
}

/// Every vertex and edge midpoint of `m`.
fn vertices_and_midpoints(m: &Mesh) -> Vec<Vec3> {
    let mut pts = m.positions.clone();
    for f in &m.faces {
        for k in 0..3 {
            pts.push((m.positions[f[k] as usize] + m.positions[f[(k + 1) % 3] as usize]) * 0.5);
        }
    }
    pts
}

#[test]
fn rays_through_shared_edges_and_vertices_never_leak() {
    let cube = grid_cube(8);
    let ico = uv_sphere(Vec3::new(0.1, -0.2, 0.05), 1.0, 48, 24, false);
    for m in [cube, ico] {
        let targets = vertices_and_midpoints(&m);
        let center = m.positions.iter().copied().sum::<Vec3>() / m.positions.len() as f32;
        let scene = Scene::new(vec![m]).unwrap();
        let bvh = Bvh::build(&scene).unwrap();
        let mut rng = Rng::new(17);
        let mut tested = 0;
        for &p in &targets {
            // From outside through p towards the interior: the segment must cross the surface.
            let out = p + (p - center) * 2.0;
            assert!(
                bvh.occluded(&scene, out, center - out, 1.0),
                "leak towards the center through {p}"
            );
            assert!(bvh.intersect(&scene, out, center - out, 1.0).is_some());
            // Random directions through p that enter the solid (away from the outward normal).
            for _ in 0..4 {
                let d = Vec3::new(
                    rng.next_f32() - 0.5,
                    rng.next_f32() - 0.5,
                    rng.next_f32() - 0.5,
                );
                let inward = (center - p).normalize();
                let dir = (d * 0.8 + inward).normalize();
                let o = p - dir * 3.0;
                // The ray passes (to rounding) through p into the interior and leaves it again.
                if (o - center).length() > 1.8 {
                    assert!(
                        bvh.occluded(&scene, o, dir, 6.0),
                        "leak through {p} along {dir}"
                    );
                    tested += 1;
                }
            }
        }
        assert!(tested > 1000);
    }
    // Axis-aligned rays exactly along the grid lines of the cube: every one hits at t = 4.
    let scene = Scene::new(vec![grid_cube(8)]).unwrap();
    let bvh = Bvh::build(&scene).unwrap();
    for i in 0..=16 {
        for j in 0..=16 {
            let (a, b) = (-1.0 + i as f32 / 8.0, -1.0 + j as f32 / 8.0);
            for (o, d) in [
                (Vec3::new(a, b, 5.0), -Vec3::Z),
                (Vec3::new(-5.0, a, b), Vec3::X),
                (Vec3::new(b, 5.0, a), -Vec3::Y),
            ] {
                let h = bvh.intersect(&scene, o, d, f32::INFINITY);
                assert_eq!(h.map(|h| h.t), Some(4.0), "ray from {o} along {d}");
            }
        }
    }
}

// ---------------------------------------------------------------- brute force agreement

/// A random soup: opaque triangles and a perforated mesh with a random binary texture.
fn soup(n: usize, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut r3 = |s: f32| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * s;
    let mut pos = Vec::new();
    for _ in 0..n {
        let c = r3(4.0);
        pos.extend([c + r3(0.6) - 0.3, c + r3(0.6) - 0.3, c + r3(0.6) - 0.3]);
    }
    let faces: Vec<[u32; 3]> = (0..n as u32)
        .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
        .collect();
    let opaque = mesh(pos.clone(), faces.clone());
    let uvs: Vec<Vec2> = pos
        .iter()
        .map(|p| Vec2::new(p.x * 3.1, p.z * 2.7 + p.y))
        .collect();
    let alpha: Vec<f32> = (0..16 * 16)
        .map(|k| ((k * 7919 + 13) % 5 < 2) as u8 as f32)
        .collect();
    let shifted: Vec<Vec3> = pos
        .iter()
        .map(|p| *p + Vec3::new(0.17, -0.11, 0.23))
        .collect();
    let perforated = Mesh::new(
        shifted,
        faces,
        Some(uvs),
        Some(AlphaTexture::new(16, 16, &alpha).unwrap()),
        false,
    )
    .unwrap();
    Scene::new(vec![opaque, perforated]).unwrap()
}

/// Brute-force closest opaque hit `(t, face)` over all triangles.
fn brute_closest(scene: &Scene, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, u32)> {
    let mut best: Option<(f32, u32)> = None;
    for (id, tri) in scene.triangles() {
        if let Some((t, b1, b2)) = intersect_triangle(o, d, tri, t_max) {
            if scene.is_opaque_at(id, b1, b2) && best.is_none_or(|(bt, _)| t < bt) {
                best = Some((t, id));
            }
        }
    }
    best
}

#[test]
fn closest_and_any_hit_equal_brute_force_on_a_random_soup() {
    let scene = soup(1500, 3);
    let bvh = Bvh::build(&scene).unwrap();
    assert!(bvh.depth() >= 3 && bvh.leaf_count() >= 3000 / 4);
    let mut rng = Rng::new(11);
    let mut hits = 0;
    for _ in 0..3000 {
        let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 1.0;
        let d = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
        let t_max = if rng.next_f32() < 0.5 {
            f32::INFINITY
        } else {
            rng.next_f32() * 4.0
        };
        let brute = brute_closest(&scene, o, d, t_max);
        let got = bvh.intersect(&scene, o, d, t_max);
        assert_eq!(got.map(|h| h.t), brute.map(|b| b.0), "ray {o} {d}");
        if let (Some(h), Some((_, face))) = (got, brute) {
            hits += 1;
            if h.face != face {
                // A tie: the BVH's face must be hit at the very same distance.
                let tri = scene.triangles().nth(h.face as usize).unwrap().1;
                assert_eq!(intersect_triangle(o, d, tri, t_max).map(|x| x.0), Some(h.t));
            }
        }
        assert_eq!(bvh.occluded(&scene, o, d, t_max), brute.is_some());
    }
    assert!(hits > 300, "{hits}");
}

#[test]
fn shadow_ray_bundles_equal_single_rays() {
    // `occluded_many` culls with the frustum of a receiver's rays; its answers must be those of
    // `occluded` ray by ray: on a random soup with bundles of every spread, and through the
    // exact vertices and edge midpoints of a closed grid cube.
    let scene = soup(1500, 8);
    let bvh = Bvh::build(&scene).unwrap();
    let mut rng = Rng::new(23);
    let (mut out, mut blocked, mut lit) = (Vec::new(), 0, 0);
    for case in 0..3000 {
        let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 5.0 - 0.5;
        let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 1.0;
        let spread = [0.01f32, 0.3, 2.0, 8.0][case % 4];
        let n = [3, 4, 16, 64][case / 4 % 4];
        let targets: Vec<Vec3> = (0..n)
            .map(|_| c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * spread)
            .collect();
        bvh.occluded_many(&scene, o, &targets, None, &mut out);
        for (y, &b) in targets.iter().zip(&out) {
            assert_eq!(
                b,
                bvh.occluded(&scene, o, *y - o, 1.0),
                "case {case}: {o} -> {y}"
            );
            if b {
                blocked += 1
            } else {
                lit += 1
            }
        }
    }
    assert!(blocked > 10_000 && lit > 10_000, "{blocked} {lit}");
    let m = grid_cube(8);
    let pts = vertices_and_midpoints(&m);
    let scene = Scene::new(vec![m]).unwrap();
    let bvh = Bvh::build(&scene).unwrap();
    for o in [
        Vec3::new(0.3, 0.2, 6.0),
        Vec3::new(-5.0, 4.0, 3.0),
        Vec3::new(0.0, 0.0, 1.5),
    ] {
        // Segments ending just past each vertex / edge midpoint, and exactly at them.
        for chunk in pts.chunks(64) {
            for scale in [1.0f32, 1.01] {
                let targets: Vec<Vec3> = chunk.iter().map(|&p| o + (p - o) * scale).collect();
                bvh.occluded_many(&scene, o, &targets, None, &mut out);
                for (y, &b) in targets.iter().zip(&out) {
                    assert_eq!(b, bvh.occluded(&scene, o, *y - o, 1.0), "{o} -> {y}");
                }
            }
        }
    }
}

#[test]
fn tiny_scenes_with_a_leaf_root_work() {
    let scene = Scene::new(vec![quad(
        Vec3::new(-1.0, 1.0, -1.0),
        Vec3::new(1.0, 1.0, -1.0),
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(-1.0, 1.0, 1.0),
    )])
    .unwrap();
    let bvh = Bvh::build(&scene).unwrap();
    assert_eq!((bvh.node_count(), bvh.leaf_count(), bvh.depth()), (0, 1, 1));
    assert!(bvh.occluded(&scene, Vec3::ZERO, Vec3::Y * 2.0, 1.0));
    assert!(!bvh.occluded(&scene, Vec3::ZERO, Vec3::Y * 2.0, 0.5));
    assert!(!bvh.occluded(&scene, Vec3::ZERO, Vec3::ZERO, 1.0));
    assert!(!bvh.occluded(&scene, Vec3::ZERO, Vec3::Y, f32::NAN));
    // The open interval: a hit exactly at t_max does not count.
    assert!(!bvh.occluded(&scene, Vec3::ZERO, Vec3::Y, 1.0));
}

// ---------------------------------------------------------------- determinism

fn shadow_scene() -> Scene {
    let alpha: Vec<f32> = (0..32 * 32)
        .map(|k| ((k / 32 / 4 + k % 32 / 4) % 2) as f32)
        .collect();
    let pos = vec![
        Vec3::new(-1.0, 2.5, -1.0),
        Vec3::new(1.0, 2.5, -1.0),
        Vec3::new(1.0, 2.5, 1.0),
        Vec3::new(-1.0, 2.5, 1.0),
    ];
    let uvs = pos.iter().map(|p| Vec2::new(p.x, p.z)).collect();
    let fence = Mesh::new(
        pos,
        vec![[0, 1, 2], [0, 2, 3]],
        Some(uvs),
        Some(AlphaTexture::new(32, 32, &alpha).unwrap()),
        false,
    )
    .unwrap();
    Scene::new(vec![
        plane(0.0, 4.0),
        uv_sphere(Vec3::new(0.7, 1.0, 0.3), 0.6, 96, 64, false),
        fence,
    ])
    .unwrap()
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let scene = shadow_scene();
    assert!(scene.num_faces() > 12_000);
    let light = Light::rect(Vec3::new(0.0, 5.0, 0.0), Vec3::X * 0.8, Vec3::Z * 0.6).unwrap();
    let cam = Camera::look_at(Vec3::new(0.0, 6.0, 6.0), Vec3::ZERO, Vec3::Y, 50.0, 48, 40).unwrap();
    let samples = SampleSet::generate(&light, 32, Pattern::Poisson, 7, 2, true, 0).unwrap();
    let go = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let bvh = Bvh::build(&scene).unwrap();
            let gb = gbuffer(&scene, &bvh, &cam, 4).unwrap();
            let rx = gb.receivers().unwrap();
            let (vis, _) = ray_traced(
                &scene,
                &bvh,
                &light,
                &rx,
                &samples,
                &RayTracedOptions::for_scene(&scene),
            )
            .unwrap();
            (bvh, gb, vis)
        })
    };
    let (b1, g1, v1) = go(1);
    let (b2, g2, v2) = go(2);
    assert!(b1 == b2 && g1 == g2, "BVH or G-buffer differ");
    assert_eq!(
        v1.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        v2.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    assert!(
        v1.iter().any(|&v| v > 0.0 && v < 1.0),
        "expected a penumbra"
    );
}

// ---------------------------------------------------------------- G-buffer and options

#[test]
fn gbuffer_of_a_plane() {
    let scene = Scene::new(vec![plane(0.0, 1.0)]).unwrap();
    let bvh = Bvh::build(&scene).unwrap();
    // Looking straight down from y = 2 with a 90 degree view: the plane covers the middle half.
    let cam = Camera::look_at(Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO, Vec3::Z, 90.0, 8, 8).unwrap();
    let gb = gbuffer(&scene, &bvh, &cam, 4).unwrap();
    assert_eq!(gb.sample_depths.len(), 8 * 8 * 4);
    for y in 0..8 {
        for x in 0..8 {
            let i = y * 8 + x;
            let inside = (2..6).contains(&x) && (2..6).contains(&y);
            assert_eq!(gb.mask[i], inside, "pixel ({x}, {y})");
            if inside {
                assert!(
                    gb.positions[i].y.abs() < 1e-6
                        && gb.normals[i] == Vec3::Y
                        && gb.face_ids[i] >= 0
                );
                for s in 0..4 {
                    let d = gb.sample_depths[i * 4 + s];
                    assert!((2.0..2.0 * 3f32.sqrt()).contains(&d), "{d}");
                }
            } else {
                assert!(gb.face_ids[i] == -1 && gb.normals[i] == Vec3::ZERO);
            }
        }
    }
    // Seen from below, the normal flips to face the camera.
    let below =
        Camera::look_at(Vec3::new(0.0, -2.0, 0.0), Vec3::ZERO, Vec3::Z, 90.0, 8, 8).unwrap();
    let gb = gbuffer(&scene, &bvh, &below, 1).unwrap();
    assert!(gb.sample_depths.is_empty() && gb.normals[3 * 8 + 3] == -Vec3::Y);
    let rx = gb.receivers().unwrap();
    assert_eq!(
        (rx.len(), rx.valid.iter().filter(|&&v| v).count()),
        (64, 16)
    );
    assert!(
        matches!(gbuffer(&scene, &bvh, &below, 3), Err(Error::InvalidInput { ref arg, .. }) if arg == "msaa")
    );
}

#[test]
fn bad_options_and_mismatched_bvh_are_refused() {
    let scene = Scene::new(vec![plane(0.0, 1.0)]).unwrap();
    let other = Scene::new(vec![plane(0.0, 1.0), plane(1.0, 1.0)]).unwrap();
    let bvh = Bvh::build(&scene).unwrap();
    let light = ceiling_light(2.0, 0.5);
    let samples = SampleSet::generate(&light, 4, Pattern::Uniform, 1, 1, false, 0).unwrap();
    let rx = ground_receivers(&[0.0]);
    let bad = RayTracedOptions {
        epsilon: f32::NAN,
        caster_faces: CasterFaces::All,
    };
    assert!(
        matches!(ray_traced(&scene, &bvh, &light, &rx, &samples, &bad), Err(Error::InvalidInput { ref arg, .. }) if arg == "epsilon")
    );
    let ok = RayTracedOptions {
        epsilon: 1e-4,
        caster_faces: CasterFaces::All,
    };
    assert!(
        matches!(ray_traced(&other, &bvh, &light, &rx, &samples, &ok), Err(Error::InvalidInput { ref arg, .. }) if arg == "bvh")
    );
    assert!((auto_epsilon(&scene) - 1e-4 * 8f64.sqrt()).abs() < 1e-9);
}

#[test]
fn textured_light_weights_samples() {
    use softshadows_core::light::lights::EmissionTexture;
    // Left half of the light emits 3, right half 1; an occluder hides exactly the left half
    // from the receiver at the origin: V = 1 / (3 + 1).
    let tex = EmissionTexture::new(2, 1, vec![3.0, 1.0]).unwrap();
    let light = Light::rect(Vec3::new(0.0, 4.0, 0.0), Vec3::X, Vec3::Z)
        .unwrap()
        .with_emission(tex)
        .unwrap();
    let blocker = quad(
        Vec3::new(-3.0, 2.0, -3.0),
        Vec3::new(0.0, 2.0, -3.0),
        Vec3::new(0.0, 2.0, 3.0),
        Vec3::new(-3.0, 2.0, 3.0),
    );
    let scene = Scene::new(vec![blocker]).unwrap();
    let samples = SampleSet::generate(&light, 64, Pattern::Stratified, 2, 1, false, 0).unwrap();
    let vis = run(
        &scene,
        &light,
        &receivers(vec![Vec3::ZERO], vec![Vec3::Y]),
        &samples,
    );
    assert!((vis[0] - 0.25).abs() < 1e-6, "{}", vis[0]);
}
