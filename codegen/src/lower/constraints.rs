//! The constraints beyond the input box, lowered onto the condensed QP's variables.
//!
//! `x_min`/`x_max`, `du_min`/`du_max` and the row groups `[[mpc.constraint]]` become rows
//!
//! lower ≤ A·z + Wx·x0 + Wd·d + Wu·u₋₁ ≤ upper,
//!
//! on z = (U, σ): the plan U (N·nu) and one slack σ_j ≥ 0 per soft component. The data enter through
//! Wx (the prediction's free response), Wd (the estimated input disturbance, which the prediction
//! carries like the command) and Wu (the last input, for the first move). The rows are grouped by
//! **slot** j = 0 … N−1, the same rows in every slot, so that a warm start shifts them by one slot:
//! - state bounds and `ax`-only rows: x_{j+1} (x_1 … x_N, the terminal state included);
//! - rows with an `au`: x_j and u_j (k = 0 … N−1; x_0 is data and enters through Wx);
//! - move bounds: u_j − u_{j−1} (u_{−1} the last input).
//!
//! A soft component is an exact penalty: one slack per constrained state component (shared by its two
//! sides and every stage) or per row of a soft group, with cost w·σ + ½·[`SOFT_QUADRATIC`]·w·σ², and
//! the row relaxed to lower − σ ≤ · ≤ upper + σ (two one-sided rows). The penalty is L∞ in time: for w
//! above the sum over the stages of the hard problem's multipliers the soft QP has the hard one's
//! solution whenever that exists, and it is always feasible.
#![allow(non_snake_case)]

use mpc_spec::Constraints;
use nalgebra::{DMatrix, DVector};

/// The quadratic weight of a slack relative to its linear weight w: ½·(this·w)·σ². It makes the slack
/// block of the Hessian definite without changing which violations the penalty allows.
pub const SOFT_QUADRATIC: f64 = 1e-3;

/// What a row of a slot constrains, for reports and the status.
#[derive(Clone, Debug, PartialEq)]
pub enum RowKind {
    /// State `index` against `x_min`/`x_max` (`side`: which one, for a soft row's two halves).
    State {
        /// The state component.
        index: usize,
        /// `Some(true)` the upper half of a soft row, `Some(false)` the lower half, `None` both.
        upper: Option<bool>,
    },
    /// The move of input `index` against `du_min`/`du_max`.
    Move {
        /// The input.
        index: usize,
    },
    /// Row `row` of `[[mpc.constraint]]` number `group`.
    Group {
        /// The group, in the order written.
        group: usize,
        /// The row within it.
        row: usize,
        /// As for [`RowKind::State`].
        upper: Option<bool>,
    },
}

impl RowKind {
    /// The spec's name for the row: `x_max[3]`, `du_min/du_max[0]`, `constraint[1] row 0`.
    pub fn name(&self) -> String {
        let side = |upper: &Option<bool>, lo: &str, hi: &str| match upper {
            Some(true) => hi.to_string(),
            Some(false) => lo.to_string(),
            None => format!("{lo}/{hi}"),
        };
        match self {
            RowKind::State { index, upper } => {
                format!("{}[{index}]", side(upper, "x_min", "x_max"))
            }
            RowKind::Move { index } => format!("du_min/du_max[{index}]"),
            RowKind::Group { group, row, upper } => {
                let s = match upper {
                    Some(true) => " upper",
                    Some(false) => " lower",
                    None => "",
                };
                format!("constraint[{group}] row {row}{s}")
            }
        }
    }
}

/// A row of a slot on its stage's variables, for the Riccati form of the interior-point method
/// ([`crate::solver::riccati`]): in slot j it is ax·x_{j+lag} + au·u_j (plus data), with lag 1 for state
/// bounds and `ax`-only rows (au zero) and lag 0 for rows with an `au`.
#[derive(Clone, Debug, PartialEq)]
pub struct StageRow {
    /// 0: the row is on (x_j, u_j); 1: on x_{j+1}.
    pub lag: usize,
    /// Its coefficients on the stage's state (nx).
    pub ax: DVector<f64>,
    /// Its coefficients on the stage's input (nu).
    pub au: DVector<f64>,
}

