//! Patch orders and their compression error, on a real transfer matrix: the
//! Cornell box (CornellBox-Original.obj) simplified to about 300 patches, form factors with
//! ray-cast visibility, all bounces (LU), three channels.

use radiosity_bake::encode::{EncodeParams, encode_dense};
use radiosity_bake::order::{
    self, Candidate, DenseMatrix, ErrorMeter, ErrorSampling, OrderKind, OrderParams,
};
use radiosity_bake::rng::SplitMix64;
use radiosity_core::{DecodeMode, Format, Patch, Rgb};
use std::sync::OnceLock;

/// The Cornell box's patches and its transfer matrix M (3 channels), built once per run.
struct Baked {
    patches: Vec<Patch>,
    m: Vec<f32>,
}

impl Baked {
    fn n(&self) -> usize {
        self.patches.len()
    }

    fn dense(&self) -> DenseMatrix<'_> {
        DenseMatrix::new(self.n(), 3, &self.m)
    }
}

fn cornell() -> &'static Baked {
    static BAKED: OnceLock<Baked> = OnceLock::new();
    BAKED.get_or_init(|| {
        let (patches, m) = radiosity_tests::fixtures::cornell_transfer(300);
        Baked { patches, m }
    })
}

fn bc1() -> EncodeParams {
    EncodeParams::for_format(Format::Bc1)
}

fn bc4() -> EncodeParams {
    EncodeParams::for_format(Format::Bc4)
}

fn exact_errors(b: &Baked, encode: EncodeParams) -> Vec<Candidate> {
    order::evaluate(
        &OrderKind::CONCRETE,
        &b.patches,
        b.dense(),
        &OrderParams::exact(encode),
    )
    .expect("evaluates")
}

fn error_of(c: &[Candidate], kind: OrderKind) -> f64 {
    c.iter()
        .find(|c| c.kind == kind)
        .expect("measured")
        .error
        .relative
}

#[test]
fn every_order_is_a_deterministic_permutation() {
    let b = cornell();
    assert!(
        (250..=350).contains(&b.n()),
        "about 300 patches, got {}",
        b.n()
    );
    let params = OrderParams::for_encode(bc1());
    for kind in OrderKind::ALL {
        let p = order::permutation(kind, &b.patches, b.dense(), &params).unwrap();
        assert!(order::is_permutation(&p, b.n()), "{}", kind.name());
        let again = order::permutation(kind, &b.patches, b.dense(), &params).unwrap();
        assert_eq!(p, again, "{} is not deterministic", kind.name());
    }
    let none = order::permutation(OrderKind::None, &b.patches, b.dense(), &params).unwrap();
    assert_eq!(none, order::identity(b.n()));
}

/// The meter's block-by-block path (no copy, per-tile scales from the full matrix) must give
/// the error of the real thing: permute, `encode_dense`, `decode_dense`. Both sum the same
/// f64 squared differences of the same f32 values, only in another order, so they agree to
/// f64 rounding (1e-9 relative is 10⁶ ulps of slack and still catches any single wrong block,
/// which changes the sum by ≥ 1e-6 relative at n = 300).
#[test]
fn full_sample_equals_encode_then_decode() {
    let b = cornell();
    let perm = order::random_order(b.n(), 11);
    for encode in [
        bc1(),
        bc4(),
        EncodeParams::for_format(Format::U8),
        EncodeParams::for_format(Format::F16),
        // Several tiles: scales then depend on the order and are recomputed per order.
        EncodeParams {
            max_tile: 64,
            ..bc1()
        },
    ] {
        let meter = ErrorMeter::new(b.dense(), &encode).unwrap();
        let oracle = meter.exact_full(Some(&perm)).unwrap();
        let blockwise = meter.measure(Some(&perm), ErrorSampling::Exact);
        assert!(blockwise.exact);
        let diff = (blockwise.squared_error - oracle.squared_error).abs() / oracle.squared_error;
        assert!(
            diff < 1e-9,
            "{:?} tile {}: blockwise {:e} vs encode+decode {:e}, relative difference {diff:e} > 1e-9",
            encode.format,
            encode.max_tile,
            blockwise.squared_error,
            oracle.squared_error
        );
        assert!(oracle.relative > 0.0);
        // The texture error in codes: the same codes of the same values (the oracle adds the
        // sparse residual back, which restores the exact value or one within an ulp of it: at
        // most a code apart, and only exactly on a rounding boundary), so equal to f64
        // rounding; `None` exactly for the float formats.
        match (oracle.code_rms, blockwise.code_rms) {
            (Some(a), Some(b)) => {
                assert!(encode.format.is_log());
                // u8 stores the codes themselves: no code error; the BC formats lose some.
                assert_eq!(
                    a > 0.0,
                    encode.format != Format::U8,
                    "{:?}: code RMS {a}",
                    encode.format
                );
                assert!(
                    (a - b).abs() <= 1e-9 * a,
                    "{:?} tile {}: code RMS blockwise {b} vs encode+decode {a}",
                    encode.format,
                    encode.max_tile
                );
            }
            (None, None) => assert!(!encode.format.is_log()),
            other => panic!("{:?}: code RMS {other:?}", encode.format),
        }
    }
}

