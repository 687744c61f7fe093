//! The path tracer against closed forms that share nothing with the bake: the white furnace,
//! Howell's view factors (tests/tests/data/viewfactors.csv), the inverse-square cosine law and
//! its solid-angle integral, hard shadows, the energy identity of closed enclosures and the
//! two-plate closed form of multiple bounces between two facing plates.
//!
//! Monte-Carlo estimates are compared within `K_SIGMA` standard errors. The seeds are fixed, so
//! every run is the same; the bound says how unlikely a failure would be for an unlucky seed:
//! at 4σ about 6e-5 per comparison (normal tails; the estimators' contributions are bounded, so
//! the sample means are close to normal at these sample counts), 5e-3 over the ~80 comparisons
//! here. Each test also checks that its standard error is small, so the bound has teeth.

use super::*;

/// The test scenes' OBJ writer of `radiosity-tests`, taken as a file rather than through that
/// crate, which depends on the bake: the path tracer stays independent of the bake it checks
/// (`cargo tree -p radiosity-pathtrace` has no `radiosity-bake`).
#[path = "../../tests/src/scenes.rs"]
// Its items are public for the tests crate; here some go unused.
#[allow(unreachable_pub, dead_code)]
mod scenes;
use glam::dvec3;
use scenes::{Material as Mat, Quad, block, closed_box, write_scene};
use std::f64::consts::PI;

const K_SIGMA: f64 = 4.0;

fn load(name: &str, quads: &[Quad], materials: &[Mat]) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let path = write_scene(dir.path(), name, quads, materials);
    Scene::load_obj(&path).unwrap()
}

fn estimate<'a>(est: &'a [ObjectEstimate], name: &str) -> &'a ObjectEstimate {
    est.iter()
        .find(|e| e.name == name)
        .unwrap_or_else(|| panic!("no object {name}"))
}

/// `|got − want| ≤ K_SIGMA·σ + slack`, printing everything on failure.
fn assert_close(what: &str, got: f64, want: f64, sigma: f64, slack: f64) {
    let diff = (got - want).abs();
    let bound = K_SIGMA * sigma + slack;
    println!(
        "{what}: {got:.6} vs {want:.6}, diff {:+.2}σ",
        (got - want) / sigma
    );
    assert!(
        diff <= bound,
        "{what}: got {got}, want {want}, |diff| {diff:.3e} > {K_SIGMA}σ ({sigma:.3e}) + {slack:.3e}"
    );
}

/// A rectangle in the plane `z`, `[x0, x1] × [y0, y1]`, facing `+z` when `up`.
fn rect_z(object: &str, material: &str, [x0, x1, y0, y1]: [f64; 4], z: f64, up: bool) -> Quad {
    let towards = [
        0.5 * (x0 + x1),
        0.5 * (y0 + y1),
        if up { z + 1.0 } else { z - 1.0 },
    ];
    Quad::facing(
        object,
        material,
        [[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]],
        towards,
    )
}

/// Closed-form values of one Howell case from the shared reference table.
struct Reference {
    p: [f64; 3],
    exact: f64,
}

fn reference(id: u32) -> Reference {
    let text = include_str!("../../tests/tests/data/viewfactors.csv");
    for line in text.lines().skip(1) {
        // Split on commas outside double quotes.
        let mut fields = Vec::new();
        let mut cur = String::new();
        let mut quoted = false;
        for ch in line.chars() {
            match ch {
                '"' => quoted = !quoted,
                ',' if !quoted => fields.push(std::mem::take(&mut cur)),
                _ => cur.push(ch),
            }
        }
        fields.push(cur);
        if fields[0] == id.to_string() {
            let num = |i: usize| fields[i].parse::<f64>().unwrap();
            return Reference {
                p: [num(3), num(4), num(5)],
                exact: num(6),
            };
        }
    }
    panic!("no row {id} in viewfactors.csv");
}

