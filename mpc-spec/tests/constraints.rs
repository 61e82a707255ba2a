//! The keys of issue 17: state, move and row constraints, `accuracy`, `[mpc.region]` and `method = "ipm"`;
//! each accepted as documented, each mistake reported at the value (or the entry) that makes it.

use mpc_spec::*;

/// A linear plant, nx = 2, nu = 1, state feedback, `method = "ipm"`, plus `extra` lines in `[mpc]` (and
/// whatever tables follow them).
fn ipm(extra: &str) -> String {
    with_method("method = \"ipm\"\n", extra)
}

/// The same plant with the method line `method` (empty: the default).
fn with_method(method: &str, extra: &str) -> String {
    format!(
        r#"[model]
type = "linear"
dt = 0.1
a = [[1, 0.1], [0, 1]]
b = [[0.005], [0.1]]

[mpc]
horizon = 10
iterations = 20
{method}q = 1
r = 0.1
u_min = [-1]
u_max = [1]
{extra}"#
    )
}

/// The one diagnostic of `src`: its message, the text its span covers, and its hint.
fn only_error(src: &str) -> (String, String, Option<String>) {
    let diags = load(src).expect_err("the spec should be rejected");
    let all: Vec<_> = diags.iter().collect();
    assert_eq!(all.len(), 1, "{diags:#?}");
    let d = all[0];
    let span = d.span.clone().expect("located");
    (d.message.clone(), src[span].to_string(), d.note.clone())
}

/// Every diagnostic of `src`: message and spanned text.
fn errors(src: &str) -> Vec<(String, String)> {
    let diags = load(src).expect_err("the spec should be rejected");
    diags
        .iter()
        .map(|d| (d.message.clone(), src[d.span.clone().unwrap()].to_string()))
        .collect()
}

#[test]
fn without_the_new_keys_nothing_is_constrained() {
    let spec = load(&with_method("", "")).unwrap();
    assert_eq!(spec.mpc.constraints, Constraints::default());
    assert!(!spec.mpc.constraints.any());
    assert_eq!(spec.mpc.accuracy, DEFAULT_ACCURACY);
    assert_eq!(spec.mpc.region, Region::default());
    // The default is the compiler's choice.
    assert_eq!(spec.mpc.method, Method::Auto);
    assert_eq!(spec.mpc.method_requested, Method::Auto);
}

#[test]
fn ipm_is_a_method() {
    let spec = load(&ipm("")).unwrap();
    assert_eq!(spec.mpc.method, Method::Ipm);
    assert!(!Method::Ipm.box_only());
}

#[test]
fn state_bounds_take_infinities_on_their_open_side() {
    let spec = load(&ipm(
        "x_min = [-inf, -2]\nx_max = [1.5, +inf]\nx_soft = 100\n",
    ))
    .unwrap();
    let c = &spec.mpc.constraints;
    assert_eq!(c.x_min, vec![f64::NEG_INFINITY, -2.0]);
    assert_eq!(c.x_max, vec![1.5, f64::INFINITY]);
    assert_eq!(c.x_soft, Some(100.0));
    assert!(c.has_state_bounds() && c.any_soft() && !c.has_move_bounds());
    // Only one side written: the other is empty (unbounded).
    let spec = load(&ipm("x_max = [1, inf]\n")).unwrap();
    assert_eq!(spec.mpc.constraints.x_min, Vec::<f64>::new());
    assert_eq!(spec.mpc.constraints.x_max, vec![1.0, f64::INFINITY]);
    assert_eq!(spec.mpc.constraints.x_soft, None);
    assert_eq!(
        spec.spans
            .get("mpc.x_max")
            .map(|s| ipm("x_max = [1, inf]\n")[s].to_string()),
        Some("[1, inf]".to_string())
    );
}

#[test]
fn a_bound_on_the_wrong_side_of_infinity_or_nan_is_located_on_its_entry() {
    let (msg, at, note) = only_error(&ipm("x_min = [0, inf]\n"));
    assert_eq!(msg, "`mpc.x_min` cannot be `inf`");
    assert_eq!(at, "inf");
    assert!(note.unwrap().contains("`-inf`"));
    let (msg, at, _) = only_error(&ipm("x_max = [-inf, 1]\n"));
    assert_eq!(
        (msg.as_str(), at.as_str()),
        ("`mpc.x_max` cannot be `-inf`", "-inf")
    );
    let (msg, at, _) = only_error(&ipm("x_min = [nan, 0]\n"));
    assert_eq!(
        (msg.as_str(), at.as_str()),
        ("`mpc.x_min` must not be nan", "nan")
    );
    // An overflowing literal is not the infinity `inf`.
    let (msg, at, _) = only_error(&ipm("du_max = [1e999]\n"));
    assert_eq!(
        (msg.as_str(), at.as_str()),
        ("`mpc.du_max` must be a finite number or `inf`", "1e999")
    );
    // The input box stays finite.
    let (msg, _, _) = only_error(&ipm("").replace("u_min = [-1]", "u_min = [-inf]"));
    assert_eq!(msg, "`mpc.u_min` must be a finite number");
}

