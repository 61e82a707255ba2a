//! Cross-cutting rules that need more than one key, one `check_*` each, and the assembly of the [`Spec`].

use crate::diag::{Diagnostic, Diagnostics};
use crate::model::*;
use crate::parse::{entries, Located, MatrixInput, Raw, RawBackoff, RawRowGroup};

/// Checks `raw` as a whole and builds the spec; `None` when anything was reported (here or while parsing).
pub fn check(raw: Raw, diags: &mut Diagnostics) -> Option<Spec> {
    let filtered = raw.has("kalman");
    let model = check_model(&raw, filtered, diags);
    let dims = model
        .as_ref()
        .map(|m| (m.kind.nx(), m.kind.nu(), m.kind.ny()));
    let mpc = dims.and_then(|(nx, nu, _)| check_mpc(&raw, nx, nu, diags));
    // `kalman = 3` was reported where it was parsed: no filter then, but no spec either.
    let kalman = match (&model, raw.tables.contains("kalman")) {
        (Some(m), true) => check_kalman(&raw, m, diags).map(Some),
        (_, false) if !filtered => Some(None),
        _ => None,
    };
    // parse.rs accepted only the spellings in `keys`, which are the enums' own.
    let scalar = spelled(&raw.scalar, Scalar::F32, Scalar::from_name);
    let emission = spelled(&raw.emission, Emission::Auto, Emission::from_name);
    let target = spelled(&raw.target, Target::Host, Target::from_name);
    check_target(&raw, target, diags);
    if !diags.is_empty() {
        return None;
    }
    Some(Spec {
        model: model?,
        mpc: mpc?,
        kalman: kalman?,
        codegen: Codegen {
            scalar,
            emission,
            target,
            clock_hz: raw.clock_hz.as_ref().map(|c| c.value),
        },
        spans: Spans(raw.spans),
    })
}

/// The value of a spelled key, or `default` when it is absent.
fn spelled<T>(value: &Option<Located<String>>, default: T, from_name: fn(&str) -> Option<T>) -> T {
    value
        .as_ref()
        .and_then(|v| from_name(&v.value))
        .unwrap_or(default)
}

/// `double_integrator` takes `axes` and no matrices nor `time`; `linear` takes `a` (nx × nx), `b`
/// (nx × nu) and `c` (ny × nx; optional without a filter, which is what uses it), optionally `time`, and
/// no `axes`.
fn check_model(raw: &Raw, filtered: bool, diags: &mut Diagnostics) -> Option<Model> {
    let ty = raw.model_type.as_ref()?;
    let dt = raw.dt.as_ref()?.value;
    let kind = if ty.value == "double_integrator" {
        for m in [&raw.a, &raw.b, &raw.c].into_iter().flatten() {
            diags.push(
                Diagnostic::new(
                    "a `double_integrator` model takes no `a`, `b` or `c`",
                    m.span.clone(),
                )
                .label("not used by this model type")
                .note("hint: write `type = \"linear\"` to give the matrices yourself"),
            );
        }
        // Present but misspelled was reported where it was parsed.
        if let Some(time) = &raw.time {
            diags.push(
                Diagnostic::new(
                    "a `double_integrator` model takes no `time`",
                    time.span.clone(),
                )
                .label("not used by this model type")
                .note("hint: the double integrator is already the exact zero-order-hold sampling of a continuous-time one; for another continuous-time plant write `type = \"linear\"`, `time = \"continuous\"` and its `a`, `b`, `c`"),
            );
        }
        let Some(axes) = &raw.axes else {
            // Present but invalid was reported where it was parsed.
            if raw.has("model.axes") {
                return None;
            }
            diags.push(
                Diagnostic::new("missing key `axes` in `[model]`", ty.span.clone())
                    .label("a `double_integrator` needs `axes`")
                    .note("hint: `axes = 3` for a drone in space"),
            );
            return None;
        };
        ModelKind::DoubleIntegrator { axes: axes.value }
    } else {
        if let Some(axes) = &raw.axes {
            diags.push(
                Diagnostic::new("a `linear` model takes no `axes`", axes.span.clone())
                    .label("the dimensions come from `a`, `b` and `c`"),
            );
        }
        let mut missing = false;
        for (key, m) in [("a", &raw.a), ("b", &raw.b), ("c", &raw.c)] {
            if m.is_none() && !(key == "c" && !filtered && !raw.has("model.c")) {
                missing = true;
                // Present but invalid was reported where it was parsed.
                if raw.has(&format!("model.{key}")) {
                    continue;
                }
                let mut d =
                    Diagnostic::new(format!("missing key `{key}` in `[model]`"), ty.span.clone())
                        .label(format!("a `linear` model needs `{key}`"));
                if key == "c" {
                    d = d.note("hint: the Kalman filter of `[kalman]` needs the measurement matrix `c` (ny × nx); without `[kalman]` the controller takes the measured state and `c` may be left out");
                }
                diags.push(d);
            }
        }
        if missing {
            return None;
        }
        let (a, b) = (raw.a.as_ref()?, raw.b.as_ref()?);
        let nx = a.value.rows;
        // Without a filter and without `c`, the measurement is the state.
        let identity = Located {
            value: Matrix::diagonal(&vec![1.0; nx]),
            span: a.span.clone(),
        };
        let c = raw.c.as_ref().unwrap_or(&identity);
        let mut ok = true;
        ok &= expect_shape(
            diags,
            "model.a",
            a,
            nx,
            nx,
            "nx × nx, nx the number of rows of `a`",
        );
        ok &= expect_shape(
            diags,
            "model.b",
            b,
            nx,
            b.value.cols,
            "nx × nu, nx the size of `a`",
        );
        ok &= expect_shape(
            diags,
            "model.c",
            c,
            c.value.rows,
            nx,
            "ny × nx, nx the size of `a`",
        );
        if !ok {
            return None;
        }
        ModelKind::Linear {
            a: a.value.clone(),
            b: b.value.clone(),
            c: c.value.clone(),
            time: spelled(&raw.time, TimeDomain::Discrete, TimeDomain::from_name),
        }
    };
    Some(Model { kind, dt })
}

