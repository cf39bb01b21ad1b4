//! `backprojection`: soft shadow mapping by backprojecting micro-occluders onto the light, with
//! budgets and smooth quality scaling (Schwarz and Stamminger 2008, "Quality Scalability of Soft
//! Shadow Mapping"; after Guennebaud, Barthe and Paulin 2006, "Real-time Soft Shadow Mapping by
//! Backprojection").
//!
//! One depth map is rendered from the light's center. Its texels, unprojected into world space,
//! approximate the occluders; for each receiver `p` (section 3):
//!
//! 1. **Search area and level of quality** (sections 3, 4.2 and 6): the light's footprint in the
//!    map through depth `z` (its bounding points projected from `p` onto that depth's plane),
//!    starting at the nearest stored depth. With a budget `b_mo` (per receiver, from a scalar or a
//!    budget map) the area, `s` level-0 texels wide, sets the fractional level
//!    `ℓ = log2(s / (⌊b_mo⌋ − 1))` (see [`Context::level_of`]); the area is grown to whole texels of
//!    level `⌈ℓ⌉` (the "over-precision" fix of Figure 7) *before* its depth range is queried from the
//!    acceleration structure (HSM, MSSM or YSM). A receiver nearer than every sample is fully lit;
//!    one farther than all of them (and than every empty texel, stored at the largest depth) is in
//!    umbra; otherwise the pyramid from `p` to the light is intersected with the plane at the
//!    range's minimum depth (Figure 2b) and the search repeats.
//! 2. **LOQ map** (section 4.2): the levels are smoothed by a separable filter (11 × 11 by default)
//!    that stops at depth discontinuities and at receivers that backproject nothing; the
//!    visibilities of levels `⌊ℓ⌋` and `⌈ℓ⌉` are blended by the fraction of `ℓ`.
//! 3. **Micro-occluders** of the chosen level nearer than the receiver (its tangent plane,
//!    [`ReceiverDepth`]): *micropatches* (a texel's square at its minimum depth, optionally with
//!    the gap filling of Guennebaud et al. 2006, [`PatchRow::gap_wall`]), *microquads* (texel
//!    centers as the vertices of a quad mesh, used when all four are nearer) or *microrects*
//!    (section 5.2, [`Microrects`]).
//! 4. **Backprojection** onto the light's plane from `p`; the occluded light is accumulated as the
//!    sum of the clipped areas (clamped to 1) or in an occlusion bitmap over jittered `k × k`
//!    light samples (Schwarz and Stamminger 2007).
//!
//! **The budget holds per pixel.** At level `⌈ℓ⌉` a receiver processes at most `⌊b_mo⌋²`
//! micro-occluders and at level `⌊ℓ⌋` at most `(2⌊b_mo⌋)²` (section 8), counted as the texels its
//! scan reads: an area `s` texels wide at any offset touches at most `⌈s / 2^j⌉ + 1` texels of
//! level `j`, hence the `− 1` in `ℓ`; and the LOQ map is smoothed after a dilation over the same
//! window, so smoothing only ever coarsens a receiver's level. The stats `processed_*` and
//! `backprojected_*` count them. Microrects are those whose reference point (texel) lies in the
//! area, like micropatches: section 5.2 keeps each extent around its own reference point and
//! clear of the others' so that the acceleration structure serves them as it is.
//!
//! Rectangular and disk lights (the light's plane); a disk's outline is a 64-gon of equal area.
//! The light behind a receiver's tangent plane counts as blocked: the bitmap starts with those
//! samples set, and areas and fully lit receivers are scaled by the fraction in front.

use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::geometry::polygon::{ClipBuffers, ConvexWindow};
use crate::geometry::receivers::Receivers;
use crate::influence::light_polytope;
use crate::interrupt;
use crate::light::bins::BoxBins;
use crate::light::lights::{concentric_disk, tangent_frame, Light, Shape};
use crate::light::sampling::Rng;
use crate::limits::Peak;
use crate::raster::cube::{self, by_light_face};
use crate::raster::depth::{raster_peak, raster_work, rasterize_depth, RasterOptions};
use crate::raster::frustum::check_resolution;
use crate::raster::frustum::{GridRays, LightFrustum};
use crate::raster::pcf::{DepthBias, ReceiverDepth};
use crate::raster::pyramid::{MinMaxPyramid, MultiScaleMap};
use crate::stats::Stats;
use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;

/// The micro-occluders built from the shadow map (sections 3 and 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Occluder {
    /// A texel's square at its depth; `extend` fills the gaps to its left and bottom neighbours
    /// (Guennebaud et al. 2006, [`PatchRow::gap_wall`]).
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
    /// The micro-occluders (default micropatches with the gap filling: at the default unbounded
    /// budget it lowered the RMSE on every scene measured, by 1.2x to 2.1x; see
    /// `bench/backprojection.py`).
    pub occluder: Occluder,
    /// Default: occlusion bitmaps of 16 × 16 jittered samples (the paper's).
    pub accumulation: Accumulation,
    /// Default: the YSM with a 256² MSSM part, which every result of the paper used (section 8).
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
            occluder: Occluder::Micropatch { extend: true },
            accumulation: Accumulation::Bitmask { side: 16 },
            acceleration: Acceleration::Ysm { resolution: 256 },
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
        check_resolution("resolution", self.resolution)?;
        if let Accumulation::Bitmask { side } = self.accumulation {
            if !(1..=64).contains(&side) {
                return Err(Error::invalid(
                    "bitmask_side",
                    format!("must be in 1..=64, got {side}"),
                ));
            }
        }
        let positive = |b: f32| b.is_finite() && b >= 1.0;
        match &self.budget {
            Budget::Uniform(b) if !positive(*b) => {
                return Err(Error::invalid("budget", format!("must be >= 1, got {b}")))
            }
            Budget::Map(m) if m.len() != receivers => {
                return Err(Error::invalid(
                    "budget",
                    format!(
                        "the budget map has {} values for {receivers} receivers",
                        m.len()
                    ),
                ))
            }
            Budget::Map(m) if !m.iter().all(|&b| positive(b)) => {
                return Err(Error::invalid("budget", "every budget must be >= 1"))
            }
            _ => {}
        }
        if let Acceleration::Ysm { resolution } = self.acceleration {
            if resolution == 0 {
                return Err(Error::invalid("ysm_resolution", "must be >= 1"));
            }
        }
        if self.smoothing.is_multiple_of(2) || self.smoothing > 101 {
            return Err(Error::invalid(
                "smoothing",
                format!("must be odd and at most 101, got {}", self.smoothing),
            ));
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
            Acceleration::Ysm { resolution } => hsm
                .levels
                .iter()
                .position(|l| l.width.max(l.height) <= resolution)
                .unwrap_or(hsm.levels.len() - 1),
        };
        let multi = match kind {
            Acceleration::Mssm => MultiScaleMap::from_level(hsm.levels[0].clone())?,
            _ => MultiScaleMap::sharing_finest(&hsm.levels[base])?,
        };
        Ok(Accel {
            hsm,
            multi: Some((base, multi)),
        })
    }

    /// `(min, max)` over the non-empty level-0 rectangle `[x0, x1) × [y0, y1)`: the HSM reads a
    /// superset at the level where it spans 2 × 2 texels; the MSSM gives the exact range; the
    /// YSM reads its HSM part while that level is finer than its MSSM's, then the MSSM (exact at
    /// that level's texels).
    fn range(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> Option<(f32, f32)> {
        match &self.multi {
            Some((base, multi)) if self.hsm.region_level(x0, y0, x1, y1) >= *base => multi
                .query_over(
                    &self.hsm.levels[*base],
                    x0 >> base,
                    y0 >> base,
                    ((x1 - 1) >> base) + 1,
                    ((y1 - 1) >> base) + 1,
                ),
            _ => self.hsm.query_region(x0, y0, x1, y1),
        }
    }

    fn memory_bytes(&self) -> usize {
        self.hsm
            .levels
            .iter()
            .map(|l| l.min.len() * 8)
            .sum::<usize>()
            + self.multi.as_ref().map_or(0, |(_, m)| m.memory_bytes())
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
        let mut levels: Vec<Level> = hsm
            .levels
            .iter()
            .map(|l| Level {
                width: l.width,
                height: l.height,
                depth: l.min.clone(),
                extent: Vec::new(),
            })
            .collect();
        if rects {
            Microrects::build(&mut levels);
        }
        Levels { levels }
    }

    /// The level-0 texel corners `(columns, rows)` that the levels' texels reach: level `i`'s
    /// texel is `2^i` level-0 texels wide, so a coarse level overhangs a map whose side is not a
    /// multiple of `2^i`.
    fn corners(&self) -> (usize, usize) {
        self.levels
            .iter()
            .enumerate()
            .fold((0, 0), |(c, r), (i, l)| {
                (c.max(l.width << i), r.max(l.height << i))
            })
    }
}

