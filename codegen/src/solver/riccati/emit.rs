//! The Riccati form of the emitted interior-point method's normal system ([`crate::solver::riccati`]):
//! `factor` and `ldl_solve` with the contract of the condensed form's (`solver/ipm/emit.rs`: the same
//! signatures but for the factor's type, f64, control flow independent of the data but for the
//! regularised retries, no reachable panic, every table index checked), which they replace where the
//! cost model chooses the Riccati form.
//!
//! The factor is per stage the gain K_k (NU × NX) and the L·D·Lᵀ of Re_k (NU × NU), and with soft rows
//! Y = M_uu⁻¹·M_uσ and the L·D·Lᵀ of the slacks' Schur complement (emitted only then). The recursion
//! visits only the nonzeros of A and B: each nonzero is a line of the emitted code (a loop over the
//! dense dimension for the matrix products), the dense dimensions are loops, so the code grows with
//! nnz(A) + nnz(B), not with the horizon. The method's unknowns stay in the envelope's order (the
//! residuals and the rows are the condensed form's); the solve reads and writes them through `ORDER`.
#![allow(non_snake_case)]

use crate::emit::sections::Sections;
use crate::emit::tokens::Num;
use crate::lower::problem::Problem;
use crate::solver::ipm::{mpc_qp, Layout, Sparsity};
use crate::solver::riccati::{Choice, Form, Stages};
use mpc_spec::Scalar;
use nalgebra::{DMatrix, DVector};
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// The interior-point method's sections completed with the normal system in the form the cost model
/// chooses for `p`: `condensed` (the normal matrix's `NormalFactor`, `NORMAL_ZERO`, `factor` and
/// `ldl_solve`, with the helpers and tables they alone read) or the Riccati form's.
pub fn form(p: &Problem, sections: Sections, condensed: Sections) -> Sections {
    let qp = &p.qp;
    let system = match Stages::of(qp) {
        Ok(stages) if Choice::of(qp).form == Form::Riccati => emit(qp, &stages),
        _ => condensed,
    };
    sections.append(system)
}

/// What the Riccati form's sections are emitted from.
struct Stagewise<'a> {
    stages: &'a Stages,
    layout: Layout,
    sparsity: Sparsity,
    /// The nonzeros (row, column, value) of A and of B: the recursion and the solve visit only these.
    a_nz: Vec<(Literal, Literal, TokenStream)>,
    b_nz: Vec<(Literal, Literal, TokenStream)>,
    /// Whether there are soft rows, whose slacks have their Schur complement.
    soft: bool,
}

