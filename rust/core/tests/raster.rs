//! Integration tests of the shadow-map machinery: light frusta, standard and conservative
//! rasterization (fill rule, brute-force overlap, perspective-correct depth, near clipping, alpha
//! test), min/max pyramids, summed-area tables, mipmaps and the hard-shadow baseline.

mod common;

use common::uv_sphere;
use glam::{DVec2, DVec3, Vec2, Vec3};
use softshadows_core::geometry::bvh::Bvh;
use softshadows_core::geometry::camera::Camera;
use softshadows_core::geometry::gbuffer::gbuffer;
use softshadows_core::geometry::mesh::{AlphaTexture, Mesh, Scene};
use softshadows_core::geometry::receivers::Receivers;
use softshadows_core::light::lights::Light;
use softshadows_core::light::sampling::Rng;
use softshadows_core::light::sampling::SampleSet;
use softshadows_core::methods::ray_traced::{ray_traced, RayTracedOptions};
use softshadows_core::methods::shadow_map::{shadow_map, ShadowMapOptions};
use softshadows_core::raster::cube;
use softshadows_core::raster::depth::{
    rasterize_depth, FaceFilter, RasterMode, RasterOptions, Rasterizer,
};
use softshadows_core::raster::frustum::{GridRays, LightFrustum, TexelRect};
use softshadows_core::raster::pyramid::{MinMaxPyramid, MipMap, MultiScaleMap, SummedAreaTable};
use softshadows_core::Error;

// ---------------------------------------------------------------- helpers

/// A frustum at the origin looking down -z, 90 degrees, `n x n` texels.
fn frustum(n: usize) -> LightFrustum {
    LightFrustum::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 90.0, 1.0, 0.1, 100.0, n, n).unwrap()
}

/// The world point at texel coordinates (sx, sy) and linear depth z.
fn at(f: &LightFrustum, sx: f64, sy: f64, z: f32) -> Vec3 {
    f.unproject(sx as f32, sy as f32, z)
}

/// Texel coordinates of `p` in f64 (an independent, exact-as-possible projection).
fn project64(f: &LightFrustum, p: Vec3) -> DVec3 {
    let d = p.as_dvec3() - f.eye.as_dvec3();
    let v = DVec3::new(
        d.dot(f.right.as_dvec3()),
        d.dot(f.up.as_dvec3()),
        d.dot(f.forward.as_dvec3()),
    );
    let sx = 0.5 * f.width as f64 * (1.0 + v.x / (v.z * f.tan_half_x as f64));
    let sy = 0.5 * f.height as f64 * (1.0 - v.y / (v.z * f.tan_half_y as f64));
    DVec3::new(sx, sy, v.z)
}

/// Per-texel write counts and minimum depths of `tris` drawn one by one with the visitor.
fn draw(f: &LightFrustum, mode: RasterMode, tris: &[[Vec3; 3]]) -> (Vec<u32>, Vec<f32>) {
    let r = Rasterizer::new(f, mode).unwrap();
    let mut counts = vec![0u32; f.width * f.height];
    let mut depth = vec![f32::INFINITY; f.width * f.height];
    for t in tris {
        r.triangle(t, TexelRect::full(f.width, f.height), |fr| {
            let k = fr.y * f.width + fr.x;
            counts[k] += 1;
            depth[k] = depth[k].min(fr.depth);
        });
    }
    (counts, depth)
}

fn uniform(rng: &mut Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.next_f32() as f64
}

/// Area of the intersection of a triangle with the square [x, x+1] x [y, y+1] (Sutherland-Hodgman).
fn overlap_area(tri: [DVec2; 3], x: f64, y: f64) -> f64 {
    let mut poly: Vec<DVec2> = tri.to_vec();
    let planes: [(DVec2, f64); 4] = [
        (DVec2::X, x),
        (-DVec2::X, -(x + 1.0)),
        (DVec2::Y, y),
        (-DVec2::Y, -(y + 1.0)),
    ];
    for (n, off) in planes {
        let mut out = Vec::new();
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let (da, db) = (n.dot(a) - off, n.dot(b) - off);
            if da >= 0.0 {
                out.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                out.push(a + (b - a) * (da / (da - db)));
            }
        }
        poly = out;
        if poly.is_empty() {
            return 0.0;
        }
    }
    (0..poly.len())
        .map(|i| poly[i].perp_dot(poly[(i + 1) % poly.len()]))
        .sum::<f64>()
        .abs()
        * 0.5
}

// ---------------------------------------------------------------- frusta

#[test]
fn frustum_projects_and_unprojects() {
    let f = LightFrustum::new(
        Vec3::new(1.0, 2.0, 3.0),
        Vec3::new(0.0, 0.0, -4.0),
        Vec3::Y,
        50.0,
        1.5,
        0.1,
        50.0,
        300,
        200,
    )
    .unwrap();
    for (sx, sy, z) in [
        (0.0, 0.0, 1.0),
        (150.0, 100.0, 5.0),
        (299.5, 10.25, 20.0),
        (37.5, 199.0, 0.5),
    ] {
        let p = f.unproject(sx, sy, z);
        let s = f.project(p).unwrap();
        assert!(
            (s - Vec3::new(sx, sy, z)).abs().max_element() < 1e-3,
            "{s} vs {sx},{sy},{z}"
        );
    }
    // The center of the map looks down forward; row 0 is the top (+up).
    assert!((f.texel_ray(150.0, 100.0) - f.forward).length() < 1e-6);
    assert!(f.texel_ray(150.0, 0.0).dot(f.up) > 0.0);
    assert!(
        f.project(f.eye + f.forward * 0.05).is_none(),
        "nearer than near"
    );
    let w = f.texel_world_size(2.0);
    assert!((w - 2.0 * 2.0 * f.tan_half_x / 300.0).abs() < 1e-6);
}

