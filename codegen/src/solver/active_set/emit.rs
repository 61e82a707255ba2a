//! The dual active-set `Mpc`: the QP's data from the arguments, the kernel (`kernel.rs`, included as
//! the reference runs it), the fallback, and the build-time tables: per independent block R, the
//! normalised rows' Gram matrix, Z and the constraints' coefficients. Everything is in the module's
//! `Real`: f64, or f32 (the certificate then ran the f32 kernel on its sample).
#![allow(non_snake_case)]

use super::mpc::prepare;
use super::{Prepared, Tolerances, KERNEL_SOURCE};
use crate::emit::sections::Sections;
use crate::emit::tokens::Num;
use crate::lower::problem::Problem;
use crate::solver::constrained::emit::{
    coordinate_check, entry, evidence_doc, mpc_type, reach, status_types, Entry, MpcParts,
};
use crate::solver::constrained::InequalityQp;
use crate::solver::ipm::mpc_qp;
use mpc_spec::Scalar;
use nalgebra::{DMatrix, DVector};
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::quote;

/// What the sections are emitted from.
struct Method<'a> {
    p: &'a Problem,
    num: Num,
    structure: InequalityQp,
    prepared: Prepared,
}

impl Method<'_> {
    fn nv(&self) -> usize {
        self.p.qp.Nc * self.p.nu + self.p.qp.rows.slacks()
    }
}

/// A literal in `num`, `Real::INFINITY` / `Real::NEG_INFINITY` where infinite.
fn real(num: Num, v: f64) -> TokenStream {
    if v == f64::INFINITY {
        quote!(Real::INFINITY)
    } else if v == f64::NEG_INFINITY {
        quote!(Real::NEG_INFINITY)
    } else {
        num.lit(v)
    }
}