/// The Riccati form's kernels and tables.
fn emit(qp: &crate::lower::problem::Qp, stages: &Stages) -> Sections {
    let wide = Num(Scalar::F64);
    let lit = Literal::usize_unsuffixed;
    let structure = mpc_qp(
        qp,
        &DVector::zeros(qp.Nc * qp.u_min.len()),
        &DVector::zeros(qp.rows.len()),
    );
    let nonzeros = |M: &DMatrix<f64>| -> Vec<(Literal, Literal, TokenStream)> {
        let mut out = Vec::new();
        for i in 0..M.nrows() {
            for j in 0..M.ncols() {
                if M[(i, j)] != 0.0 {
                    out.push((lit(i), lit(j), wide.lit(M[(i, j)])));
                }
            }
        }
        out
    };
    let form = Stagewise {
        stages,
        layout: Layout::of(&structure),
        sparsity: Sparsity::of(&structure),
        a_nz: nonzeros(&stages.A),
        b_nz: nonzeros(&stages.B),
        soft: !stages.slack_quadratic.is_empty(),
    };
    let factor = factor_kernels(&form);
    let stage_ldl = stage_ldl_kernels();
    let solve = solve_kernels(&form);
    let slack_kernels = form.soft.then(slack_kernels);
    Sections {
        kernels: quote!(#factor #stage_ldl #solve #slack_kernels),
        tables: tables(&form),
        ..Sections::default()
    }
}

/// `NormalFactor` and `factor`: the stage Hessians and the backward recursion over the nonzeros of A
/// and B.
fn factor_kernels(form: &Stagewise) -> TokenStream {
    let (a_nz, b_nz, soft) = (&form.a_nz, &form.b_nz, form.soft);
    // The factorisation's products over the nonzeros of A (ai, j, v) and B (bi, c, v).
    let pa = a_nz.iter().map(|(ai, j, v)| {
        quote! {
            for i in 0..NX { pa[i][#j] += p[i][#ai] * #v; }
        }
    });
    let pb = b_nz.iter().map(|(bi, c, v)| {
        quote! {
            for i in 0..NX { pb[i][#c] += p[i][#bi] * #v; }
        }
    });
    let re = b_nz.iter().map(|(bi, c, v)| {
        quote! {
            for d in 0..NU { re[#c][d] += #v * pb[#bi][d]; }
        }
    });
    let se = a_nz.iter().map(|(ai, j, v)| {
        quote! {
            for c in 0..NU { se[c][#j] += pb[#ai][c] * #v; }
        }
    });
    let apa = a_nz.iter().map(|(ai, i, v)| {
        quote! {
            for j in 0..NX { next[#i][j] += #v * pa[#ai][j]; }
        }
    });
    // The soft rows' slacks: their Schur complement, emitted only where there are slacks.
    let slack_fields = soft.then(|| {
        quote! {
            /// Y = M_uu⁻¹·M_uσ, a row per slack (the plan in stage order).
            coupling: [[f64; NP]; NS],
            /// The L·D·Lᵀ of the Schur complement S = M_σσ − M_uσᵀ·Y.
            schur: [[f64; NS]; NS],
        }
    });
    let slack_zero = soft.then(|| {
        quote! {
            coupling: [[0.0; NP]; NS],
            schur: [[0.0; NS]; NS],
        }
    });
    let schur_call = soft.then(|| quote!(&riccati_schur(w, delta, m)));
    quote! {
    /// The normal matrix's Riccati factor: per stage k the gain K_k = Re_k⁻¹·Se_k and the L·D·Lᵀ of
    /// Re_k = R̃_k + Bᵀ·P_{k+1}·B (L below the diagonal, D on it).
    #[derive(Clone, Copy)]
    struct NormalFactor {
        gain: [[[f64; NX]; NU]; N],
        pivot: [[[f64; NU]; NU]; N],
        #slack_fields
    }

    const NORMAL_ZERO: NormalFactor = NormalFactor {
        gain: [[[0.0; NX]; NU]; N],
        pivot: [[[0.0; NU]; NU]; N],
        #slack_zero
    };

    /// The stage variables (x, u): NX + NU.
    const RICCATI_NXU: usize = NX + NU;

    /// `v[i] += x`, nothing past its end: the index tables are in range by construction; the check
    /// is a select here, where indexing would link a panic.
    #[inline(always)]
    fn add(v: &mut [f64], i: usize, x: f64) {
        if let Some(o) = v.get_mut(i) {
            *o += x;
        }
    }

    /// Factors H + Gᵀ·diag(w)·G in the Riccati form: the stage Hessians (the rows' weights added to
    /// 2Q, 2Q_f and 2R), then the recursion, adding a growing multiple of I to every R̃_k (which is
    /// M + δ·I) when a pivot is not positive, as the condensed form does; `false` when every
    /// attempt is refused.
    fn factor(w: &[f64; NSIDES], m: &mut NormalFactor) -> bool {
        // A two-sided row's sides add their weights.
        let mut wr = [0.0; RICCATI_NR];
        for j in 0..NG {
            add(&mut wr, at_index(&RICCATI_SIDE_ROW, j), w[NB + j]);
        }
        let mut z = [[[0.0; RICCATI_NXU]; RICCATI_NXU]; N + 1];
        for (wk, &i) in w.iter().zip(RICCATI_BOX.iter()) {
            // The plan's (the slacks' floor is their Schur complement's; RICCATI_BOX is constant).
            let c = NX + i % NU;
            if let Some(e) = z.get_mut(i / NU).filter(|_| i < NP).and_then(|s| s.get_mut(c)).and_then(|r| r.get_mut(c)) {
                *e += wk;
            }
        }
        for (wj, &(k, q)) in wr.iter().zip(RICCATI_ROW.iter()) {
            let terms: &[(usize, usize, f64)] = RICCATI_TERMS
                .get(at_index(&RICCATI_TERM_START, q)..at_index(&RICCATI_TERM_START, q + 1))
                .unwrap_or(&[]);
            if let Some(stage) = z.get_mut(k) {
                for &(a, b, v) in terms {
                    if let Some(e) = stage.get_mut(a).and_then(|r| r.get_mut(b)) {
                        *e += wj * v;
                    }
                }
            }
        }
        let mut largest = 0.0;
        for stage in z.iter().take(N) {
            for c in 0..NU {
                largest = larger(largest, (RICCATI_R2[c][c] + stage[NX + c][NX + c]).abs());
            }
        }
        let scale = 1.0 + largest;
        let mut delta = 0.0;
        for _ in 0..4 {
            if riccati(&z, delta, m) #schur_call {
                return true;
            }
            delta = if delta == 0.0 { 1e-12 * scale } else { delta * 1e3 };
        }
        false
    }

    /// The backward Riccati recursion over the stage Hessians `z` with δ on every R̃_k; `false` when
    /// a pivot of an Re_k is not positive and finite. It runs to the end either way.
    fn riccati(z: &[[[f64; RICCATI_NXU]; RICCATI_NXU]; N + 1], delta: f64, m: &mut NormalFactor) -> bool {
        let mut p = [[0.0; NX]; NX];
        for i in 0..NX {
            for j in 0..NX {
                p[i][j] = RICCATI_QF2[i][j] + z[N][i][j];
            }
        }
        let mut positive = true;
        for k in (0..N).rev() {
            let zk = &z[k];
            // P·B.
            let mut pb = [[0.0; NU]; NX];
            #(#pb)*
            // Re = R̃_k + Bᵀ·(P·B).
            let mut re = [[0.0; NU]; NU];
            for c in 0..NU {
                for d in 0..NU {
                    re[c][d] = RICCATI_R2[c][d] + zk[NX + c][NX + d];
                }
                re[c][c] += delta;
            }
            #(#re)*
            positive &= riccati_ldl(&mut re);
            m.pivot[k] = re;
            // Stage 0's gain and P_0 are not needed: x_0 = 0 (the loop index, not the data).
            if k > 0 {
                // P·A.
                let mut pa = [[0.0; NX]; NX];
                #(#pa)*
                // Se = S̃_k + (P·B)ᵀ·A.
                let mut se = [[0.0; NX]; NU];
                for c in 0..NU {
                    for j in 0..NX {
                        se[c][j] = zk[NX + c][j];
                    }
                }
                #(#se)*
                // K = Re⁻¹·Se.
                let mut gain = se;
                riccati_ldl_solve_rows(&re, &mut gain);
                // P_k = Q̃_k + Aᵀ·(P·A) − Seᵀ·K.
                let mut next = [[0.0; NX]; NX];
                for i in 0..NX {
                    for j in 0..NX {
                        next[i][j] = RICCATI_Q2[i][j] + zk[i][j];
                    }
                }
                #(#apa)*
                for i in 0..NX {
                    for j in 0..NX {
                        let mut a = next[i][j];
                        for c in 0..NU {
                            a -= se[c][i] * gain[c][j];
                        }
                        next[i][j] = a;
                    }
                }
                p = next;
                m.gain[k] = gain;
            }
        }
        positive
    }
    }
}

/// The L·D·Lᵀ of a stage's NU × NU matrix and its solves.
fn stage_ldl_kernels() -> TokenStream {
    quote! {
    /// L·D·Lᵀ of an NU × NU matrix in place (D on the diagonal); `false` when a pivot is not positive
    /// and finite. It runs to the end either way.
    fn riccati_ldl<const K: usize>(m: &mut [[f64; K]; K]) -> bool {
        let mut v = [0.0; K];
        let mut positive = true;
        for j in 0..K {
            let mut d = m[j][j];
            for k in 0..j {
                v[k] = m[j][k] * m[k][k];
                d -= m[j][k] * v[k];
            }
            // `&`, not `&&`: no branch. NaN fails `d > 0.0`.
            positive &= (d > 0.0) & (d < f64::INFINITY);
            m[j][j] = d;
            for row in m.iter_mut().skip(j + 1) {
                let mut a = row[j];
                for (r, vk) in row.iter().zip(v.iter()).take(j) {
                    a -= r * vk;
                }
                row[j] = a / d;
            }
        }
        positive
    }

    /// Solves L·D·Lᵀ x = b in place for an NU × NU factor of [`riccati_ldl`].
    fn riccati_ldl_solve<const K: usize>(m: &[[f64; K]; K], b: &mut [f64; K]) {
        for i in 0..K {
            let mut a = b[i];
            for k in 0..i {
                a -= m[i][k] * b[k];
            }
            b[i] = a;
        }
        for i in 0..K {
            b[i] /= m[i][i];
        }
        for i in (0..K).rev() {
            let x = b[i];
            for k in 0..i {
                b[k] -= m[i][k] * x;
            }
        }
    }

    /// Solves L·D·Lᵀ·X = B in place for the NX columns of B (NU × NX), a row of B at a time.
    fn riccati_ldl_solve_rows(m: &[[f64; NU]; NU], b: &mut [[f64; NX]; NU]) {
        for i in 0..NU {
            for k in 0..i {
                let (l, bk) = (m[i][k], b[k]);
                for (x, y) in b[i].iter_mut().zip(bk.iter()) {
                    *x -= l * y;
                }
            }
        }
        for (i, row) in b.iter_mut().enumerate() {
            let d = m[i][i];
            for x in row.iter_mut() {
                *x /= d;
            }
        }
        for i in (0..NU).rev() {
            let bi = b[i];
            for k in 0..i {
                let l = m[i][k];
                for (x, y) in b[k].iter_mut().zip(bi.iter()) {
                    *x -= l * y;
                }
            }
        }
    }
    }
}

/// `ldl_solve`, which solves the normal system by `riccati_solve` (and the slacks' Schur complement),
/// and `riccati_solve`, the backward sweep and forward rollout over the nonzeros of A and B.
fn solve_kernels(form: &Stagewise) -> TokenStream {
    let (a_nz, b_nz, soft) = (&form.a_nz, &form.b_nz, form.soft);
    // The solve's products: Bᵀ·p, Aᵀ·p, A·x and B·u.
    let btp = b_nz
        .iter()
        .map(|(bi, c, v)| quote!(ek[#c] += #v * pv[#bi];));
    let atp = a_nz
        .iter()
        .map(|(ai, i, v)| quote!(next[#i] += #v * pv[#ai];));
    let ax = a_nz
        .iter()
        .map(|(ai, j, v)| quote!(next[#ai] += #v * x[#j];));
    let bu = b_nz
        .iter()
        .map(|(bi, c, v)| quote!(next[#bi] += #v * uk[#c];));
    let slack_rs = soft.then(|| quote!(let mut rs = [0.0; NS];));
    let slack_put = soft.then(|| {
        quote! {
            // The slacks follow the plan (ORDER is constant: the same branch every time).
            if i >= NP {
                put(&mut rs, i - NP, *v);
            }
        }
    });
    let write_back = if soft {
        quote! {
            // Δσ = S⁻¹·(r_σ − Yᵀ·r_u), ΔU = M_uu⁻¹·r_u − Y·Δσ.
            let ru = riccati_flat(&r);
            for (sj, y) in rs.iter_mut().zip(m.coupling.iter()) {
                *sj -= dot(y, &ru);
            }
            riccati_ldl_solve(&m.schur, &mut rs);
            let mut du = riccati_flat(&u);
            for (y, sj) in m.coupling.iter().zip(rs.iter()) {
                for (d, yi) in du.iter_mut().zip(y.iter()) {
                    *d -= yi * sj;
                }
            }
            for (p, o) in b.iter_mut().enumerate() {
                let i = at_index(&ORDER, p);
                *o = if i < NP { at(&du, i) } else { at(&rs, i - NP) };
            }
        }
    } else {
        quote! {
            for (p, o) in b.iter_mut().enumerate() {
                let i = at_index(&ORDER, p);
                *o = match u.get(i / NU).and_then(|s| s.get(i % NU)) {
                    Some(v) => *v,
                    None => 0.0,
                };
            }
        }
    };
    quote! {
    /// Solves the normal system for the right-hand side b (the method's order) in place: the plan's
    /// part by [`riccati_solve`], the slacks' (when there are) by their Schur complement.
    fn ldl_solve(m: &NormalFactor, b: &mut [f64; NV]) {
        // Plan entry k·NU + c is input c of stage k.
        let mut r = [[0.0; NU]; N];
        #slack_rs
        for (p, v) in b.iter().enumerate() {
            let i = at_index(&ORDER, p);
            if let Some(e) = r.get_mut(i / NU).and_then(|s| s.get_mut(i % NU)) {
                *e = *v;
            }
            #slack_put
        }
        let u = riccati_solve(m, &r);
        #write_back
    }

    /// M_uu⁻¹·r for r on the plan, in stage order: the backward sweep of the cost-to-go's linear
    /// term (e_k = Bᵀ·p − r_k, p ← Aᵀ·p − K_kᵀ·e_k) and the forward rollout from x_0 = 0
    /// (u_k = −K_k·x_k − Re_k⁻¹·e_k, x_{k+1} = A·x_k + B·u_k).
    fn riccati_solve(m: &NormalFactor, r: &[[f64; NU]; N]) -> [[f64; NU]; N] {
        let mut pv = [0.0; NX];
        let mut e = [[0.0; NU]; N];
        for k in (0..N).rev() {
            let mut ek = [0.0; NU];
            for c in 0..NU {
                ek[c] = -r[k][c];
            }
            #(#btp)*
            let mut next = [0.0; NX];
            #(#atp)*
            for (g, ec) in m.gain[k].iter().zip(ek.iter()) {
                for (n, gi) in next.iter_mut().zip(g.iter()) {
                    *n -= gi * ec;
                }
            }
            pv = next;
            riccati_ldl_solve(&m.pivot[k], &mut ek);
            e[k] = ek;
        }
        let mut x = [0.0; NX];
        let mut u = [[0.0; NU]; N];
        for k in 0..N {
            let mut uk = [0.0; NU];
            for ((u, g), ec) in uk.iter_mut().zip(m.gain[k].iter()).zip(e[k].iter()) {
                let mut a = -ec;
                for (gj, xj) in g.iter().zip(x.iter()) {
                    a -= gj * xj;
                }
                *u = a;
            }
            let mut next = [0.0; NX];
            #(#ax)*
            #(#bu)*
            x = next;
            u[k] = uk;
        }
        u
    }
    }
}

/// The slacks' Schur complement `riccati_schur` and `riccati_flat`, where there are soft rows.
fn slack_kernels() -> TokenStream {
    quote! {
        /// The slacks' Schur complement for the weights `w` and δ on its diagonal (M + δ·I): Y =
        /// M_uu⁻¹·M_uσ, a plan solve per slack (M_uσ's column j is the plan part of Gᵀ of slack j's
        /// sides' weights), and the L·D·Lᵀ of S = M_σσ − M_uσᵀ·Y; `false` when a pivot of S is not
        /// positive and finite.
        fn riccati_schur(w: &[f64; NSIDES], delta: f64, m: &mut NormalFactor) -> bool {
            let mut s = [[0.0; NS]; NS];
            for (j, row) in s.iter_mut().enumerate() {
                row[j] = RICCATI_SQ[j] + delta;
            }
            // The floor σ ≥ 0 (RICCATI_BOX is constant: the same branch every time).
            for (wk, &i) in w.iter().zip(RICCATI_BOX.iter()) {
                if i >= NP {
                    if let Some(e) = s.get_mut(i - NP).and_then(|row| row.get_mut(i - NP)) {
                        *e += wk;
                    }
                }
            }
            let mut coupling = [[0.0; NP]; NS];
            let mut columns = [[0.0; NP]; NS];
            for (j, (y, column)) in coupling.iter_mut().zip(columns.iter_mut()).enumerate() {
                let mut v = [0.0; NSIDES];
                for (t, &(sj, c)) in RICCATI_SIDE_SLACK.iter().enumerate() {
                    // RICCATI_SIDE_SLACK is constant: the same branch every time.
                    if sj == j {
                        let wt = at(w, NB + t);
                        put(&mut v, NB + t, wt * c);
                        if let Some(e) = s.get_mut(j).and_then(|row| row.get_mut(j)) {
                            *e += wt * c * c;
                        }
                    }
                }
                let mut g = [0.0; NV];
                g_tmul(&v, &mut g);
                let mut r = [[0.0; NU]; N];
                for (p, x) in g.iter().enumerate() {
                    let i = at_index(&ORDER, p);
                    if let Some(e) = r.get_mut(i / NU).and_then(|s| s.get_mut(i % NU)) {
                        *e = *x;
                    }
                }
                *column = riccati_flat(&r);
                *y = riccati_flat(&riccati_solve(m, &r));
            }
            for (row, column) in s.iter_mut().zip(columns.iter()) {
                for (e, y) in row.iter_mut().zip(coupling.iter()) {
                    *e -= dot(column, y);
                }
            }
            let positive = riccati_ldl(&mut s);
            m.coupling = coupling;
            m.schur = s;
            positive
        }

        /// A plan in stage order, flat.
        fn riccati_flat(u: &[[f64; NU]; N]) -> [f64; NP] {
            let mut out = [0.0; NP];
            for (o, v) in out.iter_mut().zip(u.iter().flatten()) {
                *o = *v;
            }
            out
        }
    }
}

/// The tables section: the stage weights, the rows' outer products on their stage and the box.
fn tables(form: &Stagewise) -> TokenStream {
    let (stages, layout, sparsity) = (form.stages, &form.layout, &form.sparsity);
    let wide = Num(Scalar::F64);
    let lit = Literal::usize_unsuffixed;
    // Each row of a slot on its stage's (x, u): the terms (a, b, v_a·v_b) of its outer product.
    let mut term_start = vec![0usize];
    let mut terms = Vec::new();
    for row in &stages.rows {
        let v: Vec<(usize, f64)> = row
            .ax
            .iter()
            .chain(row.au.iter())
            .copied()
            .enumerate()
            .filter(|(_, x)| *x != 0.0)
            .collect();
        for &(a, va) in &v {
            for &(b, vb) in &v {
                terms.push((a, b, va * vb));
            }
        }
        term_start.push(terms.len());
    }
    let per_slot = stages.rows.len().max(1);
    let row_stage = sparsity.rows.iter().map(|&r| {
        let (j, q) = (r / per_slot, r % per_slot);
        let k = lit(j + stages.rows.get(q).map_or(0, |row| row.lag));
        let q = lit(q);
        quote!((#k, #q))
    });
    let nr = lit(sparsity.rows.len());
    let side_row = sparsity.side_row.iter().map(|r| lit(*r));
    let box_index = layout.boxed.iter().map(|(i, _)| lit(*i));
    let term_start_lit = term_start.iter().map(|s| lit(*s));
    let n_terms = lit(terms.len());
    let terms_lit = terms.iter().map(|&(a, b, v)| {
        let (a, b, v) = (lit(a), lit(b), wide.lit(v));
        quote!((#a, #b, #v))
    });
    let n_kinds = lit(stages.rows.len());
    let (q2, qf2, r2) = (
        wide.matrix(&stages.Q2),
        wide.matrix(&stages.Qf2),
        wide.matrix(&stages.R2),
    );
    let slack_tables = form.soft.then(|| slack_tables(form));
    quote! {
    /// The Riccati form's stage weights: 2Q (stages 1 … N−1), 2Q_f (stage N) and 2R.
    const RICCATI_Q2: [[f64; NX]; NX] = #q2;
    const RICCATI_QF2: [[f64; NX]; NX] = #qf2;
    const RICCATI_R2: [[f64; NU]; NU] = #r2;
    /// Rows with a finite side, as in the condensed form: side j belongs to row RICCATI_SIDE_ROW[j].
    const RICCATI_NR: usize = #nr;
    const RICCATI_SIDE_ROW: [usize; NG] = [#(#side_row),*];
    /// Per row (its stage k, its kind q within a slot): its outer product on stage k's (x, u) is the
    /// terms RICCATI_TERMS[RICCATI_TERM_START[q]..RICCATI_TERM_START[q + 1]], each (a, b, v_a·v_b).
    const RICCATI_ROW: [(usize, usize); RICCATI_NR] = [#(#row_stage),*];
    const RICCATI_TERM_START: [usize; #n_kinds + 1] = [#(#term_start_lit),*];
    const RICCATI_TERMS: [(usize, usize, f64); #n_terms] = [#(#terms_lit),*];
    /// Box side k bounds unknown RICCATI_BOX[k]: plan entry i is input i % NU of stage i / NU, the
    /// slacks follow the plan.
    const RICCATI_BOX: [usize; NB] = [#(#box_index),*];
    #slack_tables
    }
}

/// The slacks' tables, where there are soft rows: each side's slack and the slacks' weights.
fn slack_tables(form: &Stagewise) -> TokenStream {
    let (stages, layout) = (form.stages, &form.layout);
    let wide = Num(Scalar::F64);
    let lit = Literal::usize_unsuffixed;
    let (ns, per_slot) = (stages.slack_quadratic.len(), stages.rows.len().max(1));
    let side_slack = layout.rows.iter().map(|&(r, sign)| {
        match stages.slack.get(r % per_slot).copied().flatten() {
            Some((j, c)) => {
                let (j, c) = (lit(j), wide.lit(sign * c));
                quote!((#j, #c))
            }
            None => {
                let (j, c) = (lit(ns), wide.lit(0.0));
                quote!((#j, #c))
            }
        }
    });
    let sq = wide.vector(stages.slack_quadratic.iter().copied());
    quote! {
        /// Side j's slack and its coefficient on it, (slack, ±1), or (NS, 0) for a hard row's side.
        const RICCATI_SIDE_SLACK: [(usize, f64); NG] = [#(#side_slack),*];
        /// The slacks' quadratic weights q_σ.
        const RICCATI_SQ: [f64; NS] = #sq;
    }
}