#[test]
fn state_bounds_are_sized_and_ordered() {
    let (msg, at, _) = only_error(&ipm("x_min = [0]\n"));
    assert_eq!(msg, "`mpc.x_min` must have 2 entries (nx = 2), found 1");
    assert_eq!(at, "[0]");
    let (msg, at, note) = only_error(&ipm("x_min = [0, 3]\nx_max = [1, 2]\n"));
    assert_eq!(msg, "state 1 has `x_min` 3 above `x_max` 2");
    assert_eq!(at, "2");
    assert!(note.unwrap().starts_with("hint: each entry of `x_min`"));
    // Equal bounds are allowed (an equality).
    load(&ipm("x_min = [0, 1]\nx_max = [1, 1]\n")).unwrap();
}

#[test]
fn x_soft_needs_state_bounds_and_is_positive() {
    let (msg, at, note) = only_error(&ipm("x_soft = 10\n"));
    assert_eq!(
        msg,
        "`x_soft` softens `x_min` and `x_max`, and neither is written"
    );
    assert_eq!(at, "10");
    assert!(note.unwrap().starts_with("hint:"));
    let (msg, _, _) = only_error(&ipm("x_max = [1, 1]\nx_soft = 0\n"));
    assert_eq!(msg, "`mpc.x_soft` must be positive, found 0");
}

#[test]
fn move_bounds_hold_zero_inside() {
    let spec = load(&ipm("du_min = [-0.5]\ndu_max = [inf]\n")).unwrap();
    assert_eq!(spec.mpc.constraints.du_min, vec![-0.5]);
    assert_eq!(spec.mpc.constraints.du_max, vec![f64::INFINITY]);
    assert!(spec.mpc.constraints.has_move_bounds());
    let (msg, at, note) = only_error(&ipm("du_min = [0.1]\n"));
    assert_eq!(
        msg,
        "`mpc.du_min` must not be positive, found 0.1 for input 0"
    );
    assert_eq!(at, "0.1");
    assert!(note.unwrap().contains("holding the last input"));
    let (msg, at, _) = only_error(&ipm("du_max = [-0.1]\n"));
    assert_eq!(
        msg,
        "`mpc.du_max` must not be negative, found -0.1 for input 0"
    );
    assert_eq!(at, "-0.1");
    let (msg, at, _) = only_error(&ipm("du_min = [0]\ndu_max = [0]\n"));
    assert_eq!(
        msg,
        "input 0 cannot move: its `du_min` and `du_max` are both 0"
    );
    assert_eq!(at, "0");
    let (msg, _, _) = only_error(&ipm("du_max = [1, 1]\n"));
    assert_eq!(msg, "`mpc.du_max` must have 1 entry (nu = 1), found 2");
}

const GROUP: &str = "
[[mpc.constraint]]
ax = [[1, 0], [0, 1]]
au = [[0], [1]]
lower = [-1, -inf]
upper = [1, 2]
soft = 50

[[mpc.constraint]]
ax = [[1, 1]]
upper = [3]
";

#[test]
fn row_groups_are_read_in_order_with_defaults() {
    let src = ipm(GROUP);
    let spec = load(&src).unwrap();
    let rows = &spec.mpc.constraints.rows;
    assert_eq!(rows.len(), 2);
    assert_eq!(
        rows[0].ax,
        Matrix::from_rows(&[vec![1.0, 0.0], vec![0.0, 1.0]])
    );
    assert_eq!(rows[0].au, Matrix::from_rows(&[vec![0.0], vec![1.0]]));
    assert_eq!(rows[0].lower, vec![-1.0, f64::NEG_INFINITY]);
    assert_eq!(rows[0].upper, vec![1.0, 2.0]);
    assert_eq!(rows[0].soft, Some(50.0));
    // `au` defaults to zero, the missing `lower` to −∞.
    assert_eq!(rows[1].au, Matrix::from_rows(&[vec![0.0]]));
    assert_eq!(rows[1].lower, vec![f64::NEG_INFINITY]);
    assert_eq!(rows[1].soft, None);
    assert!(spec.mpc.constraints.any() && spec.mpc.constraints.any_soft());
    let at = |path: &str| spec.spans.get(path).map(|s| src[s].to_string());
    assert_eq!(at("mpc.constraint[1].ax").as_deref(), Some("[[1, 1]]"));
    assert_eq!(at("mpc.constraint[0].lower[1]").as_deref(), Some("-inf"));
    assert_eq!(
        at("mpc.constraint[1]").as_deref(),
        Some("[[mpc.constraint]]")
    );
}

