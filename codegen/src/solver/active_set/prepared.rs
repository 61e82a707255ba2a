//! What the build computes once from the QP's constant data (H and A, and which bounds are finite),
//! and what a solve computes from the data that change (f and the bounds): [`Prepared`] and
//! [`Offsets`].
//!
//! With H = Rᵀ·R (R upper triangular) and z = z_free + R⁻¹·u, z_free = −H⁻¹·f the unconstrained
//! minimiser, the cost is ½‖u‖² plus a constant, and a constraint aᵀz ≤ b reads m̂ᵀu ≤ d with
//! m̂ = R⁻ᵀa / s, s = ‖R⁻ᵀa‖ and d = (b − aᵀz_free) / s: the least-distance problem DAQP solves. A
//! bound on z_j is the row a = e_j, so its m̂ is row j of R⁻¹, normalised (DAQP's packed `Rinv`).
//! Everything that depends on H and A alone is computed here in f64: R, the normalised rows M̂, their
//! Gram matrix G = M̂·M̂ᵀ (which the iteration reads instead of M̂: a slack costs |W| instead of n,
//! and a row added to the factor is a lookup), the scales s, and Z = R⁻¹·M̂ᵀ, the columns that turn
//! multipliers back into z. The offsets d are affine in f and the bounds ([`Prepared::offsets`]):
//! d = (b + aᵀH⁻¹f) / s = (b + (R⁻ᵀa)ᵀv) / s with DAQP's v = R⁻ᵀf, so for the MPC, whose f and row
//! bounds are affine in θ = (x₀, reference window, u₋₁, disturbance), d = d₀ + D_θ·θ with
//! D_θ = diag(1/s)·(A·H⁻¹·F_θ + the bounds' maps), a matrix a later step can bake in.
//!
//! The variables are split into **independent blocks**: the connected components of the graph with
//! an edge where H couples two variables or a row of A holds both. Each block is a QP of its own (the
//! paper's three axes are three), prepared and solved apart, so its G holds no structural zeros
//! between blocks and a scan never visits another block's rows.
#![allow(non_snake_case)]

use super::{Error, InequalityQp, Row};
use nalgebra::{DMatrix, DVector};

/// The build-time data of one independent block.
#[derive(Clone, Debug)]
pub struct Block {
    /// The block's variables, indices into z, ascending.
    pub vars: Vec<usize>,
    /// The block's constraints: its variables' bounds (those with a finite side), then its rows of A
    /// (those with a finite side), in the QP's order.
    pub rows: Vec<Row>,
    /// Per constraint, its nonzero coefficients as (position in `vars`, value).
    pub coefficients: Vec<Vec<(usize, f64)>>,
    /// The upper-triangular Cholesky factor of the block of H: H_bb = Rᵀ·R.
    pub R: DMatrix<f64>,
    /// Per constraint, s = ‖R⁻ᵀ·a‖, the norm its row had before it was normalised.
    pub scale: Vec<f64>,
    /// The normalised rows m̂ = R⁻ᵀ·a / s (constraints × variables).
    pub M: DMatrix<f64>,
    /// Their Gram matrix G = M̂·M̂ᵀ (constraints × constraints, unit diagonal up to round-off).
    pub G: DMatrix<f64>,
    /// Z = R⁻¹·M̂ᵀ (variables × constraints): z = z_free − Z_W·λ.
    pub Z: DMatrix<f64>,
    /// The tables the run-time kernel reads, packed ([`Packed`]).
    pub packed: Packed,
}

