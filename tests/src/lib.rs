#![doc = include_str!("../README.md")]

pub mod harness;

/// Implements [`harness::Generated`] for a module emitted by `mpc!`.
macro_rules! controllers {
    ($($name:ident => $path:literal,)*) => {
        $(
            mpc_macros::mpc!(pub mod $name = $path);
        )*

        /// Every generated controller under test, by name.
        pub mod generated {
            use super::harness::Generated;
            $(
                #[allow(non_camel_case_types)]
                /// The generated controller of
                #[doc = $path]
                pub struct $name;

                impl Generated for $name {
                    const SPEC: &'static str = concat!(env!("CARGO_MANIFEST_DIR"), "/", $path);
                    type Mpc = super::$name::Mpc;
                    type Kalman = super::$name::Kalman;
                    type Real = super::$name::Real;

                    fn mpc_new() -> Self::Mpc {
                        super::$name::Mpc::new()
                    }

                    fn mpc_solve(mpc: &mut Self::Mpc, x0: &[f64], xref: &[Vec<f64>]) -> Vec<f64> {
                        use super::$name::{NX, N};
                        let mut x: [Self::Real; NX] = [0.0; NX];
                        for (a, b) in x.iter_mut().zip(x0) {
                            *a = *b as Self::Real;
                        }
                        let mut r: [[Self::Real; NX]; N] = [[0.0; NX]; N];
                        for (a, b) in r.iter_mut().zip(xref) {
                            for (a, b) in a.iter_mut().zip(b) {
                                *a = *b as Self::Real;
                            }
                        }
                        mpc.solve(&x, &r).iter().map(|v| *v as f64).collect()
                    }

                    fn mpc_plan(mpc: &Self::Mpc) -> Vec<f64> {
                        mpc.plan().iter().flatten().map(|v| *v as f64).collect()
                    }

                    fn mpc_reset(mpc: &mut Self::Mpc) {
                        mpc.reset();
                    }

                    fn kalman_new(x0: &[f64]) -> Self::Kalman {
                        use super::$name::NX;
                        let mut x: [Self::Real; NX] = [0.0; NX];
                        for (a, b) in x.iter_mut().zip(x0) {
                            *a = *b as Self::Real;
                        }
                        super::$name::Kalman::new(x)
                    }

                    fn kalman_predict(k: &mut Self::Kalman, u: &[f64]) {
                        use super::$name::NU;
                        let mut v: [Self::Real; NU] = [0.0; NU];
                        for (a, b) in v.iter_mut().zip(u) {
                            *a = *b as Self::Real;
                        }
                        k.predict(&v);
                    }

                    fn kalman_update(k: &mut Self::Kalman, z: &[f64]) -> bool {
                        use super::$name::NY;
                        let mut v: [Self::Real; NY] = [0.0; NY];
                        for (a, b) in v.iter_mut().zip(z) {
                            *a = *b as Self::Real;
                        }
                        k.update(&v).accepted()
                    }

                    fn kalman_state(k: &Self::Kalman) -> Vec<f64> {
                        k.state().iter().map(|v| *v as f64).collect()
                    }

                    fn round(v: f64) -> f64 {
                        v as Self::Real as f64
                    }

                    fn epsilon() -> f64 {
                        Self::Real::EPSILON as f64
                    }
                }
            )*
        }
    };
}

controllers! {
    paper => "../specs/paper.toml",
    paper_faithful => "../specs/paper-faithful.toml",
    paper_initial => "../specs/paper-initial.toml",
    paper_f64 => "specs/paper-f64.toml",
    horizon1_f64 => "specs/horizon1-f64.toml",
    horizon40 => "specs/horizon40.toml",
    asymmetric_gradient => "specs/asymmetric-gradient.toml",
    full_q => "specs/full-q.toml",
    linear_f64 => "specs/linear-f64.toml",
    linear_f32 => "specs/linear-f32.toml",
    converged => "specs/converged.toml",
    offset_free => "../specs/paper-offset-free.toml",
    offset_free_f64 => "specs/offset-free-f64.toml",
    linear_offset_free => "specs/linear-offset-free.toml",
    // The same specs with the gradient's emission forced, one module per choice (`auto` chose the others).
    paper_unrolled => "specs/emission/paper-unrolled.toml",
    paper_table => "specs/emission/paper-table.toml",
    paper_matrix_free => "specs/emission/paper-matrix-free.toml",
    paper_f64_table => "specs/emission/paper-f64-table.toml",
    paper_f64_matrix_free => "specs/emission/paper-f64-matrix-free.toml",
    full_q_unrolled => "specs/emission/full-q-unrolled.toml",
    full_q_matrix_free => "specs/emission/full-q-matrix-free.toml",
    horizon40_unrolled => "specs/emission/horizon40-unrolled.toml",
    horizon40_matrix_free => "specs/emission/horizon40-matrix-free.toml",
    linear_f64_unrolled => "specs/emission/linear-f64-unrolled.toml",
    linear_f64_matrix_free => "specs/emission/linear-f64-matrix-free.toml",
    offset_free_unrolled => "specs/emission/offset-free-unrolled.toml",
    offset_free_table => "specs/emission/offset-free-table.toml",
    offset_free_matrix_free => "specs/emission/offset-free-matrix-free.toml",
    linear_offset_free_unrolled => "specs/emission/linear-offset-free-unrolled.toml",
    linear_offset_free_matrix_free => "specs/emission/linear-offset-free-matrix-free.toml",
}

/// Implements [`harness::OffsetFree`] for generated modules with a disturbance model.
macro_rules! offset_free {
    ($($name:ident),*) => {$(
        impl harness::OffsetFree for generated::$name {
            fn mpc_solve_with_disturbance(mpc: &mut Self::Mpc, x0: &[f64], d: &[f64], xref: &[Vec<f64>]) -> Vec<f64> {
                use $name::{N, ND, NX};
                type R = $name::Real;
                let x: [R; NX] = core::array::from_fn(|i| x0[i] as R);
                let d: [R; ND] = core::array::from_fn(|i| d[i] as R);
                let r: [[R; NX]; N] = core::array::from_fn(|k| core::array::from_fn(|i| xref[k][i] as R));
                mpc.solve_with_disturbance(&x, &d, &r).iter().map(|v| *v as f64).collect()
            }

            fn kalman_disturbance(k: &Self::Kalman) -> Vec<f64> {
                k.disturbance().iter().map(|v| *v as f64).collect()
            }
        }
    )*};
}

offset_free!(
    offset_free,
    offset_free_f64,
    linear_offset_free,
    offset_free_unrolled,
    offset_free_table,
    offset_free_matrix_free,
    linear_offset_free_unrolled,
    linear_offset_free_matrix_free
);
