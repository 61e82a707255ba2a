//! SVG plots of the first seed's runs (plotters' SVG backend: no system fonts needed).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::run::{Kind, Row};
use flight_sim::{Disturbance, Dryden, Step};

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// One curve: legend, color, points.
struct Curve {
    name: String,
    color: RGBColor,
    points: Vec<(f64, f64)>,
}

fn color(kind: Kind) -> RGBColor {
    match kind {
        Kind::Mpc => RGBColor(31, 119, 180),
        Kind::MpcOffsetFree => RGBColor(148, 103, 189),
        Kind::MpcFaithful => RGBColor(255, 127, 14),
        Kind::MpcInitial => RGBColor(44, 160, 44),
        Kind::Pid => RGBColor(214, 39, 40),
    }
}

const REFERENCE: RGBColor = RGBColor(40, 40, 40);

fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("plot: {e:?}")
}

/// Draws `curves` on `area` with the given title and axis labels; ranges from the data unless
/// given. `spans` are shaded x-intervals (the gust), `hlines` dashed y-levels (the step band).
fn panel(
    area: &Area,
    title: &str,
    (xl, yl): (&str, &str),
    curves: &[Curve],
    x_range: Option<(f64, f64)>,
    spans: &[(f64, f64)],
    hlines: &[f64],
) -> Result<(), String> {
    let all = curves.iter().flat_map(|c| c.points.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in all {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    for &h in hlines {
        y0 = y0.min(h);
        y1 = y1.max(h);
    }
    if let Some((a, b)) = x_range {
        (x0, x1) = (a, b);
    }
    if x0.partial_cmp(&x1) != Some(std::cmp::Ordering::Less) {
        x1 = x0 + 1.0;
    }
    let pad = ((y1 - y0) * 0.05).max(1e-6);
    let (y0, y1) = (y0 - pad, y1 + pad);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(32)
        .y_label_area_size(56)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(xl)
        .y_desc(yl)
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(err)?;
    for &(a, b) in spans {
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(a, y0), (b, y1)],
                RGBColor(200, 220, 255).mix(0.5).filled(),
            )))
            .map_err(err)?;
    }
    for &h in hlines {
        chart
            .draw_series(DashedLineSeries::new(
                [(x0, h), (x1, h)],
                4,
                4,
                RGBColor(120, 120, 120).into(),
            ))
            .map_err(err)?;
    }
    for c in curves {
        let color = c.color;
        chart
            .draw_series(LineSeries::new(
                c.points.iter().copied(),
                color.stroke_width(1),
            ))
            .map_err(err)?
            .label(c.name.clone())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], color.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(err)?;
    Ok(())
}

fn reversed<'a>(runs: &[(Kind, &'a [Row])]) -> Vec<(Kind, &'a [Row])> {
    runs.iter().rev().copied().collect()
}

fn every(rows: &[Row], n: usize) -> impl Iterator<Item = &Row> {
    rows.iter().step_by(n.max(1))
}

fn window(rows: &[Row], a: f64, b: f64) -> impl Iterator<Item = &Row> {
    rows.iter().filter(move |r| r.t >= a && r.t <= b)
}

