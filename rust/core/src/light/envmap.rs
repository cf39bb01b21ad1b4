//! `envmap`: the greedy decomposition of an environment map into square area lights (Annen et
//! al. 2008, All-Frequency Shadows in Dynamic Scenes, section 4.2), so that any single-light
//! soft-shadow method can light a scene by an environment.
//!
//! The map is a cube map of six `N × N` faces; each texel's *energy* is its radiance (RGB) times
//! its solid angle, and the greedy choices use the luminance `0.2126 R + 0.7152 G + 0.0722 B` of
//! that energy. Each face is decomposed on its own (section 4.2: "decomposing each cube map face
//! separately"), repeatedly:
//!
//! 1. seed a `1 × 1` light at the texel with the most remaining energy that no light of the face
//!    covers yet (Figure 6a; seeding only uncovered texels is what makes every light new);
//! 2. grow it: try to move each of its four sides out by one texel and accept a move when the
//!    energy it would add over the energy of the enlarged light exceeds the threshold `t`; stop
//!    when no side can move or the light covers the face (Figure 6b–e). With `square = true` (the
//!    paper's results) all four sides move together, keeping the light square;
//! 3. remove its energy from the map but leave a residual, so later lights can blend with the
//!    surroundings (Figure 6f): every texel of the light keeps the face's mean remaining radiance
//!    outside the light (or its own value, if lower). The light takes the removed energy; where
//!    the residual would leave it nothing (a light inside a uniform region), it takes all;
//!
//! until the lights cover the face (Figure 6i) or no uncovered texel has energy left. `t` alone
//! sets how many lights a face gets: a uniform face under a small `t` grows one light over the
//! whole face, each hot spot takes its own. Every light's seed has energy, so no light is empty.
//! What the residuals leave on a face goes, texel by texel, to the face's lights that cover the
//! texel (shared equally), so the lights' energies sum to the map's (up to rounding) with no
//! extra light.
//!
//! An optional cap `max_lights` bounds the total: faces then take their lights in turns
//! (brightest seed first within a face), and when the cap is reached the energy not yet taken on a
//! face goes to its nearest light (by texel distance to the light's rectangle).
//!
//! Cube-map layout: faces `+x, −x, +y, −y, +z, −z`, each row-major with rows `i` and columns `j`;
//! texel `(i, j)` of a face is the direction of the face point `(u, v) = (2 (j + ½)/N − 1,
//! 2 (i + ½)/N − 1)` in OpenGL's convention (`+x`: `(1, −v, −u)`, `−x`: `(−1, −v, u)`,
//! `+y`: `(u, 1, v)`, `−y`: `(u, −1, −v)`, `+z`: `(u, −v, 1)`, `−z`: `(−u, −v, −1)`).

use crate::error::{Error, Result};
use crate::limits;

/// The luminance weights of the greedy choices (Rec. 709).
const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// A rectangle of texels `(i0, i1, j0, j1)`: rows `i0..i1`, columns `j0..j1` of a face.
type Rect = (usize, usize, usize, usize);

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
    /// An optional cap on the number of lights (at least one per face that has energy).
    pub max_lights: Option<usize>,
    /// Grow all four sides together (square lights, as in the paper's results).
    pub square: bool,
}

/// The solid angle of cube-face texel `(i, j)` on an `n × n` face (exact: the integral of
/// `(1 + u² + v²)^(−3/2)` over the texel).
pub fn texel_solid_angle(n: usize, i: usize, j: usize) -> f64 {
    let corner = |u: f64, v: f64| (u * v).atan2((1.0 + u * u + v * v).sqrt());
    let (u0, u1) = (
        2.0 * j as f64 / n as f64 - 1.0,
        2.0 * (j + 1) as f64 / n as f64 - 1.0,
    );
    let (v0, v1) = (
        2.0 * i as f64 / n as f64 - 1.0,
        2.0 * (i + 1) as f64 / n as f64 - 1.0,
    );
    corner(u1, v1) - corner(u0, v1) - corner(u1, v0) + corner(u0, v0)
}