#[test]
fn row_groups_are_shaped_like_their_ax() {
    let group = |body: &str| ipm(&format!("\n[[mpc.constraint]]\n{body}"));
    let (msg, at, _) = only_error(&group("ax = [[1, 0, 0]]\nupper = [1]\n"));
    assert_eq!(
        msg,
        "`mpc.constraint[0].ax` must have nx = 2 columns, found 1×3"
    );
    assert_eq!(at, "[[1, 0, 0]]");
    let (msg, at, _) = only_error(&group("ax = [[1, 0]]\nau = [[1], [2]]\nupper = [1]\n"));
    assert_eq!(
        msg,
        "`mpc.constraint[0].au` must be 1×1 (a row per row of `ax`, a column per input), found 2×1"
    );
    assert_eq!(at, "[[1], [2]]");
    let (msg, at, _) = only_error(&group("ax = [[1, 0]]\nlower = [1, 2]\n"));
    assert_eq!(
        msg,
        "`mpc.constraint[0].lower` must have 1 entry (one per row of `ax`), found 2"
    );
    assert_eq!(at, "[1, 2]");
    let (msg, at, _) = only_error(&group("au = [[1]]\nupper = [1]\n"));
    assert_eq!(msg, "missing key `ax` in `[[mpc.constraint]]`");
    assert_eq!(at, "[[mpc.constraint]]");
    let (msg, at, note) = only_error(&group("ax = [[1, 0]]\n"));
    assert_eq!(msg, "`[[mpc.constraint]]` needs `lower` or `upper`");
    assert_eq!(at, "[[mpc.constraint]]");
    assert!(note.unwrap().starts_with("hint:"));
    let (msg, at, _) = only_error(&group("ax = [[1, inf]]\nupper = [1]\n"));
    assert_eq!(msg, "`mpc.constraint[0].ax` must be a finite number");
    assert_eq!(at, "inf");
    let (msg, _, _) = only_error(&group("ax = [[1, 0]]\nupper = [1]\nsoft = -1\n"));
    assert_eq!(msg, "`mpc.constraint[0].soft` must be positive, found -1");
}

#[test]
fn rows_that_constrain_nothing_or_nothing_feasible_are_located() {
    let group = |body: &str| ipm(&format!("\n[[mpc.constraint]]\n{body}"));
    let (msg, at, _) = only_error(&group("ax = [[1, 0], [0, 1]]\nlower = [0, -inf]\n"));
    assert_eq!(msg, "row 1 of `mpc.constraint[0]` has no finite bound");
    assert_eq!(at, "-inf");
    let (msg, at, note) = only_error(&group("ax = [[1, 0], [0, 0]]\nupper = [1, 1]\n"));
    assert_eq!(msg, "row 1 of `mpc.constraint[0]` is zero in `ax` and `au`");
    assert_eq!(at, "[0, 0]");
    assert!(note.unwrap().starts_with("hint:"));
    // A row on the input alone is not zero.
    load(&group("ax = [[0, 0]]\nau = [[1]]\nupper = [0.5]\n")).unwrap();
    let (msg, at, _) = only_error(&group(
        "ax = [[1, 0], [0, 1]]\nlower = [0, 2]\nupper = [1, 1]\n",
    ));
    assert_eq!(
        msg,
        "row 1 of `mpc.constraint[0]` has `lower` 2 above `upper` 1"
    );
    assert_eq!(at, "1");
    // The index names the group.
    let src = ipm(&format!(
        "{GROUP}\n[[mpc.constraint]]\nax = [[0, 0]]\nupper = [1]\n"
    ));
    let (msg, _, _) = only_error(&src);
    assert_eq!(msg, "row 0 of `mpc.constraint[2]` is zero in `ax` and `au`");
}

#[test]
fn row_group_keys_are_spelled_and_the_groups_are_tables() {
    let src = ipm("\n[[mpc.constraint]]\nax = [[1, 0]]\nuper = [1]\n");
    let diags = load(&src).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert_eq!(d.message, "unknown key `uper` in `[[mpc.constraint]]`");
    assert_eq!(d.note.as_deref(), Some("hint: did you mean `upper`?"));
    assert_eq!(&src[d.span.clone().unwrap()], "uper");
    let (msg, at, _) = only_error(&ipm("constraint = 3\n"));
    assert_eq!(
        msg,
        "`mpc.constraint` must be an array of tables, found integer"
    );
    assert_eq!(at, "3");
    let (msg, _, _) = only_error(&ipm("constraint = [1]\n"));
    assert_eq!(msg, "`mpc.constraint[0]` must be a table, found integer");
    // Inline tables are tables.
    load(&ipm("constraint = [{ ax = [[1, 0]], upper = [1] }]\n")).unwrap();
}

#[test]
fn x_min_is_a_key_now() {
    // It used to be an unknown key with "did you mean `u_min`?".
    let diags = load(&with_method("method = \"fgm\"\n", "x_min = [0, 0]\n")).unwrap_err();
    assert!(
        diags.iter().all(|d| !d.message.starts_with("unknown key")),
        "{diags:?}"
    );
    // A near miss still gets its suggestion.
    let (msg, _, note) = only_error(&ipm("x_mni = [0, 0]\n"));
    assert_eq!(msg, "unknown key `x_mni` in `[mpc]`");
    assert_eq!(note.as_deref(), Some("hint: did you mean `x_min`?"));
}

