//! Log–log scatter plots of error against run time with each series' Pareto front, drawn
//! into an RGB image and written as PNG (no display, no plotting stack).

use std::io::BufWriter;
use std::path::Path;

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
const LEFT: usize = 64;
const RIGHT: usize = 16;
const TOP: usize = 28;
const BOTTOM: usize = 44;
const LEGEND_H: usize = 16;

/// An RGB raster.
pub struct Canvas {
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<u8>,
}

impl Canvas {
    fn new(width: usize, height: usize) -> Self {
        Canvas {
            width,
            height,
            rgb: vec![255; width * height * 3],
        }
    }

    fn set(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height {
            let i = (y as usize * self.width + x as usize) * 3;
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    fn line(&mut self, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: [u8; 3], width: i64) {
        let steps = (x1 - x0).abs().max((y1 - y0).abs()).ceil().max(1.0) as i64;
        for s in 0..=steps {
            let t = s as f64 / steps as f64;
            let (x, y) = (x0 + (x1 - x0) * t, y0 + (y1 - y0) * t);
            for dx in 0..width {
                for dy in 0..width {
                    self.set(x.round() as i64 + dx, y.round() as i64 + dy, c);
                }
            }
        }
    }

    fn marker(&mut self, (x, y): (f64, f64), c: [u8; 3]) {
        let (x, y) = (x.round() as i64, y.round() as i64);
        for dx in -3..=3i64 {
            for dy in -3..=3i64 {
                if dx * dx + dy * dy <= 9 {
                    self.set(x + dx, y + dy, c);
                }
            }
        }
    }

    /// 8×8 bitmap text with its top-left corner at (x, y).
    fn text(&mut self, x: i64, y: i64, s: &str, c: [u8; 3]) {
        for (k, ch) in s.chars().enumerate() {
            let glyph = font8x8::legacy::BASIC_LEGACY
                .get(ch as usize)
                .copied()
                .unwrap_or([0; 8]);
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) != 0 {
                        self.set(x + 8 * k as i64 + col, y + row as i64, c);
                    }
                }
            }
        }
    }

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

/// Decades [10^lo, 10^hi] covering the finite positive values, at least one decade wide.
fn decade_range(values: impl Iterator<Item = f64>) -> (i32, i32) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v.log10());
        hi = hi.max(v.log10());
    }
    if !lo.is_finite() {
        return (0, 1);
    }
    let (lo, hi) = (lo.floor() as i32, hi.ceil() as i32);
    (lo, hi.max(lo + 1))
}

fn decade_label(e: i32) -> String {
    match e {
        -3..=-1 => format!("{}", 10f64.powi(e)),
        0..=4 => format!("{}", 10i64.pow(e as u32)),
        _ => format!("1e{e}"),
    }
}

/// Panels side by side, each with log axes, every point, and each series' Pareto front.
pub fn render(panels: &[Panel], x_label: &str, y_label: &str) -> Canvas {
    let labels: Vec<(String, [u8; 3])> = {
        let mut seen: Vec<(String, [u8; 3])> = Vec::new();
        for s in panels.iter().flat_map(|p| &p.series) {
            if !seen.iter().any(|(l, _)| *l == s.label) {
                seen.push((s.label.clone(), s.color));
            }
        }
        seen
    };
    let width = PANEL_W * panels.len().max(1);
    let height = PANEL_H + LEGEND_H * labels.len() + 8;
    let mut canvas = Canvas::new(width, height);
    let grey = [200, 200, 200];
    let black = [0, 0, 0];
    for (k, panel) in panels.iter().enumerate() {
        let x0 = (k * PANEL_W + LEFT) as f64;
        let x1 = ((k + 1) * PANEL_W - RIGHT) as f64;
        let y0 = TOP as f64;
        let y1 = (PANEL_H - BOTTOM) as f64;
        let points = || panel.series.iter().flat_map(|s| s.points.iter().copied());
        let (xl, xh) = decade_range(points().map(|p| p.0));
        let (yl, yh) = decade_range(points().map(|p| p.1));
        let to_px = |(x, y): (f64, f64)| {
            (
                x0 + (x.log10() - xl as f64) / (xh - xl) as f64 * (x1 - x0),
                y1 - (y.log10() - yl as f64) / (yh - yl) as f64 * (y1 - y0),
            )
        };
        for e in xl..=xh {
            let (px, _) = to_px((10f64.powi(e), 1.0));
            canvas.line((px, y0), (px, y1), grey, 1);
            let label = decade_label(e);
            canvas.text(
                px as i64 - 4 * label.len() as i64,
                y1 as i64 + 6,
                &label,
                black,
            );
        }
        for e in yl..=yh {
            let (_, py) = to_px((1.0, 10f64.powi(e)));
            canvas.line((x0, py), (x1, py), grey, 1);
            let label = decade_label(e);
            canvas.text(
                x0 as i64 - 8 * label.len() as i64 - 4,
                py as i64 - 4,
                &label,
                black,
            );
        }
        canvas.line((x0, y1), (x1, y1), black, 1);
        canvas.line((x0, y0), (x0, y1), black, 1);
        canvas.text(x0 as i64, 8, &panel.title, black);
        canvas.text(
            ((x0 + x1) / 2.0) as i64 - 4 * x_label.len() as i64,
            y1 as i64 + 22,
            x_label,
            black,
        );
        canvas.text(x0 as i64 + 4, y0 as i64 + 4, y_label, black);
        for s in &panel.series {
            let visible = |p: &&(f64, f64)| p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite();
            let front = pareto_front(&s.points);
            for pair in front.iter().filter(visible).collect::<Vec<_>>().windows(2) {
                canvas.line(to_px(*pair[0]), to_px(*pair[1]), s.color, 2);
            }
            for p in s.points.iter().filter(visible) {
                if p.1.is_finite() {
                    canvas.marker(to_px(*p), s.color);
                }
            }
        }
    }
    for (i, (label, color)) in labels.iter().enumerate() {
        let y = (PANEL_H + 4 + i * LEGEND_H) as f64;
        canvas.line(
            (LEFT as f64, y + 4.0),
            (LEFT as f64 + 24.0, y + 4.0),
            *color,
            2,
        );
        canvas.marker((LEFT as f64 + 12.0, y + 4.0), *color);
        canvas.text(LEFT as i64 + 32, y as i64, label, black);
    }
    canvas
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
        let canvas = render(&[panel.clone(), panel], "time (s)", "error");
        assert_eq!(canvas.width, 2 * PANEL_W);
        for c in [PALETTE[0], PALETTE[1]] {
            let n = canvas.rgb.chunks(3).filter(|p| *p == c).count();
            assert!(n > 50, "colour {c:?} drawn on {n} pixels");
        }
    }
}
