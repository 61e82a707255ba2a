//! `Controller`, one control cycle in the paper's order, and the `Status` it reports.

use crate::lower::problem::Problem;
use proc_macro2::TokenStream;
use quote::quote;

/// The `Controller` and `Status` types (API), and the saturation kernel.
/// `solver` names the constrained method whose status `Status::solver` carries (`None`: no such field).
pub fn emit(p: &Problem, solver: Option<&str>) -> (TokenStream, TokenStream) {
    let row = crate::solver::first_order::form::reference_row(p);
    // The constrained method's own status (the interior-point method's, ADMM's), copied into the cycle's.
    let solver = Solver::new(solver);
    let keeps_last = p.keeps_last_input();
    let moves = keeps_last.then(|| {
        quote! {
            /// Sets the last input u₋₁ the first move is weighted from (see [`Mpc::set_last_input`]), for a
            /// vehicle flown by something else until now; `false`, and nothing changes, for a non-finite
            /// entry.
            pub fn set_last_input(&mut self, u: &[Real; NU]) -> bool {
                self.mpc.set_last_input(u)
            }
        }
    });
    let kernels = quote! {
        /// Per input, whether `u` is at a bound.
        #[inline(always)]
        fn saturated(u: &[Real; NU]) -> [bool; NU] {
            let mut out = [false; NU];
            for (((s, v), lo), hi) in out.iter_mut().zip(u.iter()).zip(U_MIN.iter()).zip(U_MAX.iter()) {
                *s = *v <= *lo || *v >= *hi;
            }
            out
        }
    };
    let Solver {
        field,
        init,
        copy,
        fell_back,
    } = &solver;
    if p.filter.is_none() {
        return (state_feedback(p, &row, moves, &solver), kernels);
    }
    let (d_arg, d_doc) = if p.nd() > 0 {
        (
            quote!(&self.kalman.d,),
            " The MPC is given the filter's disturbance estimate (offset-free MPC).",
        )
    } else {
        (quote!(), "")
    };
    let step_doc = format!(
        " One control cycle: the filter update with the measurement `z` (screened: see [`Kalman::update`]), \
         the MPC from the estimate with the reference window `xref`, the filter prediction with the \
         command. Returns the command, always finite and inside [U_MIN, U_MAX]; [`Controller::status`] \
         says what happened.{d_doc}"
    );
    let api = quote! {
        /// One control cycle in the paper's order (Section 2.1): filter update with the measurement,
        /// MPC from the estimate, filter prediction with the command.
        #[derive(Clone, Debug, PartialEq)]
        pub struct Controller {
            kalman: Kalman,
            mpc: Mpc,
            estimate: [Real; NX],
            status: Status,
        }

        /// What one control cycle did ([`Controller::status`]).
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Status {
            /// What the filter did with the measurement, and its counts.
            pub filter: FilterStatus,
            /// How the command was made.
            pub command: Command,
            /// Per input, whether the command is at U_MIN or U_MAX.
            pub saturated: [bool; NU],
            #field
        }

        impl Status {
            #fell_back
        }

        /// How a control cycle's command was made.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum Command {
            /// No cycle yet.
            NoneYet,
            /// Solved from the estimate.
            Solved,
            /// [`U_REST`]: the filter has no estimate (a non-finite `x0`, and no usable reading since).
            NoEstimate,
            /// [`U_REST`]: the reference window has a NaN or infinite entry; the warm start is reset.
            InvalidReference,
        }

        impl Controller {
            /// A controller whose filter starts at `x0` and whose MPC starts cold. A non-finite `x0` is
            /// refused, visibly: until the first usable reading the status says
            /// [`Command::NoEstimate`] and the command is [`U_REST`].
            pub const fn new(x0: [Real; NX]) -> Self {
                let kalman = Kalman::new(x0);
                Controller {
                    estimate: kalman.x,
                    status: Status {
                        filter: kalman.status,
                        command: Command::NoneYet,
                        saturated: [false; NU],
                        #init
                    },
                    kalman,
                    mpc: Mpc::new(),
                }
            }

            /// Starts again from `x0`, as [`Controller::new`].
            pub fn reset(&mut self, x0: [Real; NX]) {
                *self = Self::new(x0);
            }

            #[doc = #step_doc]
            pub fn step(&mut self, z: &[Real; NY], xref: &[[Real; #row]; N]) -> [Real; NU] {
                self.kalman.update(z);
                let (u, command) = if self.kalman.status.estimate_valid {
                    self.estimate = self.kalman.x;
                    match self.mpc.checked(&self.estimate, #d_arg xref) {
                        Some(u) => (u, Command::Solved),
                        None => (U_REST, Command::InvalidReference),
                    }
                } else {
                    self.mpc.reset();
                    (U_REST, Command::NoEstimate)
                };
                self.kalman.predict(&u);
                self.status = Status {
                    filter: self.kalman.status,
                    command,
                    saturated: saturated(&u),
                    #copy
                };
                u
            }

            /// What the last cycle did.
            pub fn status(&self) -> &Status {
                &self.status
            }

            /// The estimate the last command was computed from (the filter's state before its
            /// prediction).
            pub fn estimate(&self) -> &[Real; NX] {
                &self.estimate
            }

            /// The filter.
            pub fn kalman(&self) -> &Kalman {
                &self.kalman
            }

            /// The MPC.
            pub fn mpc(&self) -> &Mpc {
                &self.mpc
            }

            #moves
        }
    };
    (api, kernels)
}

/// The controller of a spec without `[kalman]`: the MPC on the measured state.
fn state_feedback(
    p: &Problem,
    row: &TokenStream,
    moves: Option<TokenStream>,
    solver: &Solver,
) -> TokenStream {
    let Solver {
        field,
        init,
        copy,
        fell_back,
    } = solver;
    let reference = if p.qp.Cz.is_some() {
        "the output references"
    } else {
        "the state references"
    };
    let step_doc = format!(
        " One control cycle on the measured state `x` (this controller has no filter) and the window of \
         {reference} `xref`. Returns the command, always finite and inside [U_MIN, U_MAX]; \
         [`Controller::status`] says what happened: a non-finite state or reference gives [`U_REST`]."
    );
    quote! {
        /// State feedback: the MPC on the measured state, one control cycle per [`Controller::step`]
        /// (the spec has no `[kalman]`).
        #[derive(Clone, Debug, PartialEq)]
        pub struct Controller {
            mpc: Mpc,
            status: Status,
        }

        /// What one control cycle did ([`Controller::status`]).
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct Status {
            /// How the command was made.
            pub command: Command,
            /// Per input, whether the command is at U_MIN or U_MAX.
            pub saturated: [bool; NU],
            #field
        }

        impl Status {
            #fell_back
        }

        /// How a control cycle's command was made. The state is measured, not estimated: there is no
        /// filter status.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum Command {
            /// No cycle yet.
            NoneYet,
            /// Solved from the measured state.
            Solved,
            /// [`U_REST`]: the measured state has a NaN or infinite entry; the warm start is reset.
            InvalidState,
            /// [`U_REST`]: the reference window has a NaN or infinite entry; the warm start is reset.
            InvalidReference,
        }

        impl Controller {
            /// A controller whose MPC starts cold.
            pub const fn new() -> Self {
                Controller {
                    mpc: Mpc::new(),
                    status: Status {
                        command: Command::NoneYet,
                        saturated: [false; NU],
                        #init
                    },
                }
            }

            /// Starts again, as [`Controller::new`].
            pub fn reset(&mut self) {
                *self = Self::new();
            }

            #[doc = #step_doc]
            pub fn step(&mut self, x: &[Real; NX], xref: &[[Real; #row]; N]) -> [Real; NU] {
                let (u, command) = if !all_finite(x) {
                    self.mpc.reset();
                    (U_REST, Command::InvalidState)
                } else {
                    match self.mpc.checked(x, xref) {
                        Some(u) => (u, Command::Solved),
                        None => (U_REST, Command::InvalidReference),
                    }
                };
                self.status = Status {
                    command,
                    saturated: saturated(&u),
                    #copy
                };
                u
            }

            /// What the last cycle did.
            pub fn status(&self) -> &Status {
                &self.status
            }

            /// The MPC.
            pub fn mpc(&self) -> &Mpc {
                &self.mpc
            }

            #moves
        }

        impl Default for Controller {
            fn default() -> Self {
                Self::new()
            }
        }
    }
}

/// The `solver` field of `Status` with a constrained method (`ipm`, `admm`): its declaration, its value in
/// `Controller::new` and its copy after a cycle.
struct Solver {
    field: TokenStream,
    init: TokenStream,
    copy: TokenStream,
    /// `Status::fell_back`, in every module: code written against any method can ask it.
    fell_back: TokenStream,
}

impl Solver {
    fn new(method: Option<&str>) -> Self {
        let Some(method) = method else {
            return Solver {
                field: quote!(),
                init: quote!(),
                copy: quote!(),
                fell_back: quote! {
                    /// Whether the command came from the solver's fallback instead of its solve: never here,
                    /// since this method runs its fixed iterations from any start and has no fallback.
                    pub const fn fell_back(&self) -> bool {
                        false
                    }
                },
            };
        };
        let doc = format!(" What the {method} did: iterations, residuals, violations, fallback.");
        Solver {
            field: quote! {
                #[doc = #doc]
                pub solver: SolverStatus,
            },
            init: quote!(solver: Mpc::new().status,),
            copy: quote!(solver: *self.mpc.solver_status(),),
            fell_back: quote! {
                /// Whether the command came from the solver's fallback ([`Fallback::WarmStart`]) instead of
                /// its solve; [`Status::solver`] says why.
                pub fn fell_back(&self) -> bool {
                    self.solver.fallback == Fallback::WarmStart
                }
            },
        }
    }
}
