//! Markdown tables on stdout and CSV files, from the aggregated summary.

use std::fmt::Write as _;

use serde_json::Value;

use crate::run::Kind;
use crate::summary::number;

/// The paper's own figures (Tables 2 and 3, Section 3.2.4), printed beside ours for comparison.
/// They are the paper's measurements on its trajectory and hardware, not expectations.
mod paper {
    pub const TABLE2_MPC: [(&str, [f64; 3]); 8] = [
        ("max_abs_error", [0.236, 0.236, 0.207]),
        ("rmse", [0.082, 0.086, 0.088]),
        ("iae", [6.986, 8.737, 7.764]),
        ("ise", [0.673, 1.029, 0.849]),
        ("itae", [398.531, 502.689, 431.181]),
        ("itse", [39.581, 61.222, 46.987]),
        ("smoothness", [16.189, 16.276, 16.578]),
        ("variance", [1.658, 1.855, 1.171]),
    ];
    pub const TABLE2_PID: [(&str, [f64; 3]); 8] = [
        ("max_abs_error", [0.486, 0.606, 0.499]),
        ("rmse", [0.111, 0.108, 0.113]),
        ("iae", [12.433, 10.215, 9.943]),
        ("ise", [2.371, 1.679, 1.362]),
        ("itae", [705.565, 588.987, 546.251]),
        ("itse", [119.079, 88.491, 72.828]),
        ("smoothness", [114.693, 114.122, 114.167]),
        ("variance", [22.391, 22.964, 22.638]),
    ];
    /// Mean computation time on the Zynq-7000's Cortex-A9, µs.
    pub const TIME_US: (f64, f64) = (180.0, 21.0);
    pub const TABLE3_MPC: [(&str, [f64; 3]); 4] = [
        ("rise_time_s", [0.793, 0.768, 0.755]),
        ("peak_time_s", [1.241, 7.292, 1.433]),
        ("overshoot_pct", [14.81, 4.02, 9.21]),
        ("settling_time_s", [15.086, 7.961, 7.126]),
    ];
    pub const TABLE3_PID: [(&str, [f64; 3]); 4] = [
        ("rise_time_s", [0.819, 0.806, 0.832]),
        ("peak_time_s", [2.840, 2.557, 2.614]),
        ("overshoot_pct", [16.04, 19.87, 18.17]),
        ("settling_time_s", [15.632, 16.162, 14.623]),
    ];
    /// Held error, recovery time, error after recovery (MPC only).
    pub const GUST_MPC: [f64; 3] = [0.77, 2.85, 0.133];
}

const TABLE2: [(&str, &str); 8] = [
    ("max_abs_error", "Max abs error (m)"),
    ("rmse", "RMSE (m)"),
    ("iae", "IAE (m·s)"),
    ("ise", "ISE (m²·s)"),
    ("itae", "ITAE (m·s²)"),
    ("itse", "ITSE (m²·s²)"),
    ("smoothness", "Smoothness, mean abs rate of change (m/s³)"),
    ("variance", "Control variance ((m/s²)²)"),
];

const TABLE3: [(&str, &str); 4] = [
    ("rise_time_s", "Rise time 10-90 % (s)"),
    ("peak_time_s", "Peak time (s)"),
    ("overshoot_pct", "Overshoot (%)"),
    ("settling_time_s", "Settling time ±2 % (s)"),
];

/// The gust's figures; the paper has the first three.
const GUST: [(&str, &str); 6] = [
    (
        "rmse_y_during_m",
        "Y RMSE during the gust, from 3 s after onset (m)",
    ),
    ("recovery_time_s", "Recovery time after the gust (s)"),
    ("rmse_y_after_m", "Y RMSE over 10 s after recovery (m)"),
    (
        "settle_after_onset_s",
        "Time until the gust's effect on Y is back under 0.1 m, after onset (s)",
    ),
    (
        "settle_after_end_s",
        "Time until the gust's effect on Y is back under 0.1 m, after it stops (s)",
    ),
    ("max_effect_y_m", "Largest effect of the gust on Y (m)"),
];

