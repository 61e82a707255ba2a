//! ADMM's stage-wise x-update ([`crate::solver::admm::Program`]) as `stage_solve(x, z, y, q, xt, zt)`: the program's statements over
//! one scratch array `s`, in its order and with its coefficients, so that the module matches the
//! reference ([`crate::solver::admm::Operator`] with `Structure::Riccati`) to the bit. Written out, one statement
//! per line with the coefficients as literals, within [`crate::plan::WRITE_OUT_BUDGET`] terms; past it a
//! loop over the statements in compressed tables.

use crate::emit::sections::Sections;
use crate::emit::tokens::{at, Num};
use crate::solver::admm::{Program, ZERO_SLOT};
use proc_macro2::Literal;
use quote::quote;

/// `stage_solve(x, z, y, q, xt, zt)` and the tables it reads (none when written out).
pub fn kernel(num: Num, program: &Program, write_out_budget: usize) -> Sections {
    let lit = Literal::usize_unsuffixed;
    let (nv, nc) = (program.nv, program.nv + program.m);
    let range = |at: usize, n: usize| {
        let (a, b) = (lit(at), lit(at + n));
        quote!(#a..#b)
    };
    let slots = lit(program.slots);
    let (x_in, z_in, y_in, q_in) = (
        range(program.x_in, nv),
        range(program.z_in, nc),
        range(program.y_in, nc),
        range(program.q_in, nv),
    );
    let (x_out, z_out) = (range(program.x_at, nv), range(program.z_at, program.m));
    let head = quote! {
        let mut s = [0.0; #slots];
        s[#x_in].copy_from_slice(x);
        s[#z_in].copy_from_slice(z);
        s[#y_in].copy_from_slice(y);
        s[#q_in].copy_from_slice(q);
    };
    let tail = quote! {
        xt.copy_from_slice(&s[#x_out]);
        zt[..NV].copy_from_slice(xt);
        zt[NV..].copy_from_slice(&s[#z_out]);
    };
    let (doc, body, tables) = if program.terms() <= write_out_budget {
        let statements = program.statements.iter().map(|st| {
            let base = if st.base == ZERO_SLOT {
                quote!(0.0)
            } else {
                at("s", st.base)
            };
            let sum = num.fold(base, st.terms.iter().map(|&(c, i)| (c, at("s", i))));
            let out = at("s", st.out);
            match st.scale {
                Some(scale) => {
                    let scale = num.lit(scale);
                    quote!(#out = (#sum) * #scale;)
                }
                None => quote!(#out = #sum;),
            }
        });
        (
            [
                " x̃ and z̃ = C·x̃ at the iterate (x, z, y) stage by stage, written out: the right-hand side",
                " (the rows' share of Cᵀw as linear terms on the stages), the backward Riccati sweep with the",
                " gains computed at build time, the forward rollout evaluating each row on its stage (and with",
                " slacks, their Schur complement), in the scratch `s`.",
            ],
            quote!(#(#statements)*),
            quote!(),
        )
    } else {
        let t = program.tables();
        let (n_lit, terms_lit) = (lit(t.out.len()), lit(t.slot.len()));
        let outs = t.out.iter().map(|s| lit(*s));
        let bases = t.base.iter().map(|s| lit(*s));
        let starts = t.start.iter().map(|s| lit(*s));
        let slots_lit = t.slot.iter().map(|s| lit(*s));
        let coefficients = num.vector(t.coefficient.iter().copied());
        let scales = num.vector(t.scale.iter().copied());
        (
            [
                " x̃ and z̃ = C·x̃ at the iterate (x, z, y) stage by stage: the statements of [`STAGE_OUT`] in",
                " order over the scratch `s`, each s[out] = (s[base] + Σ c·s[slot])·scale (the Riccati sweep",
                " with the gains computed at build time). The tables are consistent by construction; `get`",
                " keeps the indexing free of panicking paths.",
            ],
            quote! {
                for k in 0..STAGE_STATEMENTS {
                    let mut v = s.get(STAGE_BASE[k]).copied().unwrap_or(0.0);
                    let span = STAGE_START[k]..STAGE_START[k + 1];
                    let slots = STAGE_SLOT.get(span.clone()).unwrap_or(&[]);
                    let coefficients = STAGE_COEFFICIENT.get(span).unwrap_or(&[]);
                    for (&i, &c) in slots.iter().zip(coefficients) {
                        v += c * s.get(i).copied().unwrap_or(0.0);
                    }
                    if let Some(o) = s.get_mut(STAGE_OUT[k]) {
                        *o = v * STAGE_SCALE[k];
                    }
                }
            },
            quote! {
                /// The stage-wise x-update's statements: s[STAGE_OUT[k]] = (s[STAGE_BASE[k]] + Σ
                /// STAGE_COEFFICIENT[t]·s[STAGE_SLOT[t]] over t ∈ STAGE_START[k]..STAGE_START[k + 1])
                /// · STAGE_SCALE[k], slot 0 always zero.
                const STAGE_STATEMENTS: usize = #n_lit;
                const STAGE_OUT: [usize; #n_lit] = [#(#outs),*];
                const STAGE_BASE: [usize; #n_lit] = [#(#bases),*];
                const STAGE_START: [usize; #n_lit + 1] = [#(#starts),*];
                const STAGE_SLOT: [usize; #terms_lit] = [#(#slots_lit),*];
                const STAGE_COEFFICIENT: [Real; #terms_lit] = #coefficients;
                const STAGE_SCALE: [Real; #n_lit] = #scales;
            },
        )
    };
    Sections {
        kernels: quote! {
            #(#[doc = #doc])*
            fn stage_solve(
                x: &[Real; NV],
                z: &[Real; NC],
                y: &[Real; NC],
                q: &[Real; NV],
                xt: &mut [Real; NV],
                zt: &mut [Real; NC],
            ) {
                #head
                #body
                #tail
            }
        },
        tables,
        ..Sections::default()
    }
}
