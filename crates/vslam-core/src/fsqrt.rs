//! The square root of the hot loops: the vision's (the Shi-Tomasi response
//! of every pixel, the tracker's conditioning test) and the EKF updates'
//! Cholesky factor (`ego_ekf::kernels::cholesky`, one per row).
//!
//! IEEE 754 requires the square root to be correctly rounded, and so are
//! `libm::sqrtf` and the `VSQRT.F32` instruction of every Arm floating-point
//! unit (Arm ARM, VFPv2 and later, "VSQRT"): the two give the same bits for
//! every input, so firmware and host agree. On hard-float Arm targets
//! (`target_abi = "eabihf"`, which have an FPU) the instruction is used:
//! one instruction where `libm::sqrtf` runs a software routine of about 50
//! instructions on a Cortex-M4 (`firmware/README.md`). Stable Rust does not
//! let `asm!` name single-precision registers on `thumbv7em-none-eabihf`
//! (the `sreg` class needs a target feature it does not expose), so the
//! value passes through a core register and `s15`, which the instructions
//! save and restore (five instructions in all).
//! Elsewhere it is `libm::sqrtf`.

/// `sqrt(x)`, correctly rounded (NaN for negative `x`).
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
#[allow(unsafe_code)]
pub fn sqrtf(x: f32) -> f32 {
    let mut bits = x.to_bits();
    // SAFETY: FPU instructions on registers; `s15` is saved on the stack
    // and restored, so no register but the declared operand changes.
    unsafe {
        core::arch::asm!(
            "vpush {{s15}}",
            "vmov s15, {b}",
            "vsqrt.f32 s15, s15",
            "vmov {b}, s15",
            "vpop {{s15}}",
            b = inout(reg) bits,
            options(pure, nomem),
        );
    }
    f32::from_bits(bits)
}

/// `sqrt(x)`, correctly rounded (NaN for negative `x`).
#[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
#[inline(always)]
pub fn sqrtf(x: f32) -> f32 {
    libm::sqrtf(x)
}

#[cfg(test)]
mod tests {
    #[test]
    fn is_the_correctly_rounded_square_root() {
        for x in [0.0f32, 1.0, 2.0, 1e-40, 3.4e38, 12345.678, 0.25] {
            assert_eq!(super::sqrtf(x).to_bits(), libm::sqrtf(x).to_bits(), "{x}");
        }
        assert!(super::sqrtf(-1.0).is_nan());
    }
}
