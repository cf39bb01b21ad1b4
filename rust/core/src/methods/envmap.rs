//! `envmap`: the greedy decomposition of an environment map into square area lights (Annen et
//! al. 2008, seed 002 section 4.2), so that any single-light soft-shadow method can light a scene
//! by an environment.
//!
//! The map is a cube map of six `N × N` faces; each texel's *energy* is its radiance (RGB) times
//! its solid angle, and the greedy choices use the luminance `0.2126 R + 0.7152 G + 0.0722 B` of
//! that energy. Repeatedly, over all faces:
//!
//! 1. seed a `1 × 1` light at the texel with the most remaining energy (Figure 6a);
//! 2. grow it: try to move each of its four sides out by one texel and accept a move when the
//!    energy it would add over the energy of the enlarged light exceeds `threshold`; stop when no
//!    side can move or the light covers the face (Figure 6b–e). With `square = true` (the
//!    paper's results) all four sides move together, keeping the light square;
//! 3. remove its energy from the map but leave a residual, so later lights can blend with the
//!    surroundings (Figure 6f): every texel of the light keeps the face's mean remaining radiance
//!    outside the light (or its own value, if lower). The light takes the removed energy.
//!
//! Fitting stops after `max_lights − 6` greedy lights or when every face's remaining energy is
//! below `1e-3` of the map's; then each face with energy left gets one last light covering the
//! whole face with all of it (Figure 6i: the lights cover the face). So the lights' energies sum
//! to the map's exactly (up to rounding), whatever the threshold.
//!
//! Cube-map layout: faces `+x, −x, +y, −y, +z, −z`, each row-major with rows `i` and columns `j`;
//! texel `(i, j)` of a face is the direction of the face point `(u, v) = (2 (j + ½)/N − 1,
//! 2 (i + ½)/N − 1)` in OpenGL's convention (`+x`: `(1, −v, −u)`, `−x`: `(−1, −v, u)`,
//! `+y`: `(u, 1, v)`, `−y`: `(u, −1, −v)`, `+z`: `(u, −v, 1)`, `−z`: `(−u, −v, −1)`).

use crate::error::{Error, Result};
use crate::limits;

/// The luminance weights of the greedy choices (Rec. 709).
const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];
/// Faces whose remaining energy is below this fraction of the map's get no more greedy lights.
const DONE_FRACTION: f64 = 1e-3;

/// One fitted light: a rectangle of texels `[i0, i1) × [j0, j1)` of one face and its energy.
#[derive(Debug, Clone, PartialEq)]
pub struct FittedLight {
    pub face: usize,
    pub i0: usize,
    pub i1: usize,
    pub j0: usize,
    pub j1: usize,
    /// RGB energy: radiance times solid angle summed over the texels it took.
    pub energy: [f64; 3],
}

/// Options of [`fit_area_lights`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// Growth threshold `t` on added / total energy (the paper's Figure 10: 0.015 to 0.035).
    pub threshold: f64,
    /// Total number of lights, the six face-covering ones included (>= 6).
    pub max_lights: usize,
    /// Grow all four sides together (square lights, as in the paper's results).
    pub square: bool,
}

/// The solid angle of cube-face texel `(i, j)` on an `n × n` face (exact: the integral of
/// `(1 + u² + v²)^(−3/2)` over the texel).
pub fn texel_solid_angle(n: usize, i: usize, j: usize) -> f64 {
    let corner = |u: f64, v: f64| (u * v).atan2((1.0 + u * u + v * v).sqrt());
    let (u0, u1) = (2.0 * j as f64 / n as f64 - 1.0, 2.0 * (j + 1) as f64 / n as f64 - 1.0);
    let (v0, v1) = (2.0 * i as f64 / n as f64 - 1.0, 2.0 * (i + 1) as f64 / n as f64 - 1.0);
    corner(u1, v1) - corner(u0, v1) - corner(u1, v0) + corner(u0, v0)
}

/// The remaining energy of one face and its summed-area bookkeeping.
struct Face {
    n: usize,
    /// RGB energy per texel.
    energy: Vec<[f64; 3]>,
    solid_angle: Vec<f64>,
}

impl Face {
    fn luminance(&self, k: usize) -> f64 {
        (0..3).map(|c| LUMINANCE[c] * self.energy[k][c]).sum()
    }

    fn region(&self, (i0, i1, j0, j1): (usize, usize, usize, usize)) -> f64 {
        (i0..i1).flat_map(|i| (j0..j1).map(move |j| (i, j))).map(|(i, j)| self.luminance(i * self.n + j)).sum()
    }

    fn total(&self) -> f64 {
        (0..self.n * self.n).map(|k| self.luminance(k)).sum()
    }

    /// Grows a light from `seed` by the threshold rule; returns its rectangle.
    fn grow(&self, seed: (usize, usize), opts: &FitOptions) -> (usize, usize, usize, usize) {
        let n = self.n;
        let mut r = (seed.0, seed.0 + 1, seed.1, seed.1 + 1);
        loop {
            let current = self.region(r);
            let candidates: Vec<(usize, usize, usize, usize)> = if opts.square {
                let grown = (r.0.saturating_sub(1), (r.1 + 1).min(n), r.2.saturating_sub(1), (r.3 + 1).min(n));
                vec![grown]
            } else {
                vec![
                    (r.0.saturating_sub(1), r.1, r.2, r.3),
                    (r.0, (r.1 + 1).min(n), r.2, r.3),
                    (r.0, r.1, r.2.saturating_sub(1), r.3),
                    (r.0, r.1, r.2, (r.3 + 1).min(n)),
                ]
            };
            let mut moved = false;
            for c in candidates.into_iter().filter(|c| *c != r) {
                let total = self.region(c);
                if total > 0.0 && (total - current) / total > opts.threshold {
                    r = c;
                    moved = true;
                    break;
                }
            }
            if !moved || r == (0, n, 0, n) {
                return r;
            }
        }
    }