/// The wind's figures: the gust's, and the RMSE per axis over the same window.
const WIND: [(&str, &str); 7] = [
    (
        "rmse_during_m",
        "RMSE per axis [x, y, z] while the wind blows, from 3 s after onset (m)",
    ),
    (
        "rmse_y_during_m",
        "Y RMSE while the wind blows, from 3 s after onset (m)",
    ),
    (
        "settle_after_onset_s",
        "Time until the wind's effect on Y is back under 0.1 m, after onset (s)",
    ),
    (
        "settle_after_end_s",
        "Time until the wind's effect on Y is back under 0.1 m, after it stops (s)",
    ),
    ("recovery_time_s", "Recovery time after the wind stops (s)"),
    ("rmse_y_after_m", "Y RMSE over 10 s after recovery (m)"),
    ("max_effect_y_m", "Largest effect of the wind on Y (m)"),
];

const QP_GAP: [(&str, &str); 4] = [
    ("u_dist_mean", "mean ‖u₀ − u₀*‖ (m/s²)"),
    ("u_dist_max", "max ‖u₀ − u₀*‖ (m/s²)"),
    ("u_dist_rel", "mean ‖u₀ − u₀*‖ / mean ‖u₀*‖"),
    ("cost_gap_mean", "mean J(U) − J(U*)"),
];

/// A number with a precision that suits its size.
pub fn fmt(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 {
        "0".into()
    } else if a >= 100.0 {
        format!("{x:.1}")
    } else if a >= 0.01 {
        format!("{x:.3}")
    } else {
        format!("{x:.2e}")
    }
}

/// A number or `{mean, std}` as text; "—" for an undefined figure.
pub fn cell(v: &Value) -> String {
    match v {
        Value::Array(xs) => format!("[{}]", xs.iter().map(cell).collect::<Vec<_>>().join(", ")),
        _ => match number(v) {
            Some((m, Some(s))) => format!("{} ± {}", fmt(m), fmt(s)),
            Some((m, None)) => fmt(m),
            None => "—".into(),
        },
    }
}

fn paper_cell(xs: &[f64]) -> String {
    format!(
        "[{}]",
        xs.iter().map(|x| fmt(*x)).collect::<Vec<_>>().join(", ")
    )
}

/// The controllers present in the summary, in report order.
pub fn kinds(summary: &Value) -> Vec<Kind> {
    Kind::ALL
        .into_iter()
        .filter(|k| summary["controllers"].get(k.key()).is_some())
        .collect()
}

fn header(out: &mut String, kinds: &[Kind], first: &str, extra: &[&str]) {
    let mut cols = vec![first.to_string()];
    cols.extend(kinds.iter().map(|k| format!("`{}`", k.key())));
    cols.extend(extra.iter().map(|s| s.to_string()));
    let _ = writeln!(out, "| {} |", cols.join(" | "));
    let _ = writeln!(out, "|{}", "---|".repeat(cols.len()));
}