/// The lowered rows; empty when the spec constrains the input box only.
#[derive(Clone, Debug)]
pub struct Rows {
    /// Rows on z = (U, σ), slot-major: [`Rows::per_slot`] rows per slot (m × (N·nu + ns)).
    pub A: DMatrix<f64>,
    /// Lower bounds (m), −∞ where a side is absent.
    pub lower: DVector<f64>,
    /// Upper bounds (m), +∞ where a side is absent.
    pub upper: DVector<f64>,
    /// The free response's part, m × nx.
    pub Wx: DMatrix<f64>,
    /// The input disturbance's part, m × nu (used with a disturbance model).
    pub Wd: DMatrix<f64>,
    /// The last input's part, m × nu.
    pub Wu: DMatrix<f64>,
    /// Rows per slot.
    pub per_slot: usize,
    /// What each row of a slot constrains (per_slot entries).
    pub kinds: Vec<RowKind>,
    /// Each row of a slot on its stage's variables (per_slot entries); `None` for a move row, which
    /// couples u_j and u_{j−1}.
    pub stage: Vec<Option<StageRow>>,
    /// The slacks' linear weights w (ns).
    pub slack_weight: DVector<f64>,
    /// The slacks' quadratic weights [`SOFT_QUADRATIC`]·w (ns).
    pub slack_quadratic: DVector<f64>,
    /// Whether each row is soft (its bounds may be violated at a price).
    pub soft: Vec<bool>,
}

impl Rows {
    /// No rows.
    pub fn none(N: usize, nx: usize, nu: usize) -> Self {
        Rows {
            A: DMatrix::zeros(0, N * nu),
            lower: DVector::zeros(0),
            upper: DVector::zeros(0),
            Wx: DMatrix::zeros(0, nx),
            Wd: DMatrix::zeros(0, nu),
            Wu: DMatrix::zeros(0, nu),
            per_slot: 0,
            kinds: Vec::new(),
            stage: Vec::new(),
            slack_weight: DVector::zeros(0),
            slack_quadratic: DVector::zeros(0),
            soft: Vec::new(),
        }
    }

    /// The number of rows m.
    pub fn len(&self) -> usize {
        self.A.nrows()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.A.nrows() == 0
    }

    /// Slack variables ns.
    pub fn slacks(&self) -> usize {
        self.slack_weight.len()
    }

    /// The rows' data offset Wx·x0 + Wd·d + Wu·u₋₁ (d may be shorter than nu: the disturbance states).
    pub fn offset(&self, x0: &DVector<f64>, d: &DVector<f64>, last: &DVector<f64>) -> DVector<f64> {
        let mut o = &self.Wx * x0 + &self.Wu * last;
        if !d.is_empty() {
            o += self.Wd.columns(0, d.len()) * d;
        }
        o
    }
}

/// A row under construction: its coefficients on U, x0, d and u₋₁, and its slack's sign.
#[derive(Clone)]
struct Row {
    u: DVector<f64>,
    x: DVector<f64>,
    d: DVector<f64>,
    last: DVector<f64>,
    lower: f64,
    upper: f64,
    slack: Option<(usize, f64)>,
}

/// The prediction of x_k (k ≥ 0) as coefficients on (U, x0, d): x_k = Sx_k·x0 + Su_k·(U + 1⊗d).
struct Prediction<'a> {
    Sx: &'a DMatrix<f64>,
    Su: &'a DMatrix<f64>,
    nx: usize,
    nu: usize,
}

