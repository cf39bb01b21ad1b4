//! The ray-traced oracle (`docs/design.md` section 3).
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
//! finds the few leaves they may hit (none for a lit receiver; none wholly behind the receiver's
//! tangent plane, which its rays never reach), and umbra rays reuse the leaf
//! that blocked the previous ray; neither changes an answer. When all receivers share their
//! samples, the receivers go by screen tiles: a tile whose shaft to the samples meets no leaf
//! is lit at once (Haines and Wallace 1994), and receivers in penumbra or umbra are traced as
//! coherent packets of the tile's rays to each sample ([`Bvh::occluded_converging`], after
//! Benthin and Wald 2009), or of each receiver's rays where that makes fewer packets
//! ([`Bvh::occluded_diverging`]): same answers, about twice as fast for those rays.

use crate::error::{Error, Result};
use crate::geometry::bvh::{Bvh, FrontPlane};
use crate::geometry::inside::inside_closed_meshes;
use crate::geometry::mesh::Scene;
use crate::geometry::receivers::Receivers;
use crate::interrupt;
use crate::isa::{movemask, top_bit};
use crate::light::lights::Light;
use crate::light::sampling::{lit_fraction, SampleSet};
use crate::limits::{self, Peak, Work};
use crate::methods::CasterFaces;
use crate::stats::Stats;
use glam::{DVec3, UVec3, Vec3};
use rayon::prelude::*;
use std::borrow::Cow;

/// Receivers per parallel work item (consecutive pixels share occluders: good cache reuse).
const CHUNK: usize = 64;

/// Options of [`ray_traced`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayTracedOptions {
    /// Offset of the shadow-ray origins along the receiver normal (world units, >= 0); see
    /// [`auto_epsilon`] for the default.
    pub epsilon: f32,
    /// `CasterFaces::All` (the default): every triangle, from `p + epsilon n`, the definition.
    /// `CasterFaces::Backfacing`: closed meshes' triangles block only from receivers strictly in
    /// front of their plane, from `p` itself, as `alias_free` culls them; so `alias_free` has an
    /// oracle on its default, and the definition's limit for epsilon -> 0 on closed meshes.
    pub caster_faces: CasterFaces,
}

impl RayTracedOptions {
    /// The options with `epsilon = auto_epsilon(scene)` and every triangle casting.
    pub fn for_scene(scene: &Scene) -> Self {
        Self {
            epsilon: auto_epsilon(scene) as f32,
            caster_faces: CasterFaces::All,
        }
    }
}

/// The default normal offset: `1e-4` times the diagonal of the scene's bounding box (in f64, so
/// that a diagonal beyond f32's range still gives one). Large enough to step off the receiver's
/// own triangle at float precision for any scene scale, small enough not to skip real contact
/// shadows. The Python layer (`Scene.epsilon`) and the Mitsuba reference take this value, so
/// their rays start at the same points.
pub fn auto_epsilon(scene: &Scene) -> f64 {
    let (lo, hi) = scene.bounds();
    1e-4 * (hi.as_dvec3() - lo.as_dvec3()).length()
}

/// The stats keys every call returns (beside [`crate::stats::COMMON`]), zeroed at the start:
/// the one declaration the Python docstring and the key tests read.
pub const STATS: &[&str] = &[
    "trace_seconds",
    "rays",
    "receivers",
    "samples",
    "shaft_lit_receivers",
    "frustum_lit_receivers",
    "candidate_receivers",
    "diverging_receivers",
    "converging_receivers",
];

/// Visibility of every receiver by tracing its shadow rays (see the module doc). Returns one
/// value in [0, 1] per receiver and the stats `trace_seconds`, `rays` (segments traced),
/// `receivers` (valid ones), `samples` (per receiver) and, when every receiver shares the
/// samples (else 0), how many valid receivers each path of [`trace_tile`] answered:
/// `shaft_lit_receivers` (a tile's shaft met no leaf), `frustum_lit_receivers` (the receiver's
/// frustum met none), `candidate_receivers` (its rays tested against the leaves its frustum met),
/// `diverging_receivers` and `converging_receivers` (its rays traced in packets by receiver or by
/// sample). They sum to `receivers`, and say where a scene's time goes: the packets' receivers
/// cost the most per ray.
pub fn ray_traced(
    scene: &Scene,
    bvh: &Bvh,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    opts: &RayTracedOptions,
) -> Result<(Vec<f32>, Stats)> {
    if !(opts.epsilon.is_finite() && opts.epsilon >= 0.0) {
        return Err(Error::invalid(
            "epsilon",
            format!("must be finite and >= 0, got {}", opts.epsilon),
        ));
    }
    bvh.check_scene(scene)?;
    let n = receivers.len();
    // Per thread: samples, weights, traced targets, their weights and answers (33 bytes each),
    // or for shared samples a tile's front-facing flags (one byte per receiver and sample).
    let per_thread = limits::bytes(&[samples.count() as u64, 40 + TILE as u64]);
    let threads = rayon::current_num_threads() as u64;
    let mut stats = Stats::declared(STATS);
    Peak::default()
        .buffer(&[n as u64, 4])
        .buffer(&[per_thread, threads])
        .check("ray_traced", &mut stats)?;
    Work::default()
        .loop_of(&[n as u64, samples.count() as u64, Work::RAY])
        .check("ray_traced", &mut stats)?;
    let mut out = vec![0f32; n];
    let paths = stats.time("trace", || {
        let culled = culled_receivers(scene, bvh, receivers, opts)?;
        trace_all(
            scene,
            bvh,
            light,
            receivers,
            samples,
            (opts.epsilon, culled.as_deref()),
            &mut out,
        )
    })?;
    paths.record(&mut stats);
    stats.set(
        "receivers",
        receivers.valid.iter().filter(|&&v| v).count() as f64,
    );
    stats.set("samples", samples.count() as f64);
    Ok((out, stats))
}

