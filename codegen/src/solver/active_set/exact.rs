//! The exact iteration count of the dual active-set method's **cold** start over `[mpc.region]`
//! (issue "Exact complexity certification"), after Arnström and Axehill's unifying framework
//! (ASCertain.jl's `dualQPCert`) and Cimini and Bemporad's certification of the dual method.
//!
//! **The parameter.** θ = (x₀, the reference r held constant over the window, u₋₁ where the spec keeps
//! it, the disturbance d): x₀ and r over the region's box, u₋₁ over the input box, d over the box the
//! sample draws it from ([`Parameters`]). Each block's scaled sides lo, hi are affine in θ; a block is
//! partitioned over the parameters its sides depend on, normalised to ξ ∈ [−1, 1]^p, those whose
//! effects on the sides are parallel combined into one coordinate ([`Coordinate`]: x₀'s position and
//! its reference, where no row bounds the position, act only through their difference).
//!
//! **The iteration, run on affine functions.** On a region with a fixed working set W, the multipliers
//! λ(ξ) and λ*(ξ) = −G_WW⁻¹·d_W(ξ) are affine. After the kernel adds a side p with λ_p = 0, the residual
//! G_WW·λ + d_W is nonzero in p's row alone, and stays so through the partial steps and removals that
//! follow (a removed side has λ = 0; a singular step moves along G's null space): so λ* − λ = σ(ξ)·c
//! with c = ±G_WW⁻¹·e_p constant and σ affine, and the step to the first blocking multiplier is
//! λ ← λ + t_i·c with t_i = −λ_i/c_i affine. Every decision of the kernel is then the sign of an
//! affine function, and the region is split at each one:
//! - **the add rule** (`scan`): the most violated side over the inactive constraints, upper before
//!   lower, the first of equals; side i wins on {viol_i ≥ 0, viol_i ≥ viol_j for all j};
//! - **the removal** (`blocking`): the first multiplier to reach zero, i on {λ*_i wrong,
//!   t_i ≤ t_j for every j whose sign can go wrong}; none on {no λ* wrong}: the full step;
//! - **the singular add** (a dependent side): the null direction is constant, the blocking ratios
//!   affine; no blocking ends the region as infeasible;
//! - **the pivots** (singular marks, `pivot_last`'s reordering) depend on W alone, not on ξ: they are
//!   taken from a fresh L·D·Lᵀ of G_WW in the kernel's order (the kernel's are updated by rank one;
//!   the two differ by round-off).
//!
//! **Degeneracy and round-off.** The partition is the exact-arithmetic iteration with the kernel's
//! tolerances on the slacks and multipliers taken as zero: on the boundaries of the regions (measure
//! zero) and within the tolerances of them (the kernel's primal tolerance 1e-11·(1 + |d|), dual 1e-12)
//! the kernel may take the other branch. Ties between two affine functions that agree identically
//! (duplicate rows, multipliers both zero) follow the kernel's rule: the earlier index wins. Regions
//! whose Chebyshev ball has a radius below [`MIN_RADIUS`] in ξ are pruned as boundary: the count holds
//! on the region up to these slivers. A path that scans a working set it scanned before cycles in
//! exact arithmetic ([`End::Cycles`]): its region is final, reported apart and outside the count
//! (paper-limits' third block has a sliver of radius 5e-7 where this happens; the kernel solves its
//! centre in 23 changes). The kernel's cycling guard, refactorisation and refinement at the optimum
//! (no-ops in exact arithmetic) are not modelled.
//!
//! **The LP.** Emptiness is decided by the Chebyshev ball, max r s.t. aᵢ·ξ + ‖aᵢ‖·r ≤ bᵢ, by the small
//! dense LP of [`super::small_lp`] from a feasible point (the parent's centre), and by Clarabel (already a
//! dependency, well kept, and robust on the degenerate LPs the splits produce) where that cannot decide; each
//! region's bounding box (2p more LPs) then drops the rows it makes redundant and pre-screens the next
//! split's candidates without an LP.
//!
//! **What it covers.** Cold starts (an empty working set) with a constant reference window. The emitted
//! controller warm-starts from the previous working set with the sampled cap `ITERATIONS`, and a warm
//! solve that runs out restarts cold with `COLD_ITERATIONS` ≥ this count ([`super::mpc::Caps`]): so a
//! step within the region ends at the optimum after at most `ITERATIONS + COLD_ITERATIONS` changes.
//!
//! **In the build.** [`certify`] runs it within [`Limits::of`] the region (`[mpc.region] exact_lps`, by
//! default `codegen::budget::EXACT_LPS`, LPs per block; `EXACT_DIMENSION` coordinates per block); where
//! it does not complete, the certificate says why
//! and the caps are the sample's. The dimension reached is 3 coordinates (one axis of the paper's
//! plant with both references: complete in 0.1 s at N = 6, checked against the kernel on a grid and
//! random draws, `codegen/tests/exact_count.rs`; 40 s at N = 15). Paper-limits' x and y blocks (3
//! coordinates) complete in 389 s each without a cap (1,349,309 regions, worst 78), beyond the build's
//! budget; its height (4 coordinates), afti16 (7) and the pendulum (5) do not complete within minutes,
//! so the build does not try blocks above 3 (BENCHMARKS.md, "The exact count"). The cost is the LPs:
//! about 20 per region at 3 coordinates, 60-100 at 4, most of them the add rule's candidates and the
//! regions' bounding boxes.
//!
//! **The worst case in work.** Each final region is an execution path. Where the partition completes,
//! [`path_work`] runs the kernel in the target's scalar cold at every solved region's centre and takes
//! the most work ([`super::Macs::work`], each kind of step weighed by its cost on the boards): the
//! certificate's `exact.cold_work`, with the witness of that path. The cold solve's budget of work is
//! then the larger of it and the sample's heaviest case, plus the margin; the build prices the step by
//! the budgets as before, and `mpcc check` prints the heaviest path alone in cycles and instructions,
//! the bound over the region's paths that `tests/tests/firmware/witness.rs` flies on both boards.
#![allow(non_snake_case)]

use super::small_lp::Rows;
use super::{solve_in, Offsets, Prepared, Status, Tolerances};
use crate::certify::evidence::{Exact, Region};
use crate::lower::problem::Problem;
use crate::solver::ipm::mpc_qp;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use std::time::Instant;

