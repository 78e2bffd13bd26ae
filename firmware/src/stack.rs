//! Peak stack of one call by stack painting: fill the free stack below the
//! current stack pointer with a pattern, make the call, and find the lowest
//! word the call overwrote (the high-water mark).
//!
//! Nothing else runs (no interrupt is enabled), so the free stack below the
//! stack pointer belongs to the call alone. A call that happens to write the
//! pattern itself at its deepest word is undercounted by at most that word.

/// Bytes painted below the stack pointer; deeper use is reported as "at least".
pub const DEPTH: usize = 48 * 1024;
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

/// Paints `[sp - depth, sp)`; gives `sp`.
#[inline(always)]
pub fn paint_depth(depth: usize) -> usize {
    let top = sp() & !3;
    let mut a = top - depth;
    while a < top {
        // SAFETY: the words below the stack pointer are free (no interrupts,
        // no other thread); the RAM region is 4 MiB and the stack is far
        // from .data and .bss.
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
    let mut a = top - depth;
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
