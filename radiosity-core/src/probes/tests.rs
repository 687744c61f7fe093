//! The probes' section bytes, gathers, factors and interpolation.

use super::*;
use crate::half::f16_is_finite;
use crate::{RadError, SectionKind};
use alloc::vec;

fn two() -> Probes<'static> {
    Probes {
        spacing: 1.0,
        positions: Cow::Owned(vec![[0.0; 3], [1.0, 0.0, 0.0]]),
        rows: Cow::Owned(vec![0, 2, 3]),
        weights: Cow::Owned(vec![
            ProbeWeight::new(0, [0.5; SH_COEFFICIENTS]),
            ProbeWeight::new(2, [0.25; SH_COEFFICIENTS]),
            ProbeWeight::new(1, [1.0; SH_COEFFICIENTS]),
        ]),
        factors: None,
    }
}

#[test]
fn bytes_round_trip_and_bad_values_are_named() {
    let p = two();
    p.validate(3).unwrap();
    let bytes = p.to_bytes();
    assert_eq!(Probes::from_bytes(&bytes).unwrap(), p);
    assert!(matches!(
        Probes::from_bytes(&bytes[..bytes.len() - 4]),
        Err(RadError::SectionLength {
            kind: SectionKind::Probes,
            ..
        })
    ));
    let reason = |q: Probes<'_>| match q.validate(3) {
        Err(RadError::Invalid { reason, .. }) => reason,
        other => panic!("{other:?}"),
    };
    let mut q = two();
    q.weights.to_mut()[1].patch = 3;
    assert_eq!(reason(q), "probe weight patch index out of range");
    let mut q = two();
    q.weights.to_mut()[1].patch = 0;
    assert_eq!(reason(q), "probe weight patches not increasing");
    let mut q = two();
    q.weights.to_mut()[2].sh_bits[4] = f32_to_f16(f32::NAN);
    assert_eq!(reason(q), "probe weight is NaN or infinite");
    let mut q = two();
    q.weights.to_mut()[0].reserved = 1;
    assert_eq!(reason(q), "probe weight reserved bytes are not zero");
    let mut q = two();
    q.positions.to_mut()[1][2] = f32::INFINITY;
    assert_eq!(reason(q), "probe position is NaN or infinite");
    let mut q = two();
    q.rows.to_mut()[1] = 4;
    assert_eq!(reason(q), "probe rows decrease");
    let mut q = two();
    q.spacing = 0.0;
    assert_eq!(reason(q), "probe spacing is not positive and finite");
}

/// Two probes over three patches as factors of rank 2.
fn factored() -> Probes<'static> {
    let h = |v: &[f32]| v.iter().map(|&x| f32_to_f16(x)).collect::<Vec<_>>();
    let coefficients: Vec<f32> = (0..2 * SH_COEFFICIENTS * 2)
        .map(|i| 0.25 * (i % 7) as f32 - 0.5)
        .collect();
    Probes {
        spacing: 1.0,
        positions: Cow::Owned(vec![[0.0; 3], [1.0, 0.0, 0.0]]),
        rows: Cow::Owned(vec![0; 3]),
        weights: Cow::Owned(vec![]),
        factors: Some(ProbeFactors {
            rank: 2,
            basis: Cow::Owned(h(&[0.5, -0.25, 1.0, 0.125, 0.75, -1.0])),
            coefficients: Cow::Owned(h(&coefficients)),
        }),
    }
}

#[test]
fn factored_bytes_round_trip_and_bad_factors_are_named() {
    let p = factored();
    p.validate(3).unwrap();
    let bytes = p.to_bytes();
    assert_eq!(Probes::from_bytes(&bytes).unwrap(), p);
    assert!(matches!(
        Probes::from_bytes(&bytes[..bytes.len() - 4]),
        Err(RadError::SectionLength { .. })
    ));
    // A basis over three patches does not fit a file of four.
    assert!(matches!(p.validate(4), Err(RadError::Count { .. })));
    let reason = |q: Probes<'_>| match q.validate(3) {
        Err(RadError::Invalid { reason, .. }) => reason,
        other => panic!("{other:?}"),
    };
    let mut q = factored();
    q.factors.as_mut().unwrap().coefficients.to_mut()[5] = f32_to_f16(f32::INFINITY);
    assert_eq!(reason(q), "probe coefficient is NaN or infinite");
    let mut q = factored();
    q.factors.as_mut().unwrap().basis.to_mut()[1] = f32_to_f16(f32::NAN);
    assert_eq!(reason(q), "probe basis weight is NaN or infinite");
    let mut q = factored();
    q.weights = Cow::Owned(vec![ProbeWeight::new(0, [1.0; SH_COEFFICIENTS])]);
    q.rows = Cow::Owned(vec![0, 1, 1]);
    assert_eq!(reason(q), "factored probes hold rows of weights too");
}

#[test]
fn factored_probes_gather_their_product() {
    let p = factored();
    let b = [
        Rgb::new(2.0, 0.5, 1.0),
        Rgb::splat(4.0),
        Rgb::new(8.0, 3.0, 0.25),
    ];
    let d = DecodedProbes::new(&p);
    assert_eq!(d.rank(), 2);
    let rows = p.to_rows();
    rows.validate(3).unwrap();
    let mut all = [[Rgb::ZERO; SH_COEFFICIENTS]; 2];
    d.gather(&b, &mut all);
    for i in 0..2 {
        let want = rows.gather_probe(i, &b);
        for (got, slow, want) in zip3(all[i], p.gather_probe(i, &b), want) {
            for (g, w) in [(got, want), (slow, want)] {
                // The rows round each product to binary16: half its relative step
                // (2⁻¹¹) of each of three terms, each at most 1.25·1·8 = 10.
                let tol = 3.0 * 10.0 * 2f32.powi(-11) + 1e-6;
                for (x, y) in [(g.r, w.r), (g.g, w.g), (g.b, w.b)] {
                    assert!((x - y).abs() <= tol, "{g:?} {w:?}");
                }
            }
        }
    }
}