#[test]
fn white_furnace_gives_e_over_one_minus_rho_per_channel() {
    // Closed box, every face emits Ke = 1 (E = π) and reflects ρ = (0.3, 0.5, 0.7): H = B =
    // E/(1 − ρ) at every point, whatever the geometry (multibounce.md §1). The channels differ
    // so that Russian roulette (driven by the largest channel) is checked per channel.
    let rho = [0.3, 0.5, 0.7];
    let quads = closed_box(1.0, 2, |_, _, _| "glow".into());
    let scene = load("furnace", &quads, &[Mat::new("glow", rho, [1.0; 3])]);
    let tracer = PathTracer::new(&scene, &[]).unwrap();
    let est = tracer.object_irradiance(20_000, 11);
    assert_eq!(est.len(), 6);
    for e in &est {
        assert!((e.area - 1.0).abs() < 1e-12, "{}: area {}", e.name, e.area);
        for c in 0..3 {
            let want = PI / (1.0 - rho[c]);
            assert!(e.stderr[c] < 0.01 * want, "{}: σ {:?}", e.name, e.stderr);
            assert_close(
                &format!("{} H[{c}]", e.name),
                e.irradiance[c],
                want,
                e.stderr[c],
                0.0,
            );
            assert_close(
                &format!("{} B[{c}]", e.name),
                e.radiosity[c],
                want,
                e.radiosity_stderr[c],
                0.0,
            );
        }
    }
}

#[test]
fn emitter_to_receiver_follows_howells_view_factors() {
    // A black receiver lit by a black emitter of exitance E = π·Ke: its mean irradiance is
    // E·F(receiver → emitter). F from Howell's closed forms (C-11 parallel rectangles: rows 1,
    // 2, 7; C-14 perpendicular rectangles with a common edge: rows 10, 11, 13).
    let ke = [1.0, 0.5, 0.25];
    let materials = [
        Mat::new("black", [0.0; 3], [0.0; 3]),
        Mat::new("emit", [0.0; 3], ke),
    ];
    for id in [1, 2, 7, 10, 11, 13] {
        let r = reference(id);
        let quads = if id < 10 {
            let [a, b, c] = r.p;
            vec![
                rect_z("receiver", "black", [0.0, a, 0.0, b], 0.0, true),
                rect_z("emitter", "emit", [0.0, a, 0.0, b], c, false),
            ]
        } else {
            // F_exact is from the w×l floor to the h×l wall.
            let [w, h, l] = r.p;
            vec![
                rect_z("receiver", "black", [0.0, w, 0.0, l], 0.0, true),
                Quad::facing(
                    "emitter",
                    "emit",
                    [[0.0, 0.0, 0.0], [0.0, l, 0.0], [0.0, l, h], [0.0, 0.0, h]],
                    [1.0, 0.5 * l, 0.5 * h],
                ),
            ]
        };
        let scene = load(&format!("vf{id}"), &quads, &materials);
        let est = PathTracer::new(&scene, &[])
            .unwrap()
            .object_irradiance(40_000, u64::from(id));
        let rec = estimate(&est, "receiver");
        for c in 0..3 {
            let want = PI * ke[c] * r.exact;
            assert!(rec.stderr[c] < 0.006 * want, "row {id}: σ {:?}", rec.stderr);
            assert_close(
                &format!("row {id} H[{c}]"),
                rec.irradiance[c],
                want,
                rec.stderr[c],
                0.0,
            );
        }
        // Nothing lights the emitter: the receiver is black.
        assert_eq!(estimate(&est, "emitter").irradiance, [0.0; 3]);
    }
}

#[test]
fn emission_and_reception_are_one_sided() {
    // The emitter of C-11 row 1 turned away from the receiver: nothing arrives, exactly; and a
    // receiver turned away from a facing emitter receives nothing either.
    let materials = [
        Mat::new("grey", [0.5; 3], [0.0; 3]),
        Mat::new("emit", [0.5; 3], [1.0; 3]),
    ];
    for (receiver_up, emitter_up) in [(true, true), (false, false)] {
        let quads = [
            rect_z("receiver", "grey", [0.0, 1.0, 0.0, 1.0], 0.0, receiver_up),
            rect_z("emitter", "emit", [0.0, 1.0, 0.0, 1.0], 1.0, emitter_up),
        ];
        let est = PathTracer::new(&load("sided", &quads, &materials), &[])
            .unwrap()
            .object_irradiance(500, 3);
        assert_eq!(
            estimate(&est, "receiver").irradiance,
            [0.0; 3],
            "receiver up {receiver_up}, emitter up {emitter_up}"
        );
    }
}

