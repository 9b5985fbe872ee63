//! The report's figures as SVG text (plotters' SVG backend, as the studies' figures):
//! time series through `host_tests::plot::draw`, the project's one line-chart style,
//! with limits drawn as flat lines; the SYNC jitter as a histogram.

use host_tests::plot::{draw, Chart, Legend, Scale, Series};
use plotters::prelude::*;

/// A figure: its file name, title and SVG.
#[derive(Debug, Clone)]
pub struct Figure {
    /// File name (`.svg`).
    pub file: String,
    /// Caption.
    pub title: String,
    /// The SVG document.
    pub svg: String,
}

/// Width of every figure, px.
const WIDTH: u32 = 900;
/// Height of one panel, px.
const PANEL: u32 = 300;

/// One panel of time series: `curves` (name, points), and `limits` (name, value) drawn
/// as flat lines over the curves' time span.
pub struct Panel<'a> {
    /// Title.
    pub title: &'a str,
    /// y label.
    pub y_label: &'a str,
    /// Curves.
    pub curves: Vec<(String, Vec<(f64, f64)>)>,
    /// Flat lines.
    pub limits: Vec<(String, f64)>,
}

/// Panels stacked in one figure, time (s from the log's start) along x.
pub fn time_series(file: &str, title: &str, panels: &[Panel]) -> Result<Figure, String> {
    let mut svg = String::new();
    {
        let n = panels.len().max(1) as u32;
        let root = SVGBackend::with_string(&mut svg, (WIDTH, PANEL * n)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        for (area, panel) in root.split_evenly((n as usize, 1)).iter().zip(panels) {
            let (t0, t1) = panel
                .curves
                .iter()
                .flat_map(|(_, p)| p.iter().map(|q| q.0))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                    (a.min(t), b.max(t))
                });
            let mut series: Vec<Series> = panel
                .curves
                .iter()
                .map(|(name, points)| Series {
                    name: name.clone(),
                    points: points.clone(),
                })
                .collect();
            if t0.is_finite() {
                series.extend(panel.limits.iter().map(|(name, v)| Series {
                    name: name.clone(),
                    points: vec![(t0, *v), (t1, *v)],
                }));
            }
            let chart = Chart {
                title: panel.title,
                x_label: "t, s",
                y_label: panel.y_label,
                x_scale: Scale::Linear,
                y_scale: Scale::Linear,
                legend: Legend::BelowData,
            };
            draw(area, &chart, &series)?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(Figure {
        file: file.to_string(),
        title: title.to_string(),
        svg,
    })
}

/// A histogram: `bins` as (lower edge, upper edge, count).
pub fn histogram(
    file: &str,
    title: &str,
    x_label: &str,
    bins: &[(f64, f64, u64)],
) -> Result<Figure, String> {
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, PANEL)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let x0 = bins.first().map_or(0.0, |b| b.0);
        let x1 = bins.last().map_or(1.0, |b| b.1);
        let top = bins.iter().map(|b| b.2).max().unwrap_or(1).max(1) as f64;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, (0.5f64..top * 2.0).log_scale())
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc("SYNC intervals (log)")
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()
            .map_err(|x| e(&x))?;
        let blue = RGBColor(31, 119, 180);
        chart
            .draw_series(
                bins.iter()
                    .filter(|b| b.2 > 0)
                    .map(|&(lo, hi, n)| Rectangle::new([(lo, 0.5), (hi, n as f64)], blue.filled())),
            )
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    Ok(Figure {
        file: file.to_string(),
        title: title.to_string(),
        svg,
    })
}