/// Regions whose Chebyshev ball in ξ ∈ [−1, 1]^p is smaller than this are boundary slivers, pruned.
pub const MIN_RADIUS: f64 = 1e-7;
/// A piece's changes of the working set past this end its partition as incomplete (the kernel's own
/// cap is far lower; this guards against a modelling error looping).
pub const MAX_DEPTH: usize = 2048;

/// An affine function of ξ: its p coefficients, then the constant.
type Aff = Vec<f64>;
/// Picks the lower- or upper-bound half of a parameter column.
type ColumnPick = fn(&(Vec<f64>, Vec<f64>)) -> &Vec<f64>;

/// The parameter θ and its box.
#[derive(Clone, Debug)]
pub struct Parameters {
    /// What each entry is: `x0[i]`, `r[i]`, `u_prev[i]`, `d[i]`.
    pub names: Vec<String>,
    /// Lower corner.
    pub lo: Vec<f64>,
    /// Upper corner.
    pub hi: Vec<f64>,
    nx: usize,
    nz: usize,
    nlast: usize,
    nd: usize,
}

impl Parameters {
    /// θ = (x₀, r, u₋₁ where kept, d) over the region's states and references, the input box and the
    /// disturbance's box [−u_max, −u_min] (the sample's).
    pub fn of(p: &Problem, region: &Region) -> Parameters {
        let qp = &p.qp;
        let (nx, nz, nd) = (p.nx, qp.nz, p.nd());
        let nlast = if p.keeps_last_input() { p.nu } else { 0 };
        let names = crate::certify::sampling::parameter_names(p);
        // One corner of θ's box: the states' and references' bounds, the last input's, and the
        // disturbance's, which is the input's negated (d's box is [−u_max, −u_min]).
        let corner =
            |x: &[f64], r: &[f64], u: &DVector<f64>, opposite: &DVector<f64>| -> Vec<f64> {
                x[..nx]
                    .iter()
                    .chain(&r[..nz])
                    .chain(&u.as_slice()[..nlast])
                    .copied()
                    .chain((0..nd).map(|i| -opposite[i]))
                    .collect()
            };
        let lo = corner(&region.x_min, &region.reference_min, &qp.u_min, &qp.u_max);
        let hi = corner(&region.x_max, &region.reference_max, &qp.u_max, &qp.u_min);
        Parameters {
            names,
            lo,
            hi,
            nx,
            nz,
            nlast,
            nd,
        }
    }

    /// The dimension of θ.
    pub fn len(&self) -> usize {
        self.lo.len()
    }

    /// Whether θ is empty.
    pub fn is_empty(&self) -> bool {
        self.lo.is_empty()
    }

    /// The box's centre.
    pub fn centre(&self) -> Vec<f64> {
        self.lo
            .iter()
            .zip(&self.hi)
            .map(|(a, b)| 0.5 * (a + b))
            .collect()
    }

    /// The state, reference, last input and disturbance of θ.
    pub fn split(&self, theta: &[f64]) -> [DVector<f64>; 4] {
        let mut at = 0;
        let mut take = |k: usize| {
            let v = DVector::from_column_slice(&theta[at..at + k]);
            at += k;
            v
        };
        let x0 = take(self.nx);
        let r = take(self.nz);
        let last = take(self.nlast);
        let d = take(self.nd);
        [x0, r, last, d]
    }

    /// The MPC's QP at θ (the reference constant over the window), as the sampled certificate forms it.
    pub fn qp(&self, p: &Problem, theta: &[f64]) -> crate::solver::constrained::InequalityQp {
        let (f, offset) = self.data(p, theta);
        mpc_qp(&p.qp, &f, &offset)
    }

    /// The QP's data at θ: f and the rows' offsets, as a control step takes them.
    pub fn data(&self, p: &Problem, theta: &[f64]) -> (DVector<f64>, DVector<f64>) {
        let qp = &p.qp;
        let [x0, r, last, d] = self.split(theta);
        let last = if self.nlast == 0 {
            qp.rest_input()
        } else {
            last
        };
        let (N, nz) = (qp.N, qp.nz);
        let Xref = DVector::from_fn(N * nz, |i, _| r[i % nz]);
        let mut f = &qp.Fx * &x0 - &qp.Fr * Xref + &qp.Fu * &last;
        if self.nd > 0 {
            f += qp.Fd.columns(0, self.nd) * &d;
        }
        let offset = qp.rows.offset(&x0, &d, &last);
        (f, offset)
    }

    /// θ of the normalised ξ of a block's `coordinates` (the other parameters at the centre).
    pub fn theta(&self, coordinates: &[Coordinate], xi: &[f64]) -> Vec<f64> {
        let mut t = self.centre();
        for (coordinate, x) in coordinates.iter().zip(xi) {
            for &(j, sign) in &coordinate.members {
                t[j] += 0.5 * (self.hi[j] - self.lo[j]) * sign * x;
            }
        }
        t
    }
}

/// One coordinate ξₖ ∈ [−1, 1] a block is partitioned over: parameters whose effects on the block's
/// sides are parallel enter them only through one combination (x₀'s position and its reference, through
/// their difference, where no row bounds the position), so they move together. At ξₖ each member j
/// sits at sign·ξₖ of its normalised range; the combination's range is the interval the members' box
/// maps onto, so the partition over ξₖ covers every point of their box.
#[derive(Clone, Debug, PartialEq)]
pub struct Coordinate {
    /// (index into θ, ±1).
    pub members: Vec<(usize, f64)>,
}

impl Coordinate {
    /// One parameter alone.
    pub fn single(j: usize) -> Coordinate {
        Coordinate {
            members: vec![(j, 1.0)],
        }
    }

    /// Its name from θ's: `x0[0]`, or a combination such as `x0[0] - r[0]`.
    pub fn name(&self, names: &[String]) -> String {
        let mut out = String::new();
        for (k, &(j, sign)) in self.members.iter().enumerate() {
            match (k, sign < 0.0) {
                (0, false) => {}
                (0, true) => out.push('-'),
                (_, false) => out.push_str(" + "),
                (_, true) => out.push_str(" - "),
            }
            out.push_str(&names[j]);
        }
        out
    }
}