#[test]
fn constraints_need_a_method_that_takes_them() {
    for (extra, key, at) in [
        ("x_min = [0, 0]\n", "x_min", "[0, 0]"),
        ("x_max = [1, 1]\n", "x_max", "[1, 1]"),
        ("du_min = [-1]\n", "du_min", "[-1]"),
        ("du_max = [1]\n", "du_max", "[1]"),
        (GROUP, "[[mpc.constraint]]", "[[mpc.constraint]]"),
    ] {
        // The default, `auto`, takes them.
        assert_eq!(
            load(&with_method("", extra)).unwrap().mpc.method,
            Method::Auto
        );
        // A numeric `step` is FGM's key, which `auto` no longer follows into a method that cannot
        // take the constraints: one error, on the key (issue 31, item 7).
        let (msg, span, note) = only_error(&with_method("step = 0.5\n", extra));
        assert_eq!(
            msg,
            "`step` is a setting of the first-order methods, which cannot take this spec's constraints"
        );
        assert_eq!(span, "0.5");
        assert!(note.unwrap().contains("remove `step`"));
        for method in ["method = \"fgm\"\n", "method = \"gradient\"\n"] {
            let (msg, span, note) = only_error(&with_method(method, extra));
            let name = if method.contains("gradient") {
                "gradient"
            } else {
                "fgm"
            };
            assert_eq!(
                msg,
                format!("`{key}` is a constraint, which `method = \"{name}\"` cannot take")
            );
            assert_eq!(span, at);
            let note = note.unwrap();
            assert!(note.contains("solves the input box only"), "{note}");
        }
    }
    // Both bounds written: one error each.
    let errs = errors(&with_method(
        "method = \"fgm\"\n",
        "x_min = [0, 0]\nx_max = [1, 1]\nx_soft = 3\n",
    ));
    assert_eq!(errs.len(), 2, "{errs:?}");
}

#[test]
fn ipm_takes_no_step_nor_tolerance() {
    let (msg, at, note) = only_error(&ipm("step = 0.1\n"));
    assert_eq!(
        msg,
        "`step` is a setting of the first-order methods, not of `method = \"ipm\"`"
    );
    assert_eq!(at, "0.1");
    assert!(note.unwrap().contains("remove `step`"));
    // "auto" is harmless.
    load(&ipm("step = \"auto\"\n")).unwrap();
    let (msg, at, note) = only_error(&ipm("tolerance = 1e-4\n"));
    assert_eq!(
        msg,
        "`tolerance` is a setting of the first-order methods, not of `method = \"ipm\"`"
    );
    assert_eq!(at, "1e-4");
    assert!(note.unwrap().contains("`accuracy`"));
}

#[test]
fn admm_form_is_admm_s_and_spelled() {
    let admm = |extra: &str| with_method("method = \"admm\"\n", extra);
    assert_eq!(
        load(&admm("admm_form = \"residual\"\n"))
            .unwrap()
            .mpc
            .admm_form,
        Some(AdmmForm::Residual)
    );
    assert_eq!(
        load(&admm("admm_form = \"direct\"\n"))
            .unwrap()
            .mpc
            .admm_form,
        Some(AdmmForm::Direct)
    );
    // "auto" and its absence leave the form to the certificate; `method = "auto"` weighs ADMM with it.
    assert_eq!(
        load(&admm("admm_form = \"auto\"\n")).unwrap().mpc.admm_form,
        None
    );
    assert_eq!(load(&admm("")).unwrap().mpc.admm_form, None);
    let auto = with_method("", "admm_form = \"residual\"\nx_min = [-1, -1]\n");
    assert_eq!(load(&auto).unwrap().mpc.admm_form, Some(AdmmForm::Residual));
    // "auto" asks for nothing: any method takes it.
    assert_eq!(
        load(&ipm("admm_form = \"auto\"\n")).unwrap().mpc.admm_form,
        None
    );
    // Another method: located at the value, with the way out.
    let (msg, at, note) = only_error(&ipm("admm_form = \"residual\"\n"));
    assert_eq!(
        msg,
        "`admm_form` is a setting of `method = \"admm\"`, not of `method = \"ipm\"`"
    );
    assert_eq!(at, "\"residual\"");
    assert!(note.unwrap().contains("remove `admm_form`"));
    let (msg, _, _) = only_error(&with_method(
        "method = \"fgm\"\n",
        "admm_form = \"direct\"\n",
    ));
    assert!(msg.contains("not of `method = \"fgm\"`"), "{msg}");
    // A misspelling names the choices.
    let diags = load(&admm("admm_form = \"residuals\"\n")).unwrap_err();
    let text = format!("{diags:?}");
    assert!(
        text.contains("residual") && text.contains("direct"),
        "{text}"
    );
}

/// The spec with `method = "active_set"` and `extra` in `[mpc]`.
fn active_set(extra: &str) -> String {
    with_method("method = \"active_set\"\n", extra)
}

/// `[mpc]` keys giving the active set a bounded row, then `[mpc.region]` with `keys`.
fn region(keys: &str) -> String {
    format!("x_min = [-1, -1]\n\n[mpc.region]\n{keys}")
}