/// Also check the oracle itself against a hand-written Frobenius norm of a permuted copy, so
/// that the meter's view of `P M Pᵀ` and `order::permute` agree.
#[test]
fn oracle_is_the_frobenius_error_of_the_permuted_matrix() {
    let b = cornell();
    let perm = order::random_order(b.n(), 5);
    let permuted = order::permute(&b.m, b.n(), 3, &perm);
    let encoded = encode_dense(b.n(), 3, &permuted, &bc1()).unwrap();
    let decoded = encoded.decode_dense(DecodeMode::D3d10);
    let sq = |a: &[f32], b: &[f32]| -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (f64::from(*x) - f64::from(*y)).powi(2))
            .sum()
    };
    let zeros = vec![0f32; permuted.len()];
    let want = (sq(&decoded, &permuted) / sq(&permuted, &zeros)).sqrt();
    let got = ErrorMeter::new(b.dense(), &bc1())
        .unwrap()
        .exact_full(Some(&perm))
        .unwrap()
        .relative;
    assert!(
        (got - want).abs() <= 1e-12 * want,
        "meter {got} vs by hand {want}"
    );
}

/// The sampled estimate against the exact error. At n = 300 there are 5 625 block positions;
/// a 20% sample encodes about 1 100. Tolerances:
/// - each estimate within 4 of its own reported standard errors of the truth (a wrong variance
///   formula or a biased design fails this; a correct one fails it with probability < 1e-4);
/// - the mean of 24 seeds within 3 standard errors of the mean (bias check: the squared-error
///   estimate is unbiased by construction, Horvitz–Thompson);
/// - the reported standard error itself small (≤ 10% of the squared error, i.e. ≤ 5% on the
///   relative Frobenius error): the norm-proportional design must actually help. Measured
///   ≈ 3–5% at this size.
#[test]
fn sampled_estimate_is_unbiased_and_honest_about_its_spread() {
    let b = cornell();
    for (encode, kind) in [(bc1(), OrderKind::Random), (bc4(), OrderKind::Spatial)] {
        let params = OrderParams::for_encode(encode);
        let perm = order::permutation(kind, &b.patches, b.dense(), &params).unwrap();
        let meter = ErrorMeter::new(b.dense(), &encode).unwrap();
        let truth = meter
            .measure(Some(&perm), ErrorSampling::Exact)
            .squared_error;
        let seeds = 24;
        let mut sum = 0.0;
        let mut var_sum = 0.0;
        for seed in 0..seeds {
            let e = meter.measure(
                Some(&perm),
                ErrorSampling::Blocks {
                    fraction: 0.2,
                    seed,
                },
            );
            assert!(!e.exact && e.blocks_encoded < e.blocks_nonzero / 3);
            let sd = e.relative_std * e.squared_error;
            assert!(
                (e.squared_error - truth).abs() <= 4.0 * sd,
                "{:?}/{}: seed {seed}: estimate {:e}, truth {truth:e}, 4σ = {:e}",
                encode.format,
                kind.name(),
                e.squared_error,
                4.0 * sd
            );
            assert!(
                e.relative_std <= 0.10,
                "{:?}/{}: relative standard error {} > 0.10",
                encode.format,
                kind.name(),
                e.relative_std
            );
            sum += e.squared_error;
            var_sum += sd * sd;
        }
        let mean = sum / seeds as f64;
        let sd_mean = var_sum.sqrt() / seeds as f64;
        assert!(
            (mean - truth).abs() <= 3.0 * sd_mean,
            "{:?}/{}: mean of {seeds} estimates {mean:e}, truth {truth:e}, 3σ of the mean {:e}",
            encode.format,
            kind.name(),
            3.0 * sd_mean
        );
    }
}

