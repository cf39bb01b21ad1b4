//! Light-sample patterns (DESIGN.md section 2) and the per-receiver sample sets every
//! sample-based method draws from.
//!
//! Patterns live in the light's unit parameter cube ([`crate::light::lights::Light::map`]):
//! - `uniform`: independent uniform points;
//! - `stratified`: a jittered grid when `n` is a perfect square (cube for spheres), else
//!   Latin-hypercube (n-rooks) sampling;
//! - `poisson`: Poisson-disk dart throwing with the minimum distances seed 001 section 4.1 fixes
//!   experimentally for 16 and 64 samples on the unit square (0.2456139, 0.1076681), and for other
//!   counts `c / sqrt(n)` with `c` interpolated in log n between those two (`n^(-1/3)` scaled alike
//!   for spheres); when darts run out the radius shrinks by 1% and throwing resumes;
//! - `sobol`: the (0,2)-sequence (Sobol dimensions 1-2, plus 3 for spheres) with a random digital
//!   shift by the seed, which keeps every power-of-two prefix a (0,m,2)-net;
//! - `halton`: radical inverses in bases 2, 3, 5 with a Cranley-Patterson shift by the seed.
//!
//! A [`SampleSet`] holds `k*k` such patterns for interleaved sampling (pixel `(x, y)` uses
//! pattern `(x mod k) + k (y mod k)`, seed 001 Figure 5f), an optional per-receiver decorrelating
//! rotation (seed 001 section 4.1) drawn from a hash of the seed and the receiver index, so results
//! never depend on thread scheduling, and a per-frame global rotation for temporal jitter (seed 000
//! section 4.3). Everything is a pure function of the seed.

use crate::error::{Error, Result};
use crate::light::lights::{Light, RotationSeed};
use glam::Vec3;

/// A sample pattern over the light's parameter domain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pattern {
    Uniform,
    Stratified,
    Poisson,
    Sobol,
    Halton,
}

impl Pattern {
    /// Parses a pattern name as used by the Python API.
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "uniform" => Ok(Pattern::Uniform),
            "stratified" => Ok(Pattern::Stratified),
            "poisson" => Ok(Pattern::Poisson),
            "sobol" => Ok(Pattern::Sobol),
            "halton" => Ok(Pattern::Halton),
            other => Err(Error::invalid(
                "pattern",
                format!("expected one of 'uniform', 'stratified', 'poisson', 'sobol', 'halton', got {other:?}"),
            )),
        }
    }
}

/// SplitMix64: a tiny, well-mixed generator; also the hash that derives per-receiver streams.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    /// A generator for stream `stream` of `seed`, independent of other streams.
    pub fn stream(seed: u64, stream: u64) -> Self {
        let mut r = Rng(seed ^ 0x9E37_79B9_7F4A_7C15u64.wrapping_mul(stream.wrapping_add(1)));
        r.next_u64();
        r
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform float in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A uniform integer in [0, n).
    pub fn below(&mut self, n: usize) -> usize {
        (((self.next_u64() >> 32) * n as u64) >> 32) as usize
    }
}

/// The Poisson-disk minimum distance for `n` samples in a unit domain of dimension `dim`.
pub fn poisson_radius(n: usize, dim: usize) -> f32 {
    let (c16, c64) = (0.245_613_9 * 4.0, 0.107_668_1 * 8.0);
    let t = ((n.max(1) as f32).log2() - 4.0) / 2.0;
    let c = (c16 + (c64 - c16) * t).clamp(c64, c16);
    if dim == 3 {
        c * 0.85 / (n.max(1) as f32).cbrt()
    } else {
        match n {
            16 => 0.245_613_9,
            64 => 0.107_668_1,
            _ => c / (n.max(1) as f32).sqrt(),
        }
    }
}

/// `n` points of `pattern` in [0,1)^dim (unused coordinates are 0). `dim` is 2 or 3.
pub fn unit_pattern(pattern: Pattern, n: usize, dim: usize, seed: u64) -> Vec<[f32; 3]> {
    let mut rng = Rng::stream(seed, 0x5A4D);
    match pattern {
        Pattern::Uniform => (0..n).map(|_| point(dim, |_| rng.next_f32())).collect(),
        Pattern::Stratified => stratified(n, dim, &mut rng),
        Pattern::Poisson => poisson(n, dim, &mut rng),
        Pattern::Sobol => {
            let shift = [rng.next_u64() as u32, rng.next_u64() as u32, rng.next_u64() as u32];
            (0..n as u32).map(|i| point(dim, |d| to_unit(sobol(i, d) ^ shift[d]))).collect()
        }
        Pattern::Halton => {
            let shift = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
            (0..n as u32)
                .map(|i| point(dim, |d| (radical_inverse(i, [2, 3, 5][d]) + shift[d]).fract()))
                .collect()
        }
    }
}