/// ∫∫ h/(x²+y²+h²)^{3/2} over `[0, x] × [0, y]`: the solid angle of that rectangle seen from
/// height `h` above its corner (odd in x and in y).
fn corner_solid_angle(x: f64, y: f64, h: f64) -> f64 {
    (x * y / (h * (x * x + y * y + h * h).sqrt())).atan()
}

/// Solid angle of the rectangle `[x0, x1] × [y0, y1]` in the plane z = 0 seen from `(0, 0, h)`.
fn rect_solid_angle([x0, x1, y0, y1]: [f64; 4], h: f64) -> f64 {
    corner_solid_angle(x1, y1, h) - corner_solid_angle(x0, y1, h) - corner_solid_angle(x1, y0, h)
        + corner_solid_angle(x0, y0, h)
}

#[test]
fn point_light_follows_the_inverse_square_cosine_law_and_casts_a_hard_shadow() {
    // A point light of intensity I at height 2 over the plane z = 0. Mean irradiance over a
    // rectangle R = I·Ω(R)/A(R) (I cosθ/r² integrated is the solid angle). A black square
    // [-0.25, 0.25]² at z = 1, turned towards the floor so that the light meets its back,
    // shadows exactly [-0.5, 0.5]² of the floor. The floor pieces reflect (ρ = 0.5) but are
    // coplanar and the blocker is black, so no light comes back: the answer is direct only.
    let h = 2.0;
    let intensity = [1.0, 2.0, 3.0];
    let lit = [1.0, 2.0, -0.5, 0.5];
    let penumbra_free = [-0.4, 0.4, -0.4, 0.4];
    let quads = [
        rect_z("lit", "floor", lit, 0.0, true),
        rect_z("umbra", "floor", penumbra_free, 0.0, true),
        rect_z("blocker", "black", [-0.25, 0.25, -0.25, 0.25], 1.0, false),
    ];
    let materials = [
        Mat::new("floor", [0.5; 3], [0.0; 3]),
        Mat::new("black", [0.0; 3], [0.0; 3]),
    ];
    let scene = load("shadow", &quads, &materials);
    let light = Light::Point {
        position: Vec3::new(0.0, 0.0, h as f32),
        intensity: radiosity_core::Rgb::new(1.0, 2.0, 3.0),
    };
    let est = PathTracer::new(&scene, std::slice::from_ref(&light))
        .unwrap()
        .object_irradiance(3000, 5);
    let e = estimate(&est, "lit");
    let omega = rect_solid_angle(lit, h);
    for c in 0..3 {
        let want = intensity[c] * omega / 1.0;
        // Light only varies by position here, so σ is the spread of H over the rectangle.
        assert!(e.stderr[c] < 0.01 * want, "σ {:?}", e.stderr);
        assert_close(
            &format!("lit H[{c}]"),
            e.irradiance[c],
            want,
            e.stderr[c],
            0.0,
        );
        assert_close(
            &format!("lit B[{c}]"),
            e.radiosity[c],
            0.5 * want,
            e.radiosity_stderr[c],
            0.0,
        );
    }
    assert_eq!(
        estimate(&est, "umbra").irradiance,
        [0.0; 3],
        "in the shadow"
    );

    // Pointwise, at (1, 0, 0) on the lit piece alone: H = I·cosθ/r² with r² = 1 + h².
    let open = load("open", &quads[..1], &materials);
    let tracer = PathTracer::new(&open, &[light]).unwrap();
    let mut rng = SplitMix64(1);
    let below = tracer.irradiance_at(dvec3(1.0, 0.0, 0.0), DVec3::Z, &mut rng);
    let r2 = 1.0 + h * h;
    for c in 0..3 {
        let want = intensity[c] * (h / r2.sqrt()) / r2;
        assert!((below[c] - want).abs() < 1e-6 * want, "{below:?} vs {want}");
    }
}