/// With `CasterFaces::Backfacing` on a scene with a closed mesh, per receiver whether the culling of
/// closed casters holds for it: it lies outside every closed mesh (see
/// [`crate::geometry::inside`]). `None` when every triangle casts from the moved receiver.
fn culled_receivers(
    scene: &Scene,
    bvh: &Bvh,
    receivers: &Receivers,
    opts: &RayTracedOptions,
) -> Result<Option<Vec<bool>>> {
    if opts.caster_faces == CasterFaces::All || !scene.meshes.iter().any(|m| m.closed) {
        return Ok(None);
    }
    let points: Vec<(DVec3, DVec3)> = (0..receivers.len())
        .map(|i| {
            (
                receivers.points[i].as_dvec3(),
                receivers.normals[i].as_dvec3(),
            )
        })
        .collect();
    let inside = inside_closed_meshes(scene, &points, f64::from(opts.epsilon), || {
        Ok(Cow::Borrowed(bvh))
    })?;
    Ok(Some(
        inside
            .iter()
            .zip(&receivers.valid)
            .map(|(&inside, &valid)| valid && !inside)
            .collect(),
    ))
}

/// Fills `out` in parallel with thread-local buffers, in interruptible rounds; returns the rays
/// traced and the receivers' paths. When every receiver uses the same unweighted samples and
/// every triangle casts, screen tiles of receivers are traced together ([`trace_shared`]);
/// otherwise each receiver traces its own samples, those in `culled` with the culling of closed
/// casters (no path counted).
fn trace_all(
    scene: &Scene,
    bvh: &Bvh,
    light: &Light,
    receivers: &Receivers,
    samples: &SampleSet,
    (epsilon, culled): (f32, Option<&[bool]>),
    out: &mut [f32],
) -> Result<Paths> {
    if samples.is_shared() && !light.is_textured() && culled.is_none() {
        return trace_shared(
            scene,
            bvh,
            receivers,
            samples.pattern_for(0, 0),
            epsilon,
            out,
        );
    }
    // Each round's receivers `offset..offset + part.len()` trace their own samples.
    let mut rays = 0;
    interrupt::rounds(
        out,
        interrupt::round_len(CHUNK, samples.count() as u64 * Work::RAY),
        |offset, part| {
            rays += part
                .par_chunks_mut(CHUNK)
                .enumerate()
                .map_init(
                    || {
                        (
                            Vec::with_capacity(samples.count()),
                            Vec::with_capacity(samples.count()),
                            Traced::default(),
                        )
                    },
                    |(ys, ws, traced), (c, chunk)| {
                        let mut rays = 0;
                        for (k, v) in chunk.iter_mut().enumerate() {
                            let i = offset + c * CHUNK + k;
                            if !receivers.valid[i] {
                                continue;
                            }
                            let (p, n) = (receivers.points[i], receivers.normals[i]);
                            samples.fill(light, i, receivers.pixel(i), ys, ws);
                            let origins = Origins {
                                p,
                                moved: p + n * epsilon,
                                culled: culled.is_some_and(|c| c[i]),
                            };
                            let (vis, count) =
                                receiver_visibility(scene, bvh, origins, n, ys, ws, traced);
                            *v = vis;
                            rays += count;
                        }
                        rays
                    },
                )
                .sum::<u64>();
        },
    )?;
    Ok(Paths {
        rays,
        ..Paths::default()
    })
}

/// Receivers of one tile, at most the lanes of a packet ([`Bvh::occluded_converging_lanes`]).
const TILE: usize = 64;
const _: () = assert!(TILE <= Bvh::PACKET_LANES);
/// Rows of a tile (fewer when the receiver grid has fewer rows; the width makes up `TILE`).
///
/// Square tiles of a full packet trace fastest even where the receivers lie far apart, so the
/// tile does not follow the receivers' spacing: on the bunny (64 shared Poisson samples, every
/// shape alternating in one process, 40 rounds at 128x128 and 10 at 256x256, same bits for
/// every shape), the fastest CPU time of 4x8 and 8x4 tiles (half packets) and of 4x16 and 16x4
/// was 1.04-1.06x that of 8x8 at 128x128 and 1.03-1.09x at 256x256, of 4x4 tiles 1.16x and
/// 1.22x. The packets of smaller tiles are no more coherent enough to pay for their number.
const TILE_ROWS: usize = 8;

/// [`trace_all`] for samples `ys` shared by every receiver, all of weight 1: the grid is cut
/// into bands of tile rows, each band into segments of [`SEGMENT_TILES`] tiles (the parallel work
/// items: fixed, so the paths the receivers take do not depend on the thread count, and the
/// answers never do) and each segment into tiles traced by [`trace_tile`].
///
/// All the segments go in one parallel pass, not in rounds: the cost of a band varies tenfold
/// with the shadows it crosses, and rounds of one band per thread wait for their slowest
/// (`bench/shadow_rays.py` at 128x128 measured the one pass faster on two cores). A tile is
/// the unit of interruption instead: the segments stop at their next tile once the call is
/// asked to stop, and the check after the pass reports it.
fn trace_shared(
    scene: &Scene,
    bvh: &Bvh,
    receivers: &Receivers,
    ys: &[Vec3],
    epsilon: f32,
    out: &mut [f32],
) -> Result<Paths> {
    let width = receivers.width.max(1);
    let rows = TILE_ROWS.min(receivers.height.max(1));
    let cols = TILE / rows;
    let shared = SharedSamples::new(ys);
    let band_len = rows * width;
    let segment_cols = cols * SEGMENT_TILES;
    let segments = Segment::split(out, width, band_len, segment_cols);
    interrupt::check()?;
    let watch = interrupt::watch();
    let paths = segments
        .into_par_iter()
        .map_init(TileBuffers::default, |buf, mut segment| {
            let (first, len) = (segment.band * band_len, segment.rows.len() * width);
            buf.to_packets.clear();
            buf.to_packets.resize(len, false);
            let end = (segment.x0 + segment_cols).min(width);
            (segment.x0..end)
                .step_by(cols)
                .take_while(|_| !watch.requested())
                .map(|x0| {
                    let tile = (0..rows)
                        .flat_map(|r| (x0..(x0 + cols).min(end)).map(move |x| r * width + x))
                        .filter(move |&k| k < len);
                    trace_tile(
                        scene,
                        bvh,
                        receivers,
                        &shared,
                        epsilon,
                        (first, width),
                        tile,
                        &mut segment,
                        buf,
                    )
                })
                .fold(Paths::default(), Paths::plus)
        })
        .reduce(Paths::default, Paths::plus);
    interrupt::check()?;
    Ok(paths)
}