#[test]
fn grid_rays_unproject_texel_corners_to_the_same_bits_as_the_frustum() {
    // Corners past the map included: a coarse pyramid level's last texel overhangs a side that is
    // not a multiple of its size.
    let (lo, hi) = (Vec3::new(-2.0, 0.0, -1.0), Vec3::new(3.0, 0.5, 2.0));
    let mut rng = Rng::new(4);
    for (eye, (w, h)) in [
        (Vec3::new(0.3, 5.0, -0.2), (64, 64)),
        (Vec3::new(10.0, 1.0, 0.5), (37, 90)),
    ] {
        let f = LightFrustum::fit(eye, lo, hi, 64).unwrap();
        let f = LightFrustum {
            width: w,
            height: h,
            ..f
        };
        let (columns, rows) = (w.next_multiple_of(64), h.next_multiple_of(64));
        let rays = GridRays::new(&f, columns, rows);
        for y in 0..=rows {
            for x in 0..=columns {
                let d = f.near + rng.next_f32() * (f.far - f.near);
                let (a, b) = (rays.unproject(x, y, d), f.unproject(x as f32, y as f32, d));
                assert_eq!(
                    a.to_array().map(f32::to_bits),
                    b.to_array().map(f32::to_bits)
                );
            }
        }
    }
}

#[test]
fn fitted_frustum_contains_the_box_and_refuses_an_eye_inside() {
    let (lo, hi) = (Vec3::new(-2.0, 0.0, -1.0), Vec3::new(3.0, 0.5, 2.0));
    for eye in [
        Vec3::new(0.0, 5.0, 0.0),
        Vec3::new(10.0, 1.0, 0.5),
        Vec3::new(2.9, 0.6, 1.9),
        Vec3::new(-1.0, -0.01, 0.0),
    ] {
        let f = LightFrustum::fit(eye, lo, hi, 256).unwrap();
        for i in 0..8 {
            let c = Vec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), hi, lo);
            let (x, y, z) = f
                .texel_of(c)
                .unwrap_or_else(|| panic!("corner {c} outside the frustum from {eye}"));
            assert!(x < 256 && y < 256 && z >= f.near && z <= f.far);
        }
    }
    for eye in [
        Vec3::new(0.0, 0.2, 0.0),
        Vec3::new(3.0, 0.5, 2.0),
        Vec3::new(0.0, 0.0, 0.0),
    ] {
        match LightFrustum::fit(eye, lo, hi, 256) {
            Err(Error::Unsupported { arg, message }) => {
                assert_eq!(arg, "light");
                assert!(message.contains("explicit frustum"), "{message}");
            }
            other => panic!("eye {eye} inside the box must be refused, got {other:?}"),
        }
    }
    assert!(LightFrustum::fit(Vec3::Y, lo, hi, 0).is_err());
    assert!(
        LightFrustum::new(Vec3::ZERO, Vec3::Y, Vec3::Y, 60.0, 1.0, 0.1, 10.0, 8, 8).is_err(),
        "up parallel"
    );
    assert!(
        LightFrustum::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 60.0, 1.0, 1.0, 0.5, 8, 8).is_err(),
        "near > far"
    );
}

// ---------------------------------------------------------------- standard rasterization

#[test]
fn shared_edges_are_drawn_exactly_once() {
    let n = 64;
    let f = frustum(n);
    let mut rng = Rng::new(7);
    // A jittered grid of triangles, larger than the map, including edges through texel centers.
    for trial in 0..40 {
        let k = 9;
        let cell = 100.0 / (k - 1) as f64;
        let grid: Vec<Vec3> = (0..k * k)
            .map(|i| {
                let (gx, gy) = ((i % k) as f64, (i / k) as f64);
                // At most 0.2 cells per axis, so no quad folds over its diagonal.
                let jitter = if trial == 0 { 0.0 } else { 0.2 * cell };
                let sx = -18.0
                    + gx * cell
                    + if gx > 0.0 && gx < (k - 1) as f64 {
                        uniform(&mut rng, -jitter, jitter)
                    } else {
                        0.0
                    };
                let sy = -18.0
                    + gy * cell
                    + if gy > 0.0 && gy < (k - 1) as f64 {
                        uniform(&mut rng, -jitter, jitter)
                    } else {
                        0.0
                    };
                at(&f, sx, sy, uniform(&mut rng, 1.0, 10.0) as f32)
            })
            .collect();
        let mut tris = Vec::new();
        for y in 0..k - 1 {
            for x in 0..k - 1 {
                let (a, b, c, d) = (
                    y * k + x,
                    y * k + x + 1,
                    (y + 1) * k + x,
                    (y + 1) * k + x + 1,
                );
                if (x + y + trial) % 2 == 0 {
                    tris.push([grid[a], grid[b], grid[d]]);
                    tris.push([grid[a], grid[d], grid[c]]);
                } else {
                    tris.push([grid[a], grid[b], grid[c]]);
                    tris.push([grid[b], grid[d], grid[c]]);
                }
            }
        }
        let orient = |t: &[Vec3; 3]| {
            let p = t.map(|v| project64(&f, v).truncate());
            (p[1] - p[0]).perp_dot(p[2] - p[0]).signum()
        };
        assert!(
            tris.iter().all(|t| orient(t) == orient(&tris[0])),
            "the test mesh folds"
        );
        let (counts, _) = draw(&f, RasterMode::Standard, &tris);
        let bad = counts.iter().filter(|&&c| c != 1).count();
        assert_eq!(bad, 0, "trial {trial}: {bad} texels not drawn exactly once");
    }
    // A fan around a texel center or corner with spokes through texel centers (45 degrees).
    for center in [(32.5, 32.5), (32.0, 32.0), (10.5, 50.0)] {
        let spokes = 8;
        let ring: Vec<Vec3> = (0..spokes)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / spokes as f64;
                at(
                    &f,
                    center.0 + 200.0 * a.cos(),
                    center.1 + 200.0 * a.sin(),
                    5.0,
                )
            })
            .collect();
        let c = at(&f, center.0, center.1, 5.0);
        let tris: Vec<[Vec3; 3]> = (0..spokes)
            .map(|i| [c, ring[i], ring[(i + 1) % spokes]])
            .collect();
        let (counts, _) = draw(&f, RasterMode::Standard, &tris);
        assert!(counts.iter().all(|&c| c == 1), "fan at {center:?}");
    }
}

