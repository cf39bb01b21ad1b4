//! Light frusta and triangle rasterization of linear depth: the machinery every image-based
//! method (shadow maps, alias-free shadow maps, CSSM, backprojection, VWSS, MVR, PCSS) stands on.
//!
//! # Conventions
//!
//! - **Light view space**: origin at the frustum's `eye`; orthonormal axes `right`, `up`,
//!   `forward` with `right = forward × up` (right-handed, like an OpenGL camera looking down
//!   `forward`). A point `p` has view coordinates `((p−eye)·right, (p−eye)·up, (p−eye)·forward)`.
//! - **Linear depth** is the view-space z: the distance along `forward` (not the Euclidean distance
//!   to the eye), in world units. Every map here stores linear depth, so precision is uniform in
//!   relative terms and the near plane only matters for clipping.
//! - **Texel space**: continuous coordinates `(sx, sy)`; `sx` grows along `right`, `sy` along `−up`
//!   (row 0 is the top of the light's view, as in images):
//!   `sx = width/2 · (1 + vx / (vz · tan_half_x))`, `sy = height/2 · (1 − vy / (vz · tan_half_y))`.
//!   Texel `(x, y)` covers `[x, x+1) × [y, y+1)`; its center is `(x + 0.5, y + 0.5)`.
//! - **Maps** are row-major (`y * width + x`); `+inf` marks texels nothing was drawn into.
//!
//! # Rasterization
//!
//! A triangle is transformed to view space (f64), culled when all its vertices lie outside one
//! side plane of the frustum or beyond `far` (casters behind every receiver shadow nothing), and
//! clipped (Sutherland–Hodgman) against `z >= near` and against a guard band 65536 texels beyond
//! each map edge (which keeps fixed-point coordinates in range; it never changes a texel of the
//! map). Clip points are computed from the inside vertex to the outside one, so two triangles that
//! share an edge get bit-identical clip points. Depth is perspective-correct: `1/z` is an affine
//! function of `(sx, sy)`, taken from the *unclipped* triangle's plane, `1/z = (n·r(sx, sy)) / (n·v0)`.
//!
//! - [`RasterMode::Standard`]: a texel is drawn when its center lies inside the triangle, with the
//!   top-left fill rule (a center exactly on an edge belongs to the triangle whose edge is a top or
//!   left edge), evaluated exactly on vertices snapped to 1/256 texel with i64 edge functions, so
//!   two triangles sharing an edge draw each texel center on it exactly once and a closed mesh
//!   leaves no cracks. Depth: the plane's depth at the texel center.
//! - [`RasterMode::Conservative`]: a texel is drawn when the (clipped, unsnapped) triangle overlaps
//!   its closed square at all (separating-axis test in f64, widened by 1/1000 texel against
//!   round-off, so the result is a superset of the exact overlap and of `Standard`). Depth: the
//!   minimum of the plane's depth over the texel square (the largest `1/z` at its four corners),
//!   clamped to the clipped triangle's depth range. This never exceeds the true minimum depth of
//!   the triangle within the texel, so a shadow test `receiver_depth > stored_depth` can only
//!   err towards "occluded" (conservative for occluder culling and list building).
//! - Triangles of zero projected area (edge-on to the eye) draw nothing in either mode, matching a
//!   ray tracer where such a triangle blocks no ray.
//!
//! The alpha test (perforated meshes) evaluates perspective-correct barycentrics at the texel
//! center (extrapolated outside the triangle in conservative mode; at the texel corner nearest the
//! eye where the center lies beyond the plane's horizon) and drops texels where
//! [`Scene::is_opaque_at`] is false.
//!
//! [`rasterize_depth`] runs bands of rows in parallel with rayon, each band rasterizing the
//! triangles whose texel bounds overlap it; min-depth is order-independent, so the map is identical
//! for every thread count.

use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::light::lights::Light;
use crate::limits::{self, Peak, Work};
use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;

/// The largest map side in texels accepted by a frustum.
pub const MAX_RESOLUTION: usize = 1 << 16;
/// [`LightFrustum::fit`] puts the near plane at this fraction of the nearest receiver depth.
pub const NEAR_FRACTION: f32 = 1e-3;
/// [`LightFrustum::fit`] widens the tangent of the half field of view by this factor.
pub const FOV_MARGIN: f32 = 1.01;
/// [`LightFrustum::fit`] refuses frusta whose tangent of half field of view exceeds this (89.94°).
pub const MAX_FIT_TAN: f32 = 1e3;
/// Guard band beyond each map edge, in texels (bounds the fixed-point coordinates).
const GUARD_TEXELS: f64 = 65536.0;
/// Fixed-point subdivisions of a texel for standard rasterization.
const SUBPIXEL: i64 = 256;
/// Widening of conservative coverage, in texels, against floating-point round-off.
const CONSERVATIVE_SLACK: f64 = 1e-3;
/// Vertices of a triangle clipped against five planes (one more per plane at most).
const MAX_POLY: usize = 8;

/// A perspective light camera. Build it with [`LightFrustum::new`], [`LightFrustum::fit`],
/// [`LightFrustum::for_light`] or [`LightFrustum::from_axes`], which validate and orthonormalize;
/// functions taking a frustum call [`LightFrustum::validate`] first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightFrustum {
    /// Center of projection, world units.
    pub eye: Vec3,
    /// Unit view direction (view-space +z).
    pub forward: Vec3,
    /// Unit view-space +x (texel x grows along it).
    pub right: Vec3,
    /// Unit view-space +y (texel y grows along `-up`).
    pub up: Vec3,
    /// Tangent of half the horizontal field of view (> 0).
    pub tan_half_x: f32,
    /// Tangent of half the vertical field of view (> 0).
    pub tan_half_y: f32,
    /// Near clipping plane, linear depth (> 0). Geometry closer to the eye is clipped away.
    pub near: f32,
    /// Far plane, linear depth (> near). Triangles entirely beyond it are culled (not clipped).
    pub far: f32,
    /// Map width in texels.
    pub width: usize,
    /// Map height in texels.
    pub height: usize,
}

fn finite3(arg: &str, v: Vec3) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Error::invalid(arg, format!("must be finite, got {v}")))
    }
}

/// Refuses a map side outside 1..=[`MAX_RESOLUTION`] texels, naming `arg`.
pub fn check_resolution(arg: &str, n: usize) -> Result<()> {
    if (1..=MAX_RESOLUTION).contains(&n) {
        Ok(())
    } else {
        Err(Error::invalid(
            arg,
            format!("must be in 1..={MAX_RESOLUTION} texels, got {n}"),
        ))
    }
}