/// The rays a call traced and how many valid receivers each path of [`trace_tile`] answered
/// (the stats of [`ray_traced`]).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
struct Paths {
    rays: u64,
    shaft_lit: u64,
    frustum_lit: u64,
    candidates: u64,
    diverging: u64,
    converging: u64,
}

impl Paths {
    fn plus(self, o: Paths) -> Paths {
        Paths {
            rays: self.rays + o.rays,
            shaft_lit: self.shaft_lit + o.shaft_lit,
            frustum_lit: self.frustum_lit + o.frustum_lit,
            candidates: self.candidates + o.candidates,
            diverging: self.diverging + o.diverging,
            converging: self.converging + o.converging,
        }
    }

    /// Sets the stats `rays` and `<path>_receivers` (see [`ray_traced`]).
    fn record(&self, stats: &mut Stats) {
        stats.set("rays", self.rays as f64);
        stats.set("shaft_lit_receivers", self.shaft_lit as f64);
        stats.set("frustum_lit_receivers", self.frustum_lit as f64);
        stats.set("candidate_receivers", self.candidates as f64);
        stats.set("diverging_receivers", self.diverging as f64);
        stats.set("converging_receivers", self.converging as f64);
    }
}

/// Tiles of one band per parallel work item (see [`trace_shared`]).
///
/// Whole bands were the work items before: on the bunny at 128x128 (64 shared samples, 16
/// bands) the costliest band took a fifth of the call's cycles, and a thread that finished
/// its share of the bands early waited on it. With two threads, alternating the two in one
/// process (100 rounds at 128x128, 30 at 256x256, same bits), segments of four tiles took
/// 0.92x the fastest wall time of whole bands at 128x128 (17.1 against 18.6 ms; median 0.94x)
/// and 0.95x at 256x256 (median 0.99x); in alternating processes of release builds (fastest
/// of 30 calls, eight pairs) 0.86x the fastest and 0.95x the median at 128x128, no change
/// beyond the noise at 256x256. One or two tiles per item did no better than four then.
///
/// Timed per work item (2026-12-07, two threads, bunny at 128x128), the costliest segment of four
/// tiles took 2.5-3.7 ms of a 15-20 ms call, and one thread ended 1.1-1.3 ms (median) before
/// the other, waiting. One tile per item cuts the costliest item to 1.1 ms and that wait to
/// 0.3-0.4 ms; alternating the two call by call in one process on a machine loaded by others
/// (same bits), one tile took 0.99x and 0.95x the fastest wall time of four at 128x128 (60 and
/// 40 rounds; median 0.96x and 0.92x) and 1.00x at 256x256 (25 rounds; median 0.92x): the
/// finer items let a thread whose core is taken by another process fall behind by less.
const SEGMENT_TILES: usize = 1;

/// The receivers of one parallel work item of [`trace_shared`]: the rows of band `band` between
/// column `x0` and the next segment, as pieces of the output rows (`rows[r][x - x0]` for the
/// receiver in row `r` of the band and column `x`).
struct Segment<'a> {
    band: usize,
    x0: usize,
    width: usize,
    rows: Vec<&'a mut [f32]>,
}

impl<'a> Segment<'a> {
    /// Cuts `out`, a grid `width` receivers wide, into bands of `band_len` receivers and each
    /// band into segments of `cols` columns, band by band, left to right.
    fn split(out: &'a mut [f32], width: usize, band_len: usize, cols: usize) -> Vec<Segment<'a>> {
        let per_band = width.div_ceil(cols);
        let mut segments: Vec<Segment<'a>> = Vec::new();
        for (band, rows) in out.chunks_mut(band_len).enumerate() {
            let start = segments.len();
            segments.extend((0..per_band).map(|g| Segment {
                band,
                x0: g * cols,
                width,
                rows: Vec::new(),
            }));
            for row in rows.chunks_mut(width) {
                for (g, piece) in row.chunks_mut(cols).enumerate() {
                    segments[start + g].rows.push(piece);
                }
            }
        }
        segments
    }

    /// Sets the value of the receiver at index `k` of the band.
    fn set(&mut self, k: usize, value: f32) {
        self.rows[k / self.width][k % self.width - self.x0] = value;
    }
}

/// The samples every receiver shares: as points in Morton order ([`morton_order`]), per axis
/// (for [`SharedSamples::front`]) and their bounding box.
///
/// The order sets which samples share a chunk of a packet's lanes: the 16 consecutive targets
/// of a receiver's packet ([`Bvh::occluded_diverging`]) then lie close together on the light,
/// so a node's rectangles more often reject a whole chunk. A receiver's answer is a count of its
/// unblocked samples, the same in any order. On the bunny (64 Poisson samples, one thread,
/// same bits), by cachegrind 219M instructions per 128x128 call instead of 231M (the difference
/// of 11 calls and 1 call in one process each); timed in alternating processes (fastest CPU time
/// of 20 calls, 8 rounds each), 0.95x and 1.02x at 128x128, 0.94x at 256x256 (medians 0.96-0.98x
/// and 0.95x).
struct SharedSamples {
    points: Vec<Vec3>,
    axes: [Vec<f32>; 3],
    bounds: [Vec3; 2],
}

impl SharedSamples {
    fn new(points: &[Vec3]) -> Self {
        let y0 = points.first().copied().unwrap_or(Vec3::ZERO);
        let bounds = points
            .iter()
            .fold([y0, y0], |[lo, hi], &y| [lo.min(y), hi.max(y)]);
        let points = morton_order(points, bounds);
        // Padded to whole words with NaN, which no plane has in front of it.
        let padded = points.len().next_multiple_of(64);
        let axis = |a: usize| {
            let mut v: Vec<f32> = points.iter().map(|y| y[a]).collect();
            v.resize(padded, f32::NAN);
            v
        };
        Self {
            axes: [axis(0), axis(1), axis(2)],
            points,
            bounds,
        }
    }

