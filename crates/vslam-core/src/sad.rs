//! The sum of absolute differences of two rows of 8-bit pixels: the inner
//! loop of block matching ([`crate::flow_frames::global_match`]).
//!
//! On Armv7E-M (Cortex-M4 and M7, `thumbv7em-*` targets; the build script
//! sets `cfg(armv7em)`) four pixels go through one `USADA8` of the DSP
//! extension (Arm v7-M Architecture Reference Manual, A7.7.192 "USADA8":
//! unsigned sum of absolute differences of the four bytes, accumulated),
//! each row read a word at a time; elsewhere, and for the last one to three
//! pixels, byte by byte (which x86-64 compilers vectorise). Both are the
//! same integer sum, so firmware and host agree bit for bit.

/// `sum |a[i] - b[i]|` over the shorter row's length.
#[inline]
pub fn sad(a: &[u8], b: &[u8]) -> u32 {
    let n = a.len().min(b.len());
    let (a, b) = (a.get(..n).unwrap_or(&[]), b.get(..n).unwrap_or(&[]));
    words(a, b)
}

#[cfg(armv7em)]
#[inline(always)]
#[allow(unsafe_code)]
fn words(a: &[u8], b: &[u8]) -> u32 {
    let (wa, ra) = a.as_chunks::<4>();
    let (wb, rb) = b.as_chunks::<4>();
    let mut acc = 0u32;
    for (x, y) in wa.iter().zip(wb) {
        let (x, y) = (u32::from_le_bytes(*x), u32::from_le_bytes(*y));
        // SAFETY: a register-only instruction of the DSP extension, which
        // every Armv7E-M core has; no memory, stack or flags touched.
        unsafe {
            core::arch::asm!(
                "usada8 {acc}, {x}, {y}, {acc}",
                acc = inout(reg) acc,
                x = in(reg) x,
                y = in(reg) y,
                options(pure, nomem, nostack, preserves_flags),
            );
        }
    }
    acc + bytes(ra, rb)
}

#[cfg(not(armv7em))]
#[inline(always)]
fn words(a: &[u8], b: &[u8]) -> u32 {
    bytes(a, b)
}

#[inline(always)]
fn bytes(a: &[u8], b: &[u8]) -> u32 {
    a.iter()
        .zip(b)
        .map(|(p, q)| u32::from(p.abs_diff(*q)))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equals_the_sum_of_byte_differences() {
        let mut s = 0x1234_5678u32;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            (s >> 24) as u8
        };
        let a: [u8; 64] = core::array::from_fn(|_| next());
        let b: [u8; 64] = core::array::from_fn(|_| next());
        for (i, j, n) in [(0, 0, 64), (1, 3, 35), (5, 0, 21), (0, 7, 3), (2, 2, 0)] {
            let (x, y) = (&a[i..i + n], &b[j..j + n]);
            let want: u32 = x
                .iter()
                .zip(y)
                .map(|(p, q)| (*p as i32 - *q as i32).unsigned_abs())
                .sum();
            assert_eq!(sad(x, y), want, "{i} {j} {n}");
        }
        // The shorter row's length; extremes.
        assert_eq!(sad(&[0, 255, 7], &[255, 0]), 510);
        assert_eq!(sad(&[255; 40], &[0; 40]), 255 * 40);
    }
}