/// An orthonormal `(right, up)` for `forward`, keeping `up` close to world +Y (or +Z when
/// `forward` is nearly vertical).
fn default_up(forward: Vec3) -> Vec3 {
    if forward.y.abs() < 0.9 {
        Vec3::Y
    } else {
        Vec3::Z
    }
}

impl LightFrustum {
    /// A frustum from an eye, a view direction and an up hint.
    ///
    /// Parameters
    /// ----------
    /// eye : center of projection (world units).
    /// forward : view direction, any non-zero length.
    /// up : up hint, not parallel to `forward`; it is orthonormalized (`right = forward × up`).
    /// tan_half_x, tan_half_y : tangents of the half fields of view (> 0, anisotropy allowed).
    /// near, far : linear depths, `0 < near < far`.
    /// width, height : map size in texels, 1..=[`MAX_RESOLUTION`].
    #[allow(clippy::too_many_arguments)]
    pub fn from_axes(
        eye: Vec3,
        forward: Vec3,
        up: Vec3,
        tan_half_x: f32,
        tan_half_y: f32,
        near: f32,
        far: f32,
        width: usize,
        height: usize,
    ) -> Result<Self> {
        finite3("eye", eye)?;
        finite3("forward", forward)?;
        finite3("up", up)?;
        let forward = forward.normalize_or_zero();
        if forward == Vec3::ZERO {
            return Err(Error::invalid(
                "forward",
                "the view direction has zero length (target == eye?)",
            ));
        }
        let right = forward.cross(up).normalize_or_zero();
        if right == Vec3::ZERO {
            return Err(Error::invalid(
                "up",
                format!("must not be parallel to the view direction {forward}"),
            ));
        }
        let up = right.cross(forward);
        let f = Self {
            eye,
            forward,
            right,
            up,
            tan_half_x,
            tan_half_y,
            near,
            far,
            width,
            height,
        };
        f.validate()?;
        Ok(f)
    }

