//! PNG line charts (plotters' bitmap backend with the DejaVu Sans font compiled in, so no
//! system font is needed).
use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;

pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub color: RGBColor,
    pub dashed: bool,
    /// A shaded interval (x, low, high) drawn under the line; empty for none.
    pub band: Vec<(f64, f64, f64)>,
}

/// Distinct colours for methods, in order.
pub const PALETTE: [RGBColor; 10] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(31, 31, 120),
];

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .unwrap_or_else(|_| panic!("the bundled DejaVu font parses"));
    });
}

pub struct Chart<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub x_range: (f64, f64),
    pub y_range: (f64, f64),
}

/// Writes a 900×600 PNG line chart with a legend.
pub fn line_chart_png(
    path: &Path,
    chart: &Chart,
    series: &[Series],
) -> Result<(), super::ReportError> {
    register_font();
    let err =
        |e: &dyn std::fmt::Display| super::ReportError::Chart(format!("{}: {e}", path.display()));
    let root = BitMapBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut c = ChartBuilder::on(&root)
        .caption(chart.title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(64)
        .build_cartesian_2d(
            chart.x_range.0..chart.x_range.1,
            chart.y_range.0..chart.y_range.1,
        )
        .map_err(|e| err(&e))?;
    c.configure_mesh()
        .x_desc(chart.x_label)
        .y_desc(chart.y_label)
        .label_style(("sans-serif", 15))
        .draw()
        .map_err(|e| err(&e))?;
    for s in series.iter().filter(|s| !s.band.is_empty()) {
        let outline: Vec<(f64, f64)> = s
            .band
            .iter()
            .map(|b| (b.0, b.2))
            .chain(s.band.iter().rev().map(|b| (b.0, b.1)))
            .collect();
        c.draw_series(std::iter::once(Polygon::new(
            outline,
            s.color.mix(0.18).filled(),
        )))
        .map_err(|e| err(&e))?;
    }
    for s in series {
        let color = s.color;
        let style = color.stroke_width(if s.dashed { 1 } else { 2 });
        let drawn = if s.dashed {
            c.draw_series(DashedLineSeries::new(s.points.iter().copied(), 6, 4, style))
                .map_err(|e| err(&e))?
        } else {
            c.draw_series(LineSeries::new(s.points.iter().copied(), style))
                .map_err(|e| err(&e))?
        };
        drawn.label(s.name.clone()).legend(move |(x, y)| {
            PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
        });
    }
    c.configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 15))
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
