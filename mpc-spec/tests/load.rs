//! `load` accepts the shipped specs exactly as written and reports each mistake at its line, all at once.

use mpc_spec::*;

const PAPER: &str = include_str!("../../specs/paper.toml");

/// The paper spec with one line replaced: `(old, new)`.
fn edited(old: &str, new: &str) -> String {
    assert!(PAPER.contains(old), "the paper spec has no `{old}`");
    PAPER.replacen(old, new, 1)
}

/// The messages and 1-based lines of every diagnostic.
fn errors(src: &str) -> Vec<(String, usize)> {
    let diags = load(src).expect_err("the spec should be rejected");
    diags
        .iter()
        .map(|d| (d.message.clone(), d.line_col(src).map_or(0, |(l, _)| l)))
        .collect()
}

fn line_of(src: &str, needle: &str) -> usize {
    src.lines()
        .position(|l| l.contains(needle))
        .expect("needle")
        + 1
}

#[test]
fn paper_spec_is_accepted_as_written() {
    let spec = load(PAPER).unwrap();
    assert_eq!(
        spec.model,
        Model {
            kind: ModelKind::DoubleIntegrator { axes: 3 },
            dt: 0.0128
        }
    );
    assert_eq!((spec.nx(), spec.nu(), spec.ny()), (6, 3, 3));
    let m = &spec.mpc;
    assert_eq!(
        (m.horizon, m.iterations, m.method, m.step),
        (15, Iterations::Fixed(30), Method::Fgm, Step::Auto)
    );
    assert_eq!(m.q, Matrix::diagonal(&[150.0, 150.0, 150.0, 5.0, 5.0, 5.0]));
    assert_eq!(m.qf, m.q.scaled(50.0));
    assert_eq!(m.r, Matrix::diagonal(&[0.15; 3]));
    assert_eq!(
        (m.u_min.clone(), m.u_max.clone()),
        (vec![-10.0; 3], vec![10.0; 3])
    );
    assert_eq!(
        spec.kalman.as_ref().unwrap().noise,
        KalmanNoise::WhiteAcceleration {
            sigma_a: 0.15,
            sigma_meas: vec![0.3; 3]
        }
    );
    assert_eq!(
        spec.kalman.as_ref().unwrap().p0,
        Matrix::diagonal(&[1.0; 6])
    );
    assert_eq!(
        spec.kalman.as_ref().unwrap().filter,
        FilterKind::TimeVarying
    );
    assert_eq!(spec.codegen.scalar, Scalar::F32);
    assert_eq!(
        spec.spans.get("mpc.step").map(|s| &PAPER[s]),
        Some("\"auto\"")
    );
}

#[test]
fn shipped_specs_load() {
    let faithful = load(include_str!("../../specs/paper-faithful.toml")).unwrap();
    assert_eq!(
        (faithful.mpc.method, faithful.mpc.step),
        (Method::Gradient, Step::Fixed(0.04))
    );
    let initial = load(include_str!("../../specs/paper-initial.toml")).unwrap();
    assert_eq!(
        (
            initial.mpc.horizon,
            initial.mpc.iterations,
            initial.mpc.step
        ),
        (5, Iterations::Fixed(100), Step::Fixed(0.01))
    );
    assert_eq!(initial.mpc.qf, initial.mpc.q.scaled(10.0));
}

#[test]
fn without_qf_the_terminal_weight_is_q() {
    let spec = load(&edited(
        "qf_scale = 50                # Qf = 50 Q; or give `qf` as a list / matrix\n",
        "",
    ))
    .unwrap();
    assert_eq!(spec.mpc.qf, spec.mpc.q);
}

