//! `mpcc check --plot FILE`: the dual active-set method's cold iteration count over two parameters of
//! its region, as an SVG heat map (issue 36's picture of the partition).
//!
//! The count is the kernel's own (`codegen::solver::active_set::solve`, f64, from the empty working
//! set: the cold restart the module runs), on a grid over the two chosen entries of θ = (x₀, r, u₋₁, d)
//! with every other entry at the region's centre and the reference constant over the window, as the
//! exact count and the sampled certificate form θ. Every cell is an independent check of the build's
//! cold cap: a cell above it is reported.

use codegen::solver::active_set::exact::Parameters;
use codegen::solver::active_set::{mpc::prepare, solve, Status};
use plotters::prelude::*;
use std::path::Path;

/// Cells per axis.
pub(crate) const GRID: usize = 81;

/// What the picture shows, for the line `mpcc check` prints.
pub(crate) struct Drawn {
    /// The two parameters' names.
    pub axes: [String; 2],
    /// The fewest and most changes of the working set over the solved cells.
    pub range: (usize, usize),
    /// Cells whose QP the kernel found infeasible (drawn grey).
    pub infeasible: usize,
    /// Cells above the build's cold cap (none when the certificate holds on this slice).
    pub above_cap: usize,
    /// The build's cold cap.
    pub cap: usize,
}

/// Draws the heat map of `generated`'s cold count over parameters `axes` (indices into θ) into `file`.
pub(crate) fn draw(
    source: &str,
    generated: &codegen::Generated,
    axes: Option<&str>,
    file: &Path,
) -> Result<Drawn, String> {
    let p = &generated.problem;
    if p.qp.method != mpc_spec::Method::ActiveSet {
        return Err(format!(
            "the picture is of the dual active-set method's cold count; this spec is solved by `{}`",
            p.qp.method.name()
        ));
    }
    let spec = mpc_spec::load(source).map_err(|_| "the spec does not load".to_string())?;
    let region = codegen::sampling::resolve_region(&spec, p, "active_set")
        .map_err(|_| "the spec has no `[mpc.region]` to draw".to_string())?;
    let prepared = prepare(&p.qp).ok_or("the QP's Hessian has no Cholesky factor")?;
    let parameters = Parameters::of(p, &region);
    let [a, b] = match axes {
        None => [0, 1],
        Some(written) => pick(written, &parameters.names)?,
    };
    let cap = generated.certificate.cold_iterations.unwrap_or(0);
    let (lo, hi) = (&parameters.lo, &parameters.hi);
    let at = |k: usize, j: usize| lo[j] + (hi[j] - lo[j]) * k as f64 / (GRID - 1) as f64;
    // Each cell's count, None where the QP is infeasible.
    let mut cells = vec![None; GRID * GRID];
    let (mut infeasible, mut above_cap) = (0, 0);
    for i in 0..GRID {
        for j in 0..GRID {
            let mut theta = parameters.centre();
            theta[a] = at(i, a);
            theta[b] = at(j, b);
            let qp = parameters.qp(p, &theta);
            let offsets = prepared
                .offsets(&qp)
                .map_err(|_| "the QP's data at a grid point are not finite".to_string())?;
            let o = solve(&prepared, &offsets, None, 100 * cap.max(100));
            match o.status {
                Status::Solved => {
                    above_cap += usize::from(o.iterations > cap);
                    cells[i * GRID + j] = Some(o.iterations);
                }
                _ => infeasible += 1,
            }
        }
    }
    let counts: Vec<usize> = cells.iter().flatten().copied().collect();
    let range = (
        counts.iter().copied().min().unwrap_or(0),
        counts.iter().copied().max().unwrap_or(0),
    );
    let names = [parameters.names[a].clone(), parameters.names[b].clone()];
    render(
        file,
        &names,
        (lo[a], hi[a]),
        (lo[b], hi[b]),
        &cells,
        range,
        cap,
    )
    .map_err(|e| format!("cannot draw `{}`: {e}", file.display()))?;
    Ok(Drawn {
        axes: names,
        range,
        infeasible,
        above_cap,
        cap,
    })
}

