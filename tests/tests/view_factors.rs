//! Object-to-object view factors (`radiosity_bake::check::view_factors`) against Howell's catalogue
//! (`tests/data/viewfactors.csv`), sum rules, scale invariance, and a brute-force Monte-Carlo
//! oracle for occluded scenes. Every scene goes through the OBJ loader, most in general position
//! (rotated about a skew axis, scaled, moved off the origin).

mod bake_support;

use bake_support::*;
use glam::{DVec3, dvec3};
use radiosity_bake::check::view_factors::{ViewFactorParams, ViewFactors, view_factors};
use radiosity_bake::scene::Scene;

/// The accuracy target for unoccluded configurations: 0.5% relative.
const TARGET: f64 = 5e-3;

fn vf(scene: &Scene) -> ViewFactors {
    let params = match std::env::var("VF_PRESET").as_deref() {
        Ok("hq") => ViewFactorParams::high_quality(),
        Ok("fast") => ViewFactorParams::fast(),
        _ => ViewFactorParams::default(),
    };
    view_factors(scene, &params, None)
}

fn f(v: &ViewFactors, a: &str, b: &str) -> f64 {
    v.matrix[object(&v.objects, a)][object(&v.objects, b)]
}

fn parallel(a: f64, b: f64, c: f64) -> Vec<Obj> {
    vec![
        Obj::new("one", vec![rect_z(0.0, a, 0.0, b, 0.0, true)]),
        Obj::new("two", vec![rect_z(0.0, a, 0.0, b, c, false)]),
    ]
}

fn perpendicular(w: f64, h: f64, l: f64) -> Vec<Obj> {
    let wall = facing(
        vec![
            dvec3(0.0, 0.0, 0.0),
            dvec3(0.0, l, 0.0),
            dvec3(0.0, l, h),
            dvec3(0.0, 0.0, h),
        ],
        DVec3::X,
    );
    vec![
        Obj::new("floor", vec![rect_z(0.0, w, 0.0, l, 0.0, true)]),
        Obj::new("wall", vec![wall]),
    ]
}

#[test]
fn parallel_rectangles_c11() {
    let dir = tempfile::tempdir().unwrap();
    let mut worst: f64 = 0.0;
    for r in references("C-11") {
        let [a, b, c] = r.p;
        for (k, place) in [Placement::IDENTITY, Placement::general(0.37)]
            .into_iter()
            .enumerate()
        {
            let scene = load(
                dir.path(),
                &format!("c11-{}-{k}", r.id),
                &parallel(a, b, c),
                place,
            );
            let v = vf(&scene);
            let got = f(&v, "one", "two");
            worst = worst.max((got - r.exact).abs() / r.exact);
            assert_rel(
                &format!("C-11 row {} ({a}, {b}, {c}), placement {k}", r.id),
                got,
                r.exact,
                TARGET,
            );
            assert_rel("symmetry", f(&v, "two", "one"), r.exact, TARGET);
        }
    }
    println!("C-11 worst relative error {worst:.2e}");
}

#[test]
fn perpendicular_rectangles_sharing_an_edge_c14() {
    let dir = tempfile::tempdir().unwrap();
    let mut worst: f64 = 0.0;
    for r in references("C-14") {
        let [w, h, l] = r.p;
        for (k, place) in [Placement::IDENTITY, Placement::general(2.9)]
            .into_iter()
            .enumerate()
        {
            let scene = load(
                dir.path(),
                &format!("c14-{}-{k}", r.id),
                &perpendicular(w, h, l),
                place,
            );
            let v = vf(&scene);
            let got = f(&v, "floor", "wall");
            let back = f(&v, "wall", "floor");
            let recip = r.reciprocal.expect("C-14 rows carry F_reciprocal");
            worst = worst
                .max((got - r.exact).abs() / r.exact)
                .max((back - recip).abs() / recip);
            assert_rel(
                &format!("C-14 row {} ({w}, {h}, {l}), placement {k}", r.id),
                got,
                r.exact,
                TARGET,
            );
            assert_rel(
                &format!("C-14 row {} reciprocal", r.id),
                back,
                recip,
                TARGET,
            );
        }
    }
    println!("C-14 worst relative error {worst:.2e}");
}