/// `outputs` is nz × nx; Q is nz × nz and symmetric (nz = nx without `outputs`); Qf is nz × nz, or nx × nx
/// on the state; R and `r_du` are nu × nu and symmetric, R with a positive diagonal unless `r_du` is
/// given; `qf` and `qf_scale` exclude each other; the bounds have nu entries with u_min ≤ u_max.
fn check_mpc(raw: &Raw, nx: usize, nu: usize, diags: &mut Diagnostics) -> Option<Mpc> {
    let outputs = match &raw.outputs {
        Some(c) if c.value.cols != nx => {
            diags.push(
                Diagnostic::new(
                    format!(
                        "`mpc.outputs` must have nx = {nx} columns, found {}×{}",
                        c.value.rows, c.value.cols
                    ),
                    c.span.clone(),
                )
                .label("wrong shape")
                .note("hint: `outputs` is the map z = C_z·x from the state to the tracked outputs, one row per output"),
            );
            None
        }
        // A zero row tracks the constant 0: its weight weighs nothing, and the controller does not see
        // the output it was meant to be.
        Some(c) if (0..c.value.rows).any(|i| (0..nx).all(|j| c.value.get(i, j) == 0.0)) => {
            let i = (0..c.value.rows)
                .find(|&i| (0..nx).all(|j| c.value.get(i, j) == 0.0))
                .unwrap_or(0);
            diags.push(
                Diagnostic::new(
                    format!("row {i} of `mpc.outputs` is zero"),
                    entry_span(raw, "mpc.outputs", i, &c.span),
                )
                .label("tracks the constant 0")
                .note("hint: each row of `outputs` maps the state to one tracked output; give the row the states it measures, or remove it (and its entries of `q`, `qf` and the references)"),
            );
            None
        }
        Some(c) => Some(Some(c.value.clone())),
        None if raw.has("mpc.outputs") => None,
        None => Some(None),
    };
    let nz = match &outputs {
        Some(Some(c)) => c.rows,
        _ => nx,
    };
    let (z_dim, z_name) = if raw.outputs.is_some() {
        (nz, "nz, the rows of `outputs`")
    } else {
        (nx, "nx")
    };
    let q = square(diags, "mpc.q", raw.q.as_ref(), z_dim, z_name);
    let r = square(diags, "mpc.r", raw.r.as_ref(), nu, "nu");
    let r_du = match &raw.r_du {
        Some(_) => square(diags, "mpc.r_du", raw.r_du.as_ref(), nu, "nu").map(Some),
        None if raw.has("mpc.r_du") => None,
        None => Some(None),
    };
    if let (Some(r), Some(None)) = (&r, &r_du) {
        if (0..nu).any(|i| r.get(i, i) <= 0.0) {
            diags.push(
                Diagnostic::new("`mpc.r` must be positive definite", raw.r.as_ref().map(|x| x.span.clone()))
                    .label("a zero diagonal entry")
                    .note("hint: with a zero input weight the QP is not strongly convex and the gradient method has no rate; a weight on the moves, `r_du`, allows `r = 0`"),
            );
        }
    }
    // `r = 0` needs the moves' weight on that input: with `r_du` zero there too, nothing weighs the
    // input and the LQR of the stage weights has no solution.
    if let (Some(r), Some(Some(r_du))) = (&r, &r_du) {
        if let Some(i) = (0..nu).find(|&i| r.get(i, i) <= 0.0 && r_du.get(i, i) <= 0.0) {
            diags.push(
                Diagnostic::new(
                    format!("input {i} has no weight: its entries of `mpc.r` and `mpc.r_du` are both zero"),
                    raw.r_du.as_ref().map(|x| x.span.clone()),
                )
                .label(format!("zero on input {i}, where `r` is zero too"))
                .related(raw.r.as_ref().map(|x| x.span.clone()), format!("zero on input {i}"))
                .note("hint: `r = 0` is allowed when `r_du` weighs the moves of every input; give input {i} a positive `r_du` (move suppression) or a positive `r`".replace("{i}", &i.to_string())),
            );
        }
    }
    // A state-sized `qf` with outputs is a terminal weight on x_N (a Riccati solution, say); an
    // output-sized one (also when nz = nx) weighs z_N like `q`.
    // `qf = "lqr"`: the compiler solves the Riccati equation (codegen's lowering); Q stands in here.
    let qf_lqr = raw.qf.as_ref().is_some_and(|m| m.value.is_none());
    let qf_written = raw.qf.as_ref().and_then(|m| {
        m.value.clone().map(|value| Located {
            value,
            span: m.span.clone(),
        })
    });
    let qf_on_state = raw.outputs.is_some()
        && nz != nx
        && qf_written
            .as_ref()
            .is_some_and(|m| m.value.to_square(nx).is_ok() && m.value.to_square(nz).is_err());
    let qf = match (&raw.qf, &raw.qf_scale) {
        (Some(_), Some(scale)) => {
            diags.push(
                Diagnostic::new(
                    "`qf` and `qf_scale` cannot both be given",
                    scale.span.clone(),
                )
                .label("remove this or `qf`")
                .note("hint: `qf_scale = k` means Qf = k·Q"),
            );
            None
        }
        (Some(_), None) if qf_lqr => q.clone(),
        (Some(_), None) if qf_on_state => square(diags, "mpc.qf", qf_written.as_ref(), nx, "nx"),
        (Some(_), None) => square(diags, "mpc.qf", qf_written.as_ref(), z_dim, z_name),
        (None, Some(scale)) => q.as_ref().map(|q| q.scaled(scale.value)),
        (None, None) => q.clone(),
    };
    let u_min = sized(diags, "mpc.u_min", raw.u_min.as_ref(), nu, "nu");
    let u_max = sized(diags, "mpc.u_max", raw.u_max.as_ref(), nu, "nu");
    if let (Some(lo), Some(hi)) = (&u_min, &u_max) {
        for (j, (l, h)) in lo.iter().zip(hi).enumerate() {
            if l >= h {
                diags.push(
                    Diagnostic::new(
                        format!("input {j} has `u_min` {l} not below `u_max` {h}"),
                        raw.u_max.as_ref().map(|x| x.span.clone()),
                    )
                    .label(format!("entry {j} is not above `u_min`"))
                    .note("hint: each entry of `u_min` must be below the same entry of `u_max`; a fixed input is not a decision"),
                );
            }
        }
    }
    let method_requested = spelled(&raw.method, Method::Auto, Method::from_name);
    // Keys only a first-order method takes make `auto` choose the fast gradient method.
    let fgm_keys = raw.step.as_ref().is_some_and(|s| s.value.is_some()) || raw.tolerance.is_some();
    let constrained = CONSTRAINT_KEYS.iter().any(|k| raw.has(k)) || !raw.constraints.is_empty();
    // Under `auto`, FGM-only keys choose FGM, unless the spec has constraints, which FGM cannot take:
    // then the key is the mistake (one error on it), and `auto` stays among the constrained methods.
    let method = match method_requested {
        Method::Auto if fgm_keys && constrained => {
            let (key, span, what) = match &raw.tolerance {
                Some(t) => (
                    "tolerance",
                    Some(t.span.clone()),
                    "the a priori bound on FGM's cost gap",
                ),
                None => (
                    "step",
                    raw.step.as_ref().map(|s| s.span.clone()),
                    "a gradient step size",
                ),
            };
            diags.push(
                Diagnostic::new(
                    format!("`{key}` is a setting of the first-order methods, which cannot take this spec's constraints"),
                    span,
                )
                .label(what)
                .note(format!("hint: `method = \"auto\"` weighs `ipm` and `admm` for a constrained spec, and they are certified on `[mpc.region]` against `accuracy` (default {DEFAULT_ACCURACY}), not `{key}`: remove `{key}` (write `accuracy` instead of `tolerance`), or remove the constraints for `fgm`")),
            );
            Method::Auto
        }
        Method::Auto if fgm_keys => Method::Fgm,
        m => m,
    };
    // An interior-point method's "auto" is certified on `[mpc.region]` against `accuracy`; a
    // first-order method's by its a priori bound for `tolerance`, or on `[mpc.region]` when written.
    // Under `auto` without constraints only a first-order method is certain to be a candidate.
    let first_order = method.box_only() || (method == Method::Auto && !constrained);
    if let (Some(it), None, true) = (&raw.iterations, &raw.tolerance, first_order) {
        if it.value.is_none() && !raw.has("mpc.tolerance") && !raw.has("mpc.region") {
            diags.push(
                Diagnostic::new("`iterations = \"auto\"` needs `tolerance` or `[mpc.region]`", it.span.clone())
                    .label("picks the iterations that guarantee `tolerance`, or that reach `accuracy` on the region's sample")
                    .note("hint: add `tolerance = 1e-4` to `[mpc]` (J(U_k) − J* ≤ tolerance·(J(U_0) − J*), an a priori bound), or `[mpc.region]` with the states and references the controller meets (certified by sampling against `accuracy`)"),
            );
        }
    }
    check_method_keys(raw, method, method_requested, diags);
    let constraints = check_constraints(raw, nx, nu, diags);
    let z = match &outputs {
        Some(Some(c)) => Some((c.rows, "nz, the rows of `outputs`")),
        Some(None) => Some((nx, "nx")),
        None => None,
    };
    let region = check_region(raw, nx, z, diags);
    let step = match raw.step.as_ref().and_then(|s| s.value) {
        Some(alpha) => Step::Fixed(alpha),
        None => Step::Auto,
    };
    let horizon = raw.horizon.as_ref()?.value;
    let blocks = check_blocks(raw, horizon, diags)?;
    Some(Mpc {
        horizon,
        blocks,
        iterations: match raw.iterations.as_ref()?.value {
            Some(n) => Iterations::Fixed(n),
            None => Iterations::Auto,
        },
        tolerance: raw.tolerance.as_ref().map(|t| t.value),
        strict: raw.strict.as_ref().is_some_and(|s| s.value),
        accept_unstable: raw.accept_unstable.as_ref().is_some_and(|s| s.value),
        method,
        method_requested,
        step,
        admm_form: raw
            .admm_form
            .as_ref()
            .and_then(|f| AdmmForm::from_name(&f.value)),
        restart: raw
            .restart
            .as_ref()
            .and_then(|r| Restart::from_name(&r.value))
            .unwrap_or_default(),
        outputs: outputs?,
        q: q?,
        r: r?,
        r_du: r_du?,
        qf: qf?,
        qf_on_state,
        qf_lqr,
        u_min: u_min?,
        u_max: u_max?,
        constraints: constraints?,
        accuracy: raw.accuracy.as_ref().map_or(DEFAULT_ACCURACY, |a| a.value),
        region: region?,
    })
}

