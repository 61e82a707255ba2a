//! TOML to typed values, with checks on single values. Every value keeps its span; every mistake becomes
//! a [`Diagnostic`] and parsing goes on, so that all of them are reported at once.

use crate::diag::{Diagnostic, Diagnostics};
use crate::keys;
use crate::model::{Matrix, Span};
use std::collections::{BTreeMap, BTreeSet};
use toml::de::{DeTable, DeValue};
use toml::Spanned;

/// A value and where it was written.
#[derive(Clone, Debug, PartialEq)]
pub struct Located<T> {
    /// The value.
    pub value: T,
    /// Its byte range in the source.
    pub span: Span,
}

/// A weight or covariance as written: a number (times the identity), a list (the diagonal) or a list of
/// lists (the full matrix). Its size is checked once the model's dimensions are known.
#[derive(Clone, Debug, PartialEq)]
pub enum MatrixInput {
    /// `k`: k·I.
    Scalar(f64),
    /// `[d1, d2, ...]`: diag(d).
    Diagonal(Vec<f64>),
    /// `[[..], [..]]`: the rows.
    Full(Matrix),
}

impl MatrixInput {
    /// The n × n matrix, or what was found instead when the size is wrong.
    pub fn to_square(&self, n: usize) -> Result<Matrix, String> {
        match self {
            MatrixInput::Scalar(k) => Ok(Matrix::diagonal(&vec![*k; n])),
            MatrixInput::Diagonal(d) if d.len() == n => Ok(Matrix::diagonal(d)),
            MatrixInput::Diagonal(d) => Err(format!("a diagonal of {}", entries(d.len()))),
            MatrixInput::Full(m) if m.rows == n && m.cols == n => Ok(m.clone()),
            MatrixInput::Full(m) => Err(format!("a {}×{} matrix", m.rows, m.cols)),
        }
    }

    /// Every entry that was written (the diagonal for the short forms).
    pub fn written_diagonal(&self) -> Vec<f64> {
        match self {
            MatrixInput::Scalar(k) => vec![*k],
            MatrixInput::Diagonal(d) => d.clone(),
            MatrixInput::Full(m) => (0..m.rows.min(m.cols)).map(|i| m.get(i, i)).collect(),
        }
    }
}

/// The spec as written, each key typed and located; `None` where it is absent or unreadable.
#[derive(Debug, Default)]
pub struct Raw {
    pub model_span: Span,
    pub model_type: Option<Located<String>>,
    pub axes: Option<Located<usize>>,
    pub dt: Option<Located<f64>>,
    pub time: Option<Located<String>>,
    pub a: Option<Located<Matrix>>,
    pub b: Option<Located<Matrix>>,
    pub c: Option<Located<Matrix>>,

    pub mpc_span: Span,
    pub horizon: Option<Located<usize>>,
    pub control_horizon: Option<Located<usize>>,
    /// `move_blocking`: the block lengths, each entry located as `mpc.move_blocking[i]`.
    pub move_blocking: Option<Located<Vec<usize>>>,
    /// `None` inside for `"auto"`.
    pub iterations: Option<Located<Option<usize>>>,
    pub tolerance: Option<Located<f64>>,
    pub strict: Option<Located<bool>>,
    pub accept_unstable: Option<Located<bool>>,
    pub method: Option<Located<String>>,
    pub step: Option<Located<Option<f64>>>,
    pub admm_form: Option<Located<String>>,
    pub restart: Option<Located<String>>,
    pub q: Option<Located<MatrixInput>>,
    pub r: Option<Located<MatrixInput>>,
    /// `None` inside for `"lqr"`.
    pub qf: Option<Located<Option<MatrixInput>>>,
    pub qf_scale: Option<Located<f64>>,
    pub outputs: Option<Located<Matrix>>,
    pub r_du: Option<Located<MatrixInput>>,
    pub u_min: Option<Located<Vec<f64>>>,
    pub u_max: Option<Located<Vec<f64>>>,
    /// ±∞ entries allowed on the unbounded side, here and in the other bounds of issue 17.
    pub x_min: Option<Located<Vec<f64>>>,
    pub x_max: Option<Located<Vec<f64>>>,
    pub x_soft: Option<Located<f64>>,
    pub x_backoff: Option<Located<RawBackoff>>,
    pub du_min: Option<Located<Vec<f64>>>,
    pub du_max: Option<Located<Vec<f64>>>,
    /// `[[mpc.constraint]]`, one per table written, with what could be read of each.
    pub constraints: Vec<RawRowGroup>,
    pub accuracy: Option<Located<f64>>,
    /// The key `region` of `[mpc.region]`, when it is a table.
    pub region_span: Option<Span>,
    pub region_x_min: Option<Located<Vec<f64>>>,
    pub region_x_max: Option<Located<Vec<f64>>>,
    pub reference_min: Option<Located<Vec<f64>>>,
    pub reference_max: Option<Located<Vec<f64>>>,
    pub samples: Option<Located<usize>>,
    pub sequences: Option<Located<usize>>,
    pub steps: Option<Located<usize>>,
    pub certificate: Option<Located<String>>,
    pub exact_lps: Option<Located<usize>>,

    pub kalman_span: Span,
    pub sigma_a: Option<Located<f64>>,
    pub sigma_meas: Option<Located<MatrixInput>>,
    pub kalman_q: Option<Located<MatrixInput>>,
    pub kalman_r: Option<Located<MatrixInput>>,
    pub p0: Option<Located<MatrixInput>>,
    pub filter: Option<Located<String>>,
    pub disturbance: Option<Located<MatrixInput>>,
    /// `None` inside for `"off"`.
    pub gate: Option<Located<Option<f64>>>,
    /// `None` inside for `"off"`.
    pub stuck_cycles: Option<Located<Option<usize>>>,
    pub reacquire_after: Option<Located<usize>>,