    /// An explicit frustum looking from `eye` at `target`.
    ///
    /// Parameters
    /// ----------
    /// fov_y_degrees : full vertical field of view in degrees, in (0, 180).
    /// aspect : `tan_half_x / tan_half_y` (width over height of the image plane), > 0.
    /// Other parameters as in [`LightFrustum::from_axes`].
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov_y_degrees: f32,
        aspect: f32,
        near: f32,
        far: f32,
        width: usize,
        height: usize,
    ) -> Result<Self> {
        if fov_y_degrees.is_nan() || fov_y_degrees <= 0.0 || fov_y_degrees >= 180.0 {
            return Err(Error::invalid(
                "fov_y",
                format!("must be in (0, 180) degrees, got {fov_y_degrees}"),
            ));
        }
        if !(aspect.is_finite() && aspect > 0.0) {
            return Err(Error::invalid(
                "aspect",
                format!("must be finite and > 0, got {aspect}"),
            ));
        }
        finite3("target", target)?;
        let tan_y = (0.5 * fov_y_degrees).to_radians().tan();
        Self::from_axes(
            eye,
            target - eye,
            up,
            tan_y * aspect,
            tan_y,
            near,
            far,
            width,
            height,
        )
    }

    /// Fits a square frustum from `eye` to the box `[points_min, points_max]` (the receivers'
    /// bounds).
    ///
    /// The view direction is the one, among the direction to the box center, the mean of the unit
    /// directions to the 8 corners and the axis directions towards the box, that needs the
    /// smallest square field of view; the field of view contains all 8 corners (so the whole box)
    /// with the margin [`FOV_MARGIN`]. `near` is [`NEAR_FRACTION`] times the nearest corner's
    /// linear depth (the box's nearest depth; casters closer to the eye than that are clipped),
    /// `far` the farthest corner's linear depth plus 0.1%. Planar area lights are not pulled back
    /// here: this is a frustum for a point at `eye` (later methods move the eye themselves).
    ///
    /// Errors
    /// ------
    /// `InvalidInput("light")` when no frustum of the candidates narrower than 179.9° holds the box
    /// (`eye` inside it, on it, or within ~0.06° of its plane): pass an explicit frustum
    /// ([`LightFrustum::new`]) that covers the receivers of interest instead.
    pub fn fit(eye: Vec3, points_min: Vec3, points_max: Vec3, resolution: usize) -> Result<Self> {
        Self::fit_with_up(eye, points_min, points_max, resolution, None)
    }

    /// [`LightFrustum::fit`] with the map's `up` axis as close as possible to `up` (when it is
    /// not parallel to the chosen view direction) instead of world +Y.
    pub fn fit_with_up(
        eye: Vec3,
        points_min: Vec3,
        points_max: Vec3,
        resolution: usize,
        up: Option<Vec3>,
    ) -> Result<Self> {
        finite3("eye", eye)?;
        finite3("points_min", points_min)?;
        finite3("points_max", points_max)?;
        if points_min.cmpgt(points_max).any() {
            return Err(Error::invalid(
                "points_min",
                format!("{points_min} exceeds points_max {points_max}"),
            ));
        }
        check_resolution("resolution", resolution)?;
        let corners: [Vec3; 8] = std::array::from_fn(|i| {
            Vec3::select(
                glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0),
                points_max,
                points_min,
            )
        });
        let best = fit_candidates(eye, points_min, points_max, &corners)
            .into_iter()
            .filter_map(|f| square_fit(eye, f, up, &corners))
            .min_by(|a, b| a.tan.total_cmp(&b.tan));
        let fit = match best {
            Some(fit) if fit.tan <= MAX_FIT_TAN => fit,
            _ => {
                return Err(Error::invalid(
                    "light",
                    format!(
                        "no light frustum from {eye} (under 179.9 degrees wide) holds the receivers' bounding \
                         box {points_min}..{points_max}: the light lies among the receivers. {} handle a light \
                         among the receivers (a frustum per face of a cube around it, crate::raster::cube); \
                         or pass an explicit frustum made with LightFrustum::new",
                        crate::raster::cube::METHODS
                    ),
                ))
            }
        };
        let tan = (fit.tan * FOV_MARGIN).max(1e-4);
        let near = NEAR_FRACTION * fit.z_min;
        let far = (fit.z_max * 1.001).max(near * 2.0);
        Self::from_axes(
            eye,
            fit.forward,
            fit.up,
            tan,
            tan,
            near,
            far,
            resolution,
            resolution,
        )
    }

    /// [`LightFrustum::fit`] from the light's center (a point light's position; the center of an
    /// area or sphere light) to `bounds = (min, max)`.
    pub fn for_light(light: &Light, bounds: (Vec3, Vec3), resolution: usize) -> Result<Self> {
        Self::fit(light.center(), bounds.0, bounds.1, resolution)
    }

    /// [`LightFrustum::for_light`] with the map's axes turned towards a rectangular light's edges
    /// (`up` along its `v`), so that its footprint in the map is nearly an axis-aligned rectangle:
    /// for methods that filter over the light's footprint with boxes (`cssm`, `pcss`).
    pub fn for_light_aligned(
        light: &Light,
        bounds: (Vec3, Vec3),
        resolution: usize,
    ) -> Result<Self> {
        let up = match light.shape {
            crate::light::lights::Shape::Rect { v, .. } => Some(v),
            _ => None,
        };
        Self::fit_with_up(light.center(), bounds.0, bounds.1, resolution, up)
    }

    /// Checks the invariants the rasterizer relies on (finite, orthonormal axes, positive
    /// tangents, `0 < near < far`, sizes in 1..=[`MAX_RESOLUTION`]).
    pub fn validate(&self) -> Result<()> {
        finite3("eye", self.eye)?;
        let axes = [self.forward, self.right, self.up];
        let ortho = axes
            .iter()
            .all(|a| a.is_finite() && (a.length() - 1.0).abs() < 1e-4)
            && self.forward.dot(self.right).abs() < 1e-4
            && self.forward.dot(self.up).abs() < 1e-4
            && self.right.dot(self.up).abs() < 1e-4;
        if !ortho {
            return Err(Error::invalid(
                "frustum",
                "forward, right and up must be orthonormal",
            ));
        }
        for (arg, t) in [
            ("tan_half_x", self.tan_half_x),
            ("tan_half_y", self.tan_half_y),
        ] {
            if !(t.is_finite() && t > 0.0) {
                return Err(Error::invalid(
                    arg,
                    format!("must be finite and > 0, got {t}"),
                ));
            }
        }
        if !(self.near.is_finite()
            && self.far.is_finite()
            && self.near > 0.0
            && self.far > self.near)
        {
            return Err(Error::invalid(
                "near",
                format!(
                    "need 0 < near < far, got near={} far={}",
                    self.near, self.far
                ),
            ));
        }
        check_resolution("width", self.width)?;
        check_resolution("height", self.height)
    }

    /// View-space coordinates `(x, y, linear depth)` of world point `p`.
    pub fn to_view(&self, p: Vec3) -> Vec3 {
        let d = p - self.eye;
        Vec3::new(d.dot(self.right), d.dot(self.up), d.dot(self.forward))
    }

    /// `(sx, sy, depth)`: continuous texel coordinates and linear depth of `p`, or `None` when `p`
    /// lies closer than `near` (or behind the eye). Points outside the map are returned too: check
    /// `0 <= sx < width`, `0 <= sy < height` (or use [`LightFrustum::texel_of`]).
    pub fn project(&self, p: Vec3) -> Option<Vec3> {
        let v = self.to_view(p);
        if v.z.is_nan() || v.z < self.near {
            return None;
        }
        let sx = 0.5 * self.width as f32 * (1.0 + v.x / (v.z * self.tan_half_x));
        let sy = 0.5 * self.height as f32 * (1.0 - v.y / (v.z * self.tan_half_y));
        Some(Vec3::new(sx, sy, v.z))
    }

    /// The texel `(x, y)` containing `p` and its linear depth; `None` when `p` is nearer than
    /// `near` or projects outside the map.
    pub fn texel_of(&self, p: Vec3) -> Option<(usize, usize, f32)> {
        let s = self.project(p)?;
        let inside =
            s.x >= 0.0 && s.y >= 0.0 && s.x < self.width as f32 && s.y < self.height as f32;
        inside.then(|| {
            (
                (s.x as usize).min(self.width - 1),
                (s.y as usize).min(self.height - 1),
                s.z,
            )
        })
    }

    /// World direction through texel coordinates `(sx, sy)`, scaled so that its `forward`
    /// component is 1: `eye + texel_ray(sx, sy) * depth` lies at linear depth `depth`.
    pub fn texel_ray(&self, sx: f32, sy: f32) -> Vec3 {
        let x = (2.0 * sx / self.width as f32 - 1.0) * self.tan_half_x;
        let y = (1.0 - 2.0 * sy / self.height as f32) * self.tan_half_y;
        self.forward + self.right * x + self.up * y
    }

    /// The world point at texel coordinates `(sx, sy)` and linear depth `depth` (inverse of
    /// [`LightFrustum::project`]).
    pub fn unproject(&self, sx: f32, sy: f32, depth: f32) -> Vec3 {
        self.eye + self.texel_ray(sx, sy) * depth
    }

    /// The four corners of the map at the far plane (world points, clockwise from the top left
    /// texel's corner as the light sees it).
    pub fn far_corners(&self) -> [Vec3; 4] {
        let (w, h) = (self.width as f32, self.height as f32);
        [(0.0, 0.0), (w, 0.0), (w, h), (0.0, h)].map(|(x, y)| self.unproject(x, y, self.far))
    }

    /// The world point at the center of texel `(x, y)` at linear depth `depth`.
    pub fn texel_center(&self, x: usize, y: usize, depth: f32) -> Vec3 {
        self.unproject(x as f32 + 0.5, y as f32 + 0.5, depth)
    }

    /// The larger side of a texel's footprint on the plane at linear depth `depth` (world units):
    /// `2 · depth · max(tan_half_x / width, tan_half_y / height)`.
    pub fn texel_world_size(&self, depth: f32) -> f32 {
        2.0 * depth
            * (self.tan_half_x / self.width as f32).max(self.tan_half_y / self.height as f32)
    }
}

/// A candidate square fit: direction, orthonormal up, tangent and depth range of the corners.
struct SquareFit {
    forward: Vec3,
    up: Vec3,
    tan: f32,
    z_min: f32,
    z_max: f32,
}

fn fit_candidates(eye: Vec3, lo: Vec3, hi: Vec3, corners: &[Vec3; 8]) -> Vec<Vec3> {
    let mut dirs = vec![
        (lo + hi) * 0.5 - eye,
        corners.iter().map(|c| (*c - eye).normalize_or_zero()).sum(),
    ];
    for axis in 0..3 {
        let mut d = Vec3::ZERO;
        if eye[axis] > hi[axis] {
            d[axis] = -1.0;
        } else if eye[axis] < lo[axis] {
            d[axis] = 1.0;
        }
        if d != Vec3::ZERO {
            dirs.push(d);
        }
    }
    dirs.into_iter()
        .map(|d| d.normalize_or_zero())
        .filter(|d| *d != Vec3::ZERO)
        .collect()
}

