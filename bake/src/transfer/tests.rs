//! The transfer against explicit sums and closed forms.

use super::*;

/// Two infinite parallel plates: F12 = F21 = 1.
fn plates() -> Dense {
    Dense::new(2, vec![0.0, 1.0, 1.0, 0.0])
}

#[test]
fn series_matches_the_explicit_sum() {
    // A 3-patch F with rows < 1, ρ = 0.5: compare doubling against b-by-b accumulation.
    let f = Dense::new(3, vec![0.0, 0.3, 0.2, 0.4, 0.0, 0.1, 0.25, 0.25, 0.0]);
    let rho = [[0.5; 3], [0.6; 3], [0.7; 3]];
    for k in 1..=9 {
        let (m, _) = transfer_matrix(&f, &rho, 1, BounceSpec::Fixed(k)).unwrap();
        let g = |i: usize, j: usize| f.get(i, j) * rho[j][0];
        let mut p = f.values.clone();
        let mut want = f.values.clone();
        for _ in 1..k {
            let mut next = vec![0.0; 9];
            for i in 0..3 {
                for j in 0..3 {
                    next[i * 3 + j] = (0..3).map(|l| g(i, l) * p[l * 3 + j]).sum();
                }
            }
            p = next;
            want.iter_mut().zip(&p).for_each(|(w, v)| *w += v);
        }
        for (a, b) in m.iter().zip(&want) {
            // f32 storage of an f64 result: relative 2^-24.
            assert!(
                (f64::from(*a) - b).abs() <= b.abs() * 1e-7 + 1e-12,
                "K = {k}: {a} vs {b}"
            );
        }
    }
}

#[test]
fn owned_f_gives_the_bits_of_a_borrowed_one_and_of_faers_own_lu() {
    // Five patches, rows below 1, three channels of different reflectance.
    let n = 5;
    let f = Dense::new(
        n,
        (0..n * n)
            .map(|e| {
                if e / n == e % n {
                    0.0
                } else {
                    0.05 + 0.03 * ((e * 7) % 5) as f64
                }
            })
            .collect(),
    );
    let rho: Vec<[f64; 3]> = (0..n).map(|i| [0.3 + 0.1 * i as f64, 0.5, 0.9]).collect();
    for spec in [
        BounceSpec::Infinite,
        BounceSpec::Fixed(3),
        BounceSpec::Fixed(2),
    ] {
        let (borrowed, _) = transfer_matrix(&f, &rho, 3, spec).unwrap();
        let calls = std::sync::Mutex::new(Vec::new());
        let progress = |done: usize, total: usize| calls.lock().unwrap().push((done, total));
        let (owned, _) = transfer(Cow::Owned(f.clone()), &rho, 3, spec, Some(&progress)).unwrap();
        assert_eq!(
            owned.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            borrowed.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            "{spec:?}"
        );
        let calls = calls.into_inner().unwrap();
        assert_eq!(calls.last(), Some(&(12, 12)), "{calls:?}");
        assert!(calls.windows(2).all(|w| w[0].0 < w[1].0), "{calls:?}");
    }
    // The in-place factorisation is faer's own partial-pivot LU, bit for bit.
    let (m, _) = transfer_matrix(&f, &rho, 3, BounceSpec::Infinite).unwrap();
    for c in 0..3 {
        let a = Mat::from_fn(n, n, |i, j| {
            let g = f.get(i, j) * rho[j][c];
            if i == j { 1.0 - g } else { 0.0 - g }
        });
        let mut x = Mat::from_fn(n, n, |i, j| f.get(i, j));
        faer::linalg::solvers::Solve::solve_in_place(&a.partial_piv_lu(), &mut x);
        for i in 0..n {
            for j in 0..n {
                assert_eq!(
                    m[(i * n + j) * 3 + c].to_bits(),
                    (x[(i, j)].max(0.0) as f32).to_bits(),
                    "channel {c} ({i}, {j})"
                );
            }
        }
    }
}

#[test]
fn tiled_copies_and_transposes_cover_every_entry() {
    // A side that is not a multiple of the tile.
    let n = TILE + 3;
    let f = Dense::new(n, (0..n * n).map(|e| e as f64).collect());
    let cm = column_major(&f, |_, _, v| v);
    let mut t = f.values.clone();
    transpose_in_place(&mut t, n);
    assert_eq!(cm, t);
    for i in 0..n {
        for j in 0..n {
            assert_eq!(cm[j * n + i], f.get(i, j));
        }
    }
    let plane = plane_of(MatRef::from_column_major_slice(&cm, n, n));
    assert!(
        plane
            .iter()
            .zip(&f.values)
            .all(|(p, v)| f64::from(*p) == *v)
    );
}

#[test]
fn infinite_bounces_on_two_plates_match_the_closed_form() {
    // B1 = (E1 + ρ1 E2)/(1 − ρ1ρ2): with E2 = 0, irradiance at plate 2 from unit first
    // exitance at plate 1 is M21 = 1/(1 − ρ1ρ2) (docs/reference/multibounce.md §3a).
    let (r1, r2) = (0.9, 0.99);
    let (m, rep) =
        transfer_matrix(&plates(), &[[r1; 3], [r2; 3]], 1, BounceSpec::Infinite).unwrap();
    let want = 1.0 / (1.0 - r1 * r2);
    assert!(
        (f64::from(m[2]) - want).abs() / want < 1e-6,
        "{} vs {want}",
        m[2]
    );
    assert_eq!((rep.bounces, rep.method), (Bounces::Infinite, "lu"));
}

#[test]
fn reflectance_one_in_a_closed_scene_is_divergent() {
    let r = transfer_matrix(&plates(), &[[0.5; 3], [0.5; 3]], 1, BounceSpec::Infinite);
    assert!(r.is_ok());
    let mut f = plates();
    f.values = vec![0.0, 1.0, 1.0, 0.0];
    // ρ = 1 is refused as input (must be < 1) …
    assert!(matches!(
        transfer_matrix(&f, &[[1.0; 3], [1.0; 3]], 1, BounceSpec::Infinite),
        Err(TransferError::Input(_))
    ));
    // … and a gain ≥ 1 from form factors that over-sum is divergent.
    let over = Dense::new(2, vec![0.0, 1.2, 1.2, 0.0]);
    assert!(matches!(
        transfer_matrix(&over, &[[0.9; 3], [0.9; 3]], 1, BounceSpec::Infinite),
        Err(TransferError::Divergent { .. })
    ));
}

#[test]
fn auto_uses_as_few_bounces_as_the_energy_needs() {
    let f = plates();
    let (_, rep) =
        transfer_matrix(&f, &[[1e-4; 3]; 2], 1, BounceSpec::Auto { tolerance: 1e-3 }).unwrap();
    assert_eq!(rep.bounces, Bounces::Finite(1));
    let (_, rep) =
        transfer_matrix(&f, &[[0.02; 3]; 2], 1, BounceSpec::Auto { tolerance: 1e-3 }).unwrap();
    assert_eq!(rep.bounces, Bounces::Finite(2));
    let (_, rep) =
        transfer_matrix(&f, &[[0.5; 3]; 2], 1, BounceSpec::Auto { tolerance: 1e-3 }).unwrap();
    assert_eq!(rep.bounces, Bounces::Infinite);
}