/// The keys of `[mpc]` that constrain more than the input box (with `[[mpc.constraint]]`).
const CONSTRAINT_KEYS: &[&str] = &["mpc.x_min", "mpc.x_max", "mpc.du_min", "mpc.du_max"];

/// Either `sigma_a` with `sigma_meas` (double integrator only) or `q` with `r`; the covariances are
/// symmetric of sizes nx and ny; `p0` is nx × nx.
fn check_kalman(raw: &Raw, model: &Model, diags: &mut Diagnostics) -> Option<Kalman> {
    let (nx, ny) = (model.kind.nx(), model.kind.ny());
    let sigma = raw
        .sigma_a
        .as_ref()
        .map(|x| x.span.clone())
        .or(raw.sigma_meas.as_ref().map(|x| x.span.clone()));
    let full = raw
        .kalman_q
        .as_ref()
        .map(|x| x.span.clone())
        .or(raw.kalman_r.as_ref().map(|x| x.span.clone()));
    let noise = match (sigma, full) {
        (Some(_), Some(full)) => {
            diags.push(
                Diagnostic::new(
                    "give either `sigma_a` and `sigma_meas`, or `q` and `r`, not both",
                    full,
                )
                .label("conflicts with `sigma_a`/`sigma_meas`"),
            );
            None
        }
        (None, None) => {
            diags.push(
                Diagnostic::new("missing noise model in `[kalman]`", raw.kalman_span.clone())
                    .label("needs `sigma_a` and `sigma_meas`, or `q` and `r`"),
            );
            None
        }
        (Some(span), None) => {
            if !matches!(model.kind, ModelKind::DoubleIntegrator { .. }) {
                diags.push(
                    Diagnostic::new("`sigma_a` and `sigma_meas` describe a double integrator only", span)
                        .note("hint: give the covariances `q` (nx × nx) and `r` (ny × ny) for a `linear` model"),
                );
                None
            } else {
                let sigma_a = required(diags, raw, raw.sigma_a.as_ref(), "sigma_a");
                let sigma_meas = match raw.sigma_meas.as_ref() {
                    None => required::<Vec<f64>>(diags, raw, None, "sigma_meas"),
                    Some(m) => match &m.value {
                        MatrixInput::Scalar(s) => Some(vec![*s; ny]),
                        MatrixInput::Diagonal(d) if d.len() == ny => Some(d.clone()),
                        _ => {
                            diags.push(
                                Diagnostic::new(format!("`kalman.sigma_meas` must be a number or a list of {ny} (ny) numbers"), m.span.clone())
                                    .label("wrong size"),
                            );
                            None
                        }
                    },
                };
                Some(KalmanNoise::WhiteAcceleration {
                    sigma_a: sigma_a?,
                    sigma_meas: sigma_meas?,
                })
            }
        }
        (None, Some(_)) => {
            let q = square(diags, "kalman.q", raw.kalman_q.as_ref(), nx, "nx");
            let r = square(diags, "kalman.r", raw.kalman_r.as_ref(), ny, "ny");
            if raw.kalman_q.is_none() {
                required::<f64>(diags, raw, None, "q");
            }
            if raw.kalman_r.is_none() {
                required::<f64>(diags, raw, None, "r");
            }
            if let Some(r) = &r {
                if (0..ny).any(|i| r.get(i, i) <= 0.0) {
                    diags.push(
                        Diagnostic::new(
                            "`kalman.r` must be positive definite",
                            raw.kalman_r.as_ref().map(|x| x.span.clone()),
                        )
                        .label("a zero diagonal entry"),
                    );
                }
            }
            Some(KalmanNoise::Covariances { q: q?, r: r? })
        }
    };
    let p0 = match raw.p0.as_ref() {
        Some(_) => square(diags, "kalman.p0", raw.p0.as_ref(), nx, "nx"),
        None => Some(Matrix::diagonal(&vec![1.0; nx])),
    };
    let filter = spelled(&raw.filter, FilterKind::TimeVarying, FilterKind::from_name);
    let nu = model.kind.nu();
    let disturbance = match raw.disturbance.as_ref() {
        None => None,
        Some(d) => {
            match &d.value {
                MatrixInput::Scalar(s) => Some(vec![*s; nu]),
                MatrixInput::Diagonal(v) if v.len() == nu => Some(v.clone()),
                _ => {
                    diags.push(
                    Diagnostic::new(
                        format!("`kalman.disturbance` must be a number or a list of {nu} (nu) numbers"),
                        d.span.clone(),
                    )
                    .label("one random-walk standard deviation per input channel"),
                );
                    return None;
                }
            }
        }
    };
    let defaults = Screening::default();
    let screening = Screening {
        gate: match raw.gate.as_ref().map(|g| g.value) {
            None => Gate::Default,
            Some(None) => Gate::Off,
            Some(Some(g)) => Gate::Threshold(g),
        },
        stuck_cycles: match raw.stuck_cycles.as_ref().map(|s| s.value) {
            None => defaults.stuck_cycles,
            Some(s) => s.map(|s| s as u32),
        },
        reacquire_after: raw
            .reacquire_after
            .as_ref()
            .map_or(defaults.reacquire_after, |r| r.value as u32),
    };
    Some(Kalman {
        noise: noise?,
        p0: p0?,
        filter,
        disturbance,
        screening,
    })
}