/// `n` points of `pattern` in the unit disk (the unit square mapped by Shirley and Chiu's
/// concentric map, which keeps strata and Poisson spacing), e.g. the tap patterns of PCSS.
pub fn unit_disk_pattern(pattern: Pattern, n: usize, seed: u64) -> Vec<glam::Vec2> {
    unit_pattern(pattern, n, 2, seed).into_iter().map(|p| crate::light::lights::concentric_disk(p[0], p[1])).collect()
}

fn point(dim: usize, mut f: impl FnMut(usize) -> f32) -> [f32; 3] {
    let mut p = [0.0; 3];
    for (d, c) in p.iter_mut().enumerate().take(dim) {
        *c = f(d);
    }
    p
}

/// Maps a 32-bit fixed-point fraction to a float strictly below 1.
fn to_unit(bits: u32) -> f32 {
    ((bits >> 8) as f32) / (1u32 << 24) as f32
}

fn stratified(n: usize, dim: usize, rng: &mut Rng) -> Vec<[f32; 3]> {
    let k = (n as f64).powf(1.0 / dim as f64).round() as usize;
    if k.pow(dim as u32) == n {
        return (0..n)
            .map(|i| {
                let cell = [i % k, (i / k) % k, i / (k * k)];
                point(dim, |d| (cell[d] as f32 + rng.next_f32()) / k as f32)
            })
            .collect();
    }
    let mut perms: Vec<Vec<usize>> = (0..dim).map(|_| (0..n).collect()).collect();
    for perm in perms.iter_mut().skip(1) {
        for i in (1..n).rev() {
            perm.swap(i, rng.below(i + 1));
        }
    }
    (0..n).map(|i| point(dim, |d| ((perms[d][i] as f32 + rng.next_f32()) / n as f32).min(1.0 - f32::EPSILON))).collect()
}

fn poisson(n: usize, dim: usize, rng: &mut Rng) -> Vec<[f32; 3]> {
    let mut radius = poisson_radius(n, dim);
    let mut pts: Vec<[f32; 3]> = Vec::with_capacity(n);
    let darts_per_radius = 2000 * n.max(1);
    while pts.len() < n {
        let r2 = radius * radius;
        let mut darts = 0;
        while pts.len() < n && darts < darts_per_radius {
            darts += 1;
            let c = point(dim, |_| rng.next_f32());
            let far = pts.iter().all(|q| (0..dim).map(|d| (q[d] - c[d]).powi(2)).sum::<f32>() >= r2);
            if far {
                pts.push(c);
            }
        }
        radius *= 0.99;
    }
    pts
}

/// The `i`-th component of Sobol dimension `d` (0: van der Corput, 1: x+1, 2: x^2+x+1) as a 32-bit fraction.
fn sobol(i: u32, d: usize) -> u32 {
    let mut v = [0u32; 32];
    match d {
        0 => (0..32).for_each(|k| v[k] = 1 << (31 - k)),
        1 => {
            v[0] = 1 << 31;
            for k in 1..32 {
                v[k] = v[k - 1] ^ (v[k - 1] >> 1);
            }
        }
        _ => {
            v[0] = 1 << 31;
            v[1] = 3 << 30;
            for k in 2..32 {
                v[k] = v[k - 2] ^ (v[k - 2] >> 2) ^ v[k - 1];
            }
        }
    }
    (0..32).filter(|&k| i >> k & 1 == 1).fold(0, |acc, k| acc ^ v[k])
}

fn radical_inverse(mut i: u32, base: u32) -> f32 {
    let (mut inv, mut f) = (0.0f64, 1.0f64 / base as f64);
    while i > 0 {
        inv += (i % base) as f64 * f;
        i /= base;
        f /= base as f64;
    }
    (inv as f32).min(1.0 - f32::EPSILON)
}

/// How the light samples of each receiver are chosen.
#[derive(Debug, Clone)]
pub struct SampleSet {
    /// `k * k` world-space patterns (one when not interleaved), all of the same length.
    patterns: Vec<Vec<Vec3>>,
    interleave: usize,
    /// `Some(seed)`: rotate each receiver's samples by a rotation hashed from (seed, receiver).
    rotate: Option<u64>,
}

impl SampleSet {
    /// `n` samples of `pattern` on `light` (`k*k` independent patterns when `interleave = k > 1`),
    /// jittered by frame `frame` (0: none).
    pub fn generate(
        light: &Light,
        n: usize,
        pattern: Pattern,
        seed: u64,
        interleave: usize,
        rotate: bool,
        frame: u64,
    ) -> Result<Self> {
        if n == 0 {
            return Err(Error::invalid("samples", "needs at least one light sample"));
        }
        if interleave == 0 {
            return Err(Error::invalid("interleaved", "must be >= 1"));
        }
        let patterns = (0..interleave * interleave)
            .map(|j| light_samples(light, n, pattern, Rng::stream(seed, j as u64).next_u64(), frame))
            .collect();
        Ok(Self { patterns, interleave, rotate: rotate.then_some(seed) })
    }

