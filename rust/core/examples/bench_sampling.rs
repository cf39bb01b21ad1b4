//! Poisson-disk light samples: the grid-accelerated dart throwing of `unit_pattern` against
//! the quadratic loop it replaced (every dart tested against every kept point), timed side by
//! side in one run on the very same darts, with a check that both keep the same points.
//!
//! `cargo run --release -p softshadows-core --example bench_sampling [n...]`
//! prints, per count and dimension, both times and their ratio (default counts 500, 1000, 2000;
//! the quadratic loop takes minutes from about 10,000 on). `--fast-only n...` times the grid
//! version alone, for counts the quadratic loop cannot reach.

use softshadows_core::light::sampling::{poisson_testing_every_point, unit_pattern, Pattern, Rng};
use std::process::ExitCode;
use std::time::Instant;

/// The stream `unit_pattern` draws its darts from.
const DART_STREAM: u64 = 0x5A4D;

/// Dart throwing as first written, from the same dart stream as `unit_pattern`.
fn quadratic_poisson(n: usize, dim: usize, seed: u64) -> Vec<[f32; 3]> {
    poisson_testing_every_point(n, dim, &mut Rng::stream(seed, DART_STREAM))
}

fn timed<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let start = Instant::now();
    let out = f();
    (start.elapsed().as_secs_f64(), out)
}

fn bits(pts: &[[f32; 3]]) -> Vec<[u32; 3]> {
    pts.iter().map(|p| p.map(f32::to_bits)).collect()
}

/// Times both versions at `n`; false when they disagree.
fn side_by_side(n: usize, dim: usize) -> bool {
    let (grid_s, grid) = timed(|| unit_pattern(Pattern::Poisson, n, dim, 1));
    let (quadratic_s, quadratic) = timed(|| quadratic_poisson(n, dim, 1));
    let same = bits(&grid) == bits(&quadratic);
    println!(
        "n {n:>7}  dim {dim}  grid {grid_s:>9.4} s  quadratic {quadratic_s:>9.3} s  ratio {:>8.1}  {}",
        quadratic_s / grid_s.max(1e-9),
        if same { "same points" } else { "DIFFERENT POINTS" }
    );
    same
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let fast_only = args.first().is_some_and(|a| a == "--fast-only");
    let counts: Result<Vec<usize>, _> = args
        .iter()
        .skip(usize::from(fast_only))
        .map(|a| a.parse::<usize>())
        .collect();
    let counts = match counts {
        Ok(c) if c.is_empty() => vec![500, 1000, 2000],
        Ok(c) => c,
        Err(e) => {
            eprintln!("counts must be positive integers: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut same = true;
    for n in counts {
        for dim in [2, 3] {
            if fast_only {
                let (s, pts) = timed(|| unit_pattern(Pattern::Poisson, n, dim, 1));
                println!(
                    "n {n:>7}  dim {dim}  grid {s:>9.4} s  ({} points)",
                    pts.len()
                );
            } else {
                same &= side_by_side(n, dim);
            }
        }
    }
    if same {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