/// Discs as 96-segment fans whose radius is scaled so the polygon has the disc's area: the
/// polygon-versus-circle shape error is then of order (2π/96)²/6·(its effect on F) < 1e-3,
/// inside the 0.5% target.
#[test]
fn coaxial_discs_c41() {
    let dir = tempfile::tempdir().unwrap();
    let n = 96;
    let area_fix =
        (std::f64::consts::PI / (0.5 * n as f64 * (std::f64::consts::TAU / n as f64).sin())).sqrt();
    let mut worst: f64 = 0.0;
    for r in references("C-41") {
        let [r1, r2, a] = r.p;
        let objs = vec![
            Obj::new("one", disc(r1 * area_fix, 0.0, n, true)),
            Obj::new("two", disc(r2 * area_fix, a, n, false)),
        ];
        let scene = load(
            dir.path(),
            &format!("c41-{}", r.id),
            &objs,
            Placement::general(1.0),
        );
        let v = vf(&scene);
        let got = f(&v, "one", "two");
        worst = worst.max((got - r.exact).abs() / r.exact);
        assert_rel(
            &format!("C-41 row {} ({r1}, {r2}, {a})", r.id),
            got,
            r.exact,
            TARGET,
        );
        assert_rel(
            "C-41 reciprocal",
            f(&v, "two", "one"),
            r.reciprocal.unwrap(),
            TARGET,
        );
    }
    println!("C-41 worst relative error {worst:.2e}");
}

/// Scaling the scene by 1e-3 or 1e3 changes nothing: every tolerance in the bake is relative to
/// the scene's size. 1e-4 is the bound; the computation is the same up to f64 rounding
/// and f32 ray rounding, so the real difference is far smaller.
#[test]
fn scale_invariance() {
    let dir = tempfile::tempdir().unwrap();
    let mut objs = perpendicular(1.0, 2.0, 1.0);
    // A third, partly occluding plate so that the ray path is exercised too.
    objs.push(Obj::new(
        "fin",
        vec![facing(
            vec![
                dvec3(0.3, 0.2, 0.0),
                dvec3(0.3, 0.8, 0.0),
                dvec3(0.3, 0.8, 0.5),
                dvec3(0.3, 0.2, 0.5),
            ],
            DVec3::X,
        )],
    ));
    let base = vf(&load(dir.path(), "s1", &objs, Placement::general(1.0)));
    for s in [1e-3, 1e3] {
        let v = vf(&load(
            dir.path(),
            &format!("s{s}"),
            &objs,
            Placement::general(s),
        ));
        for a in 0..3 {
            for b in 0..3 {
                let (x, y) = (v.matrix[a][b], base.matrix[a][b]);
                assert!(
                    (x - y).abs() <= 1e-4 * y.max(1e-3),
                    "scale {s}: F[{a}][{b}] = {x} vs {y} unscaled"
                );
            }
        }
    }
}

/// A closed box: every face's factors sum to 1 (the bound 1e-3), and each face's
/// factor to the opposite face is Howell's C-11 value.
#[test]
fn closed_box_sum_rule() {
    let dir = tempfile::tempdir().unwrap();
    for (k, (dx, dy, dz)) in [(1.0, 1.0, 1.0), (1.0, 2.0, 3.0), (556.0, 559.2, 548.8)]
        .into_iter()
        .enumerate()
    {
        let scene = load(
            dir.path(),
            &format!("box{k}"),
            &closed_box(dx, dy, dz),
            Placement::general(1.0),
        );
        let v = vf(&scene);
        for (name, s) in v.objects.iter().zip(v.row_sums()) {
            assert!((s - 1.0).abs() <= 1e-3, "box {k} face {name}: row sum {s}");
        }
        assert_eq!(
            v.rays_cast, 0,
            "nothing can block inside an empty box: no rays needed"
        );
    }
}

