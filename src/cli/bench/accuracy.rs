//! `bench accuracy`: the error of the scenes with analytic answers at two resolutions each,
//! and the stretch past a cell per particle (2× and 3×) with both formulations.

use dvrk_tissue_sim::mpm::Method;
use dvrk_tissue_sim::validation::analytic::{hertz, large_stretch, vibrating_bar};

/// Markdown table of all three scenes at two resolutions, then the large stretches.
pub fn table() -> String {
    let mut out = String::from("| scene | resolution | particles / samples | simulated | analytic | relative error |\n|---|---|---|---|---|---|\n");
    for cells in [4.0, 6.0] {
        let h = hertz(cells);
        let last = h.samples.last().cloned();
        out += &format!(
            "| Hertz, d/R 0.05–0.3 | R = {cells} dx | {} particles, {} samples | F(0.3R) = {:.4} N | {:.4} N | RMS {:.1}% |\n",
            h.particles,
            h.samples.len(),
            last.as_ref().map_or(f64::NAN, |s| s.force),
            last.as_ref().map_or(f64::NAN, |s| s.analytic),
            100.0 * h.rms_relative_error()
        );
    }
    for cells in [4, 8] {
        let b = vibrating_bar(cells);
        out += &format!(
            "| vibrating bar, L = 10 h | h = {cells} dx | — | T = {:.5} s | {:.5} s | {:+.1}% |\n",
            b.period,
            b.analytic_period,
            100.0 * b.relative_error()
        );
    }
    let stretches = [(1.3, Method::MlsMpm, 4), (1.3, Method::MlsMpm, 8)]
        .into_iter()
        .chain([2.0, 3.0].into_iter().flat_map(|stretch| {
            [
                (stretch, Method::MlsMpm, 4),
                (stretch, Method::TlMpm, 4),
                (stretch, Method::TlMpm, 8),
            ]
        }));
    for (stretch, method, cells) in stretches {
        let s = large_stretch(method, cells, stretch);
        out += &format!(
            "| Neo-Hookean stretch {stretch}× ({}) | h = {cells} dx | — | F = {:.5} N | {:.5} N | {:+.1}% |\n",
            method.key(),
            s.force,
            s.analytic,
            100.0 * s.relative_error()
        );
    }
    out
}