/// A block's tables as the run-time kernel reads them (and the emitted module holds them).
#[derive(Clone, Debug)]
pub struct Packed {
    /// R packed by rows: row i holds `R[i][i..n]`.
    pub r: Vec<f64>,
    /// Per constraint, its index into the QP's sides: a bound on variable j is j, row r is n + r.
    pub sides: Vec<usize>,
    /// Constraint c's coefficients are `values[starts[c]..starts[c + 1]]` at `positions[…]`.
    pub starts: Vec<usize>,
    /// See `starts`.
    pub positions: Vec<usize>,
    /// See `starts`.
    pub values: Vec<f64>,
    /// G's lower triangle packed by columns (column j holds `G[j..nc][j]`).
    pub gram: Vec<f64>,
    /// Z by columns, or empty where the kernel recovers z with two triangular solves instead.
    pub z_cols: Vec<f64>,
    /// Where the block's warm start begins in the warm-start storage.
    pub warm_at: usize,
    /// Whether the f32 kernel refines z and checks the rows on it (a block with slack variables:
    /// set by the MPC's `prepare`, which knows them).
    pub refine: bool,
    /// The constraints the scan visits where the slack rows after them are proved so at run time
    /// (the kernel's `Block::limit`): all of them but the block's rows in [`Prepared::with_slack_rows`]'s
    /// list, which come last.
    pub core: usize,
    /// Per slack row (the constraints from `core` on), the least and the most aᵀz over `z_box`
    /// ([`reach`]).
    pub reach: Vec<f64>,
    /// Per variable, the lower and the upper bound the reach assumed (empty without slack rows):
    /// [`Prepared::offsets`] refuses other bounds, which the kernel does not check.
    pub z_box: Vec<f64>,
    /// The real tables rounded to f32, for the f32 kernel: R, the scales, the values, G and Z.
    pub f32: [Vec<f32>; 5],
    /// `reach` rounded outward, for the f32 kernel.
    pub f32_reach: Vec<f32>,
}

/// The least and the most aᵀz of a row with `coefficients` (position in the block, value) for z within
/// the bounds `z_min`, `z_max` of the block's variables, widened by a millionth of the largest term
/// (so that the f32 tables, rounded outward, and the rounding of the data cannot turn the proof).
pub fn reach(coefficients: &[(usize, f64)], z_min: &[f64], z_max: &[f64]) -> (f64, f64) {
    let (mut lo, mut hi, mut largest) = (0.0f64, 0.0f64, 0.0f64);
    for &(p, v) in coefficients {
        let (a, b) = (v * z_min[p], v * z_max[p]);
        lo += a.min(b);
        hi += a.max(b);
        largest = largest.max(a.abs()).max(b.abs());
    }
    let widen = 1e-6 * largest;
    (lo - widen, hi + widen)
}

impl Block {
    /// The number of variables.
    pub fn n(&self) -> usize {
        self.vars.len()
    }

    /// The block as the f64 kernel reads it.
    pub(super) fn kernel(&self) -> super::kernel64::Block<'_> {
        let p = &self.packed;
        super::kernel64::Block {
            vars: &self.vars,
            r: &p.r,
            sides: &p.sides,
            scale: &self.scale,
            starts: &p.starts,
            positions: &p.positions,
            values: &p.values,
            gram: &p.gram,
            z_cols: &p.z_cols,
            warm_at: p.warm_at,
            refine: p.refine,
            core: p.core,
            reach: &p.reach,
        }
    }

    /// The block as the f32 kernel reads it.
    pub(super) fn kernel32(&self) -> super::kernel32::Block<'_> {
        let p = &self.packed;
        let [r, scale, values, gram, z_cols] = &p.f32;
        super::kernel32::Block {
            vars: &self.vars,
            r,
            sides: &p.sides,
            scale,
            starts: &p.starts,
            positions: &p.positions,
            values,
            gram,
            z_cols,
            warm_at: p.warm_at,
            refine: p.refine,
            core: p.core,
            reach: &p.f32_reach,
        }
    }
}

/// A QP prepared for the dual active-set method: its blocks and where each constraint went.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// The number of variables n.
    pub n: usize,
    /// The number of rows of A.
    pub m: usize,
    /// The independent blocks.
    pub blocks: Vec<Block>,
    /// Per constraint (the n bounds, then the m rows), its block and position there; `None` for a
    /// constraint without a finite side when prepared, and for a zero row of A.
    pub place: Vec<Option<(usize, usize)>>,
    /// The rows of A that are zero: lower ≤ 0 ≤ upper is checked by [`Prepared::offsets`].
    pub zero_rows: Vec<usize>,
}

/// The data of one solve, checked against the prepared QP: f and the sides, which the kernel turns
/// into each block's offsets (z_free and the scaled sides).
#[derive(Clone, Debug)]
pub struct Offsets {
    /// The linear term (n).
    pub f: Vec<f64>,
    /// The lower sides: the n bounds, then the m rows; −∞ where absent.
    pub lower: Vec<f64>,
    /// The upper sides, likewise; +∞ where absent.
    pub upper: Vec<f64>,
    /// A zero row whose sides exclude 0: the QP has no solution.
    pub empty_zero_row: Option<usize>,
}

/// A block's constraints while it is formed: each with its nonzero coefficients.
type Constraints = Vec<(Row, Vec<(usize, f64)>)>;

/// Union–find with path halving, over the variables.
struct Components(Vec<usize>);