impl Prediction<'_> {
    /// (a·Su_k, a·Sx_k, a·Su_k·(1⊗I)) for a row a (nx) on x_k.
    fn of(&self, a: &DVector<f64>, k: usize) -> (DVector<f64>, DVector<f64>, DVector<f64>) {
        let (nx, nu) = (self.nx, self.nu);
        let n = self.Su.ncols();
        if k == 0 {
            return (DVector::zeros(n), a.clone(), DVector::zeros(nu));
        }
        let block = |S: &DMatrix<f64>| S.rows((k - 1) * nx, nx).tr_mul(a);
        let u = block(self.Su);
        let d = DVector::from_fn(nu, |i, _| (i..n).step_by(nu).map(|c| u[c]).sum());
        (u, block(self.Sx), d)
    }
}

/// Whether row `r` of a group has a nonzero `au` entry (so it holds at k = 0 … N−1, not 1 … N).
fn row_has_input(group: &mpc_spec::RowGroup, r: usize, nu: usize) -> bool {
    (0..nu).any(|i| group.au.get(r, i) != 0.0)
}

/// Lowers `c` for the prediction matrices Sx (N·nx × nx) and Su (N·nx × N·nu).
pub fn lower(c: &Constraints, Sx: &DMatrix<f64>, Su: &DMatrix<f64>, nu: usize) -> Rows {
    let nx = Sx.ncols();
    let N = Su.ncols() / nu.max(1);
    if !c.any() {
        return Rows::none(N, nx, nu);
    }
    let prediction = Prediction { Sx, Su, nx, nu };
    let n = N * nu;
    // Slacks: one per soft state component with a finite bound, then one per row of each soft group.
    let mut weights = Vec::new();
    let state_slack: Vec<Option<usize>> = (0..nx)
        .map(|i| {
            let bounded = c.x_min.get(i).is_some_and(|b| b.is_finite())
                || c.x_max.get(i).is_some_and(|b| b.is_finite());
            match (bounded, c.x_soft) {
                (true, Some(w)) => {
                    weights.push(w);
                    Some(weights.len() - 1)
                }
                _ => None,
            }
        })
        .collect();
    let group_slack: Vec<Vec<Option<usize>>> = c
        .rows
        .iter()
        .map(|g| {
            (0..g.ax.rows)
                .map(|_| {
                    g.soft.map(|w| {
                        weights.push(w);
                        weights.len() - 1
                    })
                })
                .collect()
        })
        .collect();
    let unit = |len: usize, i: usize| DVector::from_fn(len, |j, _| if i == j { 1.0 } else { 0.0 });
    // The rows of slot j, in a fixed order, with their kinds.
    let slot = |j: usize| -> Vec<(Row, RowKind)> {
        let mut out = Vec::new();
        let mut push_sided =
            |row: Row, slack: Option<usize>, kind: &dyn Fn(Option<bool>) -> RowKind| {
                match slack {
                    None => out.push((row, kind(None))),
                    Some(s) => {
                        // lower − σ ≤ a ≤ upper + σ as two one-sided rows.
                        if row.upper.is_finite() {
                            let mut hi = Row {
                                slack: Some((s, -1.0)),
                                lower: f64::NEG_INFINITY,
                                ..row.clone()
                            };
                            hi.upper = row.upper;
                            out.push((hi, kind(Some(true))));
                        }
                        if row.lower.is_finite() {
                            let lo = Row {
                                slack: Some((s, 1.0)),
                                upper: f64::INFINITY,
                                ..row.clone()
                            };
                            out.push((lo, kind(Some(false))));
                        }
                    }
                }
            };
        for (i, slack) in state_slack.iter().enumerate() {
            let lo = c.x_min.get(i).copied().unwrap_or(f64::NEG_INFINITY);
            let hi = c.x_max.get(i).copied().unwrap_or(f64::INFINITY);
            if !lo.is_finite() && !hi.is_finite() {
                continue;
            }
            let (u, x, d) = prediction.of(&unit(nx, i), j + 1);
            let row = Row {
                u,
                x,
                d,
                last: DVector::zeros(nu),
                lower: lo,
                upper: hi,
                slack: None,
            };
            push_sided(row, *slack, &|upper| RowKind::State { index: i, upper });
        }
        for i in 0..nu {
            let lo = c.du_min.get(i).copied().unwrap_or(f64::NEG_INFINITY);
            let hi = c.du_max.get(i).copied().unwrap_or(f64::INFINITY);
            if !lo.is_finite() && !hi.is_finite() {
                continue;
            }
            let mut u = DVector::zeros(n);
            u[j * nu + i] = 1.0;
            let mut last = DVector::zeros(nu);
            if j == 0 {
                last[i] = -1.0;
            } else {
                u[(j - 1) * nu + i] = -1.0;
            }
            let row = Row {
                u,
                x: DVector::zeros(nx),
                d: DVector::zeros(nu),
                last,
                lower: lo,
                upper: hi,
                slack: None,
            };
            push_sided(row, None, &|_| RowKind::Move { index: i });
        }
        for (g, (group, slacks)) in c.rows.iter().zip(&group_slack).enumerate() {
            for (r, slack) in slacks.iter().enumerate() {
                // Per row, as the README states: a row with an `au` is on (x_j, u_j), one without on
                // x_{j+1}, whatever the other rows of its group are.
                let with_input = row_has_input(group, r, nu);
                let a = DVector::from_fn(nx, |i, _| group.ax.get(r, i));
                let k = if with_input { j } else { j + 1 };
                let (mut u, x, d) = prediction.of(&a, k);
                if with_input {
                    for i in 0..nu {
                        u[j * nu + i] += group.au.get(r, i);
                    }
                }
                let row = Row {
                    u,
                    x,
                    d,
                    last: DVector::zeros(nu),
                    lower: group.lower[r],
                    upper: group.upper[r],
                    slack: None,
                };
                push_sided(row, *slack, &|upper| RowKind::Group {
                    group: g,
                    row: r,
                    upper,
                });
            }
        }
        out
    };
    let slots: Vec<Vec<(Row, RowKind)>> = (0..N).map(slot).collect();
    let per_slot = slots[0].len();
    let kinds: Vec<RowKind> = slots[0].iter().map(|(_, k)| k.clone()).collect();
    let stage = kinds
        .iter()
        .map(|k| match k {
            RowKind::State { index, .. } => Some(StageRow {
                lag: 1,
                ax: unit(nx, *index),
                au: DVector::zeros(nu),
            }),
            RowKind::Move { .. } => None,
            RowKind::Group { group, row, .. } => {
                let g = &c.rows[*group];
                let with_input = row_has_input(g, *row, nu);
                Some(StageRow {
                    lag: usize::from(!with_input),
                    ax: DVector::from_fn(nx, |i, _| g.ax.get(*row, i)),
                    au: DVector::from_fn(
                        nu,
                        |i, _| if with_input { g.au.get(*row, i) } else { 0.0 },
                    ),
                })
            }
        })
        .collect();
    let rows: Vec<&Row> = slots.iter().flatten().map(|(r, _)| r).collect();
    let m = rows.len();
    let ns = weights.len();
    let mut A = DMatrix::zeros(m, n + ns);
    let mut Wx = DMatrix::zeros(m, nx);
    let mut Wd = DMatrix::zeros(m, nu);
    let mut Wu = DMatrix::zeros(m, nu);
    for (i, row) in rows.iter().enumerate() {
        A.view_mut((i, 0), (1, n)).copy_from(&row.u.transpose());
        if let Some((s, sign)) = row.slack {
            A[(i, n + s)] = sign;
        }
        Wx.row_mut(i).copy_from(&row.x.transpose());
        Wd.row_mut(i).copy_from(&row.d.transpose());
        Wu.row_mut(i).copy_from(&row.last.transpose());
    }
    let weight = DVector::from_vec(weights);
    Rows {
        A,
        lower: DVector::from_iterator(m, rows.iter().map(|r| r.lower)),
        upper: DVector::from_iterator(m, rows.iter().map(|r| r.upper)),
        Wx,
        Wd,
        Wu,
        per_slot,
        kinds,
        stage,
        slack_quadratic: &weight * SOFT_QUADRATIC,
        slack_weight: weight,
        soft: rows.iter().map(|r| r.slack.is_some()).collect(),
    }
}
