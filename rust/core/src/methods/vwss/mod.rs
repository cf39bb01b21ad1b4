//! `vwss`: view-warped multi-view soft shadows (Marrs, Watson and Healey 2018, View-warped
//! Multi-view Soft Shadows for Local Area Lights).
//!
//! The depth maps of [`mvr`](crate::methods::mvr) are made without rasterizing the scene once
//! per light sample: the occluders are rasterized once into a multi-view point cloud, and the
//! points are warped into every light sample's depth map.
//!
//! 1. **Source view** (section 3.1, equations 1–3). The views of all light samples share one
//!    orientation and field of view ([`ViewSet`]). The source view keeps them and moves its eye
//!    from the light's center `l_c` back along the view direction `f` by `d` (eq. 2,
//!    `v_e = l_c − d·f`), so that its frustum contains every light sample's frustum: `d` is the
//!    smallest pull-back that puts every sample inside the source pyramid,
//!    `d = max_s max(|x_s|, |y_s|) / tan(fov/2) − z_s` with `(x_s, y_s, z_s)` the sample's offset
//!    from `l_c` in view axes. For a `w × h` rectangle facing `f` with samples at its corners this
//!    is eq. 1, `max(w, h) / (2 tan(fov/2))`; pull-back by the actual samples keeps the source map
//!    smallest. Its near plane lies in the plane of the nearest sample (the light's plane), so
//!    nothing behind the light is rasterized. Its resolution follows eq. 3, `m · (z_n + d) / z_n`,
//!    which matches the sampling rate of the light-sample views at depth `z_n`, times
//!    `√point_density`. `z_n` is the depth (from the light's center along `f`) of the nearest
//!    scene vertex inside the source pyramid, at least 5% of the receivers' nearest depth (the
//!    paper uses the light's near plane, which in an engine lies in front of the occluders).
//!    `point_density` (default 2) is the number of points per target texel at that depth: at 1 the
//!    point lattice snaps onto the target texels with gaps wherever the two grids drift half a
//!    texel apart, and silhouettes seen more frontally from a sample than from the source get
//!    fewer points still, so the maps have holes that leak light (measured: +0.01 to +0.02 mean
//!    visibility against `mvr` on the columns and bunny scenes); at 2 the holes are gone and the
//!    slight bloat of Figure 6 remains. The scale is capped at 8 (a CPU memory guard;
//!    `source_resolution` overrides all of this). [`SourceView::Paper`] sizes the view by the
//!    equations as printed instead: `d` from the light's width and height (eq. 1, its extents
//!    along the views' axes, which are the paper's `l_w` and `l_h` when the views are aligned with
//!    its edges; undefined for volume lights), `z_n` the light-sample views' near plane
//!    as in Listing 1 (Python's `vwss` then defaults `point_density` to 1, the equation as
//!    printed). Our views' near plane lies at 1/1000 of
//!    the receivers' nearest depth (for depth precision, not as a statement about the occluders),
//!    so eq. 3 then asks for about a thousand times the side and the cap decides.
//! 2. **Point generation** (section 3.1). The source view is rasterized with no depth test:
//!    every front-facing fragment along each ray becomes a point (back faces too when
//!    `cull_backfaces` is off; perforated meshes alpha-tested), its world position at the texel
//!    center in f32, or rounded to f16 (`Precision::Float16`). Back-face culling applies to meshes
//!    flagged `closed` only: the paper's occluders are closed characters, and culling an open,
//!    one-sided mesh (a quad, a fence, a ground plane) seen from behind would drop it entirely.
//!    `layered = false` is the naive single-layer warping of Figure 4 (left): only the nearest
//!    fragment of each source texel.
//! 3. **Depth-map rendering** (section 3.2, Listing 2). Every point is projected into each target
//!    view, snapped to the texel that contains it, and written by an atomic minimum on the bit
//!    pattern of its (positive) linear depth, which orders like the float. One traversal of the
//!    points writes one map (`Parallel::Serial`), `views_per_pass` maps (`Partial`) or all of them
//!    (`Full`). `Mode::Unbuffered` streams the source rasterizer's fragments straight into the
//!    maps without the point buffer (Figure 3), rasterizing the source once per traversal. The
//!    minimum does not depend on the order of the writes, so the maps (and the result) are the same
//!    for every mode, pass size and thread count.
//! 4. **Lighting**: the PCF shadow test on every map and the weighted average, as in `mvr`, with
//!    its depth bias ([`SLACK`](crate::raster::pcf::SLACK)). A texel keeps the nearest point
//!    anywhere inside it rather than the surface's depth at its center, so at the same bias the
//!    occluders shadow themselves more than under `mvr` (the self-shadowing of section 5.1).