#[test]
fn a_plane_clipped_by_the_near_plane_has_no_cracks_or_overlaps() {
    // The ground y = -0.2 from behind the eye (z = +5) to far ahead, as a grid of triangles; many
    // triangles cross the near plane (which hides the ground nearer than 0.3) and the guard bands.
    let n = 96;
    let f = LightFrustum::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 100.0, 1.0, 0.3, 100.0, n, n).unwrap();
    let k = 21;
    let pos = |i: usize, j: usize| {
        Vec3::new(
            -60.0 + 120.0 * i as f32 / (k - 1) as f32,
            -0.2,
            5.0 - 65.0 * j as f32 / (k - 1) as f32,
        )
    };
    let mut tris = Vec::new();
    for j in 0..k - 1 {
        for i in 0..k - 1 {
            tris.push([pos(i, j), pos(i + 1, j), pos(i + 1, j + 1)]);
            tris.push([pos(i, j), pos(i + 1, j + 1), pos(i, j + 1)]);
        }
    }
    let (counts, depth) = draw(&f, RasterMode::Standard, &tris);
    let (mut checked, mut clipped) = (0, 0);
    for y in 0..n {
        for x in 0..n {
            let r = f.texel_ray(x as f32 + 0.5, y as f32 + 0.5).as_dvec3();
            let c = counts[y * n + x];
            assert!(c <= 1, "texel {x},{y} drawn {c} times");
            if r.y >= 0.0 {
                assert_eq!(c, 0, "above the horizon");
                continue;
            }
            let t = -0.2 / r.y; // linear depth of the hit (forward component of r is 1)
            let hit = r * t;
            if t < 0.3 * 0.99 {
                assert_eq!(c, 0, "texel {x},{y}: ground nearer than the near plane");
                clipped += 1;
            }
            let inside = hit.x.abs() < 59.0 && hit.z < 4.0 && hit.z > -59.0 && t > 0.3 * 1.01;
            if inside {
                checked += 1;
                assert_eq!(c, 1, "texel {x},{y} (depth {t}) not drawn");
                let d = depth[y * n + x] as f64;
                assert!((d - t).abs() <= 1e-5 * t, "texel {x},{y}: depth {d} vs {t}");
            }
        }
    }
    assert!(
        checked > n * n / 4 && clipped > n,
        "checked {checked}, clipped {clipped}"
    );
}

#[test]
fn depth_is_perspective_correct() {
    let n = 128;
    let f = LightFrustum::new(
        Vec3::new(0.5, 3.0, 1.0),
        Vec3::ZERO,
        Vec3::Y,
        70.0,
        1.3,
        0.05,
        50.0,
        n,
        n,
    )
    .unwrap();
    let mut rng = Rng::new(3);
    let mut tested = 0;
    for _ in 0..20 {
        let tri: [Vec3; 3] = std::array::from_fn(|_| {
            Vec3::new(
                uniform(&mut rng, -2.0, 2.0) as f32,
                uniform(&mut rng, -1.5, 1.5) as f32,
                uniform(&mut rng, -2.0, 2.0) as f32,
            )
        });
        let [a, b, c] = tri.map(|v| v.as_dvec3());
        let nrm = (b - a).cross(c - a);
        Rasterizer::new(&f, RasterMode::Standard).unwrap().triangle(
            &tri,
            TexelRect::full(n, n),
            |fr| {
                let r = f.texel_ray(fr.x as f32 + 0.5, fr.y as f32 + 0.5).as_dvec3();
                // eye + r t on the plane: n.(eye + r t - a) = 0, t = linear depth.
                let t = nrm.dot(a - f.eye.as_dvec3()) / nrm.dot(r);
                let err = (fr.depth as f64 - t).abs() / t;
                assert!(
                    err < 1e-5,
                    "depth {} vs analytic {t} (rel {err:e})",
                    fr.depth
                );
                tested += 1;
            },
        );
    }
    assert!(tested > 1000, "{tested}");
}

#[test]
fn near_clipping_keeps_the_visible_part_of_a_triangle() {
    let n = 64;
    let f = LightFrustum::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 90.0, 1.0, 0.5, 100.0, n, n).unwrap();
    // A horizontal triangle y = -0.3 with one vertex behind the eye (z = +2); the near plane at
    // 0.5 hides its part nearer than that.
    let tri = [
        Vec3::new(-1.5, -0.3, -3.0),
        Vec3::new(1.5, -0.3, -3.0),
        Vec3::new(0.0, -0.3, 2.0),
    ];
    let [a, b, c] = tri.map(|v| v.as_dvec3());
    let (counts, depth) = draw(&f, RasterMode::Standard, &[tri]);
    let (mut drawn, mut near_part, mut clipped) = (0, 0, 0);
    for y in 0..n {
        for x in 0..n {
            let r = f.texel_ray(x as f32 + 0.5, y as f32 + 0.5).as_dvec3();
            let k = y * n + x;
            if r.y >= 0.0 {
                assert_eq!(counts[k], 0);
                continue;
            }
            let t = -0.3 / r.y;
            let p = r * t;
            // Barycentrics of p in the xz-plane.
            let area = (b - a).cross(c - a).y;
            let w0 = (b - p).cross(c - p).y / area;
            let w1 = (c - p).cross(a - p).y / area;
            let w2 = 1.0 - w0 - w1;
            let margin = w0.min(w1).min(w2);
            let expect = margin > 0.0 && t >= 0.5;
            let clear = margin.abs() > 1e-3 && (t - 0.5).abs() > 1e-3;
            if clear {
                assert_eq!(
                    counts[k] == 1,
                    expect,
                    "texel {x},{y}: t={t} margin={margin}"
                );
                clipped += usize::from(margin > 0.0 && t < 0.5);
            }
            if counts[k] == 1 {
                drawn += 1;
                near_part += usize::from(t < 0.7);
                assert!((depth[k] as f64 - t).abs() <= 1e-5 * t);
            }
        }
    }
    assert!(
        drawn > 200 && near_part > 10 && clipped > 10,
        "drawn {drawn}, near {near_part}, clipped {clipped}"
    );
    // Entirely behind the near plane: nothing.
    let behind = [
        Vec3::new(-1.0, -0.3, -0.4),
        Vec3::new(1.0, -0.3, -0.4),
        Vec3::new(0.0, -0.3, 3.0),
    ];
    assert!(draw(&f, RasterMode::Standard, &[behind])
        .0
        .iter()
        .all(|&c| c == 0));
}