/// The construction of microrects (section 5.2, Figures 5 and 6). Level `i + 1` keeps the
/// reference points of the even texels `(2X, 2Y)` of level `i`; every other level-`i` microrect
/// merges into one kept neighbour, "that neighbor ... which features the least depth value
/// difference" (the 1D rule of section 5.2): the `+x` neighbour `B` of a kept `A` into `A` or the
/// next kept one in `x`, `C` (the paper's first pass, `B-A` against `B-C`, and second pass); the
/// `+y` neighbour `D` into `A` or `G` likewise; the diagonal neighbour `E` into whichever of its
/// four kept neighbours `A`, `C`, `G` and `P` lies nearest in depth. The paper's greedy passes
/// give `E` to `A` when `A`'s merged extent already contains it and otherwise to `P`, whatever
/// their depths; that hands an occluder's texel to a microrect of the floor behind it (or the
/// floor's to the occluder's), whose extent then takes the occluder's depth over all the floor it
/// covers. A merged microrect's extent is the bounding rectangle of its parts' and its depth their
/// minimum; the extents stay within the open neighbourhood of their reference point by
/// construction (each part lies within one level-`i` texel of it), as section 5.2 requires.
struct Microrects;

impl Microrects {
    fn build(levels: &mut [Level]) {
        let base = &mut levels[0];
        base.extent = (0..base.height)
            .flat_map(|y| {
                (0..base.width).map(move |x| [x as u32, y as u32, x as u32 + 1, y as u32 + 1])
            })
            .collect();
        for i in 1..levels.len() {
            let (finer, coarser) = levels.split_at_mut(i);
            let parents = Self::parents(&finer[i - 1], coarser[0].width);
            Self::aggregate(&finer[i - 1], &parents, &mut coarser[0]);
        }
    }

    /// For each microrect of `fine`, the index of the coarser microrect (`width` per row) it merges
    /// into: itself for the kept ones, the kept neighbour nearest in depth for the others (ties go
    /// to the paper's first-pass partner `A`).
    fn parents(fine: &Level, width: usize) -> Vec<u32> {
        let (w, h) = (fine.width, fine.height);
        // The kept coordinates within one texel of `c` (even ones), the smaller first.
        let kept = |c: usize, n: usize| {
            if c.is_multiple_of(2) {
                [Some(c), None]
            } else {
                [Some(c - 1), (c + 1 < n).then_some(c + 1)]
            }
        };
        (0..w * h)
            .into_par_iter()
            .map(|k| {
                let (x, y) = (k % w, k / w);
                let mut best = (f32::INFINITY, 0u32);
                for cy in kept(y, h).into_iter().flatten() {
                    for cx in kept(x, w).into_iter().flatten() {
                        let gap = (fine.depth[cy * w + cx] - fine.depth[k]).abs();
                        if gap < best.0 {
                            best = (gap, ((cy / 2) * width + cx / 2) as u32);
                        }
                    }
                }
                best.1
            })
            .collect()
    }

    /// The coarser level's extents (bounding rectangles of their parts') and depths (minimum).
    fn aggregate(fine: &Level, parents: &[u32], out: &mut Level) {
        let mut extent = vec![[u32::MAX, u32::MAX, 0, 0]; out.width * out.height];
        let mut depth = vec![EMPTY; out.width * out.height];
        for (k, &parent) in parents.iter().enumerate() {
            let (e, f, m) = (
                &mut extent[parent as usize],
                fine.extent[k],
                &mut depth[parent as usize],
            );
            *e = [
                e[0].min(f[0]),
                e[1].min(f[1]),
                e[2].max(f[2]),
                e[3].max(f[3]),
            ];
            *m = m.min(fine.depth[k]);
        }
        out.extent = extent;
        out.depth = depth;
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
    outline: ConvexWindow,
    outline_area: f64,
    samples: Vec<DVec2>,
    /// The samples binned, so that a micro-occluder's bounding box finds those it may cover.
    bins: BoxBins,
    /// The samples in world space.
    world: Vec<DVec3>,
}

/// The light samples `samples` (light coordinates) binned for [`Occlusion::add`]'s box look-ups.
fn binned(samples: &[DVec2]) -> BoxBins {
    BoxBins::new(&samples.iter().map(|s| s.to_array()).collect::<Vec<_>>())
}

impl LightPlane {
    fn new(light: &Light, side: usize) -> Result<LightPlane> {
        let bounds = light_polytope(light, 16)
            .into_iter()
            .map(|q| q.as_vec3())
            .collect();
        let mut rng = Rng::new(0x5EED_B4C7);
        let jittered: Vec<DVec2> = (0..side * side)
            .map(|k| {
                DVec2::new(
                    ((k % side) as f64 + f64::from(rng.next_f32())) / side as f64,
                    ((k / side) as f64 + f64::from(rng.next_f32())) / side as f64,
                )
            })
            .collect();
        match light.shape {
            Shape::Rect { center, u, v } => {
                let (u, v) = (u.as_dvec3(), v.as_dvec3());
                // Rows of the inverse Gram matrix applied to (u, v): a = r·ua, b = r·vb.
                let (uu, uv, vv) = (u.dot(u), u.dot(v), v.dot(v));
                let det = uu * vv - uv * uv;
                let to_light = [(u * vv - v * uv) / det, (v * uu - u * uv) / det];
                let outline = vec![
                    DVec2::new(-1.0, -1.0),
                    DVec2::new(1.0, -1.0),
                    DVec2::new(1.0, 1.0),
                    DVec2::new(-1.0, 1.0),
                ];
                let samples: Vec<DVec2> = jittered.iter().map(|s| *s * 2.0 - 1.0).collect();
                let world = samples
                    .iter()
                    .map(|s| center.as_dvec3() + u * s.x + v * s.y)
                    .collect();
                Ok(LightPlane {
                    bounds,
                    center: center.as_dvec3(),
                    normal: u.cross(v).normalize(),
                    to_light,
                    outline: ConvexWindow::new(&outline),
                    outline_area: 4.0,
                    bins: binned(&samples),
                    samples,
                    world,
                })
            }
            Shape::Disk {
                center,
                normal,
                radius,
            } => {
                let (t, b) = tangent_frame(normal);
                let r = f64::from(radius);
                let k = 64;
                let scale = (2.0 * std::f64::consts::PI
                    / (k as f64 * (2.0 * std::f64::consts::PI / k as f64).sin()))
                .sqrt();
                let outline: Vec<DVec2> = (0..k)
                    .map(|i| {
                        DVec2::from_angle(2.0 * std::f64::consts::PI * i as f64 / k as f64) * scale
                    })
                    .collect();
                let samples: Vec<DVec2> = jittered
                    .iter()
                    .map(|s| concentric_disk(s.x as f32, s.y as f32).as_dvec2())
                    .collect();
                let world = samples
                    .iter()
                    .map(|s| center.as_dvec3() + (t.as_dvec3() * s.x + b.as_dvec3() * s.y) * r)
                    .collect();
                Ok(LightPlane {
                    bounds,
                    center: center.as_dvec3(),
                    normal: normal.as_dvec3(),
                    to_light: [t.as_dvec3() / r, b.as_dvec3() / r],
                    outline: ConvexWindow::new(&outline),
                    outline_area: std::f64::consts::PI,
                    bins: binned(&samples),
                    samples,
                    world,
                })
            }
            _ => Err(Error::unsupported(
                "light",
                "backprojection needs a planar area light (RectLight or DiskLight)",
            )),
        }
    }

