//! Repeated timing: one warm-up call, then the median of the runs.

use std::time::{Duration, Instant};

/// Median wall time of `runs` calls of `f` (≥ 1) after one untimed warm-up call.
pub fn median(runs: usize, mut f: impl FnMut()) -> Duration {
    let runs = runs.max(1);
    f();
    let mut t: Vec<Duration> = (0..runs)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed()
        })
        .collect();
    t.sort();
    t[runs / 2]
}

/// Runs for a median: enough that the timed calls take about `budget` in all (estimated from
/// one call of `first`), at least `min` and at most `max`.
pub fn runs_for(first: Duration, budget: Duration, min: usize, max: usize) -> usize {
    let per = first.as_secs_f64().max(1e-9);
    ((budget.as_secs_f64() / per) as usize).clamp(min, max)
}

/// Milliseconds.
pub fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_is_the_middle_run() {
        // Sleeps of 0, 1, …, 6 ms (after the warm-up): the median is the 3 ms one. Sleeping
        // never returns early, and 10 ms of scheduler slack keeps the upper bound safe.
        let mut k = 0u64;
        let d = median(7, || {
            std::thread::sleep(Duration::from_millis(k.saturating_sub(1)));
            k += 1;
        });
        assert!(
            d >= Duration::from_millis(3) && d < Duration::from_millis(13),
            "{d:?}"
        );
        assert_eq!(
            runs_for(Duration::from_millis(2), Duration::from_secs(1), 5, 100),
            100
        );
        assert_eq!(
            runs_for(Duration::from_millis(300), Duration::from_secs(1), 5, 100),
            5
        );
        assert_eq!(
            runs_for(Duration::from_millis(50), Duration::from_secs(1), 5, 100),
            20
        );
    }
}