    /// Takes the light's energy out of the rectangle, leaving the mean remaining radiance of the
    /// rest of the face as residual (`all = true`: leaving nothing).
    fn take(&mut self, r: (usize, usize, usize, usize), all: bool) -> [f64; 3] {
        let n = self.n;
        let inside = |k: usize| (r.0..r.1).contains(&(k / n)) && (r.2..r.3).contains(&(k % n));
        let mut background = [0.0f64; 3];
        if !all {
            let (mut sum, mut area) = ([0.0f64; 3], 0.0f64);
            for k in (0..n * n).filter(|&k| !inside(k)) {
                sum.iter_mut().zip(self.energy[k]).for_each(|(s, e)| *s += e);
                area += self.solid_angle[k];
            }
            if area > 0.0 {
                background = sum.map(|s| s / area);
            }
        }
        let mut taken = [0.0f64; 3];
        for k in (0..n * n).filter(|&k| inside(k)) {
            for c in 0..3 {
                let keep = (background[c] * self.solid_angle[k]).min(self.energy[k][c]);
                taken[c] += self.energy[k][c] - keep;
                self.energy[k][c] = keep;
            }
        }
        taken
    }

    fn brightest(&self) -> (usize, f64) {
        (0..self.n * self.n).map(|k| (k, self.luminance(k))).fold((0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a })
    }
}

/// Fits square (or rectangular) area lights to a cube map `faces` of `6 × n × n` RGB radiance
/// texels (row-major per face, see the module documentation).
///
/// Errors: a wrong length or `n = 0`; negative or non-finite radiance; a threshold outside
/// (0, 1); fewer than 6 lights; `TooLarge`.
pub fn fit_area_lights(faces: &[f32], n: usize, opts: &FitOptions) -> Result<Vec<FittedLight>> {
    if n == 0 || faces.len() != 6 * n * n * 3 {
        return Err(Error::invalid("env", format!("expected 6 faces of {n}x{n} RGB texels ({} values), got {}", 6 * n * n * 3, faces.len())));
    }
    if faces.iter().any(|v| !v.is_finite() || *v < 0.0) {
        return Err(Error::invalid("env", "radiance must be finite and >= 0"));
    }
    if !(opts.threshold > 0.0 && opts.threshold < 1.0) {
        return Err(Error::invalid("threshold", format!("must be in (0, 1), got {}", opts.threshold)));
    }
    if opts.max_lights < 6 {
        return Err(Error::invalid("max_lights", format!("must be >= 6 (one covering light per face), got {}", opts.max_lights)));
    }
    limits::check_memory("environment fit", limits::bytes(&[6, n as u64, n as u64, 32]))?;
    let solid_angle: Vec<f64> = (0..n * n).map(|k| texel_solid_angle(n, k / n, k % n)).collect();
    let mut cube: Vec<Face> = (0..6)
        .map(|f| Face {
            n,
            energy: (0..n * n)
                .map(|k| {
                    let base = (f * n * n + k) * 3;
                    [0, 1, 2].map(|c| f64::from(faces[base + c]) * solid_angle[k])
                })
                .collect(),
            solid_angle: solid_angle.clone(),
        })
        .collect();
    let map_energy: f64 = cube.iter().map(Face::total).sum();
    let mut lights = Vec::new();
    while lights.len() + 6 < opts.max_lights && map_energy > 0.0 {
        let (face, (k, _)) = cube.iter().map(Face::brightest).enumerate().fold((0, (0, f64::NEG_INFINITY)), |a, b| if b.1 .1 > a.1 .1 { b } else { a });
        if cube[face].total() < DONE_FRACTION * map_energy {
            break;
        }
        let r = cube[face].grow((k / n, k % n), opts);
        let energy = cube[face].take(r, false);
        lights.push(FittedLight { face, i0: r.0, i1: r.1, j0: r.2, j1: r.3, energy });
    }
    for (face, f) in cube.iter_mut().enumerate() {
        if f.total() > 0.0 {
            let energy = f.take((0, n, 0, n), true);
            lights.push(FittedLight { face, i0: 0, i1: n, j0: 0, j1: n, energy });
        }
    }
    Ok(lights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texel_solid_angles_sum_to_the_sphere() {
        let n = 16;
        let total: f64 = (0..n * n).map(|k| texel_solid_angle(n, k / n, k % n)).sum::<f64>() * 6.0;
        assert!((total - 4.0 * std::f64::consts::PI).abs() < 1e-9, "{total}");
    }

    #[test]
    fn energy_is_conserved_and_a_sun_gets_one_light() {
        let n = 16;
        let mut faces = vec![0.05f32; 6 * n * n * 3];
        for c in 0..3 {
            faces[((2 * n * n) + 5 * n + 9) * 3 + c] = 500.0; // a sun on +y
        }
        let lights = fit_area_lights(&faces, n, &FitOptions { threshold: 0.03, max_lights: 20, square: true }).unwrap();
        let background = f64::from(0.05f32);
        let expected = 4.0 * std::f64::consts::PI * background + (500.0 - background) * texel_solid_angle(n, 5, 9);
        let total: f64 = lights.iter().map(|l| l.energy[1]).sum();
        assert!((total - expected).abs() < 1e-9 * total, "{total} vs {expected}");
        let brightest = lights.iter().max_by(|a, b| a.energy[1].total_cmp(&b.energy[1])).unwrap();
        assert_eq!((brightest.face, brightest.i0, brightest.j0), (2, 5, 9));
        assert!(lights.len() <= 20);
    }
}
