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

/// Median wall time per call of several methods timed *in turns*: `rounds` rounds, each
/// calling method `i` (`call(i)`) about `runs[i] / rounds` times in a row (`runs[i]` ≥ 1 in all),
/// so that every method's calls spread over the whole measurement. On a shared machine a
/// burst of outside load then slows every method alike instead of the one timed during it,
/// and ratios between methods hold. Every method gets one untimed warm-up call first.
pub fn interleaved_medians(
    runs: &[usize],
    rounds: usize,
    mut call: impl FnMut(usize),
) -> Vec<Duration> {
    let rounds = rounds.max(1);
    let runs: Vec<usize> = runs.iter().map(|&r| r.max(1)).collect();
    let mut times: Vec<Vec<Duration>> = runs.iter().map(|_| Vec::new()).collect();
    for i in 0..runs.len() {
        call(i);
    }
    for round in 0..rounds {
        for (i, t) in times.iter_mut().enumerate() {
            // This round's share of the method's runs: the rounds together make `runs[i]`,
            // spread evenly (a method with fewer runs than rounds skips some rounds).
            let share = runs[i] * (round + 1) / rounds - runs[i] * round / rounds;
            for _ in 0..share {
                let s = Instant::now();
                call(i);
                t.push(s.elapsed());
            }
        }
    }
    times
        .into_iter()
        .map(|mut t| {
            t.sort();
            t[t.len() / 2]
        })
        .collect()
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

    /// Every method is called `runs[i]` times (plus one warm-up) whether the rounds divide
    /// the runs or not, in turns; each median is that method's middle call.
    #[test]
    fn interleaved_medians_take_turns() {
        let mut order = Vec::new();
        let runs = [5, 1, 8];
        let d = interleaved_medians(&runs, 4, |i| {
            order.push(i);
            // Method 2 sleeps 2 ms, the others not at all.
            if i == 2 {
                std::thread::sleep(Duration::from_millis(2));
            }
        });
        let calls = |m: usize| order.iter().filter(|&&i| i == m).count();
        // Warm-up + shares over four rounds: 5 → 1+1+1+2, 1 → 0+0+0+1, 8 → 2 each.
        assert_eq!([calls(0), calls(1), calls(2)], [1 + 5, 1 + 1, 1 + 8]);
        // Warm-ups first, then round one in turn (shares 1, 0, 2), then round two begins.
        assert_eq!(&order[..7], &[0, 1, 2, 0, 2, 2, 0]);
        // Method 1's one timed call is in the last round.
        assert_eq!(order.iter().rposition(|&i| i == 1), Some(order.len() - 3));
        assert!(d[2] >= Duration::from_millis(2), "{d:?}");
        assert!(d[0] < Duration::from_millis(2), "{d:?}");
    }

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
