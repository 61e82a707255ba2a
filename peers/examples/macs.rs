//! Instructions per multiply-add of the generated dual active set on a board: the f64 reference
//! (`codegen::oracle::Mpc` on the spec with method = "active_set", which runs
//! `codegen::solver::active_set::mpc::control_step` with the controller's warm start) replayed on the
//! dumped states, its multiply-adds per solve (`Outcome::macs.total()`), against the instructions per
//! solve that `peers/firmware/run.sh` measured (its `SOLVES` lines, `target/peers-<board>.solves`).
//!
//! `cd peers && cargo run --release --example macs [-- firmware/target/peers-zynq.solves]`
use codegen::oracle;
use nalgebra::DVector;
use serde_json::Value;
use std::collections::HashMap;

fn main() {
    let solves_path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "firmware/target/peers-zynq.solves".into());
    let mut measured: HashMap<String, Vec<u64>> = HashMap::new();
    for line in std::fs::read_to_string(&solves_path)
        .unwrap_or_default()
        .lines()
    {
        let Some(json) = line.strip_prefix("SOLVES ") else {
            continue;
        };
        let v: Value = serde_json::from_str(json).expect("a SOLVES line is JSON");
        if v["solver"] == "active_set" {
            let i = v["instructions"].as_array().expect("instructions");
            measured.insert(
                v["problem"].as_str().expect("problem").into(),
                i.iter().map(|x| x.as_u64().expect("a count")).collect(),
            );
        }
    }
    println!("| problem | multiply-adds per solve (median / max) | changes (median / max) | fallbacks | \\|U − U*\\|∞ / span (max) | worst measured solve: instructions / its multiply-adds | instructions per multiply-add at the worst solve | median over solves of instructions / multiply-adds | least-squares fit of instructions |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for name in ["paper", "paper-limits", "quadcopter", "hover"] {
        let spec = std::fs::read_to_string(format!("{}/{name}-active_set.toml", env!("OUT_DIR")))
            .expect("peers/build.rs writes the spec");
        let p = codegen::lower(&mpc_spec::load(&spec).expect("a valid spec")).expect("lowerable");
        let dump: Value = serde_json::from_str(
            &std::fs::read_to_string(format!("data/{name}.json")).expect("scripts/peers.sh dump"),
        )
        .expect("JSON");
        let nz = dump["nz"].as_u64().expect("nz") as usize;
        let horizon = dump["N"].as_u64().expect("N") as usize;
        let np = horizon * p.nu;
        let f = |v: &Value| -> Vec<f64> {
            v.as_array()
                .expect("an array")
                .iter()
                .map(|x| x.as_f64().expect("finite"))
                .collect()
        };
        let reference = f(&dump["reference"]);
        let window: Vec<DVector<f64>> = (0..horizon)
            .map(|k| DVector::from_column_slice(&reference[k * nz..(k + 1) * nz]))
            .collect();
        let mut mpc = oracle::Mpc::new(&p);
        let (mut macs, mut changes, mut fallbacks, mut error) =
            (Vec::new(), Vec::new(), 0, 0.0_f64);
        for s in dump["steps"].as_array().expect("steps") {
            let x0 = DVector::from_vec(f(&s["x0"]));
            mpc.solve(&x0, &window);
            let step = mpc.active_set_step().expect("an active-set step");
            macs.push(step.outcome.macs.total() as u64);
            changes.push(step.outcome.iterations);
            fallbacks += usize::from(step.fallback != codegen::ipm::Fallback::Solved);
            let z = f(&s["z_star"]);
            for (i, zi) in z.iter().enumerate().take(np) {
                let span = p.qp.u_max[i % p.nu] - p.qp.u_min[i % p.nu];
                error = error.max((mpc.plan()[i] - zi).abs() / span);
            }
        }
        let med = |v: &[u64]| {
            let mut v = v.to_vec();
            v.sort_unstable();
            v[v.len() / 2]
        };
        let mut ch = changes.clone();
        ch.sort_unstable();
        let (worst, ratio, median_ratio, fit) = match measured.get(name) {
            Some(m) if m.len() == macs.len() => {
                // Least squares: instructions = a + b·multiply-adds over the solves (b the marginal
                // instructions per multiply-add, a what the tally does not see).
                let n = m.len() as f64;
                let (mx, my) = (
                    macs.iter().sum::<u64>() as f64 / n,
                    m.iter().sum::<u64>() as f64 / n,
                );
                let sxy: f64 = macs
                    .iter()
                    .zip(m)
                    .map(|(&c, &i)| (c as f64 - mx) * (i as f64 - my))
                    .sum();
                let sxx: f64 = macs.iter().map(|&c| (c as f64 - mx).powi(2)).sum();
                let b = sxy / sxx;
                let k = (0..m.len()).max_by_key(|&k| m[k]).expect("solves");
                let mut r: Vec<f64> = m
                    .iter()
                    .zip(&macs)
                    .map(|(&i, &c)| i as f64 / c.max(1) as f64)
                    .collect();
                r.sort_by(|a, b| a.total_cmp(b));
                (
                    format!("{} / {} (solve {k})", m[k], macs[k]),
                    format!("{:.2}", m[k] as f64 / macs[k].max(1) as f64),
                    format!("{:.2}", r[r.len() / 2]),
                    format!("{:.0} + {b:.2} × multiply-adds", my - b * mx),
                )
            }
            _ => ("not measured".into(), "".into(), "".into(), "".into()),
        };
        println!(
            "| {name} | {} / {} | {} / {} | {fallbacks} | {error:.1e} | {worst} | {ratio} | {median_ratio} | {fit} |",
            med(&macs),
            macs.iter().max().expect("solves"),
            ch[ch.len() / 2],
            ch[ch.len() - 1],
        );
    }
}
