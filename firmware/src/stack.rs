//! Peak stack of one call by stack painting: fill the free stack below the
//! current stack pointer with a pattern, make the call, and find the lowest
//! word the call overwrote (the high-water mark).
//!
//! Nothing else runs (no interrupt is enabled), so the free stack below the
//! stack pointer belongs to the call alone. A call of `traction::Estimator`
//! is held to [`ESTIMATOR_LIMIT`]: the painted words below the limit are a
//! canary, checked after the call (the [`crate::meter::Meter`] records the
//! first call past it, and the firmware reports it as an error and fails). A call that happens to write the
//! pattern itself at its deepest word is undercounted by at most that word.

/// Bytes painted below the stack pointer; deeper use is reported as "at least".
pub const DEPTH: usize = 48 * 1024;
/// Bytes painted below a front-end call.
pub const FRONTEND_PAINT: usize = 160 * 1024;
/// Stack limit of one `traction::Estimator` call (issue 21: 16 KB);
/// `FIRMWARE_ESTIMATOR_STACK_LIMIT=<bytes>` at build time sets another (a
/// small one shows the check firing).
pub const ESTIMATOR_LIMIT: usize = match option_env!("FIRMWARE_ESTIMATOR_STACK_LIMIT") {
    Some(s) => parse(s),
    None => 16 * 1024,
};

/// A decimal number; 0 for anything else.
pub(crate) const fn parse(s: &str) -> usize {
    let b = s.as_bytes();
    let mut i = 0;
    let mut n = 0usize;
    while i < b.len() {
        let d = b[i];
        if !d.is_ascii_digit() {
            return 0;
        }
        n = n * 10 + (d - b'0') as usize;
        i += 1;
    }
    n
}

/// The pattern.
pub const PATTERN: u32 = 0xC0DE_5A5A;

/// The stack pointer of the caller.
#[inline(always)]
pub fn sp() -> usize {
    let sp: usize;
    // SAFETY: reads a register.
    unsafe {
        core::arch::asm!("mov {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags))
    };
    sp
}

/// Paints `[sp - DEPTH, sp)`; gives `sp`. Must be inlined into the measuring
/// function so that it writes only below that function's frame.
#[inline(always)]
pub fn paint() -> usize {
    paint_depth(DEPTH)
}

/// The lowest painted word below `top`: `depth` bytes down, but not into
/// the stack guard ([`crate::guard::floor`]).
#[inline(always)]
fn bottom(top: usize, depth: usize) -> usize {
    top.saturating_sub(depth)
        .max(crate::guard::floor())
        .min(top)
}

/// Paints `[sp - depth, sp)` (not below the guard); gives `sp`.
#[inline(always)]
pub fn paint_depth(depth: usize) -> usize {
    let top = sp() & !3;
    let mut a = bottom(top, depth);
    if cfg!(debug_assertions) {
        // A debug build calls `write_volatile` out of line, and its frame
        // would land on the words being painted: paint in assembly.
        // SAFETY: as below.
        unsafe {
            core::arch::asm!(
                "2:",
                "cmp {a}, {top}",
                "bhs 3f",
                "str {v}, [{a}], #4",
                "b 2b",
                "3:",
                a = inout(reg) a,
                top = in(reg) top,
                v = in(reg) PATTERN,
                options(nostack),
            )
        };
    }
    while a < top {
        // SAFETY: the words below the stack pointer and above the guard
        // are free stack (no interrupts, no other thread).
        unsafe { core::ptr::write_volatile(a as *mut u32, PATTERN) };
        a += 4;
    }
    top
}

/// Bytes below `top` (from [`paint`]) that were written since.
#[inline(always)]
pub fn used(top: usize) -> usize {
    used_depth(top, DEPTH)
}

/// Bytes below `top` (from [`paint_depth`] with `depth`) that were written since.
#[inline(always)]
pub fn used_depth(top: usize, depth: usize) -> usize {
    let mut a = bottom(top, depth);
    while a < top {
        // SAFETY: the same painted words, read back.
        if unsafe { core::ptr::read_volatile(a as *const u32) } != PATTERN {
            break;
        }
        a += 4;
    }
    top - a
}

/// Calls `f` out of line, so that its whole frame is below the caller's.
#[inline(never)]
pub fn call<R>(f: impl FnOnce() -> R) -> R {
    f()
}