fn square_fit(
    eye: Vec3,
    forward: Vec3,
    up: Option<Vec3>,
    corners: &[Vec3; 8],
) -> Option<SquareFit> {
    let hint = up
        .filter(|u| u.normalize_or_zero().cross(forward).length() > 0.1)
        .unwrap_or_else(|| default_up(forward));
    let right = forward.cross(hint).normalize_or_zero();
    let up = right.cross(forward);
    let (mut tan, mut z_min, mut z_max) = (0.0f32, f32::INFINITY, 0.0f32);
    let scale = corners
        .iter()
        .map(|c| (*c - eye).length())
        .fold(0.0f32, f32::max);
    for c in corners {
        let d = *c - eye;
        let z = d.dot(forward);
        if z.is_nan() || z <= 1e-6 * scale {
            return None;
        }
        tan = tan.max(d.dot(right).abs() / z).max(d.dot(up).abs() / z);
        z_min = z_min.min(z);
        z_max = z_max.max(z);
    }
    Some(SquareFit {
        forward,
        up,
        tan,
        z_min,
        z_max,
    })
}

/// A half-open rectangle of texels `[x0, x1) × [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TexelRect {
    pub x0: usize,
    pub y0: usize,
    pub x1: usize,
    pub y1: usize,
}

impl TexelRect {
    /// The whole `width × height` map.
    pub fn full(width: usize, height: usize) -> Self {
        Self {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// Whether the rectangle holds no texel.
    pub fn is_empty(&self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    /// The intersection of two rectangles (possibly empty).
    pub fn intersect(&self, o: &TexelRect) -> TexelRect {
        TexelRect {
            x0: self.x0.max(o.x0),
            y0: self.y0.max(o.y0),
            x1: self.x1.min(o.x1),
            y1: self.y1.min(o.y1),
        }
    }
}

/// Which texels a triangle covers (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RasterMode {
    /// Texel centers inside the triangle, top-left fill rule; depth at the center.
    #[default]
    Standard,
    /// Every texel the triangle touches; the minimum depth over the texel (conservative).
    Conservative,
}

/// Which triangles are drawn, by their facing as seen from the frustum's eye. A triangle
/// `(a, b, c)` is *front-facing* when its normal `(b−a) × (c−a)` points towards the eye
/// (`n · (eye − a) > 0`), back-facing when `n · (eye − a) < 0`; edge-on triangles are neither.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FaceFilter {
    /// Every triangle.
    #[default]
    All,
    /// Only triangles facing the eye.
    FrontFacing,
    /// Only triangles facing away from the eye.
    BackFacing,
    /// Back-facing triangles of meshes flagged `closed`, every triangle of the other meshes (a
    /// closed caster's back faces suffice and need no depth bias, Sintorn et al. 2008).
    BackFacingIfClosed,
    /// Front-facing triangles of meshes flagged `closed`, every triangle of the other meshes
    /// (back-face culling that keeps open, one-sided meshes such as quads and planes).
    FrontFacingIfClosed,
}

impl FaceFilter {
    /// Whether triangle `tri` (global face `id` of `scene`) passes the filter for a given eye.
    pub fn keeps(&self, scene: &Scene, id: u32, tri: &[Vec3; 3], eye: Vec3) -> bool {
        let facing = || {
            let [a, b, c] = tri.map(|v| v.as_dvec3());
            (b - a).cross(c - a).dot(eye.as_dvec3() - a)
        };
        match self {
            FaceFilter::All => true,
            FaceFilter::FrontFacing => facing() > 0.0,
            FaceFilter::BackFacing => facing() < 0.0,
            FaceFilter::BackFacingIfClosed => !scene.is_closed_face(id) || facing() < 0.0,
            FaceFilter::FrontFacingIfClosed => !scene.is_closed_face(id) || facing() > 0.0,
        }
    }
}

/// Options of [`rasterize_depth`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RasterOptions {
    /// Coverage and depth rule (default [`RasterMode::Standard`]).
    pub mode: RasterMode,
    /// Which faces are drawn (default [`FaceFilter::All`]).
    pub faces: FaceFilter,
    /// Drop texels where a perforated mesh is transparent (default true).
    pub alpha_test: bool,
}

impl Default for RasterOptions {
    fn default() -> Self {
        Self {
            mode: RasterMode::Standard,
            faces: FaceFilter::All,
            alpha_test: true,
        }
    }
}

/// A map of linear depth (world units along the frustum's `forward`), `+inf` where nothing was
/// drawn; row-major, texel `(x, y)` at `y * width + x`.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthMap {
    pub width: usize,
    pub height: usize,
    pub depth: Vec<f32>,
    /// Fragments that passed coverage and alpha tests while the map was drawn (before the depth
    /// test; a texel covered by k triangles counts k times).
    pub fragments: u64,
}

impl DepthMap {
    /// An empty (`+inf`) map, after checking its memory against the limit.
    pub fn empty(width: usize, height: usize) -> Result<Self> {
        limits::check_memory(
            "depth map",
            limits::bytes(&[width as u64, height as u64, 4]),
        )?;
        Ok(Self {
            width,
            height,
            depth: vec![f32::INFINITY; width * height],
            fragments: 0,
        })
    }

    /// The depth at texel `(x, y)`; `+inf` outside the map.
    #[inline]
    pub fn get(&self, x: i64, y: i64) -> f32 {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return f32::INFINITY;
        }
        self.depth[y as usize * self.width + x as usize]
    }

    /// How many texels hold a finite depth.
    pub fn drawn_texels(&self) -> usize {
        self.depth.iter().filter(|d| d.is_finite()).count()
    }
}

/// An affine function `a·sx + b·sy + c` of texel coordinates.
#[derive(Debug, Clone, Copy)]
struct Affine {
    a: f64,
    b: f64,
    c: f64,
}

impl Affine {
    #[inline]
    fn eval(&self, sx: f64, sy: f64) -> f64 {
        self.a * sx + self.b * sy + self.c
    }
}

/// The view-space ↔ texel-space map in f64: `sx = cx + kx·x/z`, `sy = cy − ky·y/z`.
#[derive(Debug, Clone, Copy)]
struct Screen {
    kx: f64,
    ky: f64,
    cx: f64,
    cy: f64,
}