/// The coordinates of parameters with the given columns (each parameter's effect on the block's
/// sides): parallel columns (within round-off, relative `1e-9`) share one, with the sign of their
/// ratio; the rest are alone.
fn coordinates(used: &[usize], column: impl Fn(usize) -> Vec<f64>) -> Vec<Coordinate> {
    let mut groups: Vec<(Vec<f64>, Coordinate)> = Vec::new();
    for &j in used {
        let v = column(j);
        let vv: f64 = v.iter().map(|a| a * a).sum();
        // v = α·r with α = (r·v)/(r·r), within 1e-9·‖v‖: the ratio's sign, or none.
        let ratio = |r: &[f64]| {
            let rr: f64 = r.iter().map(|a| a * a).sum();
            let alpha = r.iter().zip(&v).map(|(a, b)| a * b).sum::<f64>() / rr;
            let residual: f64 = r.iter().zip(&v).map(|(a, b)| (b - alpha * a).powi(2)).sum();
            (rr > 0.0 && residual <= 1e-18 * vv).then_some(alpha.signum())
        };
        match groups
            .iter_mut()
            .find_map(|(r, c)| ratio(r).map(|s| (c, s)))
        {
            Some((c, sign)) => c.members.push((j, sign)),
            None => groups.push((v, Coordinate::single(j))),
        }
    }
    groups.into_iter().map(|(_, c)| c).collect()
}

/// How the exact iteration ends on a region.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum End {
    /// At the optimum.
    Solved,
    /// The dual is unbounded: the hard rows admit no plan.
    Infeasible,
    /// The iteration returns to a working set it scanned before (a degenerate tie broken the same
    /// way each time): in exact arithmetic it repeats forever. The kernel, whose tolerances break such
    /// ties by round-off, either leaves the cycle or its guard ends the solve with `Cycling` (the
    /// controller falls back); such a region is outside the count. `iterations` counts the changes up
    /// to the repeat.
    Cycles,
}

/// One final region of a block's partition: its sequence of working sets is fixed.
#[derive(Clone, Debug)]
pub struct Piece {
    /// Changes of the working set (additions and removals) the cold solve makes.
    pub iterations: usize,
    /// How it ends.
    pub end: End,
    /// The Chebyshev centre, in ξ.
    pub centre: Vec<f64>,
    /// The Chebyshev radius, in ξ.
    pub radius: f64,
}

/// The partition of one block.
#[derive(Clone, Debug)]
pub struct BlockCount {
    /// The parameters its sides depend on (indices into θ).
    pub parameters: Vec<usize>,
    /// The coordinates it is partitioned over: its parameters, those whose effects are parallel
    /// combined into one ([`Coordinate`]). The pieces' centres are in these.
    pub coordinates: Vec<Coordinate>,
    /// The final regions (in the order they were found).
    pub pieces: Vec<Piece>,
    /// The most changes of the working set over the region.
    pub worst: usize,
    /// θ at the worst region's Chebyshev centre.
    pub witness: Vec<f64>,
    /// Regions that end infeasible.
    pub infeasible: usize,
    /// Regions where the iteration cycles ([`End::Cycles`]), outside `worst`.
    pub cycling: usize,
    /// The largest Chebyshev radius (in ξ) of a cycling region, 0 without one.
    pub cycling_radius: f64,
    /// LPs solved.
    pub lps: usize,
    /// LPs Clarabel did not solve: their regions were dropped as empty (0 on the shipped specs).
    pub lp_failures: usize,
    /// LPs the small dense solver left to Clarabel (a step cap or a singular system).
    pub lp_fallbacks: usize,
    /// Seconds taken.
    pub seconds: f64,
    /// False when the work budget ran out (or a piece exceeded [`MAX_DEPTH`]): `worst` is then over
    /// the regions done only.
    pub complete: bool,
}

/// The exact cold-start count of a QP's blocks.
#[derive(Clone, Debug)]
pub struct ExactCount {
    /// θ.
    pub parameters: Parameters,
    /// Per block.
    pub blocks: Vec<BlockCount>,
    /// Changes of the working set over all blocks, the count the kernel caps: the sum of the blocks'
    /// maxima (exact when no two blocks share a parameter, an upper bound otherwise).
    pub worst: usize,
    /// Whether no two blocks share a parameter (then `worst` is attained at `witness`).
    pub disjoint: bool,
    /// θ with each block's parameters at its worst region's centre.
    pub witness: Vec<f64>,
    /// Final regions over all blocks.
    pub regions: usize,
    /// Seconds taken.
    pub seconds: f64,
    /// Whether every block completed.
    pub complete: bool,
}

/// The work of the worst execution path of a complete partition ([`path_work`]).
#[derive(Clone, Debug, PartialEq)]
pub struct PathWork {
    /// The most work ([`super::Macs::work`], offsets and recovery included) a cold solve spends over
    /// the region: the work at θ's centre plus, per block, the most its paths add to it.
    pub cold_work: usize,
    /// θ with each block's parameters at the centre of its heaviest path's region.
    pub witness: Vec<f64>,
    /// Regions whose centre the kernel solved with another count of changes than the region's (a
    /// decision within the kernel's tolerances); their work is counted as the kernel ran it.
    pub mismatches: usize,
}

/// Per constraint of a block, its scaled lower and upper sides at fixed offsets, as the kernel's
/// `offsets` forms them (z_free = −H_bb⁻¹·f_b, then (side − aᵀz_free)/s).
fn scaled_sides(prepared: &Prepared, offsets: &Offsets, b: usize) -> (Vec<f64>, Vec<f64>) {
    let block = &prepared.blocks[b];
    let n = block.n();
    let f = DVector::from_fn(n, |i, _| -offsets.f[block.vars[i]]);
    let y = block
        .R
        .transpose()
        .solve_lower_triangular(&f)
        .unwrap_or_else(|| DVector::zeros(n));
    let z = block
        .R
        .solve_upper_triangular(&y)
        .unwrap_or_else(|| DVector::zeros(n));
    let mut lo = Vec::with_capacity(block.rows.len());
    let mut hi = Vec::with_capacity(block.rows.len());
    for (c, coefficients) in block.coefficients.iter().enumerate() {
        let a: f64 = coefficients.iter().map(|&(p, v)| v * z[p]).sum();
        let side = block.packed.sides[c];
        let s = block.scale[c];
        lo.push((offsets.lower[side] - a) / s);
        hi.push((offsets.upper[side] - a) / s);
    }
    (lo, hi)
}