// ---------------------------------------------------------------- conservative rasterization

#[test]
fn conservative_coverage_contains_standard_and_every_overlapped_texel() {
    let n = 48;
    let f = LightFrustum::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 60.0, 1.0, 0.1, 100.0, n, n).unwrap();
    let mut rng = Rng::new(11);
    for trial in 0..300 {
        // Large, small (sub-texel) and sliver triangles.
        let size = [40.0, 3.0, 0.4][trial % 3];
        let c = DVec2::new(
            uniform(&mut rng, -5.0, n as f64 + 5.0),
            uniform(&mut rng, -5.0, n as f64 + 5.0),
        );
        let mut pts: [DVec2; 3] = std::array::from_fn(|_| {
            c + DVec2::new(
                uniform(&mut rng, -size, size),
                uniform(&mut rng, -size, size),
            )
        });
        if trial % 7 == 0 {
            pts[2] = pts[0] + (pts[1] - pts[0]) * 0.5 + DVec2::new(1e-3, -2e-3);
            // sliver
        }
        let tri = pts.map(|p| at(&f, p.x, p.y, uniform(&mut rng, 1.0, 5.0) as f32));
        let exact = tri.map(|v| project64(&f, v).truncate());
        let (std_counts, std_depth) = draw(&f, RasterMode::Standard, &[tri]);
        let (con_counts, con_depth) = draw(&f, RasterMode::Conservative, &[tri]);
        let (zmin, zmax) = tri.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), v| {
            (lo.min(-v.z), hi.max(-v.z))
        });
        for y in 0..n {
            for x in 0..n {
                let k = y * n + x;
                assert!(con_counts[k] <= 1, "a triangle draws a texel once");
                if std_counts[k] == 1 {
                    assert_eq!(
                        con_counts[k], 1,
                        "trial {trial}: standard texel {x},{y} missing from conservative"
                    );
                    assert!(
                        con_depth[k] <= std_depth[k] * (1.0 + 1e-6),
                        "conservative depth must not exceed the center depth"
                    );
                }
                if overlap_area(exact, x as f64, y as f64) > 1e-9 {
                    assert_eq!(
                        con_counts[k], 1,
                        "trial {trial}: overlapped texel {x},{y} missing ({exact:?})"
                    );
                }
                if con_counts[k] == 1 {
                    let d = con_depth[k];
                    assert!(
                        d >= zmin * (1.0 - 1e-5) && d <= zmax * (1.0 + 1e-5),
                        "depth {d} outside [{zmin}, {zmax}]"
                    );
                }
            }
        }
    }
}

#[test]
fn conservative_depth_is_the_minimum_over_the_texel() {
    // A steep plane: the conservative depth of a texel fully inside the triangle is the depth at
    // its nearest corner, below the center depth.
    let n = 32;
    let f = frustum(n);
    let tri = [
        at(&f, -50.0, -50.0, 2.0),
        at(&f, 100.0, -50.0, 2.0),
        at(&f, -50.0, 100.0, 8.0),
    ];
    let [a, b, c] = tri.map(|v| v.as_dvec3());
    let nrm = (b - a).cross(c - a);
    let depth_at = |sx: f64, sy: f64| {
        let r = f.texel_ray(sx as f32, sy as f32).as_dvec3();
        nrm.dot(a) / nrm.dot(r)
    };
    let (_, con) = draw(&f, RasterMode::Conservative, &[tri]);
    for (x, y) in [(3usize, 4usize), (20, 10), (10, 25)] {
        let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)];
        let min = corners
            .iter()
            .map(|(dx, dy)| depth_at(x as f64 + dx, y as f64 + dy))
            .fold(f64::INFINITY, f64::min);
        let got = con[y * n + x] as f64;
        assert!(
            (got - min).abs() <= 1e-5 * min,
            "texel {x},{y}: {got} vs {min}"
        );
        assert!(got < depth_at(x as f64 + 0.5, y as f64 + 0.5));
    }
}

// ---------------------------------------------------------------- scenes: alpha test, faces, bands

fn checker_quad(f: &LightFrustum, depth: f32, cells: usize) -> Mesh {
    let corners = [
        (-8.0, -8.0),
        (f.width as f64 + 8.0, -8.0),
        (f.width as f64 + 8.0, f.height as f64 + 8.0),
        (-8.0, f.height as f64 + 8.0),
    ];
    let pos: Vec<Vec3> = corners.iter().map(|&(x, y)| at(f, x, y, depth)).collect();
    let uvs = vec![
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(0.0, 1.0),
    ];
    let alpha: Vec<f32> = (0..cells * cells)
        .map(|i| ((i % cells + i / cells) % 2) as f32)
        .collect();
    let tex = AlphaTexture::new(cells, cells, &alpha).unwrap();
    Mesh::new(pos, vec![[0, 1, 2], [0, 2, 3]], Some(uvs), Some(tex), false).unwrap()
}