    /// Sets `bits` to the samples in front of the tangent plane at `p` with normal `n` (bit
    /// `s % 64` of word `s / 64` for sample `s`) and returns their count: the test
    /// `(y - p).dot(n) > 0` of [`receiver_visibility`], the same IEEE operations in the same
    /// order, in a loop LLVM vectorizes: a byte per sample, gathered by [`movemask`] (the
    /// samples padded to whole words). Written as a shift and an or per sample instead, the loop
    /// stayed scalar: 7.3M instructions per call on the bunny at 128x128 (64 samples) against
    /// 2.6M (callgrind, one thread).
    fn front(&self, p: Vec3, n: Vec3, bits: &mut Vec<u64>) -> u32 {
        bits.clear();
        let [xs, ys, zs] = &self.axes;
        for ((x, y), z) in xs
            .chunks_exact(64)
            .zip(ys.chunks_exact(64))
            .zip(zs.chunks_exact(64))
        {
            let mut ahead = [0u8; 64];
            for (l, byte) in ahead.iter_mut().enumerate() {
                let dot = (x[l] - p.x) * n.x + (y[l] - p.y) * n.y + (z[l] - p.z) * n.z;
                *byte = top_bit(dot > 0.0);
            }
            let word = (0..4).fold(0u64, |word, g| {
                word | movemask(std::array::from_fn(|l| ahead[16 * g + l])) << (16 * g)
            });
            bits.push(word);
        }
        bits.iter().map(|w| w.count_ones()).sum()
    }
}

/// `points` sorted along the Morton curve (Morton 1966, "A computer oriented geodetic data base
/// and a new technique in file sequencing") over their bounding box `[lo, hi]`, on a grid of
/// 1024 cells a side: the cell coordinates' bits interleaved, so neighbours along the curve
/// are neighbours in space. Ties keep their order.
fn morton_order(points: &[Vec3], [lo, hi]: [Vec3; 2]) -> Vec<Vec3> {
    const BITS: u32 = 10;
    let cells = ((1 << BITS) - 1) as f32;
    let extent = hi - lo;
    let scale = Vec3::select(extent.cmpgt(Vec3::ZERO), cells / extent, Vec3::ZERO);
    let code = |y: Vec3| {
        let cell = ((y - lo) * scale)
            .as_uvec3()
            .min(UVec3::splat((1 << BITS) - 1));
        (0..BITS).rev().fold(0u32, |code, bit| {
            let bit_of = |c: u32| c >> bit & 1;
            code << 3 | bit_of(cell.x) << 2 | bit_of(cell.y) << 1 | bit_of(cell.z)
        })
    };
    let mut sorted = points.to_vec();
    sorted.sort_by_key(|&y| code(y));
    sorted
}

/// The indices of the set bits of `bits` (see [`SharedSamples::front`]), in increasing order.
fn set_bits(bits: &[u64]) -> impl Iterator<Item = usize> + '_ {
    bits.iter().enumerate().flat_map(|(w, &word)| {
        std::iter::successors((word != 0).then_some(word), |&m| {
            Some(m & (m - 1)).filter(|&m| m != 0)
        })
        .map(move |m| 64 * w + m.trailing_zeros() as usize)
    })
}

/// Per-thread buffers of [`trace_tile`].
#[derive(Debug, Default)]
struct TileBuffers {
    /// The valid receivers of the tile (indices in the band).
    tile: Vec<usize>,
    /// The samples in front of one receiver, as bits and as points.
    front_bits: Vec<u64>,
    targets: Vec<Vec3>,
    blocked: Vec<bool>,
    /// The receivers left to the packets: index in the band and lit count, their ray origins
    /// and tangent planes (lane `h` for `hard[h]`).
    hard: Vec<(usize, u32)>,
    origins: Vec<Vec3>,
    tangents: Vec<FrontPlane>,
    /// Per sample, the lanes of the hard receivers it is in front of, and of those blocked.
    front: Vec<u64>,
    blocked_lanes: Vec<u64>,
    /// Per receiver of the band, whether it went to the packets in this segment (see
    /// [`trace_tile`]).
    to_packets: Vec<bool>,
}