/// The value of `[kalman] key`, reporting it as missing unless it was written (and reported) already.
fn required<T: Clone>(
    diags: &mut Diagnostics,
    raw: &Raw,
    v: Option<&Located<T>>,
    key: &str,
) -> Option<T> {
    if v.is_none() && !raw.has(&format!("kalman.{key}")) {
        diags.push(
            Diagnostic::new(
                format!("missing key `{key}` in `[kalman]`"),
                raw.kalman_span.clone(),
            )
            .label(format!("`{key}` is required here")),
        );
    }
    v.map(|x| x.value.clone())
}

/// A square symmetric matrix of size n from a number, a diagonal or a full matrix.
fn square(
    diags: &mut Diagnostics,
    path: &str,
    m: Option<&Located<MatrixInput>>,
    n: usize,
    dim: &str,
) -> Option<Matrix> {
    let m = m?;
    match m.value.to_square(n) {
        Ok(mat) if mat.is_symmetric() => Some(mat),
        Ok(mat) => {
            diags.push(
                Diagnostic::new(format!("`{path}` must be symmetric"), m.span.clone())
                    .label(format!(
                        "a_ij and a_ji differ by {:.3e} of √(|a_ii·a_jj|)",
                        mat.asymmetry()
                    ))
                    .note(format!(
                        "hint: entries may differ by up to {SYMMETRY_TOLERANCE:e} of √(|a_ii·a_jj|) (rounding); the compiler then uses (A + Aᵀ)/2"
                    )),
            );
            None
        }
        Err(found) => {
            diags.push(
                Diagnostic::new(
                    format!("`{path}` must be {n}×{n} ({dim} = {n}), found {found}"),
                    m.span.clone(),
                )
                .label(format!(
                    "expected a diagonal of {} or a {n}×{n} matrix",
                    crate::parse::entries(n)
                )),
            );
            None
        }
    }
}

/// A list of `n` entries (`dim` names n: `"nu"`).
fn sized(
    diags: &mut Diagnostics,
    path: &str,
    v: Option<&Located<Vec<f64>>>,
    n: usize,
    dim: &str,
) -> Option<Vec<f64>> {
    let v = v?;
    if v.value.len() != n {
        diags.push(
            Diagnostic::new(
                format!(
                    "`{path}` must have {} ({dim} = {n}), found {}",
                    entries(n),
                    v.value.len()
                ),
                v.span.clone(),
            )
            .label(format!("expected {}", entries(n))),
        );
        return None;
    }
    Some(v.value.clone())
}

/// An optional list of `n` entries: empty when not written, `None` when written and wrong (reported).
fn optional_list(
    diags: &mut Diagnostics,
    raw: &Raw,
    path: &str,
    v: Option<&Located<Vec<f64>>>,
    n: usize,
    dim: &str,
) -> Option<Vec<f64>> {
    match v {
        Some(_) => sized(diags, path, v, n, dim),
        None if raw.has(path) => None,
        None => Some(Vec::new()),
    }
}

/// The span of entry `i` of the list at `path`, else of the whole list.
fn entry_span(raw: &Raw, path: &str, i: usize, whole: &Span) -> Span {
    raw.spans
        .get(&format!("{path}[{i}]"))
        .cloned()
        .unwrap_or_else(|| whole.clone())
}

/// One pair of lower and upper bounds, entrywise ordered: `lower[i] ≤ upper[i]`.
struct Ordered<'a> {
    /// The lower bounds' path (`mpc.x_min`) and what is written in messages (`x_min`).
    lower: (&'a str, &'a str),
    /// Likewise the upper bounds'.
    upper: (&'a str, &'a str),
    /// What entry i bounds: "state 2".
    entry: &'a dyn Fn(usize) -> String,
}

impl Ordered<'_> {
    /// Reports every entry whose lower bound is above its upper bound, at the upper bound's entry. Empty
    /// lists (not written) are unbounded.
    fn check(&self, raw: &Raw, lo: &[f64], hi: &[f64], diags: &mut Diagnostics) -> bool {
        let Some(whole) = raw.spans.get(self.upper.0) else {
            return true;
        };
        let (lo_key, hi_key) = (self.lower.1, self.upper.1);
        let mut ok = true;
        for (i, (l, h)) in lo.iter().zip(hi).enumerate() {
            if l > h {
                ok = false;
                diags.push(
                    Diagnostic::new(
                        format!("{} has `{lo_key}` {l} above `{hi_key}` {h}", (self.entry)(i)),
                        entry_span(raw, self.upper.0, i, whole),
                    )
                    .label(format!("below entry {i} of `{lo_key}`"))
                    .note(format!(
                        "hint: each entry of `{lo_key}` must be at most the same entry of `{hi_key}`: no value lies between them"
                    )),
                );
            }
        }
        ok
    }
}

