//! AS5047P bus scripts: command framing, parity, error flag, diagnostics.

mod common;

use common::{FaultySpi, Frames, parity};
use embedded_hal::spi::ErrorKind;
use wheel_odom::as5047p::{has_even_parity, read_command, with_even_parity};
use wheel_odom::{As5047p, As5047pError, Diagnostics, ErrorFlags};

// Read commands, parity worked out by hand: 0x4000 | address, bit 15 even parity.
const READ_ANGLECOM: u16 = 0xFFFF; // 0x7FFF has 15 ones
const READ_ANGLEUNC: u16 = 0x7FFE; // 14 ones
const READ_MAG: u16 = 0x7FFD; // 14 ones
const READ_DIAAGC: u16 = 0xFFFC; // 0x7FFC has 13 ones
const READ_ERRFL: u16 = 0x4001; // 2 ones

#[test]
fn command_framing_restated() {
    assert_eq!(read_command(0x3FFF), READ_ANGLECOM);
    assert_eq!(read_command(0x3FFE), READ_ANGLEUNC);
    assert_eq!(read_command(0x3FFD), READ_MAG);
    assert_eq!(read_command(0x3FFC), READ_DIAAGC);
    assert_eq!(read_command(0x0001), READ_ERRFL);
    assert_eq!(read_command(0x0000), 0xC000);
    assert_eq!(with_even_parity(0x0000), 0x0000);
    assert!(has_even_parity(0x9234));
    assert!(!has_even_parity(0x1234));
    for x in [0u16, 1, 0x1234, 0x3FFF, 0x7FFF, 0x5555] {
        assert_eq!(with_even_parity(x), parity(x));
        assert!(has_even_parity(with_even_parity(x)));
    }
}

#[test]
fn angle_read_is_command_then_nop() {
    // 0x1234 has five ones: the chip sets PARD.
    let mut spi = Frames::new().read(READ_ANGLECOM, 0x9234).mock();
    let mut enc = As5047p::new(spi.clone());
    assert_eq!(enc.angle(), Ok(0x1234));
    spi.done();
}

#[test]
fn uncompensated_angle_and_magnitude() {
    let mut spi = Frames::new()
        .read(READ_ANGLEUNC, parity(0x3FFF))
        .read(READ_MAG, parity(0x0ABC))
        .mock();
    let mut enc = As5047p::new(spi.clone());
    assert_eq!(enc.angle_uncompensated(), Ok(0x3FFF));
    assert_eq!(enc.magnitude(), Ok(0x0ABC));
    spi.done();
}

#[test]
fn answer_with_bad_parity_is_an_error() {
    let mut spi = Frames::new().read(READ_ANGLECOM, 0x1234).mock();
    let mut enc = As5047p::new(spi.clone());
    assert_eq!(enc.angle(), Err(As5047pError::Parity { frame: 0x1234 }));
    spi.done();
}

#[test]
fn error_flag_reads_and_reports_errfl() {
    // EF set (0x4000, one 1 -> PARD set), then ERRFL says PARERR (bit 2).
    let mut spi = Frames::new()
        .read(READ_ANGLECOM, 0xC000)
        .read(READ_ERRFL, 0x8004)
        .mock();
    let mut enc = As5047p::new(spi.clone());
    assert_eq!(
        enc.angle(),
        Err(As5047pError::ErrorFlag(ErrorFlags {
            parity: true,
            invalid_command: false,
            framing: false
        }))
    );
    spi.done();
}

#[test]
fn errfl_bits() {
    let mut spi = Frames::new().read(READ_ERRFL, parity(0b011)).mock();
    let mut enc = As5047p::new(spi.clone());
    assert_eq!(
        enc.error_flags(),
        Ok(ErrorFlags {
            parity: false,
            invalid_command: true,
            framing: true
        })
    );
    spi.done();
}

#[test]
fn diaagc_warnings() {
    // LF set, AGC 0x80: healthy. Then MAGL | COF | AGC 0xFF: weak field, overflow.
    let mut spi = Frames::new()
        .read(READ_DIAAGC, 0x0180)
        .read(READ_DIAAGC, 0x0AFF)
        .read(READ_DIAAGC, parity(0x0500))
        .mock();
    let mut enc = As5047p::new(spi.clone());
    let d = enc.diagnostics().unwrap();
    assert_eq!(
        d,
        Diagnostics {
            field_too_weak: false,
            field_too_strong: false,
            cordic_overflow: false,
            offset_compensated: true,
            agc: 0x80
        }
    );
    assert!(d.is_healthy());
    let d = enc.diagnostics().unwrap();
    assert!(d.field_too_weak && d.cordic_overflow && !d.field_too_strong);
    assert!(!d.offset_compensated);
    assert_eq!(d.agc, 0xFF);
    assert!(!d.is_healthy());
    let d = enc.diagnostics().unwrap();
    assert!(d.field_too_strong && d.offset_compensated && !d.field_too_weak);
    assert_eq!(d.agc, 0);
    assert!(!d.is_healthy());
    spi.done();
}

