//! A pinhole camera for G-buffers (`docs/design.md` section 2).
//!
//! Conventions: a right-handed frame `right = forward x up`; pixel `(x, y)` has its center at the
//! continuous coordinates `(x + 0.5, y + 0.5)`; `y` grows downward, so image row 0 is the top of
//! the picture; `fov_y_degrees` is the full vertical field of view and pixels are square.

use crate::error::{Error, Result};
use glam::{DVec2, Vec2, Vec3};

/// A pinhole camera with an orthonormal frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub fov_y_degrees: f32,
    pub width: usize,
    pub height: usize,
}

fn finite(arg: &str, v: Vec3) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Error::invalid(arg, format!("must be finite, got {v}")))
    }
}

impl Camera {
    /// A camera at `eye` looking at `target`, with `up` giving the image's upward direction
    /// (orthogonalized). Refuses zero sizes ("width"/"height"), `eye == target` ("target"), an
    /// `up` parallel to the view ("up") and a field of view outside (0, 180) degrees ("fov_y").
    pub fn look_at(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov_y_degrees: f32,
        width: usize,
        height: usize,
    ) -> Result<Camera> {
        if width == 0 {
            return Err(Error::invalid("width", "must be >= 1, got 0"));
        }
        if height == 0 {
            return Err(Error::invalid("height", "must be >= 1, got 0"));
        }
        finite("eye", eye)?;
        finite("target", target)?;
        finite("up", up)?;
        if !(fov_y_degrees > 0.0 && fov_y_degrees < 180.0) {
            return Err(Error::invalid(
                "fov_y",
                format!("must be in (0, 180) degrees, got {fov_y_degrees}"),
            ));
        }
        let view = target - eye;
        if view == Vec3::ZERO {
            return Err(Error::invalid(
                "target",
                format!("must differ from eye, both are {eye}"),
            ));
        }
        // A view 1e20 long overflows its squared length: normalize it scaled down instead.
        let forward = match view.normalize_or_zero() {
            Vec3::ZERO if view.is_finite() => (view / view.abs().max_element()).normalize_or_zero(),
            forward => forward,
        };
        if forward == Vec3::ZERO {
            return Err(Error::invalid(
                "eye",
                format!("eye {eye} and target {target} are too far apart for float32 arithmetic"),
            ));
        }
        let right = forward.cross(up.normalize_or_zero());
        // Below ~1e-6 (sin of the angle) the frame would be dominated by rounding.
        if right.length() <= 1e-6 {
            return Err(Error::invalid(
                "up",
                format!("up = {up} is zero or parallel to the view direction {forward}"),
            ));
        }
        let right = right.normalize();
        let up = right.cross(forward);
        Ok(Camera {
            eye,
            forward,
            right,
            up,
            fov_y_degrees,
            width,
            height,
        })
    }

