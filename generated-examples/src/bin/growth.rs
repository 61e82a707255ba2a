//! How the benchmark figures grow with the horizon: reads `panel,series,N,value` rows (the CSV beside
//! BENCHMARKS.md, written from the runs it quotes) and draws one log-log panel per `panel`, one line
//! per `series`.
//!
//! `cargo run --release -p generated-examples --bin growth -- benchmarks/growth.csv benchmarks/growth.svg`

use std::collections::BTreeMap;
use std::error::Error;

use plotters::prelude::*;

type Panels = BTreeMap<String, BTreeMap<String, Vec<(f64, f64)>>>;

fn read(path: &str) -> Result<Panels, Box<dyn Error>> {
    let mut panels = Panels::new();
    for (n, line) in std::fs::read_to_string(path)?.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || n == 0 && line.starts_with("panel,") {
            continue;
        }
        let fields: Vec<&str> = line.split(',').collect();
        let [panel, series, horizon, value] = fields[..] else {
            return Err(format!("{path}:{}: expected panel,series,N,value", n + 1).into());
        };
        let point = (horizon.trim().parse::<f64>()?, value.trim().parse::<f64>()?);
        panels
            .entry(panel.trim().to_string())
            .or_default()
            .entry(series.trim().to_string())
            .or_default()
            .push(point);
    }
    Ok(panels)
}

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().collect();
    let [_, input, output] = &args[..] else {
        return Err("usage: growth INPUT.csv OUTPUT.svg".into());
    };
    let panels = read(input)?;
    let root = SVGBackend::new(output, (900, 420 * panels.len().max(1) as u32)).into_drawing_area();
    root.fill(&WHITE)?;
    for (area, (title, series)) in root
        .split_evenly((panels.len().max(1), 1))
        .iter()
        .zip(&panels)
    {
        let points = series.values().flatten();
        let (lo, hi) = points.fold((f64::MAX, f64::MIN), |(lo, hi), p| {
            (lo.min(p.1), hi.max(p.1))
        });
        let n_max = series.values().flatten().map(|p| p.0).fold(1.0, f64::max);
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (4.0..n_max * 1.1).log_scale(),
                (lo * 0.7..hi * 1.4).log_scale(),
            )?;
        chart
            .configure_mesh()
            .x_desc("horizon N")
            .y_label_formatter(&|v| format!("{v:.3e}"))
            .draw()?;
        for (i, (name, points)) in series.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let mut points = points.clone();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            chart
                .draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 18, y)], color.stroke_width(2))
                });
            chart.draw_series(points.iter().map(|p| Circle::new(*p, 3, color.filled())))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
    }
    root.present()?;
    Ok(())
}