/// Traces the receivers `tile` (indices into their band, whose first receiver is `first`, of a grid
/// `width` receivers wide) to the shared samples `ys`, writing their visibility into `segment`;
/// returns the rays traced and the receivers' paths.
///
/// When no leaf meets the shaft between the tile's ray origins and the samples
/// ([`Bvh::shaft_is_empty`]), every receiver of the tile sees all its front samples. Otherwise
/// each receiver's own frustum pass ([`Bvh::frustum_candidates`], through the box of all the
/// samples) answers the receivers whose rays meet few leaves (all fully lit ones, without
/// listing their samples). That pass and the packets by receiver leave out the leaves wholly
/// behind the receiver's tangent plane, which its rays never reach ([`FrontPlane`]): on the
/// bunny (64 shared samples, one thread, the two alternating call by call in one process, same
/// bits) 0.97-0.98x the fastest CPU time at 128x128 and 256x256, with 134 more receivers
/// answered by their candidates at 128x128 (1272 of 12198). A receiver whose left and upper
/// neighbours in the band both went to the packets skips that pass and goes there too: shadow
/// regions are contiguous, so the pass would almost surely fail after meeting too many leaves,
/// and either path gives the same answers (the left neighbour may lie in the previous tile of
/// the segment, so `b.to_packets` must be reset per segment). The rays of the others go as coherent packets
/// (Benthin and Wald 2009, see `bvh/packet.rs`), by sample or by receiver, whichever makes
/// fewer packets ([`by_receiver`]): those of all remaining receivers of the tile to sample
/// `y_s` converge at `y_s`, those of one receiver diverge from it. All give the answers of
/// single rays, so V is the same as [`receiver_visibility`] computes.
#[allow(clippy::too_many_arguments)]
fn trace_tile(
    scene: &Scene,
    bvh: &Bvh,
    receivers: &Receivers,
    ys: &SharedSamples,
    epsilon: f32,
    (first, width): (usize, usize),
    tile: impl Iterator<Item = usize>,
    segment: &mut Segment,
    b: &mut TileBuffers,
) -> Paths {
    // Unit weights: the sums of `receiver_visibility` are exact counts here.
    let total = ys.points.len() as f64;
    let visibility = |lit: u32| lit_fraction(f64::from(lit), total);
    b.hard.clear();
    b.origins.clear();
    b.tangents.clear();
    b.front.clear();
    b.front.resize(ys.points.len(), 0);
    b.tile.clear();
    b.tile.extend(tile.filter(|&k| receivers.valid[first + k]));
    let origin = |k: usize| receivers.points[first + k] + receivers.normals[first + k] * epsilon;
    let Some(&k0) = b.tile.first() else {
        return Paths::default();
    };
    let origins = b.tile.iter().fold([origin(k0); 2], |[lo, hi], &k| {
        [lo.min(origin(k)), hi.max(origin(k))]
    });
    let lit_tile = bvh.shaft_is_empty(origins, ys.bounds);
    let mut paths = Paths::default();
    for &k in &b.tile {
        let i = first + k;
        let (p, n) = (receivers.points[i], receivers.normals[i]);
        let origin = origin(k);
        // Every ray lies in front of it, as only the samples in front are traced.
        let tangent = FrontPlane {
            point: p,
            normal: n,
        };
        let count = ys.front(p, n, &mut b.front_bits);
        paths.rays += u64::from(count);
        if lit_tile {
            paths.shaft_lit += 1;
            segment.set(k, visibility(count));
            continue;
        }
        let left = k % width > 0 && b.to_packets[k - 1];
        let up = k >= width && b.to_packets[k - width];
        let frustum = count as usize >= Bvh::FRUSTUM_MIN_RAYS && !(left && up);
        match frustum
            .then(|| bvh.frustum_candidates(origin, ys.bounds, Some(tangent)))
            .flatten()
        {
            Some(cand) if cand.is_empty() => {
                paths.frustum_lit += 1;
                segment.set(k, visibility(count));
            }
            Some(cand) => {
                paths.candidates += 1;
                b.targets.clear();
                b.targets
                    .extend(set_bits(&b.front_bits).map(|s| ys.points[s]));
                bvh.occluded_by_candidates(scene, origin, &b.targets, &cand, &mut b.blocked);
                segment.set(
                    k,
                    visibility(b.blocked.iter().filter(|&&x| !x).count() as u32),
                );
            }
            None => {
                b.to_packets[k] = true;
                let lane = 1u64 << b.hard.len();
                for s in set_bits(&b.front_bits) {
                    b.front[s] |= lane;
                }
                b.hard.push((k, 0));
                b.origins.push(origin);
                b.tangents.push(tangent);
            }
        }
    }
    if b.hard.is_empty() {
        return paths;
    }
    if by_receiver(b.hard.len(), ys.points.len()) {
        paths.diverging = b.hard.len() as u64;
        trace_by_receiver(scene, bvh, ys, b);
    } else {
        paths.converging = b.hard.len() as u64;
        trace_by_sample(scene, bvh, ys, b);
    }
    for &(k, lit) in &b.hard {
        segment.set(k, visibility(lit));
    }
    paths
}

/// Whether the receivers left to the packets, `hard` of them with `samples` shared samples, go
/// as one packet per receiver ([`trace_by_receiver`]) rather than one per sample
/// ([`trace_by_sample`]): whichever makes fewer packets, since a packet's traversal from the
/// root costs about as much with few lanes as with many.
///
/// On the bunny (`bench/shadow_rays.py`'s rays, 64 shared samples, one thread, same bits),
/// timing a tile's two ways back to back by the time-stamp counter, the packets by receiver
/// took 1.07x the time of those by sample over the tiles of 64 such receivers at 128x128,
/// 1.34x at 256x256 and 1.89x at 512x512, but 0.2-0.8x over the tiles of fewer (0.3-1.0x at
/// 512x512). In alternating processes (`quick` builds, fastest CPU time of 15 calls) this rule
/// took 0.86-0.88x the CPU time of packets by sample alone at 128x128, 0.93-0.97x at 256x256
/// and 1.00-1.01x at 512x512; packets by receiver in every tile took 0.90-0.93x at 128x128.
fn by_receiver(hard: usize, samples: usize) -> bool {
    hard * samples.div_ceil(Bvh::PACKET_LANES) < samples
}

/// Sets the lit count of every receiver of `b.hard` by tracing its samples in front
/// (`b.front`) as packets diverging from its ray origin ([`Bvh::occluded_diverging`]).
fn trace_by_receiver(scene: &Scene, bvh: &Bvh, ys: &SharedSamples, b: &mut TileBuffers) {
    for (h, (_, lit)) in b.hard.iter_mut().enumerate() {
        b.targets.clear();
        b.targets.extend(
            ys.points
                .iter()
                .zip(&b.front)
                .filter(|(_, &lanes)| lanes >> h & 1 != 0)
                .map(|(&y, _)| y),
        );
        for targets in b.targets.chunks(Bvh::PACKET_LANES) {
            let tangent = Some(b.tangents[h]);
            let blocked = bvh.occluded_diverging(scene, b.origins[h], targets, tangent);
            *lit += targets.len() as u32 - blocked.count_ones();
        }
    }
}

