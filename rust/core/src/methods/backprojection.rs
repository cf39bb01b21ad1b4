//! `backprojection`: soft shadow mapping by backprojecting micro-occluders onto the light, with
//! budgets and smooth quality scaling (Schwarz and Stamminger 2008, seed 003; after Guennebaud,
//! Barthe and Paulin 2006).
//!
//! One depth map is rendered from the light's center. Its texels, unprojected into world space,
//! approximate the occluders; for each receiver `p` (section 3):
//!
//! 1. **Search area**: the light's footprint in the map through the nearest stored depth (its
//!    bounding points projected from `p` onto that depth's plane), refined by intersecting the pyramid from `p` to the light with the
//!    plane at the area's minimum depth `z_min` (Figure 2b), read from the min/max pyramid (the
//!    HSM). A receiver nearer than every sample of its area is fully lit; one farther than all of
//!    them (and than every empty texel, stored at the largest depth) is in umbra; neither
//!    backprojects anything.
//! 2. **Level of quality** (section 4.2): with a budget `b_mo` (per receiver, from a scalar or a
//!    budget map), the fractional shadow-map level `ℓ = log2(s / b_mo)` for an area `s` level-0
//!    texels wide keeps at most `b_mo × b_mo` micro-occluders at level `⌈ℓ⌉`. The levels form the
//!    LOQ map, smoothed by a separable box filter (11 × 11 by default) that stops at depth
//!    discontinuities and at receivers that backproject nothing; the visibilities of levels `⌊ℓ⌋`
//!    and `⌈ℓ⌉` are blended by the fraction of `ℓ`. The query region is first grown to whole
//!    level-`⌈ℓ⌉` texels (the "over-precision" fix of Figure 7).
//! 3. **Micro-occluders** of the chosen level nearer than the receiver (its tangent plane,
//!    [`ReceiverDepth`]): *micropatches* (a texel's square at its minimum depth; optionally
//!    extended to the left and bottom neighbours' squares, Guennebaud et al. 2006), *microquads*
//!    (texel centers as the vertices of a quad mesh, used when all four are nearer) or
//!    *microrects* (section 5.2, [`Microrects`]).
//! 4. **Backprojection** onto the light's plane from `p`; the occluded light is accumulated as the
//!    sum of the clipped areas (clamped to 1) or in an occlusion bitmap over jittered `k × k`
//!    light samples (Schwarz and Stamminger 2007).
//!
//! Rectangular and disk lights (the light's plane); a disk's outline is a 64-gon of equal area.
//! The light behind a receiver's tangent plane is blocked (DESIGN.md section 3): the bitmap starts
//! with those samples set, and areas and fully lit receivers are scaled by the fraction in front.

use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::light::lights::{concentric_disk, tangent_frame, Light, Shape};
use crate::light::sampling::Rng;
use crate::limits::Peak;
use crate::raster::depth::{raster_peak, rasterize_depth, LightFrustum, RasterOptions};
use crate::raster::influence::light_polytope;
use crate::raster::pcf::{DepthBias, ReceiverDepth, RASTERIZED_SLACK};
use crate::raster::pyramid::{MinMaxPyramid, MultiScaleMap};
use crate::stats::Stats;
use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;

/// The micro-occluders built from the shadow map (sections 3 and 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Occluder {
    /// A texel's square at its depth; `extend` grows it over its left and bottom neighbours.
    Micropatch { extend: bool },
    /// Texel centers as the vertices of a quad mesh.
    Microquad,
    /// Micropatches generalized to rectangles of level-0 texels (section 5.2).
    Microrect,
}

/// How the occluded parts of the light add up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Accumulation {
    /// The sum of the backprojected areas, clamped to the light's.
    Area,
    /// An occlusion bitmap over `side × side` jittered light samples.
    Bitmask { side: usize },
}

/// The acceleration structure of the search areas and of the umbra / lit classification
/// (sections 3 and 6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Acceleration {
    /// The hierarchical shadow map: a min/max pyramid (conservative ranges).
    Hsm,
    /// The multi-scale shadow map: exact ranges from every power-of-two neighbourhood.
    Mssm,
    /// The Y shadow map: the HSM's levels down to `resolution` texels per side, and an MSSM of
    /// that level (256 by default).
    Ysm { resolution: usize },
}

/// The micro-occluder budget `b_mo` (micro-occluders per light axis).
#[derive(Debug, Clone, PartialEq)]
pub enum Budget {
    /// Always level 0 (no LOQ map, no blending).
    Infinite,
    /// The same budget for every receiver.
    Uniform(f32),
    /// One budget per receiver (the budget map, receivers' order).
    Map(Vec<f32>),
}

/// Options of [`backprojection`].
#[derive(Debug, Clone, PartialEq)]
pub struct BackprojectionOptions {
    /// Shadow-map side in texels (default 1024).
    pub resolution: usize,
    pub occluder: Occluder,
    pub accumulation: Accumulation,
    pub acceleration: Acceleration,
    pub budget: Budget,
    /// A fixed shadow-map level for every receiver instead of the budget's.
    pub level: Option<usize>,
    /// Blend the visibilities of levels `⌊ℓ⌋` and `⌈ℓ⌉` (default); otherwise level `⌈ℓ⌉` only.
    pub blend: bool,
    /// Side of the LOQ map's smoothing filter (odd; 1 disables it; default 11).
    pub smoothing: usize,
    /// Constant depth bias, or `None` for the receiver's tangent plane (default).
    pub bias: Option<f32>,
}