#[test]
fn full_matrices_and_linear_models() {
    let src = r#"
[model]
type = "linear"
dt = 0.1
a = [[1, 0.1], [0, 1]]
b = [[0.005], [0.1]]
c = [[1, 0]]
[mpc]
horizon = 4
iterations = 10
q = [[2, 0.5], [0.5, 1]]
r = 0.1
qf = [[20, 5], [5, 10]]
u_min = [-1]
u_max = [1]
[kalman]
q = [[1e-4, 0], [0, 1e-3]]
r = [[0.01]]
p0 = [2, 3]
filter = "steady_state"
[codegen]
scalar = "f64"
"#;
    let spec = load(src).unwrap();
    assert_eq!((spec.nx(), spec.nu(), spec.ny()), (2, 1, 1));
    assert_eq!(
        spec.mpc.q,
        Matrix::from_rows(&[vec![2.0, 0.5], vec![0.5, 1.0]])
    );
    assert_eq!(spec.mpc.r, Matrix::diagonal(&[0.1]));
    assert_eq!(
        spec.kalman.as_ref().unwrap().p0,
        Matrix::diagonal(&[2.0, 3.0])
    );
    assert_eq!(spec.codegen.scalar, Scalar::F64);
}

#[test]
fn every_mistake_is_reported_at_its_line() {
    let src = edited("horizon = 15", "horizon = 0")
        .replacen(
            "q = [150, 150, 150, 5, 5, 5]",
            "q = [150, 150, 150, 5, 5]",
            1,
        )
        .replacen("method = \"fgm\"", "method = \"newton\"", 1)
        .replacen("sigma_a = 0.15", "sigma_a = -0.15", 1);
    let errs = errors(&src);
    let expect = [
        ("`mpc.horizon` must be between 1 and 250", "horizon = 0"),
        (
            "unknown value \"newton\" for `mpc.method`",
            "method = \"newton\"",
        ),
        (
            "`mpc.q` must be 6×6 (nx = 6), found a diagonal of 5 entries",
            "q = [150, 150, 150, 5, 5]",
        ),
        (
            "`kalman.sigma_a` must be positive, found -0.15",
            "sigma_a = -0.15",
        ),
    ];
    assert_eq!(errs.len(), expect.len(), "{errs:?}");
    for ((msg, line), (want, needle)) in errs.iter().zip(expect) {
        assert_eq!(msg, want);
        assert_eq!(*line, line_of(&src, needle), "{msg}");
    }
}

#[test]
fn unknown_keys_get_a_suggestion() {
    let src = edited("iterations = 30", "iteratons = 30");
    let diags = load(&src).unwrap_err();
    let d = diags
        .iter()
        .find(|d| d.message.starts_with("unknown key"))
        .unwrap();
    assert_eq!(d.message, "unknown key `iteratons` in `[mpc]`");
    assert_eq!(d.note.as_deref(), Some("hint: did you mean `iterations`?"));
    assert_eq!(d.line_col(&src), Some((line_of(&src, "iteratons"), 1)));
    // The misspelling is reported once, not again as a missing `iterations`.
    assert_eq!(diags.iter().count(), 1);
    let tables = errors(&format!("{PAPER}\n[solver]\nx = 1\n"));
    assert_eq!(tables[0].0, "unknown table `solver` in the spec");
}

#[test]
fn bounds_must_be_ordered_and_sized() {
    let errs = errors(&edited("u_min = [-10, -10, -10]", "u_min = [-10, 20, -10]"));
    assert_eq!(errs[0].0, "input 1 has `u_min` 20 not below `u_max` 10");
    let errs = errors(&edited("u_max = [10, 10, 10]", "u_max = [10, 10]"));
    assert_eq!(
        errs[0].0,
        "`mpc.u_max` must have 3 entries (nu = 3), found 2"
    );
}

#[test]
fn qf_and_qf_scale_exclude_each_other() {
    let errs = errors(&edited(
        "qf_scale = 50",
        "qf = [1, 1, 1, 1, 1, 1]\nqf_scale = 50",
    ));
    assert_eq!(errs[0].0, "`qf` and `qf_scale` cannot both be given");
}

#[test]
fn weights_must_be_symmetric_and_r_definite() {
    let errs = errors(&edited(
        "q = [150, 150, 150, 5, 5, 5]",
        "q = [[1,2,0,0,0,0],[0,1,0,0,0,0],[0,0,1,0,0,0],[0,0,0,1,0,0],[0,0,0,0,1,0],[0,0,0,0,0,1]]",
    ));
    assert_eq!(errs[0].0, "`mpc.q` must be symmetric");
    let errs = errors(&edited("r = [0.15, 0.15, 0.15]", "r = [0.15, 0, 0.15]"));
    assert_eq!(errs[0].0, "`mpc.r` must be positive definite");
    let errs = errors(&edited("r = [0.15, 0.15, 0.15]", "r = [0.15, -1, 0.15]"));
    assert_eq!(errs[0].0, "the diagonal of `mpc.r` must be non-negative");
}