#[test]
fn restart_is_the_active_set_s_and_spelled() {
    assert_eq!(load(&active_set("")).unwrap().mpc.restart, Restart::Cold);
    assert_eq!(
        load(&active_set("restart = \"continue\"\n"))
            .unwrap()
            .mpc
            .restart,
        Restart::Continue
    );
    // `method = "auto"` weighs the active set with it; "cold", the default, fits any method.
    let auto = with_method("", "restart = \"continue\"\nx_min = [-1, -1]\n");
    assert_eq!(load(&auto).unwrap().mpc.restart, Restart::Continue);
    assert_eq!(
        load(&ipm("restart = \"cold\"\n")).unwrap().mpc.restart,
        Restart::Cold
    );
    // Another method: located at the value, with the way out.
    let (msg, at, note) = only_error(&ipm("restart = \"continue\"\n"));
    assert_eq!(
        msg,
        "`restart` is a setting of `method = \"active_set\"`, not of `method = \"ipm\"`"
    );
    assert_eq!(at, "\"continue\"");
    assert!(note.unwrap().contains("remove `restart`"));
    // A misspelling names the choices.
    let text = format!(
        "{:?}",
        load(&active_set("restart = \"warm\"\n")).unwrap_err()
    );
    assert!(text.contains("cold") && text.contains("continue"), "{text}");
}

#[test]
fn exact_lps_is_the_active_set_s_exact_count_budget() {
    assert_eq!(load(&active_set("")).unwrap().mpc.region.exact_lps, None);
    let written = load(&active_set(&region("exact_lps = 500_000\n"))).unwrap();
    assert_eq!(written.mpc.region.exact_lps, Some(500_000));
    // `auto` may pick the active set.
    let auto = with_method("", &region("exact_lps = 500_000\n"));
    assert_eq!(load(&auto).unwrap().mpc.region.exact_lps, Some(500_000));
    // Another method: located at the value, with the way out.
    let (msg, at, note) = only_error(&ipm(&region("exact_lps = 500_000\n")));
    assert_eq!(
        msg,
        "`exact_lps` is a setting of `method = \"active_set\"`'s exact count, not of `method = \"ipm\"`"
    );
    assert_eq!(at, "500_000");
    assert!(note.unwrap().contains("remove `exact_lps`"));
    // With the sampled certificate it has nothing to limit.
    let (msg, at, _) = only_error(&active_set(&region(
        "certificate = \"sampled\"\nexact_lps = 500_000\n",
    )));
    assert!(msg.contains("runs no exact count"), "{msg}");
    assert_eq!(at, "500_000");
    // Past the most a build may spend, and zero: errors naming the range.
    for bad in ["exact_lps = 10_000_001\n", "exact_lps = 0\n"] {
        let (msg, at, _) = only_error(&active_set(&region(bad)));
        assert!(msg.contains("10000000"), "{msg}");
        assert!(at.starts_with(bad[12..].trim()), "{at}");
    }
}

#[test]
fn auto_iterations_need_tolerance_or_a_region_for_first_order_methods() {
    let src = ipm("").replace("iterations = 20", "iterations = \"auto\"");
    assert_eq!(load(&src).unwrap().mpc.iterations, Iterations::Auto);
    let src = with_method("", "").replace("iterations = 20", "iterations = \"auto\"");
    let (msg, _, _) = only_error(&src);
    assert_eq!(
        msg,
        "`iterations = \"auto\"` needs `tolerance` or `[mpc.region]`"
    );
    // A region certifies a first-order method's count by sampling instead.
    let region = format!("{src}\n[mpc.region]\nx_min = [-1, -1]\nx_max = [1, 1]\n");
    assert_eq!(load(&region).unwrap().mpc.iterations, Iterations::Auto);
}

#[test]
fn accuracy_is_a_fraction_up_to_a_half() {
    assert_eq!(load(&ipm("accuracy = 1e-4\n")).unwrap().mpc.accuracy, 1e-4);
    assert_eq!(load(&ipm("accuracy = 0.5\n")).unwrap().mpc.accuracy, 0.5);
    for bad in ["0", "-1e-3", "0.6", "1"] {
        let (msg, at, note) = only_error(&ipm(&format!("accuracy = {bad}\n")));
        assert!(
            msg.starts_with("`mpc.accuracy` must be above 0 and at most 0.5"),
            "{msg}"
        );
        assert_eq!(at, bad);
        assert!(note.unwrap().starts_with("hint:"));
    }
    let (msg, _, _) = only_error(&ipm("accuracy = inf\n"));
    assert_eq!(msg, "`mpc.accuracy` must be a finite number");
}

const REGION: &str = "
[mpc.region]
x_min = [-1, -2]
x_max = [1, 2]
reference_min = [-0.5, 0]
reference_max = [0.5, 0]
samples = 200
sequences = 4
steps = 50
";