    /// The same explicit world-space samples for every receiver (rotated per receiver if asked).
    pub fn explicit(samples: Vec<Vec3>, rotate: Option<u64>) -> Result<Self> {
        if samples.is_empty() {
            return Err(Error::invalid("samples", "needs at least one light sample"));
        }
        if let Some(i) = samples.iter().position(|s| !s.is_finite()) {
            return Err(Error::invalid("samples", format!("sample {i} is not finite")));
        }
        Ok(Self { patterns: vec![samples], interleave: 1, rotate })
    }

    /// The radius of a sphere about the light's center that holds the light and every sample of
    /// every pattern (a hair more, against round-off). Rigid rotations about the center keep the
    /// samples' distances; the other decorrelations keep samples on the light.
    pub fn bounding_radius(&self, light: &Light) -> f64 {
        let center = light.center();
        let farthest = self.patterns.iter().flatten().map(|y| (*y - center).length()).fold(light.extent(), f32::max);
        f64::from(farthest) * (1.0 + 1e-6) + 1e-12
    }

    /// Samples per receiver.
    pub fn count(&self) -> usize {
        self.patterns[0].len()
    }

    /// Whether every receiver uses the very same samples (no interleaving, no rotation).
    pub fn is_shared(&self) -> bool {
        self.patterns.len() == 1 && self.rotate.is_none()
    }

    /// Whether every receiver uses the same pattern before rotation (no interleaving).
    pub fn is_single_pattern(&self) -> bool {
        self.patterns.len() == 1
    }

    /// The rotation seed of receiver `index`, when samples are rotated per receiver.
    pub fn rotation_for(&self, index: usize) -> Option<RotationSeed> {
        self.rotate.map(|seed| rotation_seed(seed, index as u64))
    }

    /// The pattern of receiver pixel `(x, y)` before any per-receiver rotation.
    pub fn pattern_for(&self, x: usize, y: usize) -> &[Vec3] {
        let k = self.interleave;
        &self.patterns[(x % k) + k * (y % k)]
    }

    /// Writes receiver `index`'s samples (at pixel `(x, y)`) and their weights into the buffers.
    pub fn fill(&self, light: &Light, index: usize, (x, y): (usize, usize), out: &mut Vec<Vec3>, weights: &mut Vec<f32>) {
        out.clear();
        out.extend_from_slice(self.pattern_for(x, y));
        if let Some(r) = self.rotation_for(index) {
            out.iter_mut().for_each(|y| *y = light.rotate(*y, r));
        }
        weights.clear();
        weights.extend(out.iter().map(|&y| light.weight(y)));
    }
}

fn rotation_seed(seed: u64, stream: u64) -> RotationSeed {
    let mut rng = Rng::stream(seed ^ 0xD1B5_4A32_D192_ED03, stream);
    [rng.next_f32(), rng.next_f32(), rng.next_f32()]
}

/// `n` world-space samples of `pattern` on `light`, rotated as a whole for frame `frame` > 0.
pub fn light_samples(light: &Light, n: usize, pattern: Pattern, seed: u64, frame: u64) -> Vec<Vec3> {
    let unit = unit_pattern(pattern, n, light.dim().max(2), seed);
    let pts = unit.into_iter().map(|p| light.map(p));
    if frame == 0 {
        pts.collect()
    } else {
        let r = rotation_seed(seed ^ 0x00F4_A3E1, frame);
        pts.map(|y| light.rotate(y, r)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_prefixes_are_nets() {
        let pts = unit_pattern(Pattern::Sobol, 16, 2, 7);
        for (nx, ny) in [(16, 1), (8, 2), (4, 4), (2, 8), (1, 16)] {
            let mut hits = vec![0; 16];
            for p in &pts {
                hits[(p[0] * nx as f32) as usize * ny + (p[1] * ny as f32) as usize] += 1;
            }
            assert!(hits.iter().all(|&h| h == 1), "{nx}x{ny}: {hits:?}");
        }
    }

    #[test]
    fn poisson_keeps_the_papers_distances() {
        for (n, r) in [(16, 0.245_613_9f32), (64, 0.107_668_1)] {
            let pts = unit_pattern(Pattern::Poisson, n, 2, 3);
            assert_eq!(pts.len(), n);
            for (i, a) in pts.iter().enumerate() {
                for b in &pts[i + 1..] {
                    let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
                    assert!(d >= r, "{d} < {r}");
                }
            }
        }
    }

    #[test]
    fn patterns_are_deterministic_and_in_range() {
        for pat in [Pattern::Uniform, Pattern::Stratified, Pattern::Poisson, Pattern::Sobol, Pattern::Halton] {
            for dim in [2, 3] {
                let a = unit_pattern(pat, 37, dim, 11);
                assert_eq!(a, unit_pattern(pat, 37, dim, 11));
                assert_ne!(a, unit_pattern(pat, 37, dim, 12));
                assert!(a.iter().all(|p| p.iter().take(dim).all(|&c| (0.0..1.0).contains(&c))));
            }
        }
    }
}
