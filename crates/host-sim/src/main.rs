//! `host-sim`: the host program of traction. The commands are added in
//! `src/cli/` as they land.
fn main() {
    println!("host-sim {}", env!("CARGO_PKG_VERSION"));
}