impl Components {
    fn find(&mut self, mut i: usize) -> usize {
        while self.0[i] != i {
            self.0[i] = self.0[self.0[i]];
            i = self.0[i];
        }
        i
    }

    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.0[ra.max(rb)] = ra.min(rb);
        }
    }
}

impl Prepared {
    /// Prepares `qp` (its f and bounds are not read, only which bounds are finite): the blocks, and per
    /// block R, M̂, G, Z and the scales. Errors on inconsistent dimensions, non-finite H or A, or a block
    /// of H that is not positive definite (the method needs H ≻ 0; the MPC's H is, its slacks carrying a
    /// quadratic weight).
    pub fn new(qp: &InequalityQp) -> Result<Prepared, Error> {
        Prepared::with_slack_rows(qp, &[])
    }

    /// [`Prepared::new`] with the rows of A in `slack` (proved never to bind over a region, by the
    /// caller) placed last in their blocks: the kernel scans them only where its run-time check of the
    /// proof fails ([`Packed::core`]).
    pub fn with_slack_rows(qp: &InequalityQp, slack: &[usize]) -> Result<Prepared, Error> {
        let n = qp.H.nrows();
        let m = qp.A.nrows();
        if qp.H.ncols() != n
            || qp.A.ncols() != n
            || qp.z_min.len() != n
            || qp.z_max.len() != n
            || qp.lower.len() != m
            || qp.upper.len() != m
        {
            return Err(Error::Dimensions);
        }
        if !qp.H.iter().all(|v| v.is_finite()) {
            return Err(Error::NonFinite("H"));
        }
        if !qp.A.iter().all(|v| v.is_finite()) {
            return Err(Error::NonFinite("A"));
        }
        let mut comps = Components((0..n).collect());
        for j in 0..n {
            for i in 0..j {
                if qp.H[(i, j)] != 0.0 || qp.H[(j, i)] != 0.0 {
                    comps.union(i, j);
                }
            }
        }
        let supports: Vec<Vec<usize>> = (0..m)
            .map(|r| (0..n).filter(|&j| qp.A[(r, j)] != 0.0).collect())
            .collect();
        for s in &supports {
            for w in s.windows(2) {
                comps.union(w[0], w[1]);
            }
        }
        // Blocks in the order of their first variable.
        let mut block_of = vec![usize::MAX; n];
        let mut vars: Vec<Vec<usize>> = Vec::new();
        let mut root_block = vec![usize::MAX; n];
        for j in 0..n {
            let root = comps.find(j);
            if root_block[root] == usize::MAX {
                root_block[root] = vars.len();
                vars.push(Vec::new());
            }
            block_of[j] = root_block[root];
            vars[block_of[j]].push(j);
        }
        let mut place = vec![None; n + m];
        let mut rows: Vec<Constraints> = vec![Vec::new(); vars.len()];
        let mut position = vec![0; n];
        for block in &vars {
            for (p, &j) in block.iter().enumerate() {
                position[j] = p;
            }
        }
        for j in 0..n {
            if qp.z_min[j].is_finite() || qp.z_max[j].is_finite() {
                let b = block_of[j];
                place[j] = Some((b, rows[b].len()));
                rows[b].push((Row::Bound(j), vec![(position[j], 1.0)]));
            }
        }
        let mut zero_rows = Vec::new();
        let mut slack_of: Vec<Constraints> = vec![Vec::new(); vars.len()];
        for (r, support) in supports.iter().enumerate() {
            if !(qp.lower[r].is_finite() || qp.upper[r].is_finite()) {
                continue;
            }
            let Some(&first) = support.first() else {
                zero_rows.push(r);
                continue;
            };
            let b = block_of[first];
            let coefficients = support
                .iter()
                .map(|&j| (position[j], qp.A[(r, j)]))
                .collect();
            if slack.contains(&r) {
                slack_of[b].push((Row::General(r), coefficients));
            } else {
                place[n + r] = Some((b, rows[b].len()));
                rows[b].push((Row::General(r), coefficients));
            }
        }
        let mut cores = Vec::with_capacity(vars.len());
        for (b, (block_rows, slack_rows)) in rows.iter_mut().zip(slack_of).enumerate() {
            cores.push(block_rows.len());
            for (row, coefficients) in slack_rows {
                if let Row::General(r) = row {
                    place[n + r] = Some((b, block_rows.len()));
                }
                block_rows.push((row, coefficients));
            }
        }
        let blocks = vars
            .into_iter()
            .zip(rows)
            .zip(cores)
            .enumerate()
            .map(|(b, ((vars, rows), core))| block(qp, b, vars, rows, core))
            .collect::<Result<Vec<_>, _>>()?;
        let mut blocks = blocks;
        let mut warm_at = 0;
        for b in &mut blocks {
            b.packed.warm_at = warm_at;
            warm_at += b.n() + 1;
        }
        Ok(Prepared {
            n,
            m,
            blocks,
            place,
            zero_rows,
        })
    }