/// The Markdown report of the aggregated summary.
pub fn markdown(summary: &Value) -> String {
    let c = &summary["controllers"];
    let cfg = &summary["config"];
    let kinds = kinds(summary);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Seed {} ({} seed{}), GPS σ = {} m, acceleration noise σ = {} m/s², flight {} s; \
         step responses {}; PID derivative: {}.\n",
        cfg["seed"],
        cfg["seeds"],
        if cfg["seeds"].as_u64() == Some(1) {
            ""
        } else {
            "s, mean ± standard deviation"
        },
        cfg["gps_sigma"],
        cfg["accel_sigma"],
        cfg["duration_s"],
        if cfg["step_noise"].as_bool() == Some(true) {
            "with the flight's noise"
        } else {
            "without noise"
        },
        cfg["pid_derivative"].as_str().unwrap_or("difference"),
    );
    let _ = writeln!(
        out,
        "Controllers: {}.\n",
        kinds
            .iter()
            .map(|k| format!("`{}` = {}", k.key(), k.label()))
            .collect::<Vec<_>>()
            .join("; ")
    );

    let _ = writeln!(
        out,
        "#### Table 2: tracking and control signal, per axis [x, y, z]\n"
    );
    header(&mut out, &kinds, "metric", &["paper: MPC", "paper: PID"]);
    for (i, (key, label)) in TABLE2.iter().enumerate() {
        let cells: Vec<String> = kinds.iter().map(|k| cell(&c[k.key()][*key])).collect();
        let _ = writeln!(
            out,
            "| {label} | {} | {} | {} |",
            cells.join(" | "),
            paper_cell(&paper::TABLE2_MPC[i].1),
            paper_cell(&paper::TABLE2_PID[i].1)
        );
    }
    for (key, label) in [
        ("mean", "Computation time per step, mean (µs)"),
        ("median", "Computation time per step, median (µs)"),
        ("p99", "Computation time per step, 99th percentile (µs)"),
        ("max", "Computation time per step, max (µs)"),
    ] {
        let cells: Vec<String> = kinds
            .iter()
            .map(|k| cell(&c[k.key()]["solve_time_us"][key]))
            .collect();
        let (pm, pp) = if key == "mean" {
            (
                format!("{} (Cortex-A9)", fmt(paper::TIME_US.0)),
                format!("{} (Cortex-A9)", fmt(paper::TIME_US.1)),
            )
        } else {
            ("—".into(), "—".into())
        };
        let _ = writeln!(out, "| {label} | {} | {pm} | {pp} |", cells.join(" | "));
    }

    let _ = writeln!(
        out,
        "\n#### Table 3: 1 m step on each axis from hover, per axis [x, y, z]\n"
    );
    header(&mut out, &kinds, "metric", &["paper: MPC", "paper: PID"]);
    for (i, (key, label)) in TABLE3.iter().enumerate() {
        let cells: Vec<String> = kinds
            .iter()
            .map(|k| cell(&c[k.key()]["step"][*key]))
            .collect();
        let _ = writeln!(
            out,
            "| {label} | {} | {} | {} |",
            cells.join(" | "),
            paper_cell(&paper::TABLE3_MPC[i].1),
            paper_cell(&paper::TABLE3_PID[i].1)
        );
    }

    let _ = writeln!(out, "\n#### Gust: +0.6 m/s² on Y from t = 20 s to 35 s\n");
    header(&mut out, &kinds, "figure", &["paper: MPC"]);
    for (i, (key, label)) in GUST.iter().enumerate() {
        let cells: Vec<String> = kinds
            .iter()
            .map(|k| cell(&c[k.key()]["gust"][*key]))
            .collect();
        let paper = paper::GUST_MPC.get(i).map_or("—".into(), |x| fmt(*x));
        let _ = writeln!(out, "| {label} | {} | {paper} |", cells.join(" | "));
    }
    let _ = writeln!(
        out,
        "\nThe gust's *effect* is the gust run's Y error minus the calm run's (same seed, same \
         noise); — where it is not back under 0.1 m within the window.\n"
    );

    let w = &cfg["wind"];
    let _ = writeln!(
        out,
        "#### Wind: {} m/s towards {} from t = {} s to {} s, Dryden-like turbulence\n",
        w["speed_m_s"], w["direction_xy"], w["start_s"], w["end_s"]
    );
    let _ = writeln!(
        out,
        "Mean push {} m/s², turbulent push σ = {} m/s² with τ = {} s per axis [x, y, z] \
         (altitude {} m, drag {} 1/s; the wind's own seeded stream).\n",
        cell(&w["mean_accel_m_s2"]),
        cell(&w["sigma_accel_m_s2"]),
        cell(&w["tau_s"]),
        w["altitude_m"],
        w["drag_per_s"],
    );
    header(&mut out, &kinds, "figure", &[]);
    for (key, label) in WIND {
        let cells: Vec<String> = kinds
            .iter()
            .map(|k| cell(&c[k.key()]["wind"][key]))
            .collect();
        let _ = writeln!(out, "| {label} | {} |", cells.join(" | "));
    }
    targets(&mut out, summary);

    let mpcs: Vec<Kind> = kinds
        .iter()
        .copied()
        .filter(|k| !c[k.key()]["qp_gap"].is_null())
        .collect();
    if !mpcs.is_empty() {
        let _ = writeln!(
            out,
            "\n#### Distance from the exact optimum of each MPC's own QP along the flight\n"
        );
        let cols: Vec<String> = mpcs.iter().map(|k| format!("`{}`", k.key())).collect();
        let _ = writeln!(out, "| figure | {} |", cols.join(" | "));
        let _ = writeln!(out, "|---|{}", "---|".repeat(cols.len()));
        for (key, label) in QP_GAP {
            let cells: Vec<String> = mpcs
                .iter()
                .map(|k| cell(&c[k.key()]["qp_gap"][key]))
                .collect();
            let _ = writeln!(out, "| {label} | {} |", cells.join(" | "));
        }
    }
    geofence(&mut out, summary);
    out
}

