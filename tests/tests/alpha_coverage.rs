//! glTF `alphaMode` through the bake: a sheet wholly cut out (MASK, alpha under the cutoff)
//! between a sun and a floor is no surface, so the floor gets the sun's full `E·cos θ`; the
//! same sheet opaque shadows the floor. Tolerance 1%: with the sheet gone the floor is a lone
//! sheet whose shadow rays meet nothing, so only f32 rounding and the area-weighted mean over
//! the patches' points are left (as in `lone_objects`). A sheet of partial coverage (BLEND)
//! passes its share of the sun and of the light bounced between it and the floor, as the
//! path tracer sees it.

use base64::Engine;
use glam::Vec3;
use radiosity_bake::pipeline::{BakeParams, Hooks, bake};
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::VoxelParams;
use radiosity_core::{Light, Rgb};
use radiosity_pathtrace::PathTracer;
use radiosity_runtime::BakedScene;
use radiosity_tests::fixtures::reference_frame;
use serde_json::json;

/// A glTF file of two squares: `floor` (2 × 2 m at y = 0, opaque, facing up +y) and `sheet`
/// (3 × 3 m at y = 0.5, covering the floor from above, facing up or, with `sheet_down`, down
/// at the floor) with material `sheet_material`.
fn write_pair(
    dir: &std::path::Path,
    sheet_material: serde_json::Value,
    sheet_down: bool,
) -> std::path::PathBuf {
    let square = |h: f32, y: f32, down: bool| -> Vec<[f32; 3]> {
        // Counter-clockwise seen from above (+y), or from below.
        let mut q = vec![[-h, y, h], [h, y, h], [h, y, -h], [-h, y, -h]];
        if down {
            q.reverse();
        }
        q
    };
    let mut bin: Vec<u8> = Vec::new();
    for p in square(1.0, 0.0, false)
        .into_iter()
        .chain(square(1.5, 0.5, sheet_down))
    {
        for c in p {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    let doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"name": "floor", "mesh": 0}, {"name": "sheet", "mesh": 1}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0}, "indices": 2, "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": 1}, "indices": 2, "material": 1}]}
        ],
        "materials": [
            {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0}},
            sheet_material
        ],
        "accessors": [
            {"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-1.0, 0.0, -1.0], "max": [1.0, 0.0, 1.0]},
            {"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-1.5, 0.5, -1.5], "max": [1.5, 0.5, 1.5]},
            {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 96},
            {"buffer": 0, "byteOffset": 96, "byteLength": 12}
        ],
        "buffers": [{"byteLength": bin.len(), "uri": uri}]
    });
    let path = dir.join("pair.gltf");
    std::fs::write(&path, doc.to_string()).unwrap();
    path
}

/// The floor's mean irradiance (red) under a sun straight down of irradiance 1.
fn floor_irradiance(sheet_material: serde_json::Value) -> f64 {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::load(&write_pair(dir.path(), sheet_material, false)).unwrap();
    let params = BakeParams {
        voxel: VoxelParams::with_patches(96),
        ..BakeParams::default()
    };
    let out = bake(&scene, &params, Hooks::default()).expect("bakes");
    let rt = BakedScene::new(out.file);
    let lights = [Light::Directional {
        direction: Vec3::NEG_Y,
        irradiance: Rgb::splat(1.0),
    }];
    let (direct, at_samples) = rt.direct_with_samples(&lights).unwrap();
    let n = rt.file.n();
    let (mut h, mut b) = (vec![Rgb::ZERO; n], vec![Rgb::ZERO; n]);
    radiosity_core::finish_frame(
        &rt.file.patches,
        &direct,
        &vec![Rgb::ZERO; n],
        &mut h,
        &mut b,
    );
    radiosity_runtime::objects::per_object(&rt.file, &h, &b, &direct, &at_samples, None)
        .into_iter()
        .find(|o| o.name == "floor")
        .expect("the floor object")
        .irradiance[0]
}