/// What limits the partition's work.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// LPs per block at most.
    pub lps: usize,
    /// Coordinates ([`Coordinate`]) a block may depend on: a block above it is not partitioned (its
    /// regions grow exponentially with the dimension).
    pub dimension: usize,
    /// Whether parameters moving the sides in parallel share a [`Coordinate`] (the build's); without,
    /// each is its own, the same partition lifted to more dimensions (the tests compare the two).
    pub combine: bool,
}

impl Limits {
    /// The build's: [`crate::certify::budget::EXACT_LPS`] and [`crate::certify::budget::EXACT_DIMENSION`].
    pub const BUILD: Limits = Limits {
        lps: crate::certify::budget::EXACT_LPS,
        dimension: crate::certify::budget::EXACT_DIMENSION,
        combine: true,
    };

    /// The build's, with the region's `exact_lps` where written.
    pub fn of(region: &mpc_spec::Region) -> Limits {
        Limits {
            lps: region.exact_lps.unwrap_or(Limits::BUILD.lps),
            ..Limits::BUILD
        }
    }
}

/// The exact count of `p`'s QP over `region` within `limits`, as the certificate carries it: the
/// partition's result, or where it did not complete, the regions done and why.
pub fn certify(p: &Problem, prepared: &Prepared, region: &Region, limits: Limits) -> Exact {
    let count = exact_count(p, prepared, region, limits);
    let paths = path_work(p, prepared, &count, p.scalar);
    let names = &count.parameters.names;
    let by_name = |theta: &[f64]| -> Vec<(String, f64)> {
        names.iter().cloned().zip(theta.iter().copied()).collect()
    };
    let note = count.blocks.iter().enumerate().find_map(|(b, c)| {
        if c.complete {
            None
        } else if c.coordinates.len() > limits.dimension {
            Some(format!(
                "block {b} depends on {} parameters (those acting in parallel combined), above the {} the exact count partitions (codegen::budget::EXACT_DIMENSION)",
                c.coordinates.len(),
                limits.dimension
            ))
        } else if c.lps > limits.lps {
            Some(format!(
                "block {b} ran out of the build's {} feasibility LPs (`[mpc.region] exact_lps`, by default codegen::budget::EXACT_LPS) after {} regions",
                limits.lps,
                c.pieces.len()
            ))
        } else if c.parameters.is_empty() && c.pieces.is_empty() {
            Some("the QP's offsets at the region's corners are not finite".to_string())
        } else {
            Some(format!(
                "block {b}: a region changed its working set more than {MAX_DEPTH} times"
            ))
        }
    });
    Exact {
        complete: count.complete,
        note,
        parameters: count.parameters.len(),
        block_parameters: count
            .blocks
            .iter()
            .map(|c| c.coordinates.iter().map(|k| k.name(names)).collect())
            .collect(),
        regions: count.regions,
        infeasible_regions: count.blocks.iter().map(|c| c.infeasible).sum(),
        cycling_regions: count.blocks.iter().map(|c| c.cycling).sum(),
        cycling_radius: count
            .blocks
            .iter()
            .map(|c| c.cycling_radius)
            .fold(0.0, f64::max),
        lps: count.blocks.iter().map(|c| c.lps).sum(),
        cold_worst: count.worst,
        block_worst: count.blocks.iter().map(|c| c.worst).collect(),
        witness: by_name(&count.witness),
        cold_work: paths.as_ref().map(|w| w.cold_work),
        work_witness: paths.as_ref().map_or(Vec::new(), |w| by_name(&w.witness)),
        path_mismatches: paths.as_ref().map_or(0, |w| w.mismatches),
        seconds: count.seconds,
    }
}