#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(not(feature = "gpu"))]
#[path = "no_gpu.rs"]
pub mod gpu;

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::gpu::multiview::Lighting;
use crate::interrupt;
use crate::light::lights::{Light, Shape};
use crate::light::sampling::SampleSet;
use crate::limits::{self, Peak};
use crate::methods::mvr::{shared_eyes, MultiViewOptions};
use crate::raster::cube;
use crate::raster::depth::{
    casters, raster_peak, raster_work, rasterize_depth, Caster, DepthMap, FaceFilter, RasterMode,
    RasterOptions, Rasterizer,
};
use crate::raster::frustum::check_resolution;
use crate::raster::frustum::{LightFrustum, TexelRect, MAX_RESOLUTION, NEAR_FRACTION};
use crate::raster::multiview::{accumulate, resolve, ViewSet};
use crate::stats::Stats;
use glam::Vec3;
use gpu::Warper;
use half::f16;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};

/// Whether points go through an intermediate buffer (section 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// Rasterize once into a point buffer, then warp the buffer (Figure 2).
    #[default]
    Buffered,
    /// Warp the source rasterizer's fragments directly, once per traversal (Figure 3).
    Unbuffered,
}

/// How many depth maps one traversal of the points writes (section 3.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Parallel {
    /// One map per traversal.
    Serial,
    /// `views_per_pass` maps per traversal.
    #[default]
    Partial,
    /// Every map in one traversal.
    Full,
}

/// Storage of the buffered points' world positions (section 3.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Precision {
    #[default]
    Float32,
    Float16,
}

/// How the source view of section 3.1 is sized.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SourceView {
    /// Pulled back just far enough to contain the actual light samples, with `z_n` of eq. 3 the
    /// nearest occluder's depth (see the module doc).
    #[default]
    Fitted,
    /// Equations 1–3 as printed: `d` from the light's width and height (along the views' axes)
    /// and the views' field of view, `z_n` the light-sample views' near plane (Listing 1's
    /// `nearZ`).
    Paper,
}

/// Options of [`vwss`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VwssOptions {
    /// Target depth maps and lighting (resolution, PCF taps, bias), as in `mvr`.
    pub multiview: MultiViewOptions,
    pub mode: Mode,
    pub parallel: Parallel,
    /// Maps per traversal with [`Parallel::Partial`] (default 8, Listing 2).
    pub views_per_pass: usize,
    /// Cull the back faces of closed meshes (default true; false keeps back faces too).
    pub cull_backfaces: bool,
    /// Keep every fragment along each source ray (true, the method) or only the nearest (false:
    /// naive single-layer warping, for comparison).
    pub layered: bool,
    pub precision: Precision,
    pub source_view: SourceView,
    /// Points per target texel at depth `z_n` (default 2; see the module doc).
    pub point_density: f32,
    /// Source-view side in texels; `None` scales the target resolution by eq. 3 and
    /// `point_density`.
    pub source_resolution: Option<usize>,
}

impl Default for VwssOptions {
    fn default() -> Self {
        Self {
            multiview: MultiViewOptions::default(),
            mode: Mode::Buffered,
            parallel: Parallel::Partial,
            views_per_pass: 8,
            cull_backfaces: true,
            layered: true,
            precision: Precision::Float32,
            source_view: SourceView::Fitted,
            point_density: 2.0,
            source_resolution: None,
        }
    }
}