    /// The projection from receiver `p` onto the light's plane.
    fn from(&self, p: DVec3) -> Projector<'_> {
        Projector {
            light: self,
            p,
            dp: self.normal.dot(p - self.center),
        }
    }

    /// Whether light sample `y` lies in front of the tangent plane of receiver `(p, n)` (those
    /// behind it are blocked, `docs/design.md` section 3).
    fn in_front(y: DVec3, (p, n): (DVec3, DVec3)) -> bool {
        (y - p).dot(n) > 0.0
    }

    /// The fraction of the samples in front of receiver `(p, n)`.
    fn front(&self, receiver: (DVec3, DVec3)) -> f64 {
        let front = self
            .world
            .iter()
            .filter(|&&y| Self::in_front(y, receiver))
            .count();
        front as f64 / self.world.len() as f64
    }

    /// The samples behind receiver `(p, n)`, as set bits.
    fn behind(&self, receiver: (DVec3, DVec3)) -> Vec<u64> {
        let mut bits = vec![0u64; self.samples.len().div_ceil(64)];
        for (k, &y) in self.world.iter().enumerate() {
            if !Self::in_front(y, receiver) {
                bits[k / 64] |= 1 << (k % 64);
            }
        }
        bits
    }
}

/// The projections from one receiver `p` onto the light's plane, with `p`'s side of the plane
/// computed once.
struct Projector<'a> {
    light: &'a LightPlane,
    p: DVec3,
    /// `p`'s signed distance to the light's plane (along its normal).
    dp: f64,
}

impl Projector<'_> {
    /// Light coordinates of the projection of `x` from `p` onto the light's plane; `None` unless
    /// `x` lies strictly between `p` and the plane.
    fn project(&self, x: DVec3) -> Option<DVec2> {
        let light = self.light;
        let (p, dp, dx) = (self.p, self.dp, light.normal.dot(x - light.center));
        if dp == 0.0 || dp * dx < 0.0 || dx.abs() >= dp.abs() {
            return None;
        }
        let y = p + (x - p) * (dp / (dp - dx)) - light.center;
        Some(DVec2::new(
            light.to_light[0].dot(y),
            light.to_light[1].dot(y),
        ))
    }

    /// The light-coordinate quad of `quad`; `None` unless all of it lies between `p` and the
    /// light.
    fn project_quad(&self, quad: [DVec3; 4]) -> Option<[DVec2; 4]> {
        Some([
            self.project(quad[0])?,
            self.project(quad[1])?,
            self.project(quad[2])?,
            self.project(quad[3])?,
        ])
    }
}

/// The part of the light one receiver's micro-occluders block, as they are backprojected.
enum Occlusion<'a> {
    /// The sum of the backprojected areas clipped to the light (fractions of its area), and the
    /// fraction of the light in front of the receiver.
    Area {
        light: &'a LightPlane,
        covered: f64,
        front: f64,
        buffers: Box<ClipBuffers>,
    },
    /// The occlusion bitmap, the samples behind the receiver set from the start, and the
    /// samples a micro-occluder's bounding box holds.
    Bitmask {
        light: &'a LightPlane,
        bits: Vec<u64>,
        candidates: Vec<u64>,
    },
}

impl<'a> Occlusion<'a> {
    fn new(light: &'a LightPlane, accumulation: Accumulation, receiver: (DVec3, DVec3)) -> Self {
        match accumulation {
            Accumulation::Area => Occlusion::Area {
                light,
                covered: 0.0,
                front: light.front(receiver),
                buffers: Box::default(),
            },
            Accumulation::Bitmask { .. } => {
                let bits = light.behind(receiver);
                Occlusion::Bitmask {
                    light,
                    candidates: vec![0; bits.len()],
                    bits,
                }
            }
        }
    }

    /// Adds the backprojected quad `q` (light coordinates).
    fn add(&mut self, q: &[DVec2; 4]) {
        match self {
            Occlusion::Area {
                light,
                covered,
                buffers,
                ..
            } => *covered += light.outline.clipped_area(q, buffers) / light.outline_area,
            Occlusion::Bitmask {
                light,
                bits,
                candidates,
            } => {
                // Only the samples in the quad's bounding box not already occluded are tested.
                let lo = q.iter().fold(DVec2::INFINITY, |a, &c| a.min(c));
                let hi = q.iter().fold(DVec2::NEG_INFINITY, |a, &c| a.max(c));
                light
                    .bins
                    .merge_box(lo.to_array(), hi.to_array(), candidates, |o, binned| {
                        *o = binned
                    });
                for (w, (&found, word)) in candidates.iter().zip(bits.iter_mut()).enumerate() {
                    let mut open = found & !*word;
                    while open != 0 {
                        let bit = open.trailing_zeros();
                        open &= open - 1;
                        if in_quad(q, light.samples[w * 64 + bit as usize]) {
                            *word |= 1 << bit;
                        }
                    }
                }
            }
        }
    }

    /// The visible fraction of the light.
    fn visible(&self) -> f64 {
        match self {
            Occlusion::Area { covered, front, .. } => front * (1.0 - covered.min(1.0)),
            Occlusion::Bitmask { light, bits, .. } => {
                1.0 - bits.iter().map(|b| b.count_ones()).sum::<u32>() as f64
                    / light.samples.len() as f64
            }
        }
    }
}

/// Whether `s` lies inside the convex quadrilateral `q` (either winding). A sample on all four
/// edges' lines, which only a quad of no area has, is not inside: so a sample inside lies in the
/// quad's bounding box, where [`Occlusion::add`] looks for them.
fn in_quad(q: &[DVec2; 4], s: DVec2) -> bool {
    let sides = [0, 1, 2, 3].map(|i| (q[(i + 1) % 4] - q[i]).perp_dot(s - q[i]));
    sides.iter().any(|&v| v != 0.0)
        && (sides.iter().all(|&v| v >= 0.0) || sides.iter().all(|&v| v <= 0.0))
}

/// Everything the per-receiver passes read.
struct Context<'a> {
    frustum: LightFrustum,
    /// The frustum's rays through the texel corners, which every micropatch and microrect
    /// unprojects.
    rays: GridRays,
    accel: &'a Accel,
    levels: &'a Levels,
    light: &'a LightPlane,
    opts: &'a BackprojectionOptions,
    bias: DepthBias,
    /// The nearest stored depth.
    near: f32,
}

/// A rectangle `[x0, x1) × [y0, y1)` of level-0 texels.
type Rect = (usize, usize, usize, usize);

/// What the search of step 1 found for one receiver.
#[derive(Debug, Clone, Copy)]
enum Search {
    /// Facing away from the light's center or outside the map: the visibility, no backprojection.
    Fixed(f32),
    Lit,
    Umbra,
    /// The refined search area, grown to whole texels of level `⌈level⌉`, and the fractional
    /// level `ℓ` its budget gives (before smoothing).
    Area {
        area: Rect,
        level: f32,
    },
}

/// The micro-occluders one receiver's scan of one level read, and those it backprojected.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Counts {
    processed: u32,
    backprojected: u32,
}

impl std::ops::Add for Counts {
    type Output = Counts;
    fn add(self, o: Counts) -> Counts {
        Counts {
            processed: self.processed + o.processed,
            backprojected: self.backprojected + o.backprojected,
        }
    }
}

/// The side of a light-coordinate point relative to the directed line `a → b`.
fn side(a: DVec2, b: DVec2, q: DVec2) -> f64 {
    (b - a).perp_dot(q - a)
}

