//! SVG figures with plotters (its SVG backend needs no system fonts).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::study::Outcome;

/// One curve: a name and its points (points with a non-finite or, on a log axis,
/// non-positive coordinate are left out).
pub struct Series {
    /// Legend text.
    pub name: String,
    /// `(x, y)` points.
    pub points: Vec<(f64, f64)>,
}

/// Axis scaling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// Linear.
    Linear,
    /// Logarithmic (base 10).
    Log,
}

/// A chart's labels and axes.
pub struct Chart<'a> {
    /// Title.
    pub title: &'a str,
    /// x-axis label.
    pub x_label: &'a str,
    /// y-axis label.
    pub y_label: &'a str,
    /// x scaling.
    pub x_scale: Scale,
    /// y scaling.
    pub y_scale: Scale,
    /// Where the legend goes.
    pub legend: Legend,
}

/// Where a chart's legend goes. It always sits in the lower right corner; the
/// question is whether the data may run under it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Legend {
    /// Over the data: right for charts whose lower right corner is empty.
    OverData,
    /// Below the data: the y range is extended downwards to make room for it, for
    /// time series that fill the whole width (Fig. 8), whose end it would hide.
    BelowData,
}

/// The part of the plot's height the legend takes, with `entries` lines in it: fitted by
/// eye on the stacked panels of [`figure`] (320 px high) with plotters' default label
/// font — 0.07 of the height per line, 0.06 for the box's margins. Other panel sizes
/// would need other numbers; only Fig. 8 uses it.
fn legend_share(entries: usize) -> f64 {
    0.06 + 0.07 * entries as f64
}

/// `(lo, hi)` extended downwards so that the lower `share` of the height is free.
fn room_below((lo, hi): (f64, f64), scale: Scale, share: f64) -> (f64, f64) {
    let k = share / (1.0 - share);
    match scale {
        Scale::Log => (lo / (hi / lo).powf(k), hi),
        Scale::Linear => (lo - (hi - lo) * k, hi),
    }
}

const COLORS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(23, 190, 207),
    RGBColor(127, 127, 127),
];

fn keep(scale: Scale, v: f64) -> bool {
    v.is_finite() && (scale == Scale::Linear || v > 0.0)
}

fn range(values: impl Iterator<Item = f64>, scale: Scale) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !lo.is_finite() {
        return if scale == Scale::Log {
            (1e-12, 1.0)
        } else {
            (0.0, 1.0)
        };
    }
    match scale {
        Scale::Log => (lo / 2.0, hi * 2.0),
        Scale::Linear => {
            let pad = ((hi - lo) * 0.05).max(1e-12);
            (lo - pad, hi + pad)
        }
    }
}

/// Draws one chart into an area.
pub fn draw(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    chart: &Chart<'_>,
    series: &[Series],
) -> Result<(), String> {
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let points = |s: &Series| {
        s.points
            .iter()
            .copied()
            .filter(|(x, y)| keep(chart.x_scale, *x) && keep(chart.y_scale, *y))
            .collect::<Vec<_>>()
    };
    let all: Vec<(f64, f64)> = series.iter().flat_map(points).collect();
    let (x0, x1) = range(all.iter().map(|p| p.0), chart.x_scale);
    let mut y_range = range(all.iter().map(|p| p.1), chart.y_scale);
    if chart.legend == Legend::BelowData {
        // Only series with points to draw get a legend entry.
        let entries = series.iter().filter(|s| !points(s).is_empty()).count();
        y_range = room_below(y_range, chart.y_scale, legend_share(entries));
    }
    let (y0, y1) = y_range;
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(chart.title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70);
    macro_rules! plot {
        ($ctx:expr) => {{
            let mut ctx = $ctx.map_err(|x| e(&x))?;
            let tick = |scale: Scale, v: f64| match scale {
                Scale::Log => format!("{v:.0e}"),
                Scale::Linear if v == 0.0 => "0".to_string(),
                Scale::Linear if v.abs() < 1e-2 || v.abs() >= 1e4 => format!("{v:.1e}"),
                Scale::Linear => format!("{v:.3}")
                    .trim_end_matches('0')
                    .trim_end_matches('.')
                    .to_string(),
            };
            ctx.configure_mesh()
                .x_desc(chart.x_label)
                .y_desc(chart.y_label)
                .x_label_formatter(&|v| tick(chart.x_scale, *v))
                .y_label_formatter(&|v| tick(chart.y_scale, *v))
                .draw()
                .map_err(|x| e(&x))?;
            for (i, s) in series.iter().enumerate() {
                let color = COLORS[i % COLORS.len()];
                let pts = points(s);
                if pts.is_empty() {
                    continue;
                }
                ctx.draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                    .map_err(|x| e(&x))?
                    .label(s.name.as_str())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                    });
                if pts.len() <= 40 {
                    ctx.draw_series(pts.iter().map(|p| Circle::new(*p, 3, color.filled())))
                        .map_err(|x| e(&x))?;
                }
            }
            ctx.configure_series_labels()
                .position(SeriesLabelPosition::LowerRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()
                .map_err(|x| e(&x))?;
        }};
    }
    match (chart.x_scale, chart.y_scale) {
        (Scale::Log, Scale::Log) => {
            plot!(builder.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale()))
        }
        (Scale::Log, Scale::Linear) => {
            plot!(builder.build_cartesian_2d((x0..x1).log_scale(), y0..y1))
        }
        (Scale::Linear, Scale::Log) => {
            plot!(builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale()))
        }
        (Scale::Linear, Scale::Linear) => plot!(builder.build_cartesian_2d(x0..x1, y0..y1)),
    }
    Ok(())
}