impl Screen {
    fn new(f: &LightFrustum) -> Self {
        let (w, h) = (f.width as f64, f.height as f64);
        Self {
            kx: w / (2.0 * f.tan_half_x as f64),
            ky: h / (2.0 * f.tan_half_y as f64),
            cx: 0.5 * w,
            cy: 0.5 * h,
        }
    }

    #[inline]
    fn project(&self, v: DVec3) -> DVec2 {
        DVec2::new(
            self.cx + self.kx * (v.x / v.z),
            self.cy - self.ky * (v.y / v.z),
        )
    }

    /// `r(sx, sy)`: the view-space ray with z = 1 through texel coordinates `(sx, sy)`; `g · r` as
    /// an affine function of `(sx, sy)`.
    fn dot_ray(&self, g: DVec3) -> Affine {
        Affine {
            a: g.x / self.kx,
            b: -g.y / self.ky,
            c: g.z - g.x * self.cx / self.kx + g.y * self.cy / self.ky,
        }
    }
}

/// A view-space half-space `n · v >= off`.
#[derive(Debug, Clone, Copy)]
struct Plane {
    n: DVec3,
    off: f64,
}

impl Plane {
    #[inline]
    fn dist(&self, v: DVec3) -> f64 {
        self.n.dot(v) - self.off
    }
}

/// A convex polygon of at most [`MAX_POLY`] view-space vertices.
#[derive(Debug, Clone, Copy)]
struct Poly {
    v: [DVec3; MAX_POLY],
    n: usize,
}

impl Poly {
    fn clip(&self, pl: &Plane) -> Poly {
        let mut out = Poly {
            v: [DVec3::ZERO; MAX_POLY],
            n: 0,
        };
        for i in 0..self.n {
            let (a, b) = (self.v[i], self.v[(i + 1) % self.n]);
            let (da, db) = (pl.dist(a), pl.dist(b));
            // A convex polygon clipped by one plane gains at most one vertex, and at most five
            // planes clip a triangle, so `out.n < MAX_POLY` holds at every push.
            if da >= 0.0 {
                out.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                // From the inside vertex to the outside one: identical for both triangles of an edge.
                let (i_v, o_v, di, dout) = if da >= 0.0 {
                    (a, b, da, db)
                } else {
                    (b, a, db, da)
                };
                out.push(i_v + (o_v - i_v) * (di / (di - dout)));
            }
        }
        out
    }

    #[inline]
    fn push(&mut self, v: DVec3) {
        if self.n < MAX_POLY {
            self.v[self.n] = v;
            self.n += 1;
        }
    }
}

/// Everything a triangle's texels need: depth and barycentric planes, clipped screen polygon.
#[derive(Debug, Clone)]
struct Setup {
    /// `1/z` over texel space.
    inv_z: Affine,
    /// `b_k = z · g_k(sx, sy) − off_k` (perspective-correct barycentrics of vertices 1 and 2).
    g1: Affine,
    off1: f64,
    g2: Affine,
    off2: f64,
    z_min: f64,
    z_max: f64,
    pts: [DVec2; MAX_POLY],
    n: usize,
}

impl Setup {
    /// Texel bounds `(x0, y0, x1, y1)` inclusive of every texel the polygon may touch.
    fn bounds(&self) -> (i64, i64, i64, i64) {
        let pts = &self.pts[..self.n];
        let lo = pts.iter().fold(DVec2::INFINITY, |m, p| m.min(*p));
        let hi = pts.iter().fold(DVec2::NEG_INFINITY, |m, p| m.max(*p));
        let s = CONSERVATIVE_SLACK;
        (
            (lo.x - 1.0 - s).ceil() as i64,
            (lo.y - 1.0 - s).ceil() as i64,
            (hi.x + s).floor() as i64,
            (hi.y + s).floor() as i64,
        )
    }

    fn fragment(&self, x: i64, y: i64, conservative: bool) -> Fragment<'_> {
        let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
        let center = self.inv_z.eval(cx, cy);
        let corner_gain = 0.5 * (self.inv_z.a.abs() + self.inv_z.b.abs());
        let inv = if conservative {
            center + corner_gain
        } else {
            center
        };
        let depth = if inv > 0.0 {
            (1.0 / inv).clamp(self.z_min, self.z_max)
        } else {
            self.z_min
        };
        let (px, py) = if conservative && center <= 0.0 {
            (
                cx + 0.5f64.copysign(self.inv_z.a),
                cy + 0.5f64.copysign(self.inv_z.b),
            )
        } else {
            (cx, cy)
        };
        Fragment {
            x: x as usize,
            y: y as usize,
            depth: depth as f32,
            px,
            py,
            setup: self,
        }
    }
}

/// One texel drawn by a triangle.
#[derive(Debug, Clone, Copy)]
pub struct Fragment<'a> {
    /// Texel column.
    pub x: usize,
    /// Texel row.
    pub y: usize,
    /// Linear depth (see [`RasterMode`] for the rule of each mode).
    pub depth: f32,
    px: f64,
    py: f64,
    setup: &'a Setup,
}

impl Fragment<'_> {
    /// Perspective-correct barycentrics `(b1, b2)` (weights of the triangle's vertices 1 and 2, as
    /// [`Scene::is_opaque_at`] takes them) at the texel center, extrapolated where the center lies
    /// outside the triangle (conservative mode).
    pub fn barycentrics(&self) -> (f32, f32) {
        let s = self.setup;
        let inv = s.inv_z.eval(self.px, self.py);
        if inv.is_nan() || inv <= 0.0 {
            return (1.0 / 3.0, 1.0 / 3.0);
        }
        let z = 1.0 / inv;
        let b1 = z * s.g1.eval(self.px, self.py) - s.off1;
        let b2 = z * s.g2.eval(self.px, self.py) - s.off2;
        (b1 as f32, b2 as f32)
    }
}

/// Which texels of a bounding box a triangle covers.
trait Coverage {
    /// Inclusive texel bounds.
    fn bounds(&self) -> (i64, i64, i64, i64);
    fn covers(&self, x: i64, y: i64) -> bool;
}

/// A triangle snapped to 1/[`SUBPIXEL`] texel with exact integer edge functions (standard mode).
struct SnappedTriangle {
    ax: [i64; 3],
    ay: [i64; 3],
    dx: [i64; 3],
    dy: [i64; 3],
    /// 0 for a top or left edge (a center on it is inside), 1 otherwise.
    bias: [i64; 3],
}