/// A closed box with a block standing inside it: the sum rule still holds, now only if the
/// shadow rays are right (every face sees the block instead of what is behind it).
#[test]
fn closed_box_with_inner_block_sum_rule() {
    let dir = tempfile::tempdir().unwrap();
    let mut objs = closed_box(2.0, 2.0, 2.0);
    // Block [0.6,1.3]×[0.5,1.2]×[0.4,1.5], outward faces.
    let mut block = closed_box(0.7, 0.7, 1.1);
    let mut polys = Vec::new();
    for o in &mut block {
        for p in &o.polygons {
            polys.push(p.iter().rev().map(|q| *q + dvec3(0.6, 0.5, 0.4)).collect());
        }
    }
    objs.push(Obj::new("block", polys));
    let scene = load(dir.path(), "box-block", &objs, Placement::general(1.0));
    let v = vf(&scene);
    assert!(v.rays_cast > 0);
    let worst = v
        .row_sums()
        .iter()
        .map(|s| (s - 1.0).abs())
        .fold(0.0, f64::max);
    println!(
        "box with block: worst |row sum - 1| = {worst:.2e}, {} rays",
        v.rays_cast
    );
    for (name, s) in v.objects.iter().zip(v.row_sums()) {
        assert!((s - 1.0).abs() <= 1e-3, "face {name}: row sum {s}");
    }
}

/// A tiny deterministic generator for the Monte-Carlo oracle (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Brute force: uniform points on object `a`, cosine-distributed directions, nearest hit over
/// every triangle (f64 Möller–Trumbore); a hit counts when it is on `b` and on its front.
fn monte_carlo(scene: &Scene, a: usize, b: usize, rays: usize, seed: u64) -> (f64, f64) {
    let tris: Vec<[DVec3; 3]> = (0..scene.triangles.len())
        .map(|t| scene.corners(t))
        .collect();
    let src: Vec<usize> = (0..tris.len())
        .filter(|&t| scene.triangles[t].object as usize == a)
        .collect();
    let areas: Vec<f64> = src.iter().map(|&t| scene.triangle_area(t)).collect();
    let total: f64 = areas.iter().sum();
    let mut rng = Rng(seed);
    let mut hits = 0usize;
    for _ in 0..rays {
        let mut pick = rng.next() * total;
        let mut k = 0;
        while k + 1 < src.len() && pick >= areas[k] {
            pick -= areas[k];
            k += 1;
        }
        let t = tris[src[k]];
        let (mut u, mut v) = (rng.next(), rng.next());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let x = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        let e1 = n.any_orthonormal_vector();
        let e2 = n.cross(e1);
        let (r, phi) = (rng.next().sqrt(), std::f64::consts::TAU * rng.next());
        let d = e1 * r * phi.cos() + e2 * r * phi.sin() + n * (1.0 - r * r).max(0.0).sqrt();
        let mut best = (f64::INFINITY, usize::MAX);
        for (j, q) in tris.iter().enumerate() {
            let (p1, p2) = (q[1] - q[0], q[2] - q[0]);
            let pv = d.cross(p2);
            let det = p1.dot(pv);
            if det.abs() < 1e-300 {
                continue;
            }
            let s = x - q[0];
            let uu = s.dot(pv) / det;
            let qv = s.cross(p1);
            let vv = d.dot(qv) / det;
            let tt = p2.dot(qv) / det;
            if uu >= 0.0 && vv >= 0.0 && uu + vv <= 1.0 && tt > 1e-9 && tt < best.0 {
                best = (tt, j);
            }
        }
        if best.1 != usize::MAX && scene.triangles[best.1].object as usize == b {
            let q = tris[best.1];
            if (q[1] - q[0]).cross(q[2] - q[0]).dot(d) < 0.0 {
                hits += 1;
            }
        }
    }
    let f = hits as f64 / rays as f64;
    (f, (f * (1.0 - f) / rays as f64).sqrt())
}