#[test]
fn a_wholly_cut_out_sheet_lets_the_sun_through_an_opaque_one_does_not() {
    let cut = floor_irradiance(
        json!({"name": "leaf", "alphaMode": "MASK", "alphaCutoff": 0.5,
        "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 0.2], "metallicFactor": 0.0}}),
    );
    assert!((cut - 1.0).abs() < 0.01, "cut out: {cut}");
    let opaque = floor_irradiance(json!({"name": "leaf",
        "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 0.2], "metallicFactor": 0.0}}));
    // The sheet overhangs the floor by 0.5 m on every side: no direct sun reaches it.
    assert!(opaque < 0.01, "opaque: {opaque}");
}

#[test]
fn a_half_transparent_sheet_passes_half_the_sun_and_its_share_of_the_bounce() {
    // A BLEND sheet of alpha 0.5 (reflectance 0.8) facing down at the floor (0.5) under a
    // sun straight down: the sun crosses it at half strength, and light bounces between the
    // floor and the half of the sheet that is there (the rest lets it out).
    let dir = tempfile::tempdir().unwrap();
    let path = write_pair(
        dir.path(),
        json!({"name": "gauze", "alphaMode": "BLEND",
            "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 0.5], "metallicFactor": 0.0}}),
        true,
    );
    let scene = Scene::load(&path).unwrap();
    assert!(scene.coverage.iter().any(|&c| (c - 0.5).abs() < 1e-6));
    let params = BakeParams {
        voxel: VoxelParams::with_patches(96),
        ..BakeParams::default()
    };
    let out = bake(&scene, &params, Hooks::default()).expect("bakes");
    assert!(out.file.coverage.is_some(), "the file carries the coverage");
    let rt = BakedScene::new(out.file);
    let lights = [Light::Directional {
        direction: Vec3::NEG_Y,
        irradiance: Rgb::splat(1.0),
    }];
    let (direct, at_samples) = rt.direct_with_samples(&lights).unwrap();
    let f = reference_frame(&rt.file, &rt.sent(&direct, &at_samples));
    let got =
        radiosity_runtime::objects::per_object(&rt.file, &f.h, &f.b, &direct, &at_samples, None);
    let direct_only = radiosity_runtime::objects::per_object(
        &rt.file,
        &direct,
        &direct,
        &direct,
        &at_samples,
        None,
    );
    let of = |list: &[radiosity_runtime::objects::ObjectLight], name: &str| {
        list.iter().find(|o| o.name == name).unwrap().irradiance[0]
    };
    // The sun through the sheet: exactly half (the shadow rays' transmittance, no noise).
    let floor_direct = of(&direct_only, "floor");
    assert!(
        (floor_direct - 0.5).abs() < 0.005,
        "floor direct {floor_direct}"
    );
    let reference = PathTracer::new(&scene, &lights)
        .unwrap()
        .object_irradiance(16384, 11);
    for name in ["floor", "sheet"] {
        let want = reference.iter().find(|e| e.name == name).unwrap();
        let w = want.irradiance[0];
        let a = of(&got, name);
        eprintln!(
            "{name}: bake {a:.4}, path tracer {w:.4} ± {:.4}",
            want.stderr[0]
        );
    }
    let want = |name: &str| {
        reference
            .iter()
            .find(|e| e.name == name)
            .unwrap()
            .irradiance[0]
    };
    let (floor, sheet) = (of(&got, "floor"), of(&got, "sheet"));
    // Measured: floor 0.5511 against 0.5516 ± 0.0043, sheet 0.1062 against 0.1059 ± 0.0025.
    // With the form factors to the sheet left at the whole sheet's (its holes reflecting too)
    // the floor came out at 0.615 (+11%): 2% (2.5 of the path tracer's standard errors)
    // catches that; the sheet's 8% is 3.3 of its standard errors.
    assert!(
        (floor - want("floor")).abs() / want("floor") < 0.02,
        "floor {floor}"
    );
    assert!(
        (sheet - want("sheet")).abs() / want("sheet") < 0.08,
        "sheet {sheet}"
    );
}