impl Context<'_> {
    /// The receiver's projection and tangent-plane depth; `None` outside the map.
    fn receiver(&self, p: Vec3, n: Vec3) -> Option<ReceiverDepth> {
        let s = self.frustum.project(p)?;
        let inside = s.x >= 0.0
            && s.y >= 0.0
            && s.x < self.frustum.width as f32
            && s.y < self.frustum.height as f32;
        inside.then(|| ReceiverDepth::new(&self.frustum, p, n, s, self.bias))
    }

    /// The search area of receiver `p` (`rd`) through linear depth `z`: the bounding box, in
    /// level-0 texels, of the light's bounding points projected from `p` onto the plane at depth
    /// `z` (exact for a light tilted against the map).
    fn footprint(&self, p: Vec3, rd: &ReceiverDepth, z: f32) -> Rect {
        let f = &self.frustum;
        let zp = rd.depth();
        let (mut lo, mut hi) = (rd.texel_coords(), rd.texel_coords());
        for q in &self.light.bounds {
            let zq = f.to_view(*q).z;
            let t = if zp != zq {
                ((zp - z) / (zp - zq)).clamp(0.0, 1.0)
            } else {
                1.0
            };
            if let Some(s) = f.project(p + (*q - p) * t) {
                (lo, hi) = (lo.min(s.truncate()), hi.max(s.truncate()));
            } else {
                (lo, hi) = (
                    glam::Vec2::ZERO,
                    glam::Vec2::new(f.width as f32, f.height as f32),
                );
            }
        }
        let (w, h) = (f.width, f.height);
        let clamp = |v: f32, n: usize| (v.max(0.0) as usize).min(n);
        let (x0, y0) = (clamp(lo.x.floor(), w), clamp(lo.y.floor(), h));
        let (x1, y1) = (clamp(hi.x.ceil() + 1.0, w), clamp(hi.y.ceil() + 1.0, h));
        (
            x0.min(w - 1),
            y0.min(h - 1),
            x1.max(x0 + 1).min(w),
            y1.max(y0 + 1).min(h),
        )
    }

    /// `area` grown to whole texels of `level` (the "over-precision" fix of Figure 7).
    fn aligned(&self, (x0, y0, x1, y1): Rect, level: usize) -> Rect {
        let s = 1usize << level;
        (
            x0 / s * s,
            y0 / s * s,
            (x1.div_ceil(s) * s).min(self.frustum.width),
            (y1.div_ceil(s) * s).min(self.frustum.height),
        )
    }

    /// Step 1: the refined search area and the umbra / lit classification. Each round takes the
    /// level the budget gives the current area and grows the area to that level's texels before
    /// querying its depth range (section 6: "we determine the level j from the current search area
    /// and budget b_mo, and grow the area before querying its depth range").
    fn search(&self, p: Vec3, rd: &ReceiverDepth, budget: Option<f32>) -> Search {
        // Occluders must be nearer than the receiver's tangent plane at its own texel.
        let threshold = rd.at(rd.texel_coords().x as i64, rd.texel_coords().y as i64);
        let mut z = self.near;
        let mut found = None;
        for _ in 0..4 {
            let footprint = self.footprint(p, rd, z);
            let level = self.opts.level.map_or_else(
                || self.level_of(footprint, budget),
                |l| l.min(self.top()) as f32,
            );
            let j = level.ceil() as usize;
            let area = self.aligned(footprint, j);
            let Some((lo, hi)) = self.accel.range(area.0, area.1, area.2, area.3) else {
                return Search::Lit;
            };
            if lo >= threshold {
                return Search::Lit;
            }
            if hi < threshold {
                return Search::Umbra;
            }
            found = Some(Search::Area { area, level });
            if lo <= z {
                break;
            }
            z = lo;
        }
        found.unwrap_or(Search::Lit)
    }

    /// The coarsest micro-occluder level.
    fn top(&self) -> usize {
        self.levels.levels.len() - 1
    }

    /// The fractional level `ℓ` of a search area `s` level-0 texels wide under budget `b_mo`
    /// (section 4.2), 0 without a budget: `log2(s / (⌊b_mo⌋ − 1))`, so that at level `⌈ℓ⌉` the scan
    /// reads at most `⌊b_mo⌋` texels per axis wherever the area lies (see the module
    /// documentation).
    fn level_of(&self, area: Rect, budget: Option<f32>) -> f32 {
        let Some(b) = budget else { return 0.0 };
        let side = (area.2 - area.0).max(area.3 - area.1) as f32;
        let allowed = b.floor() - 1.0;
        let top = self.top() as f32;
        if allowed < 1.0 {
            return top;
        }
        (side / allowed).log2().clamp(0.0, top)
    }

    /// Steps 3 and 4 at integer level `level`: the visibility of `receiver` (`rd`) from the
    /// micro-occluders of `area`, and how many the scan read and backprojected.
    fn visibility(
        &self,
        receiver: (DVec3, DVec3),
        rd: &ReceiverDepth,
        area: Rect,
        level: usize,
    ) -> (f32, Counts) {
        let level = level.min(self.top());
        let lv = &self.levels.levels[level];
        let s = 1usize << level;
        let texels = (
            area.0 / s,
            area.1 / s,
            area.2.div_ceil(s).min(lv.width),
            area.3.div_ceil(s).min(lv.height),
        );
        let scan = Scan {
            ctx: self,
            rd,
            lv,
            s,
            from: self.light.from(receiver.0),
            texels,
        };
        let mut occlusion = Occlusion::new(self.light, self.opts.accumulation, receiver);
        let backprojected = match self.opts.occluder {
            Occluder::Micropatch { extend } => scan.micropatches(extend, &mut occlusion),
            Occluder::Microrect => scan.microrects(&mut occlusion),
            Occluder::Microquad => scan.microquads(&mut occlusion),
        };
        let counts = Counts {
            processed: ((texels.2 - texels.0) * (texels.3 - texels.1)) as u32,
            backprojected,
        };
        (occlusion.visible() as f32, counts)
    }
}

/// One receiver's scan of one level's micro-occluders over its search area (steps 3 and 4).
struct Scan<'a> {
    ctx: &'a Context<'a>,
    rd: &'a ReceiverDepth,
    lv: &'a Level,
    /// Level-0 texels per side of one of the level's texels.
    s: usize,
    from: Projector<'a>,
    /// The level's texels `[x0, x1) × [y0, y1)` the scan reads.
    texels: Rect,
}

/// One row of texels of a micropatch scan, from the column left of the search area: per texel,
/// whether its micropatch lies nearer than the receiver's plane all over its texel, and if so its
/// corners projected onto the light at its depth (in [`corner_of`]'s order; `None` where a corner
/// does not lie between the receiver and the light). A micropatch and the gap walls of its right
/// and upper neighbours read the same corners, so each is projected once.
struct PatchRow {
    occludes: Vec<bool>,
    corners: Vec<[Option<DVec2>; 4]>,
    /// The receiver-plane bound of each texel ([`plane_min`]).
    plane: Vec<f32>,
}

impl PatchRow {
    fn new(len: usize) -> Self {
        Self {
            occludes: vec![false; len],
            corners: vec![[None; 4]; len],
            plane: vec![0.0; len],
        }
    }

    /// The backprojected micropatch of texel `c`, when it occludes and all of it projects.
    #[inline]
    fn patch(&self, c: usize) -> Option<[DVec2; 4]> {
        if !self.occludes[c] {
            return None;
        }
        let [a, b, e, f] = self.corners[c];
        Some([a?, b?, e?, f?])
    }

    /// The gap filling of Guennebaud et al. 2006, as Schwarz and Stamminger 2008 (section 3) sum
    /// it up: "extending a micropatch to its left and bottom neighbors in texture space". Seen
    /// from the receiver, adjacent micropatches at different depths leave a gap (or overlap)
    /// between their backprojections, since their shared edge lies at two depths along the same
    /// light ray. A micropatch, backprojected as `patch` (with its vertices' mean `centroid`),
    /// closes the gap to its neighbour, texel `c` of this row, by the backprojection of the wall
    /// between the two copies of the shared edge: `patch`'s corners `own` and the neighbour's
    /// corners `theirs` (the same two texel corners, at the neighbour's depth), when the
    /// neighbour occludes the receiver too and its copy of the edge falls outside `patch`. Each
    /// edge has one owner, so every gap between two occluding micropatches closes once, and no
    /// wall reaches a texel that no occluder covers: an empty neighbour, or one behind the
    /// receiver, gets none.
    #[inline]
    fn gap_wall(
        &self,
        c: usize,
        theirs: [usize; 2],
        own: [usize; 2],
        (patch, centroid): (&[DVec2; 4], DVec2),
    ) -> Option<[DVec2; 4]> {
        if !self.occludes[c] {
            return None;
        }
        let far = [self.corners[c][theirs[0]]?, self.corners[c][theirs[1]]?];
        let (ea, eb) = (patch[own[0]], patch[own[1]]);
        let mid = (far[0] + far[1]) * 0.5;
        (side(ea, eb, centroid) * side(ea, eb, mid) < 0.0).then_some([ea, eb, far[1], far[0]])
    }
}

