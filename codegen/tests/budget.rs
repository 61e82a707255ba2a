//! Budgets: a spec past what a build should spend is refused, before the work, with a located error; the
//! predictions are on the certificate (`mpcc check` prints them).

use codegen::{generate_from_source, Opt};

const PAPER: &str = include_str!("../../specs/paper.toml");

fn error(src: &str) -> (String, String) {
    let Err(diags) = generate_from_source(src, &Opt::default()) else {
        panic!("the spec was accepted");
    };
    let d = diags.iter().next().unwrap();
    let at = d.span.clone().map_or(String::new(), |s| src[s].to_string());
    (d.message.clone(), at)
}

#[test]
fn thousands_of_axes_are_refused_before_any_matrix_is_formed() {
    // axes = 1000 used to allocate 7.2 GB (Q_blk alone is (15·2000)² numbers); 100,000 allocated 320 GB in
    // the spec's own matrices and is now over `model.axes`'s limit.
    let (axes, at_least) = (1000, 7.0e9);
    let src = PAPER
        .replace("axes = 3", &format!("axes = {axes}"))
        .replace("q = [150, 150, 150, 5, 5, 5]", "q = 150")
        .replace("r = [0.15, 0.15, 0.15]", "r = 0.15")
        .replace(
            "u_min = [-10, -10, -10]",
            &format!("u_min = [{}]", vec!["-10"; axes].join(", ")),
        )
        .replace(
            "u_max = [10, 10, 10]",
            &format!("u_max = [{}]", vec!["10"; axes].join(", ")),
        )
        .replace("sigma_meas = [0.3, 0.3, 0.3]", "sigma_meas = 0.3");
    let Err(diags) = generate_from_source(&src, &Opt::default()) else {
        panic!("axes = {axes} was accepted");
    };
    let d = diags.iter().next().unwrap();
    assert!(
        d.message
            .starts_with("this controller is too large to build: lowering would form "),
        "{}",
        d.message
    );
    assert_eq!(&src[d.span.clone().unwrap()], axes.to_string());
    let predicted: f64 = d.message
        ["this controller is too large to build: lowering would form ".len()..]
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(predicted * 1e9 >= at_least, "{}", d.message);
    let src = PAPER.replace("axes = 3", "axes = 100000");
    let diags = mpc_spec::load(&src).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert_eq!(d.message, "`model.axes` must be between 1 and 1000");
    assert_eq!(&src[d.span.clone().unwrap()], "100000");
}

/// A dense `linear` plant with nx states, four inputs and four outputs, a time-varying filter.
fn dense(nx: usize) -> String {
    let row = |i: usize, f: &dyn Fn(usize) -> f64, n: usize| {
        let items: Vec<String> = (0..n)
            .map(|j| format!("{:.4}", f(j) + if i == j { 0.9 } else { 0.0 }))
            .collect();
        format!("[{}]", items.join(", "))
    };
    let matrix = |rows: usize, cols: usize, scale: f64, diagonal: bool| {
        let rows: Vec<String> = (0..rows)
            .map(|i| {
                row(
                    if diagonal { i } else { usize::MAX },
                    &|j| scale * (((i * 7 + j * 13) % 17) as f64 / 17.0 - 0.5),
                    cols,
                )
            })
            .collect();
        format!("[{}]", rows.join(", "))
    };
    let identity = |n: usize, v: f64| {
        let rows: Vec<String> = (0..n)
            .map(|i| {
                let items: Vec<String> = (0..n)
                    .map(|j| if i == j { format!("{v}") } else { "0".into() })
                    .collect();
                format!("[{}]", items.join(", "))
            })
            .collect();
        format!("[{}]", rows.join(", "))
    };
    format!(
        "[model]\ntype = \"linear\"\ndt = 0.1\na = {}\nb = {}\nc = {}\n[mpc]\nhorizon = 10\niterations = 20\nq = 1\nr = 0.1\nu_min = [-1, -1, -1, -1]\nu_max = [1, 1, 1, 1]\n[kalman]\nq = {}\nr = {}\n",
        matrix(nx, nx, 0.04, true),
        matrix(nx, 4, 0.2, false),
        matrix(4, nx, 0.1, true),
        identity(nx, 0.01),
        identity(4, 0.04),
    )
}

#[test]
fn a_module_rustc_could_not_build_in_reason_is_refused_before_emission() {
    // nx = 12 builds (rustc measured 7 s, 230 MB); nx = 48 unrolls a dense covariance update of about
    // half a million multiply-adds.
    let small = generate_from_source(&dense(12), &Opt::default()).unwrap();
    let cost = small.certificate.build_cost;
    assert!(
        cost.rustc_seconds > 2.0 && cost.rustc_seconds < 30.0,
        "{cost:?}"
    );
    assert!(cost.emitted_unrolled >= small.certificate.resources.macs_filter);
    let src = dense(48);
    let (message, at) = error(&src);
    assert!(
        message.starts_with("this controller is too large to build: rustc would "),
        "{message}"
    );
    assert!(at.starts_with("[["), "the error points at `a`: {at}");
}

#[test]
fn the_solver_loop_analysis_is_skipped_past_its_budget_instead_of_hanging() {
    // N = 100 with 100,000 iterations: unrolling every iteration of the solver's loop would take about 3e12
    // multiply-adds (it used to run for minutes); the analysis is skipped and the certificate says so.
    let src = PAPER
        .replace("horizon = 15", "horizon = 100")
        .replace("iterations = 30", "iterations = 100000");
    let g = generate_from_source(&src, &Opt::default()).unwrap();
    assert_eq!(g.certificate.mpc.solver_spectral_radius, None);
    assert!(g.certificate.mpc.spectral_radius < 1.0);
    // The paper's own spec is well inside every budget and keeps its analysis.
    let paper = generate_from_source(PAPER, &Opt::default()).unwrap();
    assert!(paper.certificate.mpc.solver_spectral_radius.is_some());
    assert!(paper.certificate.build_cost.rustc_bytes < 0.5e9);
}

#[test]
fn a_forced_emission_past_the_budget_is_an_error_at_the_emission() {
    // Unrolled code at the longest horizon: about 1.3 million unrolled multiply-adds, where the cost
    // model's own choice builds.
    // At N = 250 the paper's 30 iterations guarantee nothing (a located error of their own): the count
    // the default tolerance needs.
    let src = PAPER
        .replace("horizon = 15", "horizon = 250")
        .replace("iterations = 30", "iterations = 1227")
        .replace(
            "scalar = \"f32\"",
            "scalar = \"f32\"\nemission = \"unrolled\"",
        );
    let Err(diags) = generate_from_source(&src, &Opt::default()) else {
        panic!("the spec was accepted");
    };
    let d = diags.iter().next().unwrap();
    assert!(
        d.message
            .starts_with("this controller is too large to build: rustc would "),
        "{}",
        d.message
    );
    assert_eq!(&src[d.span.clone().unwrap()], "\"unrolled\"");
    let hint = d.note.clone().unwrap_or_default();
    assert!(
        hint.contains("the cost model's own choice, `emission = \""),
        "{hint}"
    );
    // Without the forced emission it builds (its own choice is within the budget).
    let own = src.replace("\nemission = \"unrolled\"", "");
    let g = generate_from_source(&own, &Opt::default()).unwrap();
    assert!(codegen::budget::over(&g.certificate.build_cost).is_none());
}