/// What the first-order methods cannot solve needs `method = "ipm"` or `"admm"`: `x_min`, `x_max`,
/// `du_min`, `du_max` and `[[mpc.constraint]]` (and with them `x_soft` and `soft`); `ipm` and `admm` in
/// turn take no gradient `step` nor `tolerance`, their accuracy being `accuracy`.
fn check_method_keys(raw: &Raw, method: Method, requested: Method, diags: &mut Diagnostics) {
    let name = method.name();
    if let Some(lps) = raw.exact_lps.as_ref() {
        let sampled = raw
            .certificate
            .as_ref()
            .is_some_and(|c| c.value == Certificate::Sampled.name());
        if sampled {
            diags.push(
                Diagnostic::new(
                    "`exact_lps` is the exact count's budget, and `certificate = \"sampled\"` runs no exact count",
                    lps.span.clone(),
                )
                .label("the exact count's budget of feasibility LPs per block")
                .note("hint: remove `exact_lps`, or `certificate = \"sampled\"` (the default is \"exact\")"),
            );
        } else if method != Method::ActiveSet && method != Method::Auto {
            diags.push(
                Diagnostic::new(
                    format!("`exact_lps` is a setting of `method = \"active_set\"`'s exact count, not of `method = \"{name}\"`"),
                    lps.span.clone(),
                )
                .label("the exact count's budget of feasibility LPs per block")
                .note("hint: remove `exact_lps`, or write `method = \"active_set\"` (or `\"auto\"`, which weighs the active set with it)"),
            );
        }
    }
    if method == Method::Auto {
        return;
    }
    // `"auto"` asks for nothing, so it fits any method (as `step = "auto"` does).
    if let Some(form) = raw
        .admm_form
        .as_ref()
        .filter(|f| method != Method::Admm && f.value != "auto")
    {
        diags.push(
            Diagnostic::new(
                format!("`admm_form` is a setting of `method = \"admm\"`, not of `method = \"{name}\"`"),
                form.span.clone(),
            )
            .label("how ADMM computes its x-update")
            .note("hint: remove `admm_form`, or write `method = \"admm\"` (or `\"auto\"`, which weighs ADMM with it)"),
        );
    }
    if let Some(restart) = raw
        .restart
        .as_ref()
        .filter(|r| method != Method::ActiveSet && r.value != Restart::Cold.name())
    {
        diags.push(
            Diagnostic::new(
                format!("`restart` is a setting of `method = \"active_set\"`, not of `method = \"{name}\"`"),
                restart.span.clone(),
            )
            .label("what a warm active-set solve that runs out does")
            .note("hint: remove `restart`, or write `method = \"active_set\"` (or `\"auto\"`, which weighs the active set with it)"),
        );
    }
    if let Some(certificate) = raw
        .certificate
        .as_ref()
        .filter(|c| method != Method::ActiveSet && c.value == Certificate::Exact.name())
    {
        diags.push(
            Diagnostic::new(
                format!("`method = \"{name}\"` has no exact certificate: only `method = \"active_set\"` has one"),
                certificate.span.clone(),
            )
            .label("asks for the exact iteration count over the region")
            .note(format!("hint: write `certificate = \"sampled\"` (what `{name}` is certified by), or `method = \"active_set\"`")),
        );
    }
    if method.box_only() {
        let solver = if requested == Method::Auto {
            let key = if raw.tolerance.is_some() {
                "`tolerance`"
            } else {
                "a numeric `step`"
            };
            format!("`method = \"auto\"` chooses `{name}` for {key}, which only a first-order method takes, and `{name}`")
        } else {
            format!("`method = \"{name}\"`")
        };
        let span = |v: &Option<Located<Vec<f64>>>| v.as_ref().map(|v| v.span.clone());
        let keys = [
            ("x_min", "a bound on the predicted states", span(&raw.x_min)),
            ("x_max", "a bound on the predicted states", span(&raw.x_max)),
            (
                "du_min",
                "a bound on the moves u_k − u_{k−1}",
                span(&raw.du_min),
            ),
            (
                "du_max",
                "a bound on the moves u_k − u_{k−1}",
                span(&raw.du_max),
            ),
            (
                "[[mpc.constraint]]",
                "a group of constraint rows",
                raw.constraints.first().map(|g| g.span.clone()),
            ),
        ];
        let fix = if requested == Method::Auto {
            "remove it so that `auto` chooses among the methods that take constraints, or write `method = \"ipm\"` (or `\"admm\"`)"
        } else {
            "write `method = \"auto\"` (the default: the compiler's choice) or `method = \"ipm\"` (or `\"admm\"`) in `[mpc]` for state, move and row constraints"
        };
        for (key, what, span) in keys {
            let Some(span) = span else { continue };
            diags.push(
                Diagnostic::new(
                    format!("`{key}` is a constraint, which `method = \"{name}\"` cannot take"),
                    span,
                )
                .label(what)
                .note(format!(
                    "hint: {solver} solves the input box only (a projection per iteration); {fix}"
                )),
            );
        }
        return;
    }
    if let Some(step) = raw.step.as_ref().filter(|s| s.value.is_some()) {
        diags.push(
            Diagnostic::new(
                format!("`step` is a setting of the first-order methods, not of `method = \"{name}\"`"),
                step.span.clone(),
            )
            .label("a gradient step size")
            .note(format!("hint: {}; remove `step`", match method {
                Method::Admm => "ADMM's step is its penalty ρ, tuned at build time on `[mpc.region]`",
                Method::ActiveSet => "the dual active-set method steps from one working set to the next, each step as long as the multipliers allow",
                _ => "the interior-point method takes Newton steps, each as long as the boundary allows",
            })),
        );
    }
    if let Some(tolerance) = &raw.tolerance {
        diags.push(
            Diagnostic::new(
                format!("`tolerance` is a setting of the first-order methods, not of `method = \"{name}\"`"),
                tolerance.span.clone(),
            )
            .label("the a priori bound of `fgm` and `gradient`")
            .note(format!("hint: {} is certified on `[mpc.region]` against `accuracy` (default {DEFAULT_ACCURACY}): write `accuracy` instead of `tolerance`", match method {
                Method::Admm => "ADMM",
                Method::ActiveSet => "the dual active-set method",
                _ => "the interior-point method",
            })),
        );
    }
}

