//! Light shapes (`docs/design.md` section 2): point, rectangle, disk, volumetric sphere and volumetric
//! ellipsoid, with an optional emission texture on rectangles and disks (textured lights weight
//! their samples).
//!
//! Every light maps a point of the unit cube (its *parameter domain*, `dim()` coordinates used)
//! onto itself: rectangles by `center + (2s-1) u + (2t-1) v`, disks by Shirley's concentric map,
//! spheres by radius `R a^(1/3)` and a uniform direction, ellipsoids by their axes applied to the
//! unit ball's point (a linear map keeps volume-uniform points uniform), so uniform unit points
//! give uniform light points. Per-receiver decorrelation ([`Light::rotate`]) is a random rotation
//! about the symmetry axis for disks, a random 3D rotation for spheres (for ellipsoids, conjugated
//! by the axes: `A R A⁻¹` maps the ellipsoid onto itself and keeps volume), and a toroidal
//! (Cranley-Patterson) shift of the parameters for rectangles, where a geometric rotation would
//! leave the light.

use crate::error::{Error, Result};
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;

/// A nearest-texel emission texture over a light's parameter square: row `i` covers
/// t in [i/H, (i+1)/H), column `j` covers s in [j/W, (j+1)/W).
#[derive(Debug, Clone, PartialEq)]
pub struct EmissionTexture {
    width: usize,
    height: usize,
    values: Vec<f32>,
}

impl EmissionTexture {
    /// A texture of non-negative, finite values, not all zero.
    pub fn new(width: usize, height: usize, values: Vec<f32>) -> Result<Self> {
        if width == 0 || height == 0 || values.len() != width * height {
            return Err(Error::invalid(
                "emission",
                format!("expected a non-empty (H, W) array, got {height}x{width}"),
            ));
        }
        if values.iter().any(|v| !v.is_finite() || *v < 0.0) {
            return Err(Error::invalid("emission", "values must be finite and >= 0"));
        }
        if values.iter().all(|v| *v == 0.0) {
            return Err(Error::invalid(
                "emission",
                "all values are zero: the light emits nothing",
            ));
        }
        Ok(Self {
            width,
            height,
            values,
        })
    }

    /// The sampler of this texture's emission ([`EmissionWarp`]).
    fn warp(&self) -> EmissionWarp {
        let (w, h) = (self.width, self.height);
        let cumulative = |values: &mut dyn Iterator<Item = f64>| {
            let mut sum = 0.0;
            std::iter::once(0.0)
                .chain(values.map(|v| {
                    sum += v;
                    sum
                }))
                .collect::<Vec<f64>>()
        };
        let rows = cumulative(&mut (0..h).map(|i| {
            self.values[i * w..(i + 1) * w]
                .iter()
                .map(|&v| f64::from(v))
                .sum()
        }));
        let columns = (0..h)
            .flat_map(|i| {
                cumulative(
                    &mut self.values[i * w..(i + 1) * w]
                        .iter()
                        .map(|&v| f64::from(v)),
                )
            })
            .collect();
        EmissionWarp {
            width: w,
            height: h,
            rows,
            columns,
        }
    }

    fn lookup(&self, st: Vec2) -> f32 {
        let j = ((st.x.clamp(0.0, 1.0) * self.width as f32) as usize).min(self.width - 1);
        let i = ((st.y.clamp(0.0, 1.0) * self.height as f32) as usize).min(self.height - 1);
        self.values[i * self.width + j]
    }
}

/// Importance sampling of an emission texture: maps uniform points of the unit square to
/// parameters `(s, t)` distributed in proportion to the emission (the texture is constant per
/// texel: a row is picked by the cumulative sums of the rows' emission, a texel within it by the
/// row's own, and the point is placed within the texel by the rest of each coordinate). Rect and
/// disk lights map their parameters area-uniformly, so their points then fall in proportion to
/// emitted power, and the plain fraction of unblocked samples estimates the emission-weighted
/// visibility that weighted samples compute (`docs/design.md` section 3).
#[derive(Debug, Clone, PartialEq)]
pub struct EmissionWarp {
    width: usize,
    height: usize,
    /// Cumulative emission of the rows, `height + 1` values from 0.
    rows: Vec<f64>,
    /// Per row, the cumulative emission of its texels, `width + 1` values from 0.
    columns: Vec<f64>,
}