    /// The *normalized* direction of the primary ray through continuous pixel coordinates
    /// `(px, py)` (pixel `(x, y)`'s center is `(x + 0.5, y + 0.5)`; `y` grows downward).
    #[inline]
    pub fn ray(&self, px: f32, py: f32) -> Vec3 {
        let tan_half = (self.fov_y_degrees.to_radians() * 0.5).tan();
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * px / self.width as f32 - 1.0) * tan_half * aspect;
        let sy = (1.0 - 2.0 * py / self.height as f32) * tan_half;
        (self.forward + self.right * sx + self.up * sy).normalize()
    }

    /// `tan(fov_y / 2)` in f64.
    fn tan_half(&self) -> f64 {
        (f64::from(self.fov_y_degrees).to_radians() * 0.5).tan()
    }

    /// The continuous pixel coordinates where world point `p` appears, the inverse of
    /// [`Camera::ray`] (pixel `(x, y)`'s center is `(x + 0.5, y + 0.5)`); `None` for a point on
    /// or behind the camera's plane. In f64, so that a pixel center's own point projects back
    /// onto it to within about 1e-5 pixels (temporal reprojection reads it bilinearly).
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let d = (p - self.eye).as_dvec3();
        let z = d.dot(self.forward.as_dvec3());
        if z.is_nan() || z <= 0.0 {
            return None;
        }
        let (w, h) = (self.width as f64, self.height as f64);
        let tan_half = self.tan_half();
        let sx = d.dot(self.right.as_dvec3()) / (z * tan_half * w / h);
        let sy = d.dot(self.up.as_dvec3()) / (z * tan_half);
        let xy = DVec2::new((sx + 1.0) * w * 0.5, (1.0 - sy) * h * 0.5);
        xy.is_finite().then(|| xy.as_vec2())
    }

    /// The world size of one pixel on a plane facing the camera at distance `distance` from the
    /// eye along the view direction (pixels are square).
    pub fn pixel_size_at(&self, distance: f32) -> f32 {
        (2.0 * f64::from(distance) * self.tan_half() / self.height as f64) as f32
    }

    /// The depth of `p` along the view direction.
    pub fn depth(&self, p: Vec3) -> f32 {
        (p - self.eye).dot(self.forward)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arg_of(r: Result<Camera>) -> String {
        match r {
            Err(Error::InvalidInput { arg, .. }) => arg,
            other => format!("{other:?}"),
        }
    }

    #[test]
    fn bad_arguments_name_themselves() {
        let (e, t, u) = (Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y);
        assert_eq!(arg_of(Camera::look_at(e, t, u, 45.0, 0, 4)), "width");
        assert_eq!(arg_of(Camera::look_at(e, t, u, 45.0, 4, 0)), "height");
        assert_eq!(arg_of(Camera::look_at(e, e, u, 45.0, 4, 4)), "target");
        assert_eq!(arg_of(Camera::look_at(e, t, Vec3::Z, 45.0, 4, 4)), "up");
        assert_eq!(arg_of(Camera::look_at(e, t, Vec3::ZERO, 45.0, 4, 4)), "up");
        assert_eq!(arg_of(Camera::look_at(e, t, u, 180.0, 4, 4)), "fov_y");
        assert_eq!(arg_of(Camera::look_at(e, t, u, 0.0, 4, 4)), "fov_y");
        assert_eq!(arg_of(Camera::look_at(e, t, u, f32::NAN, 4, 4)), "fov_y");
    }

    #[test]
    fn frame_and_rays() {
        let cam =
            Camera::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 90.0, 4, 2).unwrap();
        assert!((cam.forward - Vec3::NEG_Z).length() < 1e-6);
        assert!((cam.right - Vec3::X).length() < 1e-6);
        assert!((cam.up - Vec3::Y).length() < 1e-6);
        // The image center looks forward; the top-left corner looks up and left.
        assert!((cam.ray(2.0, 1.0) - Vec3::NEG_Z).length() < 1e-6);
        let corner = cam.ray(0.0, 0.0);
        let expect = Vec3::new(-2.0, 1.0, -1.0).normalize();
        assert!((corner - expect).length() < 1e-6, "{corner}");
    }

    #[test]
    fn project_inverts_ray() {
        let cam = Camera::look_at(
            Vec3::new(1.0, 2.0, 5.0),
            Vec3::new(0.2, 0.0, -0.3),
            Vec3::Y,
            50.0,
            40,
            30,
        )
        .unwrap();
        for (px, py) in [(0.5, 0.5), (20.0, 15.0), (39.5, 7.25), (3.0, 29.9)] {
            let p = cam.eye + cam.ray(px, py) * 7.0;
            let back = cam.project(p).unwrap();
            assert!(
                (back - Vec2::new(px, py)).length() < 1e-3,
                "{px} {py} -> {back}"
            );
        }
        assert_eq!(cam.project(cam.eye - cam.forward), None);
        assert_eq!(cam.project(cam.eye), None);
    }
}