/// The exact cold-start count of every block of `prepared` (the MPC's QP of `p`) over `region`.
pub fn exact_count(
    p: &Problem,
    prepared: &Prepared,
    region: &Region,
    limits: Limits,
) -> ExactCount {
    let start = Instant::now();
    let parameters = Parameters::of(p, region);
    let np = parameters.len();
    let offsets_at = |theta: &[f64]| prepared.offsets(&parameters.qp(p, theta)).ok();
    let centre = parameters.centre();
    let base = offsets_at(&centre);
    let unit: Vec<Option<Offsets>> = (0..np)
        .map(|j| {
            let mut t = centre.clone();
            t[j] = parameters.hi[j];
            offsets_at(&t)
        })
        .collect();
    let not_done = |parameters: Vec<usize>, coordinates: Vec<Coordinate>| BlockCount {
        parameters,
        coordinates,
        pieces: Vec::new(),
        worst: 0,
        witness: centre.clone(),
        infeasible: 0,
        cycling: 0,
        cycling_radius: 0.0,
        lps: 0,
        lp_failures: 0,
        lp_fallbacks: 0,
        seconds: 0.0,
        complete: false,
    };
    // The blocks are independent problems: partitioned in parallel (rayon), in order.
    let count_block = |b: usize| {
        let (Some(base), true) = (&base, unit.iter().all(Option::is_some)) else {
            return not_done(Vec::new(), Vec::new());
        };
        let (lo0, hi0) = scaled_sides(prepared, base, b);
        let columns: Vec<(Vec<f64>, Vec<f64>)> = unit
            .iter()
            .map(|o| {
                let (lo, hi) = scaled_sides(prepared, o.as_ref().unwrap_or(base), b);
                (
                    lo.iter().zip(&lo0).map(|(a, c)| a - c).collect(),
                    hi.iter().zip(&hi0).map(|(a, c)| a - c).collect(),
                )
            })
            .collect();
        // The block's parameters: those moving a finite side it scans by more than round-off.
        let core = prepared.blocks[b].packed.core;
        let scale = lo0
            .iter()
            .chain(&hi0)
            .filter(|v| v.is_finite())
            .fold(1.0f64, |m, v| m.max(v.abs()));
        let used: Vec<usize> = (0..np)
            .filter(|&j| {
                let (dl, dh) = &columns[j];
                dl.iter()
                    .zip(&lo0)
                    .take(core)
                    .chain(dh.iter().zip(&hi0).take(core))
                    .any(|(d, c)| c.is_finite() && d.abs() > 1e-12 * scale)
            })
            .collect();
        // Its coordinates: parameters moving the scanned sides in parallel combined.
        let coordinates = if !limits.combine {
            used.iter().map(|&j| Coordinate::single(j)).collect()
        } else {
            coordinates(&used, |j| {
                let (dl, dh) = &columns[j];
                let finite = |d: &[f64], v: &[f64]| -> Vec<f64> {
                    d.iter()
                        .zip(v)
                        .take(core)
                        .filter(|(_, c)| c.is_finite())
                        .map(|(d, _)| *d)
                        .collect()
                };
                [finite(dl, &lo0), finite(dh, &hi0)].concat()
            })
        };
        let aff = |base: &[f64], which: ColumnPick| {
            base.iter()
                .enumerate()
                .map(|(c, v0)| {
                    v0.is_finite().then(|| {
                        let mut a: Aff = coordinates
                            .iter()
                            .map(|k| {
                                k.members
                                    .iter()
                                    .map(|&(j, sign)| sign * which(&columns[j])[c])
                                    .sum()
                            })
                            .collect();
                        a.push(*v0);
                        a
                    })
                })
                .collect::<Vec<Option<Aff>>>()
        };
        if coordinates.len() > limits.dimension {
            return not_done(used, coordinates);
        }
        // Over the region the slack rows (from `core` on) cannot bind, and the kernel does not scan
        // them: as if they had no side.
        let scanned = |mut sides: Vec<Option<Aff>>| {
            for side in sides.iter_mut().skip(core) {
                *side = None;
            }
            sides
        };
        let lo = scanned(aff(&lo0, |c| &c.0));
        let hi = scanned(aff(&hi0, |c| &c.1));
        let mut count = partition(prepared, b, lo, hi, coordinates.len(), limits);
        count.witness = parameters.theta(&coordinates, &count.witness);
        count.parameters = used;
        count.coordinates = coordinates;
        count
    };
    let blocks: Vec<BlockCount> = (0..prepared.blocks.len())
        .into_par_iter()
        .map(count_block)
        .collect();
    let mut witness = centre.clone();
    let mut seen = vec![false; np];
    let mut disjoint = true;
    for b in &blocks {
        for &j in &b.parameters {
            disjoint &= !seen[j];
            seen[j] = true;
            witness[j] = b.witness[j];
        }
    }
    ExactCount {
        worst: blocks.iter().map(|b| b.worst).sum(),
        regions: blocks.iter().map(|b| b.pieces.len()).sum(),
        complete: blocks.iter().all(|b| b.complete),
        parameters,
        blocks,
        disjoint,
        witness,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// The work of every execution path of a complete partition, by the kernel in `scalar` run cold at
/// each solved region's Chebyshev centre (inside the region, so it follows the region's sequence of
/// working sets): what the exact count is in changes, in the work the boards pay for. The blocks are
/// solved one after another with their own tallies and the offsets and the recovery of z cost the
/// same at every θ, so the work at θ is the centre's plus each block's difference from it, and the
/// worst over the region is the centre's plus the blocks' largest differences. `None` where the
/// partition did not complete, two blocks share a parameter, or the kernel fails at a centre.
pub fn path_work(
    p: &Problem,
    prepared: &Prepared,
    count: &ExactCount,
    scalar: mpc_spec::Scalar,
) -> Option<PathWork> {
    if !count.complete || !count.disjoint {
        return None;
    }
    let parameters = &count.parameters;
    let tolerances = Tolerances::of(scalar);
    let work_at = |theta: &[f64]| {
        let offsets = prepared.offsets(&parameters.qp(p, theta)).ok()?;
        let outcome = solve_in(prepared, &offsets, None, MAX_DEPTH, &tolerances, scalar);
        (outcome.status == Status::Solved).then(|| (outcome.macs.work(), outcome.block_iterations))
    };
    let centre = parameters.centre();
    let (base, _) = work_at(&centre)?;
    let mut cold_work = base;
    let mut witness = centre;
    let mut mismatches = 0;
    for (b, block) in count.blocks.iter().enumerate() {
        let paths: Vec<Option<(usize, bool, Vec<f64>)>> = block
            .pieces
            .par_iter()
            .filter(|q| q.end == End::Solved)
            .map(|q| {
                let theta = parameters.theta(&block.coordinates, &q.centre);
                let (work, changes) = work_at(&theta)?;
                Some((work, changes[b] == q.iterations, theta))
            })
            .collect();
        let mut heaviest: Option<(usize, Vec<f64>)> = None;
        for path in paths {
            let (work, agrees, theta) = path?;
            mismatches += usize::from(!agrees);
            if heaviest.as_ref().is_none_or(|(w, _)| work > *w) {
                heaviest = Some((work, theta));
            }
        }
        if let Some((work, theta)) = heaviest.filter(|(w, _)| *w > base) {
            cold_work += work - base;
            for &j in &block.parameters {
                witness[j] = theta[j];
            }
        }
    }
    Some(PathWork {
        cold_work,
        witness,
        mismatches,
    })
}

/// A polyhedron {ξ : aᵢ·ξ ≤ bᵢ} inside the box [−1, 1]^p, with a point and a bounding box.
#[derive(Clone, Debug)]
struct Polyhedron {
    rows: Rows,
    centre: Vec<f64>,
    radius: f64,
    lo: Vec<f64>,
    hi: Vec<f64>,
}

/// Where a state of the symbolic iteration stands in the kernel's loop.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// The top of the loop: λ* (or the singular direction) and the blocking test.
    Top,
    /// After a full step: the scan.
    Scan,
}

/// One region of the symbolic iteration with its working set and affine multipliers.
#[derive(Clone, Debug)]
struct State {
    region: Polyhedron,
    /// (constraint, at its upper side), in the factor's order.
    set: Vec<(usize, bool)>,
    lambda: Vec<Aff>,
    /// The side added last, whose full step is pending.
    pending: Option<usize>,
    singular: bool,
    iterations: usize,
    phase: Phase,
    /// Final: solved without another change.
    done: bool,
    /// Hashes of the working sets (in the factor's order) at each scan on this path.
    seen: Vec<u64>,
}

/// The symbolic iteration on one block.
struct Certifier<'a> {
    G: &'a DMatrix<f64>,
    n: usize,
    lo: Vec<Option<Aff>>,
    hi: Vec<Option<Aff>>,
    p: usize,
    tol: Tolerances,
    lps: usize,
    /// LPs Clarabel did not solve (their regions are dropped as empty).
    failures: usize,
    /// LPs the small dense solver left to Clarabel.
    fallbacks: usize,
}

/// a + s·b.
fn axpy(a: &[f64], s: f64, b: &[f64]) -> Aff {
    a.iter().zip(b).map(|(x, y)| x + s * y).collect()
}

