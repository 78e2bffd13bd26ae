//! traction on a Cortex-M4F under QEMU: the EKF loop and the scale pipeline
//! over embedded sample data, with instruction counts, stack high-water marks
//! and the sizes of the estimator's objects. See `firmware/README.md`.
//!
//! [`budget`] turns the measured instructions per call into the loop's CPU
//! budget. [`sample`], [`frames`] and [`replay`] are target-independent (the host check includes
//! them by `#[path]`); [`systick`], [`stack`] and [`meter`] are the
//! Cortex-M measurement; [`guard`] turns a stack overflow into a reported
//! failure.
#![no_std]

pub mod budget;
pub mod frames;
pub mod guard;
pub mod meter;
pub mod replay;
pub mod sample;
pub mod stack;
pub mod systick;
