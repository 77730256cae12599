//! Plots of the figures, drawn by `plotters` into SVG (text stays SVG text: no font files).

use plotters::prelude::*;

/// One curve of a line plot.
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub colour: RGBColor,
    /// Drawn dashed (reference curves: Mitsuba, slopes).
    pub dashed: bool,
}

/// Distinct colours for up to 12 curves (Tableau 10 + two).
pub const PALETTE: [RGBColor; 12] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(0, 0, 0),
    RGBColor(120, 120, 255),
];

fn err(e: impl std::fmt::Display) -> String {
    format!("plot: {e}")
}

/// Positive range of the values (log axes), widened a little.
fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !(lo.is_finite() && hi > 0.0) {
        return (0.1, 1.0);
    }
    if hi <= lo {
        hi = lo * 10.0;
    }
    (lo / 1.3, hi * 1.3)
}

/// Vertical error bars: (x, y, low, high) of one colour.
#[derive(Clone, Debug)]
pub struct ErrorBars {
    pub bars: Vec<(f64, f64, f64, f64)>,
    pub colour: RGBColor,
}

/// A log–log line plot with a legend, as SVG text.
pub fn log_log(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<String, String> {
    log_log_with_bars(title, x_label, y_label, series, &[])
}

/// [`log_log`] with vertical error bars (a bar's ends below zero are drawn at the plot's edge).
pub fn log_log_with_bars(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    bars: &[ErrorBars],
) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (640, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (x0, x1) = log_range(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
        let (y0, y1) = log_range(
            series
                .iter()
                .flat_map(|s| s.points.iter().map(|p| p.1))
                .chain(bars.iter().flat_map(|b| b.bars.iter().map(|p| p.3))),
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .x_label_formatter(&|v| format!("{v}"))
            .draw()
            .map_err(err)?;
        for s in series {
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .copied()
                .filter(|p| p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.1.is_finite())
                .collect();
            let style = s.colour.stroke_width(2);
            let c = s.colour;
            let drawn = if s.dashed {
                chart.draw_series(DashedLineSeries::new(pts.clone(), 6, 4, style))
            } else {
                chart.draw_series(LineSeries::new(pts.clone(), style))
            }
            .map_err(err)?;
            drawn.label(s.name.clone()).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2))
            });
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 2, c.filled())))
                .map_err(err)?;
        }
        for b in bars {
            let style = b.colour.stroke_width(1);
            chart
                .draw_series(
                    b.bars
                        .iter()
                        .filter(|p| p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.3.is_finite())
                        .flat_map(|&(x, _, lo, hi)| {
                            // A vertical line with caps 8 % either side of x (log axis).
                            let (lo, hi) = (lo.max(y0), hi.min(y1));
                            let (xl, xr) = (x / 1.08, x * 1.08);
                            [
                                PathElement::new(vec![(x, lo), (x, hi)], style),
                                PathElement::new(vec![(xl, lo), (xr, lo)], style),
                                PathElement::new(vec![(xl, hi), (xr, hi)], style),
                            ]
                        }),
                )
                .map_err(err)?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .label_font(("sans-serif", 11))
            .draw()
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// A histogram of counts per integer bin (bins `first..first + counts.len()`), as SVG text.
pub fn histogram(
    title: &str,
    x_label: &str,
    y_label: &str,
    first: u32,
    counts: &[u64],
    colour: RGBColor,
) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (640, 360)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let last = first + counts.len() as u32;
        let top = counts.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.1;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d((first..last).into_segmented(), 0.0..top)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .y_label_formatter(&|v| format!("{v:.2e}"))
            .draw()
            .map_err(err)?;
        chart
            .draw_series(
                Histogram::vertical(&chart)
                    .style(colour.filled())
                    .margin(2)
                    .data(
                        counts
                            .iter()
                            .enumerate()
                            .map(|(i, &c)| (first + i as u32, c as f64)),
                    ),
            )
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plots_are_svg_with_their_labels() {
        let s = Series {
            name: "slope −½".into(),
            points: vec![(1.0, 1.0), (100.0, 0.1)],
            colour: PALETTE[0],
            dashed: false,
        };
        let svg = log_log("RMSE", "spp", "RMSE", &[s]).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("slope −½") && svg.contains("spp"));
        let h = histogram("iterations", "k", "samples", 1, &[5, 9, 2], PALETTE[1]).unwrap();
        assert!(h.contains("<rect") && h.contains("iterations"));
    }
}