/// a − b.
fn sub(a: &[f64], b: &[f64]) -> Aff {
    axpy(a, -1.0, b)
}

/// s·a.
fn scale(a: &[f64], s: f64) -> Aff {
    a.iter().map(|x| s * x).collect()
}

/// Whether `h` (a difference of `x` and `y`) is zero up to round-off in x and y.
fn identical(h: &[f64], x: &[f64], y: &[f64]) -> bool {
    let size = x.iter().chain(y).fold(1.0f64, |m, v| m.max(v.abs()));
    h.iter().all(|v| v.abs() <= 1e-9 * size)
}

/// The cuts {h ≤ 0} that make `x_i` win over every `x_j` in an argmax (`max = true`) or argmin, the
/// first index winning ties, each h an [`Aff`] one after the other; `None` when an identical earlier
/// entry always wins. `extra` room is reserved for the caller's own cuts.
fn winner_rows(values: &[Aff], i: usize, max: bool, extra: usize) -> Option<Vec<f64>> {
    let width = values[i].len();
    let mut cuts = Vec::with_capacity(width * (values.len() + extra));
    for (j, v) in values.iter().enumerate() {
        if j == i {
            continue;
        }
        // h = x_j − x_i ≤ 0 for a max, x_i − x_j ≤ 0 for a min.
        let sign = if max { 1.0 } else { -1.0 };
        let at = cuts.len();
        cuts.extend(v.iter().zip(&values[i]).map(|(a, b)| sign * (a - b)));
        if identical(&cuts[at..], v, &values[i]) {
            if j < i {
                return None;
            }
            cuts.truncate(at);
        }
    }
    Some(cuts)
}