impl EmissionWarp {
    /// The parameters `(s, t)` of uniform point `u` of the unit square.
    pub fn warp(&self, u: [f32; 2]) -> [f32; 2] {
        let (i, t) = invert_cumulative(&self.rows, u[1]);
        let (j, s) = invert_cumulative(&self.columns[i * (self.width + 1)..][..=self.width], u[0]);
        [
            ((j as f64 + s) / self.width as f64) as f32,
            ((i as f64 + t) / self.height as f64) as f32,
        ]
    }
}

/// The bin `k` of cumulative sums `c` (from 0, non-decreasing, positive total) where `u` in
/// [0, 1) of the total falls, and the fraction of that bin below it. Bins of zero weight are
/// never returned.
fn invert_cumulative(c: &[f64], u: f32) -> (usize, f64) {
    let total = c[c.len() - 1];
    let x = f64::from(u.clamp(0.0, 1.0)) * total;
    // The last bin whose start lies at or below x, among the bins of positive weight.
    let k = c[1..].partition_point(|&end| end <= x).min(c.len() - 2);
    let k = (0..=k).rev().find(|&b| c[b + 1] > c[b]).unwrap_or(k);
    let fraction = ((x - c[k]) / (c[k + 1] - c[k])).clamp(0.0, 1.0 - f64::EPSILON);
    (k, fraction)
}

/// The geometric shape of a light.
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    Point {
        position: Vec3,
    },
    /// `u`, `v`: half-extent vectors; the light faces `normalize(u x v)`.
    Rect {
        center: Vec3,
        u: Vec3,
        v: Vec3,
    },
    Disk {
        center: Vec3,
        normal: Vec3,
        radius: f32,
    },
    /// Emits from its whole volume (Sintorn et al. 2008, Sample Based Visibility for Soft Shadows).
    Sphere {
        center: Vec3,
        radius: f32,
    },
    /// Emits from its whole volume: the points `center + axes x` with `|x| <= 1`; the columns
    /// of `axes` are the three mutually orthogonal semi-axes
    /// (Sintorn et al. 2008, Sample Based Visibility for Soft Shadows, section 4.1).
    Ellipsoid {
        center: Vec3,
        axes: Mat3,
    },
}

/// A light: a shape and an optional emission texture.
#[derive(Debug, Clone, PartialEq)]
pub struct Light {
    pub shape: Shape,
    emission: Option<EmissionTexture>,
}

/// Three uniform numbers in [0,1) that pick one decorrelating rotation (see [`Light::rotate`]).
pub type RotationSeed = [f32; 3];

fn finite_vec(arg: &str, v: Vec3) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Error::invalid(arg, format!("must be finite, got {v}")))
    }
}

fn positive_radius(r: f32) -> Result<()> {
    if r.is_finite() && r > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(
            "radius",
            format!("must be finite and > 0, got {r}"),
        ))
    }
}

/// An orthonormal basis `(t, b)` of the plane orthogonal to the unit vector `n`, with
/// `t x b = n`: `t = normalize(n x X)`, or `normalize(n x Y)` when `|n.x| >= 0.9`. The Python
/// side (`DiskLight.tangent_frame`: shading's disk polygon, Mitsuba's disk, the preview) reads
/// this frame, so a disk's emission texture has one documented orientation.
pub fn tangent_frame(n: Vec3) -> (Vec3, Vec3) {
    let helper = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let t = n.cross(helper).normalize();
    (t, n.cross(t))
}

/// Shirley and Chiu's concentric map from the unit square to the unit disk.
pub(crate) fn concentric_disk(s: f32, t: f32) -> Vec2 {
    let (a, b) = (2.0 * s - 1.0, 2.0 * t - 1.0);
    if a == 0.0 && b == 0.0 {
        return Vec2::ZERO;
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, PI / 4.0 * (b / a))
    } else {
        (b, PI / 2.0 - PI / 4.0 * (a / b))
    };
    Vec2::new(r * phi.cos(), r * phi.sin())
}