impl SnappedTriangle {
    /// `None` for a triangle of zero snapped area.
    fn new(p: [DVec2; 3]) -> Option<Self> {
        let snap = |t: f64| (t * SUBPIXEL as f64).round() as i64;
        let mut x = p.map(|q| snap(q.x));
        let mut y = p.map(|q| snap(q.y));
        let area = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
        if area == 0 {
            return None;
        }
        if area < 0 {
            x.swap(1, 2);
            y.swap(1, 2);
        }
        let dx: [i64; 3] = std::array::from_fn(|i| x[(i + 1) % 3] - x[i]);
        let dy: [i64; 3] = std::array::from_fn(|i| y[(i + 1) % 3] - y[i]);
        // With rows growing downwards and a positive orientation, the interior lies to the right
        // of a left edge (dy < 0) and below a top edge (dy == 0, dx > 0).
        let bias = std::array::from_fn(|i| i64::from(!(dy[i] < 0 || (dy[i] == 0 && dx[i] > 0))));
        Some(Self {
            ax: x,
            ay: y,
            dx,
            dy,
            bias,
        })
    }
}

impl Coverage for SnappedTriangle {
    fn bounds(&self) -> (i64, i64, i64, i64) {
        let (h, s) = (SUBPIXEL / 2, SUBPIXEL);
        let (xmin, xmax) = (self.ax.iter().min(), self.ax.iter().max());
        let (ymin, ymax) = (self.ay.iter().min(), self.ay.iter().max());
        match (xmin, xmax, ymin, ymax) {
            (Some(&x0), Some(&x1), Some(&y0), Some(&y1)) => (
                (x0 - h + s - 1).div_euclid(s),
                (y0 - h + s - 1).div_euclid(s),
                (x1 - h).div_euclid(s),
                (y1 - h).div_euclid(s),
            ),
            _ => (0, 0, -1, -1),
        }
    }

    #[inline]
    fn covers(&self, x: i64, y: i64) -> bool {
        let (px, py) = (x * SUBPIXEL + SUBPIXEL / 2, y * SUBPIXEL + SUBPIXEL / 2);
        (0..3).all(|i| {
            self.dx[i] * (py - self.ay[i]) - self.dy[i] * (px - self.ax[i]) >= self.bias[i]
        })
    }
}

/// A convex polygon with f64 edge functions widened to whole texel squares (conservative mode).
struct ConservativePolygon {
    /// Edge `i`: `nx·px + ny·py + c + reach >= 0` at a texel center means the square touches it.
    nx: [f64; MAX_POLY],
    ny: [f64; MAX_POLY],
    c: [f64; MAX_POLY],
    reach: [f64; MAX_POLY],
    n: usize,
    bounds: (i64, i64, i64, i64),
}

impl ConservativePolygon {
    /// `None` for a polygon of zero area.
    fn new(s: &Setup) -> Option<Self> {
        let p = &s.pts[..s.n];
        let area: f64 = (0..s.n).map(|i| p[i].perp_dot(p[(i + 1) % s.n])).sum();
        if area == 0.0 || !area.is_finite() {
            return None;
        }
        let sign = area.signum();
        let mut poly = Self {
            nx: [0.0; MAX_POLY],
            ny: [0.0; MAX_POLY],
            c: [0.0; MAX_POLY],
            reach: [0.0; MAX_POLY],
            n: s.n,
            bounds: s.bounds(),
        };
        for i in 0..s.n {
            let (a, b) = (p[i], p[(i + 1) % s.n]);
            let (nx, ny) = (-sign * (b.y - a.y), sign * (b.x - a.x));
            poly.nx[i] = nx;
            poly.ny[i] = ny;
            poly.c[i] = -(nx * a.x + ny * a.y);
            poly.reach[i] = (nx.abs() + ny.abs()) * (0.5 + CONSERVATIVE_SLACK);
        }
        Some(poly)
    }
}

impl Coverage for ConservativePolygon {
    fn bounds(&self) -> (i64, i64, i64, i64) {
        self.bounds
    }

    #[inline]
    fn covers(&self, x: i64, y: i64) -> bool {
        let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
        (0..self.n).all(|i| self.nx[i] * px + self.ny[i] * py + self.c[i] + self.reach[i] >= 0.0)
    }
}

/// A rasterizer bound to one frustum and mode: the reusable core of every depth, ID or list buffer.
///
/// ```
/// use glam::Vec3;
/// use softshadows_core::raster::depth::{LightFrustum, RasterMode, Rasterizer, TexelRect};
/// let f = LightFrustum::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 90.0, 1.0, 0.1, 10.0, 64, 64)?;
/// let r = Rasterizer::new(&f, RasterMode::Conservative)?;
/// let tri = [Vec3::new(-1.0, -1.0, -2.0), Vec3::new(1.0, -1.0, -2.0), Vec3::new(0.0, 1.0, -2.0)];
/// let mut lists = vec![Vec::new(); 64 * 64]; // e.g. per-texel triangle lists
/// r.triangle(&tri, TexelRect::full(64, 64), |frag| lists[frag.y * 64 + frag.x].push(7u32));
/// assert!(lists[32 * 64 + 32] == [7]);
/// # Ok::<(), softshadows_core::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Rasterizer {
    frustum: LightFrustum,
    mode: RasterMode,
    screen: Screen,
    /// near, then the four guard-band planes.
    clip: [Plane; 5],
    /// The four side planes of the map (with a hair of margin), for culling.
    sides: [Plane; 4],
}

impl Rasterizer {
    /// Validates `frustum` and precomputes its planes.
    pub fn new(frustum: &LightFrustum, mode: RasterMode) -> Result<Self> {
        frustum.validate()?;
        let (tx, ty) = (frustum.tan_half_x as f64, frustum.tan_half_y as f64);
        let gx = tx * (1.0 + 2.0 * GUARD_TEXELS / frustum.width as f64);
        let gy = ty * (1.0 + 2.0 * GUARD_TEXELS / frustum.height as f64);
        let side = |kx: f64, ky: f64, t: f64| Plane {
            n: DVec3::new(kx, ky, t),
            off: 0.0,
        };
        let clip = [
            Plane {
                n: DVec3::Z,
                off: frustum.near as f64,
            },
            side(1.0, 0.0, gx),
            side(-1.0, 0.0, gx),
            side(0.0, 1.0, gy),
            side(0.0, -1.0, gy),
        ];
        let m = 1.0 + 1e-6;
        let sides = [
            side(1.0, 0.0, tx * m),
            side(-1.0, 0.0, tx * m),
            side(0.0, 1.0, ty * m),
            side(0.0, -1.0, ty * m),
        ];
        Ok(Self {
            frustum: *frustum,
            mode,
            screen: Screen::new(frustum),
            clip,
            sides,
        })
    }

