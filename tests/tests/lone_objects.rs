//! Scenes where no patch sees another — a lone convex box, a single sheet — bake with an empty
//! (zero) transfer, and everything else works: the direct light of a sun on each face is
//! `E·cos θ` (within 1%: the shadow rays meet nothing on a convex object, so only f32 rounding
//! is left; 1% leaves room for the area-weighted mean over each patch's points).

use glam::Vec3;
use radiosity_bake::pipeline::{BakeParams, Hooks, bake};
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::VoxelParams;
use radiosity_core::{Light, Rgb};
use radiosity_runtime::BakedScene;
use radiosity_tests::fixtures::reference_frame;
use radiosity_tests::scenes::{Material, Quad, block, write_scene};

/// Bakes `quads` and lights them with a sun travelling along `d` (irradiance 1 facing it);
/// returns each object's mean irradiance (red channel) and its front normal.
fn sunlit(quads: &[Quad], d: Vec3) -> Vec<(String, f64)> {
    let dir = tempfile::tempdir().unwrap();
    let mats = [Material::new("grey", [0.5; 3], [0.0; 3])];
    let path = write_scene(dir.path(), "lone", quads, &mats);
    let scene = Scene::load_obj(&path).unwrap();
    let params = BakeParams {
        voxel: VoxelParams::with_patches(96),
        ..BakeParams::default()
    };
    let out = bake(&scene, &params, Hooks::default()).expect("a lone object bakes");
    let rt = BakedScene::new(out.file);
    let file = &rt.file;
    let lights = [Light::Directional {
        direction: d,
        irradiance: Rgb::splat(1.0),
    }];
    let (direct, at_samples) = rt.direct_with_samples(&lights).unwrap();
    let f = reference_frame(file, &rt.sent(&direct, &at_samples));
    assert!(
        f.y.iter().all(|v| *v == Rgb::ZERO),
        "no light travels between surfaces"
    );
    radiosity_runtime::objects::per_object(
        file,
        &f.h,
        &f.b,
        &direct,
        &at_samples,
        radiosity_core::sky_sh_of(&lights).as_ref(),
    )
    .into_iter()
    .map(|o| (o.name, o.irradiance[0]))
    .collect()
}

/// The unit square in y = 0 from (0, 0, 0) to (1, 0, −1), facing up, object `object`.
fn unit_sheet(object: &str) -> Quad {
    Quad {
        object: object.into(),
        material: "grey".into(),
        corners: UNIT_SHEET,
    }
}

/// [`unit_sheet`]'s corners, counter-clockwise seen from above.
const UNIT_SHEET: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 0.0, -1.0],
    [0.0, 0.0, -1.0],
];

/// The unit front normal of a quad (counter-clockwise corners).
fn normal(q: &Quad) -> Vec3 {
    let c = q
        .corners
        .map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32));
    (c[1] - c[0]).cross(c[2] - c[0]).normalize()
}

#[test]
fn a_lone_box_bakes_and_each_face_gets_e_cos_theta() {
    let mut quads = block([0.0; 3], [1.0, 2.0, 0.5], "box", "grey");
    for (k, q) in quads.iter_mut().enumerate() {
        q.object = format!("face{k}");
    }
    let d = Vec3::new(-1.0, -2.0, -3.0).normalize();
    let got = sunlit(&quads, d);
    for (q, (name, e)) in quads.iter().zip(&got) {
        assert_eq!(&q.object, name);
        let want = f64::from((-normal(q).dot(d)).max(0.0));
        assert!(
            (e - want).abs() <= 0.01 * want.max(1e-3),
            "{name}: {e} against {want}"
        );
    }
    assert!(
        got.iter().filter(|o| o.1 > 0.0).count() == 3,
        "three faces lit: {got:?}"
    );
}

#[test]
fn a_single_sheet_bakes_and_its_front_gets_e_cos_theta() {
    let sheet = unit_sheet("sheet");
    let up = normal(&sheet);
    assert!(up.y > 0.99, "the sheet faces up");
    let d = Vec3::new(0.3, -1.0, 0.2).normalize();
    let got = sunlit(std::slice::from_ref(&sheet), d);
    let want = f64::from(-up.dot(d));
    assert!(
        (got[0].1 - want).abs() <= 0.01 * want,
        "{got:?} against {want}"
    );
}

/// A two-sided sheet in the open (two back-to-back sheets of the same corners, each side its
/// own object): a sun from above lights the top with `E·|cos θ|` and not the bottom, a sun from
/// below the bottom; neither side buries the other (both keep their whole area exposed).
#[test]
fn a_two_sided_sheet_in_the_open_is_lit_on_the_side_the_sun_reaches() {
    let top = unit_sheet("top");
    let mut reversed = UNIT_SHEET;
    reversed.reverse();
    let bottom = Quad {
        object: "bottom".into(),
        material: "grey".into(),
        corners: reversed,
    };
    assert!(normal(&top).y > 0.99 && normal(&bottom).y < -0.99);
    let quads = [top, bottom];
    for d in [Vec3::new(0.3, -1.0, 0.2), Vec3::new(-0.2, 1.0, 0.4)] {
        let d = d.normalize();
        let got = sunlit(&quads, d);
        for (q, (name, e)) in quads.iter().zip(&got) {
            let want = f64::from((-normal(q).dot(d)).max(0.0));
            assert!(
                (e - want).abs() <= 0.01 * want.max(1e-3),
                "{name} under {d}: {e} against {want}"
            );
        }
    }
}

/// A point 1 cm above an open sheet, looking down at it, lies beyond the mesh's bounds but sees
/// the scene: it is answered (the light the sheet reflects), not "outside the scene"; one
/// looking away from everything is outside.
#[test]
fn a_point_in_front_of_an_open_scene_is_answered() {
    use radiosity_runtime::points::{Answer, Point, answer};
    let dir = tempfile::tempdir().unwrap();
    let sheet = unit_sheet("sheet");
    let path = write_scene(
        dir.path(),
        "sheet",
        &[sheet],
        &[Material::new("grey", [0.5; 3], [0.0; 3])],
    );
    let scene = Scene::load_obj(&path).unwrap();
    let params = BakeParams {
        voxel: VoxelParams::with_patches(16),
        ..BakeParams::default()
    };
    let rt = BakedScene::new(bake(&scene, &params, Hooks::default()).unwrap().file);
    let lights = [Light::Directional {
        direction: Vec3::new(0.0, -1.0, 0.0),
        irradiance: Rgb::splat(1.0),
    }];
    let n = rt.file.n();
    let direct = rt.direct(&lights).unwrap();
    let y = vec![Rgb::ZERO; n];
    let h: Vec<Rgb> = direct.clone();
    let at = |p: [f64; 3], d: [f64; 3]| Point {
        position: glam::DVec3::from(p),
        normal: glam::DVec3::from(d),
        given_normal: glam::DVec3::from(d),
    };
    let points = [
        at([0.5, 0.01, -0.5], [0.0, -1.0, 0.0]),
        at([0.5, 5.0, -0.5], [0.0, 1.0, 0.0]),
    ];
    let got = answer(&rt, &y, &h, &lights, &points).unwrap();
    // Looking down at a sheet of B = ρ·E = 0.5 from 1 cm: nearly all of the hemisphere is the
    // sheet, so nearly 0.5 (the sheet's edge 0.5 away cuts off well under 1%).
    match got[0] {
        Answer::Irradiance { total, .. } => {
            assert!((total.r - 0.5).abs() < 0.01, "{total:?}")
        }
        other => panic!("answered, not {other:?}"),
    }
    assert_eq!(got[1], Answer::Outside);
}
