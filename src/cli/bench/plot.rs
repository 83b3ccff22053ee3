//! Log–log scatter plots of error against run time with each series' Pareto front, one
//! panel per scene and a legend below, drawn by `plotters` into an RGB raster and written
//! as PNG. The font is DejaVu Sans, embedded, so no system font library is needed.

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::io::BufWriter;
use std::path::Path;
use std::sync::Once;

/// One solver configuration's points in a panel.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub color: [u8; 3],
    /// (x, y), both > 0 (non-positive or non-finite points are not drawn).
    pub points: Vec<(f64, f64)>,
}

/// One scene's plot.
#[derive(Clone, Debug)]
pub struct Panel {
    pub title: String,
    pub series: Vec<Series>,
}

/// Colours that stay distinct on white, in series order.
pub const PALETTE: [[u8; 3]; 6] = [
    [31, 119, 180],
    [214, 39, 40],
    [44, 160, 44],
    [148, 103, 189],
    [255, 127, 14],
    [23, 190, 207],
];

/// The points no other point beats in both coordinates (smaller is better), sorted by x.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut sorted: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for p in sorted {
        if front.last().is_none_or(|last| p.1 < last.1) {
            front.push(p);
        }
    }
    front
}

const PANEL_W: usize = 420;
const PANEL_H: usize = 360;
const LEGEND_H: usize = 18;
const FONT: &str = "sans-serif";

/// An RGB raster.
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<u8>,
}

impl Image {
    pub fn write_png(&self, path: &Path) -> std::io::Result<()> {
        let file = std::fs::File::create(path)?;
        let mut encoder =
            png::Encoder::new(BufWriter::new(file), self.width as u32, self.height as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
        writer
            .write_image_data(&self.rgb)
            .map_err(std::io::Error::other)
    }
}

/// Registers the embedded font under [`FONT`] once per process.
fn register_font() {
    static FONT_ONCE: Once = Once::new();
    FONT_ONCE.call_once(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
            .unwrap_or_else(|_| panic!("the embedded DejaVu Sans is a valid font"));
    });
}

/// Decades [10^lo, 10^hi] covering the finite positive values, at least one decade wide.
fn decade_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v.log10());
        hi = hi.max(v.log10());
    }
    if !lo.is_finite() {
        return 1.0..10.0;
    }
    let (lo, hi) = (lo.floor() as i32, hi.ceil() as i32);
    10f64.powi(lo)..10f64.powi(hi.max(lo + 1))
}

/// A tick value as short as it reads exactly (`0.01`, `300`, `1e5`).
fn tick_label(v: &f64) -> String {
    let plain = format!("{v}");
    if plain.len() <= 6 {
        plain
    } else {
        format!("{v:.0e}")
    }
}

fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// Panels side by side, each with log axes, every point, and each series' Pareto front; a
/// legend of the series below them.
pub fn render(panels: &[Panel], x_label: &str, y_label: &str) -> Result<Image> {
    register_font();
    let mut labels: Vec<(&str, [u8; 3])> = Vec::new();
    for s in panels.iter().flat_map(|p| &p.series) {
        if !labels.iter().any(|(l, _)| *l == s.label) {
            labels.push((&s.label, s.color));
        }
    }
    let width = PANEL_W * panels.len().max(1);
    let height = PANEL_H + LEGEND_H * labels.len() + 8;
    let mut rgb_buffer = vec![0u8; width * height * 3];
    draw(
        &mut rgb_buffer,
        (width, height),
        panels,
        &labels,
        (x_label, y_label),
    )
    .map_err(|e| anyhow!("drawing the plot: {e}"))?;
    Ok(Image {
        width,
        height,
        rgb: rgb_buffer,
    })
}

fn draw(
    buffer: &mut [u8],
    (width, height): (usize, usize),
    panels: &[Panel],
    labels: &[(&str, [u8; 3])],
    (x_label, y_label): (&str, &str),
) -> Result<(), Box<dyn std::error::Error>> {
    let root =
        BitMapBackend::with_buffer(buffer, (width as u32, height as u32)).into_drawing_area();
    root.fill(&WHITE)?;
    let (plots, legend) = root.split_vertically(PANEL_H as u32);
    for (area, panel) in plots
        .split_evenly((1, panels.len().max(1)))
        .iter()
        .zip(panels)
    {
        let points = || panel.series.iter().flat_map(|s| s.points.iter().copied());
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, (FONT, 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(
                decade_range(points().map(|p| p.0)).log_scale(),
                decade_range(points().map(|p| p.1)).log_scale(),
            )?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .x_label_formatter(&tick_label)
            .y_label_formatter(&tick_label)
            .label_style((FONT, 12))
            .axis_desc_style((FONT, 13))
            .draw()?;
        let visible = |p: &(f64, f64)| p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.1.is_finite();
        for s in &panel.series {
            let color = rgb(s.color);
            let front: Vec<(f64, f64)> = pareto_front(&s.points)
                .into_iter()
                .filter(visible)
                .collect();
            chart.draw_series(LineSeries::new(front, color.stroke_width(2)))?;
            chart.draw_series(
                s.points
                    .iter()
                    .copied()
                    .filter(visible)
                    .map(|p| Circle::new(p, 3, color.filled())),
            )?;
        }
    }
    for (i, (label, color)) in labels.iter().enumerate() {
        let y = 4 + (i * LEGEND_H) as i32 + LEGEND_H as i32 / 2;
        let color = rgb(*color);
        legend.draw(&PathElement::new(
            vec![(64, y), (88, y)],
            color.stroke_width(2),
        ))?;
        legend.draw(&Circle::new((76, y), 3, color.filled()))?;
        legend.draw(&Text::new(
            label.to_string(),
            (96, y - 7),
            (FONT, 13).into_font().color(&BLACK),
        ))?;
    }
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let pts = [(1.0, 5.0), (2.0, 3.0), (3.0, 4.0), (4.0, 1.0), (0.5, 9.0)];
        assert_eq!(
            pareto_front(&pts),
            vec![(0.5, 9.0), (1.0, 5.0), (2.0, 3.0), (4.0, 1.0)]
        );
    }

    #[test]
    fn render_draws_every_series_colour() {
        let panel = Panel {
            title: "t".into(),
            series: vec![
                Series {
                    label: "a".into(),
                    color: PALETTE[0],
                    points: vec![(0.1, 0.2), (1.0, 0.05)],
                },
                Series {
                    label: "b".into(),
                    color: PALETTE[1],
                    points: vec![(0.3, 0.1), (f64::NAN, 1.0)],
                },
            ],
        };
        let image = render(&[panel.clone(), panel], "time (s)", "error").unwrap();
        assert_eq!(image.width, 2 * PANEL_W);
        for c in [PALETTE[0], PALETTE[1]] {
            let n = image.rgb.chunks(3).filter(|p| *p == c).count();
            assert!(n > 50, "colour {c:?} drawn on {n} pixels");
        }
    }
}