#[test]
fn spot_cone_and_directional_light() {
    let materials = [Mat::new("floor", [0.5; 3], [0.0; 3])];
    let quads = [
        rect_z("inside", "floor", [-0.1, 0.1, -0.1, 0.1], 0.0, true),
        rect_z("outside", "floor", [0.9, 1.1, -0.1, 0.1], 0.0, true),
    ];
    let scene = load("spot", &quads, &materials);
    // A spot 1 above the origin pointing down with a 20° cone lights a disc of radius tan 20°
    // = 0.36: all of `inside` (a point light there: I·Ω/A), none of `outside`.
    let spot = Light::Spot {
        position: Vec3::new(0.0, 0.0, 1.0),
        direction: Vec3::new(0.0, 0.0, -1.0),
        cone_deg: 20.0,
        intensity: radiosity_core::Rgb::splat(4.0),
    };
    let est = PathTracer::new(&scene, &[spot])
        .unwrap()
        .object_irradiance(2000, 8);
    let inside = estimate(&est, "inside");
    let want = 4.0 * rect_solid_angle([-0.1, 0.1, -0.1, 0.1], 1.0) / 0.04;
    assert_close(
        "spot inside",
        inside.irradiance[0],
        want,
        inside.stderr[0],
        0.0,
    );
    assert_eq!(estimate(&est, "outside").irradiance, [0.0; 3]);

    // A directional light travelling along (1, 0, −2): H = E·cosθ = E·2/√5 everywhere, no noise.
    let sun = Light::Directional {
        direction: Vec3::new(1.0, 0.0, -2.0),
        irradiance: radiosity_core::Rgb::new(3.0, 2.0, 1.0),
    };
    let est = PathTracer::new(&scene, &[sun])
        .unwrap()
        .object_irradiance(100, 8);
    for e in &est {
        for (c, irr) in [3.0, 2.0, 1.0].into_iter().enumerate() {
            let want = irr * 2.0 / 5f64.sqrt();
            // f32 light arithmetic: 1e-6 relative.
            assert!(
                (e.irradiance[c] - want).abs() < 1e-6 * want,
                "{}: {:?}",
                e.name,
                e.irradiance
            );
        }
    }
}

#[test]
fn buried_surface_counts_in_the_means_with_no_irradiance() {
    // A black emitting floor 2 × 2 (E = π·0.1) with a black block 0.6 × 0.6 × 0.5 resting on
    // it, under a sun straight down (H = 3 wherever it is not shadowed). The sun's shadow is the
    // block's footprint, which is also the floor's buried part, so the floor's mean over its
    // whole area is H = 3·(4 − 0.36)/4, and B = E on every point, buried or not (ρ = 0). A mean
    // over the exposed part only, as before, gives H = 3; buried points left out of B or counted
    // with B = 0 give B = E·0.91 instead.
    let materials = [
        Mat::new("glow", [0.0; 3], [0.1; 3]),
        Mat::new("black", [0.0; 3], [0.0; 3]),
    ];
    let mut quads = vec![rect_z("floor", "glow", [-1.0, 1.0, -1.0, 1.0], 0.0, true)];
    quads.extend(block([-0.3, -0.3, 0.0], [0.3, 0.3, 0.5], "block", "black"));
    let scene = load("buried", &quads, &materials);
    let sun = Light::Directional {
        direction: Vec3::new(0.0, 0.0, -1.0),
        irradiance: radiosity_core::Rgb::splat(3.0),
    };
    let n = 20_000;
    let est = PathTracer::new(&scene, &[sun])
        .unwrap()
        .object_irradiance(n, 5);
    let floor = estimate(&est, "floor");
    let exposed = 4.0 - 0.36;
    assert!(
        (floor.area - 4.0).abs() < 1e-12,
        "floor area {}",
        floor.area
    );
    // The irradiance is 3 or 0 per sample: a Bernoulli mean, σ = 3·√(p(1 − p)/n) ≈ 0.0086.
    let sigma = floor.stderr[0];
    assert!(sigma > 0.0 && sigma < 0.005 * 3.0, "σ {sigma}");
    assert_close(
        "floor H",
        floor.irradiance[0],
        3.0 * exposed / 4.0,
        sigma,
        0.0,
    );
    // The exposed area is the same count of unburied samples: H = 3 on each of them (f32
    // light arithmetic, 1e-6 relative).
    assert!(
        (floor.exposed_area / floor.area - floor.irradiance[0] / 3.0).abs() < 1e-6,
        "exposed {} of {} vs H {}",
        floor.exposed_area,
        floor.area,
        floor.irradiance[0]
    );
    assert_close(
        "floor exposed area",
        floor.exposed_area,
        exposed,
        4.0 * sigma / 3.0,
        0.0,
    );
    let e = PI * 0.1;
    // f32 emission (Ke) against the f64 π·0.1: 1e-6 relative.
    assert!(
        (floor.radiosity[0] - e).abs() < 1e-6 * e,
        "B {:?} vs E {e}",
        floor.radiosity
    );
    // The block: whole 2·0.36 + 4·0.3 = 1.92, its bottom (0.36) buried.
    let b = estimate(&est, "block");
    assert!((b.area - 1.92).abs() < 1e-12, "block area {}", b.area);
    let p = 1.56 / 1.92;
    let sigma_b = 1.92 * (p * (1.0 - p) / n as f64).sqrt();
    assert_close("block exposed area", b.exposed_area, 1.56, sigma_b, 0.0);
}

