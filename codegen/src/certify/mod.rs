//! Certifying a lowered problem: what the compiler proves and counts ([`certificate`]), the sampled
//! evidence over `[mpc.region]` ([`sampling`], [`evidence`]), the coordinate range ([`coordinates`]),
//! and what a build may spend ([`budget`], run on every core by [`parallel`]).

pub mod budget;
pub mod certificate;
pub mod coordinates;
pub mod evidence;
pub mod parallel;
pub mod sampling;
