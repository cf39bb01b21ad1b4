//! Light frusta: the perspective light cameras every image-based method renders from or looks
//! up in, and their fitting to the receivers' bounds.
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

use crate::error::{Error, Result};
use crate::light::lights::Light;
use glam::Vec3;

/// The largest map side in texels accepted by a frustum.
pub const MAX_RESOLUTION: usize = 1 << 16;
/// [`LightFrustum::fit`] puts the near plane at this fraction of the nearest receiver depth.
pub const NEAR_FRACTION: f32 = 1e-3;
/// [`LightFrustum::fit`] widens the tangent of the half field of view by this factor.
pub const FOV_MARGIN: f32 = 1.01;
/// [`LightFrustum::fit`] refuses frusta whose tangent of half field of view exceeds this (89.94°).
pub const MAX_FIT_TAN: f32 = 1e3;

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
    /// `Unsupported("light")` when no frustum of the candidates narrower than 179.9° holds the box
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
                return Err(Error::unsupported(
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
        self.forward + self.right * self.ray_x(sx) + self.up * self.ray_y(sy)
    }

    /// The `right` component of [`LightFrustum::texel_ray`] at texel coordinate `sx`.
    fn ray_x(&self, sx: f32) -> f32 {
        (2.0 * sx / self.width as f32 - 1.0) * self.tan_half_x
    }

    /// The `up` component of [`LightFrustum::texel_ray`] at texel coordinate `sy`.
    fn ray_y(&self, sy: f32) -> f32 {
        (1.0 - 2.0 * sy / self.height as f32) * self.tan_half_y
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

/// The rays through the corners of a map's texel grid (integer texel coordinates `0..=columns` by
/// `0..=rows`, which may reach past the map: a coarse pyramid level's last texel overhangs a map
/// whose side is not a multiple of its size), computed once for code that unprojects many texel
/// corners: a part per column corner and one per row corner, which [`GridRays::unproject`] adds in
/// [`LightFrustum::texel_ray`]'s order, so that it gives the same bits as
/// [`LightFrustum::unproject`] with no division.
#[derive(Debug, Clone)]
pub struct GridRays {
    eye: Vec3,
    /// `forward + right * x` per column corner `x`.
    columns: Vec<Vec3>,
    /// `up * y` per row corner `y`.
    rows: Vec<Vec3>,
}

impl GridRays {
    /// The rays through the corners `0..=columns` by `0..=rows` of `f`'s texel grid.
    pub fn new(f: &LightFrustum, columns: usize, rows: usize) -> Self {
        Self {
            eye: f.eye,
            columns: (0..=columns)
                .map(|x| f.forward + f.right * f.ray_x(x as f32))
                .collect(),
            rows: (0..=rows).map(|y| f.up * f.ray_y(y as f32)).collect(),
        }
    }

    /// The world point at texel corner `(x, y)` and linear depth `depth`.
    #[inline]
    pub fn unproject(&self, x: usize, y: usize, depth: f32) -> Vec3 {
        self.eye + (self.columns[x] + self.rows[y]) * depth
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