#[test]
fn alpha_test_drops_transparent_texels() {
    let n = 64;
    let f = frustum(n);
    let cells = 5;
    let scene = Scene::new(vec![checker_quad(&f, 4.0, cells)]).unwrap();
    let map = rasterize_depth(&scene, &f, &RasterOptions::default()).unwrap();
    let (w0, span) = (-8.0, n as f64 + 16.0);
    let mut checked = 0;
    for y in 0..n {
        for x in 0..n {
            // The quad is parallel to the image plane: uv is affine in texel coordinates.
            let u = (x as f64 + 0.5 - w0) / span;
            let v = (y as f64 + 0.5 - w0) / span;
            let (cu, cv) = (u * cells as f64, v * cells as f64);
            if (cu - cu.round()).abs() < 0.02 || (cv - cv.round()).abs() < 0.02 {
                continue;
            }
            let opaque = (cu.floor() as usize + cv.floor() as usize) % 2 == 1;
            assert_eq!(
                map.depth[y * n + x].is_finite(),
                opaque,
                "texel {x},{y} uv {u},{v}"
            );
            checked += 1;
        }
    }
    assert!(checked > n * n / 2);
    let plain = rasterize_depth(
        &scene,
        &f,
        &RasterOptions {
            alpha_test: false,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(plain.drawn_texels(), n * n);
    assert!(map.drawn_texels() > n * n / 3 && map.drawn_texels() < 2 * n * n / 3);
}

#[test]
fn face_filter_and_parallel_bands_match_a_serial_draw() {
    // Two facing quads (a closed box would do too): front faces at depth 3, back faces at depth 6.
    let n = 200;
    let f = frustum(n);
    let quad = |z: f32, flip: bool| {
        let c = [
            (-5.0, -5.0),
            (n as f64 + 5.0, -5.0),
            (n as f64 + 5.0, n as f64 + 5.0),
            (-5.0, n as f64 + 5.0),
        ];
        let pos: Vec<Vec3> = c.iter().map(|&(x, y)| at(&f, x, y, z)).collect();
        let faces = if flip {
            vec![[0, 2, 1], [0, 3, 2]]
        } else {
            vec![[0, 1, 2], [0, 2, 3]]
        };
        Mesh::new(pos, faces, None, None, true).unwrap()
    };
    // Screen order (0,0),(w,0),(w,h) is clockwise on screen with y down... decide by the filter.
    let scene = Scene::new(vec![quad(3.0, false), quad(6.0, true)]).unwrap();
    let all = rasterize_depth(&scene, &f, &RasterOptions::default()).unwrap();
    let front = rasterize_depth(
        &scene,
        &f,
        &RasterOptions {
            faces: FaceFilter::FrontFacing,
            ..Default::default()
        },
    )
    .unwrap();
    let back = rasterize_depth(
        &scene,
        &f,
        &RasterOptions {
            faces: FaceFilter::BackFacing,
            ..Default::default()
        },
    )
    .unwrap();
    let closed = rasterize_depth(
        &scene,
        &f,
        &RasterOptions {
            faces: FaceFilter::BackFacingIfClosed,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(back, closed);
    let d = |m: &softshadows_core::raster::depth::DepthMap| m.depth[n * n / 2 + n / 2];
    assert!((d(&all) - 3.0).abs() < 1e-5);
    let (df, db) = (d(&front), d(&back));
    assert!(
        ((df - 3.0).abs() < 1e-5 && (db - 6.0).abs() < 1e-5)
            || ((df - 6.0).abs() < 1e-5 && (db - 3.0).abs() < 1e-5)
    );
    assert_eq!(all.drawn_texels(), n * n);
    assert_eq!(all.fragments, 2 * (n * n) as u64);

    // A random triangle soup: the banded parallel map equals a serial visitor draw, in both modes.
    let mut rng = Rng::new(5);
    let mut pos = Vec::new();
    for _ in 0..600 {
        let c = Vec3::new(
            uniform(&mut rng, -3.0, 3.0) as f32,
            uniform(&mut rng, -3.0, 3.0) as f32,
            -uniform(&mut rng, 2.0, 9.0) as f32,
        );
        for _ in 0..3 {
            pos.push(
                c + Vec3::new(
                    uniform(&mut rng, -1.0, 1.0) as f32,
                    uniform(&mut rng, -1.0, 1.0) as f32,
                    uniform(&mut rng, -1.0, 1.0) as f32,
                ),
            );
        }
    }
    let tris: Vec<[Vec3; 3]> = pos.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
    let faces = (0..tris.len() as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    let soup = Scene::new(vec![
        Mesh::new(pos.clone(), faces, None, None, false).unwrap()
    ])
    .unwrap();
    for mode in [RasterMode::Standard, RasterMode::Conservative] {
        let map = rasterize_depth(
            &soup,
            &f,
            &RasterOptions {
                mode,
                ..Default::default()
            },
        )
        .unwrap();
        let (counts, serial) = draw(&f, mode, &tris);
        assert_eq!(map.depth, serial, "{mode:?}");
        assert_eq!(map.fragments, counts.iter().map(|&c| c as u64).sum::<u64>());
    }
}

// ---------------------------------------------------------------- pyramids

#[test]
fn min_max_pyramid_matches_brute_force() {
    let (w, h) = (37, 53);
    let mut rng = Rng::new(9);
    let depth: Vec<f32> = (0..w * h)
        .map(|_| {
            if rng.next_f32() < 0.3 {
                f32::INFINITY
            } else {
                1.0 + 9.0 * rng.next_f32()
            }
        })
        .collect();
    let pyr = MinMaxPyramid::new(w, h, &depth).unwrap();
    assert_eq!(pyr.num_levels(), 7); // 53 -> 27 -> 14 -> 7 -> 4 -> 2 -> 1
    let brute = |x0: usize, y0: usize, x1: usize, y1: usize| {
        let mut v: Vec<f32> = Vec::new();
        for y in y0..y1.min(h) {
            for x in x0..x1.min(w) {
                if depth[y * w + x].is_finite() {
                    v.push(depth[y * w + x]);
                }
            }
        }
        (!v.is_empty()).then(|| {
            (
                v.iter().cloned().fold(f32::INFINITY, f32::min),
                v.iter().cloned().fold(0.0, f32::max),
            )
        })
    };
    for level in 0..pyr.num_levels() {
        let l = &pyr.levels[level];
        for _ in 0..200 {
            let x0 = rng.below(l.width);
            let y0 = rng.below(l.height);
            let x1 = x0 + 1 + rng.below(l.width - x0 + 1);
            let y1 = y0 + 1 + rng.below(l.height - y0 + 1);
            let s = 1usize << level;
            assert_eq!(
                pyr.query(level, x0, y0, x1, y1),
                brute(x0 * s, y0 * s, x1 * s, y1 * s),
                "level {level}"
            );
        }
    }
    for _ in 0..500 {
        let (x0, y0) = (rng.below(w), rng.below(h));
        let (x1, y1) = (x0 + 1 + rng.below(w - x0), y0 + 1 + rng.below(h - y0));
        let exact = brute(x0, y0, x1, y1);
        match (pyr.query_region(x0, y0, x1, y1), exact) {
            (Some((lo, hi)), Some((elo, ehi))) => assert!(lo <= elo && hi >= ehi),
            (_, None) => {}
            (None, Some(e)) => panic!("region {x0},{y0}..{x1},{y1} holds {e:?} but reads empty"),
        }
    }
    let empty = vec![f32::INFINITY; 16];
    assert_eq!(
        MinMaxPyramid::new(4, 4, &empty)
            .unwrap()
            .query(0, 0, 0, 4, 4),
        None
    );
    assert!(MinMaxPyramid::new(4, 4, &[f32::NAN; 16]).is_err());
}

#[test]
fn multi_scale_map_queries_are_exact() {
    let (w, h) = (45, 38);
    let mut rng = Rng::new(4);
    let depth: Vec<f32> = (0..w * h)
        .map(|_| {
            if rng.next_f32() < 0.2 {
                f32::INFINITY
            } else {
                1.0 + 9.0 * rng.next_f32()
            }
        })
        .collect();
    let mssm = MultiScaleMap::new(w, h, &depth).unwrap();
    assert_eq!(mssm.scales.len(), 7); // squares of 1 to 64 texels
    for _ in 0..2000 {
        let (x0, y0) = (rng.below(w), rng.below(h));
        let (x1, y1) = (x0 + 1 + rng.below(w - x0), y0 + 1 + rng.below(h - y0));
        let inside: Vec<f32> = (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .map(|(x, y)| depth[y * w + x])
            .filter(|d| d.is_finite())
            .collect();
        let exact = (!inside.is_empty()).then(|| {
            (
                inside.iter().cloned().fold(f32::INFINITY, f32::min),
                inside.iter().cloned().fold(0.0, f32::max),
            )
        });
        assert_eq!(mssm.query(x0, y0, x1, y1), exact, "{x0},{y0}..{x1},{y1}");
    }
    assert_eq!(mssm.memory_bytes(), 7 * w * h * 8);
}

#[test]
fn summed_area_table_is_exact_for_large_boxes() {
    let n = 2048;
    let mut rng = Rng::new(1);
    let img: Vec<f32> = (0..n * n).map(|_| rng.next_f32()).collect();
    let sat = SummedAreaTable::new(n, n, 1, &img).unwrap();
    for _ in 0..12 {
        let (bw, bh) = (512 + rng.below(1500), 512 + rng.below(1500));
        let (x0, y0) = (rng.below(n - bw + 1), rng.below(n - bh + 1));
        let mut exact = 0.0f64;
        for y in y0..y0 + bh {
            exact += img[y * n + x0..y * n + x0 + bw]
                .iter()
                .map(|&v| v as f64)
                .sum::<f64>();
        }
        let got = sat.box_sum(0, x0 as f64, y0 as f64, (x0 + bw) as f64, (y0 + bh) as f64);
        assert!(
            (got - exact).abs() <= 1e-9 * exact,
            "{bw}x{bh}: {got} vs {exact}"
        );
        let mean = sat.box_mean(0, x0 as f64, y0 as f64, (x0 + bw) as f64, (y0 + bh) as f64);
        assert!((mean - exact / (bw * bh) as f64).abs() < 1e-12);
    }
    // Clamping: a box reaching past the image sums the part inside, and means over that part.
    let whole: f64 = img.iter().map(|&v| v as f64).sum();
    assert!((sat.box_sum(0, -100.0, -5.0, 1e6, 3000.0) - whole).abs() <= 1e-9 * whole);
    assert!((sat.box_mean(0, -100.0, -5.0, 1e6, 3000.0) - whole / (n * n) as f64).abs() < 1e-12);
}

#[test]
fn summed_area_table_fractional_boxes_and_channels() {
    let (w, h) = (13, 9);
    let mut rng = Rng::new(4);
    let a: Vec<f32> = (0..w * h).map(|_| rng.next_f32()).collect();
    let b: Vec<f32> = (0..w * h).map(|_| 2.0 * rng.next_f32() - 1.0).collect();
    let sat = SummedAreaTable::from_channels(w, h, &[&a, &b]).unwrap();
    assert_eq!(sat.channels(), 2);
    let brute = |img: &[f32], x0: f64, y0: f64, x1: f64, y1: f64| {
        let mut s = 0.0;
        for y in 0..h {
            for x in 0..w {
                let ox = (x1.min(x as f64 + 1.0) - x0.max(x as f64)).max(0.0);
                let oy = (y1.min(y as f64 + 1.0) - y0.max(y as f64)).max(0.0);
                s += img[y * w + x] as f64 * ox * oy;
            }
        }
        s
    };
    let mut out = [0.0f64; 2];
    for _ in 0..300 {
        let x0 = uniform(&mut rng, -2.0, w as f64);
        let y0 = uniform(&mut rng, -2.0, h as f64);
        let (x1, y1) = (
            x0 + uniform(&mut rng, 0.0, 8.0),
            y0 + uniform(&mut rng, 0.0, 6.0),
        );
        sat.box_sum_into(x0, y0, x1, y1, &mut out);
        assert!((out[0] - brute(&a, x0, y0, x1, y1)).abs() < 1e-9);
        assert!((out[1] - brute(&b, x0, y0, x1, y1)).abs() < 1e-9);
        assert_eq!(out[1], sat.box_sum(1, x0, y0, x1, y1));
    }
    // A zero-area box reads the nearest texel.
    assert!((sat.box_mean(1, 4.5, 2.5, 4.5, 2.5) - b[2 * w + 4] as f64).abs() < 1e-12);
    assert!(SummedAreaTable::new(2, 2, 1, &[0.0, 1.0, f32::NAN, 0.0]).is_err());
}

#[test]
fn mipmap_trilinear_equals_bilinear_at_integer_levels() {
    let (w, h) = (100, 77);
    let mut rng = Rng::new(8);
    let img: Vec<f32> = (0..w * h * 2).map(|_| rng.next_f32()).collect();
    let mip = MipMap::new(w, h, 2, &img).unwrap();
    assert_eq!(mip.num_levels(), 8); // 100 -> 50 -> 25 -> 13 -> 7 -> 4 -> 2 -> 1
                                     // Level 1 is the 2x2 box mean.
    let l1 = mip.level(1).unwrap();
    let mean = (img[0] + img[2] + img[2 * w] + img[2 * (w + 1)]) / 4.0;
    assert!((l1.data[0] - mean).abs() < 1e-6);
    let (mut a, mut b) = ([0.0f32; 2], [0.0f32; 2]);
    for _ in 0..200 {
        let (x, y) = (
            uniform(&mut rng, -3.0, w as f64 + 3.0),
            uniform(&mut rng, -3.0, h as f64 + 3.0),
        );
        for level in 0..mip.num_levels() {
            mip.trilinear_into(x, y, (1u64 << level) as f64, &mut a);
            mip.bilinear_into(level, x, y, &mut b);
            assert_eq!(a, b, "level {level} at {x},{y}");
        }
        // Between levels: between the two bilinear values.
        let (lo, hi) = (mip.bilinear(2, x, y), mip.bilinear(3, x, y));
        let t = mip.trilinear(x, y, 5.6);
        assert!(t >= lo.min(hi) - 1e-6 && t <= lo.max(hi) + 1e-6);
    }
    // Bilinear at a texel center returns the texel.
    assert_eq!(mip.bilinear(0, 10.5, 20.5), img[(20 * w + 10) * 2]);
}

// ---------------------------------------------------------------- shadow_map

#[test]
fn shadow_map_matches_the_analytic_hard_shadow() {
    // Ground |x|, |z| <= 1 at y = 0; a square occluder |x|, |z| <= 0.25 at y = 0.5; a point light.
    let ground = Mesh::new(
        vec![
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(-1.0, 0.0, 1.0),
        ],
        vec![[0, 2, 1], [0, 3, 2]],
        None,
        None,
        false,
    )
    .unwrap();
    let s = 0.25;
    let occluder = Mesh::new(
        vec![
            Vec3::new(-s, 0.5, -s),
            Vec3::new(s, 0.5, -s),
            Vec3::new(s, 0.5, s),
            Vec3::new(-s, 0.5, s),
        ],
        vec![[0, 2, 1], [0, 3, 2]],
        None,
        None,
        false,
    )
    .unwrap();
    let scene = Scene::new(vec![ground, occluder]).unwrap();
    let light_pos = Vec3::new(0.1, 2.0, 0.05);
    let light = Light::point(light_pos).unwrap();
    let k = 200;
    let points: Vec<Vec3> = (0..k * k)
        .map(|i| {
            Vec3::new(
                -0.995 + 1.99 * (i % k) as f32 / (k - 1) as f32,
                0.0,
                -0.995 + 1.99 * (i / k) as f32 / (k - 1) as f32,
            )
        })
        .collect();
    let rx = Receivers::new(
        points.clone(),
        vec![Vec3::Y; k * k],
        vec![true; k * k],
        k,
        k,
    )
    .unwrap();
    for (resolution, pcf) in [(256usize, 1usize), (512, 1), (256, 3)] {
        let opts = ShadowMapOptions {
            resolution,
            pcf,
            ..Default::default()
        };
        let (vis, stats) = shadow_map(&scene, &light, &rx, &opts).unwrap();
        let f = LightFrustum::fit(
            light_pos,
            Vec3::new(-0.995, 0.0, -0.995),
            Vec3::new(0.995, 0.0, 0.995),
            resolution,
        )
        .unwrap();
        // Texel size on the occluder plane (depth of the occluder about 1.5).
        let texel = f.texel_world_size(1.5) as f64;
        let (mut mismatches, mut far_mismatches, mut shadowed) = (0, 0, 0);
        for (p, v) in points.iter().zip(&vis) {
            let (p, l) = (p.as_dvec3(), light_pos.as_dvec3());
            let q = p + (l - p) * (0.5 / l.y); // where the ray crosses y = 0.5
            let inside = q.x.abs() < s as f64 && q.z.abs() < s as f64;
            let edge_dist = (q.x.abs() - s as f64)
                .abs()
                .min((q.z.abs() - s as f64).abs());
            let expect = if inside { 0.0 } else { 1.0 };
            shadowed += usize::from(inside);
            if (*v - expect).abs() > 1e-6 {
                mismatches += 1;
                if edge_dist > (2.0 + (pcf / 2) as f64) * texel {
                    far_mismatches += 1;
                }
            }
        }
        assert_eq!(
            far_mismatches, 0,
            "res {resolution} pcf {pcf}: mismatches away from the shadow edge"
        );
        assert!(shadowed > 1000);
        // The shadow outline is about 4 * 0.5 * (4/3) world units long; receivers are 0.01 apart.
        let band =
            4.0 * 0.667 / 0.01 * (2.0 * (2.0 + (pcf / 2) as f64) * texel * 1.33 / 0.01 + 1.0);
        eprintln!("shadow_map res {resolution} pcf {pcf}: {mismatches} mismatches of {} receivers, bound {band:.0}", k * k);
        assert!(
            (mismatches as f64) < band,
            "res {resolution} pcf {pcf}: {mismatches} mismatches (bound {band})"
        );
        assert_eq!(stats.get("resolution"), Some(resolution as f64));
        assert!(stats.get("texels_drawn").unwrap() > 0.0);
        assert!(stats.get("render_seconds").is_some() && stats.get("lookup_seconds").is_some());
    }
    // Receivers facing away get 0; invalid ones get 0.
    let rx = Receivers::new(
        vec![Vec3::new(0.9, 0.0, 0.9); 2],
        vec![-Vec3::Y, Vec3::Y],
        vec![true, false],
        2,
        1,
    )
    .unwrap();
    let (vis, _) = shadow_map(&scene, &light, &rx, &ShadowMapOptions::default()).unwrap();
    assert_eq!(vis, vec![0.0, 0.0]);
    // Bad options are refused.
    for opts in [
        ShadowMapOptions {
            pcf: 2,
            ..Default::default()
        },
        ShadowMapOptions {
            resolution: 0,
            ..Default::default()
        },
        ShadowMapOptions {
            bias: Some(-1.0),
            ..Default::default()
        },
    ] {
        assert!(matches!(
            shadow_map(&scene, &light, &rx, &opts),
            Err(Error::InvalidInput { .. })
        ));
    }
    // A light inside the receivers' bounds gets a map per cube face, one for each receiver here.
    let inside = Light::point(Vec3::new(0.0, 0.0, 0.0)).unwrap();
    let (pts, nrm) = (
        vec![Vec3::new(-1.0, -1.2, -1.1), Vec3::new(1.0, 1.2, 1.1)],
        vec![Vec3::Y, -Vec3::Y],
    );
    let rx = Receivers::new(pts, nrm, vec![true; 2], 2, 1).unwrap();
    let (vis, stats) = shadow_map(&scene, &inside, &rx, &ShadowMapOptions::default()).unwrap();
    assert_eq!(stats.get("light_faces"), Some(2.0));
    assert_eq!(vis.len(), 2);
}

#[test]
fn shadow_map_agrees_with_the_ray_traced_point_light_on_a_gbuffer() {
    // Ground, a sphere (curved self-shadowing receiver) and a perforated checker fence, seen by a
    // camera; a point light. Mismatches are confined to shadow outlines: a small fraction.
    let ground = Mesh::new(
        vec![
            Vec3::new(-4.0, 0.0, -4.0),
            Vec3::new(4.0, 0.0, -4.0),
            Vec3::new(4.0, 0.0, 4.0),
            Vec3::new(-4.0, 0.0, 4.0),
        ],
        vec![[0, 2, 1], [0, 3, 2]],
        None,
        None,
        false,
    )
    .unwrap();
    let cells = 6;
    let alpha: Vec<f32> = (0..cells * cells)
        .map(|i| ((i % cells + i / cells) % 2) as f32)
        .collect();
    let fence = Mesh::new(
        vec![
            Vec3::new(0.5, 0.3, -1.5),
            Vec3::new(2.5, 0.3, -1.5),
            Vec3::new(2.5, 1.6, -1.5),
            Vec3::new(0.5, 1.6, -1.5),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
        Some(vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ]),
        Some(AlphaTexture::new(cells, cells, &alpha).unwrap()),
        false,
    )
    .unwrap();
    let scene = Scene::new(vec![
        ground,
        uv_sphere(Vec3::new(-0.8, 1.0, 0.3), 0.9, 96, 48, true),
        fence,
    ])
    .unwrap();
    let light_pos = Vec3::new(2.5, 3.0, 2.0);
    let light = Light::point(light_pos).unwrap();
    let camera = Camera::look_at(
        Vec3::new(0.0, 4.0, 7.0),
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::Y,
        50.0,
        160,
        120,
    )
    .unwrap();
    let bvh = Bvh::build(&scene).unwrap();
    let rx = gbuffer(&scene, &bvh, &camera, 1)
        .unwrap()
        .receivers()
        .unwrap();
    let samples = SampleSet::explicit(vec![light_pos], None).unwrap();
    let (reference, _) = ray_traced(
        &scene,
        &bvh,
        &light,
        &rx,
        &samples,
        &RayTracedOptions::for_scene(&scene),
    )
    .unwrap();
    let valid = rx.valid.iter().filter(|&&v| v).count();
    let shadowed = reference
        .iter()
        .zip(&rx.valid)
        .filter(|(r, &v)| v && **r == 0.0)
        .count();
    assert!(
        shadowed > valid / 20,
        "the scene must cast shadows: {shadowed}"
    );
    for (resolution, pcf, bound) in [(2048, 1, 0.005), (512, 1, 0.02), (512, 3, 0.05)] {
        let opts = ShadowMapOptions {
            resolution,
            pcf,
            ..Default::default()
        };
        let (vis, _) = shadow_map(&scene, &light, &rx, &opts).unwrap();
        let mismatches = vis
            .iter()
            .zip(&reference)
            .filter(|(a, b)| (*a - *b).abs() > 1e-6)
            .count();
        let wrong = vis
            .iter()
            .zip(&reference)
            .filter(|(a, b)| (*a - *b).abs() > 0.5)
            .count();
        eprintln!("shadow_map res {resolution} pcf {pcf} vs ray_traced: {mismatches} mismatches ({wrong} by > 0.5) of {valid} receivers ({shadowed} in shadow)");
        assert!(
            (mismatches as f64) < bound * valid as f64,
            "res {resolution} pcf {pcf}: {mismatches} of {valid}"
        );
    }
}

#[test]
fn every_point_projects_into_its_face_clear_of_the_edges_by_the_overlap() {
    let eye = Vec3::new(0.3, -0.2, 0.1);
    let mut rng = Rng::new(7);
    let points: Vec<Vec3> = (0..4000)
        .map(|_| eye + Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0)
        .collect();
    let side = 512;
    // A point on a seam sits at tan 1 of a map of tan 1 + cube::SEAM_OVERLAP: this many texels in.
    let margin = 0.5 * side as f32 * cube::SEAM_OVERLAP / (1.0 + cube::SEAM_OVERLAP);
    for face in 0..cube::FACES.len() {
        let mine: Vec<Vec3> = points
            .iter()
            .copied()
            .filter(|&p| cube::face_of(eye, p) == face)
            .collect();
        assert!(mine.len() > 400, "face {face}");
        let frustum = cube::face_frustum(eye, face, mine.iter().copied(), side).unwrap();
        for p in mine {
            let s = frustum.project(p).expect("in front of the near plane");
            let edge = s.x.min(s.y).min(side as f32 - s.x).min(side as f32 - s.y);
            assert!(
                edge >= margin - 1e-2,
                "face {face}: {p} is {edge} texels in"
            );
            assert!(s.z <= frustum.far);
        }
    }
}

#[test]
fn a_light_clear_of_the_receivers_gets_one_frustum_and_one_among_them_six() {
    let light = Light::point(Vec3::new(0.0, 3.0, 0.0)).unwrap();
    let floor = Receivers::new(
        vec![Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0)],
        vec![Vec3::Y; 2],
        vec![true; 2],
        2,
        1,
    )
    .unwrap();
    assert!(cube::light_faces(&light, &floor).is_none());
    let around: Vec<Vec3> = cube::FACES
        .iter()
        .map(|f| light.center() + f.0 * 2.0)
        .collect();
    let room = Receivers::new(around, vec![Vec3::Y; 6], vec![true; 6], 6, 1).unwrap();
    assert_eq!(
        cube::light_faces(&light, &room),
        Some(vec![0, 1, 2, 3, 4, 5])
    );
}