impl VwssOptions {
    fn validate(&self) -> Result<()> {
        if self.views_per_pass == 0 {
            return Err(Error::invalid("views_per_pass", "must be >= 1"));
        }
        if !(self.point_density.is_finite() && self.point_density > 0.0) {
            return Err(Error::invalid(
                "point_density",
                format!("must be finite and > 0, got {}", self.point_density),
            ));
        }
        if let Some(r) = self.source_resolution {
            check_resolution("source_resolution", r)?;
        }
        if self.mode == Mode::Unbuffered && !self.layered {
            return Err(Error::invalid(
                "layered",
                "single-layer warping needs the source depth test: use mode='buffered'",
            ));
        }
        if self.mode == Mode::Unbuffered && self.multiview.backend == Backend::Gpu {
            return Err(Error::unsupported(
                "mode",
                "the GPU warps a point buffer: use mode='buffered' with backend='gpu'",
            ));
        }
        if self.mode == Mode::Unbuffered && self.precision == Precision::Float16 {
            return Err(Error::invalid(
                "precision",
                "unbuffered mode stores no points: float16 applies to mode='buffered'",
            ));
        }
        Ok(())
    }

    /// Maps written per traversal for `views` views.
    fn maps_per_traversal(&self, views: usize) -> usize {
        match self.parallel {
            Parallel::Serial => 1,
            Parallel::Partial => self.views_per_pass.min(views),
            Parallel::Full => views,
        }
    }

    fn raster_options(&self) -> RasterOptions {
        let faces = if self.cull_backfaces {
            FaceFilter::FrontFacingIfClosed
        } else {
            FaceFilter::All
        };
        RasterOptions {
            mode: RasterMode::Standard,
            faces,
            alpha_test: true,
        }
    }
}

/// The largest eq. 3 scale of the source resolution (a memory guard; see the module doc).
pub const MAX_SOURCE_SCALE: f32 = 8.0;
/// The nearest occluder depth eq. 3 assumes, as a fraction of the receivers' nearest depth.
const MIN_OCCLUDER_FRACTION: f32 = 0.05;

/// The source view of section 3.1: the light-sample views' shape with the eye pulled back so its
/// frustum contains all of them (eq. 1–2) and the resolution of eq. 3 with `opts.point_density`
/// (or `opts.source_resolution`), sized as `opts.source_view` says.
pub fn source_view(
    scene: &Scene,
    light: &Light,
    views: &ViewSet,
    opts: &VwssOptions,
) -> Result<LightFrustum> {
    let v0 = views.views[0];
    let center = light.center();
    let offsets: Vec<Vec3> = views
        .views
        .iter()
        .map(|v| v0.to_view(v.eye) - v0.to_view(center))
        .collect();
    let tan = v0.tan_half_x;
    let pull_back = match opts.source_view {
        SourceView::Fitted => offsets
            .iter()
            .map(|o| o.x.abs().max(o.y.abs()) / tan - o.z)
            .fold(0.0f32, f32::max),
        SourceView::Paper => paper_pull_back(light, &v0)?,
    };
    let eye = center - v0.forward * pull_back;
    let nearest_sample = offsets.iter().map(|o| o.z).fold(f32::INFINITY, f32::min);
    let farthest_sample = offsets
        .iter()
        .map(|o| o.z)
        .fold(f32::NEG_INFINITY, f32::max);
    let near = (pull_back + nearest_sample).max(0.0) + v0.near;
    let far = v0.far + pull_back + farthest_sample.max(0.0);
    let resolution = match opts.source_resolution {
        Some(r) => r,
        None => {
            let z_n = match opts.source_view {
                SourceView::Fitted => {
                    let receivers_near = v0.near / NEAR_FRACTION;
                    nearest_occluder(scene, eye, v0.forward, v0.right, v0.up, tan, pull_back)
                        .unwrap_or(receivers_near)
                        .max(MIN_OCCLUDER_FRACTION * receivers_near)
                }
                SourceView::Paper => v0.near,
            };
            let scale = (opts.point_density.sqrt() * (z_n + pull_back) / z_n).min(MAX_SOURCE_SCALE);
            ((v0.width as f32 * scale).ceil() as usize).min(MAX_RESOLUTION)
        }
    };
    LightFrustum::from_axes(
        eye,
        v0.forward,
        v0.up,
        tan,
        tan,
        near,
        far.max(near * 2.0),
        resolution,
        resolution,
    )
}