/// The target is best ≥ 3× better than `random` with BC1 and never worse than `none`.
/// The second holds by construction with exact errors and is asserted. The first is NOT met
/// on the Cornell box: the ratio grows with n (measured random/best, BC1: 1.44 at n = 286,
/// 1.82 at 1018, 2.14 at 1938; BC4: 1.57, 2.21, 2.67), because BC1's 5:6:5 endpoints leave an
/// order-independent floor of ±4 codes (±11% in value at s = ln 1000) in every block. The
/// bench (`benches/benches/order.rs`) tracks the target at 1024+ patches; here, at n = 286,
/// the ratios are regression guards set about 10% under the measured values (the inputs are
/// deterministic; the margin absorbs changes in simplification and form factors): best vs
/// random ≥ 1.2 (BC1, measured 1.29; 1.32 were shadow rays not to end on the part of a
/// target in front of the source, 1.44 with a code-space encoder) and ≥ 1.4 (BC4,
/// measured 1.55); `paper` and `spatial` each ≥ 1.1× better than random (measured ≥ 1.14). In
/// the paper's own measure, the RMS error of the log texture in codes, the gain is larger (a
/// code wrong on a tiny entry counts as much as on a large one, and `random` gets many
/// wrong): measured 3.25× (BC1) and 3.48× (BC4) at n = 286, 8.8× for BC1 at n = 4106; guarded
/// at 2.7× and 3.2×. At this size BC4's code ratio moves with F's small entries: 3.31× with
/// every shadow ray of a quadrature leaf starting at one point, 2.91× with uniform points of
/// the leaf, 2.67× with its stratified points (BC1: 3.36×), while the
/// Frobenius ratios stayed put (BC4 1.47–1.52) and at n = 4098 both formats' code ratios are
/// 8.1×; BC4 is guarded at 2.4×.
#[test]
fn best_beats_random_and_never_loses_to_none() {
    let b = cornell();
    for (encode, want_best, want_codes) in [(bc1(), 1.2, 2.7), (bc4(), 1.4, 2.4)] {
        let c = exact_errors(b, encode);
        let best = &c[order::choose_best(&c)];
        let (random, none) = (
            error_of(&c, OrderKind::Random),
            error_of(&c, OrderKind::None),
        );
        let report: Vec<String> = c
            .iter()
            .map(|c| {
                let codes = c.error.code_rms.expect("a log format");
                format!(
                    "{} {:.5} ({codes:.2} codes)",
                    c.kind.name(),
                    c.error.relative
                )
            })
            .collect();
        eprintln!("{:?} n = {}: {report:?}", encode.format, b.n());
        assert!(
            best.error.relative <= none,
            "{:?}: best ({}) {} worse than none {}; {report:?}",
            encode.format,
            best.kind.name(),
            best.error.relative,
            none
        );
        assert!(
            random / best.error.relative >= want_best,
            "{:?}: random/best = {} < {want_best}; {report:?}",
            encode.format,
            random / best.error.relative
        );
        let codes = |c: &Candidate| c.error.code_rms.expect("a log format");
        let random_codes = codes(c.iter().find(|c| c.kind == OrderKind::Random).unwrap());
        assert!(
            random_codes / codes(best) >= want_codes,
            "{:?}: texture code RMS random/best = {} < {want_codes}; {report:?}",
            encode.format,
            random_codes / codes(best)
        );
        for kind in [OrderKind::Paper, OrderKind::Spatial] {
            let e = error_of(&c, kind);
            assert!(
                random / e >= 1.1,
                "{:?}: random/{} = {} < 1.1; {report:?}",
                encode.format,
                kind.name(),
                random / e
            );
        }
    }
}

