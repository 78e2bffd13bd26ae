//! `host-sim`: the host program of traction.
fn main() {
    println!("host-sim");
}