/// One or more charts side by side (or stacked) in one SVG file.
pub fn figure(
    path: &Path,
    panels: &[(Chart<'_>, Vec<Series>)],
    stacked: bool,
) -> Result<(), String> {
    let n = panels.len().max(1) as u32;
    let size = if stacked {
        (900, 320 * n)
    } else {
        (560 * n, 440)
    };
    let root = SVGBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let areas = if stacked {
        root.split_evenly((n as usize, 1))
    } else {
        root.split_evenly((1, n as usize))
    };
    for (area, (chart, series)) in areas.iter().zip(panels) {
        draw(area, chart, series)?;
    }
    root.present().map_err(|e| e.to_string())
}

/// A scatter chart: each series' points as small circles in its colour (clouds), and
/// `front` as a black line through its points — the trade's figures, whose clouds have
/// hundreds of points and no order.
pub fn scatter(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    chart: &Chart<'_>,
    clouds: &[Series],
    front: &Series,
) -> Result<(), String> {
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let points = |s: &Series| {
        s.points
            .iter()
            .copied()
            .filter(|(x, y)| keep(chart.x_scale, *x) && keep(chart.y_scale, *y))
            .collect::<Vec<_>>()
    };
    let all: Vec<(f64, f64)> = clouds.iter().chain([front]).flat_map(points).collect();
    let (x0, x1) = range(all.iter().map(|p| p.0), chart.x_scale);
    let (y0, y1) = range(all.iter().map(|p| p.1), chart.y_scale);
    if chart.x_scale != Scale::Log || chart.y_scale != Scale::Log {
        return Err("a scatter chart is log–log".into());
    }
    let mut ctx = ChartBuilder::on(area)
        .caption(chart.title, ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|x| e(&x))?;
    ctx.configure_mesh()
        .x_desc(chart.x_label)
        .y_desc(chart.y_label)
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|x| e(&x))?;
    for (i, s) in clouds.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        ctx.draw_series(
            points(s)
                .into_iter()
                .map(|p| Circle::new(p, 2, color.filled())),
        )
        .map_err(|x| e(&x))?
        .label(s.name.as_str())
        .legend(move |(x, y)| Circle::new((x + 9, y), 3, color.filled()));
    }
    let line = points(front);
    ctx.draw_series(LineSeries::new(line.clone(), BLACK.stroke_width(2)))
        .map_err(|x| e(&x))?
        .label(front.name.as_str())
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK.stroke_width(2)));
    ctx.draw_series(
        line.iter()
            .map(|p| Circle::new(*p, 4, BLACK.stroke_width(1))),
    )
    .map_err(|x| e(&x))?;
    ctx.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|x| e(&x))
}