#[test]
fn the_region_is_read() {
    let spec = load(&ipm(REGION)).unwrap();
    assert_eq!(
        spec.mpc.region,
        Region {
            x_min: vec![-1.0, -2.0],
            x_max: vec![1.0, 2.0],
            reference_min: vec![-0.5, 0.0],
            reference_max: vec![0.5, 0.0],
            samples: Some(200),
            sequences: Some(4),
            steps: Some(50),
            certificate: Certificate::Exact,
            exact_lps: None,
        }
    );
    let spec = load(&ipm("\n[mpc.region]\nsamples = 0\n")).unwrap();
    assert_eq!(spec.mpc.region.samples, Some(0));
    assert!(spec.mpc.region.x_min.is_empty());
}

#[test]
fn the_certificate_is_exact_by_default_and_only_the_active_set_s() {
    let certificate = |src: &str| load(src).unwrap().mpc.region.certificate;
    assert_eq!(certificate(&active_set(&region(""))), Certificate::Exact);
    assert_eq!(
        certificate(&active_set(&region("certificate = \"sampled\"\n"))),
        Certificate::Sampled
    );
    assert_eq!(
        certificate(&active_set(&region("certificate = \"exact\"\n"))),
        Certificate::Exact
    );
    // The sample is every method's: any method takes "sampled".
    assert_eq!(
        certificate(&ipm(&region("certificate = \"sampled\"\n"))),
        Certificate::Sampled
    );
    // "exact" written for a method without an exact count: at the value, with the way out.
    let (msg, at, note) = only_error(&ipm(&region("certificate = \"exact\"\n")));
    assert_eq!(
        msg,
        "`method = \"ipm\"` has no exact certificate: only `method = \"active_set\"` has one"
    );
    assert_eq!(at, "\"exact\"");
    assert!(note.unwrap().contains("`certificate = \"sampled\"`"));
    // A misspelling: the closest value.
    let (msg, _, note) = only_error(&active_set(&region("certificate = \"exakt\"\n")));
    assert_eq!(msg, "unknown value \"exakt\" for `mpc.region.certificate`");
    assert!(note.unwrap().contains("did you mean `exact`?"));
}

#[test]
fn the_region_is_sized_finite_ordered_and_bounded() {
    let region = |body: &str| ipm(&format!("\n[mpc.region]\n{body}"));
    let (msg, at, _) = only_error(&region("x_min = [-1]\n"));
    assert_eq!(
        msg,
        "`mpc.region.x_min` must have 2 entries (nx = 2), found 1"
    );
    assert_eq!(at, "[-1]");
    let (msg, at, _) = only_error(&region("x_max = [1, inf]\n"));
    assert_eq!(msg, "`mpc.region.x_max` must be a finite number");
    assert_eq!(at, "inf");
    let (msg, at, _) = only_error(&region("x_min = [0, 0]\nx_max = [-1, 1]\n"));
    assert_eq!(
        msg,
        "state 0 has `mpc.region.x_min` 0 above `mpc.region.x_max` -1"
    );
    assert_eq!(at, "-1");
    let (msg, at, _) = only_error(&region("reference_min = [1, 0]\nreference_max = [0, 0]\n"));
    assert_eq!(
        msg,
        "reference 0 has `mpc.region.reference_min` 1 above `mpc.region.reference_max` 0"
    );
    assert_eq!(at, "0");
    for (key, max) in [("samples", 10_000), ("sequences", 100), ("steps", 1000)] {
        let (msg, at, note) = only_error(&region(&format!("{key} = {}\n", max + 1)));
        assert!(
            msg.starts_with(&format!("`mpc.region.{key}` must be between")),
            "{msg}"
        );
        assert!(msg.ends_with(&format!("and {max}")), "{msg}");
        assert_eq!(at, (max + 1).to_string());
        assert!(note.unwrap().contains("build time"));
    }
    let (msg, _, _) = only_error(&region("steps = 0\n"));
    assert_eq!(msg, "`mpc.region.steps` must be between 1 and 1000");
    let (msg, at, note) = only_error(&region("sample = 10\n"));
    assert_eq!(msg, "unknown key `sample` in `[mpc.region]`");
    assert_eq!(at, "sample");
    assert_eq!(note.as_deref(), Some("hint: did you mean `samples`?"));
    let (msg, _, _) = only_error(&ipm("region = 3\n"));
    assert_eq!(msg, "`mpc.region` must be a table, found integer");
}

#[test]
fn references_follow_the_tracked_outputs() {
    let src =
        ipm("outputs = [[1, 0]]\n\n[mpc.region]\nreference_min = [-1]\nreference_max = [1]\n");
    let spec = load(&src).unwrap();
    assert_eq!(spec.mpc.region.reference_max, vec![1.0]);
    let src = ipm("outputs = [[1, 0]]\n\n[mpc.region]\nreference_min = [-1, 0]\n");
    let (msg, _, _) = only_error(&src);
    assert_eq!(
        msg,
        "`mpc.region.reference_min` must have 1 entry (nz, the rows of `outputs` = 1), found 2"
    );
}