impl Certifier<'_> {
    /// Maximises cᵀx over {A·x ≤ b} from the feasible `start` ([`super::small_lp`]), or with Clarabel
    /// where that cannot decide: the maximiser, or `None` when it has none.
    fn lp(&mut self, c: &[f64], rows: &Rows, start: &[f64]) -> Option<Vec<f64>> {
        self.lps += 1;
        if let Ok(x) = super::small_lp::maximise(c, rows, start) {
            return Some(x);
        }
        self.fallbacks += 1;
        let x = super::small_lp::with_clarabel(c, rows);
        self.failures += usize::from(x.is_none());
        x
    }

    /// The region `parent` ∩ {h ≤ 0 for each h of `cuts`} (affine functions of ξ, one after the
    /// other), with its Chebyshev ball and bounding box; `None` when it is empty or a sliver.
    fn cut(&mut self, parent: &Polyhedron, cuts: &[f64]) -> Option<Polyhedron> {
        let p = self.p;
        let mut rows = parent.rows.clone();
        let mut added = false;
        let mut normalised = vec![0.0; p];
        for h in cuts.chunks_exact(p + 1) {
            let (a, b) = (&h[..p], -h[p]);
            let norm = a.iter().map(|v| v * v).sum::<f64>().sqrt();
            let size = h.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            if norm <= 1e-12 * size {
                if b < -1e-12 * size {
                    return None;
                }
                continue;
            }
            // Its extremes over the parent's bounding box.
            let (mut most, mut least) = (0.0, 0.0);
            for ((aj, lo), hi) in a.iter().zip(&parent.lo).zip(&parent.hi).take(p) {
                let (x, y) = (aj * lo, aj * hi);
                most += x.max(y);
                least += x.min(y);
            }
            if most <= b {
                continue;
            }
            if least > b + 1e-9 * norm {
                return None;
            }
            for (u, v) in normalised.iter_mut().zip(a) {
                *u = v / norm;
            }
            rows.push(&normalised, b / norm);
            added = true;
        }
        if !added {
            return Some(parent.clone());
        }
        // The parent's bounding box holds the region: its faces are rows of every LP (the rows it
        // made redundant were dropped).
        let mut bounded = Rows::with_capacity(p, rows.len() + 2 * p);
        for (a, b) in rows.iter() {
            bounded.push(a, b);
        }
        let mut face = vec![0.0; p];
        for j in 0..p {
            face[j] = 1.0;
            bounded.push(&face, parent.hi[j]);
            face[j] = -1.0;
            bounded.push(&face, -parent.lo[j]);
            face[j] = 0.0;
        }
        // The Chebyshev ball: max r s.t. a·ξ + r ≤ b (rows of unit norm), r ≤ 1.
        let mut ball = Rows::with_capacity(p + 1, bounded.len() + 1);
        let mut widened = vec![0.0; p + 1];
        for (a, b) in bounded.iter() {
            widened[..p].copy_from_slice(a);
            widened[p] = 1.0;
            ball.push(&widened, b);
        }
        widened[..p].fill(0.0);
        widened[p] = 1.0;
        ball.push(&widened, 1.0);
        let objective = &widened;
        // A feasible start: the parent's centre with the largest radius its rows allow there.
        let mut start = parent.centre.clone();
        let room = ball
            .iter()
            .map(|(a, b)| b - a[..p].iter().zip(&start).map(|(u, v)| u * v).sum::<f64>())
            .fold(f64::INFINITY, f64::min);
        start.push(room);
        let x = self.lp(objective, &ball, &start)?;
        let radius = x[p];
        if radius.is_nan() || radius < MIN_RADIUS {
            return None;
        }
        let centre = x[..p].to_vec();
        // The bounding box, then the rows it makes redundant dropped.
        let (mut lo, mut hi) = (parent.lo.clone(), parent.hi.clone());
        let mut c = vec![0.0; p];
        for j in 0..p {
            for sign in [1.0, -1.0] {
                c[j] = sign;
                if let Some(x) = self.lp(&c, &bounded, &centre) {
                    if sign > 0.0 {
                        hi[j] = hi[j].min(x[j] + 1e-9);
                    } else {
                        lo[j] = lo[j].max(x[j] - 1e-9);
                    }
                }
            }
            c[j] = 0.0;
        }
        rows.retain(|a, b| {
            let most: f64 = (0..p).map(|j| (a[j] * lo[j]).max(a[j] * hi[j])).sum();
            most > b
        });
        Some(Polyhedron {
            rows,
            centre,
            radius,
            lo,
            hi,
        })
    }

    /// The side of working entry (c, upper).
    fn side(&self, c: usize, upper: bool) -> Aff {
        let s = if upper { &self.hi[c] } else { &self.lo[c] };
        s.clone().unwrap_or_else(|| vec![0.0; self.p + 1])
    }

    /// The pivots D of the L·D·Lᵀ of G_WW in the set's order.
    fn pivots(&self, set: &[(usize, bool)]) -> Vec<f64> {
        let k = set.len();
        let mut L = DMatrix::<f64>::zeros(k, k);
        let mut d = vec![0.0; k];
        for i in 0..k {
            for j in 0..=i {
                let mut s = self.G[(set[i].0, set[j].0)];
                for q in 0..j {
                    s -= L[(i, q)] * L[(j, q)] * d[q];
                }
                if j == i {
                    d[i] = s;
                } else {
                    L[(i, j)] = if d[j] > 0.0 { s / d[j] } else { 0.0 };
                }
            }
        }
        d
    }

    /// The kernel's `push`: appends (c, upper) with multiplier `lambda`; singular when its pivot is
    /// below the tolerance or the set has more sides than variables.
    fn push(&self, s: &mut State, c: usize, upper: bool, lambda: Aff) {
        if s.set.len() > self.n {
            s.singular = true;
            return;
        }
        s.set.push((c, upper));
        s.lambda.push(lambda);
        let pivot = *self.pivots(&s.set).last().unwrap_or(&1.0);
        if pivot.is_nan() || pivot < self.tol.singular || s.set.len() > self.n {
            s.singular = true;
        }
    }

    /// The kernel's `pivot_last`.
    fn pivot_last(&self, s: &mut State) {
        let k = s.set.len();
        if k < 2 {
            return;
        }
        let d = self.pivots(&s.set);
        let r = k - 2;
        if d[r] < self.tol.pivot && d[r] < d[k - 1] {
            let (c, upper) = s.set.remove(r);
            let lambda = s.lambda.remove(r);
            self.push(s, c, upper, lambda);
        }
    }

    /// The kernel's `remove`.
    fn remove(&self, s: &mut State, i: usize) {
        s.set.remove(i);
        s.lambda.remove(i);
        s.singular = false;
        let last = self.pivots(&s.set).last().copied().unwrap_or(1.0);
        if last.is_nan() || last < self.tol.singular {
            s.singular = true;
        } else {
            self.pivot_last(s);
        }
    }

    /// G_WW⁻¹ of a nonsingular set.
    fn inverse(&self, set: &[(usize, bool)]) -> DMatrix<f64> {
        let k = set.len();
        let Gw = DMatrix::from_fn(k, k, |i, j| self.G[(set[i].0, set[j].0)]);
        Gw.clone()
            .cholesky()
            .map(|c| c.inverse())
            .or_else(|| Gw.try_inverse())
            .unwrap_or_else(|| DMatrix::zeros(k, k))
    }

    /// One decision of the kernel on `s`: its children, or `Err((solved))` when `s` is final.
    fn advance(&mut self, mut s: State) -> Result<Vec<State>, End> {
        let p = self.p;
        let k = s.set.len();
        if s.singular {
            // The null direction (−G'⁻¹·g, 1), flipped at a lower side.
            let last = k - 1;
            let head = &s.set[..last];
            let inv = self.inverse(head);
            let g = DVector::from_fn(last, |i, _| self.G[(head[i].0, s.set[last].0)]);
            let x = -(&inv * g);
            let sign = if s.set[last].1 { 1.0 } else { -1.0 };
            let dir: Vec<f64> = (0..k)
                .map(|i| sign * if i < last { x[i] } else { 1.0 })
                .collect();
            let eligible: Vec<usize> = (0..k)
                .filter(|&j| {
                    if s.set[j].1 {
                        dir[j] < -self.tol.dual
                    } else {
                        dir[j] > self.tol.dual
                    }
                })
                .collect();
            if eligible.is_empty() {
                return Err(End::Infeasible);
            }
            let t: Vec<Aff> = eligible
                .iter()
                .map(|&j| scale(&s.lambda[j], -1.0 / dir[j]))
                .collect();
            let mut children = Vec::new();
            for (e, &i) in eligible.iter().enumerate() {
                let Some(cuts) = winner_rows(&t, e, false, 0) else {
                    continue;
                };
                let Some(region) = self.cut(&s.region, &cuts) else {
                    continue;
                };
                let mut c = s.clone();
                c.region = region;
                for (l, d) in c.lambda.iter_mut().zip(&dir).take(k) {
                    *l = axpy(l, *d, &t[e]);
                }
                c.lambda[i] = vec![0.0; p + 1];
                self.remove(&mut c, i);
                c.iterations += 1;
                c.phase = Phase::Top;
                children.push(c);
            }
            return Ok(children);
        }
        if s.phase == Phase::Top {
            let Some(pending) = s.pending else {
                let mut c = s;
                c.phase = Phase::Scan;
                return Ok(vec![c]);
            };
            let inv = self.inverse(&s.set);
            let at = s.set.iter().position(|e| e.0 == pending).unwrap_or(k - 1);
            let sign = if s.set[at].1 { 1.0 } else { -1.0 };
            let dir: Vec<f64> = (0..k).map(|j| sign * inv[(j, at)]).collect();
            let sides: Vec<Aff> = s.set.iter().map(|&(c, u)| self.side(c, u)).collect();
            let star: Vec<Aff> = (0..k)
                .map(|i| {
                    let mut a = vec![0.0; p + 1];
                    for (j, side) in sides.iter().enumerate() {
                        a = axpy(&a, -inv[(i, j)], side);
                    }
                    a
                })
                .collect();
            let eligible: Vec<usize> = (0..k)
                .filter(|&j| {
                    j != at
                        && if s.set[j].1 {
                            dir[j] < -1e-13
                        } else {
                            dir[j] > 1e-13
                        }
                })
                .collect();
            // wrong_j > 0: λ*_j has the wrong sign.
            let wrong: Vec<Aff> = eligible
                .iter()
                .map(|&j| scale(&star[j], if s.set[j].1 { -1.0 } else { 1.0 }))
                .collect();
            let t: Vec<Aff> = eligible
                .iter()
                .map(|&j| scale(&s.lambda[j], -1.0 / dir[j]))
                .collect();
            let mut children = Vec::new();
            // The full step: no multiplier goes wrong.
            if let Some(region) = self.cut(&s.region, &wrong.concat()) {
                let mut c = s.clone();
                c.region = region;
                c.lambda = star.clone();
                c.pending = None;
                c.phase = Phase::Scan;
                children.push(c);
            }
            for (e, &i) in eligible.iter().enumerate() {
                let size = wrong[e].iter().fold(1.0f64, |m, v| m.max(v.abs()));
                if wrong[e][..p].iter().all(|v| v.abs() <= 1e-9 * size) && wrong[e][p] <= 0.0 {
                    continue;
                }
                let Some(mut cuts) = winner_rows(&t, e, false, 1) else {
                    continue;
                };
                cuts.extend(wrong[e].iter().map(|v| -v));
                let Some(region) = self.cut(&s.region, &cuts) else {
                    continue;
                };
                let mut c = s.clone();
                c.region = region;
                for (l, d) in c.lambda.iter_mut().zip(&dir).take(k) {
                    *l = axpy(l, *d, &t[e]);
                }
                c.lambda[i] = vec![0.0; p + 1];
                self.remove(&mut c, i);
                c.iterations += 1;
                c.phase = Phase::Top;
                children.push(c);
            }
            return Ok(children);
        }
        // The scan: the most violated inactive side. At a working set this path scanned before, the
        // multipliers are the same functions (λ* of the set), so the same decisions follow: a cycle.
        let key = {
            use std::hash::{Hash, Hasher};
            let mut h = std::collections::hash_map::DefaultHasher::new();
            s.set.hash(&mut h);
            h.finish()
        };
        if s.seen.contains(&key) {
            return Err(End::Cycles);
        }
        s.seen.push(key);
        let nc = self.lo.len();
        let mut candidates: Vec<(usize, bool)> = Vec::new();
        let mut violations: Vec<Aff> = Vec::new();
        for c in 0..nc {
            if s.set.iter().any(|e| e.0 == c) {
                continue;
            }
            let mut mu = vec![0.0; p + 1];
            for (i, &(w, _)) in s.set.iter().enumerate() {
                let g = self.G[(w, c)];
                for (m, l) in mu.iter_mut().zip(&s.lambda[i]) {
                    *m -= g * l;
                }
            }
            for upper in [true, false] {
                let side = if upper { &self.hi[c] } else { &self.lo[c] };
                let Some(side) = side else {
                    continue;
                };
                let v = if upper {
                    sub(&mu, side)
                } else {
                    sub(side, &mu)
                };
                // Never positive over the bounding box: never added here.
                let most: f64 = (0..p)
                    .map(|j| (v[j] * s.region.lo[j]).max(v[j] * s.region.hi[j]))
                    .sum::<f64>()
                    + v[p];
                let size = v
                    .iter()
                    .chain(side.iter())
                    .fold(1.0f64, |m, x| m.max(x.abs()));
                if most <= 1e-12 * size {
                    continue;
                }
                candidates.push((c, upper));
                violations.push(v);
            }
        }
        let mut children = Vec::new();
        let solved = self.cut(&s.region, &violations.concat());
        for (e, &(c, upper)) in candidates.iter().enumerate() {
            let Some(mut cuts) = winner_rows(&violations, e, true, 1) else {
                continue;
            };
            cuts.extend(violations[e].iter().map(|v| -v));
            let Some(region) = self.cut(&s.region, &cuts) else {
                continue;
            };
            let mut child = s.clone();
            child.region = region;
            self.push(&mut child, c, upper, vec![0.0; p + 1]);
            if !child.singular {
                self.pivot_last(&mut child);
            }
            child.pending = Some(c);
            child.iterations += 1;
            child.phase = Phase::Top;
            children.push(child);
        }
        match solved {
            Some(_) if children.is_empty() => Err(End::Solved),
            Some(region) => {
                // The solved part: a final region of its own.
                let mut done = s;
                done.region = region;
                done.done = true;
                children.push(done);
                Ok(children)
            }
            None => Ok(children),
        }
    }
}