/// Corner `k` of the level-0 texel rectangle `(x0, y0, x1, y1)`, wound `(x0, y0), (x1, y0),
/// (x1, y1), (x0, y1)`.
#[inline]
fn corner_of((x0, y0, x1, y1): Rect, k: usize) -> (usize, usize) {
    (
        if k == 1 || k == 2 { x1 } else { x0 },
        if k >= 2 { y1 } else { y0 },
    )
}

impl Scan<'_> {
    #[inline]
    fn depth(&self, (x, y): (usize, usize)) -> f32 {
        self.lv.depth[y * self.lv.width + x]
    }

    /// The level-0 texels of the level's texel `(x, y)`.
    #[inline]
    fn cell(&self, (x, y): (usize, usize)) -> Rect {
        let s = self.s;
        (x * s, y * s, x * s + s, y * s + s)
    }

    /// The world point of level-0 texel corner `(x, y)` at linear depth `d`.
    #[inline]
    fn unproject(&self, (x, y): (usize, usize), d: f32) -> DVec3 {
        self.ctx.rays.unproject(x, y, d).as_dvec3()
    }

    /// The world quad of the level-0 texel rectangle `rect` at linear depth `d`, wound as
    /// [`corner_of`].
    fn rect(&self, rect: Rect, d: f32) -> [DVec3; 4] {
        [0, 1, 2, 3].map(|k| self.unproject(corner_of(rect, k), d))
    }

    /// Plain micropatches, or with `extend` the gap filling of Guennebaud et al. 2006
    /// ([`PatchRow::gap_wall`]); returns how many it backprojected. Each row of the area is filled
    /// before the row above it is backprojected, since the lower gap walls read it.
    fn micropatches(&self, extend: bool, occlusion: &mut Occlusion) -> u32 {
        let (tx0, ty0, tx1, ty1) = self.texels;
        let (mut row, mut below) = (PatchRow::new(tx1 - tx0 + 1), PatchRow::new(tx1 - tx0 + 1));
        // Texel `tx` sits at index `tx + 1 - tx0` of a row.
        self.fill(&mut row, ty0);
        let mut backprojected = 0;
        for ty in ty0..ty1 {
            if ty + 1 < self.lv.height {
                self.fill(&mut below, ty + 1);
            } else {
                below.occludes.fill(false);
            }
            for c in 1..=tx1 - tx0 {
                let Some(patch) = row.patch(c) else {
                    continue;
                };
                backprojected += 1;
                occlusion.add(&patch);
                if !extend {
                    continue;
                }
                // The left neighbour's right edge is its corners 2 → 1, the lower neighbour's top
                // edge its corners 1 → 0; they face the patch's edges 3 → 0 and 2 → 3.
                let centroid = (patch[0] + patch[1] + patch[2] + patch[3]) * 0.25;
                let left = row.gap_wall(c - 1, [2, 1], [3, 0], (&patch, centroid));
                let lower = below.gap_wall(c, [1, 0], [2, 3], (&patch, centroid));
                for wall in [left, lower].into_iter().flatten() {
                    occlusion.add(&wall);
                }
            }
            std::mem::swap(&mut row, &mut below);
        }
        backprojected
    }

    /// Fills `row` with the texels of row `ty` (see [`PatchRow`]).
    fn fill(&self, row: &mut PatchRow, ty: usize) {
        let (tx0, tx1, s) = (self.texels.0, self.texels.2, self.s);
        // The columns `first..tx1` at indices `skip..`: from the one left of the area, if any.
        let first = tx0.saturating_sub(1);
        let skip = first + 1 - tx0;
        row.occludes[..skip].fill(false);
        let plane = &mut row.plane[skip..];
        if s == 1 {
            // `plane_min` of a level-0 texel is its one prediction.
            self.rd.at_row(first as i32, ty as i32, plane);
        } else {
            for (tx, p) in (first..).zip(plane.iter_mut()) {
                *p = plane_min(self.rd, self.cell((tx, ty)));
            }
        }
        let depth = &self.lv.depth[ty * self.lv.width..][first..tx1];
        for ((o, &d), &p) in row.occludes[skip..]
            .iter_mut()
            .zip(depth)
            .zip(&row.plane[skip..])
        {
            *o = d != EMPTY && d < p;
        }
        let (y0, y1) = (ty * s, ty * s + s);
        for (c, tx) in (skip..row.occludes.len()).zip(first..) {
            if row.occludes[c] {
                let (x0, x1) = (tx * s, tx * s + s);
                let d = depth[c - skip];
                let project = |x, y| self.from.project(self.unproject((x, y), d));
                row.corners[c] = [
                    project(x0, y0),
                    project(x1, y0),
                    project(x1, y1),
                    project(x0, y1),
                ];
            }
        }
    }

    /// Microrects (section 5.2): each texel's extent at its depth; returns how many it
    /// backprojected.
    fn microrects(&self, occlusion: &mut Occlusion) -> u32 {
        let (tx0, ty0, tx1, ty1) = self.texels;
        let mut backprojected = 0;
        for ty in ty0..ty1 {
            for tx in tx0..tx1 {
                let d = self.depth((tx, ty));
                let e = self.lv.extent[ty * self.lv.width + tx].map(|v| v as usize);
                let rect = (e[0], e[1], e[2], e[3]);
                if d == EMPTY || d >= plane_min(self.rd, rect) {
                    continue;
                }
                if let Some(q) = self.from.project_quad(self.rect(rect, d)) {
                    backprojected += 1;
                    occlusion.add(&q);
                }
            }
        }
        backprojected
    }

    /// Microquads: the texel centers of each 2 × 2 block as a quad, when all four lie nearer than
    /// the receiver's plane; returns how many it backprojected.
    fn microquads(&self, occlusion: &mut Occlusion) -> u32 {
        let (tx0, ty0, tx1, ty1) = self.texels;
        let (lv, s) = (self.lv, self.s);
        let mut backprojected = 0;
        for ty in ty0..ty1 {
            for tx in tx0..tx1 {
                if self.depth((tx, ty)) == EMPTY || tx + 1 >= lv.width || ty + 1 >= lv.height {
                    continue;
                }
                let corners = [(tx, ty), (tx + 1, ty), (tx + 1, ty + 1), (tx, ty + 1)];
                let depths = corners.map(|t| self.depth(t));
                if !corners
                    .iter()
                    .zip(&depths)
                    .all(|(&t, &dz)| dz != EMPTY && dz < plane_min(self.rd, self.cell(t)))
                {
                    continue;
                }
                let center = |c: usize| ((c * s) as f32) + 0.5 * s as f32;
                let quad = [0, 1, 2, 3].map(|i| {
                    let (x, y) = corners[i];
                    self.ctx
                        .frustum
                        .unproject(center(x), center(y), depths[i])
                        .as_dvec3()
                });
                if let Some(q) = self.from.project_quad(quad) {
                    backprojected += 1;
                    occlusion.add(&q);
                }
            }
        }
        backprojected
    }
}