/// Inverse of [`concentric_disk`], for the emission lookup of world-space disk samples.
fn concentric_square(p: Vec2) -> Vec2 {
    let r = p.length();
    if r == 0.0 {
        return Vec2::splat(0.5);
    }
    let mut phi = p.y.atan2(p.x);
    if phi < -PI / 4.0 {
        phi += 2.0 * PI;
    }
    let (a, b) = if phi < PI / 4.0 {
        (r, phi * r / (PI / 4.0))
    } else if phi < 3.0 * PI / 4.0 {
        (-(phi - PI / 2.0) * r / (PI / 4.0), r)
    } else if phi < 5.0 * PI / 4.0 {
        (-r, -(phi - PI) * r / (PI / 4.0))
    } else {
        ((phi - 3.0 * PI / 2.0) * r / (PI / 4.0), -r)
    };
    Vec2::new((a + 1.0) * 0.5, (b + 1.0) * 0.5)
}

impl Light {
    pub fn point(position: Vec3) -> Result<Self> {
        finite_vec("position", position)?;
        Ok(Self {
            shape: Shape::Point { position },
            emission: None,
        })
    }

    /// A rectangle with half-extent vectors `u`, `v`; refuses zero area, and `u`, `v` parallel to
    /// within 1e-6 rad, whose Gram determinant (which maps light points to the rectangle's
    /// parameters) cancels to nothing.
    pub fn rect(center: Vec3, u: Vec3, v: Vec3) -> Result<Self> {
        finite_vec("center", center)?;
        finite_vec("u", u)?;
        finite_vec("v", v)?;
        // In f64, where the squared lengths of tiny and huge f32 vectors neither underflow nor
        // overflow: sin² of the angle between u and v is det / (|u|² |v|²).
        let (du, dv) = (u.as_dvec3(), v.as_dvec3());
        let (uu, vv, uv) = (du.dot(du), dv.dot(dv), du.dot(dv));
        if uu * vv - uv * uv <= 1e-12 * uu * vv {
            return Err(Error::invalid(
                "u",
                format!("u = {u} and v = {v} span (almost) zero area: parallel to within 1e-6 rad"),
            ));
        }
        Ok(Self {
            shape: Shape::Rect { center, u, v },
            emission: None,
        })
    }

    /// A disk facing `normal`; refuses a zero normal or a radius <= 0.
    pub fn disk(center: Vec3, normal: Vec3, radius: f32) -> Result<Self> {
        finite_vec("center", center)?;
        finite_vec("normal", normal)?;
        positive_radius(radius)?;
        if normal.length_squared() == 0.0 {
            return Err(Error::invalid("normal", "must be non-zero"));
        }
        Ok(Self {
            shape: Shape::Disk {
                center,
                normal: normal.normalize(),
                radius,
            },
            emission: None,
        })
    }

    /// A volumetric sphere; refuses a radius <= 0.
    pub fn sphere(center: Vec3, radius: f32) -> Result<Self> {
        finite_vec("center", center)?;
        positive_radius(radius)?;
        Ok(Self {
            shape: Shape::Sphere { center, radius },
            emission: None,
        })
    }

    /// A volumetric ellipsoid with the three semi-axis vectors `axes` (columns); refuses
    /// non-finite, zero or non-orthogonal axes (relative tolerance 1e-4).
    pub fn ellipsoid(center: Vec3, axes: [Vec3; 3]) -> Result<Self> {
        finite_vec("center", center)?;
        for (k, a) in axes.iter().enumerate() {
            finite_vec("axes", *a)?;
            if a.length_squared() == 0.0 || !a.length_squared().is_finite() {
                return Err(Error::invalid(
                    "axes",
                    format!("semi-axis {k} = {a} has no usable length"),
                ));
            }
        }
        for (i, j) in [(0, 1), (0, 2), (1, 2)] {
            let (a, b) = (axes[i], axes[j]);
            if a.dot(b).abs() > 1e-4 * a.length() * b.length() {
                return Err(Error::invalid(
                    "axes",
                    format!("semi-axes {i} = {a} and {j} = {b} are not orthogonal"),
                ));
            }
        }
        Ok(Self {
            shape: Shape::Ellipsoid {
                center,
                axes: Mat3::from_cols(axes[0], axes[1], axes[2]),
            },
            emission: None,
        })
    }

    /// Adds an emission texture (rectangles and disks only).
    pub fn with_emission(mut self, texture: EmissionTexture) -> Result<Self> {
        match self.shape {
            Shape::Rect { .. } | Shape::Disk { .. } => {
                self.emission = Some(texture);
                Ok(self)
            }
            _ => Err(Error::invalid(
                "emission",
                "only RectLight and DiskLight take an emission texture",
            )),
        }
    }

    /// Whether samples carry weights (an emission texture is set).
    pub fn is_textured(&self) -> bool {
        self.emission.is_some()
    }