#[test]
fn model_types_take_their_own_keys() {
    let errs = errors(&edited("axes = 3", "axes = 3\na = [[1]]"));
    assert_eq!(
        errs[0].0,
        "a `double_integrator` model takes no `a`, `b` or `c`"
    );
    let errs = errors(&edited("type = \"double_integrator\"", "type = \"linear\""));
    assert!(errs
        .iter()
        .any(|e| e.0 == "a `linear` model takes no `axes`"));
    assert!(errs.iter().any(|e| e.0 == "missing key `a` in `[model]`"));
    let src = "[model]\ntype = \"linear\"\ndt = 1\na = [[1, 0], [0, 1], [1, 1]]\nb = [[1], [1]]\nc = [[1, 0]]\n[mpc]\nhorizon = 2\niterations = 2\nq = 1\nr = 1\nu_min = [-1]\nu_max = [1]\n[kalman]\nq = 1\nr = 1\n";
    assert_eq!(
        errors(src)[0].0,
        "`model.a` must be 3×3 (nx × nx, nx the number of rows of `a`), found 3×2"
    );
}

#[test]
fn noise_models_are_exclusive_and_sized() {
    let errs = errors(&edited("sigma_a = 0.15", "sigma_a = 0.15\nq = 1\nr = 1"));
    assert_eq!(
        errs[0].0,
        "give either `sigma_a` and `sigma_meas`, or `q` and `r`, not both"
    );
    let errs = errors(&edited(
        "sigma_meas = [0.3, 0.3, 0.3]",
        "sigma_meas = [0.3, 0.3]",
    ));
    assert_eq!(
        errs[0].0,
        "`kalman.sigma_meas` must be a number or a list of 3 (ny) numbers"
    );
    let errs = errors(&edited(
        "sigma_a = 0.15               # process noise (paper eq. 3), m/s^2\n",
        "",
    ));
    assert_eq!(errs[0].0, "missing key `sigma_a` in `[kalman]`");
}

#[test]
fn wrong_types_and_syntax_are_located() {
    let errs = errors(&edited("dt = 0.0128", "dt = \"fast\""));
    assert_eq!(
        errs[0],
        ("`model.dt` must be a number, found string".to_string(), 5)
    );
    let errs = errors(&edited("horizon = 15", "horizon = 15.5"));
    assert_eq!(
        errs[0].0,
        "`mpc.horizon` must be a whole number, found float"
    );
    let errs = errors(&edited("dt = 0.0128", "dt = "));
    assert!(errs[0].0.starts_with("invalid TOML"), "{errs:?}");
    assert_eq!(errs[0].1, 5);
    let errs = errors(&edited(
        "q = [150, 150, 150, 5, 5, 5]",
        "q = [[150, 150], [150]]",
    ));
    assert_eq!(errs[0].0, "the rows of `mpc.q` differ in length");
    let errs = errors(&edited("step = \"auto\"", "step = \"fast\""));
    assert_eq!(errs[0].0, "unknown value \"fast\" for `mpc.step`");
    let errs = errors(&edited("dt = 0.0128", "dt = nan"));
    assert_eq!(errs[0].0, "`model.dt` must be a finite number");
}

#[test]
fn missing_tables_are_reported() {
    let errs = errors("[model]\ntype = \"double_integrator\"\naxes = 1\ndt = 0.1\n");
    let msgs: Vec<&str> = errs.iter().map(|e| e.0.as_str()).collect();
    // `[kalman]` is optional: without it the controller takes the measured state.
    assert_eq!(msgs, ["missing table `[mpc]`"]);
}