/// `d` of eq. 1, `max(l_w, l_h) / (2 tan(fov / 2))`, for views of half-angle tangent `tan`
/// (square, so the larger of the two fields of view is either). `l_w` and `l_h` are the light's
/// extents along the views' `right` and `up` axes: its width and height when, as in the paper,
/// the views are aligned with its edges. The equation is written for planar lights facing along
/// the views.
fn paper_pull_back(light: &Light, view: &LightFrustum) -> Result<f32> {
    if matches!(light.shape, Shape::Sphere { .. } | Shape::Ellipsoid { .. }) {
        return Err(Error::invalid(
            "source_view",
            "equation 1 is written for planar lights (width and height); for a sphere or \
             ellipsoid light use source_view='fitted', which contains every light sample",
        ));
    }
    let largest_side = 2.0
        * light
            .half_extent_along(view.right)
            .max(light.half_extent_along(view.up));
    Ok(largest_side / (2.0 * view.tan_half_x))
}

/// The depth beyond the light's center (along `forward`) of the nearest scene vertex inside the
/// source pyramid and in front of the light, if any: `z_n` of eq. 3.
fn nearest_occluder(
    scene: &Scene,
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    tan: f32,
    pull_back: f32,
) -> Option<f32> {
    scene
        .meshes
        .par_iter()
        .flat_map_iter(|m| m.positions.iter())
        .filter_map(|&p| {
            let d = p - eye;
            let z = d.dot(forward);
            let inside =
                z > pull_back && d.dot(right).abs() <= tan * z && d.dot(up).abs() <= tan * z;
            inside.then_some(z - pull_back)
        })
        .reduce_with(f32::min)
}

/// The multi-view point cloud of section 3.1.
#[derive(Debug, Clone)]
pub enum Points {
    Float32(Vec<Vec3>),
    Float16(Vec<[f16; 3]>),
}

impl Points {
    /// The number of points.
    pub fn len(&self) -> usize {
        match self {
            Points::Float32(p) => p.len(),
            Points::Float16(p) => p.len(),
        }
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every point's world position, in order.
    pub fn iter(&self) -> Box<dyn ExactSizeIterator<Item = Vec3> + '_> {
        match self {
            Points::Float32(p) => Box::new(p.iter().copied()),
            Points::Float16(p) => Box::new(
                p.iter()
                    .map(|q| Vec3::new(q[0].to_f32(), q[1].to_f32(), q[2].to_f32())),
            ),
        }
    }

    /// Visits every point's world position, in parallel chunks.
    fn par_for_each(&self, visit: impl Fn(Vec3) + Sync) {
        const CHUNK: usize = 4096;
        match self {
            Points::Float32(p) => p
                .par_chunks(CHUNK)
                .for_each(|c| c.iter().for_each(|&q| visit(q))),
            Points::Float16(p) => p.par_chunks(CHUNK).for_each(|c| {
                c.iter()
                    .for_each(|q| visit(Vec3::new(q[0].to_f32(), q[1].to_f32(), q[2].to_f32())))
            }),
        }
    }
}

/// Triangles per parallel work item of the source rasterization.
const CASTER_CHUNK: usize = 256;

/// The memory of [`generate_points`]: the points (12 bytes each, 6 more for their f16 copy) at an
/// upper bound of their number: the source map's texels, whose rasterization it also holds; or,
/// layered, the triangles' texel bounds summed, twice (the per-chunk vectors and their
/// concatenation), with the triangles' set-up.
pub fn points_peak(scene: &Scene, source: &LightFrustum, opts: &VwssOptions) -> Result<Peak> {
    let f16_copy = match opts.precision {
        Precision::Float32 => 0,
        Precision::Float16 => 6,
    };
    if !opts.layered {
        return Ok(raster_peak(scene, source.width, source.height).buffer(&[
            source.width as u64,
            source.height as u64,
            12 + f16_copy,
        ]));
    }
    let raster = Rasterizer::new(source, RasterMode::Standard)?;
    let bound: u64 = casters(scene, &opts.raster_options(), source.eye)
        .par_iter()
        .filter_map(|c| raster.bounds(&c.vertices))
        .map(|r| ((r.x1 - r.x0) * (r.y1 - r.y0)) as u64)
        .sum();
    Ok(Peak::default()
        .buffer(&[bound, 2 * 12 + f16_copy])
        .buffer(&[scene.num_faces() as u64, 96]))
}