impl Default for BackprojectionOptions {
    fn default() -> Self {
        Self {
            resolution: 1024,
            occluder: Occluder::Micropatch { extend: false },
            accumulation: Accumulation::Bitmask { side: 16 },
            acceleration: Acceleration::Hsm,
            budget: Budget::Infinite,
            level: None,
            blend: true,
            smoothing: 11,
            bias: None,
        }
    }
}

impl BackprojectionOptions {
    fn validate(&self, receivers: usize) -> Result<()> {
        if !(1..=crate::raster::depth::MAX_RESOLUTION).contains(&self.resolution) {
            return Err(Error::invalid("resolution", format!("must be in 1..=65536, got {}", self.resolution)));
        }
        if let Accumulation::Bitmask { side } = self.accumulation {
            if !(1..=64).contains(&side) {
                return Err(Error::invalid("bitmask_side", format!("must be in 1..=64, got {side}")));
            }
        }
        let positive = |b: f32| b.is_finite() && b >= 1.0;
        match &self.budget {
            Budget::Uniform(b) if !positive(*b) => return Err(Error::invalid("budget", format!("must be >= 1, got {b}"))),
            Budget::Map(m) if m.len() != receivers => {
                return Err(Error::invalid("budget", format!("the budget map has {} values for {receivers} receivers", m.len())))
            }
            Budget::Map(m) if !m.iter().all(|&b| positive(b)) => return Err(Error::invalid("budget", "every budget must be >= 1")),
            _ => {}
        }
        if let Acceleration::Ysm { resolution } = self.acceleration {
            if resolution == 0 {
                return Err(Error::invalid("ysm_resolution", "must be >= 1"));
            }
        }
        if self.smoothing.is_multiple_of(2) || self.smoothing > 101 {
            return Err(Error::invalid("smoothing", format!("must be odd and at most 101, got {}", self.smoothing)));
        }
        Ok(())
    }
}

/// The built acceleration structure: the HSM (always: the micro-occluder levels come from it)
/// and, for the MSSM and the YSM, a multi-scale map of HSM level `base`.
struct Accel {
    hsm: MinMaxPyramid,
    multi: Option<(usize, MultiScaleMap)>,
}

impl Accel {
    fn new(kind: Acceleration, width: usize, height: usize, depth: &[f32]) -> Result<Accel> {
        let hsm = MinMaxPyramid::new(width, height, depth)?;
        let base = match kind {
            Acceleration::Hsm => return Ok(Accel { hsm, multi: None }),
            Acceleration::Mssm => 0,
            Acceleration::Ysm { resolution } => hsm.levels.iter().position(|l| l.width.max(l.height) <= resolution).unwrap_or(hsm.levels.len() - 1),
        };
        let multi = MultiScaleMap::from_level(hsm.levels[base].clone())?;
        Ok(Accel { hsm, multi: Some((base, multi)) })
    }

    /// `(min, max)` over the non-empty level-0 rectangle `[x0, x1) × [y0, y1)`: the HSM reads a
    /// superset at the level where it spans 2 × 2 texels; the MSSM gives the exact range; the
    /// YSM reads its HSM part while that level is finer than its MSSM's, then the MSSM (exact at
    /// that level's texels).
    fn range(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> Option<(f32, f32)> {
        match &self.multi {
            Some((base, multi)) if self.hsm.region_level(x0, y0, x1, y1) >= *base => {
                multi.query(x0 >> base, y0 >> base, ((x1 - 1) >> base) + 1, ((y1 - 1) >> base) + 1)
            }
            _ => self.hsm.query_region(x0, y0, x1, y1),
        }
    }

    fn memory_bytes(&self) -> usize {
        self.hsm.levels.iter().map(|l| l.min.len() * 8).sum::<usize>() + self.multi.as_ref().map_or(0, |(_, m)| m.memory_bytes())
    }
}

/// Depth stored for texels where nothing is drawn: an occluder farther than any receiver, so
/// that it never occludes and never lets an area pass for umbra.
const EMPTY: f32 = f32::MAX;

/// The micro-occluder levels built from the shadow map: per level its size, the depth of each
/// texel's micro-occluder (minimum aggregation) and, for microrects, its extent in level-0 texels.
struct Levels {
    levels: Vec<Level>,
}

struct Level {
    width: usize,
    height: usize,
    depth: Vec<f32>,
    /// `[x0, y0, x1, y1)` in level-0 texels (microrects only).
    extent: Vec<[u32; 4]>,
}

impl Levels {
    /// The min-aggregated levels of the pyramid; with `rects`, the microrects of section 5.2.
    fn new(hsm: &MinMaxPyramid, rects: bool) -> Levels {
        let mut levels: Vec<Level> =
            hsm.levels.iter().map(|l| Level { width: l.width, height: l.height, depth: l.min.clone(), extent: Vec::new() }).collect();
        if rects {
            Microrects::build(&mut levels);
        }
        Levels { levels }
    }
}

/// The greedy two-pass construction of microrects (section 5.2, Figures 5 and 6). Level `i + 1`
/// keeps the reference points of the even texels `(2X, 2Y)` of level `i`; each other level-`i`
/// microrect merges into one kept neighbour. First pass: a kept microrect `A` takes its `+x`
/// neighbour `B` when `B`'s depth is nearer to `A`'s than to the next kept one's `C`, likewise its
/// `+y` neighbour, and its diagonal neighbour when the merged extent already contains it. Second
/// pass: each kept microrect takes the neighbours in the negative directions not yet merged.
/// A merge takes the bounding rectangle of the extents and the minimum depth; extents are then
/// clipped so that no other reference point of the level lies inside.
struct Microrects;

impl Microrects {
    fn build(levels: &mut [Level]) {
        let base = &mut levels[0];
        base.extent = (0..base.height).flat_map(|y| (0..base.width).map(move |x| [x as u32, y as u32, x as u32 + 1, y as u32 + 1])).collect();
        for i in 1..levels.len() {
            let (finer, coarser) = levels.split_at_mut(i);
            Self::merge(&finer[i - 1], &mut coarser[0], i);
        }
    }