#[test]
fn every_mistake_is_reported_at_once() {
    let src = ipm(
        "x_min = [0, inf]\ndu_min = [1]\naccuracy = 2\n\n[[mpc.constraint]]\nax = [[0, 0]]\nupper = [1]\n\n[mpc.region]\nsteps = 0\n",
    );
    let errs = errors(&src);
    let messages: Vec<_> = errs.iter().map(|e| e.0.as_str()).collect();
    assert_eq!(
        messages,
        [
            "`mpc.x_min` cannot be `inf`",
            "`mpc.du_min` must not be positive, found 1 for input 0",
            "`mpc.accuracy` must be above 0 and at most 0.5, found 2",
            "row 0 of `mpc.constraint[0]` is zero in `ax` and `au`",
            "`mpc.region.steps` must be between 1 and 1000",
        ]
    );
}

#[test]
fn a_row_coefficient_past_the_limit_is_located_on_its_row() {
    let group = |body: &str| ipm(&format!("\n[[mpc.constraint]]\n{body}"));
    // 1e160 squared overflows f64; the limit is MAX_ROW_COEFFICIENT, inclusive.
    let (msg, at, note) = only_error(&group("ax = [[1, 0]]\nau = [[1e160]]\nupper = [1]\n"));
    assert_eq!(
        msg,
        "row 0 of `mpc.constraint[0].au` has a coefficient 1e160, beyond the largest a row may have, 1e100"
    );
    assert_eq!(at, "[1e160]");
    assert!(note.unwrap().starts_with("hint:"));
    let (msg, at, _) = only_error(&group("ax = [[1, 0], [-2e100, 1]]\nupper = [1, 1]\n"));
    assert!(
        msg.starts_with("row 1 of `mpc.constraint[0].ax` has a coefficient -2e100"),
        "{msg}"
    );
    assert_eq!(at, "[-2e100, 1]");
    load(&group(&format!(
        "ax = [[{:e}, 0]]\nupper = [1]\n",
        MAX_ROW_COEFFICIENT
    )))
    .unwrap();
}

#[test]
fn auto_with_tolerance_and_constraints_is_one_error_on_tolerance() {
    let src = with_method("", "tolerance = 1e-4\nx_max = [1, 1]\n");
    let (msg, at, note) = only_error(&src);
    assert!(
        msg.starts_with("`tolerance` is a setting of the first-order methods, which cannot take"),
        "{msg}"
    );
    assert_eq!(at, "1e-4");
    assert!(note.unwrap().contains("`accuracy`"));
    // The method stays `auto` (the constrained methods), not FGM.
    let spec = load(&with_method("", "accuracy = 1e-3\nx_max = [1, 1]\n")).unwrap();
    assert_eq!(spec.mpc.method, Method::Auto);
    // Without constraints `tolerance` still chooses FGM.
    let spec = load(&with_method("", "tolerance = 1e-4\n")).unwrap();
    assert_eq!(spec.mpc.method, Method::Fgm);
}

#[test]
fn an_input_weighted_by_neither_r_nor_r_du_is_located_on_r_du() {
    let src = with_method("method = \"fgm\"\n", "r_du = 0\n").replace("r = 0.1", "r = 0");
    let (msg, at, _) = only_error(&src);
    assert_eq!(
        msg,
        "input 0 has no weight: its entries of `mpc.r` and `mpc.r_du` are both zero"
    );
    assert_eq!(at, "0");
    // A weight on the moves allows `r = 0`.
    load(&with_method("method = \"fgm\"\n", "r_du = 1\n").replace("r = 0.1", "r = 0")).unwrap();
}

#[test]
fn a_zero_row_of_outputs_is_located_on_the_row() {
    let src = with_method("method = \"fgm\"\n", "outputs = [[1, 0], [0, 0]]\n")
        .replace("q = 1", "q = [1, 1]");
    let (msg, at, note) = only_error(&src);
    assert_eq!(msg, "row 1 of `mpc.outputs` is zero");
    assert_eq!(at, "[0, 0]");
    assert!(note.unwrap().starts_with("hint:"));
}

#[test]
fn a_backoff_is_a_margin_a_list_or_sigmas() {
    let spec = load(&ipm(
        "x_min = [-1, -inf]\nx_max = [1, 2]\nx_backoff = 0.1\n",
    ))
    .unwrap();
    assert_eq!(
        spec.mpc.constraints.x_backoff,
        Some(Backoff::Margin(vec![0.1, 0.1]))
    );
    let spec = load(&ipm("x_max = [1, 2]\nx_backoff = [0, 0.25]\n")).unwrap();
    assert_eq!(
        spec.mpc.constraints.x_backoff,
        Some(Backoff::Margin(vec![0.0, 0.25]))
    );
    let group = "\n[[mpc.constraint]]\nax = [[1, 0], [0, 1]]\nupper = [1, 1]\nbackoff = ";
    let spec = load(&ipm(&format!("{group}[0.5, 0]\n"))).unwrap();
    assert_eq!(
        spec.mpc.constraints.rows[0].backoff,
        Some(Backoff::Margin(vec![0.5, 0.0]))
    );
    // In standard deviations, with a filter.
    let filtered = format!(
        "{}\n[kalman]\nq = [[0.01, 0], [0, 0.01]]\nr = [[0.1]]\n",
        ipm(&format!("{group}\"2.5sigma\"\n"))
    )
    .replace("b = [[0.005], [0.1]]", "b = [[0.005], [0.1]]\nc = [[1, 0]]");
    let spec = load(&filtered).unwrap();
    assert_eq!(
        spec.mpc.constraints.rows[0].backoff,
        Some(Backoff::Sigmas(2.5))
    );
}