fn zip3(
    a: [Rgb; SH_COEFFICIENTS],
    b: [Rgb; SH_COEFFICIENTS],
    c: [Rgb; SH_COEFFICIENTS],
) -> impl Iterator<Item = (Rgb, Rgb, Rgb)> {
    (0..SH_COEFFICIENTS).map(move |k| (a[k], b[k], c[k]))
}

#[test]
fn weights_round_to_half_precision() {
    let w = ProbeWeight::new(3, [0.1, -0.2, 1e-6, 0.0, 1.0, -1.0, 3.0e-3, 7.0, -0.5]);
    for (got, want) in w
        .sh()
        .iter()
        .zip([0.1f32, -0.2, 1e-6, 0.0, 1.0, -1.0, 3.0e-3, 7.0, -0.5])
    {
        // Half of binary16's relative step (2⁻¹¹), or its subnormal step 2⁻²⁴ near zero.
        assert!(
            (got - want).abs() <= want.abs() * 2f32.powi(-11) + 2f32.powi(-25),
            "{got} {want}"
        );
    }
    assert_eq!(core::mem::size_of::<ProbeWeight>(), 24);
}

#[test]
fn the_fast_conversion_is_exact_for_every_finite_half() {
    for h in 0..=u16::MAX {
        if f16_is_finite(h) {
            let got = finite_f16s_to_f32(&[h; SH_COEFFICIENTS])[0];
            assert_eq!(got.to_bits(), f16_to_f32(h).to_bits(), "{h:#06x}");
        }
    }
}

#[test]
fn decoded_probes_gather_the_same_bits() {
    let p = two();
    let d = DecodedProbes::new(&p);
    assert_eq!(d.len(), 2);
    let b = [
        Rgb::new(2.0, 0.5, 1.0),
        Rgb::splat(4.0),
        Rgb::new(8.0, 3.0, 0.25),
    ];
    for i in 0..2 {
        assert_eq!(d.gather_probe(i, &b), p.gather_probe(i, &b));
    }
}

#[test]
fn interpolation_is_trilinear_and_skips_hidden_probes() {
    // A unit lattice cell: eight probes at its corners.
    let positions: Vec<[f32; 3]> = (0..8)
        .map(|i| [(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32])
        .collect();
    let p = Probes {
        spacing: 1.0,
        positions: Cow::Owned(positions),
        rows: Cow::Owned(vec![0; 9]),
        weights: Cow::Owned(vec![]),
        factors: None,
    };
    let mut w = Vec::new();
    assert!(p.interpolation_weights([0.25, 0.5, 0.5], None, |_| true, &mut w));
    // Without a normal the weights are the trilinear ones: 0.75·0.5·0.5 at x = 0.
    assert_eq!(w.len(), 8);
    assert!(
        (w[0].1 - 0.1875).abs() < 1e-6 && (w[1].1 - 0.0625).abs() < 1e-6,
        "{w:?}"
    );
    // Probes at x = 1 hidden: the rest share everything.
    assert!(p.interpolation_weights([0.25, 0.5, 0.5], None, |i| i & 1 == 0, &mut w));
    assert_eq!(w.len(), 4);
    assert!(
        w.iter()
            .all(|&(i, v)| i & 1 == 0 && (v - 0.25).abs() < 1e-6),
        "{w:?}"
    );
    // A normal towards +x favours the probes at x = 1 over a plain trilinear blend.
    assert!(p.interpolation_weights([0.5, 0.5, 0.5], Some([1.0, 0.0, 0.0]), |_| true, &mut w));
    let ahead: f32 = w.iter().filter(|(i, _)| i & 1 == 1).map(|x| x.1).sum();
    assert!(ahead > 0.6, "{w:?}");
    // None in sight, even in a cell twice as wide.
    assert!(!p.interpolation_weights([0.5, 0.5, 0.5], None, |_| false, &mut w));
    assert!(w.is_empty());
}

#[test]
fn a_gather_sums_each_probes_row() {
    let p = two();
    let b = [Rgb::splat(2.0), Rgb::splat(4.0), Rgb::splat(8.0)];
    let mut out = [[Rgb::ZERO; SH_COEFFICIENTS]; 2];
    p.gather(&b, &mut out);
    assert_eq!(out[0][0], Rgb::splat(0.5 * 2.0 + 0.25 * 8.0));
    assert_eq!(out[1][8], Rgb::splat(4.0));
}

#[test]
fn a_uniform_sky_gives_pi_times_its_radiance_for_every_normal() {
    // Radiance L = 1 everywhere: only Y00 is non-zero, c00 = 4π·0.2821 = √(4π).
    let mut c = [Rgb::ZERO; SH_COEFFICIENTS];
    c[0] = Rgb::splat((4.0 * core::f32::consts::PI).sqrt());
    for n in [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]] {
        let e = sh_irradiance(&c, n);
        assert!((e.r - core::f32::consts::PI).abs() < 1e-5, "{e:?}");
    }
}