    fn merge(fine: &Level, out: &mut Level, level: usize) {
        let (w, h) = (fine.width, fine.height);
        let at = |x: usize, y: usize| y * w + x;
        let depth = |x: usize, y: usize| fine.depth[at(x, y)];
        // Whether the non-kept microrect at (x, y) merged in the first pass.
        let mut taken = vec![false; w * h];
        let mut extent = vec![[0u32; 4]; out.width * out.height];
        let mut min_depth = vec![EMPTY; out.width * out.height];
        let union = |a: [u32; 4], b: [u32; 4]| [a[0].min(b[0]), a[1].min(b[1]), a[2].max(b[2]), a[3].max(b[3])];
        let nearer_to_kept = |b: f32, kept: f32, other: Option<f32>| other.is_none_or(|c| (b - kept).abs() <= (b - c).abs());
        for oy in 0..out.height {
            for ox in 0..out.width {
                let (x, y) = (2 * ox, 2 * oy);
                let (mut e, mut d) = (fine.extent[at(x, y)], depth(x, y));
                let mut merged_x = false;
                let mut merged_y = false;
                if x + 1 < w && nearer_to_kept(depth(x + 1, y), d, (x + 2 < w).then(|| depth(x + 2, y))) {
                    (e, d) = (union(e, fine.extent[at(x + 1, y)]), d.min(depth(x + 1, y)));
                    taken[at(x + 1, y)] = true;
                    merged_x = true;
                }
                if y + 1 < h && nearer_to_kept(depth(x, y + 1), fine.depth[at(x, y)], (y + 2 < h).then(|| depth(x, y + 2))) {
                    (e, d) = (union(e, fine.extent[at(x, y + 1)]), d.min(depth(x, y + 1)));
                    taken[at(x, y + 1)] = true;
                    merged_y = true;
                }
                if merged_x && merged_y && x + 1 < w && y + 1 < h {
                    let diag = fine.extent[at(x + 1, y + 1)];
                    if union(e, diag) == e {
                        d = d.min(depth(x + 1, y + 1));
                        taken[at(x + 1, y + 1)] = true;
                    }
                }
                extent[oy * out.width + ox] = e;
                min_depth[oy * out.width + ox] = d;
            }
        }
        for oy in 0..out.height {
            for ox in 0..out.width {
                let (x, y) = (2 * ox, 2 * oy);
                let k = oy * out.width + ox;
                for (nx, ny) in [(x.wrapping_sub(1), y), (x, y.wrapping_sub(1)), (x.wrapping_sub(1), y.wrapping_sub(1))] {
                    if nx < w && ny < h && !taken[at(nx, ny)] {
                        extent[k] = union(extent[k], fine.extent[at(nx, ny)]);
                        min_depth[k] = min_depth[k].min(depth(nx, ny));
                    }
                }
                // No other reference point of the level inside: reference points sit at
                // multiples of 2^level, so the extent stays within the open neighbourhood.
                let (s, rx, ry) = (1u32 << level, (ox as u32) << level, (oy as u32) << level);
                let e = &mut extent[k];
                e[0] = e[0].max((rx + 1).saturating_sub(s));
                e[1] = e[1].max((ry + 1).saturating_sub(s));
                e[2] = e[2].min(rx + s);
                e[3] = e[3].min(ry + s);
            }
        }
        out.extent = extent;
        out.depth = min_depth;
    }
}

/// The light's plane, its outline and its sample points, in light coordinates: `[-1, 1]²` for a
/// rectangle (`center + a u + b v`), the unit disk for a disk.
struct LightPlane {
    /// World points whose hull holds the light (for the search areas).
    bounds: Vec<Vec3>,
    center: DVec3,
    normal: DVec3,
    /// Maps a point of the plane (relative to the center) to light coordinates.
    to_light: [DVec3; 2],
    outline: Vec<DVec2>,
    outline_area: f64,
    samples: Vec<DVec2>,
    /// The samples in world space.
    world: Vec<DVec3>,
}

impl LightPlane {
    fn new(light: &Light, side: usize) -> Result<LightPlane> {
        let bounds = light_polytope(light, 16).into_iter().map(|q| q.as_vec3()).collect();
        let mut rng = Rng::new(0x5EED_B4C7);
        let jittered: Vec<DVec2> = (0..side * side)
            .map(|k| DVec2::new(((k % side) as f64 + f64::from(rng.next_f32())) / side as f64, ((k / side) as f64 + f64::from(rng.next_f32())) / side as f64))
            .collect();
        match light.shape {
            Shape::Rect { center, u, v } => {
                let (u, v) = (u.as_dvec3(), v.as_dvec3());
                // Rows of the inverse Gram matrix applied to (u, v): a = r·ua, b = r·vb.
                let (uu, uv, vv) = (u.dot(u), u.dot(v), v.dot(v));
                let det = uu * vv - uv * uv;
                let to_light = [(u * vv - v * uv) / det, (v * uu - u * uv) / det];
                let outline = vec![DVec2::new(-1.0, -1.0), DVec2::new(1.0, -1.0), DVec2::new(1.0, 1.0), DVec2::new(-1.0, 1.0)];
                let samples: Vec<DVec2> = jittered.iter().map(|s| *s * 2.0 - 1.0).collect();
                let world = samples.iter().map(|s| center.as_dvec3() + u * s.x + v * s.y).collect();
                Ok(LightPlane { bounds, center: center.as_dvec3(), normal: u.cross(v).normalize(), to_light, outline, outline_area: 4.0, samples, world })
            }
            Shape::Disk { center, normal, radius } => {
                let (t, b) = tangent_frame(normal);
                let r = f64::from(radius);
                let k = 64;
                let scale = (2.0 * std::f64::consts::PI / (k as f64 * (2.0 * std::f64::consts::PI / k as f64).sin())).sqrt();
                let outline = (0..k).map(|i| DVec2::from_angle(2.0 * std::f64::consts::PI * i as f64 / k as f64) * scale).collect();
                let samples: Vec<DVec2> = jittered.iter().map(|s| concentric_disk(s.x as f32, s.y as f32).as_dvec2()).collect();
                let world = samples.iter().map(|s| center.as_dvec3() + (t.as_dvec3() * s.x + b.as_dvec3() * s.y) * r).collect();
                Ok(LightPlane {
                    bounds,
                    center: center.as_dvec3(),
                    normal: normal.as_dvec3(),
                    to_light: [t.as_dvec3() / r, b.as_dvec3() / r],
                    outline,
                    outline_area: std::f64::consts::PI,
                    samples,
                    world,
                })
            }
            _ => Err(Error::invalid("light", "backprojection needs a planar area light (RectLight or DiskLight)")),
        }
    }

