//! Temporal accumulation of any method's per-frame visibility over a sequence of frames: the
//! previous frame's accumulated visibility is reprojected into the current G-buffer and blended
//! with the current frame (Schied et al. 2017, Spatiotemporal Variance-Guided Filtering,
//! section 4.1; the temporal stage of `denoised` is this very code).
//!
//! **Reprojection** (backward, per current pixel): the pixel's world point `p` is projected into
//! the previous camera ([`Camera::project`]) and the previous accumulation is read there
//! bilinearly from its four nearest pixel centers. Each tap is tested for consistency as Schied
//! et al. test depth and normals: it is rejected when its surface point `q` lies off the tangent
//! plane of `p` or `p` off the tangent plane of `q` by more than `depth_tolerance` times the
//! distance of `p` from the previous eye (a plane distance rather than a depth difference, so
//! that neighbouring taps on one slanted surface agree however grazing the view), or when the
//! normals differ by more than `normal_tolerance` degrees. The accepted taps' bilinear weights
//! are renormalized; a pixel whose accepted taps carry less than 1% of the weight (new on
//! screen, disoccluded, or whose surface changed) restarts from the current frame. The G-buffer holds positions only, no motion
//! vectors: a point of a moving object is looked up where it lay in world space, which the tests
//! reject unless the object moves within its own surface.
//!
//! **Blend**: an exponential moving average `C'_i = a C_i + (1 - a) C'_{i-1}` (Schied et al.
//! 2017, section 4.1) with `a = max(alpha, 1 / n)`, `n` the pixel's history length in frames
//! (itself reprojected, plus one): while a history is shorter than `1 / alpha` frames it is the
//! plain mean of its frames, so that the first frame does not dominate it (our choice; a static
//! sequence of at most `1 / alpha` frames thus accumulates to exactly their mean).

use crate::error::{Error, Result};
use crate::geometry::camera::Camera;
use crate::geometry::receivers::Receivers;
use crate::interrupt;
use crate::limits::{Peak, Work};
use crate::stats::Stats;
use glam::{Vec2, Vec3};

/// The stats keys of [`accumulate`] (beside [`crate::stats::COMMON`]): the stage's seconds, the
/// valid pixels that took a reprojected history and those that restarted from the current frame.
pub const STATS: &[&str] = &["temporal_seconds", "reprojected", "restarted"];

/// Options of [`accumulate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TemporalOptions {
    /// The weight of the current frame once the history is long enough, in (0, 1] (default
    /// 0.1; Schied et al. 2017 use 0.2).
    pub alpha: f32,
    /// The largest plane distance between a pixel's point and a reprojected tap's, relative to
    /// the point's distance from the previous eye (default 0.02).
    pub depth_tolerance: f32,
    /// The largest angle between their normals, in degrees (default 25: a cosine of 0.9).
    pub normal_tolerance: f32,
}

impl Default for TemporalOptions {
    fn default() -> Self {
        Self {
            alpha: 0.1,
            depth_tolerance: 0.02,
            normal_tolerance: 25.0,
        }
    }
}

impl TemporalOptions {
    /// Refuses options out of range, naming them.
    pub fn validate(&self) -> Result<()> {
        if !(self.alpha > 0.0 && self.alpha <= 1.0) {
            return Err(Error::invalid(
                "alpha",
                format!("must be in (0, 1], got {}", self.alpha),
            ));
        }
        if !(self.depth_tolerance.is_finite() && self.depth_tolerance > 0.0) {
            return Err(Error::invalid(
                "depth_tolerance",
                format!("must be finite and > 0, got {}", self.depth_tolerance),
            ));
        }
        if !(0.0..=180.0).contains(&self.normal_tolerance) {
            return Err(Error::invalid(
                "normal_tolerance",
                format!("must be in [0, 180] degrees, got {}", self.normal_tolerance),
            ));
        }
        Ok(())
    }

    /// The history length beyond which the blend is the plain moving average: `1 / alpha`.
    fn mean_frames(&self) -> f32 {
        1.0 / self.alpha
    }
}

/// The previous frame of a sequence: its G-buffer (receivers on the camera's pixel grid) with
/// its camera, its accumulated visibility and each pixel's history length in frames.
#[derive(Debug, Clone, Copy)]
pub struct Previous<'a> {
    pub camera: &'a Camera,
    pub receivers: &'a Receivers,
    pub visibility: &'a [f32],
    pub length: &'a [f32],
}