/// The nearest depth of the receiver's tangent plane over the level-0 texels `[x0, x1) × [y0, y1)`
/// (at a corner: the plane's depth is monotonic across the map). A coarse micro-occluder takes the
/// minimum depth of its texels, so it must be nearer than the receiver's plane everywhere over its
/// extent, or a tilted receiver would shadow itself. A texel one level-0 texel wide or high has
/// fewer distinct corners, each read once.
fn plane_min(rd: &ReceiverDepth, (x0, y0, x1, y1): Rect) -> f32 {
    let (x1, y1) = (x1.max(x0 + 1) - 1, y1.max(y0 + 1) - 1);
    let at = |x: usize, y: usize| rd.at(x as i64, y as i64);
    let column = |x: usize| {
        let top = f32::INFINITY.min(at(x, y0));
        if y1 == y0 {
            top
        } else {
            top.min(at(x, y1))
        }
    };
    if x1 == x0 {
        column(x0)
    } else {
        column(x0).min(column(x1))
    }
}

/// Smooths the LOQ map (section 4.2): per axis, a box filter of `side` texels over the receiver
/// grid, each run stopping at a depth discontinuity (linear light depths differing by more than
/// 2%) and at receivers without a level (`None`: no backprojection). Each box follows a maximum
/// over the same runs: a run around `x` holds `y` exactly when the run around `y` holds `x`, so
/// every term of `x`'s mean is at least its own level and smoothing never lowers a level below
/// the one its budget needs (the budget's bound holds at every pixel), while the box still turns
/// the steps of the raw map into ramps.
fn smooth_levels(
    levels: &[Option<f32>],
    depth: &[f32],
    (w, h): (usize, usize),
    side: usize,
) -> Vec<Option<f32>> {
    let r = side / 2;
    let joined = |a: usize, b: usize| {
        levels[b].is_some()
            && (depth[a] - depth[b]).abs() <= 0.02 * depth[a].abs().max(depth[b].abs())
    };
    // The run around `i` along `step`: `i` and the joined receivers within `r` on either side.
    let run = |i: usize, step: (usize, usize), visit: &mut dyn FnMut(usize)| {
        visit(i);
        let (x, y) = (i % w, i / w);
        for dir in [-1i64, 1] {
            let mut prev = i;
            for k in 1..=r as i64 {
                let (nx, ny) = (
                    x as i64 + dir * k * step.0 as i64,
                    y as i64 + dir * k * step.1 as i64,
                );
                if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                    break;
                }
                let j = ny as usize * w + nx as usize;
                if !joined(prev, j) {
                    break;
                }
                visit(j);
                prev = j;
            }
        }
    };
    let filter = |input: &[Option<f32>], step: (usize, usize), mean: bool| -> Vec<Option<f32>> {
        (0..w * h)
            .into_par_iter()
            .map(|i| {
                input[i]?;
                let (mut sum, mut max, mut n) = (0.0f32, f32::NEG_INFINITY, 0.0f32);
                run(i, step, &mut |j| {
                    let v = input[j].unwrap_or(f32::NEG_INFINITY);
                    (sum, max, n) = (sum + v, max.max(v), n + 1.0);
                });
                Some(if mean { sum / n } else { max })
            })
            .collect()
    };
    let mut out = levels.to_vec();
    for step in [(1, 0), (0, 1)] {
        out = filter(&filter(&out, step, false), step, true);
    }
    out
}

/// The memory of [`backprojection_levels`] for `receivers` receivers and a `w × h` shadow map:
/// the map and its stored copy, the acceleration structure, the micro-occluder levels (depths;
/// for microrects also extents and the merge's buffers), and per receiver its search, levels
/// (raw, depths, smoothed twice), result, visibility and level.
/// The texels one receiver's search and backprojection visit: at most five budgets' worth
/// (the search and both blended levels of section 4.4), and without a budget about one side of
/// the map (a typical penumbra footprint; the whole map is the worst case).
fn receiver_work(opts: &BackprojectionOptions, (w, h): (usize, usize)) -> u64 {
    let side = (w.max(h) as u64).max(1);
    let bounded = |b: f32| ((f64::from(b).powi(2) * 5.0).ceil() as u64).clamp(1, side * side);
    match &opts.budget {
        Budget::Infinite => side,
        Budget::Uniform(b) => bounded(*b),
        Budget::Map(m) => bounded(m.iter().copied().fold(0.0, f32::max)),
    }
}

fn peak(
    scene: &Scene,
    receivers: usize,
    (w, h): (usize, usize),
    opts: &BackprojectionOptions,
) -> Peak {
    let hsm = MinMaxPyramid::peak(w, h);
    let accel = match opts.acceleration {
        Acceleration::Hsm => hsm,
        Acceleration::Mssm => hsm.and(MultiScaleMap::peak(w, h)),
        Acceleration::Ysm { resolution } => {
            hsm.and(MultiScaleMap::peak(w.min(resolution), h.min(resolution)))
        }
    };
    // Microrects: the level's depths and extents, and the merge's parents, extents and depths.
    let per_texel = if opts.occluder == Occluder::Microrect {
        4 + 16 + 4 + 16 + 4
    } else {
        4
    };
    // The search, the raw and smoothed levels and the two of each filter pass, the depths, the
    // result, and the visibility and level returned.
    let per_receiver = std::mem::size_of::<(Search, Option<ReceiverDepth>)>()
        + 4 * std::mem::size_of::<Option<f32>>()
        + 4
        + std::mem::size_of::<(f32, Option<Counts>)>()
        + 4
        + 4;
    raster_peak(scene, w, h)
        .buffer(&[w as u64, h as u64, 4])
        .and(accel)
        .buffer(&[w as u64, h as u64, 2 * per_texel])
        .buffer(&[receivers as u64, per_receiver as u64])
}

/// The stats keys every call returns (beside [`crate::stats::COMMON`]), zeroed at the start:
/// the one declaration the Python docstring and the key tests read.
pub const STATS: &[&str] = &[
    "depth_map_seconds",
    "acceleration_seconds",
    "microrects_seconds",
    "search_seconds",
    "smoothing_seconds",
    "backprojection_seconds",
    "backprojecting_percent",
    "processed",
    "processed_mean",
    "processed_std",
    "processed_max",
    "backprojected",
    "backprojected_mean",
    "backprojected_std",
    "backprojected_max",
    "level_mean",
    "umbra",
    "lit",
    "acceleration_bytes",
    "microrects_bytes",
    "light_faces",
];

/// Soft-shadow visibility of every receiver by backprojection soft shadow mapping (see the module
/// doc). Returns the visibility (receivers' order) and stats: `depth_map_seconds`,
/// `acceleration_seconds` (HSM and micro-occluder levels), `acceleration_bytes`,
/// `search_seconds`, `smoothing_seconds`, `backprojection_seconds`, `backprojecting_percent`
/// (valid receivers that backproject), `processed` (micro-occluders read, summed over the
/// receivers), `processed_mean`, `processed_std` and `processed_max` (per backprojecting
/// receiver, both levels when blending: Table 2's count), `backprojected` (those of them in
/// front of the receiver that project onto the light, summed), `backprojected_mean`, `_std` and
/// `_max`, `level_mean` (mean LOQ level `ℓ`), `umbra` and `lit` (receivers
/// classified so).
///
/// A light among the receivers gets a map per face of a cube around its center
/// ([`crate::raster::cube`]), each receiver's micro-occluders taken from its own face's map and
/// backprojected onto the light's plane as ever; stat `light_faces`, and the other stats the
/// largest face's.
///
/// Errors: invalid options; a light that is not a rectangle or a disk; `TooLarge`.
pub fn backprojection(
    scene: &Scene,
    light: &Light,
    receivers: &Receivers,
    opts: &BackprojectionOptions,
) -> Result<(Vec<f32>, Stats)> {
    backprojection_levels(scene, light, receivers, opts).map(|out| (out.visibility, out.stats))
}

/// What [`backprojection_levels`] returns, per receiver (receivers' order) and in all.
#[derive(Debug, Clone)]
pub struct Backprojected {
    pub visibility: Vec<f32>,
    /// The smoothed LOQ map: each receiver's shadow-map level `ℓ`, NaN where it backprojects
    /// nothing (umbra, fully lit, facing away, outside the map; Figure 8).
    pub levels: Vec<f32>,
    /// The micro-occluders each receiver processed (both levels when blending; 0 where it
    /// backprojects nothing): Table 2's count, per pixel.
    pub processed: Vec<u32>,
    pub stats: Stats,
}

