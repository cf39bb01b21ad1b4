//! Triangle rasterization of linear depth into a light frustum's map (conventions in
//! [`crate::raster::frustum`]): the machinery every image-based method (shadow maps, alias-free
//! shadow maps, CSSM, backprojection, VWSS, MVR, PCSS) stands on.
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

use crate::error::Result;
use crate::geometry::mesh::Scene;
use crate::limits::{self, Peak, Work};
use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;
use std::ops::Range;

use crate::geometry::polygon::{ClippedPolygon, MAX_CLIPPED};
use crate::raster::frustum::{LightFrustum, TexelRect};

/// Guard band beyond each map edge, in texels (bounds the fixed-point coordinates).
const GUARD_TEXELS: f64 = 65536.0;
/// Fixed-point subdivisions of a texel for standard rasterization.
const SUBPIXEL: i64 = 256;
/// Widening of conservative coverage, in texels, against floating-point round-off.
const CONSERVATIVE_SLACK: f64 = 1e-3;

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

/// Everything a triangle's texels need: depth and barycentric planes, clipped screen polygon.
#[derive(Debug, Clone)]
struct TriangleSetup {
    /// `1/z` over texel space.
    inv_z: Affine,
    /// `b_k = z · g_k(sx, sy) − off_k` (perspective-correct barycentrics of vertices 1 and 2).
    g1: Affine,
    off1: f64,
    g2: Affine,
    off2: f64,
    z_min: f64,
    z_max: f64,
    pts: [DVec2; MAX_CLIPPED],
    n: usize,
}

impl TriangleSetup {
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
    setup: &'a TriangleSetup,
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
    nx: [f64; MAX_CLIPPED],
    ny: [f64; MAX_CLIPPED],
    c: [f64; MAX_CLIPPED],
    reach: [f64; MAX_CLIPPED],
    n: usize,
    bounds: (i64, i64, i64, i64),
}