/// Writes all the plots into `out`.
pub fn all(
    out: &Path,
    flight: &[(Kind, &[Row])],
    gust: &[(Kind, &[Row])],
    wind: &[(Kind, &[Row])],
    step: &[(Kind, &[Row])],
    dryden: &Dryden,
) -> Result<(), String> {
    const AXES: [&str; 3] = ["x", "y", "z"];
    // The PID first, so that the MPC curves are drawn on top of its wider excursions.
    let (flight, gust, wind, step) = (
        reversed(flight),
        reversed(gust),
        reversed(wind),
        reversed(step),
    );
    let (flight, gust, wind, step) = (
        flight.as_slice(),
        gust.as_slice(),
        wind.as_slice(),
        step.as_slice(),
    );
    let reference_rows = flight[0].1;

    // The path against the reference: three projections, then a zoom on the square's corner
    // at (10, 10), reached at t = 20 s.
    let path = out.join("path.svg");
    let root = SVGBackend::new(&path, (2000, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let panels = root.split_evenly((1, 4));
    let zoom = (8.8, 10.6, 8.8, 10.6);
    let in_zoom = |r: &Row, x: &[f64; 6]| {
        r.t > 17.0
            && r.t < 23.0
            && (zoom.0..=zoom.1).contains(&x[0])
            && (zoom.2..=zoom.3).contains(&x[1])
    };
    for (n, (p, (i, j))) in panels
        .iter()
        .zip([(0, 1), (0, 2), (1, 2), (0, 1)])
        .enumerate()
    {
        let zoomed = n == 3;
        let stride = if zoomed { 1 } else { 2 };
        let keep = |r: &Row, x: &[f64; 6]| !zoomed || in_zoom(r, x);
        let mut curves = vec![Curve {
            name: "reference".into(),
            color: REFERENCE,
            points: every(reference_rows, stride)
                .filter(|r| keep(r, &r.reference))
                .map(|r| (r.reference[i], r.reference[j]))
                .collect(),
        }];
        for &(k, rows) in flight {
            curves.push(Curve {
                name: k.key().into(),
                color: color(k),
                points: every(rows, stride)
                    .filter(|r| keep(r, &r.state))
                    .map(|r| (r.state[i], r.state[j]))
                    .collect(),
            });
        }
        let title = if zoomed {
            "zoom: the corner at (10, 10), t = 17-23 s".to_string()
        } else {
            format!("flight path, {}{} projection", AXES[i], AXES[j])
        };
        panel(
            p,
            &title,
            (&format!("{} (m)", AXES[i]), &format!("{} (m)", AXES[j])),
            &curves,
            zoomed.then_some((zoom.0, zoom.1)),
            &[],
            &[],
        )?;
    }
    root.present().map_err(err)?;

    // Tracking errors along the flight.
    let path = out.join("errors.svg");
    let root = SVGBackend::new(&path, (1400, 900)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    for (a, p) in root.split_evenly((3, 1)).iter().enumerate() {
        let curves: Vec<Curve> = flight
            .iter()
            .map(|&(k, rows)| Curve {
                name: k.key().into(),
                color: color(k),
                points: every(rows, 2)
                    .map(|r| (r.t, r.state[a] - r.reference[a]))
                    .collect(),
            })
            .collect();
        panel(
            p,
            &format!("tracking error, {} axis", AXES[a]),
            ("t (s)", "p − p_ref (m)"),
            &curves,
            None,
            &[],
            &[],
        )?;
    }
    root.present().map_err(err)?;

    // Control signals over the square with its sharp corners.
    let (a, b) = (10.0, 30.0);
    let path = out.join("controls.svg");
    let root = SVGBackend::new(&path, (1400, 900)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    for (ax, p) in root.split_evenly((3, 1)).iter().enumerate() {
        let curves: Vec<Curve> = flight
            .iter()
            .map(|&(k, rows)| Curve {
                name: k.key().into(),
                color: color(k),
                points: window(rows, a, b).map(|r| (r.t, r.command[ax])).collect(),
            })
            .collect();
        let title = format!(
            "commanded acceleration, {} axis (t = {a}-{b} s: the square's corners)",
            AXES[ax]
        );
        panel(
            p,
            &title,
            ("t (s)", "a (m/s²)"),
            &curves,
            Some((a, b)),
            &[],
            &[],
        )?;
    }
    root.present().map_err(err)?;

    // Step responses.
    let s = Step::paper();
    let path = out.join("step.svg");
    let root = SVGBackend::new(&path, (1500, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    for (ax, p) in root.split_evenly((1, 3)).iter().enumerate() {
        let mut curves = vec![Curve {
            name: "reference".into(),
            color: REFERENCE,
            points: window(step[0].1, s.at - 0.5, s.at + 12.0)
                .map(|r| (r.t - s.at, r.reference[ax] - s.origin[ax]))
                .collect(),
        }];
        for &(k, rows) in step {
            curves.push(Curve {
                name: k.key().into(),
                color: color(k),
                points: window(rows, s.at - 0.5, s.at + 12.0)
                    .map(|r| (r.t - s.at, r.state[ax] - s.origin[ax]))
                    .collect(),
            });
        }
        let band = StepBand::of(s.size[ax]);
        let title = format!("{} m step, {} axis (dashed: ±2 %)", s.size[ax], AXES[ax]);
        panel(
            p,
            &title,
            ("t − t_step (s)", "position (m)"),
            &curves,
            None,
            &[],
            &[band.lo, band.hi],
        )?;
    }
    root.present().map_err(err)?;

    // Gust response, and the disturbance estimates against the gust.
    let g = Disturbance::GUST;
    let path = out.join("gust.svg");
    let root = SVGBackend::new(&path, (1400, 900)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let areas = root.split_evenly((2, 1));
    let curves: Vec<Curve> = gust
        .iter()
        .map(|&(k, rows)| Curve {
            name: k.key().into(),
            color: color(k),
            points: window(rows, 10.0, 60.0)
                .map(|r| (r.t, r.state[1] - r.reference[1]))
                .collect(),
        })
        .collect();
    let title = format!(
        "Y tracking error with a {} m/s² gust on Y from {} s to {} s (shaded)",
        g.accel[1], g.start, g.end
    );
    panel(
        &areas[0],
        &title,
        ("t (s)", "y − y_ref (m)"),
        &curves,
        Some((10.0, 60.0)),
        &[(g.start, g.end)],
        &[-0.1, 0.1],
    )?;
    panel(
        &areas[1],
        "the push on Y and the offset-free filter's estimate of it",
        ("t (s)", "a (m/s²)"),
        &disturbance_curves(gust, &[1], 10.0, 60.0),
        Some((10.0, 60.0)),
        &[(g.start, g.end)],
        &[],
    )?;
    root.present().map_err(err)?;

    // Wind response: X and Y errors, and the push with its estimate.
    let (a, b) = (
        10.0,
        (dryden.end + 20.0).min(wind[0].1.last().map_or(b_max(), |r| r.t)),
    );
    let path = out.join("wind.svg");
    let root = SVGBackend::new(&path, (1400, 1200)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let areas = root.split_evenly((3, 1));
    for (n, ax) in [0, 1].into_iter().enumerate() {
        let curves: Vec<Curve> = wind
            .iter()
            .map(|&(k, rows)| Curve {
                name: k.key().into(),
                color: color(k),
                points: every(
                    window(rows, a, b).copied().collect::<Vec<_>>().as_slice(),
                    2,
                )
                .map(|r| (r.t, r.state[ax] - r.reference[ax]))
                .collect(),
            })
            .collect();
        let title = format!(
            "{} tracking error in a {} m/s wind with Dryden-like gusts from {} s to {} s (shaded)",
            AXES[ax], dryden.speed, dryden.start, dryden.end
        );
        panel(
            &areas[n],
            &title,
            ("t (s)", &format!("{0} − {0}_ref (m)", AXES[ax])),
            &curves,
            Some((a, b)),
            &[(dryden.start, dryden.end)],
            &[-0.1, 0.1],
        )?;
    }
    panel(
        &areas[2],
        "the wind's push on X and Y and the offset-free filter's estimates of it",
        ("t (s)", "a (m/s²)"),
        &disturbance_curves(wind, &[0, 1], a, b),
        Some((a, b)),
        &[(dryden.start, dryden.end)],
        &[],
    )?;
    root.present().map_err(err)?;

    // Computation time per step.
    let path = out.join("computation_time.svg");
    let root = SVGBackend::new(&path, (1400, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "wall-clock time per control step (filter + control law), this host",
            ("sans-serif", 16),
        )
        .margin(8)
        .x_label_area_size(32)
        .y_label_area_size(56)
        .build_cartesian_2d(
            0.0..reference_rows.last().map_or(1.0, |r| r.t),
            (0.05f64..20_000.0).log_scale(),
        )
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("t (s)")
        .y_desc("µs (log)")
        .draw()
        .map_err(err)?;
    for &(k, rows) in flight {
        let c = color(k);
        chart
            .draw_series(
                rows.iter()
                    .map(|r| Circle::new((r.t, r.solve_us.max(0.05)), 1, c.filled())),
            )
            .map_err(err)?
            .label(k.key())
            .legend(move |(x, y)| Circle::new((x + 8, y), 3, c.filled()));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// An upper bound for the wind plot's time axis when the trace is empty.
fn b_max() -> f64 {
    1.0
}

/// The true push on `axes` and the disturbance estimates of the controllers that have one.
fn disturbance_curves(runs: &[(Kind, &[Row])], axes: &[usize], a: f64, b: f64) -> Vec<Curve> {
    const AXES: [&str; 3] = ["x", "y", "z"];
    let mut curves = Vec::new();
    let shades = [RGBColor(40, 40, 40), RGBColor(150, 150, 150)];
    for (n, &ax) in axes.iter().enumerate() {
        curves.push(Curve {
            name: format!("push on {}", AXES[ax]),
            color: shades[n % 2],
            points: window(runs[0].1, a, b)
                .map(|r| (r.t, r.disturbance[ax]))
                .collect(),
        });
    }
    for &(k, rows) in runs {
        if rows.first().and_then(|r| r.disturbance_estimate).is_none() {
            continue;
        }
        for (n, &ax) in axes.iter().enumerate() {
            let base = color(k);
            let c = if n == 0 {
                base
            } else {
                RGBColor(base.0 / 2 + 100, base.1 / 2 + 100, base.2 / 2 + 100)
            };
            curves.push(Curve {
                name: format!("{}: estimate on {}", k.key(), AXES[ax]),
                color: c,
                points: window(rows, a, b)
                    .filter_map(|r| r.disturbance_estimate.map(|d| (r.t, d[ax])))
                    .collect(),
            });
        }
    }
    curves
}

/// The ±2 % settling band of a step, in position units relative to the origin.
struct StepBand {
    lo: f64,
    hi: f64,
}

impl StepBand {
    fn of(size: f64) -> Self {
        let b = flight_sim::metrics::StepResponse::BAND * size.abs();
        Self {
            lo: size - b,
            hi: size + b,
        }
    }
}

/// The geofence controller's color.
const GEOFENCE: RGBColor = RGBColor(214, 39, 140);
/// Its estimate's, lighter.
const GEOFENCE_ESTIMATE: RGBColor = RGBColor(240, 160, 205);

/// `geofence.svg`: the geofence scenario of the first seed. The path in the plane with the wall (and,
/// when `plain` is given, the `mpc` of `paper.toml` without it); how far beyond the wall the drone and
/// its estimate are along the square's crossing; y over the two crossings; and the speed, the largest
/// |v_i| over the axes, against its limit.
pub fn geofence(out: &Path, rows: &[Row], plain: Option<&[Row]>) -> Result<(), String> {
    use generated_examples::geofence::{SPEED_LIMIT, WALL_Y};
    let path = out.join("geofence.svg");
    let root = SVGBackend::new(&path, (1600, 1100)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let areas = root.split_evenly((2, 2));

    // The path in the plane.
    let mut curves = vec![Curve {
        name: "reference".into(),
        color: REFERENCE,
        points: every(rows, 2)
            .map(|r| (r.reference[0], r.reference[1]))
            .collect(),
    }];
    if let Some(plain) = plain {
        curves.push(Curve {
            name: format!("{} (no wall)", Kind::Mpc.key()),
            color: color(Kind::Mpc),
            points: every(plain, 2).map(|r| (r.state[0], r.state[1])).collect(),
        });
    }
    curves.push(Curve {
        name: "mpc-geofence".into(),
        color: GEOFENCE,
        points: every(rows, 2).map(|r| (r.state[0], r.state[1])).collect(),
    });
    panel(
        &areas[0],
        &format!("flight path, xy projection; the wall y = {WALL_Y} m dashed"),
        ("x (m)", "y (m)"),
        &curves,
        Some((-7.0, 16.0)),
        &[],
        &[WALL_Y],
    )?;

    // How far beyond the wall, while the square's reference is beyond it (20-24 s) and a little
    // around.
    let (a, b) = (19.8, 24.6);
    let curves = vec![
        Curve {
            name: "mpc-geofence: estimate".into(),
            color: GEOFENCE_ESTIMATE,
            points: window(rows, a, b)
                .map(|r| (r.t, r.estimate[1] - WALL_Y))
                .collect(),
        },
        Curve {
            name: "mpc-geofence: true".into(),
            color: GEOFENCE,
            points: window(rows, a, b)
                .map(|r| (r.t, r.state[1] - WALL_Y))
                .collect(),
        },
    ];
    panel(
        &areas[1],
        &format!("y − {WALL_Y} m along the wall, t = {a}-{b} s (the reference is 2 m beyond from 20 to 24 s)"),
        ("t (s)", "y − wall (m)"),
        &curves,
        Some((a, b + 1.6)),
        &[],
        &[0.0],
    )?;

    // y against time over the two crossings (the axis runs on to leave the legend room).
    let (a, b) = (15.0, 50.0);
    let mut curves = vec![Curve {
        name: "reference".into(),
        color: REFERENCE,
        points: window(rows, a, b).map(|r| (r.t, r.reference[1])).collect(),
    }];
    if let Some(plain) = plain {
        curves.push(Curve {
            name: format!("{} (no wall)", Kind::Mpc.key()),
            color: color(Kind::Mpc),
            points: window(plain, a, b).map(|r| (r.t, r.state[1])).collect(),
        });
    }
    curves.push(Curve {
        name: "mpc-geofence: estimate".into(),
        color: GEOFENCE_ESTIMATE,
        points: window(rows, a, b).map(|r| (r.t, r.estimate[1])).collect(),
    });
    curves.push(Curve {
        name: "mpc-geofence: true".into(),
        color: GEOFENCE,
        points: window(rows, a, b).map(|r| (r.t, r.state[1])).collect(),
    });
    panel(
        &areas[2],
        &format!("y: the square (19-25 s) and the circle (43-48 s) cross the wall y = {WALL_Y} m"),
        ("t (s)", "y (m)"),
        &curves,
        Some((a, b + 12.0)),
        &[],
        &[WALL_Y],
    )?;

    // The speed against its limit: the largest |v_i| over the axes, as the limit is per axis.
    let speed = |x: &[f64; 6]| x[3..6].iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let curves = vec![
        Curve {
            name: "reference".into(),
            color: REFERENCE,
            points: every(rows, 2).map(|r| (r.t, speed(&r.reference))).collect(),
        },
        Curve {
            name: "mpc-geofence: true".into(),
            color: GEOFENCE,
            points: every(rows, 2).map(|r| (r.t, speed(&r.state))).collect(),
        },
    ];
    panel(
        &areas[3],
        &format!("speed, maxᵢ |v_i|, against the limit {SPEED_LIMIT} m/s per axis (dashed)"),
        ("t (s)", "max |v_i| (m/s)"),
        &curves,
        Some((0.0, 1.3 * rows.last().map_or(1.0, |r| r.t))),
        &[],
        &[SPEED_LIMIT],
    )?;
    root.present().map_err(err)?;
    Ok(())
}