/// [`backprojection`] with the LOQ map and the micro-occluders processed per receiver.
pub fn backprojection_levels(
    scene: &Scene,
    light: &Light,
    receivers: &Receivers,
    opts: &BackprojectionOptions,
) -> Result<Backprojected> {
    super::refuse_textured(light, "backprojection")?;
    opts.validate(receivers.len())?;
    let n = receivers.len();
    let (mut levels, mut processed) = (vec![f32::NAN; n], vec![0u32; n]);
    let (visibility, stats) = by_light_face(light, receivers, |part, face| {
        let out = backprojection_view(scene, light, part, face, opts)?;
        for i in (0..n).filter(|&i| part.valid[i]) {
            levels[i] = out.levels[i];
            processed[i] = out.processed[i];
        }
        Ok((out.visibility, out.stats))
    })?;
    Ok(Backprojected {
        visibility,
        levels,
        processed,
        stats,
    })
}

/// [`backprojection_levels`] on the receivers one light frustum serves: fitted, or cube face
/// `face`'s.
fn backprojection_view(
    scene: &Scene,
    light: &Light,
    receivers: &Receivers,
    face: Option<usize>,
    opts: &BackprojectionOptions,
) -> Result<Backprojected> {
    let side = match opts.accumulation {
        Accumulation::Bitmask { side } => side,
        Accumulation::Area => 16,
    };
    let plane = LightPlane::new(light, side)?;
    let mut stats = Stats::declared(STATS);
    let n = receivers.len();
    let Some(bounds) = receivers.bounds() else {
        return Ok(Backprojected {
            visibility: vec![0.0; n],
            levels: vec![f32::NAN; n],
            processed: vec![0; n],
            stats,
        });
    };
    let frustum = cube::footprint_frustum(light, receivers, face, bounds, opts.resolution)?;
    peak(scene, n, (frustum.width, frustum.height), opts).check("backprojection", &mut stats)?;
    raster_work(scene, frustum.width, frustum.height)
        .loop_of(&[
            n as u64,
            receiver_work(opts, (frustum.width, frustum.height)),
        ])
        .check("backprojection", &mut stats)?;
    let map = stats.time("depth_map", || {
        rasterize_depth(scene, &frustum, &RasterOptions::default())
    })?;
    let stored: Vec<f32> = map
        .depth
        .iter()
        .map(|&d| if d.is_finite() { d } else { EMPTY })
        .collect();
    let near = stored
        .iter()
        .copied()
        .fold(f32::INFINITY, f32::min)
        .max(frustum.near);
    let accel = stats.time("acceleration", || {
        Accel::new(opts.acceleration, map.width, map.height, &stored)
    })?;
    stats.set("acceleration_bytes", accel.memory_bytes() as f64);
    let levels = stats.time("microrects", || {
        Levels::new(&accel.hsm, opts.occluder == Occluder::Microrect)
    });
    stats.set(
        "microrects_bytes",
        levels
            .levels
            .iter()
            .map(|l| l.extent.len() * 20)
            .sum::<usize>() as f64,
    );
    let ctx = Context {
        rays: {
            let (columns, rows) = levels.corners();
            GridRays::new(&frustum, columns, rows)
        },
        frustum,
        accel: &accel,
        levels: &levels,
        light: &plane,
        opts,
        bias: DepthBias::new(opts.bias)?,
        near,
    };
    let budget = |i: usize| match &opts.budget {
        Budget::Infinite => None,
        Budget::Uniform(b) => Some(*b),
        Budget::Map(m) => Some(m[i]),
    };
    // Step 1 and the raw LOQ map.
    let per_receiver = receiver_work(opts, (map.width, map.height));
    let searched: Vec<(Search, Option<ReceiverDepth>)> = stats.time("search", || {
        interrupt::par_map(n, per_receiver, |i| {
            let (p, nrm) = (receivers.points[i], receivers.normals[i]);
            if !receivers.valid[i] || nrm.dot(light.center() - p) <= 0.0 {
                return (Search::Fixed(0.0), None);
            }
            let Some(rd) = ctx.receiver(p, nrm) else {
                return (Search::Fixed(1.0), None);
            };
            (ctx.search(p, &rd, budget(i)), Some(rd))
        })
    })?;
    let raw: Vec<Option<f32>> = searched
        .iter()
        .map(|s| {
            if let Search::Area { level, .. } = s.0 {
                Some(level)
            } else {
                None
            }
        })
        .collect();
    let smoothed =
        if matches!(opts.budget, Budget::Infinite) || opts.level.is_some() || opts.smoothing == 1 {
            raw
        } else {
            let depth: Vec<f32> = searched
                .iter()
                .map(|s| s.1.map_or(0.0, |rd| rd.depth()))
                .collect();
            stats.time("smoothing", || {
                smooth_levels(
                    &raw,
                    &depth,
                    (receivers.width, receivers.height),
                    opts.smoothing,
                )
            })
        };
    let results: Vec<(f32, Option<Counts>)> = stats.time("backprojection", || {
        interrupt::par_map(n, per_receiver, |i| {
            let ((search, rd), level) = (&searched[i], &smoothed[i]);
            match (search, rd, level) {
                (Search::Fixed(v), _, _) => (*v, None),
                (Search::Lit, _, _) => (
                    ctx.light.front((
                        receivers.points[i].as_dvec3(),
                        receivers.normals[i].as_dvec3(),
                    )) as f32,
                    None,
                ),
                (Search::Umbra, _, _) => (0.0, None),
                (Search::Area { area, .. }, Some(rd), Some(l)) => {
                    let p = (
                        receivers.points[i].as_dvec3(),
                        receivers.normals[i].as_dvec3(),
                    );
                    let (lo, hi) = (l.floor() as usize, l.ceil() as usize);
                    if !opts.blend || lo == hi {
                        let (v, c) = ctx.visibility(p, rd, *area, hi);
                        return (v, Some(c));
                    }
                    let alpha = l - l.floor();
                    let ((v0, c0), (v1, c1)) = (
                        ctx.visibility(p, rd, *area, lo),
                        ctx.visibility(p, rd, *area, hi),
                    );
                    ((1.0 - alpha) * v0 + alpha * v1, Some(c0 + c1))
                }
                _ => (1.0, None),
            }
        })
    })?;
    let valid = searched.iter().filter(|s| s.1.is_some()).count().max(1) as f64;
    let counts: Vec<Counts> = results.iter().filter_map(|r| r.1).collect();
    stats.set(
        "backprojecting_percent",
        100.0 * counts.len() as f64 / valid,
    );
    for (name, values) in [
        (
            "processed",
            counts.iter().map(|c| c.processed).collect::<Vec<_>>(),
        ),
        (
            "backprojected",
            counts.iter().map(|c| c.backprojected).collect(),
        ),
    ] {
        let (mean, std, max) = moments(&values);
        stats.set(name, values.iter().map(|&v| f64::from(v)).sum());
        stats.set(&format!("{name}_mean"), mean);
        stats.set(&format!("{name}_std"), std);
        stats.set(&format!("{name}_max"), max);
    }
    let levels_used: Vec<f32> = smoothed.iter().flatten().copied().collect();
    stats.set(
        "level_mean",
        levels_used.iter().map(|&l| f64::from(l)).sum::<f64>() / levels_used.len().max(1) as f64,
    );
    stats.set(
        "umbra",
        searched
            .iter()
            .filter(|s| matches!(s.0, Search::Umbra))
            .count() as f64,
    );
    stats.set(
        "lit",
        searched
            .iter()
            .filter(|s| matches!(s.0, Search::Lit))
            .count() as f64,
    );
    let levels = smoothed.iter().map(|l| l.unwrap_or(f32::NAN)).collect();
    let processed = results
        .iter()
        .map(|r| r.1.map_or(0, |c| c.processed))
        .collect();
    Ok(Backprojected {
        visibility: results.into_iter().map(|r| r.0).collect(),
        levels,
        processed,
        stats,
    })
}