    pub scalar: Option<Located<String>>,
    pub emission: Option<Located<String>>,
    pub target: Option<Located<String>>,
    pub clock_hz: Option<Located<f64>>,

    pub spans: BTreeMap<String, Span>,
    /// Every table and key written, readable or not (`"kalman"`, `"kalman.sigma_a"`), so that a value
    /// already reported as wrong is not reported again as missing.
    pub present: BTreeSet<String>,
    /// Keys offered as "did you mean" for a misspelled one: not reported again as missing.
    pub suggested: BTreeSet<String>,
    /// The top-level tables that are tables (`kalman = 3` is present, and reported, but not one).
    pub tables: BTreeSet<String>,
}

/// One `[[mpc.constraint]]` as written; `None` where a key is absent or unreadable.
#[derive(Debug)]
pub struct RawRowGroup {
    /// `mpc.constraint[i]`: the prefix of its keys in [`Raw::spans`] and [`Raw::present`].
    pub path: String,
    /// Its header `[[mpc.constraint]]` (or the inline table).
    pub span: Span,
    pub ax: Option<Located<Matrix>>,
    pub au: Option<Located<Matrix>>,
    pub lower: Option<Located<Vec<f64>>>,
    pub upper: Option<Located<Vec<f64>>>,
    pub soft: Option<Located<f64>>,
    pub backoff: Option<Located<RawBackoff>>,
}

/// A `backoff` as written, before its length is checked against the bounds it tightens.
#[derive(Clone, Debug, PartialEq)]
pub enum RawBackoff {
    /// One margin for every bound.
    Each(f64),
    /// One margin per entry (`x_backoff`: per state; a group's: per row), each located as `path[i]`.
    List(Vec<f64>),
    /// `"<z>sigma"`: z standard deviations of the filter's steady-state estimation error.
    Sigmas(f64),
}

/// What a `backoff` may be, for its errors.
const BACKOFF_HINT: &str = "hint: a margin in the bound's units (a number for every bound, or a list with one per entry), or \"<z>sigma\" (e.g. \"3sigma\") for z standard deviations of the Kalman filter's steady-state estimation error along the row";

/// Which side of a bound a list is: the side whose infinity means "unbounded".
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Side {
    /// A lower bound: `-inf` is unbounded, `inf` admits nothing.
    Lower,
    /// An upper bound: `inf` is unbounded, `-inf` admits nothing.
    Upper,
}

impl Raw {
    /// Whether `path` was written at all.
    pub fn has(&self, path: &str) -> bool {
        self.present.contains(path)
    }
}

type Value<'i> = Spanned<DeValue<'i>>;