    /// The frustum this rasterizer draws into.
    pub fn frustum(&self) -> &LightFrustum {
        &self.frustum
    }

    /// The mode this rasterizer draws with.
    pub fn mode(&self) -> RasterMode {
        self.mode
    }

    fn view(&self, p: Vec3) -> DVec3 {
        let f = &self.frustum;
        let d = p.as_dvec3() - f.eye.as_dvec3();
        DVec3::new(
            d.dot(f.right.as_dvec3()),
            d.dot(f.up.as_dvec3()),
            d.dot(f.forward.as_dvec3()),
        )
    }

    /// Culls, clips and sets up a triangle; `None` when it cannot draw anything.
    fn setup(&self, tri: &[Vec3; 3]) -> Option<Setup> {
        let v = tri.map(|p| self.view(p));
        let far = self.frustum.far as f64;
        if v.iter().all(|p| p.z > far)
            || self
                .sides
                .iter()
                .any(|pl| v.iter().all(|p| pl.dist(*p) < 0.0))
        {
            return None;
        }
        let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
        let n = e1.cross(e2);
        let (d, nn) = (n.dot(v[0]), n.length_squared());
        if d == 0.0 || nn == 0.0 || !d.is_finite() {
            return None;
        }
        let mut poly = Poly {
            v: [DVec3::ZERO; MAX_POLY],
            n: 3,
        };
        poly.v[..3].copy_from_slice(&v);
        for pl in &self.clip {
            if poly.v[..poly.n].iter().any(|p| pl.dist(*p) < 0.0) {
                poly = poly.clip(pl);
                if poly.n < 3 {
                    return None;
                }
            }
        }
        let mut pts = [DVec2::ZERO; MAX_POLY];
        let (mut z_min, mut z_max) = (f64::INFINITY, 0.0f64);
        for (q, p) in pts.iter_mut().zip(&poly.v[..poly.n]) {
            *q = self.screen.project(*p);
            z_min = z_min.min(p.z);
            z_max = z_max.max(p.z);
        }
        // Why: clipping interpolates in f64, so when `near` is tiny next to the triangle (a light
        // almost touching a receiver) a clipped vertex can round to z <= 0 and project to ±inf or
        // NaN, which overflowed the fixed-point snapping (found by fuzzing). Every exact clipped
        // vertex lies inside the guard band: clamp to it, and drop a polygon with a NaN vertex.
        if pts[..poly.n].iter().any(|q| q.is_nan()) {
            return None;
        }
        let band = DVec2::splat(GUARD_TEXELS + 1.0);
        let size = DVec2::new(self.frustum.width as f64, self.frustum.height as f64);
        pts[..poly.n]
            .iter_mut()
            .for_each(|q| *q = q.clamp(-band, size + band));
        let (g1, g2) = (e2.cross(n) / nn, n.cross(e1) / nn);
        Some(Setup {
            inv_z: self.screen.dot_ray(n / d),
            g1: self.screen.dot_ray(g1),
            off1: v[0].dot(g1),
            g2: self.screen.dot_ray(g2),
            off2: v[0].dot(g2),
            z_min,
            z_max,
            pts,
            n: poly.n,
        })
    }

    /// The texels of the map the triangle may draw (a superset, exact up to one texel), or `None`
    /// when it draws nothing (culled, clipped away, edge-on). Cheap: for binning.
    pub fn bounds(&self, tri: &[Vec3; 3]) -> Option<TexelRect> {
        let s = self.setup(tri)?;
        let r = clamp_bounds(
            s.bounds(),
            &TexelRect::full(self.frustum.width, self.frustum.height),
        );
        (!r.is_empty()).then_some(r)
    }