/// The rows of the geofence table: the label, and the path under `geofence.flight` of the object whose
/// `wall_m`, `speed_m_s`, `floor_m` fill the three columns (`@t`: its `*_t_s`, when they happened).
const GEOFENCE: [(&str, &str); 6] = [
    ("true state: worst violation", "true_state"),
    ("true state: when (t, s)", "true_state@t"),
    ("estimate x̂₀: worst violation", "estimate"),
    ("plan x₁ … x_N: worst violation", "plan.worst"),
    (
        "plan: worst excess over the unavoidable, solved plans",
        "plan.excess",
    ),
    ("plan: worst excess, fallback plans", "plan.fallback_excess"),
];

/// The three columns of a row of [`GEOFENCE`].
fn geofence_cells(flight: &Value, path: &str) -> [Value; 3] {
    let (path, times) = match path.strip_suffix("@t") {
        Some(p) => (p, true),
        None => (path, false),
    };
    let v = path.split('.').fold(flight, |v, k| &v[k]);
    if times {
        [
            v["wall_t_s"].clone(),
            v["speed_t_s"].clone(),
            v["floor_t_s"].clone(),
        ]
    } else {
        [
            v["wall_m"].clone(),
            v["speed_m_s"].clone(),
            v["floor_m"].clone(),
        ]
    }
}

/// A count as an integer (one seed); otherwise as [`cell`] shows a figure.
fn count(v: &Value) -> String {
    match v.as_f64() {
        Some(x) if x.fract() == 0.0 && x.abs() < 1e15 => format!("{}", x as i64),
        _ => cell(v),
    }
}

/// The geofence scenario (issue 18), when it was flown.
fn geofence(out: &mut String, summary: &Value) {
    let g = &summary["geofence"];
    if g.is_null() {
        return;
    }
    let (cfg, f) = (&g["config"], &g["flight"]);
    let _ = writeln!(
        out,
        "\n#### Geofence: `{}`, the flight with the wall y ≤ {} m, |v_i| ≤ {} m/s and z ≥ {} m \
         (soft, dual active-set method)\n",
        cfg["spec"].as_str().unwrap_or(""),
        cfg["wall_y_m"],
        cfg["speed_limit_m_s"],
        cfg["floor_m"],
    );
    let _ = writeln!(
        out,
        "The reference crosses the wall by 2 m along the square (t = 19.2-24.8 s) and the circle \
         (43.3-47.7 s). A violation is 0 where the constraint holds; the wall and the floor in m, the \
         speed in m/s (its worst axis). The plan is the states x₁ … x_N the controller predicts from its \
         estimate x̂₀ with the inputs it returned; its excess is what it violates beyond the least any \
         plan in the input box reaches from the same x̂₀ (an estimate beyond the wall, or too fast to \
         stop before it), and is 0 within `accuracy` when it is at most the tolerance. The plan holds \
         the wall pulled in by the spec's back-off, y ≤ {} − {:.4} m (3σ of the filter's steady-state \
         error); the violations are of the wall itself.\n",
        cfg["wall_y_m"],
        cfg["wall_backoff_m"].as_f64().unwrap_or(f64::NAN),
    );
    let _ = writeln!(
        out,
        "| figure | wall, y ≤ {} (m) | speed, \\|v_i\\| ≤ {} (m/s) | floor, z ≥ {} (m) |",
        cfg["wall_y_m"], cfg["speed_limit_m_s"], cfg["floor_m"]
    );
    let _ = writeln!(out, "|---|---|---|---|");
    for (label, path) in GEOFENCE {
        let cells = geofence_cells(f, path).map(|v| cell(&v));
        let _ = writeln!(out, "| {label} | {} |", cells.join(" | "));
    }
    let t = &cfg["tolerance"];
    let _ = writeln!(
        out,
        "| tolerance: accuracy {} × max(1, \\|bound\\|) | {} | {} | {} |",
        cfg["accuracy"],
        cell(&t["wall_m"]),
        cell(&t["speed_m_s"]),
        cell(&t["floor_m"])
    );
    let tb = &f["true_state_time_beyond_s"];
    let _ = writeln!(
        out,
        "| true state: time beyond (s) | {} | {} | {} |",
        cell(&tb["wall"]),
        cell(&tb["speed"]),
        cell(&tb["floor"])
    );
    let p = &f["plan"];
    let worst = &g["worst_over_seeds"];
    let ratio = number(&worst["plan_excess_over_tolerance"]).map_or(f64::NAN, |x| x.0);
    let _ = writeln!(
        out,
        "\nSolved plans within `accuracy` of the unavoidable, every cycle of every seed: {} (worst \
         excess / tolerance {}). Fallbacks (a solve that did not end at the optimum: the plan is the \
         previous one shifted): {} in a flight of {} cycles, the largest final dual residual among them \
         {} (the active set reports none: 0). `SolverStatus`: `softened` at most {} (the largest of the plan's three; it agrees with the \
         prediction to {}), `violation` {} (the spec has no hard row), at most {} iterations. Tracking \
         RMSE [x, y, z] {} m; computation per step {} µs mean, {} µs max (this host).",
        if ratio <= 1.0 { "yes" } else { "no" },
        fmt(ratio),
        count(&p["fallbacks"]),
        count(&f["cycles"]),
        cell(&p["fallback_dual_residual_max"]),
        cell(&p["solver_softened_max"]),
        cell(&p["softened_mismatch"]),
        cell(&p["solver_violation_max"]),
        count(&p["iterations_max"]),
        cell(&f["rmse_m"]),
        cell(&f["solve_time_us"]["mean"]),
        cell(&f["solve_time_us"]["max"]),
    );
    if summary["config"]["seeds"].as_u64().unwrap_or(1) > 1 {
        let (s, e) = (&worst["true_state"], &worst["estimate"]);
        let _ = writeln!(
            out,
            "\nWorst over the seeds: the true state {} m beyond the wall, {} m/s over the speed \
             limit, {} m below the floor; the estimate {} m, {} m/s, {} m; {} fallbacks in one flight.",
            cell(&s["wall_m"]),
            cell(&s["speed_m_s"]),
            cell(&s["floor_m"]),
            cell(&e["wall_m"]),
            cell(&e["speed_m_s"]),
            cell(&e["floor_m"]),
            count(&worst["fallbacks"]),
        );
    }
}