/// Reads `source` into [`Raw`], reporting syntax errors, unknown or missing tables and keys, and values of
/// the wrong type or range.
pub fn parse(source: &str, diags: &mut Diagnostics) -> Raw {
    let mut raw = Raw::default();
    let root = match DeTable::parse(source) {
        Ok(root) => root,
        Err(e) => {
            diags.push(Diagnostic::new(
                format!("invalid TOML: {}", e.message().trim()),
                e.span(),
            ));
            return raw;
        }
    };
    let mut p = Parser {
        diags,
        spans: BTreeMap::new(),
        present: BTreeSet::new(),
        suggested: BTreeSet::new(),
        tables: BTreeSet::new(),
    };
    let root_span = root.span();
    let root = root.get_ref();
    p.unknown_keys(root, keys::TABLES, "", "table");

    if let Some((span, t)) = p.table(root, keys::MODEL, &root_span, true) {
        raw.model_span = span.clone();
        p.unknown_keys(t, keys::MODEL_KEYS, "model", "key");
        raw.model_type = p
            .required(t, "model", "type", &span)
            .and_then(|v| p.choice(v, "model.type", keys::MODEL_TYPES));
        raw.axes = t
            .get("axes")
            .and_then(|v| p.count_at_most(v, "model.axes", 1, crate::MAX_AXES as i64, AXES_LIMIT));
        raw.dt = p
            .required(t, "model", "dt", &span)
            .and_then(|v| p.positive(v, "model.dt"));
        raw.time = t
            .get("time")
            .and_then(|v| p.choice(v, "model.time", keys::TIMES));
        raw.a = t.get("a").and_then(|v| p.matrix(v, "model.a"));
        raw.b = t.get("b").and_then(|v| p.matrix(v, "model.b"));
        raw.c = t.get("c").and_then(|v| p.matrix(v, "model.c"));
    }
    if let Some((span, t)) = p.table(root, keys::MPC, &root_span, true) {
        raw.mpc_span = span.clone();
        p.unknown_keys(t, keys::MPC_KEYS, "mpc", "key");
        raw.horizon = p.required(t, "mpc", "horizon", &span).and_then(|v| {
            p.count_at_most(
                v,
                "mpc.horizon",
                1,
                crate::MAX_HORIZON as i64,
                HORIZON_LIMIT,
            )
        });
        raw.control_horizon = t.get("control_horizon").and_then(|v| {
            p.count_at_most(
                v,
                "mpc.control_horizon",
                1,
                crate::MAX_HORIZON as i64,
                HORIZON_LIMIT,
            )
        });
        raw.move_blocking = t
            .get("move_blocking")
            .and_then(|v| p.counts(v, "mpc.move_blocking", 1, crate::MAX_HORIZON as i64));
        raw.iterations = p
            .required(t, "mpc", "iterations", &span)
            .and_then(|v| p.iterations(v));
        raw.tolerance = t
            .get("tolerance")
            .and_then(|v| p.fraction(v, "mpc.tolerance"));
        raw.strict = t.get("strict").and_then(|v| p.boolean(v, "mpc.strict"));
        raw.accept_unstable = t
            .get("accept_unstable")
            .and_then(|v| p.boolean(v, "mpc.accept_unstable"));
        raw.method = t
            .get("method")
            .and_then(|v| p.choice(v, "mpc.method", keys::METHODS));
        raw.step = t.get("step").and_then(|v| p.step(v));
        raw.admm_form = t
            .get("admm_form")
            .and_then(|v| p.choice(v, "mpc.admm_form", keys::ADMM_FORMS));
        raw.restart = t
            .get("restart")
            .and_then(|v| p.choice(v, "mpc.restart", keys::RESTARTS));
        raw.q = p
            .required(t, "mpc", "q", &span)
            .and_then(|v| p.matrix_input(v, "mpc.q", false));
        raw.r = p
            .required(t, "mpc", "r", &span)
            .and_then(|v| p.matrix_input(v, "mpc.r", false));
        raw.qf = t.get("qf").and_then(|v| {
            p.word_or(
                v,
                "mpc.qf",
                "lqr",
                "hint: write \"lqr\" for the solution of the discrete algebraic Riccati equation, or a number, a list (a diagonal) or a list of lists (a matrix)",
                |p, v| p.matrix_input(v, "mpc.qf", false),
            )
        });
        raw.qf_scale = t
            .get("qf_scale")
            .and_then(|v| p.non_negative(v, "mpc.qf_scale"));
        raw.outputs = t.get("outputs").and_then(|v| p.rows(v, "mpc.outputs"));
        raw.r_du = t
            .get("r_du")
            .and_then(|v| p.matrix_input(v, "mpc.r_du", false));
        raw.u_min = p
            .required(t, "mpc", "u_min", &span)
            .and_then(|v| p.vector(v, "mpc.u_min"));
        raw.u_max = p
            .required(t, "mpc", "u_max", &span)
            .and_then(|v| p.vector(v, "mpc.u_max"));
        raw.x_min = t
            .get("x_min")
            .and_then(|v| p.bounds(v, "mpc.x_min", Side::Lower));
        raw.x_max = t
            .get("x_max")
            .and_then(|v| p.bounds(v, "mpc.x_max", Side::Upper));
        raw.x_soft = t.get("x_soft").and_then(|v| p.positive(v, "mpc.x_soft"));
        raw.x_backoff = t
            .get("x_backoff")
            .and_then(|v| p.backoff(v, "mpc.x_backoff"));
        raw.du_min = t
            .get("du_min")
            .and_then(|v| p.bounds(v, "mpc.du_min", Side::Lower));
        raw.du_max = t
            .get("du_max")
            .and_then(|v| p.bounds(v, "mpc.du_max", Side::Upper));
        if let Some(v) = t.get(keys::CONSTRAINT) {
            raw.constraints = p.row_groups(v);
        }
        raw.accuracy = t.get("accuracy").and_then(|v| p.accuracy(v));
        if let Some(r) = p.sub_table(t, "mpc", keys::REGION) {
            raw.region_span = Some(r.0);
            let r = r.1;
            p.unknown_keys(r, keys::REGION_KEYS, "mpc.region", "key");
            raw.region_x_min = r.get("x_min").and_then(|v| p.listed(v, "mpc.region.x_min"));
            raw.region_x_max = r.get("x_max").and_then(|v| p.listed(v, "mpc.region.x_max"));
            raw.reference_min = r
                .get("reference_min")
                .and_then(|v| p.listed(v, "mpc.region.reference_min"));
            raw.reference_max = r
                .get("reference_max")
                .and_then(|v| p.listed(v, "mpc.region.reference_max"));
            raw.samples = r
                .get("samples")
                .and_then(|v| p.count_at_most(v, "mpc.region.samples", 0, 10_000, SAMPLES_LIMIT));
            raw.sequences = r
                .get("sequences")
                .and_then(|v| p.count_at_most(v, "mpc.region.sequences", 0, 100, SEQUENCES_LIMIT));
            raw.steps = r
                .get("steps")
                .and_then(|v| p.count_at_most(v, "mpc.region.steps", 1, 1000, STEPS_LIMIT));
            raw.certificate = r
                .get("certificate")
                .and_then(|v| p.choice(v, "mpc.region.certificate", keys::CERTIFICATES));
            raw.exact_lps = r.get("exact_lps").and_then(|v| {
                p.count_at_most(
                    v,
                    "mpc.region.exact_lps",
                    1,
                    EXACT_LPS_MAX as i64,
                    EXACT_LPS_LIMIT,
                )
            });
        }
    }
    // `[kalman]` is optional: without it the controller takes the measured state.
    if let Some((span, t)) = p.table(root, keys::KALMAN, &root_span, false) {
        raw.kalman_span = span;
        p.unknown_keys(t, keys::KALMAN_KEYS, "kalman", "key");
        raw.sigma_a = t
            .get("sigma_a")
            .and_then(|v| p.positive(v, "kalman.sigma_a"));
        raw.sigma_meas = t
            .get("sigma_meas")
            .and_then(|v| p.matrix_input(v, "kalman.sigma_meas", true));
        raw.kalman_q = t
            .get("q")
            .and_then(|v| p.matrix_input(v, "kalman.q", false));
        raw.kalman_r = t
            .get("r")
            .and_then(|v| p.matrix_input(v, "kalman.r", false));
        raw.p0 = t
            .get("p0")
            .and_then(|v| p.matrix_input(v, "kalman.p0", false));
        raw.disturbance = t
            .get("disturbance")
            .and_then(|v| p.matrix_input(v, "kalman.disturbance", true));
        raw.filter = t
            .get("filter")
            .and_then(|v| p.choice(v, "kalman.filter", keys::FILTERS));
        raw.gate = t.get("gate").and_then(|v| {
            p.word_or(v, "kalman.gate", "off", GATE_HINT, |p, v| {
                p.positive(v, "kalman.gate")
            })
        });
        raw.stuck_cycles = t.get("stuck_cycles").and_then(|v| {
            p.word_or(v, "kalman.stuck_cycles", "off", STUCK_HINT, |p, v| {
                p.count_at_most(v, "kalman.stuck_cycles", 2, COUNT_MAX, STUCK_HINT)
            })
        });
        raw.reacquire_after = t.get("reacquire_after").and_then(|v| {
            p.count_at_most(v, "kalman.reacquire_after", 1, COUNT_MAX, REACQUIRE_HINT)
        });
    }
    if let Some((_, t)) = p.table(root, keys::CODEGEN, &root_span, false) {
        p.unknown_keys(t, keys::CODEGEN_KEYS, "codegen", "key");
        raw.scalar = t
            .get("scalar")
            .and_then(|v| p.choice(v, "codegen.scalar", keys::SCALARS));
        raw.emission = t
            .get("emission")
            .and_then(|v| p.choice(v, "codegen.emission", keys::EMISSIONS));
        raw.target = t
            .get("target")
            .and_then(|v| p.choice(v, "codegen.target", keys::TARGETS));
        raw.clock_hz = t
            .get("clock_hz")
            .and_then(|v| p.positive(v, "codegen.clock_hz"));
    }
    raw.spans = p.spans;
    raw.present = p.present;
    raw.suggested = p.suggested;
    raw.tables = p.tables;
    raw
}