    /// The texels of the emission texture (0 without one).
    pub fn emission_texels(&self) -> usize {
        self.emission.as_ref().map_or(0, |e| e.width * e.height)
    }

    /// The importance sampler of the emission texture, for textured lights.
    pub fn emission_warp(&self) -> Option<EmissionWarp> {
        self.emission.as_ref().map(EmissionTexture::warp)
    }

    pub fn center(&self) -> Vec3 {
        match self.shape {
            Shape::Point { position } => position,
            Shape::Rect { center, .. }
            | Shape::Disk { center, .. }
            | Shape::Sphere { center, .. }
            | Shape::Ellipsoid { center, .. } => center,
        }
    }

    /// The emitting side's unit normal of a planar light.
    pub fn normal(&self) -> Option<Vec3> {
        match self.shape {
            Shape::Rect { u, v, .. } => {
                let c = u.cross(v);
                Some((c / c.abs().max_element()).normalize())
            }
            Shape::Disk { normal, .. } => Some(normal),
            _ => None,
        }
    }

    /// The largest distance from the center to a point of the light, in world units. Computed
    /// in f64: in f32, `|u + v|²` of a rectangle overflows once its sides reach 1e19 although
    /// the extent itself is representable (the Python `extent` is this value).
    pub fn extent(&self) -> f64 {
        match self.shape {
            Shape::Point { .. } => 0.0,
            Shape::Rect { u, v, .. } => {
                let (u, v) = (u.as_dvec3(), v.as_dvec3());
                (u + v).length().max((u - v).length())
            }
            Shape::Disk { radius, .. } | Shape::Sphere { radius, .. } => f64::from(radius),
            // Orthogonal semi-axes: the longest is the farthest point.
            Shape::Ellipsoid { axes, .. } => axes
                .x_axis
                .as_dvec3()
                .length()
                .max(axes.y_axis.as_dvec3().length())
                .max(axes.z_axis.as_dvec3().length()),
        }
    }

    /// The half extent of the light along the unit direction `axis`: the largest `|(y − c) · axis|`
    /// over its points `y` (`c` its center), in world units.
    pub fn half_extent_along(&self, axis: Vec3) -> f32 {
        match self.shape {
            Shape::Point { .. } => 0.0,
            Shape::Rect { u, v, .. } => u.dot(axis).abs() + v.dot(axis).abs(),
            Shape::Disk { normal, radius, .. } => {
                radius * (1.0 - normal.dot(axis).powi(2)).max(0.0).sqrt()
            }
            Shape::Sphere { radius, .. } => radius,
            // The support function of the ellipsoid: |Aᵀ axis|.
            Shape::Ellipsoid { axes, .. } => axes.transpose().mul_vec3(axis).length(),
        }
    }

    /// How many unit-cube coordinates [`Light::map`] uses: 0, 2 (rect, disk) or 3 (sphere, ellipsoid).
    pub fn dim(&self) -> usize {
        match self.shape {
            Shape::Point { .. } => 0,
            Shape::Rect { .. } | Shape::Disk { .. } => 2,
            Shape::Sphere { .. } | Shape::Ellipsoid { .. } => 3,
        }
    }

    /// Maps a unit-cube point onto the light (area- or volume-uniformly).
    pub fn map(&self, p: [f32; 3]) -> Vec3 {
        match self.shape {
            Shape::Point { position } => position,
            Shape::Rect { center, u, v } => {
                center + u * (2.0 * p[0] - 1.0) + v * (2.0 * p[1] - 1.0)
            }
            Shape::Disk {
                center,
                normal,
                radius,
            } => {
                let (t, b) = tangent_frame(normal);
                let d = concentric_disk(p[0], p[1]) * radius;
                center + t * d.x + b * d.y
            }
            Shape::Sphere { center, radius } => center + ball(p, radius),
            Shape::Ellipsoid { center, axes } => center + axes * ball(p, 1.0),
        }
    }

