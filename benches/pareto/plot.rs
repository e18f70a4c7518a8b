//! The Pareto plot: one row per mesh, one panel per error measure, frame time on x.

use crate::Point;
use crate::font::{FONT_PATHS, register_font};
use plotters::prelude::*;
use std::path::Path;

type Measure = (&'static str, fn(&Point) -> f64);

/// Draws the plot; returns a note for the caller's message (empty, or why there is no text).
pub fn draw(path: &Path, points: &[Point]) -> Result<String, Box<dyn std::error::Error>> {
    let text = register_font();
    let root = BitMapBackend::new(path, (1500, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let measures: [Measure; 3] = [
        ("particles inside (%)", |p| 100.0 * p.accuracy.inside_fraction),
        ("max penetration (mm)", |p| p.accuracy.max_penetration as f64 * 1e3),
        ("resting gap mean (mm, log)", |p| (p.accuracy.gap_mean as f64 * 1e3).max(1e-3)),
    ];
    let meshes = ["bunny", "dragon"];
    let panels = root.split_evenly((meshes.len(), measures.len()));
    for (i, panel) in panels.iter().enumerate() {
        let (mesh, (title, value)) = (meshes[i / measures.len()], measures[i % measures.len()]);
        let mine: Vec<&Point> = points.iter().filter(|p| p.mesh == mesh).collect();
        if mine.is_empty() {
            continue;
        }
        let x_max = mine.iter().map(|p| p.median_ms).fold(0.0, f64::max) * 1.15;
        let y_max = mine.iter().map(|p| value(p)).fold(0.0, f64::max).max(1e-3) * 1.2;
        let log = title.contains("log");
        let mut builder = ChartBuilder::on(panel);
        builder.margin(12);
        if text {
            builder.caption(format!("{mesh}: {title}"), ("sans-serif", 18)).x_label_area_size(35).y_label_area_size(55);
        }
        // The two y axes have different types, so the rest of the panel is written once for both.
        macro_rules! finish_panel {
            ($y_range:expr) => {{
                let mut chart = builder.build_cartesian_2d(0.0..x_max, $y_range)?;
                let mut mesh_style = chart.configure_mesh();
                mesh_style.x_desc("frame time, median (ms)");
                if !text {
                    mesh_style.disable_x_mesh().disable_y_mesh().x_labels(0).y_labels(0);
                }
                mesh_style.draw()?;
                points_and_labels(&mut chart, &mine, value, text)?;
            }};
        }
        if log {
            let y_min = mine.iter().map(|p| value(p)).fold(f64::INFINITY, f64::min) / 1.5;
            finish_panel!((y_min..y_max).log_scale());
        } else {
            finish_panel!(0.0..y_max);
        }
    }
    root.present()?;
    Ok(if text {
        String::new()
    } else {
        format!(" (no TrueType font found in $DRAPE_FONT or {FONT_PATHS:?}: no text)")
    })
}

/// Spheres in blue, triangles in red, each point labelled with its configuration.
fn points_and_labels<X, Y>(
    chart: &mut ChartContext<'_, BitMapBackend<'_>, Cartesian2d<X, Y>>,
    points: &[&Point],
    value: fn(&Point) -> f64,
    text: bool,
) -> Result<(), Box<dyn std::error::Error>>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    for p in points {
        let colour = if p.contact == "spheres" { BLUE } else { RED };
        let at = (p.median_ms, value(p));
        chart.draw_series(std::iter::once(Circle::new(at, 5, colour.filled())))?;
        if text {
            // Beside the dot, not on it.
            let label =
                EmptyElement::at(at) + Text::new(p.label(), (8, -6), ("sans-serif", 12).into_font().color(&colour));
            chart.draw_series(std::iter::once(label))?;
        }
    }
    Ok(())
}