/// A method that computes in f64 needs a target with f64 in hardware: `method = "ipm"` on `cortex-m4f`
/// would run every operation of its factorisations in software floating point. (An f64 `scalar` there
/// is allowed, with a warning from the compiler: the first-order methods and the filter still run.)
fn check_target(raw: &Raw, target: Target, diags: &mut Diagnostics) {
    if let (Some(clock), Target::Host) = (&raw.clock_hz, target) {
        diags.push(
            Diagnostic::new(
                "`clock_hz` needs a `target`: the host has no fixed clock to time a step against",
                clock.span.clone(),
            )
            .label("a clock for no target")
            .note("hint: write `target = \"cortex-a9\"` or `target = \"cortex-m4f\"` in `[codegen]` with it (their clocks default to 667 MHz and 168 MHz), or remove `clock_hz`"),
        );
    }
    let Some(method) = &raw.method else { return };
    if Method::from_name(&method.value) == Some(Method::Ipm) && !target.has_f64() {
        let name = target.name();
        let target_span = raw.target.as_ref().map(|t| t.span.clone());
        diags.push(
            Diagnostic::new(
                format!("`method = \"ipm\"` computes in f64, which `target = \"{name}\"` has no hardware for"),
                method.span.clone(),
            )
            .label("the interior-point method runs in f64")
            .related(target_span, "a single-precision FPU: f64 runs in software, about 45× slower")
            .note("hint: the first-order methods compute in the spec's `scalar` (f32 by default): `method = \"fgm\"` solves a problem constrained by the input box alone; for state, move or row constraints, `target = \"cortex-a9\"` runs the interior-point method on its VFP"),
        );
    }
}

/// `x_min`/`x_max` have nx entries and `du_min`/`du_max` nu, each lower bound at most its upper one, and
/// `du_min ≤ 0 ≤ du_max` with room to move; `x_soft` softens written state bounds; each
/// `[[mpc.constraint]]` is checked by [`check_row_group`].
fn check_constraints(
    raw: &Raw,
    nx: usize,
    nu: usize,
    diags: &mut Diagnostics,
) -> Option<Constraints> {
    let x_min = optional_list(diags, raw, "mpc.x_min", raw.x_min.as_ref(), nx, "nx");
    let x_max = optional_list(diags, raw, "mpc.x_max", raw.x_max.as_ref(), nx, "nx");
    let mut ok = true;
    if let (Some(lo), Some(hi)) = (&x_min, &x_max) {
        let order = Ordered {
            lower: ("mpc.x_min", "x_min"),
            upper: ("mpc.x_max", "x_max"),
            entry: &|i| format!("state {i}"),
        };
        ok &= order.check(raw, lo, hi, diags);
    }
    if let Some(soft) = &raw.x_soft {
        if !raw.has("mpc.x_min") && !raw.has("mpc.x_max") {
            ok = false;
            diags.push(
                Diagnostic::new(
                    "`x_soft` softens `x_min` and `x_max`, and neither is written",
                    soft.span.clone(),
                )
                .label("a penalty on no constraint")
                .note("hint: add `x_min` or `x_max` to `[mpc]`, or remove `x_soft`; a `[[mpc.constraint]]` is softened by its own `soft`"),
            );
        }
    }
    let x_backoff = match &raw.x_backoff {
        Some(b) if !raw.has("mpc.x_min") && !raw.has("mpc.x_max") => {
            diags.push(
                Diagnostic::new(
                    "`x_backoff` pulls in `x_min` and `x_max`, and neither is written",
                    b.span.clone(),
                )
                .label("a margin on no constraint")
                .note("hint: add `x_min` or `x_max` to `[mpc]`, or remove `x_backoff`; a `[[mpc.constraint]]` is pulled in by its own `backoff`"),
            );
            None
        }
        Some(b) => backoff(raw, "mpc.x_backoff", b, nx, "nx (one per state)", diags).map(Some),
        None if raw.has("mpc.x_backoff") => None,
        None => Some(None),
    };
    ok &= x_backoff.is_some();
    let du_min = optional_list(diags, raw, "mpc.du_min", raw.du_min.as_ref(), nu, "nu");
    let du_max = optional_list(diags, raw, "mpc.du_max", raw.du_max.as_ref(), nu, "nu");
    if let (Some(lo), Some(hi)) = (&du_min, &du_max) {
        ok &= check_moves(raw, lo, hi, diags);
    }
    let mut rows = Vec::with_capacity(raw.constraints.len());
    for group in &raw.constraints {
        match check_row_group(raw, group, nx, nu, diags) {
            Some(g) => rows.push(g),
            None => ok = false,
        }
    }
    if !ok {
        return None;
    }
    Some(Constraints {
        x_min: x_min?,
        x_max: x_max?,
        x_soft: raw.x_soft.as_ref().map(|s| s.value),
        x_backoff: x_backoff?,
        du_min: du_min?,
        du_max: du_max?,
        rows,
    })
}

/// A back-off as written, checked: a list has `n` entries; `"<z>sigma"` needs `[kalman]`, whose
/// steady-state covariance gives σ. `None` after a reported error.
fn backoff(
    raw: &Raw,
    path: &str,
    b: &Located<RawBackoff>,
    n: usize,
    what: &str,
    diags: &mut Diagnostics,
) -> Option<Backoff> {
    match &b.value {
        RawBackoff::Each(m) => Some(Backoff::Margin(vec![*m; n])),
        RawBackoff::List(list) if list.len() == n => Some(Backoff::Margin(list.clone())),
        RawBackoff::List(list) => {
            diags.push(
                Diagnostic::new(
                    format!(
                        "`{path}` must have {n} entries, {what}, found {}",
                        list.len()
                    ),
                    b.span.clone(),
                )
                .label(format!("expected {}", entries(n)))
                .note("hint: or write one number for every bound"),
            );
            None
        }
        RawBackoff::Sigmas(_) if !raw.tables.contains("kalman") => {
            diags.push(
                Diagnostic::new(
                    format!("`{path}` in standard deviations needs the Kalman filter of `[kalman]`"),
                    b.span.clone(),
                )
                .label("no estimation error to measure it in")
                .note("hint: without `[kalman]` the controller is given the state; write the margin in the bound's units instead"),
            );
            None
        }
        RawBackoff::Sigmas(z) => Some(Backoff::Sigmas(*z)),
    }
}