    /// Parameters `(s, t)` in \[0, 1\]^2 of a point on a planar light (its emission-texture coordinates).
    pub(crate) fn params(&self, y: Vec3) -> Vec2 {
        match self.shape {
            Shape::Rect { center, u, v } => {
                // Solve d = a u + b v through the Gram matrix: u and v need not be orthogonal. In
                // f64: in f32 the determinant underflows for half extents below ~1e-10, overflows
                // above ~1e9 and cancels for nearly parallel u, v (found by fuzzing).
                let (d, u, v) = ((y - center).as_dvec3(), u.as_dvec3(), v.as_dvec3());
                let (uu, uv, vv) = (u.dot(u), u.dot(v), v.dot(v));
                let (du, dv) = (d.dot(u), d.dot(v));
                let det = uu * vv - uv * uv;
                let (a, b) = ((du * vv - dv * uv) / det, (dv * uu - du * uv) / det);
                Vec2::new(((a + 1.0) * 0.5) as f32, ((b + 1.0) * 0.5) as f32)
            }
            Shape::Disk {
                center,
                normal,
                radius,
            } => {
                let (t, b) = tangent_frame(normal);
                let d = y - center;
                concentric_square(Vec2::new(d.dot(t), d.dot(b)) / radius)
            }
            _ => Vec2::splat(0.5),
        }
    }

    /// The emission weight of light point `y`: 1 without a texture.
    pub fn weight(&self, y: Vec3) -> f32 {
        match &self.emission {
            Some(tex) => tex.lookup(self.params(y)),
            None => 1.0,
        }
    }

    /// Applies the decorrelating rotation picked by `r` to light point `y` (see the module doc).
    pub fn rotate(&self, y: Vec3, r: RotationSeed) -> Vec3 {
        match self.shape {
            Shape::Point { position } => position,
            Shape::Rect { center, u, v } => rect_shifted(center, u, v, self.params(y), r),
            Shape::Disk { center, normal, .. } => {
                center + glam::Quat::from_axis_angle(normal, 2.0 * PI * r[0]) * (y - center)
            }
            Shape::Sphere { center, .. } => center + random_rotation(r) * (y - center),
            // In f64, and back into the unit ball: for a very skinny ellipsoid, the f32 rounding of
            // `y` across its thin axis grows by the inverse's huge scale, and rotated into the
            // long axes it put samples far off the light (found by fuzzing).
            Shape::Ellipsoid { center, axes } => {
                let a = axes.as_dmat3();
                let unit = a.inverse() * (y - center).as_dvec3();
                let unit = if unit.length() > 1.0 {
                    unit.normalize()
                } else {
                    unit
                };
                center + (a * (random_rotation(r).as_dmat3() * unit)).as_vec3()
            }
        }
    }
}

impl Light {
    /// The decorrelating rotation [`Light::rotate`] applies for `r`, as a rigid rotation about the
    /// light's center, for the lights it is one of (point, disk, sphere); `None` for a rectangle,
    /// whose decorrelation is a shift of its parameters, and for an ellipsoid, whose is not rigid.
    pub fn rigid_rotation(&self, r: RotationSeed) -> Option<Mat3> {
        match self.shape {
            Shape::Point { .. } => Some(Mat3::IDENTITY),
            Shape::Disk { normal, .. } => Some(Mat3::from_quat(glam::Quat::from_axis_angle(
                normal,
                2.0 * PI * r[0],
            ))),
            Shape::Sphere { .. } => Some(random_rotation(r)),
            Shape::Rect { .. } | Shape::Ellipsoid { .. } => None,
        }
    }
}

/// The volume-uniform map of the unit cube onto the ball of `radius` about the origin: radius
/// `radius a^(1/3)`, uniform direction.
fn ball(p: [f32; 3], radius: f32) -> Vec3 {
    let r = radius * p[0].cbrt();
    let z = 1.0 - 2.0 * p[1];
    let s = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * p[2];
    Vec3::new(s * phi.cos(), s * phi.sin(), z) * r
}

/// The point of the rectangle of `center` and half-extent vectors `u`, `v` at the parameters
/// `st` shifted by `r` and wrapped ([`Light::rotate`]'s decorrelation of a rectangle).
pub(crate) fn rect_shifted(center: Vec3, u: Vec3, v: Vec3, st: Vec2, r: RotationSeed) -> Vec3 {
    let st = st + Vec2::new(r[0], r[1]);
    let st = st - st.floor();
    center + u * (2.0 * st.x - 1.0) + v * (2.0 * st.y - 1.0)
}

