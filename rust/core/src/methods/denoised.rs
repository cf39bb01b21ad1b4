//! `denoised`: a few stochastic shadow rays per pixel and a penumbra-aware spatio-temporal
//! denoiser, the approach of the shadow denoisers in current engines and of Boksansky, Wimmer and
//! Bittner 2019, Ray Traced Shadows: Maintaining Real-Time Frame Rates (Ray Tracing Gems,
//! chapter 13): the baseline an engine programmer compares the classic methods with.
//!
//! The receivers are a G-buffer on a camera's pixel grid (the filter works in screen space).
//! Stages, each timed in the stats:
//!
//! 1. **trace**: `spp` shadow rays per pixel on the BVH that `ray_traced` uses, to points of the
//!    pixel's own Owen-scrambled Sobol sequence ([`pixel_sequence_point`]; frame `f` draws its
//!    indices `f spp .. (f + 1) spp`, so frames continue one stratified sequence), warped by the
//!    emission texture of a textured light ([`EmissionWarp`]) so that the plain fraction of
//!    unblocked rays estimates the weighted visibility of `docs/design.md` section 3. Each ray is
//!    a nearest-hit query ([`Bvh::intersect`]), whose hit gives the distance to the first
//!    blocker as a fraction `t` of the segment; rays to samples behind the tangent plane are not
//!    traced and count as shadowed, as in the definition.
//! 2. **blocker**: the penumbra estimate of percentage-closer soft shadows (Fernando 2005,
//!    Percentage-Closer Soft Shadows) from the ray hits: the blocked rays' mean `t` over a
//!    `search_radius` window (edge-aware, as the filter below; a pixel's own rays are mostly
//!    unblocked in a bright penumbra), and by parallel planes the penumbra width
//!    `w = light size * t / (1 - t)` (the receiver-to-blocker over the blocker-to-light
//!    distance, the light's size its bounding diameter; an isotropic estimate). The filter
//!    follows it, as Boksansky et al. size their kernel by the penumbra: a Gaussian of standard
//!    deviation `w / 4` on the receiver's surface, whose two deviations either side span the
//!    penumbra, reaching as many pixels as that covers at the receiver's depth (at most
//!    `max_radius`). A contact shadow (blocker at `t` near 0) stays sharp, and a pixel with no
//!    blocked ray in its window, lit or facing away, is left as traced.
//! 3. **temporal** (with a history): the per-frame visibility is reprojected and accumulated by
//!    [`crate::temporal`], the stage every method's `accumulate` runs.
//! 4. **filter**: that Gaussian, over each tap's world distance from the center (so a surface
//!    seen at a grazing angle is not blurred further along it than across), separable
//!    (horizontal, then vertical, each pass weighting its taps against its own center), with the
//!    edge-stopping weights of Schied et al. 2017, Spatiotemporal Variance-Guided Filtering,
//!    section 4.4: normals by `max(0, n_p . n_q)^sigma_n`, depth by
//!    `exp(-dz / (sigma_z * expected change))`. The G-buffer holds world positions, so `dz` is
//!    the tap's distance from the center's tangent plane and the expected change one pixel's
//!    world size per pixel of offset (theirs: the screen-space depth gradient times the
//!    offset): taps on the same plane weigh fully however grazing the view. The deviation
//!    shrinks as `1 / sqrt(spp * history length)`, as the noise it averages away does (our
//!    choice, in place of their variance-guided luminance weight): with more rays or frames the
//!    filter narrows, and `denoised` converges to `ray_traced` as `spp` grows.
//!
//! Everything is a pure function of the seed, the frame and the inputs, whatever the thread
//! count: each pixel draws its own sequence, and each filter pass reads only the previous one.

use crate::error::{Error, Result};
use crate::geometry::bvh::Bvh;
use crate::geometry::camera::Camera;
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::interrupt;
use crate::light::lights::{EmissionWarp, Light};
use crate::light::sampling::pixel_sequence_point;
use crate::limits::{Peak, Work};
use crate::stats::Stats;
use crate::temporal::{self, Accumulated, Previous, TemporalOptions};
use glam::Vec3;