#[test]
fn disturbance_is_optional_and_sized() {
    assert_eq!(load(PAPER).unwrap().kalman.unwrap().disturbance, None);
    let spec = load(&edited(
        "filter = \"time_varying\"",
        "filter = \"time_varying\"\ndisturbance = 0.01",
    ))
    .unwrap();
    assert_eq!(
        spec.kalman.as_ref().unwrap().disturbance,
        Some(vec![0.01; 3])
    );
    let errs = errors(&edited(
        "filter = \"time_varying\"",
        "filter = \"time_varying\"\ndisturbance = [0.01, 0.02]",
    ));
    assert_eq!(
        errs[0].0,
        "`kalman.disturbance` must be a number or a list of 3 (nu) numbers"
    );
    let errs = errors(&edited(
        "filter = \"time_varying\"",
        "filter = \"time_varying\"\ndisturbance = 0",
    ));
    assert_eq!(
        errs[0].0,
        "the diagonal of `kalman.disturbance` must be positive"
    );
}

/// The linear model of `full_matrices_and_linear_models`, with `extra` after `dt`.
fn linear_with(extra: &str) -> String {
    format!(
        "[model]\ntype = \"linear\"\ndt = 0.1\n{extra}\na = [[0, 1], [0, 0]]\nb = [[0], [1]]\nc = [[1, 0]]\n[mpc]\nhorizon = 4\niterations = 10\nq = 1\nr = 0.1\nu_min = [-1]\nu_max = [1]\n[kalman]\nq = [1e-4, 1e-3]\nr = 0.01\n"
    )
}

#[test]
fn linear_models_are_discrete_unless_said_continuous() {
    let time = |src: &str| match load(src).unwrap().model.kind {
        ModelKind::Linear { time, .. } => time,
        other => panic!("{other:?}"),
    };
    assert_eq!(time(&linear_with("")), TimeDomain::Discrete);
    assert_eq!(
        time(&linear_with("time = \"discrete\"")),
        TimeDomain::Discrete
    );
    assert_eq!(
        time(&linear_with("time = \"continuous\"")),
        TimeDomain::Continuous
    );
}

#[test]
fn time_is_spelled_and_belongs_to_linear_models() {
    let src = linear_with("time = \"contiuous\"");
    let diags = load(&src).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert_eq!(d.message, "unknown value \"contiuous\" for `model.time`");
    assert_eq!(
        d.note.as_deref(),
        Some("hint: did you mean `continuous`? (expected one of `discrete`, `continuous`)")
    );
    assert_eq!(d.line_col(&src), Some((line_of(&src, "contiuous"), 8)));
    assert_eq!(diags.iter().count(), 1);

    let src = edited("dt = 0.0128", "dt = 0.0128\ntime = \"continuous\"");
    let errs = errors(&src);
    assert_eq!(
        errs,
        [(
            "a `double_integrator` model takes no `time`".to_string(),
            line_of(&src, "time = ")
        )]
    );

    let src = linear_with("tiem = \"continuous\"");
    let diags = load(&src).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert_eq!(d.message, "unknown key `tiem` in `[model]`");
    assert_eq!(d.note.as_deref(), Some("hint: did you mean `time`?"));
}

/// `qf = "lqr"` is read as the Riccati terminal weight; any other word is an error at the value naming
/// "lqr" in its hint.
#[test]
fn qf_takes_the_word_lqr() {
    let spec = load(&edited("qf_scale = 50", "qf = \"lqr\"")).unwrap();
    assert!(spec.mpc.qf_lqr);
    assert!(!spec.mpc.qf_on_state);
    assert!(!load(PAPER).unwrap().mpc.qf_lqr);
    let src = edited("qf_scale = 50", "qf = \"lqe\"");
    let diags = load(&src).expect_err("an unknown word");
    let d = &diags.0[0];
    assert_eq!(d.message, "unknown value \"lqe\" for `mpc.qf`");
    assert_eq!(&src[d.span.clone().unwrap()], "\"lqe\"");
    assert!(
        d.note.as_deref().unwrap().contains("\"lqr\""),
        "{:?}",
        d.note
    );
    // With `qf_scale` it is the same conflict as a written matrix.
    let both = edited("qf_scale = 50", "qf = \"lqr\"\nqf_scale = 50");
    assert_eq!(
        errors(&both)[0].0,
        "`qf` and `qf_scale` cannot both be given"
    );
}