/// Sets the lit count of every receiver of `b.hard` by tracing, for each sample, the rays of
/// the receivers in front of it (`b.front`) as one packet converging at the sample
/// ([`Bvh::occluded_converging_lanes`]).
fn trace_by_sample(scene: &Scene, bvh: &Bvh, ys: &SharedSamples, b: &mut TileBuffers) {
    b.blocked_lanes.resize(ys.points.len(), 0);
    bvh.occluded_converging_lanes(
        scene,
        &b.origins,
        &ys.points,
        &b.front,
        &mut b.blocked_lanes,
    );
    for (&front, &blocked) in b.front.iter().zip(&b.blocked_lanes) {
        let mut lit = front & !blocked;
        while lit != 0 {
            b.hard[lit.trailing_zeros() as usize].1 += 1;
            lit &= lit - 1;
        }
    }
}

/// Per-thread buffers: the targets a receiver actually traces, their weights and answers.
#[derive(Debug, Default)]
struct Traced {
    targets: Vec<Vec3>,
    weights: Vec<f32>,
    blocked: Vec<bool>,
}

/// Where a receiver's shadow rays start: the receiver, moved along its normal, and whether the
/// culling of closed casters holds for it.
#[derive(Debug, Clone, Copy)]
struct Origins {
    p: Vec3,
    moved: Vec3,
    culled: bool,
}

/// The weighted fraction of unblocked samples `ys` (weights `ws`) of the receiver at
/// `origins.p` with normal `n`, and the number of rays traced.
fn receiver_visibility(
    scene: &Scene,
    bvh: &Bvh,
    origins: Origins,
    n: Vec3,
    ys: &[Vec3],
    ws: &[f32],
    s: &mut Traced,
) -> (f32, u64) {
    let Origins {
        p,
        moved: origin,
        culled,
    } = origins;
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
    if culled {
        occluded_with_culling(scene, bvh, origins, &s.targets, &mut s.blocked);
    } else {
        // Every ray lies in front of the tangent plane, as only the samples in front are traced.
        let tangent = FrontPlane {
            point: p,
            normal: n,
        };
        bvh.occluded_many(scene, origin, &s.targets, Some(tangent), &mut s.blocked);
    }
    let lit = s
        .weights
        .iter()
        .zip(&s.blocked)
        .filter(|(_, &b)| !b)
        .fold(0.0, |acc, (&w, _)| acc + f64::from(w));
    (lit_fraction(lit, total), s.targets.len() as u64)
}

/// For each target, whether its segment is blocked with the culling of closed casters (Sintorn,
/// Eisemann and Assarsson 2008, section 3.3): an open mesh's face blocks the segment from the
/// moved receiver (the watertight test), a closed mesh's face the segment from the receiver
/// itself ([`culled_face_blocks`]). Clears and fills `out`.
fn occluded_with_culling(
    scene: &Scene,
    bvh: &Bvh,
    origins: Origins,
    targets: &[Vec3],
    out: &mut Vec<bool>,
) {
    let open = |f: u32| !scene.is_closed_face(f);
    let p = origins.p.as_dvec3();
    out.clear();
    out.extend(targets.iter().map(|&y| {
        bvh.occluded_by_faces(scene, origins.moved, y - origins.moved, 1.0, &open)
            || bvh.any_face_along(origins.p, y - origins.p, 1.0, |f| {
                culled_face_blocks(scene, f, p, y.as_dvec3())
            })
    }));
}

