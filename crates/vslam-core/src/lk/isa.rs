//! Which instruction set the tracker's row kernels run on.
//!
//! The row kernels (`template`, `gain`) are straight-line loops over eight
//! `f32` lanes. Compiled for the x86-64 baseline (SSE2) each lane group
//! takes two 4-wide registers; with AVX2 it takes one 8-wide register. With
//! the `std` feature on x86-64, each kernel is compiled twice ([`twins`])
//! and [`Isa::detect`] picks the AVX2 copy at run time when the CPU has it;
//! elsewhere (Cortex-M, no `std`) only the baseline copy exists. On AVX2 the
//! two hottest loops, the template fill and the constant-brightness sweep,
//! run hand-written intrinsics instead (`avx2`, a whole window per call).
//! One tracking call of the `lk` bench's input runs 2.91 M instructions on
//! AVX2 against 8.07 M with the baseline copies (callgrind, see
//! `benches/README.md`).
//!
//! Both copies give the same bits: they run the same lane-wise `f32`
//! additions and multiplications in the same order, and Rust never fuses a
//! multiply and an add into an FMA on its own (AVX2 does not enable FMA).
//! The tracker's tests compare the two on every window size, and `avx2`'s
//! tests its intrinsics against the baseline copies.

/// The instruction set of the row kernels: the baseline, or AVX2 when the
/// CPU has it (x86-64 with `std` only).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Isa {
    avx2: bool,
}

impl Isa {
    /// The baseline copy everywhere.
    #[cfg_attr(not(test), allow(dead_code))]
    pub(super) const BASELINE: Isa = Isa { avx2: false };

    /// The fastest copy this CPU runs.
    #[inline]
    pub(super) fn detect() -> Isa {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        {
            extern crate std;
            Isa {
                avx2: std::is_x86_feature_detected!("avx2"),
            }
        }
        #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
        {
            Isa::BASELINE
        }
    }

    /// Whether the AVX2 copies run (only [`Isa::detect`] sets it, and only
    /// on a CPU with AVX2).
    #[inline(always)]
    #[cfg_attr(not(all(feature = "std", target_arch = "x86_64")), allow(dead_code))]
    pub(super) fn avx2(self) -> bool {
        self.avx2
    }
}

/// `twins! { fn name<const ..>(isa, args..) => body; }` defines `name`, which
/// runs `body` (an `#[inline(always)]` function of `args`) out of line,
/// compiled for the baseline or, where `isa` says so, for AVX2.
macro_rules! twins {
    ($(#[$attr:meta])* $vis:vis fn $name:ident<$(const $g:ident: $gt:ty),*>(
        $isa:ident $(, $arg:ident: $ty:ty)* $(,)?
    ) => $body:ident;) => {
        $(#[$attr])*
        #[inline(always)]
        $vis fn $name<$(const $g: $gt),*>($isa: $crate::lk::isa::Isa $(, $arg: $ty)*) {
            #[inline(never)]
            fn baseline<$(const $g: $gt),*>($($arg: $ty),*) {
                $body::<$($g),*>($($arg),*)
            }
            #[cfg(all(feature = "std", target_arch = "x86_64"))]
            #[target_feature(enable = "avx2")]
            #[inline(never)]
            fn avx2<$(const $g: $gt),*>($($arg: $ty),*) {
                $body::<$($g),*>($($arg),*)
            }
            #[cfg(all(feature = "std", target_arch = "x86_64"))]
            if $isa.avx2() {
                // SAFETY: `Isa::avx2` is true only when `Isa::detect` found
                // AVX2 on this CPU, which is all `avx2` needs.
                #[allow(unsafe_code)]
                unsafe {
                    avx2::<$($g),*>($($arg),*)
                };
                return;
            }
            let _ = $isa;
            baseline::<$($g),*>($($arg),*)
        }
    };
}
pub(super) use twins;
