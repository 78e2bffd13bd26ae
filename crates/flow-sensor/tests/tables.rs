//! The configuration tables against their sources, restated here.

mod common;

use common::{PAA5100_WRITES, PMW3901_WRITES};
use flow_sensor::config::{self, ConfigStep};
use flow_sensor::{Variant, registers};

fn writes(table: &[ConfigStep]) -> Vec<(u8, u8)> {
    table
        .iter()
        .filter_map(|s| match *s {
            ConfigStep::Write { register, value } => Some((register, value)),
            ConfigStep::DelayMs(_) => None,
        })
        .collect()
}

fn total_wait_ms(table: &[ConfigStep]) -> u32 {
    table
        .iter()
        .map(|s| match *s {
            ConfigStep::DelayMs(ms) => ms,
            _ => 0,
        })
        .sum()
}

fn final_bank(table: &[ConfigStep]) -> Option<u8> {
    table.iter().rev().find_map(|s| match *s {
        ConfigStep::Write {
            register: 0x7F,
            value,
        } => Some(value),
        _ => None,
    })
}

#[test]
fn tables_match_their_sources() {
    assert_eq!(writes(Variant::Pmw3901.configuration()), PMW3901_WRITES);
    assert_eq!(writes(Variant::Paa5100je.configuration()), PAA5100_WRITES);
    assert_eq!(total_wait_ms(Variant::Pmw3901.configuration()), 100);
    assert_eq!(total_wait_ms(Variant::Paa5100je.configuration()), 20);
}

#[test]
fn every_table_ends_in_bank_zero() {
    for t in [
        Variant::Pmw3901.configuration(),
        Variant::Paa5100je.configuration(),
        config::FRAME_CAPTURE_SETUP,
    ] {
        assert_eq!(final_bank(t), Some(0x00));
    }
    // The calibration steps end in bank 0x0E, where their registers are read.
    assert_eq!(final_bank(config::CALIBRATION_STEP_1), Some(0x0E));
    assert_eq!(final_bank(config::CALIBRATION_STEP_2), Some(0x0E));
    assert_eq!(final_bank(config::CALIBRATION_TRIM_SETUP), Some(0x0E));
}

#[test]
fn readback_checks_are_what_the_table_last_wrote_in_bank_zero() {
    for v in [Variant::Pmw3901, Variant::Paa5100je] {
        let mut bank = 0xFF;
        let mut last = std::collections::HashMap::new();
        for (r, val) in writes(v.configuration()) {
            if r == 0x7F {
                bank = val;
            } else if bank == 0 {
                last.insert(r, val);
            }
        }
        for &(r, val) in v.readback_checks() {
            assert_eq!(last.get(&r), Some(&val), "{v:?} register 0x{r:02X}");
        }
    }
}

#[test]
fn trim_adjustment() {
    assert_eq!(config::adjusted_c1(0), 14);
    assert_eq!(config::adjusted_c1(28), 42);
    assert_eq!(config::adjusted_c1(29), 40);
    assert_eq!(config::adjusted_c1(60), 0x3F);
    assert_eq!(config::adjusted_c1(255), 0x3F);
    assert_eq!(config::adjusted_c2(255), 114);
    assert_eq!(config::adjusted_c2(10), 4);
}

#[test]
fn register_map_restated() {
    assert_eq!(registers::PRODUCT_ID, 0x00);
    assert_eq!(registers::MOTION, 0x02);
    assert_eq!(registers::MOTION_BURST, 0x16);
    assert_eq!(registers::POWER_UP_RESET, 0x3A);
    assert_eq!(registers::RAW_DATA_GRAB, 0x58);
    assert_eq!(registers::RAW_DATA_GRAB_STATUS, 0x59);
    assert_eq!(registers::ORIENTATION, 0x5B);
    assert_eq!(registers::INVERSE_PRODUCT_ID, 0x5F);
    assert_eq!(registers::PRODUCT_ID_VALUE, 0x49);
    assert_eq!(registers::INVERSE_PRODUCT_ID_VALUE, !0x49u8);
    assert_eq!(registers::ORIENTATION_SWAP_XY, 0x80);
    assert_eq!(registers::ORIENTATION_INVERT_Y, 0x40);
    assert_eq!(registers::ORIENTATION_INVERT_X, 0x20);
}