/// The stats keys every call returns (beside [`crate::stats::COMMON`]): the four stages' seconds
/// (`temporal_seconds` 0 without a history), `rays` traced (to samples in front of the tangent
/// plane), `blocked_rays`, the temporal stage's
/// `reprojected` and `restarted` pixels, `filter_taps` weighed by the filter, the mean filter
/// `radius` (reach) in pixels over the valid receivers, `receivers` and `spp`.
pub const STATS: &[&str] = &[
    "trace_seconds",
    "blocker_seconds",
    "temporal_seconds",
    "filter_seconds",
    "rays",
    "blocked_rays",
    "reprojected",
    "restarted",
    "filter_taps",
    "radius",
    "receivers",
    "spp",
];

/// The most shadow rays per pixel, and the widest filter or search radius in pixels.
pub const MAX_SPP: usize = 4096;
pub const MAX_RADIUS: usize = 256;

/// Options of [`denoised`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DenoisedOptions {
    /// Shadow rays per pixel and frame (default 1).
    pub spp: usize,
    /// Seed of every pixel's sequence.
    pub seed: u64,
    /// The frame of a sequence: frame `f` draws indices `f spp .. (f + 1) spp`.
    pub frame: u64,
    /// Shadow-ray origin offset along the normal (world units, >= 0), as in `ray_traced`.
    pub epsilon: f32,
    /// Half width in pixels of the blocker search window (default 8).
    pub search_radius: usize,
    /// The largest filter radius in pixels (default 16).
    pub max_radius: usize,
    /// Depth edge-stopping scale (Schied et al. 2017: 1).
    pub sigma_z: f32,
    /// Normal edge-stopping exponent (Schied et al. 2017: 128).
    pub sigma_n: f32,
    /// The temporal stage's options, or `None` for a still frame (no history).
    pub temporal: Option<TemporalOptions>,
}

impl DenoisedOptions {
    /// The defaults with `epsilon`.
    pub fn with_epsilon(epsilon: f32) -> Self {
        Self {
            spp: 1,
            seed: 0,
            frame: 0,
            epsilon,
            search_radius: 8,
            max_radius: 16,
            sigma_z: 1.0,
            sigma_n: 128.0,
            temporal: None,
        }
    }

    fn validate(&self) -> Result<()> {
        if !(1..=MAX_SPP).contains(&self.spp) {
            return Err(Error::invalid(
                "spp",
                format!("must be in 1..={MAX_SPP}, got {}", self.spp),
            ));
        }
        if !(self.epsilon.is_finite() && self.epsilon >= 0.0) {
            return Err(Error::invalid(
                "epsilon",
                format!("must be finite and >= 0, got {}", self.epsilon),
            ));
        }
        for (arg, r) in [
            ("search_radius", self.search_radius),
            ("max_radius", self.max_radius),
        ] {
            if r > MAX_RADIUS {
                return Err(Error::invalid(
                    arg,
                    format!("must be at most {MAX_RADIUS} pixels, got {r}"),
                ));
            }
        }
        for (arg, x) in [("sigma_z", self.sigma_z), ("sigma_n", self.sigma_n)] {
            if !(x.is_finite() && x > 0.0) {
                return Err(Error::invalid(
                    arg,
                    format!("must be finite and > 0, got {x}"),
                ));
            }
        }
        let spp = self.spp as u64;
        let end = self.frame.checked_mul(spp).and_then(|f| f.checked_add(spp));
        if end.is_none_or(|e| e > u64::from(u32::MAX)) {
            return Err(Error::invalid(
                "frame",
                format!(
                    "frame {} of {spp} rays per pixel runs past the 2^32 points of a pixel's sequence",
                    self.frame
                ),
            ));
        }
        if let Some(t) = &self.temporal {
            t.validate()?;
        }
        Ok(())
    }
}

/// The denoised visibility, and the temporal stage's accumulation (the history's next frame;
/// without a history, the traced visibility with a history length of 1).
#[derive(Debug, Clone, PartialEq)]
pub struct Denoised {
    pub visibility: Vec<f32>,
    pub accumulated: Accumulated,
}