    /// Light coordinates of the projection of `x` from `p` onto the light's plane; `None` unless
    /// `x` lies strictly between `p` and the plane.
    fn project(&self, p: DVec3, x: DVec3) -> Option<DVec2> {
        let (dp, dx) = (self.normal.dot(p - self.center), self.normal.dot(x - self.center));
        if dp == 0.0 || dp * dx < 0.0 || dx.abs() >= dp.abs() {
            return None;
        }
        let y = p + (x - p) * (dp / (dp - dx)) - self.center;
        Some(DVec2::new(self.to_light[0].dot(y), self.to_light[1].dot(y)))
    }

    /// The samples behind the tangent plane of receiver `(p, n)` as set bits (they are blocked,
    /// DESIGN.md section 3), and the fraction in front.
    fn behind(&self, p: DVec3, n: DVec3) -> (Vec<u64>, f64) {
        let mut bits = vec![0u64; self.samples.len().div_ceil(64)];
        let mut front = 0usize;
        for (k, y) in self.world.iter().enumerate() {
            if (*y - p).dot(n) > 0.0 {
                front += 1;
            } else {
                bits[k / 64] |= 1 << (k % 64);
            }
        }
        (bits, front as f64 / self.world.len() as f64)
    }

    /// The fraction of the light covered by the convex polygon `poly` (light coordinates).
    fn covered_fraction(&self, poly: &[DVec2]) -> f64 {
        let mut clipped = poly.to_vec();
        let n = self.outline.len();
        for i in 0..n {
            let (a, b) = (self.outline[i], self.outline[(i + 1) % n]);
            clipped = clip_half_plane(&clipped, a, b);
            if clipped.is_empty() {
                return 0.0;
            }
        }
        polygon_area(&clipped).abs() / self.outline_area
    }
}

/// Sutherland–Hodgman: the part of `poly` to the left of the directed line `a → b`.
fn clip_half_plane(poly: &[DVec2], a: DVec2, b: DVec2) -> Vec<DVec2> {
    let side = |p: DVec2| (b - a).perp_dot(p - a);
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let (sp, sq) = (side(p), side(q));
        if sp >= 0.0 {
            out.push(p);
        }
        if (sp >= 0.0) != (sq >= 0.0) {
            out.push(p + (q - p) * (sp / (sp - sq)));
        }
    }
    out
}

fn polygon_area(poly: &[DVec2]) -> f64 {
    0.5 * (0..poly.len()).map(|i| poly[i].perp_dot(poly[(i + 1) % poly.len()])).sum::<f64>()
}

/// Whether `s` lies inside the convex quadrilateral `q` (either winding).
fn in_quad(q: &[DVec2; 4], s: DVec2) -> bool {
    let sides = [0, 1, 2, 3].map(|i| (q[(i + 1) % 4] - q[i]).perp_dot(s - q[i]));
    sides.iter().all(|&v| v >= 0.0) || sides.iter().all(|&v| v <= 0.0)
}

/// Everything the per-receiver passes read.
struct Context<'a> {
    frustum: LightFrustum,
    accel: &'a Accel,
    levels: &'a Levels,
    light: &'a LightPlane,
    opts: &'a BackprojectionOptions,
    bias: DepthBias,
    /// The nearest stored depth.
    near: f32,
}

/// What the search of step 1 found for one receiver.
#[derive(Debug, Clone, Copy)]
enum Search {
    /// Facing away from the light's center or outside the map: the visibility, no backprojection.
    Fixed(f32),
    Lit,
    Umbra,
    /// The refined search area `[x0, x1) × [y0, y1)` in level-0 texels.
    Area { x0: usize, y0: usize, x1: usize, y1: usize },
}