/// `[v, …]` in `num`.
fn real_table(num: Num, v: impl IntoIterator<Item = f64>) -> TokenStream {
    let v = v.into_iter().map(|x| real(num, x));
    quote!([#(#v),*])
}

/// `e`, a `Real`, in f64 (exact).
fn in_f64(num: Num, e: TokenStream) -> TokenStream {
    match num.0 {
        Scalar::F32 => quote!(f64::from(#e)),
        Scalar::F64 => e,
    }
}

/// `[i, …]`.
fn index_table(v: &[usize]) -> TokenStream {
    let v = v.iter().map(|i| Literal::usize_unsuffixed(*i));
    quote!([#(#v),*])
}

/// Where θ = (x0, the reference window, u₋₁, d) holds each part: x0 at 0, the others at these.
struct Theta {
    reference: usize,
    last: Option<usize>,
    d: Option<usize>,
    len: usize,
}

impl Theta {
    fn of(p: &Problem) -> Theta {
        let reference = p.nx;
        let mut len = reference + p.qp.N * p.qp.nz;
        let last = p.keeps_last_input().then(|| {
            len += p.nu;
            len - p.nu
        });
        let d = (p.nd() > 0).then(|| {
            len += p.nd();
            len - p.nd()
        });
        Theta {
            reference,
            last,
            d,
            len,
        }
    }

    /// `parts` placed at θ's columns: (x0's, the reference's, u₋₁'s, d's), each `rows` high.
    fn matrix(&self, rows: usize, parts: [Option<&DMatrix<f64>>; 4]) -> DMatrix<f64> {
        let mut out = DMatrix::zeros(rows, self.len);
        let at = [Some(0), Some(self.reference), self.last, self.d];
        for (part, at) in parts.iter().zip(at) {
            if let (Some(m), Some(at)) = (part, at) {
                let cols = m.ncols().min(self.len - at);
                out.view_mut((0, at), (rows, cols))
                    .copy_from(&m.view((0, 0), (rows, cols)));
            }
        }
        out
    }
}

/// θ's length (x0, the reference window, u₋₁ and d where the QP depends on them).
pub(super) fn theta_len(p: &Problem) -> usize {
    Theta::of(p).len
}

/// Zeros between two nonzeros of a row that one run bridges rather than start another: a run costs
/// a few instructions more than a multiply-add.
const GAP: usize = 2;

/// A matrix's rows as runs of consecutive columns without structural zeros (gaps of up to [`GAP`]
/// bridged): per row the end of its runs, per run its first column and length, and the runs' values.
struct Runs {
    starts: Vec<usize>,
    cols: Vec<usize>,
    lens: Vec<usize>,
    values: Vec<f64>,
}

impl Runs {
    fn of(m: &DMatrix<f64>) -> Runs {
        let mut r = Runs {
            starts: vec![0],
            cols: Vec::new(),
            lens: Vec::new(),
            values: Vec::new(),
        };
        for i in 0..m.nrows() {
            let nonzero: Vec<usize> = (0..m.ncols()).filter(|&j| m[(i, j)] != 0.0).collect();
            let mut k = 0;
            while k < nonzero.len() {
                let first = nonzero[k];
                let mut last = first;
                while k + 1 < nonzero.len() && nonzero[k + 1] - last <= GAP + 1 {
                    k += 1;
                    last = nonzero[k];
                }
                r.cols.push(first);
                r.lens.push(last - first + 1);
                r.values.extend((first..=last).map(|j| m[(i, j)]));
                k += 1;
            }
            r.starts.push(r.cols.len());
        }
        r
    }

    /// The largest index the tables hold.
    fn largest(&self) -> usize {
        let end = self.cols.iter().zip(&self.lens).map(|(c, l)| c + l);
        self.starts.iter().copied().chain(end).max().unwrap_or(0)
    }

    /// `const NAME: Sparse = …`.
    fn emit(&self, num: Num, name: &str, doc: &str) -> TokenStream {
        let name = Ident::new(name, Span::call_site());
        let ix = |v: &[usize]| {
            let v = v.iter().map(|i| Literal::usize_unsuffixed(*i));
            quote!(&[#(#v),*])
        };
        let (starts, cols, lens) = (ix(&self.starts), ix(&self.cols), ix(&self.lens));
        let values = self.values.iter().map(|v| num.lit(*v));
        quote! {
            #[doc = #doc]
            const #name: Sparse = Sparse {
                starts: #starts,
                cols: #cols,
                lens: #lens,
                values: &[#(#values),*],
            };
        }
    }
}

/// The dual active-set `Mpc`, its kernel and its tables.
pub fn emit(p: &Problem, num: Num) -> Sections {
    let qp = &p.qp;
    let np = qp.Nc * p.nu;
    let structure = mpc_qp(qp, &DVector::zeros(np), &DVector::zeros(qp.rows.len()));
    let prepared = prepare(qp).unwrap_or_else(|| Prepared {
        n: 0,
        m: 0,
        blocks: Vec::new(),
        place: Vec::new(),
        zero_rows: Vec::new(),
    });
    let m = Method {
        p,
        num,
        structure,
        prepared,
    };
    let (reach_tables, reach_code) = reach(p, num, false);
    let (coordinate_tables, coordinate_code) = coordinate_check(p, false);
    Sections {
        constants: constants(&m),
        api: api(&m, &reach_code, &coordinate_code),
        kernels: kernels(&m),
        tables: tables(&m, quote!(#reach_tables #coordinate_tables)),
    }
}

/// The constants section: the dimensions of the QP, the blocks and the kernel's storage.
fn constants(m: &Method) -> TokenStream {
    let plan_steps = crate::emit::plan_steps(m.p);
    let qp = &m.p.qp;
    let blocks = &m.prepared.blocks;
    let (nv, ns, ng) = (m.nv(), qp.rows.slacks(), qp.rows.len());
    let n_max = blocks.iter().map(|b| b.n()).max().unwrap_or(0);
    let nc_max = blocks.iter().map(|b| b.rows.len()).max().unwrap_or(0);
    let lit = Literal::usize_unsuffixed;
    let [nv, ns, ng, nblocks, n_max, nc_max, nwarm] = [
        nv,
        ns,
        ng,
        blocks.len(),
        n_max,
        nc_max,
        m.prepared.warm_len(),
    ]
    .map(lit);
    let accuracy = Num(Scalar::F64).lit(qp.accuracy);
    let ntheta = lit(Theta::of(m.p).len);
    let caps = super::mpc::Caps::of(qp);
    let cold = lit(caps.cold);
    let warm = lit(caps.warm);
    let continues = caps.restart == mpc_spec::Restart::Continue;
    let warm_started_worst = qp.evidence.as_ref().map_or(0, |e| e.warm_started_worst);
    let warm_doc = if continues {
        format!(
            " The most a warm-started step of the sample needed ({warm_started_worst}) plus its margin, at most [`ITERATIONS`]. With `restart = \"continue\"` a solve, warm or cold, makes at most [`COLD_ITERATIONS`] changes and spends at most [`WARM_WORK`]: a step makes at most {} changes; one that runs out falls back and the next step resumes from its working set.",
            caps.per_step()
        )
    } else {
        format!(
            " Changes of the working set a warm solve (from the previous working set) may make: the most a warm-started step of the sample needed ({warm_started_worst}) plus its margin, at most [`ITERATIONS`]. A warm solve needs a change or two at the median; one that runs out restarts cold, so a step makes at most WARM_ITERATIONS + COLD_ITERATIONS = {} changes (and spends at most what [`WARM_WORK`] and [`COLD_WORK`] allow).",
            caps.per_step()
        )
    };
    let budget = |work: usize| {
        if work == super::UNLIMITED_WORK {
            quote!(usize::MAX)
        } else {
            let work = lit(work);
            quote!(#work)
        }
    };
    let (warm_work, cold_work) = (budget(caps.warm_work), budget(caps.of_solve(false).1));
    let evidence = qp.evidence.as_ref();
    let warm_work_doc = match evidence {
        Some(e) => format!(
            " The work a warm solve may spend before it stops changing the working set (then restarts cold): the most a warm-started step of the sample spent ({}) plus its margin. Work is the kernel's multiply-adds and scanned rows weighed by their cost on the boards, in tenths of a multiply-add of the factor's loops (`WORK_MULTIPLY_ADD`); `report::MACS_PER_CYCLE` and the build's period check price the budgets, which make the bound hold on every path.",
            e.warm_started_work_worst
        ),
        None => " The work a warm solve may spend: no budget without a sampled certificate.".to_string(),
    };
    let exact_work = evidence
        .and_then(|e| e.exact.as_ref())
        .filter(|x| x.complete)
        .and_then(|x| x.cold_work);
    let cold_work_doc = match evidence {
        Some(_) if continues => " The work a cold solve may spend before it stops changing the working set and falls back: [`WARM_WORK`], as `restart = \"continue\"` asks (the next step resumes from its working set).".to_string(),
        Some(e) if caps.cold_work != super::UNLIMITED_WORK => match exact_work {
            Some(w) => format!(
                " The work a cold solve may spend before it stops changing the working set and falls back: the heaviest execution path of the exact partition ({w}; the sample's heaviest cold case {}), the larger plus its margin (see [`WARM_WORK`]).",
                e.cold_work_worst
            ),
            None => format!(
                " The work a cold solve may spend before it stops changing the working set and falls back: the most a cold case of the sample spent ({}) plus its margin (see [`WARM_WORK`]).",
                e.cold_work_worst
            ),
        },
        Some(_) => " The work a cold solve may spend: no budget, the exact cold count caps its changes ([`COLD_ITERATIONS`]), its paths' work unknown.".to_string(),
        None => " The work a cold solve may spend: no budget without a sampled certificate.".to_string(),
    };
    let exact = qp.evidence.as_ref().and_then(|e| e.exact.as_ref());
    let cold_doc = match exact {
        Some(x) if x.complete => format!(
            " Changes of the working set a cold solve (the first, or after a warm one ran out) may make: the exact cold count over `[mpc.region]` ({}, proved for constant reference windows; `report::EXACT_*`), or [`ITERATIONS`] if larger.",
            x.cold_worst,
        ),
        _ => format!(
            " Changes of the working set a cold solve (the first, or after a warm one ran out) may make: [`ITERATIONS`], the sampled count ({}).",
            exact.map_or("`certificate = \"sampled\"`", |x| x.note.as_deref().unwrap_or("the exact count did not complete")),
        ),
    };
    quote! {
        #[doc = #cold_doc]
        pub const COLD_ITERATIONS: usize = #cold;
        #[doc = #warm_doc]
        pub const WARM_ITERATIONS: usize = #warm;
        #[doc = #cold_work_doc]
        pub const COLD_WORK: usize = #cold_work;
        #[doc = #warm_work_doc]
        pub const WARM_WORK: usize = #warm_work;
        /// Entries of the plan, N·NU.
        pub const NP: usize = #plan_steps * NU;
        /// The QP's unknowns z: the plan, then one slack per soft constraint component.
        pub const NV: usize = #nv;
        /// Slacks of the soft constraints.
        pub const NS: usize = #ns;
        /// General constraint rows (their sides move with the data).
        pub const NG: usize = #ng;
        /// The QP's sides: a bound per unknown, then the general rows.
        pub const NC: usize = NV + NG;
        /// Independent blocks of the QP, each solved on its own.
        pub const NBLOCKS: usize = #nblocks;
        /// Unknowns of the largest block.
        pub const N_MAX: usize = #n_max;
        /// Constraints of the largest block.
        pub const NC_MAX: usize = #nc_max;
        /// A working set's capacity: N_MAX + 1 (the last side may be dependent, until it leaves).
        pub const CAP: usize = N_MAX + 1;
        /// The warm start's storage: CAP entries per block.
        pub const NWARM: usize = #nwarm;
        /// `[mpc] accuracy`: the plan within ACCURACY·(U_MAX − U_MIN) of the exact solution.
        pub const ACCURACY: f64 = #accuracy;
        /// θ's length: x0, the reference window, then u₋₁ and d where the QP depends on them.
        const NTHETA: usize = #ntheta;
    }
}

/// The api section: `SolverStatus`, `Fallback`, the kernel's storage and the `Mpc` struct.
fn api(m: &Method, reach_code: &TokenStream, coordinate_code: &TokenStream) -> TokenStream {
    let continues = m.p.qp.restart == mpc_spec::Restart::Continue;
    let status_types = status_types(
        "dual active-set method",
        if continues {
            &[
                " Changes of the working set (sides added or removed) over all blocks: at most [`COLD_ITERATIONS`]",
                " within [`WARM_WORK`]. A solve that needs more falls back and the next step resumes.",
            ]
        } else {
            &[
                " Changes of the working set (sides added or removed) over all blocks, of the warm solve and",
                " of its cold restart: at most [`WARM_ITERATIONS`] + [`COLD_ITERATIONS`]. A solve that needs more falls back.",
            ]
        },
    );
    let warm_doc = if continues {
        " Whether the working sets are a warm start (false after `new`, `reset` or a fallback, but true\n after a solve that ran out, which the next resumes: `restart = \"continue\"`)."
    } else {
        " Whether the working sets are a warm start (false after `new`, `reset` or a fallback)."
    };
    let evidence_doc = evidence_doc(m.p.qp.evidence.as_ref(), "");
    let blocks = m.prepared.blocks.len();
    let real_name = m.num.numeric().name();
    let stops = if continues {
        "stops at the optimum or after [`COLD_ITERATIONS`] changes or [`WARM_WORK`] work;\n where it stops short the next step resumes from its working set (`restart = \"continue\"`)"
    } else {
        "stops at the optimum or after [`WARM_ITERATIONS`] changes\n or [`WARM_WORK`] work, then restarts cold with at most [`COLD_ITERATIONS`] and [`COLD_WORK`]"
    };
    let doc = format!(
        " Warm-started MPC with state, output and rate constraints: a dual active-set method (Goldfarb and\n Idnani's, as DAQP) on the condensed QP in {real_name}, in {blocks} independent block(s), with the Cholesky\n factor, the normalised rows' Gram matrix and the parameter maps computed at build time. Each solve\n starts from the previous working set and {stops}; a solve that does not reach the optimum\n falls back to the held plan ([`Fallback::WarmStart`])."
    );
    let doc: Vec<&str> = doc.split('\n').collect();
    let entry = entry(m.p);
    let checked = checked(m, &entry, reach_code, coordinate_code);
    let mpc = mpc_type(MpcParts {
        status_types,
        doc: &doc,
        evidence_doc: &evidence_doc,
        plan_scalar: quote!(Real),
        point_fields: quote! {
            /// The last solve's working sets, block by block (CAP entries each, `warm_len` of them used):
            /// twice the constraint, plus one at its upper side.
            warm_set: [u32; NWARM],
            /// The used entries of each block's working set.
            warm_len: [u32; NBLOCKS],
            #[doc = #warm_doc]
            warm: bool,
            /// The kernel's storage, kept here rather than on the stack.
            work: Storage,
            /// The solve's data, likewise.
            data: Data,
        },
        point_init: quote! {
            warm_set: [0; NWARM],
            warm_len: [0; NBLOCKS],
            work: Storage::new(),
            data: Data::new(),
        },
        new_doc: " A cold controller: its first solve starts from an empty working set.",
        plan_step: quote!(o.copy_from_slice(step);),
        held: crate::solver::constrained::emit::held(m.p),
        entry,
        checked,
    });
    quote! {
        #mpc

        /// The kernel's storage for the largest block: the working set, its multipliers and factor,
        /// and per constraint its scaled sides and marks.
        #[derive(Clone, Debug, PartialEq)]
        struct Storage {
            set: [u32; CAP],
            upper: [bool; CAP],
            lambda: [Real; CAP],
            star: [Real; CAP],
            y: [Real; CAP],
            scaled: [Real; CAP],
            tmp: [Real; CAP],
            l: [Real; CAP * CAP],
            d: [Real; CAP],
            mu: [Real; NC_MAX],
            active: [bool; NC_MAX],
            excluded: [bool; NC_MAX],
            lo: [Real; NC_MAX],
            hi: [Real; NC_MAX],
            z_free: [Real; N_MAX],
        }

        impl Storage {
            /// Zeroed storage.
            const fn new() -> Self {
                Storage {
                    set: [0; CAP],
                    upper: [false; CAP],
                    lambda: [0.0; CAP],
                    star: [0.0; CAP],
                    y: [0.0; CAP],
                    scaled: [0.0; CAP],
                    tmp: [0.0; CAP],
                    l: [0.0; CAP * CAP],
                    d: [0.0; CAP],
                    mu: [0.0; NC_MAX],
                    active: [false; NC_MAX],
                    excluded: [false; NC_MAX],
                    lo: [0.0; NC_MAX],
                    hi: [0.0; NC_MAX],
                    z_free: [0.0; N_MAX],
                }
            }

            /// The kernel's view of it.
            fn work(&mut self) -> Work<'_> {
                Work {
                    set: &mut self.set,
                    upper: &mut self.upper,
                    lambda: &mut self.lambda,
                    star: &mut self.star,
                    y: &mut self.y,
                    scaled: &mut self.scaled,
                    tmp: &mut self.tmp,
                    l: &mut self.l,
                    d: &mut self.d,
                    mu: &mut self.mu,
                    active: &mut self.active,
                    excluded: &mut self.excluded,
                    lo: &mut self.lo,
                    hi: &mut self.hi,
                    z_free: &mut self.z_free,
                    cap: CAP,
                }
            }
        }

        /// A solve's data: θ, the QP's linear term and sides, the rows' offsets, z and the held plan.
        #[derive(Clone, Debug, PartialEq)]
        struct Data {
            /// θ = (x0, the reference window, u₋₁, d): what f and the rows' sides are affine in.
            theta: [Real; NTHETA],
            f: [Real; NV],
            lower: [Real; NC],
            upper: [Real; NC],
            /// The rows' offsets ROW_THETA·θ (their sides before any widening are ROW_* − offset).
            offset: [Real; NG],
            z: [Real; NV],
            held: [Real; NP],
        }

        impl Data {
            /// Zeroed data.
            const fn new() -> Self {
                Data {
                    theta: [0.0; NTHETA],
                    f: [0.0; NV],
                    lower: [0.0; NC],
                    upper: [0.0; NC],
                    offset: [0.0; NG],
                    z: [0.0; NV],
                    held: [0.0; NP],
                }
            }
        }
    }
}

/// `Mpc::checked`, the solve: the QP's data from the arguments, the warm start, the kernel, and the
/// choice between its plan and the held one.
fn checked(
    m: &Method,
    entry: &Entry,
    reach_code: &TokenStream,
    coordinate_code: &TokenStream,
) -> TokenStream {
    let p = m.p;
    let row = crate::solver::first_order::form::reference_row(p);
    let Entry {
        d_param,
        d_finite,
        set_last,
        ..
    } = entry;
    let theta = Theta::of(p);
    let (r_at, r_end) = (
        Literal::usize_unsuffixed(theta.reference),
        Literal::usize_unsuffixed(theta.reference + p.qp.N * p.qp.nz),
    );
    let last_theta = theta.last.map(|at| {
        let (at, end) = (
            Literal::usize_unsuffixed(at),
            Literal::usize_unsuffixed(at + p.nu),
        );
        quote!(theta[#at..#end].copy_from_slice(&last);)
    });
    let d_theta = theta.d.map(|at| {
        let (at, end) = (
            Literal::usize_unsuffixed(at),
            Literal::usize_unsuffixed(at + p.nd()),
        );
        quote!(theta[#at..#end].copy_from_slice(&d);)
    });
    let d_flush = (p.nd() > 0).then(|| quote!(let d = flushed(d);));
    let last_local = p.keeps_last_input().then(|| quote!(let last = self.last;));
    // Shorthand fields in f64 (clippy's `redundant_field_names`), widened in f32.
    let field = |name: TokenStream| match m.num.0 {
        Scalar::F32 => quote!(#name: f64::from(#name)),
        Scalar::F64 => name,
    };
    let (violation, softened) = (field(quote!(violation)), field(quote!(softened)));
    let held_violation = in_f64(m.num, quote!(violations(held, offset).0));
    let zero_rows = (!m.prepared.zero_rows.is_empty()).then(|| {
        quote! {
            // A row without coefficients: its sides must hold 0, or no plan meets it.
            let mut empty = false;
            for j in ZERO_ROWS {
                empty |= !((at(lower, NV + j) <= 0.0) & (0.0 <= at(upper, NV + j)));
            }
        }
    });
    let (caps, restart, next_warm) = match p.qp.restart {
        mpc_spec::Restart::Cold => (
            quote! {
                let (cap, budget) =
                    if warm { (WARM_ITERATIONS, WARM_WORK) } else { (COLD_ITERATIONS, COLD_WORK) };
            },
            quote! {
                // A warm solve that ran out (or cycled) restarts cold: its count is certified.
                if warm & ((ended == Ended::IterationLimit) | (ended == Ended::Cycling)) {
                    self.warm_len = [0; NBLOCKS];
                    let (ended, cold) = solve(
                        &BLOCKS, f, lower, upper, &mut work, &mut self.warm_set, &mut self.warm_len,
                        COLD_ITERATIONS, &TOLERANCES, &mut Tally::new(COLD_WORK), z, |_, _, _, _| {},
                    );
                    (ended, iterations + cold)
                } else {
                    (ended, iterations)
                }
            },
            quote!(self.warm = trusted & !relax;),
        ),
        mpc_spec::Restart::Continue => (
            // One solve a step, warm or cold, at one price.
            quote!(let (cap, budget) = (COLD_ITERATIONS, WARM_WORK);),
            quote!((ended, iterations)),
            quote! {
                // `restart = "continue"`: a solve that ran out of changes or work leaves a dual feasible
                // working set, where the next step resumes.
                self.warm = (trusted | (ended == Ended::IterationLimit)) & !relax;
            },
        ),
    };
    let (empty_check, empty_end) = if zero_rows.is_some() {
        (
            quote!(let (ended, iterations) = if empty { (Ended::Infeasible, 0) } else),
            quote!(;),
        )
    } else {
        (quote!(let (ended, iterations) =), quote!(;))
    };
    quote! {
        /// The solve, with `None` (and a reset warm start) for a non-finite argument.
        fn checked(&mut self, x0: &[Real; NX], #d_param xref: &[[Real; #row]; N]) -> Option<[Real; NU]> {
            if !(all_finite(x0) #d_finite && xref.iter().all(|r| all_finite(r))) {
                // Out of line: `reset` builds a whole `Mpc`, which would otherwise sit in this frame.
                #[cold]
                #[inline(never)]
                fn refused(mpc: &mut Mpc) {
                    mpc.reset();
                }
                refused(self);
                return None;
            }
            let x0 = flushed(x0);
            #d_flush
            #last_local
            let Data { theta, f, lower, upper, offset, z, held } = &mut self.data;
            theta[..NX].copy_from_slice(&x0);
            let reference = &mut theta[#r_at..#r_end];
            for (r, row) in reference.chunks_exact_mut(xref[0].len()).zip(xref.iter()) {
                r.copy_from_slice(&flushed(row));
            }
            #coordinate_code
            #reach_code
            #last_theta
            #d_theta
            // f = F_θ·θ (Fx·x0 − Fr·Xref + Fu·u₋₁ + Fd·d, their nonzeros) for the plan, the penalties'
            // weights for the slacks.
            F_THETA.times(theta, &mut f[..NP]);
            f[NP..].copy_from_slice(&SLACK_WEIGHT);
            // The sides: the unknowns' bounds (constant), then the rows' moved by the data.
            lower[..NV].copy_from_slice(&Z_LO);
            upper[..NV].copy_from_slice(&Z_HI);
            ROW_THETA.times(theta, offset);
            let rows = lower[NV..].iter_mut().zip(upper[NV..].iter_mut());
            let sides = ROW_LOWER.iter().zip(ROW_UPPER.iter()).zip(offset.iter());
            for ((lo, hi), ((row_lo, row_hi), o)) in rows.zip(sides) {
                *lo = *row_lo - *o;
                *hi = *row_hi - *o;
            }
            // The held plan: the fallback, and what a relaxed solve widens the hard rows to.
            *held = self.plan;
            shift(held, NU);
            held[NP - NU..].copy_from_slice(&REST);
            for (i, p) in held.iter_mut().enumerate() {
                *p = clamp(*p, i);
            }
            // Recovering, the held plan violating a hard row: relaxed, each hard row widened to the
            // held plan's value, so that the QP has a plan that violates no row more than holding would.
            let relax = self.relax && #held_violation > ACCURACY;
            if relax {
                let mut rows = lower[NV..].iter_mut().zip(upper[NV..].iter_mut()).zip(ROW_SOFT.iter());
                ROW_A.each_row(held, |a| {
                    if let Some(((lo, hi), soft)) = rows.next() {
                        if !*soft {
                            *lo = if a < *lo { a } else { *lo };
                            *hi = if a > *hi { a } else { *hi };
                        }
                    }
                });
            }
            // A cold start after `new`, `reset`, a fallback or a relaxed solve.
            let warm = self.warm & !relax;
            if !warm {
                self.warm_len = [0; NBLOCKS];
            }
            #zero_rows
            let mut work = self.work.work();
            #empty_check {
                #caps
                let (ended, iterations) = solve(
                    &BLOCKS, f, lower, upper, &mut work, &mut self.warm_set, &mut self.warm_len, cap,
                    &TOLERANCES, &mut Tally::new(budget), z, |_, _, _, _| {},
                );
                #restart
            } #empty_end
            let trusted = ended == Ended::Solved;
            if trusted {
                for (i, (p, v)) in self.plan.iter_mut().zip(z.iter()).enumerate() {
                    *p = clamp(*v, i);
                }
            } else {
                self.plan = *held;
            }
            #next_warm
            let (violation, softened) = violations(&self.plan, offset);
            let infeasible = ended == Ended::Infeasible;
            // Recovering after a solve found the hard rows infeasible, or made a relaxed plan.
            self.relax = infeasible | (trusted & relax);
            self.status = SolverStatus {
                iterations: iterations as u32,
                primal_residual: 0.0,
                dual_residual: 0.0,
                gap: 0.0,
                #violation,
                #softened,
                infeasible,
                numerical_failure: (ended == Ended::NumericalFailure) | (ended == Ended::Cycling),
                reference_beyond_region: beyond,
                beyond_coordinate_range: beyond_coordinates,
                fallback: match (trusted, relax) {
                    (true, false) => Fallback::Solved,
                    (true, true) => Fallback::Relaxed,
                    (false, _) => Fallback::WarmStart,
                },
            };
            let mut first = [0.0; NU];
            first.copy_from_slice(&self.plan[..NU]);
            #set_last
            Some(first)
        }
    }
}

/// The kernels section: the helpers, the rows' values and violations, and the kernel (`kernel.rs`,
/// as the reference compiles it) with a tally that counts nothing.
fn kernels(m: &Method) -> TokenStream {
    let (input, entry) = (crate::emit::input_of(m.p), crate::emit::entry_param(m.p));
    let kernel: TokenStream = KERNEL_SOURCE
        .replace("pub(super) ", "")
        .parse()
        .unwrap_or_default();
    // The tally's methods, one per kind of work, each adding its weight (`WORK_KINDS`).
    let tally_kinds = super::WORK_KINDS.iter().map(|(kind, weight, _)| {
        let (kind, weight) = (
            Ident::new(kind, Span::call_site()),
            Ident::new(weight, Span::call_site()),
        );
        if kind == "pass" {
            quote! {
                #[inline(always)]
                fn #kind(&mut self) {
                    self.add(1, #weight);
                }
            }
        } else {
            quote! {
                #[inline(always)]
                fn #kind(&mut self, n: usize) {
                    self.add(n, #weight);
                }
            }
        }
    });
    quote! {
        /// The rest plan: U_REST at every step.
        const fn rest_plan() -> [Real; NP] {
            let mut out = [0.0; NP];
            let mut i = 0;
            while i < NP {
                out[i] = REST[#input];
                i += 1;
            }
            out
        }

        /// Plan entry `i` projected onto its input's bounds; NaN maps to the lower bound.
        #[inline(always)]
        fn clamp(v: Real, #entry: usize) -> Real {
            let (lo, hi) = (LO[#input], HI[#input]);
            let v = if v >= lo { v } else { lo };
            if v <= hi { v } else { hi }
        }

        /// Moves every block of `width` up by one; the last block stays.
        #[inline(always)]
        fn shift(v: &mut [Real], width: usize) {
            if width > 0 && v.len() > width {
                v.copy_within(width.., 0);
            }
        }

        /// A sparse matrix by rows, each row a list of runs of consecutive columns: row j's runs are
        /// `cols[starts[j]..starts[j + 1]]` (their first columns) with `lens[…]`, their values one after
        /// the other in `values`.
        struct Sparse {
            starts: &'static [Ix],
            cols: &'static [Ix],
            lens: &'static [Ix],
            values: &'static [Real],
        }

        impl Sparse {
            /// Each row's product with `x`, in the rows' order.
            #[inline(always)]
            fn each_row(&self, x: &[Real], mut each: impl FnMut(Real)) {
                let (mut run, mut next) = (0, 0);
                for end in self.starts.iter().skip(1) {
                    let end = *end as usize;
                    let mut s = 0.0;
                    if let (Some(cols), Some(lens)) = (self.cols.get(run..end), self.lens.get(run..end)) {
                        for (c, l) in cols.iter().zip(lens) {
                            let (c, l) = (*c as usize, *l as usize);
                            if let (Some(v), Some(x)) = (self.values.get(next..next + l), x.get(c..c + l)) {
                                for (a, b) in v.iter().zip(x) {
                                    s += *a * *b;
                                }
                            }
                            next += l;
                        }
                    }
                    run = end;
                    each(s);
                }
            }

            /// `out` = the product with `x`, row by row.
            #[inline(always)]
            fn times(&self, x: &[Real], out: &mut [Real]) {
                let mut out = out.iter_mut();
                self.each_row(x, |v| {
                    if let Some(o) = out.next() {
                        *o = v;
                    }
                });
            }
        }

        /// The largest hard-row violation of the plan (slacks zero) relative to max(1, |bound|), and
        /// the largest soft-row violation in its row's units, against the rows' sides before any
        /// widening, ROW_LOWER/ROW_UPPER − `offset`.
        fn violations(plan: &[Real; NP], offset: &[Real; NG]) -> (Real, Real) {
            let (mut hard, mut soft): (Real, Real) = (0.0, 0.0);
            let mut rows = ROW_LOWER.iter().zip(ROW_UPPER.iter()).zip(ROW_SOFT.iter().zip(offset.iter()));
            ROW_A.each_row(plan, |value| {
                if let Some(((row_lo, row_hi), (is_soft, o))) = rows.next() {
                    let (lo, hi) = ((*row_lo - *o) - value, value - (*row_hi - *o));
                    if *is_soft {
                        soft = soft.max(lo.max(hi).max(0.0));
                    } else {
                        let below = lo.max(0.0) / row_lo.abs().max(1.0);
                        let above = hi.max(0.0) / row_hi.abs().max(1.0);
                        hard = hard.max(below.max(above));
                    }
                }
            });
            (hard, soft)
        }

        /// A solve's work against its budget ([`WARM_WORK`], [`COLD_WORK`]): the kernel's multiply-adds
        /// and scanned rows, weighed as the build's reference weighs them.
        struct Tally {
            spent: usize,
            budget: usize,
        }

        impl Tally {
            fn new(budget: usize) -> Self {
                Tally { spent: 0, budget }
            }
            #[inline(always)]
            fn add(&mut self, n: usize, weight: usize) {
                self.spent = self.spent.saturating_add(n.saturating_mul(weight));
            }
            #(#tally_kinds)*
            #[inline(always)]
            fn exhausted(&self) -> bool {
                self.spent > self.budget
            }
        }

        #kernel
    }
}

/// The tables section: the tolerances, the sides, the rows, and each block's data.
fn tables(m: &Method, data_tables: TokenStream) -> TokenStream {
    let (qp, num) = (&m.p.qp, m.num);
    let rows = &qp.rows;
    let s = &m.structure;
    let np = qp.Nc * m.p.nu;
    let nu = m.p.nu;
    let [lo, hi, rest] =
        [&qp.u_min, &qp.u_max, &qp.rest_input()].map(|v| real_table(num, v.iter().copied()));
    let (z_lo, z_hi) = (
        real_table(num, s.z_min.iter().copied()),
        real_table(num, s.z_max.iter().copied()),
    );
    let (row_lower, row_upper) = (
        real_table(num, rows.lower.iter().copied()),
        real_table(num, rows.upper.iter().copied()),
    );
    let soft = rows.soft.iter();
    let slack_weight = real_table(num, rows.slack_weight.iter().copied());
    // f = F_θ·θ and the rows' offsets ROW_θ·θ, and the rows' coefficients on the plan, as runs.
    let p = m.p;
    let theta = Theta::of(p);
    let minus_fr = -&qp.Fr;
    let fd = qp.Fd.columns(0, p.nd()).into_owned();
    let wd = rows.Wd.columns(0, p.nd()).into_owned();
    let f_theta =
        Runs::of(&theta.matrix(np, [Some(&qp.Fx), Some(&minus_fr), Some(&qp.Fu), Some(&fd)]));
    let row_theta = Runs::of(&theta.matrix(
        rows.len(),
        [Some(&rows.Wx), None, Some(&rows.Wu), Some(&wd)],
    ));
    let row_a = Runs::of(&rows.A.columns(0, np).into_owned());
    let largest = [&f_theta, &row_theta, &row_a]
        .iter()
        .map(|r| r.largest())
        .max()
        .unwrap_or(0);
    let ix = if largest <= usize::from(u16::MAX) {
        quote!(u16)
    } else {
        quote!(u32)
    };
    let sparse_tables = [
        f_theta.emit(
            num,
            "F_THETA",
            " f's dependence on θ, F_θ = (Fx, −Fr, Fu, Fd), without its structural zeros.",
        ),
        row_theta.emit(
            num,
            "ROW_THETA",
            " The rows' offsets' dependence on θ, (Wx, 0, Wu, Wd), without their structural zeros.",
        ),
        row_a.emit(
            num,
            "ROW_A",
            " The rows' coefficients on the plan, without their structural zeros.",
        ),
    ];
    let tol = Tolerances::of(num.0);
    let t = |v: f64| num.lit(v);
    let [primal, dual, singular, refactor, pivot, progress, infeasible] = [
        tol.primal,
        tol.dual,
        tol.singular,
        tol.refactor,
        tol.pivot,
        tol.progress,
        tol.infeasible,
    ]
    .map(t);
    let cycle = Literal::usize_unsuffixed(tol.cycle);
    let zero_rows = (!m.prepared.zero_rows.is_empty()).then(|| {
        let count = Literal::usize_unsuffixed(m.prepared.zero_rows.len());
        let table = index_table(&m.prepared.zero_rows);
        quote! {
            /// Rows without coefficients on the unknowns.
            const ZERO_ROWS: [usize; #count] = #table;
        }
    });
    let mut block_tables = TokenStream::new();
    let mut block_items = Vec::new();
    for (b, block) in m.prepared.blocks.iter().enumerate() {
        let name = |s: &str| Ident::new(&format!("{s}_{b}"), Span::call_site());
        let [vars, r, sides, scale, starts, positions, values, gram, z_cols] = [
            "VARS",
            "R",
            "SIDES",
            "SCALE",
            "STARTS",
            "POSITIONS",
            "VALUES",
            "GRAM",
            "Z_COLS",
        ]
        .map(name);
        let pk = &block.packed;
        let len = |n: usize| Literal::usize_unsuffixed(n);
        let (l_vars, l_r, l_sides, l_starts, l_pos, l_gram, l_z) = (
            len(block.vars.len()),
            len(pk.r.len()),
            len(pk.sides.len()),
            len(pk.starts.len()),
            len(pk.positions.len()),
            len(pk.gram.len()),
            len(pk.z_cols.len()),
        );
        let (t_vars, t_r, t_sides, t_scale, t_starts, t_pos, t_values, t_gram, t_z) = (
            index_table(&block.vars),
            real_table(num, pk.r.iter().copied()),
            index_table(&pk.sides),
            real_table(num, block.scale.iter().copied()),
            index_table(&pk.starts),
            index_table(&pk.positions),
            real_table(num, pk.values.iter().copied()),
            real_table(num, pk.gram.iter().copied()),
            real_table(num, pk.z_cols.iter().copied()),
        );
        let doc = format!(
            " Block {b}: {} unknowns, {} constraints.",
            block.n(),
            block.rows.len()
        );
        block_tables.extend(quote! {
            #[doc = #doc]
            const #vars: [usize; #l_vars] = #t_vars;
            const #r: [Real; #l_r] = #t_r;
            const #sides: [usize; #l_sides] = #t_sides;
            const #scale: [Real; #l_sides] = #t_scale;
            const #starts: [usize; #l_starts] = #t_starts;
            const #positions: [usize; #l_pos] = #t_pos;
            const #values: [Real; #l_pos] = #t_values;
            const #gram: [Real; #l_gram] = #t_gram;
            const #z_cols: [Real; #l_z] = #t_z;
        });
        // The slack rows' proof: their reach (in f32 rounded outward) and the bounds it assumed.
        let reach = name("REACH");
        let proof = if pk.core < pk.sides.len() {
            let reach_values: Vec<f64> = match num.0 {
                Scalar::F32 => pk.f32_reach.iter().map(|v| f64::from(*v)).collect(),
                Scalar::F64 => pk.reach.clone(),
            };
            let l_reach = len(reach_values.len());
            let t_reach = real_table(num, reach_values);
            let doc = format!(
                " Block {b}'s rows from {} on cannot bind over `[mpc.region]`: per row the least and the most aᵀz within the bounds; the scan skips them where the data keep every side beyond its reach.",
                pk.core
            );
            block_tables.extend(quote! {
                #[doc = #doc]
                const #reach: [Real; #l_reach] = #t_reach;
            });
            quote!(reach: &#reach,)
        } else {
            quote!(reach: &[],)
        };
        let core = Literal::usize_unsuffixed(pk.core);
        let warm_at = Literal::usize_unsuffixed(pk.warm_at);
        let refine = pk.refine;
        block_items.push(quote! {
            Block {
                vars: &#vars,
                r: &#r,
                sides: &#sides,
                scale: &#scale,
                starts: &#starts,
                positions: &#positions,
                values: &#values,
                gram: &#gram,
                z_cols: &#z_cols,
                warm_at: #warm_at,
                refine: #refine,
                core: #core,
                #proof
            }
        });
    }
    let _ = nu;
    quote! {
        /// The kernel's tolerances, relative to the normalised problem (`codegen`'s
        /// `active_set::Tolerances` for this scalar).
        const TOLERANCES: Tolerances = Tolerances {
            primal: #primal,
            dual: #dual,
            singular: #singular,
            refactor: #refactor,
            pivot: #pivot,
            progress: #progress,
            cycle: #cycle,
            infeasible: #infeasible,
        };
        const LO: [Real; NU] = #lo;
        const HI: [Real; NU] = #hi;
        const REST: [Real; NU] = #rest;
        /// The unknowns' bounds: the input box on the plan, σ ≥ 0 on the slacks.
        const Z_LO: [Real; NV] = #z_lo;
        const Z_HI: [Real; NV] = #z_hi;
        /// The rows' sides before the data move them.
        const ROW_LOWER: [Real; NG] = #row_lower;
        const ROW_UPPER: [Real; NG] = #row_upper;
        /// Whether each row is soft (its violation priced by a slack).
        const ROW_SOFT: [bool; NG] = [#(#soft),*];
        /// The soft rows' L1 weights: the slacks' linear term.
        const SLACK_WEIGHT: [Real; NS] = #slack_weight;
        /// The index type of the sparse tables.
        type Ix = #ix;
        #(#sparse_tables)*
        #zero_rows
        #data_tables
        /// The independent blocks.
        const BLOCKS: [Block<'static>; NBLOCKS] = [#(#block_items),*];
        #block_tables
    }
}