/// One pixel's rays: the fraction unblocked, the rays traced (to samples in front of the
/// tangent plane), and the blocked ones with their summed hit fractions `t`.
#[derive(Debug, Clone, Copy, Default)]
struct Traced {
    visibility: f32,
    rays: u32,
    blocked: u32,
    t_sum: f32,
}

/// Denoised visibility of the G-buffer `receivers` of `camera` (see the module doc), with the
/// previous frame `previous` when the temporal stage runs.
pub fn denoised(
    scene: &Scene,
    bvh: &Bvh,
    light: &Light,
    receivers: &Receivers,
    camera: &Camera,
    previous: Option<&Previous>,
    opts: &DenoisedOptions,
) -> Result<(Denoised, Stats)> {
    opts.validate()?;
    bvh.check_scene(scene)?;
    if receivers.width != camera.width || receivers.height != camera.height {
        return Err(Error::invalid(
            "receivers",
            format!(
                "expected the camera's {}x{} G-buffer, got {}x{} receivers",
                camera.width, camera.height, receivers.width, receivers.height
            ),
        ));
    }
    let n = receivers.len() as u64;
    let mut stats = Stats::declared(STATS);
    // Per receiver while the filter runs: its rays (16 bytes), world size, mean blocker and
    // standard deviation (12), the accumulation and its lengths (8), the filter's input pairs and
    // two passes, each collected from (pair, taps) tuples (8 + 2 x 24), and the output (4); a
    // textured light's importance sampler, a cumulative sum (f64) per texel.
    Peak::default()
        .buffer(&[n, 96])
        .buffer(&[light.emission_texels() as u64, 8])
        .check("denoised", &mut stats)?;
    let taps = 2 * (2 * (opts.search_radius + opts.max_radius) as u64 + 2);
    Work::default()
        .loop_of(&[n, opts.spp as u64, Work::RAY])
        .loop_of(&[n, taps])
        .check("denoised", &mut stats)?;
    let traced = stats.time("trace", || trace(scene, bvh, light, receivers, opts))?;
    let guide = Guide::new(receivers, camera, opts);
    let t_mean = stats.time("blocker", || {
        mean_blocker_t(&guide, &traced, opts.search_radius)
    })?;
    let visibility: Vec<f32> = traced.iter().map(|t| t.visibility).collect();
    let accumulated = match &opts.temporal {
        Some(t) => {
            let (acc, temporal_stats) = temporal::accumulate(receivers, &visibility, previous, t)?;
            for key in temporal::STATS {
                stats.set(key, temporal_stats.get(key).unwrap_or(0.0));
            }
            acc
        }
        None => Accumulated {
            length: receivers
                .valid
                .iter()
                .map(|&v| f32::from(u8::from(v)))
                .collect(),
            visibility,
        },
    };
    let size = 2.0 * light.extent() as f32;
    let sigma: Vec<f32> = (0..receivers.len())
        .map(|i| {
            let len = accumulated.length[i].max(1.0);
            filter_sigma(&guide, i, t_mean[i], size, opts.spp as f32 * len)
        })
        .collect();
    let (out, filter_taps) = stats.time("filter", || {
        gaussian(&guide, &accumulated.visibility, &sigma)
    })?;
    let valid = receivers.valid.iter().filter(|&&v| v).count();
    let count = |f: fn(&Traced) -> u32| traced.iter().map(|t| u64::from(f(t))).sum::<u64>();
    stats.set("rays", count(|t| t.rays) as f64);
    let blocked = count(|t| t.blocked);
    stats.set("blocked_rays", blocked as f64);
    stats.set("filter_taps", filter_taps as f64);
    stats.set(
        "radius",
        (0..receivers.len())
            .map(|i| filter_reach(&guide, i, sigma[i]) as f64)
            .sum::<f64>()
            / valid.max(1) as f64,
    );
    stats.set("receivers", valid as f64);
    stats.set("spp", opts.spp as f64);
    Ok((
        Denoised {
            visibility: out,
            accumulated,
        },
        stats,
    ))
}