struct Parser<'d> {
    diags: &'d mut Diagnostics,
    spans: BTreeMap<String, Span>,
    present: BTreeSet<String>,
    /// Keys offered as "did you mean" for a misspelled one: not reported again as missing.
    suggested: BTreeSet<String>,
    /// The tables written as tables (`Raw::tables`).
    tables: BTreeSet<String>,
}

impl Parser<'_> {
    fn err(&mut self, d: Diagnostic) {
        self.diags.push(d);
    }

    /// The table `name`, its span, and whether it is a table; reports it when required and absent.
    fn table<'a, 'i>(
        &mut self,
        root: &'a DeTable<'i>,
        name: &str,
        root_span: &Span,
        required: bool,
    ) -> Option<(Span, &'a DeTable<'i>)> {
        let Some(v) = root.get(name) else {
            if required {
                self.err(
                    Diagnostic::new(
                        format!("missing table `[{name}]`"),
                        root_span.start..root_span.start,
                    )
                    .note(format!(
                        "hint: every spec has `[model]` and `[mpc]`; add `[{name}]`"
                    )),
                );
            }
            return None;
        };
        // The header's span: the key of the table in its parent.
        let key_span = root.get_key_value(name).map_or(v.span(), |(k, _)| k.span());
        self.spans.insert(name.to_string(), key_span.clone());
        match v.get_ref() {
            DeValue::Table(t) => {
                self.tables.insert(name.to_string());
                Some((key_span, t))
            }
            other => {
                self.err(
                    Diagnostic::new(
                        format!("`{name}` must be a table, found {}", other.type_str()),
                        v.span(),
                    )
                    .note(format!(
                        "hint: write `[{name}]` on a line of its own, followed by its keys"
                    )),
                );
                None
            }
        }
    }

    /// Reports every key of `t` not in `allowed`, with the closest allowed one as a hint.
    /// Records every key of the table `table` ("" for the root) as present.
    fn unknown_keys(&mut self, t: &DeTable<'_>, allowed: &[&str], table: &str, what: &str) {
        let place = if table.is_empty() {
            "the spec".to_string()
        } else {
            format!("`[{table}]`")
        };
        self.unknown_keys_in(t, allowed, table, &place, what);
    }

    /// [`Self::unknown_keys`] of the table at `table` (`mpc.constraint[0]`), called `place` in messages.
    fn unknown_keys_in(
        &mut self,
        t: &DeTable<'_>,
        allowed: &[&str],
        table: &str,
        place: &str,
        what: &str,
    ) {
        for (k, _) in t.iter() {
            let key: &str = k.get_ref();
            self.present.insert(if table.is_empty() {
                key.to_string()
            } else {
                format!("{table}.{key}")
            });
            if allowed.contains(&key) {
                continue;
            }
            let mut d = Diagnostic::new(format!("unknown {what} `{key}` in {place}"), k.span())
                .label(format!("unknown {what}"));
            d = if let Some(close) = closest(allowed, key) {
                let prefix = if table.is_empty() {
                    String::new()
                } else {
                    format!("{table}.")
                };
                self.suggested.insert(format!("{prefix}{close}"));
                d.note(format!("hint: did you mean `{close}`?"))
            } else {
                d.note(format!(
                    "hint: the {what}s allowed here are {}",
                    quoted(allowed)
                ))
            };
            self.err(d);
        }
    }

    fn required<'a, 'i>(
        &mut self,
        t: &'a DeTable<'i>,
        table: &str,
        key: &str,
        table_span: &Span,
    ) -> Option<&'a Value<'i>> {
        self.required_in(t, table, &format!("`[{table}]`"), key, table_span)
    }

    /// [`Self::required`] in the table at `table`, called `place` in messages.
    fn required_in<'a, 'i>(
        &mut self,
        t: &'a DeTable<'i>,
        table: &str,
        place: &str,
        key: &str,
        table_span: &Span,
    ) -> Option<&'a Value<'i>> {
        let v = t.get(key);
        // A misspelled key was reported with this one as its suggestion: once is enough.
        if v.is_none() && !self.suggested.contains(&format!("{table}.{key}")) {
            self.err(
                Diagnostic::new(
                    format!("missing key `{key}` in {place}"),
                    table_span.clone(),
                )
                .label(format!("`{key}` is required in this table")),
            );
        }
        v
    }

    fn located<T>(&mut self, path: &str, v: &Value<'_>, value: T) -> Located<T> {
        self.spans.insert(path.to_string(), v.span());
        Located {
            value,
            span: v.span(),
        }
    }

    /// A finite number, written as an integer or a float.
    fn number_of(&mut self, v: &Value<'_>, path: &str) -> Option<f64> {
        let parsed = match v.get_ref() {
            DeValue::Integer(i) => i64::from_str_radix(&i.as_str().replace('_', ""), i.radix())
                .ok()
                .map(|i| i as f64),
            DeValue::Float(f) => f.as_str().replace('_', "").parse::<f64>().ok(),
            other => {
                self.err(
                    Diagnostic::new(
                        format!("`{path}` must be a number, found {}", other.type_str()),
                        v.span(),
                    )
                    .label("expected a number"),
                );
                return None;
            }
        };
        match parsed {
            Some(x) if x.is_finite() => Some(x),
            _ => {
                self.err(
                    Diagnostic::new(format!("`{path}` must be a finite number"), v.span())
                        .label("not finite"),
                );
                None
            }
        }
    }

    fn number(&mut self, v: &Value<'_>, path: &str) -> Option<Located<f64>> {
        let x = self.number_of(v, path)?;
        Some(self.located(path, v, x))
    }

    fn positive(&mut self, v: &Value<'_>, path: &str) -> Option<Located<f64>> {
        let x = self.number(v, path)?;
        if x.value > 0.0 {
            return Some(x);
        }
        self.err(
            Diagnostic::new(
                format!("`{path}` must be positive, found {}", x.value),
                v.span(),
            )
            .label("must be > 0"),
        );
        None
    }

    fn non_negative(&mut self, v: &Value<'_>, path: &str) -> Option<Located<f64>> {
        let x = self.number(v, path)?;
        if x.value >= 0.0 {
            return Some(x);
        }
        self.err(
            Diagnostic::new(
                format!("`{path}` must not be negative, found {}", x.value),
                v.span(),
            )
            .label("must be ≥ 0"),
        );
        None
    }

    /// A whole number in `min..=max`; `why` explains the upper limit.
    fn count_at_most(
        &mut self,
        v: &Value<'_>,
        path: &str,
        min: i64,
        max: i64,
        why: &str,
    ) -> Option<Located<usize>> {
        let n = match v.get_ref() {
            DeValue::Integer(i) => {
                i64::from_str_radix(&i.as_str().replace('_', ""), i.radix()).ok()
            }
            other => {
                self.err(
                    Diagnostic::new(
                        format!(
                            "`{path}` must be a whole number, found {}",
                            other.type_str()
                        ),
                        v.span(),
                    )
                    .label("expected an integer"),
                );
                return None;
            }
        };
        match n {
            Some(n) if n >= min && n <= max => Some(self.located(path, v, n as usize)),
            _ => {
                let mut d = Diagnostic::new(
                    format!("`{path}` must be between {min} and {max}"),
                    v.span(),
                )
                .label("out of range");
                if !why.is_empty() && n.is_some_and(|n| n > max) {
                    d = d.note(why.to_string());
                }
                self.err(d);
                None
            }
        }
    }

    /// One of `options`.
    fn choice(&mut self, v: &Value<'_>, path: &str, options: &[&str]) -> Option<Located<String>> {
        match v.get_ref() {
            DeValue::String(s) if options.contains(&s.as_ref()) => {
                let s = s.to_string();
                Some(self.located(path, v, s))
            }
            DeValue::String(s) => {
                let note = match closest(options, s) {
                    Some(close) => format!(
                        "hint: did you mean `{close}`? (expected one of {})",
                        quoted(options)
                    ),
                    None => format!("hint: expected one of {}", quoted(options)),
                };
                self.err(
                    Diagnostic::new(format!("unknown value \"{s}\" for `{path}`"), v.span())
                        .label("unknown value")
                        .note(note),
                );
                None
            }
            other => {
                self.err(
                    Diagnostic::new(
                        format!("`{path}` must be a string, found {}", other.type_str()),
                        v.span(),
                    )
                    .note(format!("hint: expected one of {}", quoted(options))),
                );
                None
            }
        }
    }

    /// `word` (None) or what `value` reads; any other string is an unknown value with `hint`.
    fn word_or<T>(
        &mut self,
        v: &Value<'_>,
        path: &str,
        word: &str,
        hint: &str,
        value: impl FnOnce(&mut Self, &Value<'_>) -> Option<Located<T>>,
    ) -> Option<Located<Option<T>>> {
        match v.get_ref() {
            DeValue::String(s) if s == word => Some(self.located(path, v, None)),
            DeValue::String(s) => {
                self.err(
                    Diagnostic::new(format!("unknown value \"{s}\" for `{path}`"), v.span())
                        .label("unknown value")
                        .note(hint.to_string()),
                );
                None
            }
            _ => value(self, v).map(|x| Located {
                value: Some(x.value),
                span: x.span,
            }),
        }
    }

    /// `"auto"` (None) or a whole number of at least 1.
    fn iterations(&mut self, v: &Value<'_>) -> Option<Located<Option<usize>>> {
        let max = crate::MAX_ITERATIONS as i64;
        self.word_or(
            v,
            "mpc.iterations",
            "auto",
            "hint: write \"auto\" (with `tolerance`) or a whole number",
            |p, v| p.count_at_most(v, "mpc.iterations", 1, max, ""),
        )
    }

    /// A number strictly between 0 and 1.
    fn fraction(&mut self, v: &Value<'_>, path: &str) -> Option<Located<f64>> {
        let x = self.number(v, path)?;
        if x.value > 0.0 && x.value < 1.0 {
            return Some(x);
        }
        self.err(
            Diagnostic::new(
                format!(
                    "`{path}` must be between 0 and 1 (exclusive), found {}",
                    x.value
                ),
                v.span(),
            )
            .label("out of range"),
        );
        None
    }

    /// `true` or `false`.
    fn boolean(&mut self, v: &Value<'_>, path: &str) -> Option<Located<bool>> {
        match v.get_ref() {
            DeValue::Boolean(b) => Some(self.located(path, v, *b)),
            other => {
                self.err(
                    Diagnostic::new(
                        format!("`{path}` must be true or false, found {}", other.type_str()),
                        v.span(),
                    )
                    .label("expected a boolean"),
                );
                None
            }
        }
    }

    /// `"auto"` (None) or a positive number.
    fn step(&mut self, v: &Value<'_>) -> Option<Located<Option<f64>>> {
        self.word_or(
            v,
            "mpc.step",
            "auto",
            "hint: write \"auto\" for 1/L, or a positive number",
            |p, v| p.positive(v, "mpc.step"),
        )
    }

    fn array<'a, 'i>(
        &mut self,
        v: &'a Value<'i>,
        path: &str,
        what: &str,
    ) -> Option<&'a [Value<'i>]> {
        match v.get_ref() {
            DeValue::Array(a) if !a.is_empty() => Some(a),
            DeValue::Array(_) => {
                self.err(
                    Diagnostic::new(format!("`{path}` must not be empty"), v.span()).label("empty"),
                );
                None
            }
            other => {
                self.err(
                    Diagnostic::new(
                        format!("`{path}` must be {what}, found {}", other.type_str()),
                        v.span(),
                    )
                    .label(format!("expected {what}")),
                );
                None
            }
        }
    }

    /// A list of whole numbers in `min..=max`, each entry located as `path[i]`.
    fn counts(
        &mut self,
        v: &Value<'_>,
        path: &str,
        min: i64,
        max: i64,
    ) -> Option<Located<Vec<usize>>> {
        let items = self.array(v, path, "a list of whole numbers")?;
        self.item_spans(v, path);
        let values: Vec<Option<usize>> = items
            .iter()
            .map(|x| self.count_at_most(x, path, min, max, "").map(|c| c.value))
            .collect();
        let values: Option<Vec<usize>> = values.into_iter().collect();
        Some(self.located(path, v, values?))
    }

    /// A list of numbers.
    fn vector(&mut self, v: &Value<'_>, path: &str) -> Option<Located<Vec<f64>>> {
        let items = self.array(v, path, "a list of numbers")?;
        let values: Vec<Option<f64>> = items.iter().map(|x| self.number_of(x, path)).collect();
        let values: Option<Vec<f64>> = values.into_iter().collect();
        Some(self.located(path, v, values?))
    }

    /// A list of equally long lists of numbers.
    fn matrix(&mut self, v: &Value<'_>, path: &str) -> Option<Located<Matrix>> {
        let rows = self.array(v, path, "a list of rows")?;
        // A flat list is a matrix written without its rows, not rows of the wrong type (a number among
        // rows is that row's mistake, reported by `vector`).
        if rows.iter().all(|r| !r.get_ref().is_array()) {
            self.err(
                Diagnostic::new(
                    format!(
                        "`{path}` must be a list of rows, found a flat list of {}",
                        entries(rows.len())
                    ),
                    v.span(),
                )
                .label("expected a list of rows")
                .note("hint: write each row in brackets: `[[1, 0.1], [0, 1]]`"),
            );
            return None;
        }
        let mut out = Vec::with_capacity(rows.len());
        for row in rows {
            out.push(self.vector(row, path)?.value);
        }
        if out.iter().any(|r| r.len() != out[0].len()) {
            self.err(
                Diagnostic::new(format!("the rows of `{path}` differ in length"), v.span()).label(
                    format!(
                        "row lengths {:?}",
                        out.iter().map(Vec::len).collect::<Vec<_>>()
                    ),
                ),
            );
            return None;
        }
        Some(self.located(path, v, Matrix::from_rows(&out)))
    }

    /// A number, a list (a diagonal) or a list of lists (a full matrix).
    fn matrix_input(
        &mut self,
        v: &Value<'_>,
        path: &str,
        positive: bool,
    ) -> Option<Located<MatrixInput>> {
        let input = match v.get_ref() {
            DeValue::Integer(_) | DeValue::Float(_) => {
                MatrixInput::Scalar(self.number_of(v, path)?)
            }
            DeValue::Array(a) if a.first().is_some_and(|x| x.get_ref().is_array()) => {
                MatrixInput::Full(self.matrix(v, path)?.value)
            }
            DeValue::Array(_) => MatrixInput::Diagonal(self.vector(v, path)?.value),
            other => {
                self.err(
                    Diagnostic::new(
                        format!(
                            "`{path}` must be a number, a list or a list of lists, found {}",
                            other.type_str()
                        ),
                        v.span(),
                    )
                    .note("hint: a list is a diagonal; a list of lists is a full matrix"),
                );
                return None;
            }
        };
        let diag = input.written_diagonal();
        let bad = if positive {
            diag.iter().any(|d| *d <= 0.0)
        } else {
            diag.iter().any(|d| *d < 0.0)
        };
        if bad {
            let rule = if positive { "positive" } else { "non-negative" };
            self.err(
                Diagnostic::new(format!("the diagonal of `{path}` must be {rule}"), v.span())
                    .label(format!(
                        "a {} diagonal entry",
                        if positive { "non-positive" } else { "negative" }
                    )),
            );
            return None;
        }
        Some(self.located(path, v, input))
    }

    /// The table `key` of `parent` (at `parent_path`) and the span of its key; reports it when it is not a
    /// table.
    fn sub_table<'a, 'i>(
        &mut self,
        parent: &'a DeTable<'i>,
        parent_path: &str,
        key: &str,
    ) -> Option<(Span, &'a DeTable<'i>)> {
        let (k, v) = parent.get_key_value(key)?;
        let path = format!("{parent_path}.{key}");
        self.spans.insert(path.clone(), k.span());
        match v.get_ref() {
            DeValue::Table(t) => Some((k.span(), t)),
            other => {
                self.err(
                    Diagnostic::new(
                        format!("`{path}` must be a table, found {}", other.type_str()),
                        v.span(),
                    )
                    .label("expected a table")
                    .note(format!(
                        "hint: write `[{path}]` on a line of its own, followed by its keys"
                    )),
                );
                None
            }
        }
    }

    /// Records the span of every item of the list `v` as `path[i]`, for diagnostics on one entry or row.
    fn item_spans(&mut self, v: &Value<'_>, path: &str) {
        if let DeValue::Array(items) = v.get_ref() {
            for (i, item) in items.iter().enumerate() {
                self.spans.insert(format!("{path}[{i}]"), item.span());
            }
        }
    }

    /// A list of finite numbers, each entry located as `path[i]`.
    fn listed(&mut self, v: &Value<'_>, path: &str) -> Option<Located<Vec<f64>>> {
        let list = self.vector(v, path)?;
        self.item_spans(v, path);
        Some(list)
    }

    /// A list of bounds: finite numbers, or the TOML infinity of the unbounded side (`-inf` for a lower
    /// bound, `inf` for an upper one); each entry located as `path[i]`.
    fn bounds(&mut self, v: &Value<'_>, path: &str, side: Side) -> Option<Located<Vec<f64>>> {
        let items = self.array(v, path, "a list of numbers")?;
        let (free, wrong) = match side {
            Side::Lower => ("-inf", "inf"),
            Side::Upper => ("inf", "-inf"),
        };
        let mut ok = true;
        let mut out = Vec::with_capacity(items.len());
        for item in items {
            let x = match item.get_ref() {
                DeValue::Float(f) => {
                    let text = f.as_str().replace('_', "");
                    let x = text.parse::<f64>().ok();
                    // Only the literal `inf` is an infinity: `1e999` overflowed.
                    let literal = text.trim_start_matches(['+', '-']) == "inf";
                    match x {
                        Some(x) if x.is_finite() || (literal && x.is_infinite()) => Some(x),
                        Some(x) if x.is_nan() => {
                            self.err(
                                Diagnostic::new(format!("`{path}` must not be nan"), item.span())
                                    .label("not a number")
                                    .note(format!(
                                        "hint: write `{free}` for an entry without a bound"
                                    )),
                            );
                            None
                        }
                        _ => {
                            self.err(
                                Diagnostic::new(
                                    format!("`{path}` must be a finite number or `{free}`"),
                                    item.span(),
                                )
                                .label("beyond the range of f64")
                                .note(format!("hint: write `{free}` for an entry without a bound")),
                            );
                            None
                        }
                    }
                }
                _ => self.number_of(item, path),
            };
            let x = match x {
                Some(x) if x.is_infinite() && (x < 0.0) != (side == Side::Lower) => {
                    let what = match side {
                        Side::Lower => "a lower bound of +∞ admits no value",
                        Side::Upper => "an upper bound of −∞ admits no value",
                    };
                    self.err(
                        Diagnostic::new(format!("`{path}` cannot be `{wrong}`"), item.span())
                            .label(what)
                            .note(format!(
                                "hint: `{free}` leaves an entry of `{path}` unbounded"
                            )),
                    );
                    None
                }
                x => x,
            };
            ok &= x.is_some();
            out.push(x.unwrap_or(0.0));
        }
        if !ok {
            return None;
        }
        self.item_spans(v, path);
        Some(self.located(path, v, out))
    }

    /// `[[mpc.constraint]]`: an array of tables, each read as far as it goes.
    fn row_groups(&mut self, v: &Value<'_>) -> Vec<RawRowGroup> {
        let path = "mpc.constraint";
        self.spans.insert(path.to_string(), v.span());
        let DeValue::Array(items) = v.get_ref() else {
            self.err(
                Diagnostic::new(
                    format!(
                        "`{path}` must be an array of tables, found {}",
                        v.get_ref().type_str()
                    ),
                    v.span(),
                )
                .label("expected `[[mpc.constraint]]` tables")
                .note("hint: write each group of rows as a table of its own: `[[mpc.constraint]]` on a line, then its `ax`, `au`, `lower`, `upper`"),
            );
            return Vec::new();
        };
        let place = "`[[mpc.constraint]]`";
        let mut out = Vec::new();
        for (i, item) in items.iter().enumerate() {
            let group = format!("{path}[{i}]");
            self.spans.insert(group.clone(), item.span());
            self.present.insert(group.clone());
            let DeValue::Table(t) = item.get_ref() else {
                self.err(
                    Diagnostic::new(
                        format!(
                            "`{group}` must be a table, found {}",
                            item.get_ref().type_str()
                        ),
                        item.span(),
                    )
                    .label("expected a table")
                    .note("hint: write `[[mpc.constraint]]` on a line of its own, followed by the group's keys"),
                );
                continue;
            };
            self.unknown_keys_in(t, keys::CONSTRAINT_KEYS, &group, place, "key");
            let span = item.span();
            let ax = self
                .required_in(t, &group, place, "ax", &span)
                .and_then(|v| self.rows(v, &format!("{group}.ax")));
            let au = t
                .get("au")
                .and_then(|v| self.rows(v, &format!("{group}.au")));
            let lower = t
                .get("lower")
                .and_then(|v| self.bounds(v, &format!("{group}.lower"), Side::Lower));
            let upper = t
                .get("upper")
                .and_then(|v| self.bounds(v, &format!("{group}.upper"), Side::Upper));
            let soft = t
                .get("soft")
                .and_then(|v| self.positive(v, &format!("{group}.soft")));
            let backoff = t
                .get("backoff")
                .and_then(|v| self.backoff(v, &format!("{group}.backoff")));
            out.push(RawRowGroup {
                path: group,
                span,
                ax,
                au,
                lower,
                upper,
                soft,
                backoff,
            });
        }
        out
    }

    /// A `backoff`: a margin ≥ 0, a list of them, or `"<z>sigma"` with z > 0.
    fn backoff(&mut self, v: &Value<'_>, path: &str) -> Option<Located<RawBackoff>> {
        match v.get_ref() {
            DeValue::String(s) => {
                let z = s
                    .strip_suffix("sigma")
                    .and_then(|z| z.trim().parse::<f64>().ok())
                    .filter(|z| z.is_finite() && *z > 0.0);
                match z {
                    Some(z) => Some(self.located(path, v, RawBackoff::Sigmas(z))),
                    None => {
                        self.err(
                            Diagnostic::new(
                                format!("unknown value \"{s}\" for `{path}`"),
                                v.span(),
                            )
                            .label("expected \"<z>sigma\" with z > 0, or a margin")
                            .note(BACKOFF_HINT),
                        );
                        None
                    }
                }
            }
            DeValue::Array(_) => {
                let list = self.listed(v, path)?;
                let mut ok = true;
                if let DeValue::Array(items) = v.get_ref() {
                    for (item, x) in items.iter().zip(&list.value) {
                        if *x < 0.0 {
                            ok = false;
                            self.err(
                                Diagnostic::new(
                                    format!("`{path}` must not be negative, found {x}"),
                                    item.span(),
                                )
                                .label("a back-off pulls a bound in, by a margin ≥ 0")
                                .note(BACKOFF_HINT),
                            );
                        }
                    }
                }
                ok.then(|| self.located(path, v, RawBackoff::List(list.value)))
            }
            DeValue::Integer(_) | DeValue::Float(_) => {
                let x = self.non_negative(v, path)?;
                Some(self.located(path, v, RawBackoff::Each(x.value)))
            }
            other => {
                self.err(
                    Diagnostic::new(format!("`{path}` must be a number, a list of numbers or \"<z>sigma\", found {}", other.type_str()), v.span())
                        .label("expected a margin or \"<z>sigma\"")
                        .note(BACKOFF_HINT),
                );
                None
            }
        }
    }

    /// A matrix whose rows are located as `path[i]`.
    fn rows(&mut self, v: &Value<'_>, path: &str) -> Option<Located<Matrix>> {
        let m = self.matrix(v, path)?;
        self.item_spans(v, path);
        Some(m)
    }

    /// `accuracy`: a number in (0, 0.5].
    fn accuracy(&mut self, v: &Value<'_>) -> Option<Located<f64>> {
        let path = "mpc.accuracy";
        let x = self.number(v, path)?;
        if x.value > 0.0 && x.value <= 0.5 {
            return Some(x);
        }
        self.err(
            Diagnostic::new(
                format!("`{path}` must be above 0 and at most 0.5, found {}", x.value),
                v.span(),
            )
            .label("out of range")
            .note(format!("hint: `accuracy` is relative: the plan within accuracy·(u_max − u_min) of the exact solution, a row violated by at most accuracy·max(1, |bound|); the default is {}", crate::DEFAULT_ACCURACY)),
        );
        None
    }
}