/// Rasterizes `source` and returns the points of section 3.1 (see the module documentation).
///
/// Errors: `TooLarge` when the points could exceed the memory limit ([`points_peak`], estimated
/// before rasterizing).
pub fn generate_points(scene: &Scene, source: &LightFrustum, opts: &VwssOptions) -> Result<Points> {
    limits::check_memory(
        "vwss point buffer",
        points_peak(scene, source, opts)?.bytes(),
    )?;
    let world: Vec<Vec3> = if opts.layered {
        let raster = Rasterizer::new(source, RasterMode::Standard)?;
        let casters = casters(scene, &opts.raster_options(), source.eye);
        let full = TexelRect::full(source.width, source.height);
        let chunks: Vec<Vec<Vec3>> = casters
            .par_chunks(CASTER_CHUNK)
            .map(|chunk| {
                let mut out = Vec::new();
                for caster in chunk {
                    raster.opaque_fragments(scene, caster, full, |f| {
                        out.push(source.texel_center(f.x, f.y, f.depth))
                    });
                }
                out
            })
            .collect();
        chunks.concat()
    } else {
        let map = rasterize_depth(scene, source, &opts.raster_options())?;
        (0..map.depth.len())
            .filter(|&i| map.depth[i].is_finite())
            .map(|i| source.texel_center(i % map.width, i / map.width, map.depth[i]))
            .collect()
    };
    Ok(match opts.precision {
        Precision::Float32 => Points::Float32(world),
        Precision::Float16 => Points::Float16(
            world
                .iter()
                .map(|p| p.to_array().map(f16::from_f32))
                .collect(),
        ),
    })
}

/// Depth maps under construction, allocated once and reused by every traversal: atomic texel
/// arrays (bit patterns of positive linear depths, `+inf` where nothing landed).
struct AtomicMaps {
    texels: Vec<Vec<AtomicU32>>,
}

impl AtomicMaps {
    /// `count` maps of `texels` texels each, after checking their memory (and that of the plain
    /// maps they are copied into) against the limit.
    fn new(count: usize, texels: usize) -> Result<Self> {
        limits::check_memory(
            "vwss depth maps",
            limits::bytes(&[count as u64, texels as u64, 8]),
        )?;
        let texels = (0..count)
            .map(|_| {
                (0..texels)
                    .map(|_| AtomicU32::new(f32::INFINITY.to_bits()))
                    .collect()
            })
            .collect();
        Ok(Self { texels })
    }

    /// Empties the first `count` maps.
    fn clear(&self, count: usize) {
        let empty = f32::INFINITY.to_bits();
        self.texels[..count]
            .par_iter()
            .for_each(|t| t.iter().for_each(|a| a.store(empty, Ordering::Relaxed)));
    }

    /// Projects world point `p` into every view, snaps it to the texel containing it and keeps
    /// the minimum depth there (Listing 2).
    #[inline]
    fn splat(&self, views: &[LightFrustum], p: Vec3) {
        for (view, texels) in views.iter().zip(&self.texels) {
            if let Some((x, y, depth)) = view.texel_of(p) {
                texels[y * view.width + x].fetch_min(depth.to_bits(), Ordering::Relaxed);
            }
        }
    }

    /// Copies the first `out.len()` maps into `out`.
    fn copy_into(&self, out: &mut [DepthMap]) {
        out.par_iter_mut()
            .zip(&self.texels)
            .for_each(|(map, texels)| {
                map.depth
                    .iter_mut()
                    .zip(texels)
                    .for_each(|(d, a)| *d = f32::from_bits(a.load(Ordering::Relaxed)));
            });
    }
}

/// One traversal's source of world points: the buffer, or the source rasterizer (unbuffered).
enum PointSource<'a> {
    Buffer(&'a Points),
    Raster {
        scene: &'a Scene,
        source: &'a LightFrustum,
        opts: &'a VwssOptions,
    },
}