/// `best` through [`order::permutation`] returns the permutation of the candidate it measured
/// smallest, or `none` when the others are not clearly better.
#[test]
fn best_returns_the_chosen_candidates_permutation() {
    let b = cornell();
    let params = OrderParams::for_encode(bc1());
    let c = order::evaluate(&OrderKind::CANDIDATES, &b.patches, b.dense(), &params).unwrap();
    let want = &c[order::choose_best(&c)];
    let got = order::permutation(OrderKind::Best, &b.patches, b.dense(), &params).unwrap();
    assert_eq!(got, want.perm, "best chose {}", want.kind.name());
}

/// `choose_best` keeps `none` unless another order is better by more than the noise.
#[test]
fn choose_best_needs_a_clear_win_over_none() {
    let estimate = |sq: f64, rel_std: f64| order::ErrorEstimate {
        relative: sq.sqrt(),
        squared_error: sq,
        squared_norm: 1.0,
        relative_std: rel_std,
        blocks_encoded: 10,
        blocks_nonzero: 100,
        exact: rel_std == 0.0,
        code_rms: None,
    };
    let cand = |kind, sq, sd| Candidate {
        kind,
        perm: vec![],
        error: estimate(sq, sd),
        order_ms: 0.0,
        measure_ms: 0.0,
    };
    // Within noise: 0.95 ± 5% against 1.0 ± 5% is not a clear win.
    let c = [
        cand(OrderKind::None, 1.0, 0.05),
        cand(OrderKind::Spatial, 0.95, 0.05),
    ];
    assert_eq!(c[order::choose_best(&c)].kind, OrderKind::None);
    // Clear: 0.5 ± 5%.
    let c = [
        cand(OrderKind::None, 1.0, 0.05),
        cand(OrderKind::Spatial, 0.5, 0.05),
    ];
    assert_eq!(c[order::choose_best(&c)].kind, OrderKind::Spatial);
    // Exact: any improvement counts, and a tie keeps none.
    let c = [
        cand(OrderKind::Paper, 0.999, 0.0),
        cand(OrderKind::None, 1.0, 0.0),
    ];
    assert_eq!(c[order::choose_best(&c)].kind, OrderKind::Paper);
    let c = [
        cand(OrderKind::Spatial, 1.0, 0.0),
        cand(OrderKind::None, 1.0, 0.0),
    ];
    assert_eq!(c[order::choose_best(&c)].kind, OrderKind::None);
}