#[test]
fn a_backoff_mistake_is_located_at_its_value() {
    // Sigmas need the filter that measures them.
    let (message, at, note) = only_error(&ipm("x_max = [1, 2]\nx_backoff = \"3sigma\"\n"));
    assert!(message.contains("needs the Kalman filter"), "{message}");
    assert_eq!(at, "\"3sigma\"");
    assert!(note.unwrap().contains("bound's units"));
    // No bounds to pull in.
    let (message, at, _) = only_error(&ipm("x_backoff = 0.1\n"));
    assert!(message.contains("neither is written"), "{message}");
    assert_eq!(at, "0.1");
    // The wrong length, a negative margin, a word that is not sigmas.
    let (message, at, _) = only_error(&ipm("x_max = [1, 2]\nx_backoff = [0.1]\n"));
    assert!(message.contains("must have 2 entries"), "{message}");
    assert_eq!(at, "[0.1]");
    let (message, at, _) = only_error(&ipm("x_max = [1, 2]\nx_backoff = [0.1, -0.2]\n"));
    assert!(message.contains("must not be negative"), "{message}");
    assert_eq!(at, "-0.2");
    let (message, at, note) = only_error(&ipm("x_max = [1, 2]\nx_backoff = \"3 sigmas\"\n"));
    assert!(message.contains("unknown value"), "{message}");
    assert_eq!(at, "\"3 sigmas\"");
    assert!(note.unwrap().contains("\"3sigma\""));
    let (message, at, _) = only_error(&ipm("x_max = [1, 2]\nx_backoff = \"-1sigma\"\n"));
    assert!(message.contains("unknown value"), "{message}");
    assert_eq!(at, "\"-1sigma\"");
    // A group's, one per row.
    let (message, at, _) = only_error(&ipm(
        "\n[[mpc.constraint]]\nax = [[1, 0], [0, 1]]\nupper = [1, 1]\nbackoff = [0.1]\n",
    ));
    assert!(
        message.contains("mpc.constraint[0].backoff") && message.contains("one per row"),
        "{message}"
    );
    assert_eq!(at, "[0.1]");
}

#[test]
fn move_blocking_has_matlabs_meaning() {
    // A sum short of the horizon gets a last block of the rest (MATLAB's [1 2 3] at p = 10).
    let spec = load(&with_method("", "move_blocking = [1, 2, 3]\n")).unwrap();
    assert_eq!(spec.mpc.blocks, vec![1, 2, 3, 4]);
    assert_eq!(spec.mpc.control_horizon(), 4);
    let spec = load(&with_method("", "move_blocking = [5, 5]\n")).unwrap();
    assert_eq!(spec.mpc.blocks, vec![5, 5]);
    // A control horizon is blocks of one and a held tail; neither key is N blocks of one.
    let spec = load(&with_method("", "control_horizon = 3\n")).unwrap();
    assert_eq!(spec.mpc.blocks, vec![1, 1, 8]);
    assert_eq!(spec.mpc.blocks, held_after(10, 3));
    let spec = load(&with_method("", "")).unwrap();
    assert_eq!(spec.mpc.blocks, vec![1; 10]);
}

#[test]
fn move_blocking_mistakes_are_located() {
    // Blocks past the horizon: MATLAB truncates them; here it is an error that names the truncation.
    let src = with_method("", "move_blocking = [1, 2, 3, 6, 7]\n");
    let (message, at, hint) = only_error(&src);
    assert!(message.contains("sum to 19 steps"), "{message}");
    assert_eq!(at, "[1, 2, 3, 6, 7]");
    assert!(hint.unwrap().contains("[1, 2, 3, 4]"));
    // A block of no steps, on its entry.
    let src = with_method("", "move_blocking = [2, 0, 3]\n");
    let (message, at, _) = only_error(&src);
    assert!(
        message.contains("`mpc.move_blocking` must be between 1"),
        "{message}"
    );
    assert_eq!(at, "0");
    // Not a list of whole numbers.
    for bad in ["[]", "[1.5, 2]", "3", "[\"2\"]"] {
        let src = with_method("", &format!("move_blocking = {bad}\n"));
        let (message, _, _) = only_error(&src);
        assert!(message.contains("mpc.move_blocking"), "{bad}: {message}");
    }
    // Both keys: at the blocks, the control horizon pointed at, the equivalent blocks in the hint.
    let src = with_method("", "control_horizon = 4\nmove_blocking = [1, 2]\n");
    let diags = load(&src).expect_err("both keys");
    let d = diags.iter().next().unwrap();
    assert!(d.message.contains("both set"), "{}", d.message);
    assert_eq!(&src[d.span.clone().unwrap()], "[1, 2]");
    assert_eq!(&src[d.related[0].0.clone()], "4");
    assert!(d.note.as_ref().unwrap().contains("[1, 1, 1, 7]"));
}