/// The mean, standard deviation and maximum of `values` (zeros when empty).
fn moments(values: &[u32]) -> (f64, f64, f64) {
    let n = values.len().max(1) as f64;
    let mean = values.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    let var = values
        .iter()
        .map(|&v| (f64::from(v) - mean).powi(2))
        .sum::<f64>()
        / n;
    (
        mean,
        var.sqrt(),
        values.iter().copied().max().map_or(0.0, f64::from),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A depth map of two plateaus (near on the left third, far elsewhere) with empty texels.
    fn map(w: usize, h: usize) -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                if i % w < w / 3 {
                    2.0
                } else if (i / w) % 7 == 3 {
                    EMPTY
                } else {
                    5.0 + (i % w) as f32 * 0.01
                }
            })
            .collect()
    }

    /// For every level, the level-0 texels each microrect holds (following the merges down).
    fn members(levels: &Levels) -> Vec<Vec<Vec<usize>>> {
        let base = &levels.levels[0];
        let mut owner: Vec<usize> = (0..base.width * base.height).collect();
        let mut out = vec![(0..owner.len()).map(|k| vec![k]).collect::<Vec<_>>()];
        for i in 1..levels.levels.len() {
            let parents = Microrects::parents(&levels.levels[i - 1], levels.levels[i].width);
            owner.iter_mut().for_each(|o| *o = parents[*o] as usize);
            let mut sets = vec![Vec::new(); levels.levels[i].depth.len()];
            for (texel, &o) in owner.iter().enumerate() {
                sets[o].push(texel);
            }
            out.push(sets);
        }
        out
    }

    #[test]
    fn each_microrect_is_the_bounding_rectangle_and_minimum_depth_of_the_texels_it_replaces(
    ) -> Result<()> {
        let (w, h) = (37, 29);
        let depth = map(w, h);
        let levels = Levels::new(&MinMaxPyramid::new(w, h, &depth)?, true);
        for (i, (lv, sets)) in levels.levels.iter().zip(members(&levels)).enumerate() {
            let s = 1u32 << i;
            for (k, texels) in sets.iter().enumerate() {
                // Every texel merges into exactly one microrect per level (the sets partition the
                // map), which keeps its reference point.
                let (rx, ry) = ((k % lv.width) as u32 * s, (k / lv.width) as u32 * s);
                assert!(
                    texels.contains(&((ry as usize) * w + rx as usize)),
                    "level {i}, microrect {k} lost its reference texel"
                );
                let bounds = texels.iter().fold([u32::MAX, u32::MAX, 0, 0], |b, &t| {
                    let (x, y) = ((t % w) as u32, (t / w) as u32);
                    [b[0].min(x), b[1].min(y), b[2].max(x + 1), b[3].max(y + 1)]
                });
                assert_eq!(
                    lv.extent[k], bounds,
                    "level {i}, microrect {k}: extent is not its texels' bounding rectangle"
                );
                let nearest = texels.iter().map(|&t| depth[t]).fold(EMPTY, f32::min);
                assert_eq!(
                    lv.depth[k], nearest,
                    "level {i}, microrect {k}: depth is not its texels' minimum"
                );
                // Section 5.2's constraints: no other reference point of the level inside.
                let e = lv.extent[k];
                assert!(
                    e[0] + s > rx && e[2] <= rx + s && e[1] + s > ry && e[3] <= ry + s,
                    "level {i}, microrect {k}: {e:?}"
                );
            }
            assert_eq!(sets.iter().map(Vec::len).sum::<usize>(), w * h);
        }
        Ok(())
    }

    #[test]
    fn microrects_merge_into_the_kept_neighbour_nearest_in_depth() -> Result<()> {
        let mut rng = Rng::new(11);
        let (w, h) = (33, 26);
        let depth: Vec<f32> = (0..w * h)
            .map(|i| {
                if rng.next_f32() < 0.1 {
                    EMPTY
                } else {
                    (i % 5) as f32 + rng.next_f32()
                }
            })
            .collect();
        let levels = Levels::new(&MinMaxPyramid::new(w, h, &depth)?, true);
        for i in 1..levels.levels.len() {
            let (fine, coarse) = (&levels.levels[i - 1], &levels.levels[i]);
            let parents = Microrects::parents(fine, coarse.width);
            for (k, &parent) in parents.iter().enumerate() {
                let (x, y) = (k % fine.width, k / fine.width);
                let gap = |px: usize, py: usize| {
                    (fine.depth[2 * py * fine.width + 2 * px] - fine.depth[k]).abs()
                };
                let (px, py) = (
                    parent as usize % coarse.width,
                    parent as usize / coarse.width,
                );
                assert!(
                    (2 * px).abs_diff(x) <= 1 && (2 * py).abs_diff(y) <= 1,
                    "level {i}: {k} merged into a far microrect"
                );
                for cy in [y.wrapping_sub(1), y, y + 1]
                    .into_iter()
                    .filter(|&c| c < fine.height && c.is_multiple_of(2))
                {
                    for cx in [x.wrapping_sub(1), x, x + 1]
                        .into_iter()
                        .filter(|&c| c < fine.width && c.is_multiple_of(2))
                    {
                        assert!(
                            gap(px, py) <= gap(cx / 2, cy / 2),
                            "level {i}: texel ({x}, {y}) skipped a nearer kept neighbour"
                        );
                    }
                }
            }
        }
        Ok(())
    }

    #[test]
    fn an_occluder_texel_diagonal_to_the_floor_stays_with_the_occluder() -> Result<()> {
        // Level 0 of a 4 x 4 map: the floor (depth 9) at the kept texel A = (0, 0) and its +x
        // and +y neighbours B and D, an occluder (depth 2) at the diagonal E = (1, 1) and at the
        // next kept P = (2, 2). The paper's first pass would give E to A, whose extent A + B + D
        // contains it, and set the floor's microrect to the occluder's depth.
        let mut depth = vec![9.0f32; 16];
        for (x, y) in [(1, 1), (2, 2), (3, 2), (2, 3), (3, 3)] {
            depth[y * 4 + x] = 2.0;
        }
        let levels = Levels::new(&MinMaxPyramid::new(4, 4, &depth)?, true);
        let level1 = &levels.levels[1];
        assert_eq!(level1.depth[0], 9.0);
        assert_eq!(level1.depth[3], 2.0);
        assert_eq!(level1.extent[3], [1, 1, 4, 4]);
        Ok(())
    }

    #[test]
    fn finer_structures_give_nested_depth_ranges() {
        let (w, h) = (200, 170);
        let mut rng = Rng::new(3);
        let depth: Vec<f32> = (0..w * h)
            .map(|i| {
                if rng.next_f32() < 0.05 {
                    EMPTY
                } else {
                    1.0 + ((i % w) as f32 * 0.05).sin() + rng.next_f32()
                }
            })
            .collect();
        let hsm = Accel::new(Acceleration::Hsm, w, h, &depth).unwrap();
        let ysm = Accel::new(Acceleration::Ysm { resolution: 64 }, w, h, &depth).unwrap();
        let mssm = Accel::new(Acceleration::Mssm, w, h, &depth).unwrap();
        for _ in 0..3000 {
            let (x0, y0) = (
                (rng.next_f32() * w as f32) as usize,
                (rng.next_f32() * h as f32) as usize,
            );
            let (x1, y1) = (
                (x0 + 1 + (rng.next_f32() * 40.0) as usize).min(w),
                (y0 + 1 + (rng.next_f32() * 40.0) as usize).min(h),
            );
            let depth = &depth;
            let exact = (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| depth[y * w + x]))
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), d| {
                    (a.min(d), b.max(d))
                });
            let [m, y, hh] = [&mssm, &ysm, &hsm].map(|a| a.range(x0, y0, x1, y1).unwrap());
            assert_eq!(m, exact);
            assert!(
                hh.0 <= y.0 && y.0 <= m.0 && m.1 <= y.1 && y.1 <= hh.1,
                "{x0},{y0}..{x1},{y1}: hsm {hh:?} ysm {y:?} mssm {m:?}"
            );
        }
    }
}
