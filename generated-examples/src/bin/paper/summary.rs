//! From runs to `summary.json`: one JSON object per controller and seed, then mean ± standard
//! deviation over seeds, number by number.

use flight_sim::metrics::{gust, gust_settling, rms_over, StepMetrics, GUST_SETTLE, SETTLE_BAND};
use flight_sim::{Disturbance, DT};
use serde_json::{json, Map, Value};

use crate::run::Run;

fn axes<T>(f: impl Fn(usize) -> T) -> [T; 3] {
    core::array::from_fn(f)
}

/// The figures of a disturbance on `[start, end)`, from the disturbed run and the calm run of the
/// same controller and seed: the paper's three (Y RMSE from 3 s after the onset to the end, the
/// recovery time and the Y RMSE after it, `metrics::gust`), the times to get the disturbance's
/// own effect on Y back under 0.1 m after the onset and after the end and its largest value
/// (`metrics::gust_settling`), and the RMSE per axis over the same window as the first.
fn disturbed(disturbed: &Run, calm: &Run, start: f64, end: f64) -> Value {
    let axis = |run: &Run, i: usize| run.error.iter().map(|e| e[i]).collect::<Vec<f64>>();
    let (y_gust, y_calm) = (axis(disturbed, 1), axis(calm, 1));
    let g = gust(DT, &y_gust, &y_calm, start, end);
    let s = gust_settling(DT, &y_gust, &y_calm, start, end, SETTLE_BAND);
    json!({
        "rmse_y_during_m": g.rmse_y_during,
        "recovery_time_s": g.recovery_time,
        "rmse_y_after_m": g.rmse_y_after,
        "settle_after_onset_s": s.settle_after_onset,
        "settle_after_end_s": s.settle_after_end,
        "max_effect_y_m": s.max_effect,
        "rmse_during_m": axes(|i| rms_over(DT, &axis(disturbed, i), start + GUST_SETTLE, end)),
    })
}

/// The figures of one controller for one seed, from its flight, gust, wind and step runs; `wind`
/// is the wind's window `[start, end)`.
pub fn per_seed(flight: &Run, gusty: &Run, windy: &Run, step: &Run, wind: (f64, f64)) -> Value {
    let t = &flight.table2;
    let s: &[StepMetrics; 3] = &step.step;
    let mut v = json!({
        "max_abs_error": t.max_abs_error,
        "rmse": t.rmse,
        "iae": t.iae,
        "ise": t.ise,
        "itae": t.itae,
        "itse": t.itse,
        "smoothness": t.smoothness,
        "variance": t.variance,
        "solve_time_us": {
            "mean": flight.solve_us_mean,
            "median": flight.solve_us_median,
            "p99": flight.solve_us_p99,
            "max": flight.solve_us_max,
        },
        "step": {
            "rise_time_s": axes(|i| s[i].rise_time),
            "peak_time_s": axes(|i| s[i].peak_time),
            "overshoot_pct": axes(|i| s[i].overshoot_pct),
            "settling_time_s": axes(|i| s[i].settling_time),
        },
        "gust": disturbed(gusty, flight, Disturbance::GUST.start, Disturbance::GUST.end),
        "wind": disturbed(windy, flight, wind.0, wind.1),
        // Readings the generated filter's screening rejected (the default gate is meant to reject none
        // of the nominal flight's).
        "rejected_measurements": {
            "flight": flight.rejected,
            "gust": gusty.rejected,
            "wind": windy.rejected,
            "step": step.rejected,
        },
    });
    if let Some(gap) = flight.gap.filter(|g| g.count > 0) {
        let n = gap.count as f64;
        v["qp_gap"] = json!({
            "u_dist_mean": gap.u_dist_sum / n,
            "u_dist_max": gap.u_dist_max,
            "u_dist_rel": gap.u_dist_sum / gap.u_star_sum.max(f64::MIN_POSITIVE),
            "cost_gap_mean": gap.cost_gap_sum / n,
            "cycles_compared": n,
        });
    }
    v
}

/// Merges same-shaped values over seeds: every number becomes `{mean, std}` (sample standard
/// deviation; 0 for one value) over the seeds where it is defined, `null` where it never is.
/// A single value is returned as it is.
pub fn aggregate(values: &[Value]) -> Value {
    if values.len() == 1 {
        return values[0].clone();
    }
    match values.first() {
        Some(Value::Object(first)) => {
            let mut out = Map::new();
            for key in first.keys() {
                let column: Vec<Value> = values
                    .iter()
                    .map(|v| v.get(key).cloned().unwrap_or(Value::Null))
                    .collect();
                out.insert(key.clone(), aggregate(&column));
            }
            Value::Object(out)
        }
        Some(Value::Array(first)) => Value::Array(
            (0..first.len())
                .map(|i| {
                    let column: Vec<Value> = values
                        .iter()
                        .map(|v| v.get(i).cloned().unwrap_or(Value::Null))
                        .collect();
                    aggregate(&column)
                })
                .collect(),
        ),
        _ => {
            let xs: Vec<f64> = values.iter().filter_map(Value::as_f64).collect();
            if xs.is_empty() {
                return Value::Null;
            }
            let (mean, std) = mean_std(&xs);
            json!({ "mean": mean, "std": std })
        }
    }
}

/// Mean and sample standard deviation (0 for fewer than two values).
pub fn mean_std(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    if xs.len() < 2 || xs.iter().all(|x| *x == xs[0]) {
        // Identical values (a deterministic run repeated) have no spread, whatever the rounding
        // of the mean.
        return (if xs.len() < 2 { mean } else { xs[0] }, 0.0);
    }
    let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

/// A number, or `{mean, std}`, as (mean, std).
pub fn number(v: &Value) -> Option<(f64, Option<f64>)> {
    match v {
        Value::Number(n) => n.as_f64().map(|x| (x, None)),
        Value::Object(o) => Some((
            o.get("mean")?.as_f64()?,
            o.get("std").and_then(Value::as_f64),
        )),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_sample_std_by_hand() {
        // 2, 4, 4, 4, 5, 5, 7, 9: mean 5, sum of squares 32, sample variance 32/7.
        let (m, s) = mean_std(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]);
        assert_eq!(m, 5.0);
        assert!((s - (32.0f64 / 7.0).sqrt()).abs() < 1e-12);
        assert_eq!(mean_std(&[3.0]), (3.0, 0.0));
        assert_eq!(mean_std(&[0.1; 50]), (0.1, 0.0));
    }

    #[test]
    fn aggregate_keeps_the_shape_and_skips_undefined_values() {
        let a =
            json!({"rmse": [1.0, 2.0, 3.0], "gust": {"recovery_time_s": 2.0}, "t": {"mean": 1.0}});
        let b =
            json!({"rmse": [3.0, 2.0, 1.0], "gust": {"recovery_time_s": null}, "t": {"mean": 3.0}});
        let m = aggregate(&[a.clone(), b]);
        assert_eq!(m["rmse"][0], json!({"mean": 2.0, "std": 2f64.sqrt()}));
        assert_eq!(m["rmse"][1], json!({"mean": 2.0, "std": 0.0}));
        assert_eq!(
            m["gust"]["recovery_time_s"],
            json!({"mean": 2.0, "std": 0.0})
        );
        assert_eq!(number(&m["t"]["mean"]), Some((2.0, Some(2f64.sqrt()))));
        // One seed: the plain numbers.
        assert_eq!(aggregate(std::slice::from_ref(&a)), a);
        assert_eq!(aggregate(&[json!(null), json!(null)]), Value::Null);
    }
}