/// Stage 1: every pixel's rays (see the module doc).
fn trace(
    scene: &Scene,
    bvh: &Bvh,
    light: &Light,
    receivers: &Receivers,
    opts: &DenoisedOptions,
) -> Result<Vec<Traced>> {
    let warp = light.emission_warp();
    let dim = light.dim();
    let first = opts.frame * opts.spp as u64;
    interrupt::par_map(receivers.len(), opts.spp as u64 * Work::RAY, |i| {
        if !receivers.valid[i] {
            return Traced::default();
        }
        let (p, n) = (receivers.points[i], receivers.normals[i]);
        let origin = p + n * opts.epsilon;
        let mut traced = Traced::default();
        let mut lit = 0u32;
        for k in 0..opts.spp as u64 {
            let unit = pixel_sequence_point(opts.seed, i as u64, (first + k) as u32, dim);
            let y = light_point(light, warp.as_ref(), unit);
            // Behind the tangent plane: blocked by the receiver itself, never traced.
            if (y - p).dot(n) <= 0.0 {
                continue;
            }
            traced.rays += 1;
            match bvh.intersect(scene, origin, y - origin, 1.0) {
                None => lit += 1,
                Some(hit) => {
                    traced.t_sum += hit.t;
                    traced.blocked += 1;
                }
            }
        }
        traced.visibility = lit as f32 / opts.spp as f32;
        traced
    })
}

/// The light point of unit point `unit`, through the emission warp of a textured light.
fn light_point(light: &Light, warp: Option<&EmissionWarp>, unit: [f32; 3]) -> Vec3 {
    match warp {
        Some(w) => {
            let [s, t] = w.warp([unit[0], unit[1]]);
            light.map([s, t, 0.0])
        }
        None => light.map(unit),
    }
}

/// What the edge-aware passes read: the receivers on their pixel grid, each pixel's world size,
/// the edge-stopping parameters and the cap of the filter radius.
struct Guide<'a> {
    receivers: &'a Receivers,
    pixel_size: Vec<f32>,
    sigma_z: f32,
    sigma_n: f32,
    max_radius: f32,
}

impl<'a> Guide<'a> {
    fn new(receivers: &'a Receivers, camera: &Camera, opts: &DenoisedOptions) -> Self {
        let pixel_size = receivers
            .points
            .iter()
            .map(|&p| camera.pixel_size_at(camera.depth(p)))
            .collect();
        Self {
            receivers,
            pixel_size,
            sigma_z: opts.sigma_z,
            sigma_n: opts.sigma_n,
            max_radius: opts.max_radius as f32,
        }
    }

    /// The edge-stopping weight of tap `q`, `offset` pixels from center `c` (Schied et al.
    /// 2017, section 4.4, with the depth change measured off `c`'s tangent plane: see the
    /// module doc); 0 for an invalid tap.
    fn weight(&self, c: usize, q: usize, offset: usize) -> f32 {
        let r = self.receivers;
        if !r.valid[q] {
            return 0.0;
        }
        if offset == 0 {
            return 1.0;
        }
        let (nc, nq) = (r.normals[c], r.normals[q]);
        let normal = nc.dot(nq).max(0.0).powf(self.sigma_n);
        let dz = nc.dot(r.points[q] - r.points[c]).abs();
        let expected = self.sigma_z * self.pixel_size[c] * offset as f32;
        normal * (-dz / expected).exp()
    }
}

/// A weighted sum and its total weight, which the separable passes carry, so that two passes
/// compute one normalized 2D weighted mean.
type Pair = [f32; 2];

