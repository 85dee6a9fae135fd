//! SVG plots for the reproduction reports, drawn with plotters' SVG backend.
//!
//! Text is emitted as SVG `<text>` elements and laid out with plotters' built-in size
//! estimate, so no system font library is needed on a fresh machine. Logarithmic axes
//! are drawn by plotting log10 of the values on a linear axis with labels `1e±k`.

use anyhow::{Context, anyhow};
use plotters::prelude::*;
use std::path::Path;

/// How a series is drawn.
#[allow(
    dead_code,
    reason = "the harness offers every style to all reproductions; not each is used at every moment"
)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Polyline through the points.
    Line,
    /// Markers only.
    Points,
    /// Polyline with markers.
    LinePoints,
}

/// One named data series.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// (x, y) points in data units.
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub style: Style,
}

impl Series {
    /// A series from a label, points and a style.
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>, style: Style) -> Self {
        Self {
            label: label.into(),
            points,
            style,
        }
    }
}

/// An axis: its label and whether it is logarithmic.
#[derive(Debug, Clone)]
pub struct Axis {
    /// Axis label.
    pub label: String,
    /// Logarithmic (base 10) axis; non-positive values are dropped.
    pub log: bool,
}

#[allow(
    dead_code,
    reason = "the harness offers linear and log axes to all reproductions; not each is used at every moment"
)]
impl Axis {
    /// A linear axis.
    pub fn linear(label: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            log: false,
        }
    }
    /// A base-10 logarithmic axis.
    pub fn log(label: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            log: true,
        }
    }
    fn forward(&self, v: f64) -> Option<f64> {
        if self.log {
            (v > 0.0 && v.is_finite()).then(|| v.log10())
        } else {
            v.is_finite().then_some(v)
        }
    }
    fn format(&self, v: f64) -> String {
        if self.log {
            let e = v.round();
            if (v - e).abs() < 1e-6 {
                format!("1e{e}")
            } else {
                format!("{:.1e}", 10f64.powf(v))
            }
        } else {
            format!("{v:.3}")
        }
    }
}

fn padded_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !lo.is_finite() || !hi.is_finite() {
        return None;
    }
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        0.5_f64.max(lo.abs() * 0.1)
    };
    Some((lo - pad, hi + pad))
}

/// Writes an x–y plot of `series` to `path` (SVG, 900×600).
///
/// # Errors
/// Fails when no series has a drawable point or the file cannot be written.
pub fn xy_plot(
    path: &Path,
    title: &str,
    x: &Axis,
    y: &Axis,
    series: &[Series],
) -> anyhow::Result<()> {
    let mapped: Vec<Vec<(f64, f64)>> = series
        .iter()
        .map(|s| {
            s.points
                .iter()
                .filter_map(|&(a, b)| Some((x.forward(a)?, y.forward(b)?)))
                .collect()
        })
        .collect();
    let (x0, x1) = padded_range(mapped.iter().flatten().map(|p| p.0))
        .ok_or_else(|| anyhow!("plot {}: no drawable points", path.display()))?;
    let (y0, y1) = padded_range(mapped.iter().flatten().map(|p| p.1))
        .ok_or_else(|| anyhow!("plot {}: no drawable points", path.display()))?;

    let root = SVGBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow!("{e:?}"))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| anyhow!("{e:?}"))?;
    let xf = |v: &f64| x.format(*v);
    let yf = |v: &f64| y.format(*v);
    chart
        .configure_mesh()
        .x_desc(x.label.as_str())
        .y_desc(y.label.as_str())
        .x_label_formatter(&xf)
        .y_label_formatter(&yf)
        .draw()
        .map_err(|e| anyhow!("{e:?}"))?;
    for (i, (s, pts)) in series.iter().zip(&mapped).enumerate() {
        let color = Palette99::pick(i).to_rgba();
        if matches!(s.style, Style::Line | Style::LinePoints) {
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
                .map_err(|e| anyhow!("{e:?}"))?
                .label(s.label.as_str())
                .legend(move |(a, b)| {
                    PathElement::new(vec![(a, b), (a + 20, b)], color.stroke_width(2))
                });
        }
        if matches!(s.style, Style::Points | Style::LinePoints) {
            let anno = chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(|e| anyhow!("{e:?}"))?;
            if s.style == Style::Points {
                anno.label(s.label.as_str())
                    .legend(move |(a, b)| Circle::new((a + 10, b), 3, color.filled()));
            }
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| anyhow!("{e:?}"))?;
    root.present()
        .map_err(|e| anyhow!("{e:?}"))
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