impl PointSource<'_> {
    /// Splats every point into `views`; returns the number of points.
    fn warp(&self, maps: &AtomicMaps, views: &[LightFrustum]) -> Result<usize> {
        match self {
            PointSource::Buffer(points) => {
                points.par_for_each(|p| maps.splat(views, p));
                Ok(points.len())
            }
            PointSource::Raster {
                scene,
                source,
                opts,
            } => {
                let raster = Rasterizer::new(source, RasterMode::Standard)?;
                let casters: Vec<Caster> = casters(scene, &opts.raster_options(), source.eye);
                let full = TexelRect::full(source.width, source.height);
                Ok(casters
                    .par_chunks(CASTER_CHUNK)
                    .map(|chunk| {
                        let mut count = 0;
                        for caster in chunk {
                            raster.opaque_fragments(scene, caster, full, |f| {
                                count += 1;
                                maps.splat(views, source.texel_center(f.x, f.y, f.depth));
                            });
                        }
                        count
                    })
                    .sum())
            }
        }
    }
}

fn warp_once(source: PointSource<'_>, views: &[LightFrustum]) -> Result<(Vec<DepthMap>, usize)> {
    let texels = views.first().map_or(0, |v| v.width * v.height);
    let maps = AtomicMaps::new(views.len(), texels)?;
    let count = source.warp(&maps, views)?;
    let mut out: Vec<DepthMap> = views
        .iter()
        .map(|v| DepthMap::empty(v.width, v.height))
        .collect::<Result<_>>()?;
    maps.copy_into(&mut out);
    Ok((out, count))
}

/// Warps every point into each of `views` (one traversal) and returns their depth maps.
pub fn warp_points(points: &Points, views: &[LightFrustum]) -> Result<Vec<DepthMap>> {
    Ok(warp_once(PointSource::Buffer(points), views)?.0)
}

/// Rasterizes `source` and warps each fragment straight into `views` (unbuffered, Figure 3);
/// returns the maps and the number of fragments.
pub fn warp_fragments(
    scene: &Scene,
    source: &LightFrustum,
    opts: &VwssOptions,
    views: &[LightFrustum],
) -> Result<(Vec<DepthMap>, usize)> {
    warp_once(
        PointSource::Raster {
            scene,
            source,
            opts,
        },
        views,
    )
}

/// The stats keys every call returns (beside [`crate::stats::COMMON`]), zeroed at the start:
/// the one declaration the Python docstring and the key tests read.
pub const STATS: &[&str] = &[
    "point_generation_seconds",
    "depth_maps_seconds",
    "lighting_seconds",
    "points",
    "point_warps",
    "traversals",
    "maps_per_traversal",
    "views",
    "resolution",
    "source_resolution",
    "pull_back",
];