    /// Calls `visit` once per texel of `region ∩ map` that the triangle draws (texels within the
    /// region in row-major order; in standard mode a triangle clipped into a polygon is drawn as
    /// a fan, still once per texel).
    pub fn triangle(
        &self,
        tri: &[Vec3; 3],
        region: TexelRect,
        mut visit: impl FnMut(Fragment<'_>),
    ) {
        let Some(s) = self.setup(tri) else { return };
        let region = region.intersect(&TexelRect::full(self.frustum.width, self.frustum.height));
        if region.is_empty() {
            return;
        }
        match self.mode {
            RasterMode::Standard => {
                for k in 1..s.n - 1 {
                    if let Some(t) = SnappedTriangle::new([s.pts[0], s.pts[k], s.pts[k + 1]]) {
                        traverse(&t, &s, &region, false, &mut visit);
                    }
                }
            }
            RasterMode::Conservative => {
                if let Some(p) = ConservativePolygon::new(&s) {
                    traverse(&p, &s, &region, true, &mut visit);
                }
            }
        }
    }
}

/// Inclusive i64 bounds clamped into a half-open rectangle.
fn clamp_bounds((x0, y0, x1, y1): (i64, i64, i64, i64), r: &TexelRect) -> TexelRect {
    let cl = |v: i64, lo: usize, hi: usize| v.clamp(lo as i64, hi as i64) as usize;
    TexelRect {
        x0: cl(x0, r.x0, r.x1),
        y0: cl(y0, r.y0, r.y1),
        x1: cl(x1.saturating_add(1), r.x0, r.x1),
        y1: cl(y1.saturating_add(1), r.y0, r.y1),
    }
}

/// The one traversal both modes share: every texel of the clipped bounds that `cov` covers.
fn traverse<C: Coverage>(
    cov: &C,
    s: &Setup,
    region: &TexelRect,
    conservative: bool,
    visit: &mut impl FnMut(Fragment<'_>),
) {
    let r = clamp_bounds(cov.bounds(), region);
    for y in r.y0..r.y1 {
        for x in r.x0..r.x1 {
            if cov.covers(x as i64, y as i64) {
                visit(s.fragment(x as i64, y as i64, conservative));
            }
        }
    }
}

/// Rasterizes one triangle (convenience over [`Rasterizer`]; build a `Rasterizer` once to draw
/// many). Errors only for an invalid frustum.
pub fn rasterize_triangle(
    frustum: &LightFrustum,
    tri: &[Vec3; 3],
    mode: RasterMode,
    region: TexelRect,
    visit: impl FnMut(Fragment<'_>),
) -> Result<()> {
    Rasterizer::new(frustum, mode)?.triangle(tri, region, visit);
    Ok(())
}

/// A triangle to draw: global face id, world vertices, whether to alpha-test it (its mesh is
/// perforated and the alpha test is on).
pub type Caster = (u32, [Vec3; 3], bool);

/// The triangles of `scene` that pass `opts.faces` as seen from `eye`, in face order.
pub fn casters(scene: &Scene, opts: &RasterOptions, eye: Vec3) -> Vec<Caster> {
    scene
        .triangles()
        .filter(|(id, t)| opts.faces.keeps(scene, *id, t, eye))
        .map(|(id, t)| (id, t, opts.alpha_test && scene.is_perforated_face(id)))
        .collect()
}

impl Rasterizer {
    /// [`Rasterizer::triangle`] for a caster, dropping the fragments where its perforated mesh is
    /// transparent (when the caster is alpha-tested).
    pub fn opaque_fragments(
        &self,
        scene: &Scene,
        caster: &Caster,
        region: TexelRect,
        mut visit: impl FnMut(Fragment<'_>),
    ) {
        let (id, tri, alpha) = caster;
        self.triangle(tri, region, |f| {
            if *alpha {
                let (b1, b2) = f.barycentrics();
                if !scene.is_opaque_at(*id, b1, b2) {
                    return;
                }
            }
            visit(f);
        });
    }
}

/// The memory of [`rasterize_depth`] into a `width × height` map: the map and the triangles'
/// set-up and row bins (96 bytes per face).
pub fn raster_peak(scene: &Scene, width: usize, height: usize) -> Peak {
    Peak::default()
        .buffer(&[width as u64, height as u64, 4])
        .buffer(&[scene.num_faces() as u64, 96])
}

/// The work of [`rasterize_depth`] into a `width × height` map: each triangle set up, each
/// texel cleared and filled at least once.
pub fn raster_work(scene: &Scene, width: usize, height: usize) -> Work {
    Work::default()
        .loop_of(&[scene.num_faces() as u64, Work::TRIANGLE])
        .loop_of(&[width as u64, height as u64])
}

/// Rasterizes the linear depth of every triangle of `scene` that passes `opts.faces` into a
/// `frustum.width × frustum.height` map (minimum depth per texel, `+inf` where nothing was drawn),
/// alpha-testing perforated meshes when `opts.alpha_test`.
///
/// Errors: an invalid frustum; `TooLarge` when the map and triangle lists exceed the memory limit.
pub fn rasterize_depth(
    scene: &Scene,
    frustum: &LightFrustum,
    opts: &RasterOptions,
) -> Result<DepthMap> {
    let raster = Rasterizer::new(frustum, opts.mode)?;
    let (w, h) = (frustum.width, frustum.height);
    limits::check_memory("depth-map rasterization", raster_peak(scene, w, h).bytes())?;
    let mut map = DepthMap::empty(w, h)?;
    let casters = casters(scene, opts, frustum.eye);
    let band = band_rows(h);
    let bins = bin_rows(&raster, &casters, band, h.div_ceil(band));
    map.fragments = map
        .depth
        .par_chunks_mut(band * w)
        .zip(bins.par_iter())
        .enumerate()
        .map(|(b, (rows, bin))| draw_band(scene, &raster, &casters, bin, b * band, rows))
        .sum();
    Ok(map)
}

/// Rows per parallel band: a function of the height only, so work splits identically everywhere.
pub(crate) fn band_rows(height: usize) -> usize {
    (height / 64).clamp(8, 64)
}

/// For each band of `band` rows, the indices of the casters whose texel bounds reach it.
pub(crate) fn bin_rows(
    raster: &Rasterizer,
    casters: &[Caster],
    band: usize,
    bands: usize,
) -> Vec<Vec<u32>> {
    let rows: Vec<Option<(usize, usize)>> = casters
        .par_iter()
        .map(|(_, t, _)| raster.bounds(t).map(|r| (r.y0, r.y1)))
        .collect();
    bin_row_ranges(&rows, band, bands)
}

/// For each band of `band` rows, the indices of the items whose row range `[y0, y1)` (non-empty,
/// inside the map; `None`: no rows) reaches it.
pub(crate) fn bin_row_ranges(
    rows: &[Option<(usize, usize)>],
    band: usize,
    bands: usize,
) -> Vec<Vec<u32>> {
    let mut bins = vec![Vec::new(); bands];
    for (i, r) in rows.iter().enumerate() {
        if let Some((y0, y1)) = *r {
            for bin in &mut bins[y0 / band..=(y1 - 1) / band] {
                bin.push(i as u32);
            }
        }
    }
    bins
}

/// Draws the casters of one band into its rows (`rows` starts at map row `y0`); returns fragments.
fn draw_band(
    scene: &Scene,
    raster: &Rasterizer,
    casters: &[Caster],
    bin: &[u32],
    y0: usize,
    rows: &mut [f32],
) -> u64 {
    let w = raster.frustum.width;
    let region = TexelRect {
        x0: 0,
        y0,
        x1: w,
        y1: y0 + rows.len() / w,
    };
    let mut fragments = 0u64;
    for &i in bin {
        raster.opaque_fragments(scene, &casters[i as usize], region, |f| {
            fragments += 1;
            // The region keeps f.x < w and y0 <= f.y < y0 + rows.len() / w: the index is in range.
            let texel = &mut rows[(f.y - y0) * w + f.x];
            if f.depth < *texel {
                *texel = f.depth;
            }
        });
    }
    fragments
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fuzzing regression: a point light 1.4e-30 from its only receiver gets `near = 1e-33`;
    /// clipping a flat box (y = 0) seen edge-on rounded a vertex behind the eye, and its infinite
    /// projection overflowed the fixed-point snapping ("attempt to subtract with overflow").
    #[test]
    fn clipping_at_a_tiny_near_plane_stays_in_the_guard_band() {
        let eye = Vec3::new(-1e-30, -1e-30, 0.0);
        let f = LightFrustum::fit(eye, Vec3::ZERO, Vec3::ZERO, 59).unwrap();
        let corner = |i: usize| Vec3::new([-5.5, 6.5][i & 1], 0.0, [-6.0, 6.0][i >> 1 & 1]);
        let quads = [[0, 1, 3], [0, 3, 2], [0, 2, 3], [0, 3, 1]];
        for mode in [RasterMode::Standard, RasterMode::Conservative] {
            for q in quads {
                let tri = q.map(corner);
                rasterize_triangle(&f, &tri, mode, TexelRect::full(59, 59), |frag| {
                    assert!(frag.x < 59 && frag.y < 59)
                })
                .unwrap();
            }
        }
    }
}
