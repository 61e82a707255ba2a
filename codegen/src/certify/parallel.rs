//! The build-time work that is independent case by case (a certificate's cold cases and warm
//! sequences, ADMM's ρ trials) on every core, with results that do not depend on the threads.

use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// `work` on every item in parallel (rayon), and the results in the items' order up to and including
/// the first that `failed` says ends the run (a sequential loop would have stopped there). Items after
/// a failure already seen are skipped; every item before the first failure is computed, so what is
/// returned is what the sequential loop would have computed, whatever the threads did.
pub fn until_failure<I: Sync, R: Send>(
    items: &[I],
    work: impl Fn(&I) -> R + Sync,
    failed: impl Fn(&R) -> bool + Sync,
) -> Vec<R> {
    let first_failure = AtomicUsize::new(usize::MAX);
    let results: Vec<Option<R>> = items
        .par_iter()
        .enumerate()
        .map(|(i, item)| {
            if i > first_failure.load(Ordering::Relaxed) {
                return None;
            }
            let r = work(item);
            if failed(&r) {
                first_failure.fetch_min(i, Ordering::Relaxed);
            }
            Some(r)
        })
        .collect();
    let mut ordered = Vec::new();
    for r in results.into_iter().map_while(|r| r) {
        let stop = failed(&r);
        ordered.push(r);
        if stop {
            break;
        }
    }
    ordered
}

#[cfg(test)]
mod tests {
    use super::until_failure;

    #[test]
    fn results_come_in_order_up_to_the_first_failure() {
        let items: Vec<usize> = (0..200).collect();
        let all = until_failure(&items, |&i| i * i, |_| false);
        assert_eq!(all, items.iter().map(|i| i * i).collect::<Vec<_>>());
        // Failures at 37 and at every multiple of 50: the run ends at 37, as a loop would.
        let cut = until_failure(&items, |&i| i, |&i| i == 37 || (i > 0 && i % 50 == 0));
        assert_eq!(cut, (0..=37).collect::<Vec<_>>());
        assert!(until_failure(&[] as &[usize], |&i| i, |_| true).is_empty());
    }
}