    /// The offsets of a QP with this one's H and A (not checked: the caller forms both from the same
    /// constant data) for its f and bounds: per block z_free = −H_bb⁻¹·f_b (two triangular solves), then
    /// per constraint d = (bound − aᵀz_free) / s. Errors on dimensions that differ from the prepared
    /// QP's, a non-finite f, a NaN bound, or a finite side on a constraint that had none when prepared
    /// (it was left out of the blocks).
    pub fn offsets(&self, qp: &InequalityQp) -> Result<Offsets, Error> {
        let (n, m) = (self.n, self.m);
        if qp.f.len() != n
            || qp.z_min.len() != n
            || qp.z_max.len() != n
            || qp.lower.len() != m
            || qp.upper.len() != m
        {
            return Err(Error::Dimensions);
        }
        if !qp.f.iter().all(|v| v.is_finite()) {
            return Err(Error::NonFinite("f"));
        }
        let bounds = [&qp.z_min, &qp.z_max, &qp.lower, &qp.upper];
        if bounds.iter().any(|b| b.iter().any(|v| v.is_nan())) {
            return Err(Error::NonFinite("a bound"));
        }
        // A block's slack rows were proved within its bounds at build time.
        for b in self.blocks.iter().filter(|b| !b.packed.z_box.is_empty()) {
            for (i, &v) in b.vars.iter().enumerate() {
                let (lo, hi) = (b.packed.z_box[2 * i], b.packed.z_box[2 * i + 1]);
                if qp.z_min[v] < lo || qp.z_max[v] > hi {
                    return Err(Error::Bounds(v));
                }
            }
        }
        for (c, place) in self.place.iter().enumerate() {
            let finite = if c < n {
                qp.z_min[c].is_finite() || qp.z_max[c].is_finite()
            } else {
                qp.lower[c - n].is_finite() || qp.upper[c - n].is_finite()
            };
            let zero = c >= n && self.zero_rows.contains(&(c - n));
            if place.is_none() && finite && !zero {
                return Err(Error::Pattern(if c < n {
                    Row::Bound(c)
                } else {
                    Row::General(c - n)
                }));
            }
        }
        let empty_zero_row = self
            .zero_rows
            .iter()
            .copied()
            .find(|&r| !(qp.lower[r] <= 0.0 && 0.0 <= qp.upper[r]));
        let sides = |lo: &DVector<f64>, rows: &DVector<f64>| {
            lo.iter().chain(rows.iter()).copied().collect()
        };
        Ok(Offsets {
            f: qp.f.iter().copied().collect(),
            lower: sides(&qp.z_min, &qp.lower),
            upper: sides(&qp.z_max, &qp.upper),
            empty_zero_row,
        })
    }

    /// The length of the warm-start storage: n + 1 entries per block.
    pub fn warm_len(&self) -> usize {
        self.blocks.iter().map(|b| b.n() + 1).sum()
    }

    /// The number of constraints the blocks hold (bounds and rows with a finite side).
    pub fn constraints(&self) -> usize {
        self.blocks.iter().map(|b| b.rows.len()).sum()
    }
}