/// `du_min ≤ 0 ≤ du_max` entrywise, not both zero: holding the last input (a zero move) must be allowed,
/// and an input must be able to move.
fn check_moves(raw: &Raw, lo: &[f64], hi: &[f64], diags: &mut Diagnostics) -> bool {
    const HOLD: &str = "hint: `du_min ≤ 0 ≤ du_max` entrywise, so that holding the last input (a zero move) is always allowed; write `-inf`/`inf` for an input whose moves are free";
    let mut ok = true;
    for (path, list, sign) in [("mpc.du_min", lo, 1.0), ("mpc.du_max", hi, -1.0)] {
        let Some(whole) = raw.spans.get(path) else {
            continue;
        };
        for (j, d) in list.iter().enumerate() {
            if sign * d > 0.0 {
                ok = false;
                let (rule, way) = if sign > 0.0 {
                    ("positive", "upward")
                } else {
                    ("negative", "downward")
                };
                diags.push(
                    Diagnostic::new(
                        format!("`{path}` must not be {rule}, found {d} for input {j}"),
                        entry_span(raw, path, j, whole),
                    )
                    .label(format!("forces every move of input {j} {way}"))
                    .note(HOLD),
                );
            }
        }
    }
    if let Some(whole) = raw.spans.get("mpc.du_max") {
        for (j, (l, h)) in lo.iter().zip(hi).enumerate() {
            if *l == 0.0 && *h == 0.0 {
                ok = false;
                diags.push(
                    Diagnostic::new(
                        format!("input {j} cannot move: its `du_min` and `du_max` are both 0"),
                        entry_span(raw, "mpc.du_max", j, whole),
                    )
                    .label("pins the input to its last value forever")
                    .note("hint: give the moves of this input a range, or fix it with `u_min`/`u_max` of the model instead"),
                );
            }
        }
    }
    ok
}

/// One `[[mpc.constraint]]`: `ax` rows × nx; `au` rows × nu (zero when absent); `lower` and/or `upper`
/// with one entry per row (the absent one ∓∞), `lower ≤ upper`; every row with a finite bound and a
/// nonzero entry in `ax` or `au`.
fn check_row_group(
    raw: &Raw,
    g: &RawRowGroup,
    nx: usize,
    nu: usize,
    diags: &mut Diagnostics,
) -> Option<RowGroup> {
    let p = &g.path;
    // Written (and maybe reported), or offered for a misspelled key (reported).
    let has = |key: &str| {
        let path = format!("{p}.{key}");
        raw.has(&path) || raw.suggested.contains(&path)
    };
    let mut ok = true;
    if g.lower.is_none() && g.upper.is_none() && !has("lower") && !has("upper") {
        ok = false;
        diags.push(
            Diagnostic::new("`[[mpc.constraint]]` needs `lower` or `upper`", g.span.clone())
                .label("a group of rows without bounds")
                .note("hint: `lower` and `upper` hold one entry per row of `ax`; write the one you need, the other is then unbounded (`-inf` or `inf`)"),
        );
    }
    // A missing `ax` was reported where it was parsed.
    let ax = g.ax.as_ref()?;
    let rows = ax.value.rows;
    if ax.value.cols != nx {
        ok = false;
        diags.push(
            Diagnostic::new(
                format!(
                    "`{p}.ax` must have nx = {nx} columns, found {}×{}",
                    rows, ax.value.cols
                ),
                ax.span.clone(),
            )
            .label("wrong shape")
            .note("hint: `ax` maps the state to the group's rows: one row per constraint, one column per state"),
        );
    }
    let au = match &g.au {
        Some(au) if au.value.rows != rows || au.value.cols != nu => {
            diags.push(
                Diagnostic::new(
                    format!(
                        "`{p}.au` must be {rows}×{nu} (a row per row of `ax`, a column per input), found {}×{}",
                        au.value.rows, au.value.cols
                    ),
                    au.span.clone(),
                )
                .label("wrong shape")
                .note("hint: `au` maps the input to the group's rows, beside `ax`; leave it out for rows on the state alone"),
            );
            None
        }
        Some(au) => Some(au.value.clone()),
        None if has("au") => None,
        None => Some(Matrix {
            rows,
            cols: nu,
            data: vec![0.0; rows * nu],
        }),
    };
    let side =
        |key: &str, v: &Option<Located<Vec<f64>>>, free: f64, diags: &mut Diagnostics| match v {
            Some(v) if v.value.len() != rows => {
                diags.push(
                    Diagnostic::new(
                        format!(
                            "`{p}.{key}` must have {} (one per row of `ax`), found {}",
                            entries(rows),
                            v.value.len()
                        ),
                        v.span.clone(),
                    )
                    .label(format!("expected {}", entries(rows))),
                );
                None
            }
            Some(v) => Some(v.value.clone()),
            None if has(key) => None,
            None => Some(vec![free; rows]),
        };
    let lower = side("lower", &g.lower, f64::NEG_INFINITY, diags);
    let upper = side("upper", &g.upper, f64::INFINITY, diags);
    let (Some(au), Some(lower), Some(upper), true) = (au, lower, upper, ok) else {
        return None;
    };
    if ax.value.cols != nx {
        return None;
    }
    // A coefficient past MAX_ROW_COEFFICIENT: the interior-point method forms products of two entries
    // of a row times the row's weight, which overflow f64 from about 1.3e154 (and are meaningless far
    // before: such a row is solved at the rounding of its other entries).
    for (key, m) in [("ax", &ax.value), ("au", &au)] {
        let Some((i, v)) = (0..rows)
            .flat_map(|i| {
                m.data[i * m.cols..(i + 1) * m.cols]
                    .iter()
                    .map(move |v| (i, *v))
            })
            .find(|(_, v)| v.abs() > crate::MAX_ROW_COEFFICIENT)
        else {
            continue;
        };
        ok = false;
        let path = format!("{p}.{key}");
        let whole = raw
            .spans
            .get(&path)
            .cloned()
            .unwrap_or_else(|| g.span.clone());
        diags.push(
            Diagnostic::new(
                format!("row {i} of `{path}` has a coefficient {v:e}, beyond the largest a row may have, {:e}", crate::MAX_ROW_COEFFICIENT),
                entry_span(raw, &path, i, &whole),
            )
            .label("too large to square in f64 with the row's weight")
            .note("hint: the solver forms products of two coefficients of a row and its weight, which overflow f64; divide the row's `ax`, `au`, `lower` and `upper` by the same factor (a row's scale does not change what it allows)"),
        );
    }
    for i in 0..rows {
        if lower[i] == f64::NEG_INFINITY && upper[i] == f64::INFINITY {
            ok = false;
            let (key, bound) = match &g.lower {
                Some(l) => ("lower", l),
                None => ("upper", g.upper.as_ref()?),
            };
            diags.push(
                Diagnostic::new(format!("row {i} of `{p}` has no finite bound"), entry_span(raw, &format!("{p}.{key}"), i, &bound.span))
                    .label("unbounded on both sides")
                    .note("hint: a row without a finite `lower` or `upper` constrains nothing; give it a bound or remove the row"),
            );
        }
        let zero =
            (0..nx).all(|j| ax.value.get(i, j) == 0.0) && (0..nu).all(|j| au.get(i, j) == 0.0);
        if zero {
            ok = false;
            diags.push(
                Diagnostic::new(format!("row {i} of `{p}` is zero in `ax` and `au`"), entry_span(raw, &format!("{p}.ax"), i, &ax.span))
                    .label("bounds the constant 0")
                    .note("hint: a zero row is always satisfied or never, whatever the controller does; remove it, or give it the states and inputs it constrains"),
            );
        }
    }
    let lower_path = format!("{p}.lower");
    let upper_path = format!("{p}.upper");
    let order = Ordered {
        lower: (&lower_path, "lower"),
        upper: (&upper_path, "upper"),
        entry: &|i| format!("row {i} of `{p}`"),
    };
    ok &= order.check(raw, &lower, &upper, diags);
    let backoff = match &g.backoff {
        Some(b) => backoff(
            raw,
            &format!("{p}.backoff"),
            b,
            rows,
            "one per row of `ax`",
            diags,
        )
        .map(Some),
        None if has("backoff") => None,
        None => Some(None),
    };
    let backoff = backoff?;
    ok.then(|| RowGroup {
        ax: ax.value.clone(),
        au,
        lower,
        upper,
        soft: g.soft.as_ref().map(|s| s.value),
        backoff,
    })
}