/// Whether closed face `f` blocks the segment from `p` to `y` under culling: `p` lies strictly
/// in front of its plane, `y` strictly behind it, and the segment crosses strictly inside its
/// three edges (the signed volumes of the segment with each edge agree), where the face is
/// opaque. In f64: the receiver lies on a closed surface to within f32 rounding, which the
/// watertight test in f32 cannot tell from crossing it (a shadow ray from `p` would hit its own
/// face at t ~ 1e-8 for light samples grazing the surface).
fn culled_face_blocks(scene: &Scene, f: u32, p: DVec3, y: DVec3) -> bool {
    if !scene.is_closed_face(f) {
        return false;
    }
    let [a, b, c] = scene.triangle(f).map(Vec3::as_dvec3);
    let n = (b - a).cross(c - a);
    if !(n.dot(p - a) > 0.0 && n.dot(y - a) < 0.0) {
        return false;
    }
    let d = y - p;
    let volume = |u: DVec3, v: DVec3| (u - p).cross(v - p).dot(d);
    let (ab, bc, ca) = (volume(a, b), volume(b, c), volume(c, a));
    let inside = (ab > 0.0 && bc > 0.0 && ca > 0.0) || (ab < 0.0 && bc < 0.0 && ca < 0.0);
    // The barycentric weight of each vertex is the volume with the opposite edge.
    let sum = ab + bc + ca;
    inside && scene.is_opaque_at(f, (ca / sum) as f32, (ab / sum) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::mesh::{AlphaTexture, Mesh};
    use crate::light::sampling::Pattern;
    use glam::Vec2;

    /// A ground quad, a sphere (umbra and penumbra below it) and a perforated checker quad.
    fn scene() -> Result<Scene> {
        let quad = |y: f32, s: f32, c: Vec2| {
            let p =
                [(-s, -s), (s, -s), (s, s), (-s, s)].map(|(x, z)| Vec3::new(c.x + x, y, c.y + z));
            (p.to_vec(), vec![[0, 1, 2], [0, 2, 3]])
        };
        let (g, gf) = quad(0.0, 4.0, Vec2::ZERO);
        let ground = Mesh::new(g, gf, None, None, false)?;
        let sphere = Mesh::uv_sphere(Vec3::new(-0.8, 1.0, 0.0), 0.5, 24, 12, true)?;
        // The checker: a 16 x 16 grid of quads (many leaves, so its penumbra goes to packets).
        let k = 17u32;
        let c: Vec<Vec3> = (0..k * k)
            .map(|i| {
                Vec3::new(
                    0.4 + 1.2 * (i % k) as f32 / 16.0,
                    0.8,
                    -0.6 + 1.2 * (i / k) as f32 / 16.0,
                )
            })
            .collect();
        let cf = (0..16 * 16)
            .map(|q| q % 16 + k * (q / 16))
            .flat_map(|a| [[a, a + 1, a + k + 1], [a, a + k + 1, a + k]])
            .collect();
        let uvs = c.iter().map(|p| Vec2::new(p.x, p.z)).collect();
        let alpha: Vec<f32> = (0..64)
            .map(|k| ((k / 8 + k % 8) % 2 == 0) as u8 as f32)
            .collect();
        let checker = Mesh::new(
            c,
            cf,
            Some(uvs),
            Some(AlphaTexture::new(8, 8, &alpha)?),
            false,
        )?;
        Scene::new(vec![ground, sphere, checker])
    }

    /// A 37 x 21 grid of ground receivers (partial edge tiles), some invalid, normals tilted
    /// so that some samples fall behind the tangent plane.
    fn grid() -> Result<Receivers> {
        let (w, h) = (37, 21);
        let points = (0..w * h)
            .map(|i| {
                Vec3::new(
                    -2.0 + 4.0 * (i % w) as f32 / w as f32,
                    0.0,
                    -1.0 + 2.0 * (i / w) as f32 / h as f32,
                )
            })
            .collect();
        let normals = (0..w * h)
            .map(|i| Vec3::new(0.4 * ((i % 7) as f32 - 3.0) / 3.0, 1.0, 0.0))
            .collect();
        let valid = (0..w * h).map(|i| i % 11 != 3).collect();
        Receivers::new(points, normals, valid, w, h)
    }

    /// A 40 x 24 grid of receivers on the sphere of [`scene`] (radius 0.5 around
    /// (-0.8, 1, 0), its faces' chords lie just inside), over the upper two thirds of it,
    /// normals outwards: their neighbouring faces lie behind their tangent planes.
    fn on_sphere() -> Result<Receivers> {
        let (w, h) = (40, 24);
        let dirs: Vec<Vec3> = (0..w * h)
            .map(|i| {
                let theta = 0.65 * std::f32::consts::PI * ((i / w) as f32 + 0.5) / h as f32;
                let phi = 2.0 * std::f32::consts::PI * ((i % w) as f32 + 0.5) / w as f32;
                Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                )
            })
            .collect();
        let points = dirs
            .iter()
            .map(|&d| Vec3::new(-0.8, 1.0, 0.0) + 0.5 * d)
            .collect();
        Receivers::new(points, dirs, vec![true; w * h], w, h)
    }

    /// V of every receiver ray by ray, one receiver at a time (the path before tiling).
    fn per_receiver(
        scene: &Scene,
        bvh: &Bvh,
        light: &Light,
        rx: &Receivers,
        samples: &SampleSet,
        eps: f32,
    ) -> Vec<f32> {
        let (mut ys, mut ws, mut traced) = (Vec::new(), Vec::new(), Traced::default());
        (0..rx.len())
            .map(|i| {
                if !rx.valid[i] {
                    return 0.0;
                }
                samples.fill(light, i, rx.pixel(i), &mut ys, &mut ws);
                let (p, n) = (rx.points[i], rx.normals[i]);
                let origins = Origins {
                    p,
                    moved: p + n * eps,
                    culled: false,
                };
                receiver_visibility(scene, bvh, origins, n, &ys, &ws, &mut traced).0
            })
            .collect()
    }

    /// The stats of the receivers' paths, in the order of [`STATS`].
    const PATH_STATS: [&str; 5] = [
        "shaft_lit_receivers",
        "frustum_lit_receivers",
        "candidate_receivers",
        "diverging_receivers",
        "converging_receivers",
    ];

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn tiled_packets_equal_per_receiver_rays_for_any_thread_count() -> Result<()> {
        let scene = scene()?;
        let bvh = Bvh::build(&scene)?;
        let light = Light::rect(Vec3::new(0.0, 3.0, 0.0), Vec3::X * 0.6, Vec3::Z * 0.6)?;
        let rx = grid()?;
        let opts = RayTracedOptions {
            epsilon: 1e-4,
            caster_faces: CasterFaces::All,
        };
        // With 48 shared samples the tiles of this grid go both ways to the packets (see
        // `by_receiver`): 16 to 41 hard receivers by receiver, 48 and 58 by sample; with 100,
        // a receiver's samples take two packets by receiver.
        let variants = [
            (48, 1, false),
            (48, 1, true),
            (48, 3, false),
            (100, 1, false),
        ];
        for (count, interleave, rotate) in variants {
            let samples =
                SampleSet::generate(&light, count, Pattern::Poisson, 5, interleave, rotate, 0)?;
            let expected = per_receiver(&scene, &bvh, &light, &rx, &samples, opts.epsilon);
            if count == 48 && interleave == 1 && !rotate {
                let (lit, umbra) = (
                    expected.iter().filter(|&&v| v == 1.0).count(),
                    expected.iter().filter(|&&v| v == 0.0).count(),
                );
                let penumbra = expected.len() - lit - umbra;
                assert!(
                    lit > 50 && umbra > 20 && penumbra > 100,
                    "lit {lit} umbra {umbra} penumbra {penumbra}"
                );
            }
            for threads in [1, 4] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .map_err(|e| Error::invalid("threads", e.to_string()))?;
                let (v, stats) =
                    pool.install(|| ray_traced(&scene, &bvh, &light, &rx, &samples, &opts))?;
                assert_eq!(
                    bits(&v),
                    bits(&expected),
                    "{count} samples, interleave {interleave}, rotate {rotate}, {threads} threads"
                );
                // A missing key reads NaN, which fails the assertions below.
                let path = |key: &str| stats.get(key).unwrap_or(f64::NAN);
                let paths = PATH_STATS.map(path);
                if samples.is_shared() {
                    // Every valid receiver takes exactly one path.
                    assert_eq!(paths.iter().sum::<f64>(), path("receivers"), "{paths:?}");
                } else {
                    assert_eq!(paths, [0.0; 5]);
                }
                if count == 48 && interleave == 1 && !rotate {
                    // Candidate tests, and packets both ways (see above).
                    assert!(
                        paths[2] > 0.0 && paths[3] > 0.0 && paths[4] > 0.0,
                        "{paths:?}"
                    );
                }
            }
        }
        Ok(())
    }

    /// Receivers on a curved surface take the tangent-plane cut of their frustum passes and
    /// packets by receiver (see [`FrontPlane`]): the same bits as one receiver at a time, whose
    /// frustum passes have no such cut.
    #[test]
    fn curved_receivers_equal_per_receiver_rays() -> Result<()> {
        // The scene of the other tests and a small quad shadowing part of the sphere.
        let quad = [(-1.0, -0.2), (-0.6, -0.2), (-0.6, 0.2), (-1.0, 0.2)]
            .map(|(x, z)| Vec3::new(x, 1.8, z));
        let blocker = Mesh::new(quad.to_vec(), vec![[0, 2, 1], [0, 3, 2]], None, None, false)?;
        let mut meshes = scene()?.meshes;
        meshes.push(blocker);
        let scene = Scene::new(meshes)?;
        let bvh = Bvh::build(&scene)?;
        let light = Light::rect(Vec3::new(-0.3, 3.0, 0.2), Vec3::X * 1.2, Vec3::Z * 0.9)?;
        let rx = on_sphere()?;
        let opts = RayTracedOptions {
            epsilon: 1e-4,
            caster_faces: CasterFaces::All,
        };
        let samples = SampleSet::generate(&light, 64, Pattern::Poisson, 9, 1, false, 0)?;
        let expected = per_receiver(&scene, &bvh, &light, &rx, &samples, opts.epsilon);
        let (v, stats) = ray_traced(&scene, &bvh, &light, &rx, &samples, &opts)?;
        assert_eq!(bits(&v), bits(&expected));
        let paths = PATH_STATS.map(|key| stats.get(key).unwrap_or(f64::NAN));
        assert!(paths[2] > 0.0 && paths[3] > 0.0, "{paths:?}");
        // Some rays blocked: unblocked, V would be the fraction of samples in front.
        let blocked = (0..rx.len())
            .filter(|&i| {
                let front = samples.pattern_for(0, 0).iter();
                let n = front
                    .filter(|&&y| (y - rx.points[i]).dot(rx.normals[i]) > 0.0)
                    .count();
                expected[i] < n as f32 / 64.0
            })
            .count();
        assert!(blocked > 50, "{blocked} receivers with blocked rays");
        Ok(())
    }

    /// The front masks of the shared samples are the scalar test `(y - p).dot(n) > 0` of each
    /// sample in its Morton place, for counts that fill no word, one word, and part of a second
    /// (the padding must set no bit), and for planes through and beside the samples.
    #[test]
    fn front_masks_equal_the_scalar_test() {
        let sample = |i: usize| {
            let t = i as f32 * 0.618_034;
            Vec3::new((t * 7.3).sin(), 0.2 * (t * 3.1).cos(), (t * 5.7).cos())
        };
        let mut bits = Vec::new();
        for count in [1, 5, 63, 64, 65, 100, 128] {
            let points: Vec<Vec3> = (0..count).map(sample).collect();
            let shared = SharedSamples::new(&points);
            for (p, n) in [
                (Vec3::ZERO, Vec3::Y),
                (Vec3::new(0.3, -0.1, 0.2), Vec3::new(0.6, 0.0, 0.8)),
                (Vec3::new(-2.0, 0.0, 0.0), Vec3::X),
            ] {
                let got = shared.front(p, n, &mut bits);
                let expected: Vec<bool> = shared
                    .points
                    .iter()
                    .map(|&y| (y - p).dot(n) > 0.0)
                    .collect();
                assert_eq!(bits.len(), count.div_ceil(64), "{count} samples");
                let read: Vec<bool> = (0..64 * bits.len())
                    .map(|s| bits[s / 64] >> (s % 64) & 1 != 0)
                    .collect();
                assert_eq!(&read[..count], &expected[..], "{count} samples, n {n}");
                assert!(
                    read[count..].iter().all(|&b| !b),
                    "padding set, {count} samples"
                );
                let lit = expected.iter().filter(|&&b| b).count();
                assert_eq!(got as usize, lit);
                if count >= 5 && n == Vec3::Y {
                    assert!(lit > 0 && lit < count, "{count} samples: {lit} in front");
                }
            }
        }
    }

    #[test]
    fn morton_order_visits_each_quadrant_in_turn() {
        // A 4x4 grid on a tilted plane, listed row by row: along the Z curve (x the most
        // significant of each level's bits) each 2x2 quadrant comes whole, in the order
        // (low x, low y), (low x, high y), (high x, low y), (high x, high y), and so do the
        // points of each quadrant.
        let at = |x: u32, y: u32| Vec3::new(x as f32, y as f32, 0.5 * y as f32);
        let points: Vec<Vec3> = (0..4).flat_map(|y| (0..4).map(move |x| at(x, y))).collect();
        let bounds = [at(0, 0), at(3, 3)];
        let sorted = morton_order(&points, bounds);
        let cell = |p: Vec3| (p.x as u32, p.y as u32);
        let expected = (0..16u32).map(|m| (m >> 2 & 2 | m >> 1 & 1, m >> 1 & 2 | m & 1));
        assert_eq!(
            sorted.iter().map(|&p| cell(p)).collect::<Vec<_>>(),
            expected.collect::<Vec<_>>()
        );
    }
}