/// The targets of issue 8, when both the plain and the offset-free MPC were flown: the offset-free
/// controller's Y RMSE during the gust under 0.1 m, and its RMSE without wind at most 1.1 times
/// the plain MPC's (ratio of the means over the seeds, per axis).
fn targets(out: &mut String, summary: &Value) {
    let c = &summary["controllers"];
    let (plain, free) = (&c[Kind::Mpc.key()], &c[Kind::MpcOffsetFree.key()]);
    if plain.is_null() || free.is_null() {
        return;
    }
    let seeds = summary["config"]["seeds"].as_u64().unwrap_or(1);
    let _ = writeln!(
        out,
        "\n#### Offset-free targets (issue 8), over {seeds} seed{}\n",
        if seeds == 1 { "" } else { "s" }
    );
    let _ = writeln!(out, "| target | `mpc` | `mpc-offset-free` | met |");
    let _ = writeln!(out, "|---|---|---|---|");
    let during = |v: &Value| number(&v["gust"]["rmse_y_during_m"]);
    if let Some(f) = during(free) {
        let _ = writeln!(
            out,
            "| Y RMSE during the gust < 0.1 m | {} | {} | {} |",
            cell(&plain["gust"]["rmse_y_during_m"]),
            cell(&free["gust"]["rmse_y_during_m"]),
            if f.0 < 0.1 { "yes" } else { "no" }
        );
    }
    for axis in 0..3 {
        let rmse = |v: &Value| number(&v["rmse"][axis]).map(|x| x.0);
        if let (Some(p), Some(f)) = (rmse(plain), rmse(free)) {
            let _ = writeln!(
                out,
                "| RMSE without wind, {} axis: offset-free ≤ 1.1 × plain | {} | {} (× {:.3}) | {} |",
                ["x", "y", "z"][axis],
                fmt(p),
                fmt(f),
                f / p,
                if f <= 1.1 * p { "yes" } else { "no" }
            );
        }
    }
}

