//! The reference gather against a plain dense mat-vec of the decoded matrix, for every format,
//! tile size, channel count and decode mode.

use radiosity_core::{DecodeMode, Format, Gather, GatherError, ReferenceGather, Rgb};
use radiosity_tests::fixtures::{FORMAT_CASES, exitance, sample_file};

#[test]
fn gather_equals_dense_matvec_of_the_decoded_matrix() {
    let n = 37;
    for (format, channels) in FORMAT_CASES {
        for max_tile in [8, 16, 8192] {
            for mode in [DecodeMode::D3d10, DecodeMode::Mesa] {
                let file = sample_file(n, channels, format, max_tile);
                let dense = file.matrix.decode_dense(mode);
                let x = exitance(n, 1);
                let mut y = vec![Rgb::ZERO; n];
                let mut g = ReferenceGather::new(file.matrix, mode);
                assert_eq!(g.patches(), n);
                g.gather(&x, &mut y).unwrap();
                for r in 0..n {
                    for k in 0..3 {
                        let mut want = 0f64;
                        for c in 0..n {
                            let v =
                                dense[(r * n + c) * channels + if channels == 1 { 0 } else { k }];
                            want += f64::from(v) * f64::from(x[c].channel(k));
                        }
                        // Both sums are f64 over the same f32 products; only the order differs
                        // (blocks then sparse vs. row order), and the result is rounded to f32
                        // once: 2 ulp of f32 plus n·ε64 of reordering covers it.
                        let got = f64::from(y[r].channel(k));
                        let tol = want.abs() * 2.0 * f64::from(f32::EPSILON) + 1e-30;
                        assert!(
                            (got - want).abs() <= tol,
                            "{format}×{channels} tile {max_tile} {mode:?}: row {r} ch {k}: {got} vs {want} (tol {tol})"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn grey_matrix_carries_coloured_light() {
    let n = 20;
    let file = sample_file(n, 1, Format::U8, 8);
    let mut g = ReferenceGather::new(file.matrix, DecodeMode::D3d10);
    let white: Vec<Rgb> = (0..n).map(|_| Rgb::ONE).collect();
    let red: Vec<Rgb> = (0..n).map(|_| Rgb::new(1.0, 0.0, 0.0)).collect();
    let (mut yw, mut yr) = (vec![Rgb::ZERO; n], vec![Rgb::ZERO; n]);
    g.gather(&white, &mut yw).unwrap();
    g.gather(&red, &mut yr).unwrap();
    for i in 0..n {
        assert!(
            yw[i].is_grey() && yw[i].r > 0.0,
            "white in, grey out: {:?}",
            yw[i]
        );
        assert_eq!(yr[i], Rgb::new(yw[i].r, 0.0, 0.0), "red in, red out");
    }
}

#[test]
fn gather_refuses_bad_arguments() {
    let n = 9;
    let mut g = ReferenceGather::new(sample_file(n, 3, Format::Bc1, 8).matrix, DecodeMode::D3d10);
    let mut y = vec![Rgb::ZERO; n];
    let short = vec![Rgb::ONE; n - 1];
    assert_eq!(
        g.gather(&short, &mut y),
        Err(GatherError::Length {
            expected: n,
            exitance: n - 1,
            irradiance: n
        })
    );
    let mut x = vec![Rgb::ONE; n];
    x[4].g = f32::NAN;
    assert_eq!(
        g.gather(&x, &mut y),
        Err(GatherError::NonFinite { index: 4 })
    );
    assert!(
        GatherError::NonFinite { index: 4 }
            .to_string()
            .contains("patch 4")
    );
}