impl Previous<'_> {
    /// Refuses a history whose arrays do not match its G-buffer.
    fn validate(&self) -> Result<()> {
        let r = self.receivers;
        let n = self.camera.width * self.camera.height;
        if r.width != self.camera.width || r.height != self.camera.height || r.len() != n {
            return Err(Error::invalid(
                "history",
                format!(
                    "its G-buffer has {}x{} receivers, its camera {}x{} pixels",
                    r.width, r.height, self.camera.width, self.camera.height
                ),
            ));
        }
        if self.visibility.len() != n || self.length.len() != n {
            return Err(Error::invalid(
                "history",
                format!(
                    "expected {n} accumulated values and lengths, got {} and {}",
                    self.visibility.len(),
                    self.length.len()
                ),
            ));
        }
        let bad = |v: &f32| !(v.is_finite() && *v >= 0.0);
        if self.visibility.iter().any(bad) || self.length.iter().any(bad) {
            return Err(Error::invalid(
                "history",
                "accumulated values and lengths must be finite and >= 0",
            ));
        }
        Ok(())
    }
}

/// The accumulated visibility of a frame and each pixel's history length in frames (0 for an
/// invalid pixel): the next frame's [`Previous`].
#[derive(Debug, Clone, PartialEq)]
pub struct Accumulated {
    pub visibility: Vec<f32>,
    pub length: Vec<f32>,
}

/// The least bilinear weight the accepted taps must carry: renormalized, a sliver of a tap's
/// weight would stand for the whole pixel (a disoccluded pixel's point projects next to its
/// own previous pixel, rejected, and would take its neighbour's history at full weight).
const MIN_WEIGHT: f32 = 0.01;

/// What a reprojection found for one pixel: the previous accumulation and history length read
/// from the accepted taps, or nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Reprojected {
    visibility: f32,
    length: f32,
}

/// Accumulates `visibility` (one value per receiver of `current`, in [0, 1]) with `previous`
/// (none: the first frame of a sequence), as the module doc describes.
pub fn accumulate(
    current: &Receivers,
    visibility: &[f32],
    previous: Option<&Previous>,
    opts: &TemporalOptions,
) -> Result<(Accumulated, Stats)> {
    opts.validate()?;
    if visibility.len() != current.len() {
        return Err(Error::invalid(
            "visibility",
            format!(
                "expected {} values (one per receiver), got {}",
                current.len(),
                visibility.len()
            ),
        ));
    }
    // A hit pixel's value enters the history (the blend ignores the others).
    let outside = |i: usize| current.valid[i] && !(0.0..=1.0).contains(&visibility[i]);
    if let Some(i) = (0..current.len()).find(|&i| outside(i)) {
        return Err(Error::invalid(
            "visibility",
            format!(
                "expected values in [0, 1] at the hit pixels, got {} at pixel {i}",
                visibility[i]
            ),
        ));
    }
    if let Some(prev) = previous {
        prev.validate()?;
    }
    let mut stats = Stats::declared(STATS);
    // The blended visibility and history length of every receiver, collected from pairs.
    Peak::default()
        .buffer(&[current.len() as u64, 2 * 4 + 8])
        .check("accumulate", &mut stats)?;
    Work::default()
        .loop_of(&[current.len() as u64, 4])
        .check("accumulate", &mut stats)?;
    let out = stats.time("temporal", || blend(current, visibility, previous, opts))?;
    let taken = out.length.iter().filter(|&&n| n > 1.0).count();
    let valid = current.valid.iter().filter(|&&v| v).count();
    stats.set("reprojected", taken as f64);
    stats.set("restarted", (valid - taken) as f64);
    Ok((out, stats))
}

/// The blend of every pixel (see the module doc), in parallel and interruptible rounds.
fn blend(
    current: &Receivers,
    visibility: &[f32],
    previous: Option<&Previous>,
    opts: &TemporalOptions,
) -> Result<Accumulated> {
    let cos_max = opts.normal_tolerance.to_radians().cos();
    let pixels = interrupt::par_map(current.len(), 16, |i| {
        if !current.valid[i] {
            return (0.0, 0.0);
        }
        let v = visibility[i];
        let found = previous.and_then(|prev| {
            reproject(
                prev,
                current.points[i],
                current.normals[i],
                opts.depth_tolerance,
                cos_max,
            )
        });
        match found {
            None => (v, 1.0),
            Some(h) => {
                let length = h.length + 1.0;
                let a = 1.0 / length.min(opts.mean_frames());
                (
                    (h.visibility + a * (v - h.visibility)).clamp(0.0, 1.0),
                    length,
                )
            }
        }
    })?;
    Ok(Accumulated {
        visibility: pixels.iter().map(|p| p.0).collect(),
        length: pixels.iter().map(|p| p.1).collect(),
    })
}