/// A matrix with a known best order: 16 clusters of 4 identical patches (identical rows and
/// columns up to tiny noise), numbered in a shuffled order. The paper's neighbour sort must
/// find the clusters again: every aligned group of four is then one cluster, each BC block is
/// nearly constant, and the error drops far below the shuffled order's.
#[test]
fn paper_order_recovers_hidden_clusters() {
    let (clusters, size) = (16, 4);
    let n = clusters * size;
    let mut rng = SplitMix64(77);
    let level: Vec<f32> = (0..clusters * clusters)
        .map(|_| (-6.0 * rng.next_f32()).exp())
        .collect();
    let hidden = order::random_order(n, 3); // patch i belongs to cluster hidden[i] / size
    let cluster = |i: usize| hidden[i] as usize / size;
    let mut m = vec![0f32; n * n];
    for i in 0..n {
        for j in 0..n {
            m[i * n + j] =
                level[cluster(i) * clusters + cluster(j)] * (1.0 + 1e-3 * rng.next_f32());
        }
    }
    let patches = vec![
        Patch {
            centre: [0.0; 3],
            area: 1.0,
            normal: [0.0, 0.0, 1.0],
            object: 0,
            reflectance: Rgb::splat(0.5),
            emission: Rgb::ZERO,
        };
        n
    ];
    let encode = EncodeParams {
        sparse_fraction: 0.0,
        ..bc4()
    };
    let params = OrderParams::exact(encode);
    let dense = DenseMatrix::new(n, 1, &m);
    let perm = order::permutation(OrderKind::Paper, &patches, dense, &params).unwrap();
    for group in perm.chunks(size) {
        let c0 = cluster(group[0] as usize);
        assert!(
            group.iter().all(|&p| cluster(p as usize) == c0),
            "a group of four mixes clusters: {:?}",
            group
                .iter()
                .map(|&p| cluster(p as usize))
                .collect::<Vec<_>>()
        );
    }
    let meter = ErrorMeter::new(dense, &encode).unwrap();
    let sorted = meter.measure(Some(&perm), ErrorSampling::Exact).relative;
    let shuffled = meter.measure(None, ErrorSampling::Exact).relative;
    // Sorted blocks are constant up to 0.1% noise: only the log quantiser's half step
    // (e^(s/510) − 1 ≈ 1.4%) remains. Shuffled blocks mix levels spread over e^6.
    assert!(sorted < 0.02, "sorted error {sorted}");
    assert!(
        shuffled > 5.0 * sorted,
        "shuffled {shuffled} vs sorted {sorted}"
    );
}

/// Tiny and ragged sizes: n = 1, 2, 5 (partial blocks) must work for every order and the
/// meter's exact path must still equal encode + decode.
#[test]
fn tiny_matrices() {
    for n in [1usize, 2, 5, 7] {
        let mut rng = SplitMix64(n as u64);
        let m: Vec<f32> = (0..n * n * 3).map(|_| rng.next_f32() + 0.01).collect();
        let patches: Vec<Patch> = (0..n)
            .map(|i| Patch {
                centre: [i as f32, (i % 2) as f32, 0.0],
                area: 1.0,
                normal: if i % 3 == 0 {
                    [0.0, 1.0, 0.0]
                } else {
                    [1.0, 0.0, 0.0]
                },
                object: 0,
                reflectance: Rgb::splat(0.5),
                emission: Rgb::ZERO,
            })
            .collect();
        let dense = DenseMatrix::new(n, 3, &m);
        let params = OrderParams::exact(bc1());
        for kind in OrderKind::ALL {
            let p = order::permutation(kind, &patches, dense, &params).unwrap();
            assert!(order::is_permutation(&p, n), "n = {n}, {}", kind.name());
            let meter = ErrorMeter::new(dense, &bc1()).unwrap();
            let a = meter.measure(Some(&p), ErrorSampling::Exact).squared_error;
            let b = meter.exact_full(Some(&p)).unwrap().squared_error;
            assert!(
                (a - b).abs() <= 1e-9 * b.max(1e-30),
                "n = {n}, {}: {a} vs {b}",
                kind.name()
            );
        }
    }
}

/// Bad input is refused as `encode_dense` refuses it, not by a panic deep inside.
#[test]
fn meter_refuses_what_the_encoder_refuses() {
    let m = vec![0.5f32, -1.0, 0.25, 0.0];
    assert!(ErrorMeter::new(DenseMatrix::new(2, 1, &m), &bc4()).is_err());
    let ok = vec![0.5f32; 4 * 3];
    let bad_shift = EncodeParams {
        shift: 0.0,
        ..bc1()
    };
    assert!(ErrorMeter::new(DenseMatrix::new(2, 3, &ok), &bad_shift).is_err());
}