/// Soft-shadow visibility of every receiver by view-warped multi-view soft shadows.
///
/// Returns the visibility (receivers' order) and stats as in the paper's Tables 1–2:
/// `point_generation_seconds` (0 when unbuffered), `depth_maps_seconds`, `lighting_seconds`,
/// `points` (buffered; the fragments streamed per traversal when unbuffered), `point_warps`
/// (points warped into a view's map, summed over the traversals), `maps_per_traversal`,
/// `traversals`, `views`, `resolution`, `source_resolution`, `pull_back` (`d` of eq. 1, world
/// units).
///
/// Errors: invalid options; rotated or interleaved samples; a light among the receivers (its
/// center or a sample inside or level with their bounds: no source view behind the light holds
/// them); `TooLarge` past the memory limit.
pub fn vwss(
    scene: &Scene,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &VwssOptions,
) -> Result<(Vec<f32>, Stats)> {
    let (kernel, bias) = opts.multiview.shadow_test()?;
    opts.validate()?;
    let eyes = shared_eyes(samples)?;
    let mut stats = Stats::declared(STATS);
    let per_pass = opts.maps_per_traversal(eyes.len());
    stats.set("maps_per_traversal", per_pass as f64);
    stats.set("views", eyes.len() as f64);
    stats.set("resolution", opts.multiview.resolution as f64);
    let Some(bounds) = receivers.bounds() else {
        return Ok((vec![0.0; receivers.len()], stats));
    };
    let Some(views) = ViewSet::fit(light, eyes, bounds, opts.multiview.resolution)? else {
        return Err(Error::unsupported(
            "light",
            format!(
                "vwss warps one source view into every light sample's view, its eye pulled back behind the \
                 light to contain them all (Marrs et al. 2018, section 3.1), and leaves omni-directional \
                 lights to future work (section 5.2); this light lies among the receivers, so no view from \
                 behind it holds them. {} handle a light among the receivers",
                cube::METHODS
            ),
        ));
    };
    let source = source_view(scene, light, &views, opts)?;
    stats.set("source_resolution", source.width as f64);
    stats.set(
        "pull_back",
        f64::from((light.center() - source.eye).dot(source.forward)),
    );
    let side = opts.multiview.resolution;
    // The sums and the visibility, the atomic and plain maps of one traversal, and the points
    // (streamed when unbuffered: only the triangles' set-up).
    let points_peak = match opts.mode {
        Mode::Buffered => points_peak(scene, &source, opts)?,
        Mode::Unbuffered => Peak::default().buffer(&[scene.num_faces() as u64, 96]),
    };
    Peak::default()
        .buffer(&[receivers.len() as u64, 4 + 4])
        .buffer(&[per_pass as u64, side as u64, side as u64, 4 + 4])
        .and(points_peak)
        .check("vwss", &mut stats)?;
    // Every source point warped into every view's map, after the source view is rasterized.
    opts.multiview
        .lighting_work(views.views.len(), receivers.len())
        .loop_of(&[
            views.views.len() as u64,
            source.width as u64,
            source.height as u64,
        ])
        .and(raster_work(scene, source.width, source.height))
        .check("vwss", &mut stats)?;
    let points = match opts.mode {
        Mode::Buffered => {
            Some(stats.time("point_generation", || generate_points(scene, &source, opts))?)
        }
        Mode::Unbuffered => None,
    };
    let point_source = match &points {
        Some(p) => PointSource::Buffer(p),
        None => PointSource::Raster {
            scene,
            source: &source,
            opts,
        },
    };
    let sums = match (opts.multiview.backend, &points) {
        (Backend::Gpu, Some(points)) => {
            let warper = stats.time_add("depth_maps", || Warper::new(points.iter()))?;
            let lighting =
                stats.time_add("lighting", || Lighting::new(receivers, &kernel, bias))?;
            for (targets, weights) in views
                .views
                .chunks(per_pass)
                .zip(views.weights.chunks(per_pass))
            {
                interrupt::check()?;
                let (warp, light) = warper.warp_and_light(targets, weights, &lighting)?;
                stats.add("depth_maps_seconds", warp);
                stats.add("lighting_seconds", light);
                stats.set("points", points.len() as f64);
                stats.add("point_warps", (points.len() * targets.len()) as f64);
                stats.add("traversals", 1.0);
            }
            stats.time_add("lighting", || lighting.sums())?
        }
        _ => {
            let atomic = AtomicMaps::new(per_pass, side * side)?;
            let mut maps: Vec<DepthMap> = (0..per_pass)
                .map(|_| DepthMap::empty(side, side))
                .collect::<Result<_>>()?;
            let mut sums = vec![0.0f32; receivers.len()];
            for (pass, targets) in views.views.chunks(per_pass).enumerate() {
                interrupt::check()?;
                let count = stats.time_add("depth_maps", || {
                    atomic.clear(targets.len());
                    let count = point_source.warp(&atomic, targets)?;
                    atomic.copy_into(&mut maps[..targets.len()]);
                    Ok::<_, Error>(count)
                })?;
                stats.set("points", count as f64);
                stats.add("point_warps", (count * targets.len()) as f64);
                stats.add("traversals", 1.0);
                let indexed: Vec<(usize, &DepthMap)> = maps[..targets.len()]
                    .iter()
                    .enumerate()
                    .map(|(k, m)| (pass * per_pass + k, m))
                    .collect();
                stats.time_add("lighting", || {
                    accumulate(&mut sums, &views, &indexed, receivers, &kernel, bias)
                });
            }
            sums
        }
    };
    Ok((resolve(&sums, views.total_weight(), receivers), stats))
}
