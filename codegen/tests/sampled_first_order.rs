//! `accuracy` for the first-order methods: with `[mpc.region]`, the fast gradient method's iteration
//! count is measured on the region's sample (`codegen::sampling`, the same certificate as the
//! interior-point method's) and then checked here on a fresh sample against an independent exact
//! solution (projected gradient run to a KKT residual of 1e-12, `oracle::exact_solution`), cold and in
//! warm closed loops.
#![allow(non_snake_case)]

use codegen::oracle::{exact_solution, iterate};
use codegen::solver::{Algorithm, Fgm};
use codegen::{generate_from_source, lower, Opt};
use mpc_spec::load;
use nalgebra::DVector;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The paper's spec with its `iterations = 30` replaced by `auto` certified on a region: the reference
/// flight's envelope (specs/paper-limits.toml's region), speeds up to 4 m/s.
fn paper_with_region(iterations: &str, extra: &str) -> String {
    include_str!("../../specs/paper.toml")
        .replace("iterations = 30", &format!("iterations = {iterations}"))
        .replace(
            "[kalman]",
            &format!(
                "{extra}\n[mpc.region]\nx_min = [-7.0, -5.0, 0.0, -4.0, -4.0, -4.0]\nx_max = [11.0, 11.0, 16.0, 4.0, 4.0, 4.0]\n\n[kalman]"
            ),
        )
}

/// |U − U*|∞ over the input span.
fn error(U: &DVector<f64>, exact: &DVector<f64>, span: f64) -> f64 {
    (U - exact).amax() / span
}

#[test]
fn auto_on_a_region_reaches_accuracy_on_a_fresh_sample() {
    let spec = load(&paper_with_region("\"auto\"", "")).unwrap();
    let p = lower(&spec).unwrap();
    let qp = &p.qp;
    let e = qp.evidence.as_ref().expect("a region is sampled");
    assert_eq!(e.method, mpc_spec::Method::Fgm);
    assert!(e.auto);
    assert_eq!(qp.iterations, e.iterations);
    assert!(e.iterations >= e.worst_needed);
    assert!(e.worst_error <= qp.accuracy, "{}", e.worst_error);
    println!(
        "fgm on the paper's region: cold worst {} (median {}), warm worst {} (median {}), iterations {}, {:.2e} multiply-adds sampled",
        e.cold_worst, e.cold_median, e.warm_worst, e.warm_median, e.iterations, e.sample_macs
    );
    // A fresh sample, another seed: cold cases from the rest plan and warm closed loops.
    let span = 20.0;
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let (lo, hi) = (e.region.x_min.clone(), e.region.x_max.clone());
    let draw = |rng: &mut ChaCha8Rng, lo: &[f64], hi: &[f64]| {
        DVector::from_iterator(
            lo.len(),
            lo.iter().zip(hi).map(|(a, b)| rng.gen_range(*a..=*b)),
        )
    };
    let f_of = |x0: &DVector<f64>, r: &DVector<f64>| {
        let xref = DVector::from_fn(qp.N * qp.nz, |i, _| r[i % qp.nz]);
        &qp.Fx * x0 - &qp.Fr * xref
    };
    let mut worst: f64 = 0.0;
    for _ in 0..40 {
        let x0 = draw(&mut rng, &lo, &hi);
        let r = draw(&mut rng, &e.region.reference_min, &e.region.reference_max);
        let f = f_of(&x0, &r);
        let U = iterate(qp, &f, qp.rest_plan(), qp.iterations);
        let exact = exact_solution(qp, &f, 1e-12, 200_000);
        worst = worst.max(error(&U, &exact, span));
    }
    for _ in 0..4 {
        let mut x = draw(&mut rng, &lo, &hi);
        let r = draw(&mut rng, &e.region.reference_min, &e.region.reference_max);
        let mut plan = qp.rest_plan();
        for _ in 0..40 {
            let f = f_of(&x, &r);
            let mut start = plan.clone();
            let n = start.len();
            start.as_mut_slice().copy_within(3.., 0);
            start.rows_mut(n - 3, 3).copy_from(&qp.rest_input());
            plan = iterate(qp, &f, start, qp.iterations);
            let exact = exact_solution(qp, &f, 1e-12, 200_000);
            worst = worst.max(error(&plan, &exact, span));
            x = &p.F * &x + &p.G * plan.rows(0, 3);
        }
    }
    println!("fresh sample: worst |U − U*|∞ / span = {worst:.3e}");
    assert!(worst <= qp.accuracy, "{worst:.3e} > {}", qp.accuracy);
}

#[test]
fn a_tighter_accuracy_needs_more_iterations() {
    let count = |accuracy: &str| {
        let spec = load(&paper_with_region(
            "\"auto\"",
            &format!("accuracy = {accuracy}"),
        ))
        .unwrap();
        lower(&spec).unwrap().qp.iterations
    };
    let (loose, tight) = (count("1e-2"), count("1e-5"));
    assert!(loose < tight, "{loose} vs {tight}");
}

#[test]
fn tolerance_is_a_floor_of_auto() {
    // The a priori bound of `tolerance = 1e-8` asks more than the sample does for 1e-3: both promises hold.
    let spec = load(&paper_with_region("\"auto\"", "tolerance = 1e-8")).unwrap();
    let p = lower(&spec).unwrap();
    let e = p.qp.evidence.as_ref().unwrap();
    let bound = Fgm.rate(&p.qp.parameters()).unwrap().iterations_for(1e-8);
    assert!(bound > e.worst_needed, "{bound} vs {}", e.worst_needed);
    assert_eq!(p.qp.iterations, bound);
}

#[test]
fn fixed_count_below_the_sample_warns_and_the_certificate_says_so() {
    let g = generate_from_source(&paper_with_region("3", ""), &Opt::default()).unwrap();
    let e = g.certificate.sampled.as_ref().unwrap();
    assert!(e.worst_needed > 3);
    assert!(e.worst_error > g.problem.qp.accuracy);
    let warning = g
        .warnings
        .iter()
        .map(|d| d.message.clone())
        .find(|m| m.contains("sampled cases of `[mpc.region]`"))
        .expect("a warning for the count below the sample's need");
    assert!(warning.contains("`iterations = 3`"), "{warning}");
    // The report module carries the evidence, and the first-order bound stays beside it.
    let text = g.tokens.to_string();
    assert!(text.contains("SAMPLED_COLD_WORST"), "no sampled constants");
    assert!(text.contains("pub const RATE"), "the a priori rate is gone");
}

#[test]
fn accuracy_without_a_region_is_not_certified_and_says_so() {
    let src =
        include_str!("../../specs/paper.toml").replace("[kalman]", "accuracy = 1e-4\n\n[kalman]");
    let g = generate_from_source(&src, &Opt::default()).unwrap();
    assert!(g.certificate.sampled.is_none());
    assert!(
        g.warnings.iter().any(|d| d
            .message
            .contains("`accuracy` is not certified without `[mpc.region]`")),
        "{:?}",
        g.warnings.iter().map(|d| &d.message).collect::<Vec<_>>()
    );
}

#[test]
fn auto_needs_tolerance_or_a_region() {
    let src =
        include_str!("../../specs/paper.toml").replace("iterations = 30", "iterations = \"auto\"");
    let err = load(&src).unwrap_err();
    assert!(
        err.iter()
            .any(|d| d.message.contains("needs `tolerance` or `[mpc.region]`")),
        "{err:?}"
    );
    assert!(load(&paper_with_region("\"auto\"", "")).is_ok());
}
