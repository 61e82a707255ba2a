//! Rows that cannot bind anywhere over `[mpc.region]` (issue 33: "rows that can never become active
//! over the region are dropped where you can prove it").
//!
//! **The proof.** A row lower ≤ aᵀz ≤ upper holds for every plan within the bounds wherever its lower
//! side is at most the least aᵀz over the bounds' box and its upper side at least the most ([`reach`]:
//! interval arithmetic, widened by a millionth). Its sides are affine in θ = (x₀, the reference, u₋₁, d)
//! ([`Parameters`]), so over the region's box their extremes are the centre's value plus or minus the
//! slopes' magnitudes. A row whose sides stay beyond its reach over the whole box is redundant there:
//! dropping it changes neither the feasible set nor the optimum, so the method need not scan it.
//! Where the bounds themselves move with θ no row is dropped.
//!
//! **At run time.** The rows are not removed: they go last in their block ([`super::Prepared::with_slack_rows`]),
//! and each solve checks the proof on its own data before it starts (the kernel's `Block::limit`: each
//! side beyond its row's reach, a comparison or two a row; the bounds are the build's, which the emitted
//! module's constants are and the reference's `Prepared::offsets` checks). Where it holds the scan stops
//! short of them; where it fails (the state or the reference outside the
//! region, a relaxed recovery) the solve scans every row, as without the proof. Measured: hover drops 40
//! of its 120 rows of A (its positions' and velocities' bounds, which its input box cannot reach from
//! its region); paper-limits and the pendulum none (BENCHMARKS.md, "Two ways to cut the cold solve").
use super::exact::Parameters;
use super::prepared::reach;
use crate::certify::evidence::Region;
use crate::lower::problem::Problem;

/// The rows of A (indices) of `p`'s MPC QP that no plan within its bounds violates at any θ of
/// `region`'s box: the ones a solve need not scan there.
pub fn slack_rows(p: &Problem, region: &Region) -> Vec<usize> {
    let parameters = Parameters::of(p, region);
    let centre = parameters.centre();
    let at_centre = parameters.qp(p, &centre);
    let moved: Vec<_> = (0..parameters.len())
        .map(|j| {
            let mut theta = centre.clone();
            theta[j] = parameters.hi[j];
            parameters.qp(p, &theta)
        })
        .collect();
    let n = at_centre.z_min.len();
    let bounds_move = moved.iter().any(|q| {
        (0..n).any(|i| q.z_min[i] != at_centre.z_min[i] || q.z_max[i] != at_centre.z_max[i])
    });
    if bounds_move {
        return Vec::new();
    }
    let (z_min, z_max): (Vec<f64>, Vec<f64>) = (
        at_centre.z_min.iter().copied().collect(),
        at_centre.z_max.iter().copied().collect(),
    );
    (0..at_centre.A.nrows())
        .filter(|&r| {
            let (lower, upper) = (at_centre.lower[r], at_centre.upper[r]);
            if !(lower.is_finite() || upper.is_finite()) {
                return false;
            }
            let coefficients: Vec<(usize, f64)> = (0..n)
                .filter(|&j| at_centre.A[(r, j)] != 0.0)
                .map(|j| (j, at_centre.A[(r, j)]))
                .collect();
            if coefficients.is_empty() {
                return false;
            }
            let (least, most) = reach(&coefficients, &z_min, &z_max);
            // The sides' extremes over the box: θ's half-widths are the moves to `hi`.
            let swing = |side: &dyn Fn(&crate::solver::constrained::InequalityQp) -> f64| {
                moved
                    .iter()
                    .map(|q| (side(q) - side(&at_centre)).abs())
                    .sum::<f64>()
            };
            let lower_most = lower + swing(&|q| q.lower[r]);
            let upper_least = upper - swing(&|q| q.upper[r]);
            let lower_holds = lower == f64::NEG_INFINITY || lower_most <= least;
            let upper_holds = upper == f64::INFINITY || upper_least >= most;
            lower_holds && upper_holds
        })
        .collect()
}