#[test]
fn closed_box_keeps_the_energy_identity() {
    // multibounce.md §2: in a closed enclosure with uniform ρ, Σ A_i B_i = Σ A_i E_i / (1 − ρ)
    // wherever the light is. Only the floor emits (E = π·0.2), ρ = 0.6.
    let rho = 0.6;
    let quads = closed_box(1.0, 1, |face, _, _| {
        if face == "floor" { "emit" } else { "white" }.into()
    });
    let materials = [
        Mat::new("white", [rho; 3], [0.0; 3]),
        Mat::new("emit", [rho; 3], [0.2; 3]),
    ];
    let scene = load("identity", &quads, &materials);
    let est = PathTracer::new(&scene, &[])
        .unwrap()
        .object_irradiance(20_000, 21);
    let emitted: f64 = scene
        .triangles
        .iter()
        .enumerate()
        .map(|(t, tri)| {
            scene.triangle_area(t) * f64::from(scene.materials[tri.material as usize].emission.r)
        })
        .sum();
    let want = emitted / (1.0 - rho);
    let got: f64 = est.iter().map(|e| e.area * e.radiosity[0]).sum();
    let sigma = est
        .iter()
        .map(|e| (e.area * e.radiosity_stderr[0]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(sigma < 0.005 * want, "σ {sigma} of {want}");
    assert_close("Σ A·B", got, want, sigma, 0.0);
    // The ceiling, opposite the emitter, gets less than the walls beside it (F_opposite <
    // F_adjacent, and the walls see each other); a sanity check on where the light goes.
    assert!(estimate(&est, "floor").radiosity[0] > estimate(&est, "left").radiosity[0]);
}

#[test]
fn wide_parallel_plates_approach_the_infinite_plate_closed_form() {
    // multibounce.md §3a, RGB: plate 1 ρ = (0.725, 0.71, 0.68), E1 = 1; plate 2 ρ = (0.63, 0.065,
    // 0.05), E2 = 0; infinite plates give B1 = (1.8408, 1.0484, 1.0352), B2 = (1.1597, 0.06814,
    // 0.05176). These plates are 1000 × 1000 at distance 1 (C-11 row 9: mean F = 0.998006).
    // The missing 0.2% of F loses B by at most d ln B/d F·ΔF: ≤ 2ρ1ρ2/(1 − ρ1ρ2) ≈ 1.7 times
    // 0.2% for B1 (0.34%) plus 0.2% more for B2 — so 1% slack covers it with room.
    let a = 1000.0;
    assert!((reference(9).exact - 0.998005631908).abs() < 1e-12);
    let quads = [
        rect_z("one", "one", [0.0, a, 0.0, a], 0.0, true),
        rect_z("two", "two", [0.0, a, 0.0, a], 1.0, false),
    ];
    let materials = [
        Mat::new("one", [0.725, 0.71, 0.68], [1.0 / PI; 3]),
        Mat::new("two", [0.63, 0.065, 0.05], [0.0; 3]),
    ];
    let scene = load("plates", &quads, &materials);
    let est = PathTracer::new(&scene, &[])
        .unwrap()
        .object_irradiance(40_000, 4);
    let want = [
        ("one", [1.840773125, 1.048382869, 1.035196687]),
        ("two", [1.159687069, 0.06814488651, 0.05175983437]),
    ];
    for (name, b) in want {
        let e = estimate(&est, name);
        for c in 0..3 {
            assert!(
                e.radiosity_stderr[c] < 0.01 * b[c],
                "{name}: σ {:?}",
                e.radiosity_stderr
            );
            assert_close(
                &format!("{name} B[{c}]"),
                e.radiosity[c],
                b[c],
                e.radiosity_stderr[c],
                0.01 * b[c],
            );
        }
    }
}

#[test]
fn results_depend_on_the_seed_only_not_the_thread_count() {
    let quads = closed_box(1.0, 1, |face, _, _| {
        if face == "ceiling" { "emit" } else { "white" }.into()
    });
    let materials = [
        Mat::new("white", [0.7; 3], [0.0; 3]),
        Mat::new("emit", [0.7; 3], [1.0; 3]),
    ];
    let scene = load("threads", &quads, &materials);
    let tracer = PathTracer::new(&scene, &[]).unwrap();
    let run = |threads: usize, seed: u64| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| tracer.object_irradiance(1000, seed))
    };
    let one = run(1, 9);
    assert_eq!(one, run(3, 9), "bit-identical across thread counts");
    assert_ne!(one, run(1, 10), "another seed, other samples");
    let camera =
        Camera::parse(r#"{"position":[0.5,0.5,0.9],"look_at":[0.5,0.5,0],"width":9,"height":7}"#)
            .unwrap();
    let image = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| tracer.render(&camera, 3, 2))
    };
    assert_eq!(image(1), image(4));
}