/// Arvo's uniformly distributed random rotation from three uniform numbers.
fn random_rotation(r: RotationSeed) -> Mat3 {
    let theta = 2.0 * PI * r[0];
    let phi = 2.0 * PI * r[1];
    let z = r[2];
    let rz = Mat3::from_rotation_z(theta);
    let v = Vec3::new(phi.cos() * z.sqrt(), phi.sin() * z.sqrt(), (1.0 - z).sqrt());
    let householder = Mat3::IDENTITY - 2.0 * Mat3::from_cols(v * v.x, v * v.y, v * v.z);
    -(householder * rz)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fuzzing regressions: rotated samples of tiny or huge rectangles and of a very skinny
    /// ellipsoid stay finite and on the light (their parameters were solved in f32).
    #[test]
    fn rotated_samples_of_extreme_lights_stay_on_the_light() {
        for h in [1e-12f32, 1e-3, 1e12] {
            let light = Light::rect(
                Vec3::new(1.0, 2.0, 3.0),
                Vec3::new(h, 0.0, 0.0),
                Vec3::new(0.0, 0.0, h),
            )
            .unwrap();
            let y = light.map([0.3, 0.6, 0.0]);
            let z = light.rotate(y, [0.4, 0.7, 0.0]);
            let d = z - light.center();
            assert!(
                z.is_finite() && d.x.abs() <= h * 1.001 && d.z.abs() <= h * 1.001 && d.y == 0.0,
                "half extent {h}: {z}"
            );
        }
        let axes = [
            Vec3::new(1e8, 0.0, 0.0),
            Vec3::new(0.0, 1e-9, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let light = Light::ellipsoid(Vec3::ZERO, axes).unwrap();
        let z = light.rotate(light.map([0.2, 0.5, 0.7]), [0.3, 0.1, 0.9]);
        let unit = Vec3::new(z.x / 1e8, z.y / 1e-9, z.z);
        assert!(
            unit.length() <= 1.0 + 1e-3,
            "{z} lies off the ellipsoid ({unit})"
        );
    }

    #[test]
    fn concentric_map_round_trips() {
        for &(s, t) in &[(0.1, 0.2), (0.9, 0.3), (0.5, 0.95), (0.3, 0.7), (0.05, 0.5)] {
            let back = concentric_square(concentric_disk(s, t));
            assert!(
                (back - Vec2::new(s, t)).length() < 1e-5,
                "{s},{t} -> {back}"
            );
        }
    }

    #[test]
    fn rotations_keep_points_on_the_light() {
        let disk = Light::disk(Vec3::ZERO, Vec3::Y, 2.0).unwrap();
        let sphere = Light::sphere(Vec3::ONE, 1.5).unwrap();
        let rect = Light::rect(Vec3::ZERO, Vec3::X, Vec3::Z * 0.5).unwrap();
        for k in 0..50 {
            let f = k as f32 / 50.0;
            let p = [f, (f * 7.3) % 1.0, (f * 3.1) % 1.0];
            let r = [(f * 5.7) % 1.0, (f * 2.3) % 1.0, (f * 9.1) % 1.0];
            let y = disk.rotate(disk.map(p), r);
            assert!(y.y.abs() < 1e-5 && y.length() <= 2.0 + 1e-4);
            let y = sphere.rotate(sphere.map(p), r);
            assert!((y - Vec3::ONE).length() <= 1.5 + 1e-4);
            let y = rect.rotate(rect.map(p), r);
            assert!(y.x.abs() <= 1.0 + 1e-5 && y.z.abs() <= 0.5 + 1e-5 && y.y.abs() < 1e-6);
        }
    }

    #[test]
    fn skewed_rectangles_map_back_to_their_parameters() {
        let rect = Light::rect(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(1.0, 0.0, 0.3),
            Vec3::new(0.4, 0.0, 0.8),
        )
        .unwrap();
        for &(s, t) in &[(0.1f32, 0.2f32), (0.9, 0.35), (0.5, 0.5), (0.02, 0.97)] {
            let st = rect.params(rect.map([s, t, 0.0]));
            assert!((st - Vec2::new(s, t)).length() < 1e-5, "{s},{t} -> {st}");
        }
    }

    #[test]
    fn disk_frames_are_right_handed_around_the_normal() {
        for n in [
            Vec3::Y,
            -Vec3::Y,
            Vec3::X,
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::new(-0.95, 0.1, 0.0).normalize(),
        ] {
            let (t, b) = tangent_frame(n);
            assert!((t.cross(b) - n).length() < 1e-6 && t.dot(n).abs() < 1e-6);
        }
    }

    #[test]
    fn zero_area_and_bad_radius_are_refused() {
        assert!(matches!(
            Light::rect(Vec3::ZERO, Vec3::X, Vec3::X * 2.0),
            Err(Error::InvalidInput { .. })
        ));
        assert!(matches!(
            Light::disk(Vec3::ZERO, Vec3::Y, -1.0),
            Err(Error::InvalidInput { .. })
        ));
        assert!(matches!(
            Light::sphere(Vec3::ZERO, 0.0),
            Err(Error::InvalidInput { .. })
        ));
    }

    /// A tilted prolate ellipsoid: semi-axes 0.9, 0.3 and 0.2 along a rotated frame.
    fn ellipsoid() -> Light {
        let r = Mat3::from_rotation_y(0.7) * Mat3::from_rotation_x(-0.4);
        Light::ellipsoid(
            Vec3::new(1.0, 3.0, -2.0),
            [r.x_axis * 0.9, r.y_axis * 0.3, r.z_axis * 0.2],
        )
        .unwrap()
    }

    /// `|A⁻¹ (y − c)|`: at most 1 inside the ellipsoid.
    fn ellipsoid_radius(light: &Light, y: Vec3) -> f32 {
        match light.shape {
            Shape::Ellipsoid { center, axes } => (axes.inverse() * (y - center)).length(),
            _ => unreachable!(),
        }
    }

    #[test]
    fn ellipsoid_points_and_rotations_stay_inside_and_bounds_hold() {
        let light = ellipsoid();
        assert!((light.extent() - 0.9).abs() < 1e-6);
        let mut rng = crate::light::sampling::Rng::new(3);
        let mut along = [0f32; 3];
        for _ in 0..2000 {
            let y = light.map([rng.next_f32(), rng.next_f32(), rng.next_f32()]);
            assert!(ellipsoid_radius(&light, y) <= 1.0 + 1e-5);
            let moved = light.rotate(y, [rng.next_f32(), rng.next_f32(), rng.next_f32()]);
            assert!((ellipsoid_radius(&light, moved) - ellipsoid_radius(&light, y)).abs() < 1e-4);
            for (k, axis) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().enumerate() {
                let d = (y - light.center()).dot(axis).abs();
                assert!(d <= light.half_extent_along(axis) + 1e-5);
                along[k] = along[k].max(d);
            }
        }
        // The support bound is tight: samples come close to it on every axis.
        for (k, axis) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().enumerate() {
            assert!(along[k] > 0.85 * light.half_extent_along(axis), "axis {k}");
        }
        assert!(light.rigid_rotation([0.1, 0.2, 0.3]).is_none());
    }

    #[test]
    fn degenerate_or_skewed_ellipsoids_are_refused() {
        let bad = [
            [Vec3::X, Vec3::Y, Vec3::ZERO],
            [Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Z],
            [Vec3::X, Vec3::Y, Vec3::splat(f32::NAN)],
        ];
        for axes in bad {
            assert!(
                matches!(
                    Light::ellipsoid(Vec3::ZERO, axes),
                    Err(Error::InvalidInput { .. })
                ),
                "{axes:?}"
            );
        }
    }

    #[test]
    fn the_emission_warp_samples_texels_in_proportion_to_their_emission() {
        // Rows: t in [0, 1/3) emits 1 then 0; [1/3, 2/3) nothing; [2/3, 1) 0 then 3.
        let texture = EmissionTexture::new(2, 3, vec![1.0, 0.0, 0.0, 0.0, 0.0, 3.0]).unwrap();
        let light = Light::rect(Vec3::ZERO, Vec3::X, Vec3::Z)
            .unwrap()
            .with_emission(texture)
            .unwrap();
        let warp = light.emission_warp().unwrap();
        let n = 64;
        let mut counts = [0usize; 6];
        for a in 0..n {
            for b in 0..n {
                let u = [(a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32];
                let [s, t] = warp.warp(u);
                assert!(
                    (0.0..1.0).contains(&s) && (0.0..1.0).contains(&t),
                    "{s} {t}"
                );
                // Every warped point lies where the light emits.
                let y = light.map([s, t, 0.0]);
                assert!(light.weight(y) > 0.0, "{s} {t}");
                counts[(t * 3.0) as usize * 2 + (s * 2.0) as usize] += 1;
            }
        }
        assert_eq!(counts, [n * n / 4, 0, 0, 0, 0, 3 * n * n / 4]);
    }
}