/// The remaining energy of one face and which of its texels its lights cover.
struct Face {
    n: usize,
    /// RGB energy per texel.
    energy: Vec<[f64; 3]>,
    solid_angle: Vec<f64>,
    covered: Vec<bool>,
    /// The rectangles `(i0, i1, j0, j1)` of the face's emitted lights and their indices in the result.
    lights: Vec<(Rect, usize)>,
    /// No uncovered texel has energy left (or the face is covered).
    done: bool,
}

impl Face {
    fn luminance(&self, k: usize) -> f64 {
        (0..3).map(|c| LUMINANCE[c] * self.energy[k][c]).sum()
    }

    fn region(&self, (i0, i1, j0, j1): Rect) -> f64 {
        (i0..i1)
            .flat_map(|i| (j0..j1).map(move |j| (i, j)))
            .map(|(i, j)| self.luminance(i * self.n + j))
            .sum()
    }

    /// Grows a light from `seed` by the threshold rule; returns its rectangle.
    fn grow(&self, seed: (usize, usize), opts: &FitOptions) -> Rect {
        let n = self.n;
        let mut r = (seed.0, seed.0 + 1, seed.1, seed.1 + 1);
        loop {
            let current = self.region(r);
            let candidates: Vec<Rect> = if opts.square {
                let grown = (
                    r.0.saturating_sub(1),
                    (r.1 + 1).min(n),
                    r.2.saturating_sub(1),
                    (r.3 + 1).min(n),
                );
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
    /// rest of the face as residual; or, where that residual would leave the light nothing (a
    /// light inside a uniform region, whose texels are all at the mean), taking everything.
    fn take(&mut self, r: Rect) -> [f64; 3] {
        let n = self.n;
        let inside = |k: usize| (r.0..r.1).contains(&(k / n)) && (r.2..r.3).contains(&(k % n));
        let (mut sum, mut area) = ([0.0f64; 3], 0.0f64);
        for k in (0..n * n).filter(|&k| !inside(k)) {
            sum.iter_mut()
                .zip(self.energy[k])
                .for_each(|(s, e)| *s += e);
            area += self.solid_angle[k];
        }
        let background = if area > 0.0 {
            sum.map(|s| s / area)
        } else {
            [0.0; 3]
        };
        let keep =
            |k: usize, c: usize, e: &[[f64; 3]]| (background[c] * self.solid_angle[k]).min(e[k][c]);
        let leaves_some = (0..n * n)
            .filter(|&k| inside(k))
            .any(|k| (0..3).any(|c| keep(k, c, &self.energy) < self.energy[k][c]));
        let mut taken = [0.0f64; 3];
        for k in (0..n * n).filter(|&k| inside(k)) {
            let kept: [f64; 3] = std::array::from_fn(|c| {
                if leaves_some {
                    keep(k, c, &self.energy)
                } else {
                    0.0
                }
            });
            for ((t, e), kept) in taken.iter_mut().zip(self.energy[k].iter_mut()).zip(kept) {
                *t += *e - kept;
                *e = kept;
            }
        }
        taken
    }

    /// The uncovered texel with the most remaining energy, if it has any.
    fn seed(&self) -> Option<(usize, usize)> {
        let (k, e) = (0..self.n * self.n)
            .filter(|&k| !self.covered[k])
            .map(|k| (k, self.luminance(k)))
            .fold((0, 0.0f64), |a, b| if b.1 > a.1 { b } else { a });
        (e > 0.0).then_some((k / self.n, k % self.n))
    }

    /// Steps 1-3 of the module documentation once: the next light's rectangle and energy, `None`
    /// when the face is done.
    fn next_light(&mut self, opts: &FitOptions) -> Option<(Rect, [f64; 3])> {
        let Some(seed) = self.seed() else {
            self.done = true;
            return None;
        };
        let r = self.grow(seed, opts);
        let energy = self.take(r);
        for i in r.0..r.1 {
            self.covered[i * self.n + r.2..i * self.n + r.3]
                .iter_mut()
                .for_each(|c| *c = true);
        }
        Some((r, energy))
    }

    /// Hands the energy left on every texel to the face's lights: shared equally by the lights
    /// covering the texel, or wholly to the nearest light's rectangle if none covers it.
    fn distribute_rest(&mut self, lights: &mut [FittedLight]) {
        let n = self.n;
        for k in 0..n * n {
            let (i, j) = (k / n, k % n);
            let inside = |r: &Rect| (r.0..r.1).contains(&i) && (r.2..r.3).contains(&j);
            let covering: Vec<usize> = self
                .lights
                .iter()
                .filter(|(r, _)| inside(r))
                .map(|&(_, l)| l)
                .collect();
            let gap = |r: &Rect| {
                let di = r.0.saturating_sub(i) + i.saturating_sub(r.1 - 1);
                let dj = r.2.saturating_sub(j) + j.saturating_sub(r.3 - 1);
                di * di + dj * dj
            };
            let targets = match self.lights.iter().min_by_key(|(r, _)| gap(r)) {
                _ if !covering.is_empty() => covering,
                Some(&(_, nearest)) => vec![nearest],
                None => return,
            };
            let share = self.energy[k].map(|e| e / targets.len() as f64);
            for l in targets {
                lights[l]
                    .energy
                    .iter_mut()
                    .zip(share)
                    .for_each(|(e, s)| *e += s);
            }
            self.energy[k] = [0.0; 3];
        }
    }
}

/// Fits square (or rectangular) area lights to a cube map `faces` of `6 × n × n` RGB radiance
/// texels (row-major per face, see the module documentation).
///
/// Errors: a wrong length or `n = 0`; negative or non-finite radiance; a threshold outside
/// (0, 1); a cap below 6 (a light per face); `TooLarge`.
pub fn fit_area_lights(faces: &[f32], n: usize, opts: &FitOptions) -> Result<Vec<FittedLight>> {
    if n == 0 || faces.len() != 6 * n * n * 3 {
        return Err(Error::invalid(
            "env",
            format!(
                "expected 6 faces of {n}x{n} RGB texels ({} values), got {}",
                6 * n * n * 3,
                faces.len()
            ),
        ));
    }
    if faces.iter().any(|v| !v.is_finite() || *v < 0.0) {
        return Err(Error::invalid("env", "radiance must be finite and >= 0"));
    }
    if !(opts.threshold > 0.0 && opts.threshold < 1.0) {
        return Err(Error::invalid(
            "threshold",
            format!("must be in (0, 1), got {}", opts.threshold),
        ));
    }
    if let Some(cap) = opts.max_lights.filter(|&cap| cap < 6) {
        return Err(Error::invalid(
            "max_lights",
            format!("must be >= 6 (a light for each face with energy), or None, got {cap}"),
        ));
    }
    limits::check_memory(
        "environment fit",
        limits::bytes(&[6, n as u64, n as u64, 40]),
    )?;
    let solid_angle: Vec<f64> = (0..n * n)
        .map(|k| texel_solid_angle(n, k / n, k % n))
        .collect();
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
            covered: vec![false; n * n],
            lights: Vec::new(),
            done: false,
        })
        .collect();
    let cap = opts.max_lights.unwrap_or(usize::MAX);
    let mut lights = Vec::new();
    // Faces take turns, one light each per round: without a cap this is each face decomposed on
    // its own; with one, every face with energy has its first light before any face its second.
    while lights.len() < cap && cube.iter().any(|f| !f.done) {
        for (face, f) in cube.iter_mut().enumerate() {
            if lights.len() == cap {
                break;
            }
            if let Some((r, energy)) = f.next_light(opts) {
                f.lights.push((r, lights.len()));
                lights.push(FittedLight {
                    face,
                    i0: r.0,
                    i1: r.1,
                    j0: r.2,
                    j1: r.3,
                    energy,
                });
            }
        }
    }
    for f in &mut cube {
        f.distribute_rest(&mut lights);
    }
    Ok(lights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texel_solid_angles_sum_to_the_sphere() {
        let n = 16;
        let total: f64 = (0..n * n)
            .map(|k| texel_solid_angle(n, k / n, k % n))
            .sum::<f64>()
            * 6.0;
        assert!((total - 4.0 * std::f64::consts::PI).abs() < 1e-9, "{total}");
    }

    fn lights(
        faces: &[f32],
        n: usize,
        threshold: f64,
        max_lights: Option<usize>,
    ) -> Vec<FittedLight> {
        fit_area_lights(
            faces,
            n,
            &FitOptions {
                threshold,
                max_lights,
                square: true,
            },
        )
        .unwrap()
    }

    fn sun_map(n: usize) -> Vec<f32> {
        let mut faces = vec![0.05f32; 6 * n * n * 3];
        for c in 0..3 {
            faces[((2 * n * n) + 5 * n + 9) * 3 + c] = 500.0; // a sun on +y
        }
        faces
    }

    #[test]
    fn energy_is_conserved_and_a_sun_gets_one_light() {
        let n = 16;
        let lights = lights(&sun_map(n), n, 0.03, None);
        let background = f64::from(0.05f32);
        let expected = 4.0 * std::f64::consts::PI * background
            + (500.0 - background) * texel_solid_angle(n, 5, 9);
        let total: f64 = lights.iter().map(|l| l.energy[1]).sum();
        assert!(
            (total - expected).abs() < 1e-9 * total,
            "{total} vs {expected}"
        );
        let brightest = lights
            .iter()
            .max_by(|a, b| a.energy[1].total_cmp(&b.energy[1]))
            .unwrap();
        assert_eq!((brightest.face, brightest.i0, brightest.j0), (2, 5, 9));
        assert!(
            brightest.energy[1] > 0.5 * total,
            "the sun's light carries {} of {total}",
            brightest.energy[1]
        );
    }

    #[test]
    fn a_uniform_face_is_one_light_and_an_unlit_face_none() {
        let n = 12;
        let mut faces = vec![0.0f32; 6 * n * n * 3];
        faces[..n * n * 3].iter_mut().for_each(|v| *v = 1.0); // only +x emits, uniformly
        let lights = lights(&faces, n, 0.02, None);
        assert_eq!(lights.len(), 1);
        assert_eq!(
            (
                lights[0].face,
                lights[0].i0,
                lights[0].i1,
                lights[0].j0,
                lights[0].j1
            ),
            (0, 0, n, 0, n)
        );
    }

    #[test]
    fn no_light_repeats_or_is_empty_and_more_lights_follow_a_larger_threshold() {
        let n = 24;
        let mut faces = sun_map(n);
        for (k, v) in faces.iter_mut().enumerate() {
            *v += ((k / 3) % 17) as f32 * 0.01; // structure for the growth to follow
        }
        let counts: Vec<usize> = [0.01, 0.03, 0.1]
            .iter()
            .map(|&t| {
                let lights = lights(&faces, n, t, None);
                for (a, la) in lights.iter().enumerate() {
                    assert!(la.energy[1] > 0.0, "empty light {la:?}");
                    for lb in &lights[a + 1..] {
                        assert!(
                            (la.face, la.i0, la.i1, la.j0, la.j1)
                                != (lb.face, lb.i0, lb.i1, lb.j0, lb.j1),
                            "repeated {la:?}"
                        );
                    }
                }
                lights.len()
            })
            .collect();
        assert!(
            counts[0] <= counts[1] && counts[1] <= counts[2] && counts[0] < counts[2],
            "{counts:?}"
        );
    }

    #[test]
    fn a_cap_bounds_the_lights_and_keeps_the_energy() {
        let n = 16;
        let faces: Vec<f32> = (0..6 * n * n * 3)
            .map(|k| 0.1 + ((k * 7919) % 101) as f32 * 0.01)
            .collect();
        let free = lights(&faces, n, 0.2, None);
        let capped = lights(&faces, n, 0.2, Some(8));
        assert!(free.len() > 8, "{}", free.len());
        assert_eq!(capped.len(), 8);
        let sum = |ls: &[FittedLight]| ls.iter().map(|l| l.energy[0]).sum::<f64>();
        assert!((sum(&free) - sum(&capped)).abs() < 1e-9 * sum(&free));
    }
}