#[test]
fn images_show_radiance() {
    let materials = [
        Mat::new("emit", [0.0; 3], [1.0, 2.0, 3.0]),
        Mat::new("floor", [0.5; 3], [0.0; 3]),
    ];
    // An emitter filling the view shows its radiance Ke exactly; seen from behind, black.
    let scene = load(
        "glow",
        &[rect_z(
            "glow",
            "emit",
            [-10.0, 10.0, -10.0, 10.0],
            0.0,
            true,
        )],
        &materials,
    );
    let tracer = PathTracer::new(&scene, &[]).unwrap();
    let front =
        Camera::parse(r#"{"position":[0,0,1],"look_at":[0,0,0],"width":8,"height":8}"#).unwrap();
    let img = tracer.render(&front, 2, 1);
    for p in &img.pixels {
        assert!(
            (*p - Vec3::new(1.0, 2.0, 3.0)).abs().max_element() < 1e-6,
            "{p}"
        );
    }
    let back =
        Camera::parse(r#"{"position":[0,0,-1],"look_at":[0,0,0],"width":8,"height":8}"#).unwrap();
    assert!(
        tracer
            .render(&back, 2, 1)
            .pixels
            .iter()
            .all(|p| *p == Vec3::ZERO)
    );

    // A lit floor seen from above: radiance ρ·H/π with H = I/h² below a point light.
    let scene = load(
        "lit",
        &[rect_z(
            "floor",
            "floor",
            [-10.0, 10.0, -10.0, 10.0],
            0.0,
            true,
        )],
        &materials,
    );
    let light = Light::Point {
        position: Vec3::new(0.0, 0.0, 2.0),
        intensity: radiosity_core::Rgb::splat(8.0),
    };
    let tracer = PathTracer::new(&scene, &[light]).unwrap();
    let cam = Camera::parse(
        r#"{"position":[0,0,3],"look_at":[0,0,0],"fov_deg":10,"width":9,"height":9}"#,
    )
    .unwrap();
    let img = tracer.render(&cam, 4, 1);
    let centre = img.pixels[4 * 9 + 4];
    // 8 W/sr / 4 m² = 2 W/m²; the pixel spans ±0.03 around the centre, where H changes by
    // under 0.1% (cos³ falloff), so 1e-3 relative.
    let want = 0.5 * 2.0 / PI as f32;
    assert!((centre.x - want).abs() < 1e-3 * want, "{centre} vs {want}");
}

#[test]
fn bad_inputs_are_errors() {
    assert!(PathTracer::new(&Scene::default(), &[]).is_err());
    let scene = load(
        "one",
        &[rect_z("floor", "floor", [0.0, 1.0, 0.0, 1.0], 0.0, true)],
        &[Mat::new("floor", [0.5; 3], [0.0; 3])],
    );
    let bad = Light::Point {
        position: Vec3::new(0.0, 0.0, f32::NAN),
        intensity: radiosity_core::Rgb::splat(1.0),
    };
    let err = PathTracer::new(&scene, &[bad]).err().unwrap();
    assert!(format!("{err:#}").contains("light 0"), "{err:#}");
}
