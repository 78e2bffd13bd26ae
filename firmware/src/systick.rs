//! Instruction counts from SysTick under QEMU `-icount shift=0`.
//!
//! With `-icount shift=0` QEMU advances its virtual clock by exactly
//! 2^0 = 1 ns per executed instruction. SysTick, clocked from the core clock
//! (`CLKSOURCE = 1`; the MPS2 AN386 model feeds it the 25 MHz SYSCLK), then
//! decrements once every 40 instructions. [`calibrate`] measures that ratio
//! on a loop of known length instead of assuming it.
//!
//! SysTick is a 24-bit down-counter (ARMv7-M ARM, B3.3): with the reload
//! value `0x00FF_FFFF` it counts `RVR, RVR-1, ..., 0, RVR, ...`, a period of
//! exactly 2^24, so `(start - end) mod 2^24` is the elapsed tick count for any
//! interval shorter than 2^24 ticks (671 million instructions), wrap or not.

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;

/// The 24-bit counter's mask and reload value.
pub const MASK: u32 = 0x00FF_FFFF;

/// Starts SysTick free-running from the core clock, no interrupt.
pub fn start(syst: &mut SYST) {
    syst.disable_interrupt();
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(MASK);
    syst.clear_current();
    syst.enable_counter();
}

/// The current count (counts down).
#[inline(always)]
pub fn now() -> u32 {
    SYST::get_current()
}

/// Ticks from `start` to `end`, both read with [`now`], across a wrap.
#[inline(always)]
pub const fn elapsed(start: u32, end: u32) -> u32 {
    start.wrapping_sub(end) & MASK
}

/// Runs exactly `2 * n` instructions (`subs`, `bne` per turn), `n >= 1`.
#[inline(never)]
fn spin(n: u32) {
    let n = n.max(1);
    // SAFETY: a register-only loop; no memory, no stack.
    unsafe {
        core::arch::asm!(
            "2:",
            "subs {0}, {0}, #1",
            "bne 2b",
            inout(reg) n => _,
            options(nomem, nostack),
        );
    }
}

/// Instructions per SysTick tick, measured: the difference between a long
/// and a one-turn spin is exactly `2 * (LONG - 1)` instructions.
pub fn calibrate() -> f32 {
    const LONG: u32 = 2_000_001;
    let t0 = now();
    spin(1);
    let t1 = now();
    spin(LONG);
    let t2 = now();
    let short = elapsed(t0, t1);
    let long = elapsed(t1, t2);
    let ticks = long.saturating_sub(short).max(1);
    (2 * (LONG - 1)) as f32 / ticks as f32
}

/// Checks the wrap arithmetic on the hardware (model): clears the counter
/// (it reloads `0xFF_FFFF` on the next tick, ARMv7-M ARM B3.3.1), so a
/// measurement started now necessarily crosses the reload; gives
/// `(start, end, elapsed ticks, expected ticks)` for `2 * n` instructions.
pub fn wrap_check(syst: &mut SYST, n: u32, instructions_per_tick: f32) -> (u32, u32, u32, u32) {
    syst.clear_current();
    let t0 = now();
    spin(n);
    let t1 = now();
    let expected = (2.0 * n as f32 / instructions_per_tick) as u32;
    (t0, t1, elapsed(t0, t1), expected)
}