/// One pass of a separable cross-bilateral filter along rows (`horizontal`) or columns over
/// `input` pairs: each valid pixel `c` sums its taps `q` within `reach(c)` pixels, weighted by
/// `kernel(c, q)` and the edge-stopping weight. Returns the pairs and the taps weighed (those
/// whose pair is not zero).
fn pass(
    guide: &Guide,
    input: &[Pair],
    horizontal: bool,
    reach: &(dyn Fn(usize) -> usize + Sync),
    kernel: &(dyn Fn(usize, usize) -> f32 + Sync),
) -> Result<(Vec<Pair>, u64)> {
    let r = guide.receivers;
    let (w, h) = (r.width, r.height);
    let pixels = interrupt::par_map(r.len(), 64, |c| {
        if !r.valid[c] {
            return ([0.0; 2], 0);
        }
        let k = reach(c);
        let (x, y) = (c % w, c / w);
        let (pos, len, stride) = if horizontal { (x, w, 1) } else { (y, h, w) };
        let (lo, hi) = (pos.saturating_sub(k), (pos + k).min(len - 1));
        let (mut sum, mut taps) = ([0.0f32; 2], 0u64);
        for t in lo..=hi {
            let q = c + t * stride - pos * stride;
            // A pair of zeros adds nothing whatever its weight (the weights are finite): most
            // pixels of the blocker search, which have no blocked ray.
            if input[q] == [0.0; 2] {
                continue;
            }
            let offset = t.abs_diff(pos);
            let weight = kernel(c, q) * guide.weight(c, q, offset);
            sum[0] += weight * input[q][0];
            sum[1] += weight * input[q][1];
            taps += 1;
        }
        (sum, taps)
    })?;
    let taps = pixels.iter().map(|p| p.1).sum();
    Ok((pixels.into_iter().map(|p| p.0).collect(), taps))
}

/// The two passes of [`pass`], rows then columns; returns the pairs and the taps weighed.
fn separable(
    guide: &Guide,
    input: &[Pair],
    reach: &(dyn Fn(usize) -> usize + Sync),
    kernel: &(dyn Fn(usize, usize) -> f32 + Sync),
) -> Result<(Vec<Pair>, u64)> {
    let (rows, a) = pass(guide, input, true, reach, kernel)?;
    let (both, b) = pass(guide, &rows, false, reach, kernel)?;
    Ok((both, a + b))
}

/// Stage 2: each pixel's mean blocker fraction `t` over the blocked rays in its search window
/// (NaN where there are none).
fn mean_blocker_t(guide: &Guide, traced: &[Traced], search_radius: usize) -> Result<Vec<f32>> {
    let input: Vec<Pair> = traced.iter().map(|t| [t.t_sum, t.blocked as f32]).collect();
    let (sums, _) = separable(guide, &input, &|_| search_radius, &|_, _| 1.0)?;
    Ok(sums
        .iter()
        .map(|&[t, count]| if count > 0.0 { t / count } else { f32::NAN })
        .collect())
}

/// The filter's standard deviation at pixel `i`, in world units on its surface: a quarter of the
/// parallel-planes penumbra width of a light of diameter `size` over a blocker at the fraction
/// `t` of the way to the light (Fernando 2005), so that the kernel's two standard deviations
/// either side span the penumbra, over `sqrt(estimates)` (rays times frames averaged), and at
/// most half the cap's pixels at the pixel's world size; 0 without a blocker.
fn filter_sigma(guide: &Guide, i: usize, t: f32, size: f32, estimates: f32) -> f32 {
    if !(guide.receivers.valid[i] && t.is_finite()) {
        return 0.0;
    }
    let t = t.clamp(0.0, 0.999);
    let penumbra = size * t / (1.0 - t);
    (0.25 * penumbra / estimates.sqrt()).min(0.5 * guide.max_radius * guide.pixel_size[i])
}

/// The filter's reach at pixel `i` in pixels: two standard deviations at its world size, 0 when
/// that is below half a pixel (the pixel is left as it is).
fn filter_reach(guide: &Guide, i: usize, sigma: f32) -> usize {
    let pixels = 2.0 * sigma / guide.pixel_size[i];
    if pixels < 0.5 {
        0
    } else {
        pixels.ceil() as usize
    }
}

