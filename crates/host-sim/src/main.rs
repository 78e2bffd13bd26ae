//! `host-sim`: the host program of traction.
// The readers and writers below are wired into the commands as those land;
// until then parts of them are exercised only by their tests.
#![allow(dead_code)]

mod asl;
mod chips;
mod error;
mod matches;
mod metrics;
mod pngio;
mod sim;
mod svg;
mod tum;

fn main() {
    println!("host-sim");
}