/// The largest cycle count `[kalman]` takes: the emitted counters are `u32`.
const COUNT_MAX: i64 = u32::MAX as i64;
const GATE_HINT: &str = "hint: the gate is a threshold on the normalized innovation squared (χ² with ny degrees of freedom), e.g. 30.7 for ny = 3 at a false-rejection probability of 1e-6; write \"off\" to fuse every finite reading";
const STUCK_HINT: &str = "hint: the number of bit-identical readings in a row after which the sensor is taken as stuck (at least 2), or \"off\"";
const REACQUIRE_HINT: &str = "hint: the number of consecutive gated, changing readings after which the filter re-acquires from the measurement";
/// Why the number of axes is bounded.
const AXES_LIMIT: &str = "hint: each axis adds two states, and every weight and covariance is a dense matrix over all of them; a controller this large is refused by the build budgets anyway";

/// Why the region's sample counts are bounded: the compiler runs them all at build time.
const SAMPLES_LIMIT: &str = "hint: the compiler solves every sampled QP at build time to certify the interior-point method, in the macro's compilation; 10000 draws (besides the corners) already take seconds";
const SEQUENCES_LIMIT: &str = "hint: the compiler runs every closed-loop sequence at build time to certify the interior-point method warm-started, in the macro's compilation; keep it to a few dozen";
/// The most feasibility LPs `[mpc.region] exact_lps` may give each block's partition.
pub const EXACT_LPS_MAX: usize = 10_000_000;
const EXACT_LPS_LIMIT: &str = "hint: the exact count solves up to this many small LPs per block in the macro's compilation, about 10 µs each: 10000000 is a couple of minutes a block; a partition that needs more has more regions than a build can enumerate";
const STEPS_LIMIT: &str = "hint: each step of a closed-loop sequence is one QP the compiler solves at build time; 1000 steps per sequence are far past any transient";

/// Why the horizon is bounded.
const HORIZON_LIMIT: &str = "hint: the emitted code unrolls the products with H (N·nu × N·nu) and Fr (N·nu × N·nx), which grow as N²; beyond this the generated source and its compile time grow past what is sensible for a fixed-iteration controller";

/// "1 entry", "3 entries".
pub fn entries(n: usize) -> String {
    if n == 1 {
        "1 entry".to_string()
    } else {
        format!("{n} entries")
    }
}

/// The spelling in `options` closest to `written`, when it is close enough to be a typo of it (Jaro-Winkler
/// similarity above 0.8): the "did you mean" of unknown keys and values.
fn closest<'a>(options: &[&'a str], written: &str) -> Option<&'a str> {
    let (score, best) = options
        .iter()
        .map(|o| (strsim::jaro_winkler(o, written), *o))
        .fold((0.0, ""), |best, c| if c.0 > best.0 { c } else { best });
    (score > 0.8).then_some(best)
}

fn quoted(options: &[&str]) -> String {
    options
        .iter()
        .map(|o| format!("`{o}`"))
        .collect::<Vec<_>>()
        .join(", ")
}
