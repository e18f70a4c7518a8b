//! The integrators' plot: error at t = 0.5 s (log) against GPU frame time (log), one series
//! per integrator, each point labelled with its substeps per frame.

use crate::Point;
use crate::font::{FONT_PATHS, register_font};
use plotters::prelude::*;
use std::path::Path;

/// Draws the plot; returns a note for the caller's message (empty, or why there is no text).
pub fn draw(path: &Path, points: &[Point]) -> Result<String, Box<dyn std::error::Error>> {
    let text = register_font();
    let root = BitMapBackend::new(path, (1000, 700)).into_drawing_area();
    root.fill(&WHITE)?;
    let stable: Vec<&Point> = points.iter().filter(|p| p.max_error.is_some() && p.median_ms.is_finite()).collect();
    let error = |p: &Point| p.max_error.unwrap_or(f64::NAN).max(1e-9);
    let (x_min, x_max) =
        stable.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| (lo.min(p.median_ms), hi.max(p.median_ms)));
    let (y_min, y_max) =
        stable.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| (lo.min(error(p)), hi.max(error(p))));
    if stable.is_empty() {
        return Err("no configuration ran stably".into());
    }
    let mut builder = ChartBuilder::on(&root);
    builder.margin(20);
    if text {
        builder
            .caption(
                "swinging cloth 32x32, 0.5 s: max error vs f64 reference against GPU frame time",
                ("sans-serif", 20),
            )
            .x_label_area_size(40)
            .y_label_area_size(70);
    }
    let mut chart =
        builder.build_cartesian_2d((x_min / 1.3..x_max * 1.3).log_scale(), (y_min / 2.0..y_max * 2.0).log_scale())?;
    let mut mesh = chart.configure_mesh();
    mesh.x_desc("GPU frame time, median (ms)").y_desc("max error (m)");
    if !text {
        mesh.disable_x_mesh().disable_y_mesh().x_labels(0).y_labels(0);
    }
    mesh.draw()?;
    for (name, colour) in [("RK4", RED), ("semi-implicit Euler", BLUE)] {
        let mine: Vec<(f64, f64)> =
            stable.iter().filter(|p| p.integrator == name).map(|p| (p.median_ms, error(p))).collect();
        let series = chart.draw_series(LineSeries::new(mine.clone(), colour.stroke_width(2)))?;
        if text {
            series.label(name).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        }
        chart.draw_series(mine.iter().map(|&at| Circle::new(at, 5, colour.filled())))?;
        if text {
            for p in stable.iter().filter(|p| p.integrator == name) {
                let label = EmptyElement::at((p.median_ms, error(p)))
                    + Text::new(format!("{}", p.substeps), (8, -6), ("sans-serif", 13).into_font().color(&colour));
                chart.draw_series(std::iter::once(label))?;
            }
        }
    }
    if text {
        chart.configure_series_labels().background_style(WHITE).border_style(BLACK).draw()?;
    }
    root.present()?;
    Ok(if text {
        String::new()
    } else {
        format!(" (no TrueType font found in $DRAPE_FONT or {FONT_PATHS:?}: no text)")
    })
}