/// The partition of block `b` of `prepared` with the given affine sides in p parameters.
fn partition(
    prepared: &Prepared,
    b: usize,
    lo: Vec<Option<Aff>>,
    hi: Vec<Option<Aff>>,
    p: usize,
    limits: Limits,
) -> BlockCount {
    let start = Instant::now();
    let block = &prepared.blocks[b];
    let mut cert = Certifier {
        G: &block.G,
        n: block.n(),
        lo,
        hi,
        p,
        tol: Tolerances::F64,
        lps: 0,
        failures: 0,
        fallbacks: 0,
    };
    let rows = super::small_lp::unit_box(p);
    let root = State {
        region: Polyhedron {
            rows,
            centre: vec![0.0; p],
            radius: 1.0,
            lo: vec![-1.0; p],
            hi: vec![1.0; p],
        },
        set: Vec::new(),
        lambda: Vec::new(),
        pending: None,
        singular: false,
        iterations: 0,
        phase: Phase::Top,
        done: false,
        seen: Vec::new(),
    };
    let mut stack = vec![root];
    let mut pieces = Vec::new();
    let mut complete = true;
    while let Some(s) = stack.pop() {
        if cert.lps > limits.lps || s.iterations > MAX_DEPTH {
            complete = false;
            break;
        }
        if s.done {
            pieces.push(Piece {
                iterations: s.iterations,
                end: End::Solved,
                centre: s.region.centre.clone(),
                radius: s.region.radius,
            });
            continue;
        }
        let (iterations, centre, radius) = (s.iterations, s.region.centre.clone(), s.region.radius);
        match cert.advance(s) {
            Ok(children) => stack.extend(children),
            Err(end) => pieces.push(Piece {
                iterations,
                end,
                centre,
                radius,
            }),
        }
    }
    let worst = pieces
        .iter()
        .filter(|q| q.end != End::Cycles)
        .max_by_key(|q| q.iterations);
    let cycling = pieces.iter().filter(|q| q.end == End::Cycles);
    BlockCount {
        parameters: Vec::new(),
        coordinates: Vec::new(),
        worst: worst.map_or(0, |q| q.iterations),
        witness: worst.map_or(vec![0.0; p], |q| q.centre.clone()),
        infeasible: pieces.iter().filter(|q| q.end == End::Infeasible).count(),
        cycling: cycling.clone().count(),
        cycling_radius: cycling.map(|q| q.radius).fold(0.0, f64::max),
        pieces,
        lps: cert.lps,
        lp_failures: cert.failures,
        lp_fallbacks: cert.fallbacks,
        seconds: start.elapsed().as_secs_f64(),
        complete,
    }
}