/// Parallel plates with a tilted, off-centre triangular blocker between them, in general
/// position, against the Monte-Carlo oracle: within 4 standard errors plus 0.5%.
#[test]
fn occluded_plates_against_monte_carlo() {
    let dir = tempfile::tempdir().unwrap();
    let mut objs = parallel(1.0, 1.0, 1.0);
    objs.push(Obj::new(
        "blocker",
        // Front (counter-clockwise side) facing plate `one` below it.
        vec![vec![
            dvec3(0.1, 0.2, 0.4),
            dvec3(0.3, 0.95, 0.5),
            dvec3(0.9, 0.35, 0.6),
        ]],
    ));
    let scene = load(dir.path(), "occluded", &objs, Placement::general(1.0));
    let v = vf(&scene);
    let (one, two) = (object(&v.objects, "one"), object(&v.objects, "two"));
    let got = v.matrix[one][two];
    let (mc, se) = monte_carlo(
        &scene,
        one,
        two,
        std::env::var("MC_RAYS").map_or(400_000, |s| s.parse().unwrap()),
        7,
    );
    let tol = 4.0 * se + 5e-3 * mc;
    println!("occluded plates: F = {got:.6}, Monte Carlo {mc:.6} ± {se:.6}");
    assert!(
        (got - mc).abs() <= tol,
        "occluded F = {got}, Monte Carlo {mc} ± {se}, |diff| {} > {tol}",
        (got - mc).abs()
    );
    assert!(
        got < 0.199_824_895_698 * 0.9,
        "the blocker must take a visible share: F = {got}"
    );
    // And towards the blocker's two sides (it blocks from both, receives on its front only).
    let blk = object(&v.objects, "blocker");
    let (mc_b, se_b) = monte_carlo(
        &scene,
        one,
        blk,
        std::env::var("MC_RAYS").map_or(200_000, |s| s.parse().unwrap()),
        11,
    );
    let got_b = v.matrix[one][blk];
    println!("plate to blocker: F = {got_b:.6}, Monte Carlo {mc_b:.6} ± {se_b:.6}");
    assert!(
        (got_b - mc_b).abs() <= 4.0 * se_b + 5e-3 * mc_b,
        "F to blocker {got_b}, Monte Carlo {mc_b} ± {se_b}"
    );
    assert!(
        got_b > 0.05,
        "plate one faces the blocker's front: F = {got_b}"
    );
    assert_eq!(
        f(&v, "two", "blocker"),
        0.0,
        "plate two sees only the blocker's back"
    );
}

/// A plate that covers the whole view blocks everything: exactly zero.
#[test]
fn full_blocker_gives_zero() {
    let dir = tempfile::tempdir().unwrap();
    let mut objs = parallel(1.0, 1.0, 1.0);
    objs.push(Obj::new(
        "wall",
        vec![rect_z(-50.0, 50.0, -50.0, 50.0, 0.5, true)],
    ));
    let v = vf(&load(dir.path(), "blocked", &objs, Placement::general(1.0)));
    let got = f(&v, "one", "two");
    assert!(got.abs() <= 1e-9, "F through a wall = {got}");
}

/// McGuire's Cornell box (open at the front): factors are non-negative, reciprocal, and rows
/// sum to less than 1.
#[test]
fn cornell_box_is_consistent() {
    let scene = Scene::load_obj(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/cornell-box/CornellBox-Original.obj"
    )))
    .unwrap();
    let v = view_factors(&scene, &ViewFactorParams::fast(), None);
    for a in 0..v.objects.len() {
        let s: f64 = v.matrix[a].iter().sum();
        assert!(s > 0.5 && s < 1.0, "{}: row sum {s}", v.objects[a]);
        for b in 0..v.objects.len() {
            assert!(v.matrix[a][b] >= 0.0);
            let (x, y) = (v.areas[a] * v.matrix[a][b], v.areas[b] * v.matrix[b][a]);
            assert!(
                (x - y).abs() <= 1e-12 * x.max(y).max(1e-300),
                "reciprocity {a} {b}: {x} vs {y}"
            );
        }
    }
}
