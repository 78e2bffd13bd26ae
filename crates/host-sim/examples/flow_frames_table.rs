//! The README's table: `To` from the flow sensor's raw frames and from its
//! motion counts against the truth, per floor and speed
//! (`host_sim::sim::flow_accuracy`).
//!
//! `cargo run --release -p host-sim --example flow_frames_table`

use host_sim::sim::flow_accuracy::measure;
use host_sim::sim::world::Surface;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!(
        "| floor | speed (m/s) | frames: RMS per 100 ms (%) | counts: RMS per 100 ms (%) | frames: run total (%) | counts: run total (%) | frame pairs refused (%) | block-match distinctness, median |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for surface in [
        Surface::Carpet,
        Surface::Wood,
        Surface::Tile,
        Surface::Concrete,
    ] {
        for speed in [0.1, 0.3, 0.5, 0.8] {
            let a = measure(surface, speed, 3.0, 7)?;
            println!(
                "| {} | {speed:.1} | {} | {:.1} | {} | {:+.1} | {:.0} | {:.3} |",
                surface.name(),
                or_dash(a.frames_rms_pct, false),
                a.counts_rms_pct,
                or_dash(a.frames_total_pct, true),
                a.counts_total_pct,
                a.frames_refused_pct,
                a.frames_distinctness
            );
        }
    }
    Ok(())
}

/// One decimal (signed if `signed`), or a dash when no interval was left.
fn or_dash(x: f64, signed: bool) -> String {
    match (x.is_finite(), signed) {
        (false, _) => "—".to_string(),
        (true, true) => format!("{x:+.1}"),
        (true, false) => format!("{x:.1}"),
    }
}
