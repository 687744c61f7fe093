//! The report's arithmetic: the Pareto front of (time, error) points and the fitted exponent
//! of a power law.

/// Indices of the Pareto-optimal points when both coordinates are to be minimised: no other
/// point is at least as good in both and better in one. Sorted by the first coordinate.
/// Points with a non-finite coordinate are never on the front.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

/// Least-squares fit of `y = c·x^k` on log-log axes: `(k, c)`. `None` with fewer than two
/// distinct positive `x`, or any non-positive value.
pub fn power_fit(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    if points.iter().any(|(x, y)| !(*x > 0.0 && *y > 0.0)) {
        return None;
    }
    let n = points.len() as f64;
    let (lx, ly): (Vec<f64>, Vec<f64>) = points.iter().map(|(x, y)| (x.ln(), y.ln())).unzip();
    let mx = lx.iter().sum::<f64>() / n;
    let my = ly.iter().sum::<f64>() / n;
    let sxx: f64 = lx.iter().map(|x| (x - mx).powi(2)).sum();
    if !(sxx > 1e-12) {
        return None;
    }
    let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    let k = sxy / sxx;
    Some((k, (my - k * mx).exp()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_the_non_dominated() {
        // (time, error): 0 and 2 and 4 trade off; 1 is dominated by 0; 3 by 2; 5 is NaN.
        let p = [
            (1.0, 0.5),
            (2.0, 0.6),
            (3.0, 0.1),
            (3.5, 0.1),
            (10.0, 0.01),
            (0.5, f64::NAN),
        ];
        assert_eq!(pareto_front(&p), vec![0, 2, 4]);
        // Equal times: only the lower error survives.
        assert_eq!(pareto_front(&[(1.0, 0.3), (1.0, 0.2)]), vec![1]);
        assert!(pareto_front(&[]).is_empty());
    }

    #[test]
    fn power_fit_recovers_an_exact_power_law() {
        // y = 3·x^2.5 exactly: the fit is exact up to rounding (1e-9 relative).
        let p: Vec<(f64, f64)> = [256.0, 512.0, 1024.0, 4096.0]
            .iter()
            .map(|&x: &f64| (x, 3.0 * x.powf(2.5)))
            .collect();
        let (k, c) = power_fit(&p).unwrap();
        assert!((k - 2.5).abs() < 1e-9, "k = {k}");
        assert!((c - 3.0).abs() < 1e-6, "c = {c}");
        assert_eq!(power_fit(&[(1.0, 1.0)]), None);
        assert_eq!(power_fit(&[(1.0, 1.0), (2.0, 0.0)]), None);
    }
}