impl ConservativePolygon {
    /// `None` for a polygon of zero area.
    fn new(s: &TriangleSetup) -> Option<Self> {
        let p = &s.pts[..s.n];
        let area: f64 = (0..s.n).map(|i| p[i].perp_dot(p[(i + 1) % s.n])).sum();
        if area == 0.0 || !area.is_finite() {
            return None;
        }
        let sign = area.signum();
        let mut poly = Self {
            nx: [0.0; MAX_CLIPPED],
            ny: [0.0; MAX_CLIPPED],
            c: [0.0; MAX_CLIPPED],
            reach: [0.0; MAX_CLIPPED],
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
/// use softshadows_core::raster::depth::{RasterMode, Rasterizer};
/// use softshadows_core::raster::frustum::{LightFrustum, TexelRect};
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
    fn setup(&self, tri: &[Vec3; 3]) -> Option<TriangleSetup> {
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
        let mut poly = ClippedPolygon::triangle(v);
        for pl in &self.clip {
            if poly.vertices().iter().any(|p| pl.dist(*p) < 0.0) {
                poly = poly.clip(|p| pl.dist(p));
                if poly.vertices().len() < 3 {
                    return None;
                }
            }
        }
        let mut pts = [DVec2::ZERO; MAX_CLIPPED];
        let (mut z_min, mut z_max) = (f64::INFINITY, 0.0f64);
        for (q, p) in pts.iter_mut().zip(poly.vertices()) {
            *q = self.screen.project(*p);
            z_min = z_min.min(p.z);
            z_max = z_max.max(p.z);
        }
        // Why: clipping interpolates in f64, so when `near` is tiny next to the triangle (a light
        // almost touching a receiver) a clipped vertex can round to z <= 0 and project to ±inf or
        // NaN, which overflowed the fixed-point snapping (found by fuzzing). Every exact clipped
        // vertex lies inside the guard band: clamp to it, and drop a polygon with a NaN vertex.
        if pts[..poly.vertices().len()].iter().any(|q| q.is_nan()) {
            return None;
        }
        let band = DVec2::splat(GUARD_TEXELS + 1.0);
        let size = DVec2::new(self.frustum.width as f64, self.frustum.height as f64);
        pts[..poly.vertices().len()]
            .iter_mut()
            .for_each(|q| *q = q.clamp(-band, size + band));
        let (g1, g2) = (e2.cross(n) / nn, n.cross(e1) / nn);
        Some(TriangleSetup {
            inv_z: self.screen.dot_ray(n / d),
            g1: self.screen.dot_ray(g1),
            off1: v[0].dot(g1),
            g2: self.screen.dot_ray(g2),
            off2: v[0].dot(g2),
            z_min,
            z_max,
            pts,
            n: poly.vertices().len(),
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
    s: &TriangleSetup,
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

/// A triangle to draw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Caster {
    /// Global face id.
    pub face: u32,
    /// World-space vertices.
    pub vertices: [Vec3; 3],
    /// Whether to alpha-test it: its mesh is perforated and the alpha test is on.
    pub alpha_tested: bool,
}

/// The triangles of `scene` that pass `opts.faces` as seen from `eye`, in face order.
pub fn casters(scene: &Scene, opts: &RasterOptions, eye: Vec3) -> Vec<Caster> {
    scene
        .triangles()
        .filter(|(id, t)| opts.faces.keeps(scene, *id, t, eye))
        .map(|(face, vertices)| Caster {
            face,
            vertices,
            alpha_tested: opts.alpha_test && scene.is_perforated_face(face),
        })
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
        self.triangle(&caster.vertices, region, |f| {
            if caster.alpha_tested {
                let (b1, b2) = f.barycentrics();
                if !scene.is_opaque_at(caster.face, b1, b2) {
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
        // A job per band: the casters crowd a few neighbouring bands (see
        // `ReceiverLists::split_by_band`).
        .with_max_len(1)
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
        .map(|c| raster.bounds(&c.vertices).map(|r| (r.y0, r.y1)))
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
    let runs: Vec<Range<usize>> = (0..bands).map(|b| b * band..(b + 1) * band).collect();
    bin_to_runs(rows, &runs)
}

/// Cuts the rows `0..height` into at most `parts` runs of about equal work, a row's work being
/// how many of the half-open `row_ranges` (`None`: no rows) reach it.
pub(crate) fn balanced_runs(
    row_ranges: &[Option<(usize, usize)>],
    height: usize,
    parts: usize,
) -> Vec<Range<usize>> {
    let mut steps = vec![0i64; height + 1];
    for &(first, end) in row_ranges.iter().flatten() {
        steps[first] += 1;
        steps[end] -= 1;
    }
    let per_row: Vec<i64> = steps[..height]
        .iter()
        .scan(0, |open, step| {
            *open += step;
            Some(*open)
        })
        .collect();
    let total = per_row.iter().sum::<i64>().max(1);
    let (mut runs, mut start, mut done) = (Vec::new(), 0, 0);
    for (y, work) in per_row.iter().enumerate() {
        done += work;
        if done * parts as i64 >= (runs.len() as i64 + 1) * total && y + 1 < height {
            runs.push(start..y + 1);
            start = y + 1;
        }
    }
    runs.push(start..height);
    runs
}

/// For each run of rows of `runs` (consecutive, from row 0), the indices of the `row_ranges`
/// (half-open, `None`: no rows) that reach it.
pub(crate) fn bin_to_runs(
    row_ranges: &[Option<(usize, usize)>],
    runs: &[Range<usize>],
) -> Vec<Vec<u32>> {
    let starts: Vec<usize> = runs.iter().map(|r| r.start).collect();
    let mut bins = vec![Vec::new(); runs.len()];
    for (i, range) in row_ranges.iter().enumerate() {
        if let Some((first, end)) = *range {
            let from = starts.partition_point(|&s| s <= first) - 1;
            let to = starts.partition_point(|&s| s < end);
            for bin in &mut bins[from..to] {
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
    use crate::light::sampling::Rng;

    #[test]
    fn runs_of_rows_split_the_work_and_hold_every_range_that_reaches_them() {
        // Ranges crowded in a few rows, spread, of one row, none: the runs tile the rows, are at
        // most as many as asked, and each run's bin holds exactly the ranges that reach it.
        let mut rng = Rng::new(11);
        for (height, parts) in [(1usize, 4), (7, 3), (64, 8), (512, 8), (300, 1)] {
            let ranges: Vec<Option<(usize, usize)>> = (0..400)
                .map(|k| {
                    let first = match k % 3 {
                        0 => {
                            height / 2 + rng.below(height.div_ceil(8)).min(height - height / 2 - 1)
                        }
                        _ => rng.below(height),
                    };
                    (k % 7 != 0).then(|| (first, first + 1 + rng.below(height - first)))
                })
                .collect();
            let runs = balanced_runs(&ranges, height, parts);
            assert!(
                runs.len() <= parts && runs[0].start == 0 && runs[runs.len() - 1].end == height
            );
            assert!(runs
                .windows(2)
                .all(|w| w[0].end == w[1].start && !w[0].is_empty()));
            let bins = bin_to_runs(&ranges, &runs);
            for (run, bin) in runs.iter().zip(&bins) {
                let expected: Vec<u32> = (0..ranges.len() as u32)
                    .filter(|&i| {
                        ranges[i as usize].is_some_and(|(f, e)| f < run.end && run.start < e)
                    })
                    .collect();
                assert_eq!(bin, &expected, "{height} rows, run {run:?}");
            }
        }
    }

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