/// The previous accumulation at point `p` (normal `n`): bilinear over the four pixel centers
/// around its projection, each tap tested for consistency (see the module doc); `None` when
/// no tap passes.
fn reproject(
    prev: &Previous,
    p: Vec3,
    n: Vec3,
    depth_tolerance: f32,
    cos_max: f32,
) -> Option<Reprojected> {
    let xy = prev.camera.project(p)? - Vec2::splat(0.5);
    let base = xy.floor();
    let t = xy - base;
    let tolerance = depth_tolerance * (p - prev.camera.eye).length();
    let r = prev.receivers;
    let (mut weight, mut visibility, mut length) = (0.0f32, 0.0f32, 0.0f32);
    for (dx, dy, w) in [
        (0, 0, (1.0 - t.x) * (1.0 - t.y)),
        (1, 0, t.x * (1.0 - t.y)),
        (0, 1, (1.0 - t.x) * t.y),
        (1, 1, t.x * t.y),
    ] {
        let (x, y) = (base.x as i64 + dx, base.y as i64 + dy);
        if w <= 0.0 || x < 0 || y < 0 || x >= r.width as i64 || y >= r.height as i64 {
            continue;
        }
        let j = y as usize * r.width + x as usize;
        let (q, m) = (r.points[j], r.normals[j]);
        let consistent = r.valid[j]
            && n.dot(m) >= cos_max
            && n.dot(q - p).abs() <= tolerance
            && m.dot(q - p).abs() <= tolerance;
        if consistent {
            weight += w;
            visibility += w * prev.visibility[j];
            length += w * prev.length[j];
        }
    }
    (weight >= MIN_WEIGHT).then(|| Reprojected {
        visibility: visibility / weight,
        length: length / weight,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ground plane y = 0 seen from `eye` by a `size x size` camera, as receivers.
    fn ground(eye: Vec3, size: usize) -> (Camera, Receivers) {
        let cam = Camera::look_at(eye, Vec3::ZERO, Vec3::Y, 40.0, size, size).unwrap();
        let mut points = Vec::new();
        let mut valid = Vec::new();
        for i in 0..size * size {
            let d = cam.ray((i % size) as f32 + 0.5, (i / size) as f32 + 0.5);
            let t = -cam.eye.y / d.y;
            valid.push(t > 0.0);
            points.push(if t > 0.0 { cam.eye + d * t } else { Vec3::ZERO });
        }
        let rx = Receivers::new(points, vec![Vec3::Y; size * size], valid, size, size).unwrap();
        (cam, rx)
    }

    #[test]
    fn a_static_view_accumulates_the_mean_of_its_frames() {
        let (cam, rx) = ground(Vec3::new(0.0, 3.0, 4.0), 16);
        let opts = TemporalOptions::default();
        let frames: Vec<Vec<f32>> = (0..10)
            .map(|f| {
                (0..256)
                    .map(|i| ((i * 7 + f * 13) % 10) as f32 / 9.0)
                    .collect()
            })
            .collect();
        let mut acc: Option<Accumulated> = None;
        for frame in &frames {
            let prev = acc.as_ref().map(|a| Previous {
                camera: &cam,
                receivers: &rx,
                visibility: &a.visibility,
                length: &a.length,
            });
            acc = Some(accumulate(&rx, frame, prev.as_ref(), &opts).unwrap().0);
        }
        let acc = acc.unwrap();
        for i in (0..256).filter(|&i| rx.valid[i]) {
            let mean = frames.iter().map(|f| f[i]).sum::<f32>() / 10.0;
            assert!((acc.visibility[i] - mean).abs() < 1e-4, "pixel {i}");
            assert!((acc.length[i] - 10.0).abs() < 1e-4, "pixel {i}");
        }
    }

    #[test]
    fn bad_options_and_histories_name_themselves() {
        let (cam, rx) = ground(Vec3::new(0.0, 3.0, 4.0), 4);
        let v = vec![0.5; 16];
        let arg = |r: Result<(Accumulated, Stats)>| match r {
            Err(Error::InvalidInput { arg, .. }) => arg,
            other => format!("{other:?}"),
        };
        for (opts, name) in [
            (
                TemporalOptions {
                    alpha: 0.0,
                    ..Default::default()
                },
                "alpha",
            ),
            (
                TemporalOptions {
                    depth_tolerance: f32::NAN,
                    ..Default::default()
                },
                "depth_tolerance",
            ),
            (
                TemporalOptions {
                    normal_tolerance: 200.0,
                    ..Default::default()
                },
                "normal_tolerance",
            ),
        ] {
            assert_eq!(arg(accumulate(&rx, &v, None, &opts)), name);
        }
        let opts = TemporalOptions::default();
        assert_eq!(arg(accumulate(&rx, &v[..3], None, &opts)), "visibility");
        assert!(rx.valid.contains(&true), "the receivers have hit pixels");
        for wrong in [f32::NAN, 1.5, -0.25] {
            let bad: Vec<f32> = v
                .iter()
                .zip(&rx.valid)
                .map(|(&x, &hit)| if hit { wrong } else { x })
                .collect();
            assert_eq!(arg(accumulate(&rx, &bad, None, &opts)), "visibility");
        }
        let short = Previous {
            camera: &cam,
            receivers: &rx,
            visibility: &v[..3],
            length: &v,
        };
        assert_eq!(arg(accumulate(&rx, &v, Some(&short), &opts)), "history");
    }
}
