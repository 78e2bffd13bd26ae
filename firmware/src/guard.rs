//! A stack guard: an MPU region with no access at the bottom of the stack, so
//! that a stack overflow faults at its first write past the stack instead of
//! overwriting the statics below it, and a fault handler that reports it
//! through semihosting and fails the run instead of hanging.
//!
//! ARMv7-M Architecture Reference Manual (ARM DDI 0403E), B3.5 "Protected
//! Memory System Architecture, PMSAv7": region `RNR`/`RBAR`/`RASR` with
//! `AP = 0b000` (no access) and `XN`, `MPU_CTRL.PRIVDEFENA` keeping the
//! default memory map elsewhere; B1.5.6 and B3.2.15: a write the MPU refuses,
//! also while stacking an exception frame (`MMFSR.MSTKERR`), raises
//! MemManage once `SHCSR.MEMFAULTENA` is set. The handlers
//! (`MemoryManagement` and `HardFault`, in assembly) first move the stack
//! pointer back to the top of RAM, since the faulting one points into the
//! guard, and then report the fault (`error stack_overflow guard ...` or
//! `error hard_fault ...`) and exit with a failure.
//!
//! The stack is `[guard top, _stack_start)`: the guard sits just above the
//! statics (`_stack_end`, rounded up to its size), or with
//! `FIRMWARE_STACK_BYTES=<bytes>` at build time right below that many bytes
//! of stack (rounded up to a multiple of the guard's 32 KB), as a part with
//! a small stack has it (a demonstration:
//! `FIRMWARE_STACK_BYTES=32768 firmware/run-qemu`). The stack painting of
//! [`crate::stack`] paints no lower than [`floor`].

use core::fmt::Write;
use cortex_m::peripheral::{MPU, SCB};
use cortex_m_semihosting::debug::{self, EXIT_FAILURE};
use cortex_m_semihosting::hio;

/// Guard size, bytes: a power of two, at least 32. A frame larger than this
/// whose first write lands below the guard escapes it (no stack probes on
/// this target); the largest frame in the image is about 21 KB.
pub const GUARD: usize = 32 * 1024;

/// Bytes of stack the image may use when set at build time
/// (`FIRMWARE_STACK_BYTES`); the whole RAM above the statics otherwise.
const STACK_BYTES: usize = match option_env!("FIRMWARE_STACK_BYTES") {
    Some(s) => crate::stack::parse(s),
    None => 0,
};

unsafe extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// The top of the stack (`_stack_start` of cortex-m-rt's `link.x`).
pub fn stack_start() -> usize {
    core::ptr::addr_of!(_stack_start) as usize
}

/// The base of the guard region: aligned to [`GUARD`], above the statics,
/// and with `FIRMWARE_STACK_BYTES` right below that many bytes of stack
/// rounded up to a multiple of [`GUARD`].
fn guard_base() -> usize {
    let above_statics = (core::ptr::addr_of!(_stack_end) as usize).next_multiple_of(GUARD);
    if STACK_BYTES == 0 {
        return above_statics;
    }
    let floor = stack_start().saturating_sub(STACK_BYTES.next_multiple_of(GUARD)) & !(GUARD - 1);
    floor.saturating_sub(GUARD).max(above_statics)
}

/// The lowest address the stack may use: the top of the guard (0 before
/// [`enable`]).
pub fn floor() -> usize {
    // SAFETY: written once by `enable` before any reader, single core.
    unsafe { core::ptr::read_volatile(core::ptr::addr_of!(FLOOR)) }
}

static mut FLOOR: usize = 0;

/// Sets up the guard region and enables MemManage faults. Call once, first.
pub fn enable(mpu: &mut MPU, scb: &mut SCB) {
    let base = guard_base();
    // RASR.SIZE: region of 2^(SIZE + 1) bytes.
    let size_field = (GUARD.trailing_zeros() - 1) << 1;
    const ENABLE: u32 = 1;
    const XN: u32 = 1 << 28;
    // SAFETY: MPU and SHCSR register writes with valid values (B3.5.8-B3.5.9,
    // B3.2.13); no access to the guard region exists yet.
    unsafe {
        mpu.rnr.write(0);
        mpu.rbar.write(base as u32);
        mpu.rasr.write(XN | size_field | ENABLE); // AP = 0b000: no access
        // ENABLE | PRIVDEFENA: the default map for everything else.
        mpu.ctrl.write(0b101);
        scb.shcsr.modify(|v| v | (1 << 16)); // MEMFAULTENA
        core::ptr::write_volatile(core::ptr::addr_of_mut!(FLOOR), base + GUARD);
    }
    cortex_m::asm::dsb();
    cortex_m::asm::isb();
}

// The fault handlers: a fresh stack pointer at the top of RAM, then Rust.
core::arch::global_asm!(
    ".section .text.MemoryManagement,\"ax\",%progbits",
    ".global MemoryManagement",
    ".type MemoryManagement,%function",
    ".thumb_func",
    "MemoryManagement:",
    "    mrs r0, msp",
    "    ldr r1, =_stack_start",
    "    mov sp, r1",
    "    movs r1, #0",
    "    b {report}",
    ".ltorg",
    ".section .text.HardFault,\"ax\",%progbits",
    ".global HardFault",
    ".type HardFault,%function",
    ".thumb_func",
    "HardFault:",
    "    mrs r0, msp",
    "    ldr r1, =_stack_start",
    "    mov sp, r1",
    "    movs r1, #1",
    "    b {report}",
    ".ltorg",
    report = sym fault_report,
);

/// Reports a fault with the stack pointer `sp` at the fault (`hard` for a
/// HardFault) and ends the run with a failure.
extern "C" fn fault_report(sp: usize, hard: u32) -> ! {
    // SAFETY: reads of the fault status registers (B3.2.15-B3.2.17).
    let (cfsr, mmfar, hfsr, bfar) = unsafe {
        (
            core::ptr::read_volatile(0xE000_ED28 as *const u32),
            core::ptr::read_volatile(0xE000_ED34 as *const u32),
            core::ptr::read_volatile(0xE000_ED2C as *const u32),
            core::ptr::read_volatile(0xE000_ED38 as *const u32),
        )
    };
    let floor = floor();
    if let Ok(mut out) = hio::hstdout() {
        let top = stack_start();
        let _ = if hard == 0 {
            writeln!(
                out,
                "error stack_overflow guard sp {sp:#010x} address {mmfar:#010x} mmfsr {:#04x} \
                 stack {} bytes ({top:#010x} down to {floor:#010x})",
                cfsr & 0xFF,
                top - floor
            )
        } else {
            // The stacked frame's PC, when the frame is above the guard.
            let pc = if sp >= floor && sp + 32 <= top {
                // SAFETY: an aligned word of the stack (B1.5.6: PC at +24).
                unsafe { core::ptr::read_volatile((sp + 24) as *const u32) }
            } else {
                0
            };
            writeln!(
                out,
                "error hard_fault sp {sp:#010x} pc {pc:#010x} cfsr {cfsr:#010x} hfsr {hfsr:#010x} \
                 bfar {bfar:#010x}"
            )
        };
        let _ = writeln!(out, "firmware: failed");
    }
    debug::exit(EXIT_FAILURE);
    loop {
        core::hint::spin_loop();
    }
}
