//! The instruction sets that lane loops are compiled for, the one dispatch between them, and
//! the byte masks such loops write their answers in ([`top_bit`], [`movemask`]).
//!
//! A lane loop (the packet traversal of `geometry/bvh/packet.rs`, `alias_free`'s pair tests)
//! is written once, as plain `for` loops over fixed-size arrays whose bodies are made of
//! `#[inline(always)]` functions; [`isa_dispatch`] compiles that one body for each instruction
//! set and picks the widest this CPU has. No feature set here enables fused multiply-add
//! contraction (Rust never contracts `a * b + c`), so every variant rounds as the baseline does:
//! the same bits on every CPU.

/// The instruction sets lane loops are compiled for; [`Isa::detect`] picks the widest the CPU
/// has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Isa {
    /// The target's baseline (SSE2 on x86-64).
    Baseline,
    /// 256-bit registers.
    #[cfg(target_arch = "x86_64")]
    Avx2,
    /// 512-bit registers, compares straight into mask registers.
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

impl Isa {
    /// The widest instruction set of this CPU.
    pub(crate) fn detect() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            if has_avx512() {
                return Isa::Avx512;
            }
            if std::is_x86_feature_detected!("avx2") {
                return Isa::Avx2;
            }
        }
        Isa::Baseline
    }

    /// Every instruction set of this CPU, for tests that run each variant.
    #[cfg(test)]
    pub(crate) fn all_on_this_cpu() -> Vec<Isa> {
        let mut isas = vec![Isa::Baseline];
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") {
                isas.push(Isa::Avx2);
            }
            if has_avx512() {
                isas.push(Isa::Avx512);
            }
        }
        isas
    }
}

/// `x.signum()` (NaN for NaN, else ±1 with `x`'s sign) without the branch that the standard
/// library's takes lane by lane.
#[inline(always)]
pub(crate) fn signum(x: f64) -> f64 {
    let sign = 1.0f64.copysign(x);
    if x.is_nan() {
        f64::NAN
    } else {
        sign
    }
}

/// Lane `l`'s entry of a byte mask of 16 lanes (see [`movemask`]).
///
/// Every lane loop writes such bytes in a plain `for` loop whose body is made of
/// `#[inline(always)]` functions: LLVM vectorizes it into compares and one mask move per
/// register. Closures, iterator adaptors and `array::map` would risk being left out of line,
/// compiled for the baseline instead of the dispatched instruction set.
#[inline(always)]
pub(crate) fn top_bit(b: bool) -> u8 {
    if b {
        0x80
    } else {
        0
    }
}

/// The top bits of `bytes` as a bitmask: `pmovmskb`, which LLVM folds with the compares before
/// it into one mask move (the shift-and-or loop it does not recognize).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn movemask(bytes: [u8; 16]) -> u64 {
    // SAFETY: SSE2 is part of the x86-64 baseline, so every x86-64 CPU has it.
    unsafe { movemask_sse2(bytes) }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse2")]
#[inline]
fn movemask_sse2(b: [u8; 16]) -> u64 {
    use std::arch::x86_64::{_mm_movemask_epi8, _mm_set_epi8};
    let [b0, b1, b2, b3, b4, b5, b6, b7, b8, b9, b10, b11, b12, b13, b14, b15] = b.map(|x| x as i8);
    let v = _mm_set_epi8(
        b15, b14, b13, b12, b11, b10, b9, b8, b7, b6, b5, b4, b3, b2, b1, b0,
    );
    u64::from(_mm_movemask_epi8(v) as u16)
}

/// The top bits of `bytes` as a bitmask (portable).
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub(crate) fn movemask(bytes: [u8; 16]) -> u64 {
    let mut m = 0u64;
    for (l, &b) in bytes.iter().enumerate() {
        m |= u64::from(b >> 7) << l;
    }
    m
}

/// Whether the CPU has the AVX-512 subsets the `avx512` variants of [`isa_dispatch`] are
/// compiled for.
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx512() -> bool {
    std::is_x86_feature_detected!("avx512f")
        && std::is_x86_feature_detected!("avx512bw")
        && std::is_x86_feature_detected!("avx512vl")
        && std::is_x86_feature_detected!("avx512dq")
}

/// Defines, in an `impl` of `$recv`, the method `$name(&self, isa: Isa, args...)`, which runs
/// `self.$body(args...)` compiled for `isa` (the baseline unless the CPU has it): one body,
/// inlined into one wrapper per instruction set, each compiled with its target features.
/// `$body` must be `#[inline(always)]`, and so must everything its lane loops call.
///
/// Neither feature set holds `popcnt`, so the lane counts of the packet traversal take a dozen
/// instructions; adding `popcnt`, `lzcnt` and BMI1/2 (checked at run time beside the rest)
/// took 0.99-1.00x the CPU time of `ray_traced` at 128x128, not worth a stricter CPU check.
macro_rules! isa_dispatch {
    ($(#[$doc:meta])* fn $name:ident(&$recv:ty) => $body:ident($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty) => {
        $(#[$doc])*
        #[allow(clippy::too_many_arguments)]
        fn $name(&self, isa: $crate::isa::Isa, $($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx512f,avx512bw,avx512vl,avx512dq")]
            fn avx512(this: &$recv, $($arg: $ty),*) -> $ret {
                this.$body($($arg),*)
            }
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2")]
            fn avx2(this: &$recv, $($arg: $ty),*) -> $ret {
                this.$body($($arg),*)
            }
            match isa {
                #[cfg(target_arch = "x86_64")]
                $crate::isa::Isa::Avx512 if $crate::isa::has_avx512() => {
                    // SAFETY: the CPU has every feature `avx512` is compiled for (checked just
                    // above).
                    unsafe { avx512(self, $($arg),*) }
                }
                #[cfg(target_arch = "x86_64")]
                $crate::isa::Isa::Avx2 if std::is_x86_feature_detected!("avx2") => {
                    // SAFETY: the CPU has AVX2 (checked just above).
                    unsafe { avx2(self, $($arg),*) }
                }
                _ => self.$body($($arg),*),
            }
        }
    };
}
pub(crate) use isa_dispatch;