impl Context<'_> {
    /// The receiver's projection and tangent-plane depth; `None` outside the map.
    fn receiver(&self, p: Vec3, n: Vec3) -> Option<ReceiverDepth> {
        let s = self.frustum.project(p)?;
        let inside = s.x >= 0.0 && s.y >= 0.0 && s.x < self.frustum.width as f32 && s.y < self.frustum.height as f32;
        inside.then(|| ReceiverDepth::new(&self.frustum, p, n, s, self.bias))
    }

    /// The search area of receiver `p` (`rd`) through linear depth `z` (step 1): the bounding box,
    /// in level-0 texels, of the light's bounding points projected from `p` onto the plane at
    /// depth `z` (exact for a light tilted against the map), grown to the support of the
    /// level-`level` micro-occluders it partly covers (the over-precision fix of Figure 7).
    fn area(&self, p: Vec3, rd: &ReceiverDepth, z: f32, level: usize) -> (usize, usize, usize, usize) {
        let f = &self.frustum;
        let zp = rd.depth();
        let (mut lo, mut hi) = (rd.texel_coords(), rd.texel_coords());
        for q in &self.light.bounds {
            let zq = f.to_view(*q).z;
            let t = if zp != zq { ((zp - z) / (zp - zq)).clamp(0.0, 1.0) } else { 1.0 };
            if let Some(s) = f.project(p + (*q - p) * t) {
                (lo, hi) = (lo.min(s.truncate()), hi.max(s.truncate()));
            } else {
                (lo, hi) = (glam::Vec2::ZERO, glam::Vec2::new(f.width as f32, f.height as f32));
            }
        }
        let (w, h) = (f.width, f.height);
        let clamp = |v: f32, n: usize| (v.max(0.0) as usize).min(n);
        let s = 1usize << level;
        // Microrects reach up to one level texel past their own (section 5.2): grow by their support.
        let reach = if level > 0 && self.opts.occluder == Occluder::Microrect { s } else { 0 };
        let (x0, y0) = ((clamp(lo.x.floor(), w) / s * s).saturating_sub(reach), (clamp(lo.y.floor(), h) / s * s).saturating_sub(reach));
        let (x1, y1) = (clamp(hi.x.ceil() + 1.0, w).div_ceil(s) * s + reach, clamp(hi.y.ceil() + 1.0, h).div_ceil(s) * s + reach);
        (x0, y0, x1.min(w).max(x0 + 1), y1.min(h).max(y0 + 1))
    }

    /// Step 1: the refined search area and the umbra / lit classification, the query region
    /// grown to whole texels of `level` (the level the budget will use, 0 without one).
    fn search(&self, p: Vec3, rd: &ReceiverDepth, level: usize) -> Search {
        // Occluders must be nearer than the receiver's tangent plane at its own texel.
        let threshold = rd.at(rd.texel_coords().x as i64, rd.texel_coords().y as i64);
        let mut z = self.near;
        let mut area = self.area(p, rd, z, level);
        for _ in 0..4 {
            let Some((lo, hi)) = self.accel.range(area.0, area.1, area.2, area.3) else { return Search::Lit };
            if lo >= threshold {
                return Search::Lit;
            }
            if hi < threshold {
                return Search::Umbra;
            }
            if lo <= z {
                break;
            }
            z = lo;
            area = self.area(p, rd, z, level);
        }
        Search::Area { x0: area.0, y0: area.1, x1: area.2, y1: area.3 }
    }

    /// The budget level `ℓ` of an area (section 4.2), 0 without a budget.
    fn level_of(&self, area: (usize, usize, usize, usize), budget: Option<f32>) -> f32 {
        let side = (area.2 - area.0).max(area.3 - area.1) as f32;
        let top = (self.levels.levels.len() - 1) as f32;
        match budget {
            Some(b) => (side / b).log2().clamp(0.0, top),
            None => 0.0,
        }
    }

    /// Steps 3 and 4 at integer level `level`: the visibility of receiver `p` (`rd`) from the
    /// micro-occluders of the area, and how many it backprojected.
    fn visibility(&self, (p, n): (DVec3, DVec3), rd: &ReceiverDepth, area: (usize, usize, usize, usize), level: usize) -> (f32, u32) {
        let lv = &self.levels.levels[level.min(self.levels.levels.len() - 1)];
        let s = 1usize << level;
        let (mut bits, front) = self.light.behind(p, n);
        let mut covered = 0.0f64;
        let mut count = 0u32;
        // Microrects reach up to one level texel beyond their own: widen the scan by one.
        let grow = usize::from(self.opts.occluder == Occluder::Microrect);
        let (tx0, ty0) = ((area.0 / s).saturating_sub(grow), (area.1 / s).saturating_sub(grow));
        let (tx1, ty1) = ((area.2.div_ceil(s) + grow).min(lv.width), (area.3.div_ceil(s) + grow).min(lv.height));
        let mut add = |quad: [DVec3; 4]| {
            let Some(q) = project_quad(self.light, p, quad) else { return };
            count += 1;
            match self.opts.accumulation {
                Accumulation::Area => covered += self.light.covered_fraction(&q),
                Accumulation::Bitmask { .. } => {
                    for (k, sample) in self.light.samples.iter().enumerate() {
                        if in_quad(&q, *sample) {
                            bits[k / 64] |= 1 << (k % 64);
                        }
                    }
                }
            }
        };
        for ty in ty0..ty1 {
            for tx in tx0..tx1 {
                let d = lv.depth[ty * lv.width + tx];
                if d == EMPTY {
                    continue;
                }
                match self.opts.occluder {
                    Occluder::Micropatch { extend } => {
                        let (x0, y0) = (tx * s, ty * s);
                        if d >= plane_min(rd, (x0, y0, x0 + s, y0 + s)) {
                            continue;
                        }
                        let (x0, y0, x1, y1) = (x0 as f32, y0 as f32, (x0 + s) as f32, (y0 + s) as f32);
                        let (x0, y1) = if extend { (x0 - s as f32, y1 + s as f32) } else { (x0, y1) };
                        add(self.rect((x0, y0, x1, y1), d));
                    }
                    Occluder::Microrect => {
                        let e = lv.extent[ty * lv.width + tx];
                        if (e[2] as usize) <= area.0 || (e[0] as usize) >= area.2 || (e[3] as usize) <= area.1 || (e[1] as usize) >= area.3 {
                            continue;
                        }
                        if d >= plane_min(rd, (e[0] as usize, e[1] as usize, e[2] as usize, e[3] as usize)) {
                            continue;
                        }
                        add(self.rect((e[0] as f32, e[1] as f32, e[2] as f32, e[3] as f32), d));
                    }
                    Occluder::Microquad => {
                        if tx + 1 >= lv.width || ty + 1 >= lv.height {
                            continue;
                        }
                        let corners = [(tx, ty), (tx + 1, ty), (tx + 1, ty + 1), (tx, ty + 1)];
                        let depths = corners.map(|(x, y)| lv.depth[y * lv.width + x]);
                        let nearer = corners.iter().zip(&depths).all(|(&(x, y), &dz)| dz != EMPTY && dz < plane_min(rd, (x * s, y * s, x * s + s, y * s + s)));
                        if nearer {
                            let f = &self.frustum;
                            add(corners.map(|(x, y)| f.unproject(((x * s) as f32) + 0.5 * s as f32, ((y * s) as f32) + 0.5 * s as f32, lv.depth[y * lv.width + x]).as_dvec3()));
                        }
                    }
                }
            }
        }
        let visible = match self.opts.accumulation {
            Accumulation::Area => front * (1.0 - covered.min(1.0)),
            Accumulation::Bitmask { .. } => 1.0 - bits.iter().map(|b| b.count_ones()).sum::<u32>() as f64 / self.light.samples.len() as f64,
        };
        (visible as f32, count)
    }

    /// The world quad of the level-0 texel rectangle `(x0, y0, x1, y1)` at linear depth `d`.
    fn rect(&self, (x0, y0, x1, y1): (f32, f32, f32, f32), d: f32) -> [DVec3; 4] {
        let f = &self.frustum;
        [(x0, y0), (x1, y0), (x1, y1), (x0, y1)].map(|(x, y)| f.unproject(x, y, d).as_dvec3())
    }
}