/// One block's R, M̂, G, Z and scales.
fn block(
    qp: &InequalityQp,
    index: usize,
    vars: Vec<usize>,
    rows: Constraints,
    core: usize,
) -> Result<Block, Error> {
    let nb = vars.len();
    let H = DMatrix::from_fn(nb, nb, |i, j| {
        0.5 * (qp.H[(vars[i], vars[j])] + qp.H[(vars[j], vars[i])])
    });
    let chol = H
        .cholesky()
        .ok_or(Error::NotPositiveDefinite { block: index })?;
    let Lc = chol.l();
    if !Lc.iter().all(|v| v.is_finite()) || (0..nb).any(|i| Lc[(i, i)] <= 0.0) {
        return Err(Error::NotPositiveDefinite { block: index });
    }
    let R = Lc.transpose();
    let nc = rows.len();
    let mut M = DMatrix::zeros(nc, nb);
    let mut scale = Vec::with_capacity(nc);
    for (k, (_, coefficients)) in rows.iter().enumerate() {
        // Rᵀ·m = a (forward substitution, Rᵀ lower triangular).
        let mut a = DVector::zeros(nb);
        for &(p, v) in coefficients {
            a[p] = v;
        }
        let mut mrow = DVector::zeros(nb);
        for i in 0..nb {
            let mut s = a[i];
            for j in 0..i {
                s -= Lc[(i, j)] * mrow[j];
            }
            mrow[i] = s / Lc[(i, i)];
        }
        let s = mrow.norm();
        if !(s.is_finite() && s > 0.0) {
            return Err(Error::NotPositiveDefinite { block: index });
        }
        M.row_mut(k).copy_from(&(mrow / s).transpose());
        scale.push(s);
    }
    let G = &M * M.transpose();
    // Z = R⁻¹·M̂ᵀ, column by column (back substitution).
    let mut Z = DMatrix::zeros(nb, nc);
    for k in 0..nc {
        for i in (0..nb).rev() {
            let mut s = M[(k, i)];
            for j in i + 1..nb {
                s -= R[(i, j)] * Z[(j, k)];
            }
            Z[(i, k)] = s / R[(i, i)];
        }
    }
    /// A block with at least this many constraints a variable keeps no Z ([`Packed::z_cols`]).
    const Z_DROPPED_FROM: usize = 4;
    let n = qp.H.nrows();
    let mut packed = Packed {
        r: (0..nb)
            .flat_map(|i| (i..nb).map(move |j| (i, j)))
            .map(|(i, j)| R[(i, j)])
            .collect(),
        sides: Vec::with_capacity(nc),
        starts: vec![0],
        positions: Vec::new(),
        values: Vec::new(),
        gram: (0..nc)
            .flat_map(|j| (j..nc).map(move |i| (i, j)))
            .map(|(i, j)| G[(i, j)])
            .collect(),
        // Z pays where it is small against what it saves: a word of it saves n/nc multiply-adds of a
        // solve's recovery (the kernel's two triangular solves without it), so a block with many
        // constraints a variable (hover's 160 for 40) recovers z without Z, and stores a fifth less.
        z_cols: if nc < Z_DROPPED_FROM * nb {
            (0..nc)
                .flat_map(|c| (0..nb).map(move |p| (p, c)))
                .map(|(p, c)| Z[(p, c)])
                .collect()
        } else {
            Vec::new()
        },
        warm_at: 0,
        refine: false,
        core,
        reach: Vec::new(),
        // Read only where the block has slack rows.
        z_box: if core < nc {
            vars.iter()
                .flat_map(|&v| [qp.z_min[v], qp.z_max[v]])
                .collect()
        } else {
            Vec::new()
        },
        f32: Default::default(),
        f32_reach: Vec::new(),
    };
    let z_min: Vec<f64> = vars.iter().map(|&v| qp.z_min[v]).collect();
    let z_max: Vec<f64> = vars.iter().map(|&v| qp.z_max[v]).collect();
    for (_, coefficients) in rows.iter().skip(core) {
        let (lo, hi) = reach(coefficients, &z_min, &z_max);
        packed.reach.extend([lo, hi]);
    }
    for (row, coefficients) in &rows {
        packed.sides.push(match *row {
            Row::Bound(j) => j,
            Row::General(r) => n + r,
        });
        for &(p, v) in coefficients {
            packed.positions.push(p);
            packed.values.push(v);
        }
        packed.starts.push(packed.positions.len());
    }
    let round = |v: &[f64]| v.iter().map(|x| *x as f32).collect::<Vec<f32>>();
    packed.f32 = [
        round(&packed.r),
        round(&scale),
        round(&packed.values),
        round(&packed.gram),
        round(&packed.z_cols),
    ];
    // Outward: the f32 reach covers the f64 one.
    let outward = packed.reach.chunks(2).flat_map(|r| {
        let (lo, hi) = (r[0] as f32, r[1] as f32);
        [
            if f64::from(lo) > r[0] {
                lo.next_down()
            } else {
                lo
            },
            if f64::from(hi) < r[1] {
                hi.next_up()
            } else {
                hi
            },
        ]
    });
    packed.f32_reach = outward.collect();
    let (rows, coefficients) = rows.into_iter().unzip();
    Ok(Block {
        vars,
        rows,
        coefficients,
        R,
        scale,
        M,
        G,
        Z,
        packed,
    })
}