/// `[mpc.region]`: `x_min`/`x_max` of nx finite entries, `reference_min`/`reference_max` of nz (`z` is nz
/// and its name, `None` when `outputs` is wrong), each lower corner at most the upper one.
fn check_region(
    raw: &Raw,
    nx: usize,
    z: Option<(usize, &str)>,
    diags: &mut Diagnostics,
) -> Option<Region> {
    let x_min = optional_list(
        diags,
        raw,
        "mpc.region.x_min",
        raw.region_x_min.as_ref(),
        nx,
        "nx",
    );
    let x_max = optional_list(
        diags,
        raw,
        "mpc.region.x_max",
        raw.region_x_max.as_ref(),
        nx,
        "nx",
    );
    let (nz, z_name) = z?;
    let reference_min = optional_list(
        diags,
        raw,
        "mpc.region.reference_min",
        raw.reference_min.as_ref(),
        nz,
        z_name,
    );
    let reference_max = optional_list(
        diags,
        raw,
        "mpc.region.reference_max",
        raw.reference_max.as_ref(),
        nz,
        z_name,
    );
    let mut ok = true;
    if let (Some(lo), Some(hi)) = (&x_min, &x_max) {
        let order = Ordered {
            lower: ("mpc.region.x_min", "mpc.region.x_min"),
            upper: ("mpc.region.x_max", "mpc.region.x_max"),
            entry: &|i| format!("state {i}"),
        };
        ok &= order.check(raw, lo, hi, diags);
    }
    if let (Some(lo), Some(hi)) = (&reference_min, &reference_max) {
        let order = Ordered {
            lower: ("mpc.region.reference_min", "mpc.region.reference_min"),
            upper: ("mpc.region.reference_max", "mpc.region.reference_max"),
            entry: &|i| format!("reference {i}"),
        };
        ok &= order.check(raw, lo, hi, diags);
    }
    if !ok {
        return None;
    }
    let count = |c: &Option<Located<usize>>| c.as_ref().map(|c| c.value);
    Some(Region {
        x_min: x_min?,
        x_max: x_max?,
        reference_min: reference_min?,
        reference_max: reference_max?,
        samples: count(&raw.samples),
        sequences: count(&raw.sequences),
        steps: count(&raw.steps),
        certificate: raw
            .certificate
            .as_ref()
            .and_then(|c| Certificate::from_name(&c.value))
            .unwrap_or_default(),
        exact_lps: count(&raw.exact_lps),
    })
}

fn expect_shape(
    diags: &mut Diagnostics,
    path: &str,
    m: &Located<Matrix>,
    rows: usize,
    cols: usize,
    what: &str,
) -> bool {
    if m.value.rows == rows && m.value.cols == cols {
        return true;
    }
    diags.push(
        Diagnostic::new(
            format!(
                "`{path}` must be {rows}×{cols} ({what}), found {}×{}",
                m.value.rows, m.value.cols
            ),
            m.span.clone(),
        )
        .label("wrong shape"),
    );
    false
}

/// The move blocks: from `move_blocking` (MATLAB's vector `ControlHorizon`: block lengths; a sum short
/// of the horizon gets a last block holding the rest) or `control_horizon` (Nc ≤ N), N blocks of one
/// when both are absent. The two keys exclude each other, and blocks that overrun the horizon are an
/// error (MATLAB truncates them silently).
fn check_blocks(raw: &Raw, horizon: usize, diags: &mut Diagnostics) -> Option<Vec<usize>> {
    if let (Some(nc), Some(blocks)) = (&raw.control_horizon, &raw.move_blocking) {
        diags.push(
            Diagnostic::new(
                "`mpc.move_blocking` and `mpc.control_horizon` both set the free inputs",
                blocks.span.clone(),
            )
            .label("second definition of the blocks")
            .related(Some(nc.span.clone()), "and here")
            .note(format!(
                "hint: `control_horizon = {}` is `move_blocking = [{}]`; keep one of the two keys",
                nc.value,
                crate::held_after(horizon, nc.value.min(horizon))
                    .iter()
                    .map(|b| b.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        );
        return None;
    }
    if let Some(blocks) = &raw.move_blocking {
        let mut sum = 0;
        let mut kept = Vec::new();
        for &b in &blocks.value {
            if sum + b > horizon {
                let truncated = crate::truncated_blocks(&blocks.value, horizon);
                let list = |v: &[usize]| {
                    v.iter()
                        .map(|b| b.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                };
                diags.push(
                    Diagnostic::new(
                        format!(
                            "the blocks of `mpc.move_blocking` sum to {} steps, more than the prediction horizon `mpc.horizon` = {horizon}",
                            blocks.value.iter().sum::<usize>()
                        ),
                        blocks.span.clone(),
                    )
                    .label(format!("must sum to at most {horizon}"))
                    .note(format!(
                        "hint: MATLAB truncates these blocks to [{}]; write that to keep its meaning",
                        list(&truncated)
                    )),
                );
                return None;
            }
            sum += b;
            kept.push(b);
        }
        if sum < horizon {
            kept.push(horizon - sum);
        }
        return Some(kept);
    }
    let Some(nc) = &raw.control_horizon else {
        return Some(vec![1; horizon]);
    };
    if nc.value > horizon {
        diags.push(
            Diagnostic::new(
                format!(
                    "`mpc.control_horizon` = {} is longer than the prediction horizon `mpc.horizon` = {horizon}",
                    nc.value
                ),
                nc.span.clone(),
            )
            .label(format!("must be between 1 and {horizon}"))
            .note("hint: the control horizon counts the free inputs u_0 … u_{Nc−1} of the N predicted steps; leave it out for Nc = N"),
        );
        return None;
    }
    Some(crate::held_after(horizon, nc.value))
}