/// The nearest depth of the receiver's tangent plane over the level-0 texels `[x0, x1) × [y0, y1)`
/// (at a corner: the plane's depth is monotonic across the map). A coarse micro-occluder takes the
/// minimum depth of its texels, so it must be nearer than the receiver's plane everywhere over its
/// extent, or a tilted receiver would shadow itself.
fn plane_min(rd: &ReceiverDepth, (x0, y0, x1, y1): (usize, usize, usize, usize)) -> f32 {
    let (x1, y1) = (x1.max(x0 + 1) - 1, y1.max(y0 + 1) - 1);
    [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].map(|(x, y)| rd.at(x as i64, y as i64)).into_iter().fold(f32::INFINITY, f32::min)
}

/// The light-coordinate quad of `quad` projected from `p`; `None` unless it lies between them.
fn project_quad(light: &LightPlane, p: DVec3, quad: [DVec3; 4]) -> Option<[DVec2; 4]> {
    let q = [light.project(p, quad[0])?, light.project(p, quad[1])?, light.project(p, quad[2])?, light.project(p, quad[3])?];
    Some(q)
}

/// Smooths the LOQ map (section 4.2): a separable box filter of `side` texels over the receiver
/// grid, each run stopping at a depth discontinuity (linear light depths differing by more than
/// 2%) and at receivers without a level (`None`: no backprojection).
fn smooth_levels(levels: &[Option<f32>], depth: &[f32], (w, h): (usize, usize), side: usize) -> Vec<Option<f32>> {
    let r = side / 2;
    let joined = |a: usize, b: usize| levels[b].is_some() && (depth[a] - depth[b]).abs() <= 0.02 * depth[a].abs().max(depth[b].abs());
    let pass = |input: &[Option<f32>], step: (usize, usize)| -> Vec<Option<f32>> {
        (0..w * h)
            .into_par_iter()
            .map(|i| {
                let v = input[i]?;
                let (x, y) = (i % w, i / w);
                let (mut sum, mut n) = (v, 1.0f32);
                for dir in [-1i64, 1] {
                    let mut prev = i;
                    for k in 1..=r as i64 {
                        let (nx, ny) = (x as i64 + dir * k * step.0 as i64, y as i64 + dir * k * step.1 as i64);
                        if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                            break;
                        }
                        let j = ny as usize * w + nx as usize;
                        if !joined(prev, j) {
                            break;
                        }
                        sum += input[j].unwrap_or(v);
                        n += 1.0;
                        prev = j;
                    }
                }
                Some(sum / n)
            })
            .collect()
    };
    let across = pass(levels, (1, 0));
    pass(&across, (0, 1))
}

/// The memory of [`backprojection_levels`] for `receivers` receivers and a `w × h` shadow map:
/// the map and its stored copy, the acceleration structure, the micro-occluder levels (depths;
/// for microrects also extents and the merge's buffers), and per receiver its search, levels
/// (raw, depths, smoothed twice), result, visibility and level.
fn peak(scene: &Scene, receivers: usize, (w, h): (usize, usize), opts: &BackprojectionOptions) -> Peak {
    let hsm = MinMaxPyramid::peak(w, h);
    let accel = match opts.acceleration {
        Acceleration::Hsm => hsm,
        Acceleration::Mssm => hsm.and(MultiScaleMap::peak(w, h)),
        Acceleration::Ysm { resolution } => hsm.and(MultiScaleMap::peak(w.min(resolution), h.min(resolution))),
    };
    let per_texel = if opts.occluder == Occluder::Microrect { 4 + 16 + 1 + 16 + 4 } else { 4 };
    let per_receiver = std::mem::size_of::<(Search, Option<ReceiverDepth>, Option<f32>)>() + 3 * 8 + 4 + 8 + 4 + 4;
    raster_peak(scene, w, h)
        .buffer(&[w as u64, h as u64, 4])
        .and(accel)
        .buffer(&[w as u64, h as u64, 2 * per_texel])
        .buffer(&[receivers as u64, per_receiver as u64])
}