/// Stage 4: the separable Gaussian of standard deviation `sigma` (world units) per pixel over the
/// world distance of each tap from the center (see the module doc). Returns the visibility and
/// the taps weighed.
fn gaussian(guide: &Guide, visibility: &[f32], sigma: &[f32]) -> Result<(Vec<f32>, u64)> {
    let r = guide.receivers;
    let input: Vec<Pair> = visibility
        .iter()
        .zip(&r.valid)
        .map(|(&v, &ok)| if ok { [v, 1.0] } else { [0.0; 2] })
        .collect();
    let reach = |c: usize| filter_reach(guide, c, sigma[c]);
    let kernel = |c: usize, q: usize| {
        if q == c {
            return 1.0;
        }
        let d2 = (r.points[q] - r.points[c]).length_squared();
        (-d2 / (2.0 * sigma[c] * sigma[c])).exp()
    };
    let (sums, taps) = separable(guide, &input, &reach, &kernel)?;
    let out = sums
        .iter()
        .zip(&r.valid)
        .map(|(&[v, weight], &ok)| {
            if ok && weight > 0.0 {
                (v / weight).clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
        .collect();
    Ok((out, taps))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::gbuffer::gbuffer;
    use crate::geometry::mesh::Mesh;
    use crate::light::sampling::SampleSet;
    use crate::methods::ray_traced::{ray_traced, RayTracedOptions};

    /// A ground square and a smaller square floating over it, seen from above at an angle.
    fn setup() -> (Scene, Bvh, Camera, Receivers) {
        let quad = |y: f32, s: f32| {
            let p = [(-s, -s), (s, -s), (s, s), (-s, s)].map(|(x, z)| Vec3::new(x, y, z));
            Mesh::new(p.to_vec(), vec![[0, 2, 1], [0, 3, 2]], None, None, false).unwrap()
        };
        let scene = Scene::new(vec![quad(0.0, 3.0), quad(0.6, 0.5)]).unwrap();
        let bvh = Bvh::build(&scene).unwrap();
        let camera =
            Camera::look_at(Vec3::new(0.0, 4.0, 3.0), Vec3::ZERO, Vec3::Y, 50.0, 40, 32).unwrap();
        let rx = gbuffer(&scene, &bvh, &camera, 1)
            .unwrap()
            .receivers()
            .unwrap();
        (scene, bvh, camera, rx)
    }

    #[test]
    fn a_point_light_gives_the_oracles_hard_shadow_bit_for_bit() {
        // A point light has no penumbra: no pixel is filtered, and every ray answers as the
        // oracle's one ray does, shadowed pixels included.
        let (scene, bvh, camera, rx) = setup();
        let light = Light::point(Vec3::new(0.4, 3.0, 0.2)).unwrap();
        let opts = DenoisedOptions {
            spp: 3,
            ..DenoisedOptions::with_epsilon(1e-4)
        };
        let (out, stats) = denoised(&scene, &bvh, &light, &rx, &camera, None, &opts).unwrap();
        let samples = SampleSet::explicit(vec![light.center()], None).unwrap();
        let oracle_opts = RayTracedOptions {
            epsilon: 1e-4,
            ..RayTracedOptions::for_scene(&scene)
        };
        let (oracle, _) = ray_traced(&scene, &bvh, &light, &rx, &samples, &oracle_opts).unwrap();
        assert_eq!(out.visibility, oracle);
        let shadowed = oracle
            .iter()
            .zip(&rx.valid)
            .filter(|(&v, &ok)| ok && v == 0.0);
        assert!(shadowed.count() > 20);
        assert_eq!(stats.get("radius"), Some(0.0));
        assert!(stats.get("blocked_rays").unwrap() > 60.0);
    }

    #[test]
    fn an_area_light_is_filtered_within_the_valid_range() {
        let (scene, bvh, camera, rx) = setup();
        let light = Light::rect(Vec3::new(0.0, 3.0, 0.0), Vec3::X * 0.5, Vec3::Z * 0.5).unwrap();
        let opts = DenoisedOptions::with_epsilon(1e-4);
        let (out, stats) = denoised(&scene, &bvh, &light, &rx, &camera, None, &opts).unwrap();
        assert!(stats.get("radius").unwrap() > 0.0);
        for (v, &ok) in out.visibility.iter().zip(&rx.valid) {
            assert!((0.0..=1.0).contains(v) && (ok || *v == 0.0), "{v}");
        }
        // A penumbra: values strictly between the umbra and the lit ground.
        assert!(out.visibility.iter().any(|&v| v > 0.05 && v < 0.95));
        // A G-buffer of another size than the camera's is refused.
        let other = Camera { width: 8, ..camera };
        let refused = denoised(&scene, &bvh, &light, &rx, &other, None, &opts);
        assert!(matches!(refused, Err(Error::InvalidInput { arg, .. }) if arg == "receivers"));
    }
}
