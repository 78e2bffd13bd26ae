//! [`MlpTable::scores`] on Arm cores with a floating-point unit: one cell's
//! scores in one pass of `VLDM` loads and `VMUL`/`VMLA`/`VADD`, the
//! features and the seven scores held in registers throughout.
//!
//! The compiler's code for the same loop loads each weight with its own
//! `VLDR` (14 per hidden unit, 7 per active unit's output weights); here a
//! unit's 14 input weights and bias take two `VLDM` and its output weights
//! one (Armv7-M Architecture Reference Manual, `VLDM`; a `VLDM` of n
//! registers is one instruction of 1 + n cycles on a Cortex-M4, a `VLDR` one
//! of two). `VMLA.F32` rounds the product and then the sum (not fused, unlike
//! `VFMA`), so each score is the same sum of the same rounded products in
//! the same order as [`MlpTable::scores_portable`] and
//! [`super::MlpWeights::scores`]: the same bits. Stable Rust's `asm!` cannot
//! name single-precision registers on this target, so the block saves and
//! restores all of `d0`-`d15` (`s0`-`s31`) itself and leaves every register
//! as it found it.
//!
//! Registers: `s0`-`s13` the standardised features, `s14`-`s20` the scores,
//! `s21` a hidden unit's activation, `s22`-`s29` weights as they are loaded.
//! The code is written for 14 features and 7 classes ([`SHAPE`]); a model
//! of another shape takes the portable loop.

use super::table::{MlpTable, UNIT};
use super::{CLASSES, FEATURES, HIDDEN};

/// The shape the code below is written for.
const SHAPE: bool = FEATURES == 14 && CLASSES == 7 && UNIT == 22;

// The table is its floats back to back, as the block walks it.
const _: () = assert!(
    core::mem::size_of::<MlpTable>() == 4 * (2 * FEATURES + CLASSES + HIDDEN * UNIT + CLASSES)
        && core::mem::align_of::<MlpTable>() == 4
);

/// [`MlpTable::scores`] by the `VLDM` kernel; `None` for a model of another
/// shape than [`SHAPE`]. Out of line: the compiler sizes an `asm!` block by
/// its lines, not by what `.rept` makes of them, so branches placed across
/// the block inside a larger function could end up out of range.
#[inline(never)]
#[allow(unsafe_code)]
pub(super) fn scores(t: &MlpTable, f: &[f32; FEATURES]) -> Option<[f32; CLASSES]> {
    if !SHAPE {
        return None;
    }
    let mut out = [0.0f32; CLASSES];
    // SAFETY: with `SHAPE`, the block reads the 14 floats of `f` and the
    // `MlpTable` (`repr(C)`: means, scales, starts, the units' records and
    // the output biases, each a run of `f32`, read in that order and not
    // past its end) and writes the 7 floats of `out`. It saves `d0`-`d15`
    // on the stack first and restores them last; the flags it changes are
    // not declared preserved.
    unsafe {
        core::arch::asm!(
            "vpush {{d0-d15}}",
            "vldmia {f}, {{s0-s13}}",
            "vldmia {t}!, {{s22-s28}}",
            "vsub.f32 s0, s0, s22",
            "vsub.f32 s1, s1, s23",
            "vsub.f32 s2, s2, s24",
            "vsub.f32 s3, s3, s25",
            "vsub.f32 s4, s4, s26",
            "vsub.f32 s5, s5, s27",
            "vsub.f32 s6, s6, s28",
            "vldmia {t}!, {{s22-s28}}",
            "vsub.f32 s7, s7, s22",
            "vsub.f32 s8, s8, s23",
            "vsub.f32 s9, s9, s24",
            "vsub.f32 s10, s10, s25",
            "vsub.f32 s11, s11, s26",
            "vsub.f32 s12, s12, s27",
            "vsub.f32 s13, s13, s28",
            "vldmia {t}!, {{s22-s28}}",
            "vmul.f32 s0, s0, s22",
            "vmul.f32 s1, s1, s23",
            "vmul.f32 s2, s2, s24",
            "vmul.f32 s3, s3, s25",
            "vmul.f32 s4, s4, s26",
            "vmul.f32 s5, s5, s27",
            "vmul.f32 s6, s6, s28",
            "vldmia {t}!, {{s22-s28}}",
            "vmul.f32 s7, s7, s22",
            "vmul.f32 s8, s8, s23",
            "vmul.f32 s9, s9, s24",
            "vmul.f32 s10, s10, s25",
            "vmul.f32 s11, s11, s26",
            "vmul.f32 s12, s12, s27",
            "vmul.f32 s13, s13, s28",
            "vldmia {t}!, {{s14-s20}}",
            ".rept {hidden}",
            "vldmia {t}!, {{s22-s29}}",
            "vmul.f32 s21, s22, s0",
            "vmla.f32 s21, s23, s1",
            "vmla.f32 s21, s24, s2",
            "vmla.f32 s21, s25, s3",
            "vmla.f32 s21, s26, s4",
            "vmla.f32 s21, s27, s5",
            "vmla.f32 s21, s28, s6",
            "vmla.f32 s21, s29, s7",
            "vldmia {t}!, {{s22-s28}}",
            "vmla.f32 s21, s22, s8",
            "vmla.f32 s21, s23, s9",
            "vmla.f32 s21, s24, s10",
            "vmla.f32 s21, s25, s11",
            "vmla.f32 s21, s26, s12",
            "vmla.f32 s21, s27, s13",
            "vadd.f32 s21, s21, s28",
            "vcmp.f32 s21, #0",
            "vmrs APSR_nzcv, fpscr",
            "ble.w 1f",
            "vldmia {t}, {{s22-s28}}",
            "vmla.f32 s14, s22, s21",
            "vmla.f32 s15, s23, s21",
            "vmla.f32 s16, s24, s21",
            "vmla.f32 s17, s25, s21",
            "vmla.f32 s18, s26, s21",
            "vmla.f32 s19, s27, s21",
            "vmla.f32 s20, s28, s21",
            "1:",
            "add {t}, {t}, #28",
            ".endr",
            "vldmia {t}, {{s22-s28}}",
            "vadd.f32 s14, s14, s22",
            "vadd.f32 s15, s15, s23",
            "vadd.f32 s16, s16, s24",
            "vadd.f32 s17, s17, s25",
            "vadd.f32 s18, s18, s26",
            "vadd.f32 s19, s19, s27",
            "vadd.f32 s20, s20, s28",
            "vstmia {o}, {{s14-s20}}",
            "vpop {{d0-d15}}",
            f = in(reg) f.as_ptr(),
            t = inout(reg) core::ptr::from_ref(t).cast::<f32>() => _,
            o = in(reg) out.as_mut_ptr(),
            hidden = const HIDDEN,
        );
    }
    Some(out)
}