/// CSV files `(name, contents)`: Table 2 (with the computation time), Table 3, gust, wind, QP gap and
/// the geofence scenario's violations (when it was flown).
/// Per-axis figures have columns x, y, z; with several seeds each is a mean and a std column.
pub fn csv(summary: &Value) -> Vec<(&'static str, String)> {
    let c = &summary["controllers"];
    let kinds = kinds(summary);
    let seeds = summary["config"]["seeds"].as_u64().unwrap_or(1) > 1;
    let head = |names: &[&str]| -> String {
        let mut cols = vec!["controller".to_string(), "metric".to_string()];
        for n in names {
            if seeds {
                cols.push(format!("{n}_mean"));
                cols.push(format!("{n}_std"));
            } else {
                cols.push(n.to_string());
            }
        }
        cols.join(",") + "\n"
    };
    let value = |v: &Value| -> String {
        match number(v) {
            Some((m, s)) if seeds => format!("{m},{}", s.unwrap_or(0.0)),
            Some((m, _)) => m.to_string(),
            None if seeds => ",".into(),
            None => String::new(),
        }
    };
    let row = |out: &mut String, kind: Kind, metric: &str, v: &Value| {
        let cells: Vec<String> = match v {
            Value::Array(xs) => xs.iter().map(value).collect(),
            v => vec![value(v)],
        };
        let _ = writeln!(out, "{},{metric},{}", kind.key(), cells.join(","));
    };
    let mut table2 = head(&["x", "y", "z"]);
    for &k in &kinds {
        for (key, _) in TABLE2 {
            row(&mut table2, k, key, &c[k.key()][key]);
        }
    }
    let mut time = head(&["value"]);
    for &k in &kinds {
        for key in ["mean", "median", "p99", "max"] {
            row(
                &mut time,
                k,
                &format!("solve_time_us_{key}"),
                &c[k.key()]["solve_time_us"][key],
            );
        }
    }
    let mut table3 = head(&["x", "y", "z"]);
    for &k in &kinds {
        for (key, _) in TABLE3 {
            row(&mut table3, k, key, &c[k.key()]["step"][key]);
        }
    }
    let mut gust = head(&["value"]);
    for &k in &kinds {
        for (key, _) in GUST {
            row(&mut gust, k, key, &c[k.key()]["gust"][key]);
        }
    }
    let mut wind = head(&["x", "y", "z"]);
    for &k in &kinds {
        for (key, _) in WIND {
            let v = &c[k.key()]["wind"][key];
            // Scalar figures in the y column.
            let v = match v {
                Value::Array(_) => v.clone(),
                v => Value::Array(vec![Value::Null, v.clone(), Value::Null]),
            };
            row(&mut wind, k, key, &v);
        }
    }
    let mut gap = head(&["value"]);
    for &k in &kinds {
        if !c[k.key()]["qp_gap"].is_null() {
            for (key, _) in QP_GAP {
                row(&mut gap, k, key, &c[k.key()]["qp_gap"][key]);
            }
        }
    }
    let fence = &summary["geofence"]["flight"];
    let mut geofence = head(&["wall_m", "speed_m_s", "floor_m"]);
    if !fence.is_null() {
        for (_, path) in GEOFENCE {
            let metric = path.replace('.', "_").replace("@t", "_t_s");
            let cells: Vec<String> = geofence_cells(fence, path).iter().map(value).collect();
            let _ = writeln!(geofence, "mpc-geofence,{metric},{}", cells.join(","));
        }
    }
    let mut files = vec![
        ("table2.csv", table2),
        ("computation_time.csv", time),
        ("table3.csv", table3),
        ("gust.csv", gust),
        ("wind.csv", wind),
        ("qp_gap.csv", gap),
    ];
    if !fence.is_null() {
        files.push(("geofence.csv", geofence));
    }
    files
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn numbers_format_by_size_and_seeds() {
        assert_eq!(fmt(0.08234), "0.082");
        assert_eq!(fmt(398.531), "398.5");
        assert_eq!(fmt(0.000123), "1.23e-4");
        assert_eq!(
            cell(&json!([1.0, null, {"mean": 2.0, "std": 0.5}])),
            "[1.000, —, 2.000 ± 0.500]"
        );
    }
}