/// Scatter charts ([`scatter`]) in a grid of `columns`, in one SVG file.
pub fn scatter_figure(
    path: &Path,
    panels: &[(Chart<'_>, Vec<Series>, Series)],
    columns: usize,
) -> Result<(), String> {
    let columns = columns.max(1);
    let rows = panels.len().div_ceil(columns).max(1);
    let root = SVGBackend::new(path, (620 * columns as u32, 480 * rows as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    for (area, (chart, clouds, front)) in root.split_evenly((rows, columns)).iter().zip(panels) {
        scatter(area, chart, clouds, front)?;
    }
    root.present().map_err(|e| e.to_string())
}

/// The colour of an outcome in heat maps.
pub fn outcome_color(o: Option<Outcome>) -> RGBColor {
    match o {
        Some(Outcome::Ok) => RGBColor(46, 160, 67),
        Some(Outcome::Inaccurate) => RGBColor(240, 200, 40),
        Some(Outcome::NewtonFailure) => RGBColor(214, 39, 40),
        Some(Outcome::NonFinite) => RGBColor(120, 0, 120),
        Some(Outcome::Refused) => RGBColor(160, 160, 160),
        Some(Outcome::Panic) => BLACK,
        None => WHITE,
    }
}

/// One panel of a heat map: a grid of outcomes, one row per configuration, one
/// column per step size.
pub struct Facet {
    /// The panel's title (a scheme).
    pub title: String,
    /// Row labels.
    pub rows: Vec<String>,
    /// Outcomes, row by row.
    pub cells: Vec<Vec<Option<Outcome>>>,
}

/// Panels side by side, `per_line` to a line, sharing the step-size columns: a map of
/// hundreds of configurations in one column could not be read.
pub fn heat_map(
    path: &Path,
    title: &str,
    columns: &[String],
    facets: &[Facet],
    per_line: usize,
) -> Result<(), String> {
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let (cw, ch, label) = (40i32, 14i32, 110i32);
    let per_line = per_line.max(1);
    let facet_w = label + cw * columns.len() as i32 + 30;
    let most_rows = facets.iter().map(|f| f.rows.len()).max().unwrap_or(0) as i32;
    let facet_h = 50 + ch * most_rows + 20;
    let lines = facets.len().div_ceil(per_line) as i32;
    let width = (facet_w * per_line.min(facets.len().max(1)) as i32 + 20).max(800) as u32;
    let height = (40 + facet_h * lines + 40) as u32;
    let root = SVGBackend::new(path, (width, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let text = |s: &str, x: i32, y: i32, size: u32| {
        Text::new(s.to_string(), (x, y), ("sans-serif", size).into_font())
    };
    root.draw(&text(title, 10, 10, 18)).map_err(|x| e(&x))?;
    for (n, facet) in facets.iter().enumerate() {
        let x0 = 10 + facet_w * (n % per_line) as i32;
        let y0 = 40 + facet_h * (n / per_line) as i32;
        root.draw(&text(&facet.title, x0, y0, 15))
            .map_err(|x| e(&x))?;
        let top = y0 + 40;
        for (j, c) in columns.iter().enumerate() {
            root.draw(&text(c, x0 + label + cw * j as i32 + 2, top - 16, 10))
                .map_err(|x| e(&x))?;
        }
        for (i, (r, row)) in facet.rows.iter().zip(&facet.cells).enumerate() {
            let y = top + ch * i as i32;
            root.draw(&text(r, x0, y + 1, 10)).map_err(|x| e(&x))?;
            for (j, cell) in row.iter().enumerate() {
                let x = x0 + label + cw * j as i32;
                root.draw(&Rectangle::new(
                    [(x, y), (x + cw - 2, y + ch - 2)],
                    outcome_color(*cell).filled(),
                ))
                .map_err(|x| e(&x))?;
            }
        }
    }
    let legend_y = 40 + facet_h * lines + 10;
    for (k, o) in [
        Outcome::Ok,
        Outcome::Inaccurate,
        Outcome::NewtonFailure,
        Outcome::NonFinite,
        Outcome::Refused,
        Outcome::Panic,
    ]
    .iter()
    .enumerate()
    {
        let x = 10 + 130 * k as i32;
        root.draw(&Rectangle::new(
            [(x, legend_y), (x + 14, legend_y + 14)],
            outcome_color(Some(*o)).filled(),
        ))
        .map_err(|x| e(&x))?;
        root.draw(&text(o.as_str(), x + 20, legend_y + 1, 12))
            .map_err(|x| e(&x))?;
    }
    root.present().map_err(|x| e(&x))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The data's lowest value lies at `share` of the new height, on either scale.
    #[test]
    fn room_below_frees_the_lower_share_of_the_height() {
        let (lo, hi) = room_below((0.0, 100.0), Scale::Linear, 0.25);
        assert_eq!(hi, 100.0);
        assert!(((0.0 - lo) / (hi - lo) - 0.25).abs() < 1e-12, "{lo}");
        let (lo, hi) = room_below((1.0, 100.0), Scale::Log, 0.5);
        assert_eq!(hi, 100.0);
        assert!((lo - 0.01).abs() < 1e-12, "{lo}");
    }
}