#[test]
fn bus_error_on_the_nop_frame() {
    let mut mock = Frames::new().f(READ_ANGLECOM, 0).mock();
    let mut enc = As5047p::new(FaultySpi {
        inner: mock.clone(),
        fail_at: 1,
        seen: 0,
    });
    assert_eq!(enc.angle(), Err(As5047pError::Spi(ErrorKind::Other)));
    mock.done();
}

#[test]
fn error_display() {
    let e: As5047pError<ErrorKind> = As5047pError::Parity { frame: 0x1234 };
    assert!(format!("{e}").contains("0x1234"));
}

#[test]
fn register_map_restated() {
    use wheel_odom::registers as r;
    assert_eq!(r::NOP, 0x0000);
    assert_eq!(r::ERRFL, 0x0001);
    assert_eq!(r::PROG, 0x0003);
    assert_eq!(r::DIAAGC, 0x3FFC);
    assert_eq!(r::MAG, 0x3FFD);
    assert_eq!(r::ANGLEUNC, 0x3FFE);
    assert_eq!(r::ANGLECOM, 0x3FFF);
    assert_eq!(
        (r::ZPOSM, r::ZPOSL, r::SETTINGS1, r::SETTINGS2),
        (0x16, 0x17, 0x18, 0x19)
    );
    assert_eq!(
        (r::FRAME_PARITY, r::FRAME_READ, r::FRAME_DATA_MASK),
        (0x8000, 0x4000, 0x3FFF)
    );
    assert_eq!(
        (r::ERRFL_FRERR, r::ERRFL_INVCOMM, r::ERRFL_PARERR),
        (1, 2, 4)
    );
    assert_eq!(
        (r::DIAAGC_LF, r::DIAAGC_COF, r::DIAAGC_MAGH, r::DIAAGC_MAGL),
        (0x100, 0x200, 0x400, 0x800)
    );
    assert_eq!(r::COUNTS_PER_REVOLUTION, 16_384);
}

#[test]
fn angle_with_diagnostics_is_pipelined_in_three_frames() {
    // READ DIAAGC (answer ignored), READ ANGLECOM (answer DIAAGC: LF, AGC 0x70),
    // NOP (answer ANGLECOM 0x2000).
    let mut spi = Frames::new()
        .f(READ_DIAAGC, 0x0000)
        .f(READ_ANGLECOM, parity(0x0170))
        .f(0x0000, parity(0x2000))
        .mock();
    let mut enc = As5047p::new(spi.clone());
    let (angle, d) = enc.angle_with_diagnostics().unwrap();
    assert_eq!(angle, 0x2000);
    assert!(d.is_healthy());
    assert_eq!(d.agc, 0x70);
    spi.done();
}

#[test]
fn cordic_overflow_invalidates_the_angle() {
    let mut spi = Frames::new()
        .f(READ_DIAAGC, 0x0000)
        .f(READ_ANGLECOM, parity(0x0B00))
        .f(0x0000, parity(0x0123))
        .mock();
    let mut enc = As5047p::new(spi.clone());
    match enc.angle_with_diagnostics() {
        Err(As5047pError::AngleInvalid(d)) => {
            assert!(d.cordic_overflow && d.field_too_weak && d.offset_compensated)
        }
        other => panic!("expected AngleInvalid, got {other:?}"),
    }
    spi.done();
}

#[test]
fn pipelined_read_checks_the_error_flag() {
    // The ANGLECOM answer carries EF: ERRFL is read (INVCOMM).
    let mut spi = Frames::new()
        .f(READ_DIAAGC, 0x0000)
        .f(READ_ANGLECOM, parity(0x0100))
        .f(0x0000, parity(0x4000))
        .read(READ_ERRFL, parity(0x0002))
        .mock();
    let mut enc = As5047p::new(spi.clone());
    assert_eq!(
        enc.angle_with_diagnostics(),
        Err(As5047pError::ErrorFlag(ErrorFlags {
            parity: false,
            invalid_command: true,
            framing: false
        }))
    );
    spi.done();
}