/// Soft-shadow visibility of every receiver by backprojection soft shadow mapping (see the module
/// doc). Returns the visibility (receivers' order) and stats: `depth_map_seconds`,
/// `acceleration_seconds` (HSM and micro-occluder levels), `acceleration_bytes`,
/// `search_seconds`, `smoothing_seconds`, `backprojection_seconds`, `backprojecting_percent`
/// (valid receivers that backproject), `occluders_mean` and `occluders_std` (micro-occluders
/// processed per backprojecting receiver, Table 2), `level_mean` (mean LOQ level `ℓ`), `umbra`
/// and `lit` (receivers classified so).
///
/// Errors: invalid options; a light that is not a rectangle or a disk; `TooLarge`.
pub fn backprojection(scene: &Scene, light: &Light, receivers: &Receivers, opts: &BackprojectionOptions) -> Result<(Vec<f32>, Stats)> {
    backprojection_levels(scene, light, receivers, opts).map(|(vis, _, stats)| (vis, stats))
}

/// [`backprojection`] with the smoothed LOQ map: each receiver's shadow-map level `ℓ`, NaN where
/// it backprojects nothing (umbra, fully lit, facing away, outside the map; Figure 8).
pub fn backprojection_levels(scene: &Scene, light: &Light, receivers: &Receivers, opts: &BackprojectionOptions) -> Result<(Vec<f32>, Vec<f32>, Stats)> {
    super::refuse_textured(light, "backprojection")?;
    opts.validate(receivers.len())?;
    let side = match opts.accumulation {
        Accumulation::Bitmask { side } => side,
        Accumulation::Area => 16,
    };
    let plane = LightPlane::new(light, side)?;
    let mut stats = Stats::default();
    for name in ["depth_map_seconds", "acceleration_seconds", "microrects_seconds", "search_seconds", "smoothing_seconds", "backprojection_seconds", "backprojecting_percent", "occluders_mean", "occluders_std", "level_mean", "umbra", "lit"] {
        stats.set(name, 0.0);
    }
    let n = receivers.len();
    let Some(bounds) = receivers.bounds() else { return Ok((vec![0.0; n], vec![f32::NAN; n], stats)) };
    let frustum = LightFrustum::for_light_aligned(light, bounds, opts.resolution)?;
    peak(scene, n, (frustum.width, frustum.height), opts).check("backprojection", &mut stats)?;
    let map = stats.time("depth_map", || rasterize_depth(scene, &frustum, &RasterOptions::default()))?;
    let stored: Vec<f32> = map.depth.iter().map(|&d| if d.is_finite() { d } else { EMPTY }).collect();
    let near = stored.iter().copied().fold(f32::INFINITY, f32::min).max(frustum.near);
    let accel = stats.time("acceleration", || Accel::new(opts.acceleration, map.width, map.height, &stored))?;
    stats.set("acceleration_bytes", accel.memory_bytes() as f64);
    let levels = stats.time("microrects", || Levels::new(&accel.hsm, opts.occluder == Occluder::Microrect));
    stats.set("microrects_bytes", levels.levels.iter().map(|l| l.extent.len() * 20).sum::<usize>() as f64);
    let ctx = Context { frustum, accel: &accel, levels: &levels, light: &plane, opts, bias: DepthBias::new(opts.bias, RASTERIZED_SLACK)?, near };
    let budget = |i: usize| match &opts.budget {
        Budget::Infinite => None,
        Budget::Uniform(b) => Some(*b),
        Budget::Map(m) => Some(m[i]),
    };
    // Step 1 and the raw LOQ map: the query region grown to the budget's integer level.
    let searched: Vec<(Search, Option<ReceiverDepth>, Option<f32>)> = stats.time("search", || {
        (0..n)
            .into_par_iter()
            .map(|i| {
                let (p, nrm) = (receivers.points[i], receivers.normals[i]);
                if !receivers.valid[i] || nrm.dot(light.center() - p) <= 0.0 {
                    return (Search::Fixed(0.0), None, None);
                }
                let Some(rd) = ctx.receiver(p, nrm) else { return (Search::Fixed(1.0), None, None) };
                let first = ctx.search(p, &rd, 0);
                let level = match (first, opts.level) {
                    (Search::Area { x0, y0, x1, y1 }, None) => ctx.level_of((x0, y0, x1, y1), budget(i)),
                    (_, Some(l)) => l as f32,
                    _ => 0.0,
                };
                let search = if level > 0.0 { ctx.search(p, &rd, level.ceil() as usize) } else { first };
                let level = matches!(search, Search::Area { .. }).then_some(level);
                (search, Some(rd), level)
            })
            .collect()
    });
    let raw: Vec<Option<f32>> = searched.iter().map(|s| s.2).collect();
    let smoothed = if matches!(opts.budget, Budget::Infinite) || opts.level.is_some() || opts.smoothing == 1 {
        raw
    } else {
        let depth: Vec<f32> = searched.iter().map(|s| s.1.map_or(0.0, |rd| rd.depth())).collect();
        stats.time("smoothing", || smooth_levels(&raw, &depth, (receivers.width, receivers.height), opts.smoothing))
    };
    let results: Vec<(f32, Option<u32>)> = stats.time("backprojection", || {
        searched
            .par_iter()
            .zip(&smoothed)
            .enumerate()
            .map(|(i, ((search, rd, _), level))| match (search, rd, level) {
                (Search::Fixed(v), _, _) => (*v, None),
                (Search::Lit, _, _) => (ctx.light.behind(receivers.points[i].as_dvec3(), receivers.normals[i].as_dvec3()).1 as f32, None),
                (Search::Umbra, _, _) => (0.0, None),
                (Search::Area { x0, y0, x1, y1 }, Some(rd), Some(l)) => {
                    let area = (*x0, *y0, *x1, *y1);
                    let p = (receivers.points[i].as_dvec3(), receivers.normals[i].as_dvec3());
                    let (lo, hi) = (l.floor() as usize, l.ceil() as usize);
                    if !opts.blend || lo == hi {
                        let (v, c) = ctx.visibility(p, rd, area, hi);
                        return (v, Some(c));
                    }
                    let alpha = l - l.floor();
                    let ((v0, c0), (v1, c1)) = (ctx.visibility(p, rd, area, lo), ctx.visibility(p, rd, area, hi));
                    ((1.0 - alpha) * v0 + alpha * v1, Some(c0 + c1))
                }
                _ => (1.0, None),
            })
            .collect()
    });
    let valid = searched.iter().filter(|s| s.1.is_some()).count().max(1) as f64;
    let counts: Vec<f64> = results.iter().filter_map(|r| r.1).map(f64::from).collect();
    let mean = counts.iter().sum::<f64>() / counts.len().max(1) as f64;
    let var = counts.iter().map(|c| (c - mean).powi(2)).sum::<f64>() / counts.len().max(1) as f64;
    stats.set("backprojecting_percent", 100.0 * counts.len() as f64 / valid);
    stats.set("occluders_mean", mean);
    stats.set("occluders_std", var.sqrt());
    let levels_used: Vec<f32> = smoothed.iter().flatten().copied().collect();
    stats.set("level_mean", levels_used.iter().map(|&l| f64::from(l)).sum::<f64>() / levels_used.len().max(1) as f64);
    stats.set("umbra", searched.iter().filter(|s| matches!(s.0, Search::Umbra)).count() as f64);
    stats.set("lit", searched.iter().filter(|s| matches!(s.0, Search::Lit)).count() as f64);
    let levels = smoothed.iter().map(|l| l.unwrap_or(f32::NAN)).collect();
    Ok((results.into_iter().map(|r| r.0).collect(), levels, stats))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A depth map of two plateaus (near on the left third, far elsewhere) with empty texels.
    fn map(w: usize, h: usize) -> Vec<f32> {
        (0..w * h).map(|i| if i % w < w / 3 { 2.0 } else if (i / w) % 7 == 3 { EMPTY } else { 5.0 + (i % w) as f32 * 0.01 }).collect()
    }

    #[test]
    fn microrects_cover_their_level_and_keep_minimum_depths() {
        let (w, h) = (37, 29);
        let depth = map(w, h);
        let hsm = MinMaxPyramid::new(w, h, &depth).unwrap();
        let levels = Levels::new(&hsm, true);
        for (i, lv) in levels.levels.iter().enumerate() {
            let s = 1u32 << i;
            // Every level-0 texel lies in some microrect of every level, whose depth is at most its own.
            for y in 0..h as u32 {
                for x in 0..w as u32 {
                    let holders: Vec<usize> = (0..lv.extent.len()).filter(|&k| {
                        let e = lv.extent[k];
                        e[0] <= x && x < e[2] && e[1] <= y && y < e[3]
                    }).collect();
                    assert!(!holders.is_empty(), "level {i}: texel ({x}, {y}) uncovered");
                    assert!(holders.iter().any(|&k| lv.depth[k] <= depth[(y * w as u32 + x) as usize]), "level {i}: texel ({x}, {y})");
                }
            }
            // Each extent holds its own reference point and no other.
            for (k, e) in lv.extent.iter().enumerate() {
                let (rx, ry) = ((k % lv.width) as u32 * s, (k / lv.width) as u32 * s);
                assert!(e[0] <= rx && rx < e[2] && e[1] <= ry && ry < e[3], "level {i}, microrect {k}: {e:?}");
                assert!(e[2] - e[0] < 2 * s && e[3] - e[1] < 2 * s);
            }
        }
    }

    #[test]
    fn finer_structures_give_nested_depth_ranges() {
        let (w, h) = (200, 170);
        let mut rng = Rng::new(3);
        let depth: Vec<f32> = (0..w * h).map(|i| if rng.next_f32() < 0.05 { EMPTY } else { 1.0 + ((i % w) as f32 * 0.05).sin() + rng.next_f32() }).collect();
        let hsm = Accel::new(Acceleration::Hsm, w, h, &depth).unwrap();
        let ysm = Accel::new(Acceleration::Ysm { resolution: 64 }, w, h, &depth).unwrap();
        let mssm = Accel::new(Acceleration::Mssm, w, h, &depth).unwrap();
        for _ in 0..3000 {
            let (x0, y0) = ((rng.next_f32() * w as f32) as usize, (rng.next_f32() * h as f32) as usize);
            let (x1, y1) = ((x0 + 1 + (rng.next_f32() * 40.0) as usize).min(w), (y0 + 1 + (rng.next_f32() * 40.0) as usize).min(h));
            let depth = &depth;
            let exact = (y0..y1).flat_map(|y| (x0..x1).map(move |x| depth[y * w + x])).fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), d| (a.min(d), b.max(d)));
            let [m, y, hh] = [&mssm, &ysm, &hsm].map(|a| a.range(x0, y0, x1, y1).unwrap());
            assert_eq!(m, exact);
            assert!(hh.0 <= y.0 && y.0 <= m.0 && m.1 <= y.1 && y.1 <= hh.1, "{x0},{y0}..{x1},{y1}: hsm {hh:?} ysm {y:?} mssm {m:?}");
        }
    }
}
