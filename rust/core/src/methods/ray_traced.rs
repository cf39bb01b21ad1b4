//! The ray-traced oracle (DESIGN.md section 3).
//!
//! V(p) = sum_s w_s v(p, y_s) / sum_s w_s over the receiver's light samples (the weights are the
//! emission-texture values, all 1 for untextured lights; a zero weight sum gives 0). v = 1 when
//! the open segment from p' = p + epsilon n to y_s hits no opaque surface (alpha-tested for
//! perforated meshes, see [`crate::geometry::bvh`]) and y_s lies strictly in front of p's
//! tangent plane, `dot(y_s - p, n) > 0`; else 0. Samples behind the plane, or of weight 0, are
//! not traced. Invalid receivers (G-buffer pixels with no hit) get 0.
//!
//! Receivers are processed in parallel chunks; each receiver's result depends only on its own
//! samples, so the output is the same bits for any thread count. The shadow rays of a receiver
//! go to [`Bvh::occluded_many`] together: they share their origin, so one frustum traversal
//! finds the few leaves they may hit (none for a lit receiver), and umbra rays reuse the leaf
//! that blocked the previous ray; neither changes an answer.

use crate::error::{Error, Result};
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::light::lights::Light;
use crate::light::sampling::SampleSet;
use crate::limits;
use crate::stats::Stats;
use glam::Vec3;
use rayon::prelude::*;

/// Receivers per parallel work item (consecutive pixels share occluders: good cache reuse).
const CHUNK: usize = 64;

/// Options of [`ray_traced`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayTracedOptions {
    /// Offset of the shadow-ray origins along the receiver normal (world units, >= 0); see
    /// [`auto_epsilon`] for the default.
    pub epsilon: f32,
}

impl RayTracedOptions {
    /// The options with `epsilon = auto_epsilon(scene)`.
    pub fn for_scene(scene: &Scene) -> Self {
        Self { epsilon: auto_epsilon(scene) }
    }
}

/// The default normal offset: `1e-4` times the diagonal of the scene's bounding box. Large
/// enough to step off the receiver's own triangle at float precision for any scene scale, small
/// enough not to skip real contact shadows. The Python layer and the Mitsuba reference use the
/// same value, so their rays start at the same points.
pub fn auto_epsilon(scene: &Scene) -> f32 {
    let (lo, hi) = scene.bounds();
    1e-4 * (hi - lo).length()
}

/// Visibility of every receiver by tracing its shadow rays (see the module doc). Returns one
/// value in [0, 1] per receiver and the stats `trace_seconds`, `rays` (segments traced),
/// `receivers` (valid ones) and `samples` (per receiver).
pub fn ray_traced(
    scene: &Scene,
    bvh: &Bvh,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &RayTracedOptions,
) -> Result<(Vec<f32>, Stats)> {
    if !(opts.epsilon.is_finite() && opts.epsilon >= 0.0) {
        return Err(Error::invalid("epsilon", format!("must be finite and >= 0, got {}", opts.epsilon)));
    }
    bvh.check_scene(scene)?;
    let n = receivers.len();
    // Per thread: samples, weights, traced targets, their weights and answers (33 bytes each).
    let per_thread = limits::bytes(&[samples.count() as u64, 40]);
    let threads = rayon::current_num_threads() as u64;
    limits::check_memory(
        "ray_traced",
        limits::bytes(&[n as u64, 4]).saturating_add(per_thread.saturating_mul(threads)),
    )?;
    let mut out = vec![0f32; n];
    let mut stats = Stats::default();
    let rays = stats.time("trace", || trace_all(scene, bvh, light, receivers, samples, opts.epsilon, &mut out));
    stats.set("rays", rays as f64);
    stats.set("receivers", receivers.valid.iter().filter(|&&v| v).count() as f64);
    stats.set("samples", samples.count() as f64);
    Ok((out, stats))
}

/// Fills `out` in parallel chunks with thread-local buffers; returns the rays traced. When every
/// receiver uses the same unweighted samples they are read in place instead of copied.
fn trace_all(
    scene: &Scene,
    bvh: &Bvh,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    epsilon: f32,
    out: &mut [f32],
) -> u64 {
    let shared = samples.is_shared() && !light.is_textured();
    let ones = if shared { vec![1.0f32; samples.count()] } else { Vec::new() };
    out.par_chunks_mut(CHUNK)
        .enumerate()
        .map_init(
            || (Vec::with_capacity(samples.count()), Vec::with_capacity(samples.count()), Traced::default()),
            |(ys, ws, traced), (c, chunk)| {
                let mut rays = 0;
                for (k, v) in chunk.iter_mut().enumerate() {
                    let i = c * CHUNK + k;
                    if !receivers.valid[i] {
                        continue;
                    }
                    let (p, n) = (receivers.points[i], receivers.normals[i]);
                    let (vis, count) = if shared {
                        let pattern = samples.pattern_for(0, 0);
                        receiver_visibility(scene, bvh, p, n, epsilon, pattern, &ones, traced)
                    } else {
                        samples.fill(light, i, receivers.pixel(i), ys, ws);
                        receiver_visibility(scene, bvh, p, n, epsilon, ys, ws, traced)
                    };
                    *v = vis;
                    rays += count;
                }
                rays
            },
        )
        .sum()
}

/// Per-thread buffers: the targets a receiver actually traces, their weights and answers.
#[derive(Debug, Default)]
struct Traced {
    targets: Vec<Vec3>,
    weights: Vec<f32>,
    blocked: Vec<bool>,
}

/// The weighted fraction of unblocked samples `ys` (weights `ws`) of the receiver at `p` with
/// normal `n`, and the number of rays traced.
#[allow(clippy::too_many_arguments)]
fn receiver_visibility(
    scene: &Scene,
    bvh: &Bvh,
    p: Vec3,
    n: Vec3,
    epsilon: f32,
    ys: &[Vec3],
    ws: &[f32],
    s: &mut Traced,
) -> (f32, u64) {
    let origin = p + n * epsilon;
    s.targets.clear();
    s.weights.clear();
    let mut total = 0f64;
    for (&y, &w) in ys.iter().zip(ws) {
        total += f64::from(w);
        // Behind the tangent plane, or of weight zero: contributes nothing, traced never.
        if w != 0.0 && (y - p).dot(n) > 0.0 {
            s.targets.push(y);
            s.weights.push(w);
        }
    }
    bvh.occluded_many(scene, origin, &s.targets, &mut s.blocked);
    let lit: f64 = s.weights.iter().zip(&s.blocked).filter(|(_, &b)| !b).map(|(&w, _)| f64::from(w)).sum();
    let v = if total > 0.0 { (lit / total).clamp(0.0, 1.0) as f32 } else { 0.0 };
    (v, s.targets.len() as u64)
}