/// The two parameters `written` names (`x0[0],r[2]`, or indices into θ: `0,6`).
fn pick(written: &str, names: &[String]) -> Result<[usize; 2], String> {
    let picked: Vec<Option<usize>> = written
        .split(',')
        .map(|w| {
            let w = w.trim();
            w.parse::<usize>()
                .ok()
                .filter(|&i| i < names.len())
                .or_else(|| names.iter().position(|n| n == w))
        })
        .collect();
    match picked[..] {
        [Some(a), Some(b)] if a != b => Ok([a, b]),
        _ => Err(format!(
            "`--plot-axes {written}`: two different parameters, by name or index, of the {}: {}",
            names.len(),
            names.join(", ")
        )),
    }
}

/// The colour of `count` on a scale from blue (the fewest) to red (the most).
fn colour(count: usize, range: (usize, usize)) -> RGBColor {
    let t = if range.1 > range.0 {
        (count - range.0) as f64 / (range.1 - range.0) as f64
    } else {
        0.0
    };
    let mix = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
    RGBColor(mix(49.0, 215.0), mix(104.0, 48.0), mix(172.0, 39.0))
}

fn render(
    file: &Path,
    names: &[String; 2],
    x: (f64, f64),
    y: (f64, f64),
    cells: &[Option<usize>],
    range: (usize, usize),
    cap: usize,
) -> Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(file, (760, 640)).into_drawing_area();
    root.fill(&WHITE)?;
    let (plot, legend) = root.split_horizontally(640);
    let mut chart = ChartBuilder::on(&plot)
        .caption(
            format!("cold iterations of the dual active set (cap {cap})"),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x.0..x.1, y.0..y.1)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(names[0].as_str())
        .y_desc(names[1].as_str())
        .draw()?;
    let (dx, dy) = (
        (x.1 - x.0) / (GRID - 1) as f64,
        (y.1 - y.0) / (GRID - 1) as f64,
    );
    chart.draw_series((0..GRID * GRID).map(|c| {
        let (i, j) = (c / GRID, c % GRID);
        let (cx, cy) = (x.0 + dx * i as f64, y.0 + dy * j as f64);
        let fill = match cells[c] {
            Some(k) => colour(k, range).filled(),
            None => RGBColor(200, 200, 200).filled(),
        };
        Rectangle::new(
            [
                (cx - dx / 2.0, cy - dy / 2.0),
                (cx + dx / 2.0, cy + dy / 2.0),
            ],
            fill,
        )
    }))?;
    // The legend: one swatch per count from the fewest to the most (at most 24, evenly spaced), and
    // grey for an infeasible QP when a cell has one.
    legend.draw(&Text::new("changes", (10, 16), ("sans-serif", 14)))?;
    let steps = (range.1 - range.0).min(23) + 1;
    for s in 0..steps {
        let count = range.0 + (range.1 - range.0) * s / (steps - 1).max(1);
        let y0 = 40 + 22 * s as i32;
        legend.draw(&Rectangle::new(
            [(10, y0), (30, y0 + 16)],
            colour(count, range).filled(),
        ))?;
        legend.draw(&Text::new(
            count.to_string(),
            (36, y0 + 2),
            ("sans-serif", 14),
        ))?;
    }
    if cells.iter().any(Option::is_none) {
        let y0 = 40 + 22 * steps as i32 + 10;
        legend.draw(&Rectangle::new(
            [(10, y0), (30, y0 + 16)],
            RGBColor(200, 200, 200).filled(),
        ))?;
        legend.draw(&Text::new("infeasible", (36, y0 + 2), ("sans-serif", 14)))?;
    }
    root.present()?;
    Ok(())
}
