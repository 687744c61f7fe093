//! glTF 2.0 loading: the Cornell box copy against its OBJ, the node hierarchy, primitive modes,
//! materials and textures, doubleSided, object names, and bad input that must be one clear
//! error naming the file and what is wrong.

use base64::Engine as _;
use glam::{DMat4, DQuat, DVec3};
use radiosity_bake::scene::{LoadOptions, Scene, SceneError};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes")
}

/// A glTF document under construction: one buffer, written as a data URI by [`Self::write`].
#[derive(Default)]
struct Doc {
    bin: Vec<u8>,
    accessors: Vec<Value>,
    views: Vec<Value>,
    meshes: Vec<Value>,
    nodes: Vec<Value>,
    materials: Vec<Value>,
    extra: serde_json::Map<String, Value>,
}

impl Doc {
    fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn positions(&mut self, p: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = p.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
        let v = self.view(&bytes);
        self.accessors.push(
            json!({"bufferView": v, "componentType": 5126, "count": p.len(), "type": "VEC3"}),
        );
        self.accessors.len() - 1
    }

    fn texcoords(&mut self, t: &[[f32; 2]]) -> usize {
        let bytes: Vec<u8> = t.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
        let v = self.view(&bytes);
        self.accessors.push(
            json!({"bufferView": v, "componentType": 5126, "count": t.len(), "type": "VEC2"}),
        );
        self.accessors.len() - 1
    }

    fn indices(&mut self, i: &[u16]) -> usize {
        let bytes: Vec<u8> = i.iter().flat_map(|c| c.to_le_bytes()).collect();
        let v = self.view(&bytes);
        self.accessors.push(
            json!({"bufferView": v, "componentType": 5123, "count": i.len(), "type": "SCALAR"}),
        );
        self.accessors.len() - 1
    }

    /// A mesh of one primitive; returns its index.
    fn mesh(&mut self, name: Option<&str>, prims: Vec<Value>) -> usize {
        let mut m = json!({"primitives": prims});
        if let Some(n) = name {
            m["name"] = json!(n);
        }
        self.meshes.push(m);
        self.meshes.len() - 1
    }

    fn node(&mut self, n: Value) -> usize {
        self.nodes.push(n);
        self.nodes.len() - 1
    }

    fn json(&self, roots: &[usize]) -> Value {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.bin)
        );
        let mut v = json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": roots}],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{"byteLength": self.bin.len(), "uri": uri}],
        });
        if !self.materials.is_empty() {
            v["materials"] = json!(self.materials);
        }
        for (k, x) in &self.extra {
            v[k] = x.clone();
        }
        v
    }

    fn write(&self, dir: &Path, name: &str, roots: &[usize]) -> PathBuf {
        write(dir, name, &self.json(roots).to_string())
    }
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn prim(positions: usize, indices: Option<usize>, mode: u32) -> Value {
    let mut p = json!({"attributes": {"POSITION": positions}, "mode": mode});
    if let Some(i) = indices {
        p["indices"] = json!(i);
    }
    p
}

/// A unit right triangle in z = 0, front (counter-clockwise) +z, as one node.
fn one_triangle(d: &mut Doc) -> usize {
    let p = d.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let m = d.mesh(None, vec![prim(p, None, 4)]);
    d.node(json!({"mesh": m}))
}

/// A 2×1 PNG: a black texel, then a white one.
fn black_white_png() -> Vec<u8> {
    let mut png = Vec::new();
    image::RgbImage::from_raw(2, 1, vec![0, 0, 0, 255, 255, 255])
        .unwrap()
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    png
}

fn load_err(path: &Path) -> String {
    let e = Scene::load(path).unwrap_err();
    let s = e.to_string();
    assert!(
        s.starts_with(&path.display().to_string()),
        "the message names the file: {s}"
    );
    assert_eq!(s.lines().count(), 1, "one line: {s}");
    s
}

/// The glTF and GLB copies of CornellBox-Original (written by `scripts/obj2gltf.py`, objects
/// under a TRS node, its inverse as a matrix and a pair of mirrors) load to the OBJ's world
/// geometry: same objects, the same triangles with the same winding, the same materials.
#[test]
fn cornell_box_gltf_and_glb_match_the_obj() {
    let obj = Scene::load(&scenes().join("cornell-box/CornellBox-Original.obj")).unwrap();
    for f in ["CornellBox-Original.gltf", "CornellBox-Original.glb"] {
        let g = Scene::load(&scenes().join("cornell-box-gltf").join(f)).unwrap();
        assert_eq!(g.objects, obj.objects, "{f}");
        // The converter drops the OBJ's four duplicate triangles itself.
        assert_eq!(g.triangles.len(), obj.triangles.len(), "{f}");
        assert_eq!(g.report.duplicate_triangles, 0, "{f}");
        for (t, (a, b)) in g.triangles.iter().zip(&obj.triangles).enumerate() {
            assert_eq!(a.object, b.object, "{f} triangle {t}");
            // glTF positions are f32: the OBJ's decimals rounded to f32 differ by at most half
            // an f32 ulp at 2 m, 1.2e-7; the hierarchy composes to the exact identity.
            for (p, q) in g.corners(t).iter().zip(obj.corners(t)) {
                assert!(
                    (*p - q).abs().max_element() < 2e-7,
                    "{f} triangle {t}: {p} vs {q}"
                );
            }
            let (ma, mb) = (
                &g.materials[a.material as usize],
                &obj.materials[b.material as usize],
            );
            assert_eq!(ma.name, mb.name);
            assert_eq!(ma.reflectance, mb.reflectance, "{}", ma.name);
            // Emission: emissiveFactor (f32, the largest channel 1) × emissiveStrength.
            for (x, y) in ma.emission.to_array().iter().zip(mb.emission.to_array()) {
                assert!((x - y).abs() <= 1e-6 * y.abs(), "{}: {x} vs {y}", ma.name);
            }
        }
        for (t, _) in obj.triangles.iter().enumerate() {
            assert!(g.triangle_normal(t).dot(obj.triangle_normal(t)) > 1.0 - 1e-9);
        }
    }
}

/// Nested transforms: TRS (with a 90° rotation), a mirroring matrix (negative determinant)
/// and a translation, applied in f64 in the right order, with the winding flipped so the front
/// faces where the mirrored geometry's front is.
#[test]
fn node_hierarchy_applies_the_world_transform_and_keeps_the_front() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    let leaf = one_triangle(&mut d);
    d.nodes[leaf]["translation"] = json!([0.0, 0.0, 1.0]);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let mirror = [
        -1.0f32, 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0.5, 0., 0., 1.,
    ];
    let mid = d.node(json!({"matrix": mirror, "children": [leaf]}));
    let root = d.node(json!({
        "translation": [1.0, 2.0, 3.0], "rotation": [0.0, 0.0, s, s], "scale": [2.0, 2.0, 2.0],
        "children": [mid]
    }));
    let path = d.write(dir.path(), "h.gltf", &[root]);
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.triangles.len(), 1);

    let q = DQuat::from_xyzw(0.0, 0.0, f64::from(s), f64::from(s)).normalize();
    let world =
        DMat4::from_scale_rotation_translation(DVec3::splat(2.0), q, DVec3::new(1.0, 2.0, 3.0))
            * DMat4::from_cols_array(&mirror.map(f64::from))
            * DMat4::from_translation(DVec3::Z);
    let local = [DVec3::ZERO, DVec3::X, DVec3::Y];
    let expect: Vec<DVec3> = local.iter().map(|&p| world.transform_point3(p)).collect();
    let got = scene.corners(0);
    // The loader's corners are the same set (two swapped for the mirror); f64 arithmetic on
    // the same f32 inputs in another association order: 1e-12.
    for e in &expect {
        assert!(
            got.iter().any(|g| (*g - *e).length() < 1e-12),
            "{e} not in {got:?}"
        );
    }
    // Front: the local +z normal carried by the inverse transpose, which already points to
    // the mirrored front side; the loader's flipped winding must give it (glTF: a negative
    // determinant makes the front clockwise in world space, so the corners are reversed).
    let n = (world.inverse().transpose().transform_vector3(DVec3::Z)).normalize();
    assert!(world.determinant() < 0.0);
    assert!(
        scene.triangle_normal(0).dot(n) > 1.0 - 1e-12,
        "{:?} vs {n}",
        scene.triangle_normal(0)
    );
}

/// A triangle strip of 4 vertices is 2 triangles, a fan of 5 is 3, with alternating strip
/// corners reordered so that every triangle keeps the front of the first; a non-indexed list
/// reads its vertices in order.
#[test]
fn strips_fans_and_non_indexed_lists() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    let strip_p = d.positions(&[[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [1., 1., 0.]]);
    let fan_p = d.positions(&[
        [0., 0., 1.],
        [1., 0., 1.],
        [1., 1., 1.],
        [0.5, 1.5, 1.],
        [0., 1., 1.],
    ]);
    let fan_i = d.indices(&[0, 1, 2, 3, 4]);
    let list_p = d.positions(&[[0., 0., 2.], [1., 0., 2.], [0., 1., 2.]]);
    let m = d.mesh(
        Some("modes"),
        vec![
            prim(strip_p, None, 5),
            prim(fan_p, Some(fan_i), 6),
            prim(list_p, None, 4),
        ],
    );
    let n = d.node(json!({"mesh": m}));
    let scene = Scene::load(&d.write(dir.path(), "modes.gltf", &[n])).unwrap();
    assert_eq!(scene.triangles.len(), 2 + 3 + 1);
    for t in 0..scene.triangles.len() {
        assert!(
            scene.triangle_normal(t).z > 1.0 - 1e-12,
            "triangle {t} faces +z"
        );
    }
    // Areas: strip 1, fan 1.25 (unit square plus a 0.25 gable), list 0.5.
    let total: f64 = (0..6).map(|t| scene.triangle_area(t)).sum();
    assert!((total - 2.75).abs() < 1e-12, "{total}");
    assert_eq!(scene.objects, ["modes"]);
    assert!(
        !scene
            .report
            .warnings
            .iter()
            .any(|w| w.contains("TRIANGLES with")),
        "{:?}",
        scene.report.warnings
    );

    // A list of 5 indices: one triangle, and a warning for the 2 left over.
    let mut d = Doc::default();
    let p = d.positions(&[[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [1., 1., 0.]]);
    let i = d.indices(&[0, 1, 2, 1, 3]);
    let m = d.mesh(Some("short"), vec![prim(p, Some(i), 4)]);
    let n = d.node(json!({"mesh": m}));
    let scene = Scene::load(&d.write(dir.path(), "short.gltf", &[n])).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    let w = scene.report.warnings.join("\n");
    assert!(
        w.contains("TRIANGLES with 5 indices") && w.contains("last 2 ignored"),
        "{w}"
    );
}

#[test]
fn points_and_lines_are_skipped_with_one_warning() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    let p = d.positions(&[[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]]);
    let m = d.mesh(
        None,
        vec![
            prim(p, None, 4),
            prim(p, None, 0),
            prim(p, None, 1),
            prim(p, None, 3),
        ],
    );
    let n = d.node(json!({"mesh": m}));
    let scene = Scene::load(&d.write(dir.path(), "pl.gltf", &[n])).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    let w: Vec<&String> = scene
        .report
        .warnings
        .iter()
        .filter(|w| w.contains("point or line"))
        .collect();
    assert_eq!(w.len(), 1, "{:?}", scene.report.warnings);
    assert!(w[0].contains("3 point or line primitive"), "{}", w[0]);
    // Points and lines alone: refused, and the error says why there is nothing to bake.
    let m = d.mesh(None, vec![prim(p, None, 0), prim(p, None, 1)]);
    let n = d.node(json!({"mesh": m}));
    let e = load_err(&d.write(dir.path(), "lines.gltf", &[n]));
    assert!(
        e.contains("its 2 primitive(s) are points or lines, which have no surface"),
        "{e}"
    );
}

/// Objects: node name, else mesh name, else `node<i>`; a repeated name gets `#2`, `#3`.
#[test]
fn objects_are_named_by_node_then_mesh_and_made_unique() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    let p = d.positions(&[[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]]);
    let named = d.mesh(Some("table"), vec![prim(p, None, 4)]);
    let anon = d.mesh(None, vec![prim(p, None, 4)]);
    let mut roots = Vec::new();
    for (k, (name, mesh)) in [
        (Some("chair"), anon),
        (Some("chair"), anon),
        (None, named),
        (None, anon),
        (Some("chair"), anon),
    ]
    .into_iter()
    .enumerate()
    {
        // Each instance elsewhere, so that none is a duplicate of another.
        let mut n = json!({"mesh": mesh, "translation": [0.0, 0.0, k as f32]});
        if let Some(name) = name {
            n["name"] = json!(name);
        }
        roots.push(d.node(n));
    }
    let scene = Scene::load(&d.write(dir.path(), "names.gltf", &roots)).unwrap();
    assert_eq!(
        scene.objects,
        ["chair", "chair#2", "table", "node3", "chair#3"]
    );
    let per: Vec<u32> = scene.triangles.iter().map(|t| t.object).collect();
    assert_eq!(per, [0, 1, 2, 3, 4]);
}

/// doubleSided: an open surface gets a reversed copy of each triangle (both sides are patches),
/// a closed one does not (its back faces its own inside), with a warning.
#[test]
fn double_sided_open_surfaces_get_a_back_closed_ones_do_not() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    d.materials
        .push(json!({"name": "paper", "doubleSided": true,
        "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0}}));
    let quad = d.positions(&[[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]]);
    let qi = d.indices(&[0, 1, 2, 0, 2, 3]);
    let mut qp = prim(quad, Some(qi), 4);
    qp["material"] = json!(0);
    let qm = d.mesh(Some("sheet"), vec![qp]);
    // A tetrahedron, every face counter-clockwise seen from outside.
    let tet = d.positions(&[[0., 0., 5.], [1., 0., 5.], [0., 1., 5.], [0., 0., 6.]]);
    let ti = d.indices(&[0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]);
    let mut tp = prim(tet, Some(ti), 4);
    tp["material"] = json!(0);
    let tm = d.mesh(Some("tet"), vec![tp]);
    let a = d.node(json!({"mesh": qm}));
    let b = d.node(json!({"mesh": tm}));
    let scene = Scene::load(&d.write(dir.path(), "ds.gltf", &[a, b])).unwrap();
    let sheet: Vec<usize> = (0..scene.triangles.len())
        .filter(|&t| scene.triangles[t].object == 0)
        .collect();
    assert_eq!(sheet.len(), 4, "two triangles and their reversed copies");
    let up = sheet
        .iter()
        .filter(|&&t| scene.triangle_normal(t).z > 0.999)
        .count();
    let down = sheet
        .iter()
        .filter(|&&t| scene.triangle_normal(t).z < -0.999)
        .count();
    assert_eq!((up, down), (2, 2));
    let tet_count = scene.triangles.iter().filter(|t| t.object == 1).count();
    assert_eq!(tet_count, 4, "a closed surface keeps its outside only");
    assert!(
        scene
            .report
            .warnings
            .iter()
            .any(|w| w.contains("1 doubleSided primitive(s) are closed")),
        "{:?}",
        scene.report.warnings
    );
}

/// Materials: reflectance = baseColorFactor × the mean of baseColorTexture (sRGB decoded), the
/// emission π × emissiveFactor × emissiveStrength, a primitive without material grey 0.5, and
/// a baseColorFactor of 1 refused unless the reflectance cap lowers it.
#[test]
fn materials_textures_and_emission() {
    let dir = tempfile::tempdir().unwrap();
    // sRGB 0 and 255, whose linear mean is 0.5.
    let png = black_white_png();
    let mut d = Doc::default();
    d.materials.push(json!({"name": "tex",
        "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.4, 0.2, 1.0], "metallicFactor": 0.0,
            "baseColorTexture": {"index": 0, "texCoord": 1}}}));
    d.materials
        .push(json!({"name": "lamp", "emissiveFactor": [1.0, 0.5, 0.0],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}},
        "pbrMetallicRoughness": {"baseColorFactor": [0.1, 0.1, 0.1, 1.0], "metallicFactor": 0.0}}));
    d.extra.insert(
        "images".into(),
        json!([{"uri": format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(&png))}]),
    );
    d.extra.insert("textures".into(), json!([{"source": 0}]));
    d.extra.insert(
        "extensionsUsed".into(),
        json!(["KHR_materials_emissive_strength"]),
    );
    let p = d.positions(&[[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]]);
    let i = d.indices(&[0, 1, 2, 0, 2, 3]);
    let uv0 = d.texcoords(&[[0.5, 0.5]; 4]);
    let uv1 = d.texcoords(&[[0., 0.], [1., 0.], [1., 1.], [0., 1.]]);
    let mut textured = prim(p, Some(i), 4);
    textured["attributes"]["TEXCOORD_0"] = json!(uv0);
    textured["attributes"]["TEXCOORD_1"] = json!(uv1);
    textured["material"] = json!(0);
    let lamp_p = d.positions(&[[0., 0., 3.], [0., 1., 3.], [1., 0., 3.]]);
    let mut lamp = prim(lamp_p, None, 4);
    lamp["material"] = json!(1);
    let bare_p = d.positions(&[[0., 0., 6.], [1., 0., 6.], [0., 1., 6.]]);
    let m = d.mesh(None, vec![textured, lamp, prim(bare_p, None, 4)]);
    let n = d.node(json!({"mesh": m}));
    let path = d.write(dir.path(), "mat.gltf", &[n]);
    let scene = Scene::load(&path).unwrap();
    let whole = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mean = |t: usize| scene.reflectance_over(t, whole);
    let r = [mean(0), mean(1)];
    // TEXCOORD_1 covers the whole image (TEXCOORD_0 would sample one texel): the two halves
    // of the square average to the texture's mean 0.5, to the lattice's resolution (2%).
    for c in 0..3 {
        let m = 0.5 * (r[0][c] + r[1][c]);
        let f = [0.8, 0.4, 0.2][c];
        assert!((m - 0.5 * f).abs() < 0.02 * f, "channel {c}: {m}");
    }
    let pi = std::f32::consts::PI;
    let lamp = &scene.materials[scene.triangles[2].material as usize];
    assert_eq!(lamp.name, "lamp");
    for (x, y) in lamp
        .emission
        .to_array()
        .iter()
        .zip([4.0 * pi, 2.0 * pi, 0.0])
    {
        assert!((x - y).abs() < 1e-5, "{x} vs {y}");
    }
    assert_eq!(
        scene.triangles[3].material, 0,
        "no material: the grey fallback"
    );
    assert!(
        scene
            .report
            .warnings
            .iter()
            .any(|w| w.contains("without a material"))
    );

    // White as glTF writes it: baseColorFactor 1 over a texture is the texture, not refused and
    // not lowered (its mean over the triangle is 0.636 here).
    let whole = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    d.materials[0]["pbrMetallicRoughness"]["baseColorFactor"] = json!([1.0, 1.0, 1.0, 1.0]);
    let path = d.write(dir.path(), "white.gltf", &[n]);
    let s = Scene::load(&path).unwrap();
    let t = (0..s.triangles.len())
        .find(|&t| s.triangles[t].material == 1)
        .expect("a textured triangle");
    let texture = s.reflectance_over(t, whole);
    assert!(texture.iter().all(|&c| c > 0.5 && c < 1.0), "{texture:?}");
    assert!(!s.report.warnings.iter().any(|w| w.contains("lowered")));
    // A factor that takes the product to 1 or above: lowered to 0.95 by default, to the cap
    // when one is given, with one warning.
    let f = 1.0 / texture[0] as f32 + 0.05;
    d.materials[0]["pbrMetallicRoughness"]["baseColorFactor"] = json!([f, f, f, 1.0]);
    let path = d.write(dir.path(), "bright.gltf", &[n]);
    for (cap, want) in [(None, 0.95), (Some(0.9), 0.9)] {
        let options = LoadOptions {
            max_reflectance: cap,
            ..LoadOptions::default()
        };
        let s = Scene::load_with(&path, &options).unwrap();
        assert_eq!(s.reflectance_over(t, whole), [want; 3]);
        let said: Vec<&String> = s
            .report
            .warnings
            .iter()
            .filter(|w| w.contains("lowered"))
            .collect();
        assert_eq!(said.len(), 1, "{said:?}");
        assert!(
            said[0].contains(&format!("lowered to {want} on")) && said[0].contains("× texture"),
            "{said:?}"
        );
    }
}

/// Ignored features give a warning only when present.
#[test]
fn ignored_features_warn_only_when_present() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    let n = one_triangle(&mut d);
    let plain = Scene::load(&d.write(dir.path(), "plain.gltf", &[n])).unwrap();
    // Its one warning is the missing material's.
    assert!(
        plain.report.warnings.iter().all(|w| !w.contains("ignored")),
        "{:?}",
        plain.report.warnings
    );
    d.extra.insert(
        "cameras".into(),
        json!([{"type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.1}}]),
    );
    d.extra
        .insert("extensionsUsed".into(), json!(["KHR_lights_punctual"]));
    let s = Scene::load(&d.write(dir.path(), "cam.gltf", &[n])).unwrap();
    let all = s.report.warnings.join("\n");
    assert!(
        all.contains("cameras") && all.contains("KHR_lights_punctual"),
        "{all}"
    );
}

#[test]
fn malformed_json_and_glb() {
    let dir = tempfile::tempdir().unwrap();
    let e = load_err(&write(
        dir.path(),
        "bad.gltf",
        "{\"asset\": {\"version\": \"2.0\"},",
    ));
    assert!(e.contains("not a valid glTF JSON file"), "{e}");
    // A GLB cut short: its header promises more bytes than there are.
    let glb = std::fs::read(scenes().join("cornell-box-gltf/CornellBox-Original.glb")).unwrap();
    let p = dir.path().join("short.glb");
    std::fs::write(&p, &glb[..glb.len() / 2]).unwrap();
    let e = load_err(&p);
    assert!(e.contains("not a valid GLB file"), "{e}");
}

/// glTF 1.0 (maps where 2.0 has arrays) is refused by name, as JSON and as GLB (header
/// version 1); a glTF 2.0 scene without `nodes` (optional) loads and is merely empty.
#[test]
fn gltf_1_is_named_and_a_scene_without_nodes_is_valid() {
    let dir = tempfile::tempdir().unwrap();
    let v1 = r#"{"asset":{"version":"1.0"},"meshes":{"m":{"primitives":[]}},"scene":"s","scenes":{"s":{"nodes":[]}}}"#;
    let e = load_err(&write(dir.path(), "v1.gltf", v1));
    assert!(e.contains("glTF 1.0 is not supported"), "{e}");
    let mut glb = b"glTF".to_vec();
    glb.extend(1u32.to_le_bytes());
    glb.extend(20u32.to_le_bytes());
    glb.extend([0u8; 8]);
    let p = dir.path().join("v1.glb");
    std::fs::write(&p, &glb).unwrap();
    let e = load_err(&p);
    assert!(e.contains("glTF 1.0 is not supported"), "{e}");
    let e = load_err(&write(
        dir.path(),
        "empty.gltf",
        r#"{"asset":{"version":"2.0"},"scenes":[{}],"scene":0}"#,
    ));
    assert!(e.contains("no non-degenerate triangle"), "{e}");
    assert!(e.contains("its scene has no nodes"), "{e}");
}

#[test]
fn missing_and_short_buffers() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    let n = one_triangle(&mut d);
    let mut v = d.json(&[n]);
    v["buffers"][0]["uri"] = json!("nowhere.bin");
    let e = load_err(&write(dir.path(), "missing.gltf", &v.to_string()));
    assert!(
        e.contains("buffer 0: cannot read") && e.contains("nowhere.bin"),
        "{e}"
    );
    // An external file two bytes shorter than its byteLength.
    std::fs::write(dir.path().join("short.bin"), &d.bin[..d.bin.len() - 2]).unwrap();
    v["buffers"][0]["uri"] = json!("short.bin");
    let e = load_err(&write(dir.path(), "short.gltf", &v.to_string()));
    assert!(e.contains("fewer than its byteLength 36"), "{e}");
    // The external file read, percent-encoded in the URI.
    std::fs::write(dir.path().join("a b.bin"), &d.bin).unwrap();
    v["buffers"][0]["uri"] = json!("a%20b.bin");
    let s = Scene::load(&write(dir.path(), "ok.gltf", &v.to_string())).unwrap();
    assert_eq!(s.triangles.len(), 1);
}

#[test]
fn accessor_out_of_range_and_index_past_the_vertices() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    let p = d.positions(&[[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]]);
    let i = d.indices(&[0, 1, 3]);
    let m = d.mesh(None, vec![prim(p, Some(i), 4)]);
    let n = d.node(json!({"mesh": m}));
    let e = load_err(&d.write(dir.path(), "idx.gltf", &[n]));
    assert!(
        e.contains("index 3") && e.contains("past the 3 vertices"),
        "{e}"
    );
    let mut v = d.json(&[n]);
    v["accessors"][p]["count"] = json!(4);
    let e = load_err(&write(dir.path(), "count.gltf", &v.to_string()));
    assert!(
        e.contains("accessor 0 (POSITION)") && e.contains("run past the end of buffer view"),
        "{e}"
    );
    let mut v = d.json(&[n]);
    v["bufferViews"][0]["byteLength"] = json!(400);
    let e = load_err(&write(dir.path(), "view.gltf", &v.to_string()));
    assert!(
        e.contains("buffer view 0") && e.contains("runs past the end of buffer 0"),
        "{e}"
    );
    // An index the crate's own validation catches: a mesh that does not exist.
    let mut v = d.json(&[n]);
    v["nodes"][n]["mesh"] = json!(7);
    let e = load_err(&write(dir.path(), "mesh.gltf", &v.to_string()));
    assert!(e.contains("invalid glTF: nodes[0].mesh"), "{e}");
}

#[test]
fn non_finite_positions_also_after_the_transforms() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    let p = d.positions(&[[0., 0., 0.], [f32::NAN, 0., 0.], [0., 1., 0.]]);
    let m = d.mesh(None, vec![prim(p, None, 4)]);
    let n = d.node(json!({"mesh": m}));
    let e = load_err(&d.write(dir.path(), "nan.gltf", &[n]));
    assert!(e.contains("vertex 1 is not finite"), "{e}");
    // Finite f32 scales whose product overflows f64: 1e38^9 = 1e342.
    let mut d = Doc::default();
    let mut top = one_triangle(&mut d);
    for _ in 0..9 {
        top = d.node(json!({"scale": [1e38, 1e38, 1e38], "children": [top]}));
    }
    let e = load_err(&d.write(dir.path(), "inf.gltf", &[top]));
    assert!(e.contains("not finite after the node transforms"), "{e}");
}

#[test]
fn a_cycle_in_the_node_graph_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    let a = one_triangle(&mut d);
    let b = d.node(json!({"children": [a]}));
    d.nodes[a]["children"] = json!([b]);
    let e = load_err(&d.write(dir.path(), "cycle.gltf", &[b]));
    assert!(e.contains("the node graph has a cycle"), "{e}");
    // A node its own child.
    let mut d = Doc::default();
    let a = one_triangle(&mut d);
    d.nodes[a]["children"] = json!([a]);
    let e = load_err(&d.write(dir.path(), "self.gltf", &[a]));
    assert!(e.contains("cycle"), "{e}");
}

#[test]
fn unsupported_required_extensions_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    let n = one_triangle(&mut d);
    for ext in [
        "KHR_draco_mesh_compression",
        "EXT_meshopt_compression",
        "ACME_teleport",
    ] {
        let mut v = d.json(&[n]);
        v["extensionsUsed"] = json!([ext]);
        v["extensionsRequired"] = json!([ext]);
        let e = Scene::load(&write(dir.path(), "ext.gltf", &v.to_string())).unwrap_err();
        assert!(matches!(e, SceneError::UnsupportedExtension { .. }), "{e}");
        assert!(e.to_string().contains(&format!("`{ext}`")), "{e}");
    }
    // The one that is read may be required.
    let mut v = d.json(&[n]);
    v["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    v["extensionsRequired"] = json!(["KHR_materials_emissive_strength"]);
    assert!(Scene::load(&write(dir.path(), "ok.gltf", &v.to_string())).is_ok());
}

/// Loading time of a 100k-triangle grid as glTF and as OBJ (run with `--ignored
/// --nocapture`; a measurement, not a check).
#[test]
#[ignore]
fn load_time_100k_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let k = 224usize; // 224² quads × 2 = 100 352 triangles
    let mut pos = Vec::new();
    let mut obj = String::from("o grid\n");
    for y in 0..=k {
        for x in 0..=k {
            pos.push([x as f32, y as f32, 0.0]);
            obj.push_str(&format!("v {x} {y} 0\n"));
        }
    }
    let mut idx = Vec::new();
    for y in 0..k {
        for x in 0..k {
            let a = (y * (k + 1) + x) as u32;
            let (b, c, d) = (a + 1, a + (k as u32) + 2, a + (k as u32) + 1);
            idx.extend_from_slice(&[a, b, c, a, c, d]);
            obj.push_str(&format!(
                "f {} {} {}\nf {} {} {}\n",
                a + 1,
                b + 1,
                c + 1,
                a + 1,
                c + 1,
                d + 1
            ));
        }
    }
    let mut bin: Vec<u8> = pos.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
    let plen = bin.len();
    bin.extend(idx.iter().flat_map(|i| i.to_le_bytes()));
    std::fs::write(dir.path().join("grid.bin"), &bin).unwrap();
    let g = json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "grid"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": pos.len(), "type": "VEC3"},
            {"bufferView": 1, "componentType": 5125, "count": idx.len(), "type": "SCALAR"}],
        "bufferViews": [{"buffer": 0, "byteLength": plen},
            {"buffer": 0, "byteOffset": plen, "byteLength": bin.len() - plen}],
        "buffers": [{"uri": "grid.bin", "byteLength": bin.len()}]
    });
    let gp = write(dir.path(), "grid.gltf", &g.to_string());
    let op = write(dir.path(), "grid.obj", &obj);
    for p in [&gp, &op, &gp, &op] {
        let t = std::time::Instant::now();
        let s = Scene::load(p).unwrap();
        println!(
            "{}: {} triangles in {:.1} ms",
            p.display(),
            s.triangles.len(),
            t.elapsed().as_secs_f64() * 1e3
        );
        assert_eq!(s.triangles.len(), 2 * k * k);
    }
}

/// `COLOR_0` multiplies the base colour, linearly over each triangle (float VEC3 and
/// normalised u8 VEC4 alike); a primitive without it beside one with it stays white; a
/// negative colour is refused.
#[test]
fn vertex_colours_multiply_the_base_colour() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    d.materials
        .push(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0]}}));
    let p = d.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let colours: Vec<u8> = [[1.0f32, 0.5, 0.0], [1.0, 0.5, 0.0], [1.0, 0.5, 0.75]]
        .iter()
        .flatten()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    let v = d.view(&colours);
    d.accessors
        .push(json!({"bufferView": v, "componentType": 5126, "count": 3, "type": "VEC3"}));
    let c = d.accessors.len() - 1;
    let q = d.positions(&[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]);
    let u8s = d.view(&[255, 0, 0, 255, 255, 0, 0, 255, 255, 0, 0, 255]);
    d.accessors.push(json!({"bufferView": u8s, "componentType": 5121, "normalized": true, "count": 3, "type": "VEC4"}));
    let c8 = d.accessors.len() - 1;
    let r = d.positions(&[[0.0, 0.0, 2.0], [1.0, 0.0, 2.0], [0.0, 1.0, 2.0]]);
    let mut coloured = prim(p, None, 4);
    coloured["attributes"]["COLOR_0"] = json!(c);
    coloured["material"] = json!(0);
    let mut red = prim(q, None, 4);
    red["attributes"]["COLOR_0"] = json!(c8);
    red["material"] = json!(0);
    let mut plain = prim(r, None, 4);
    plain["material"] = json!(0);
    let m = d.mesh(Some("coloured"), vec![coloured, red, plain]);
    let n = d.node(json!({"mesh": m}));
    let s = Scene::load(&d.write(dir.path(), "colours.gltf", &[n])).unwrap();
    let whole = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|k| (a[k] - b[k]).abs() < 1e-6);
    // The mean of a linear colour over a triangle is the mean of its corners: 1, 0.5, 0.25.
    let got = s.reflectance_over(0, whole);
    assert!(close(got, [0.8, 0.4, 0.2]), "{got:?}");
    let got = s.reflectance_over(1, whole);
    assert!(close(got, [0.8, 0.0, 0.0]), "{got:?}");
    let got = s.reflectance_over(2, whole);
    assert!(close(got, [0.8, 0.8, 0.8]), "{got:?}");

    // Negative: refused, naming COLOR_0.
    let neg: Vec<u8> = [[-1.0f32, 0.5, 0.0]; 3]
        .iter()
        .flatten()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    let v = d.view(&neg);
    d.accessors
        .push(json!({"bufferView": v, "componentType": 5126, "count": 3, "type": "VEC3"}));
    d.meshes[m]["primitives"][0]["attributes"]["COLOR_0"] = json!(d.accessors.len() - 1);
    let e = load_err(&d.write(dir.path(), "negative.gltf", &[n]));
    assert!(e.contains("COLOR_0 of vertex 0"), "{e}");
}

/// `COLOR_0` alpha multiplies `baseColorFactor` alpha under MASK and BLEND, interpolated
/// over the triangle; under OPAQUE it is ignored (as glTF says of every alpha there).
#[test]
fn vertex_colour_alpha_multiplies_the_coverage() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    d.materials.push(json!({"alphaMode": "BLEND",
        "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 0.8], "metallicFactor": 0.0}}));
    let p = d.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let colours: Vec<u8> = [
        [1.0f32, 1.0, 1.0, 1.0],
        [1.0, 1.0, 1.0, 1.0],
        [1.0, 1.0, 1.0, 0.25],
    ]
    .iter()
    .flatten()
    .flat_map(|c| c.to_le_bytes())
    .collect();
    let v = d.view(&colours);
    d.accessors
        .push(json!({"bufferView": v, "componentType": 5126, "count": 3, "type": "VEC4"}));
    let mut tri = prim(p, None, 4);
    tri["attributes"]["COLOR_0"] = json!(d.accessors.len() - 1);
    tri["material"] = json!(0);
    let m = d.mesh(Some("veil"), vec![tri]);
    let n = d.node(json!({"mesh": m}));
    // BLEND: 0.8 × the mean of the corners' alphas (1, 1, 0.25) = 0.6; the lattice's
    // centroids average a linear alpha exactly, so only f32 rounding is left.
    let s = Scene::load(&d.write(dir.path(), "blend.gltf", &[n])).unwrap();
    assert!((s.coverage[0] - 0.6).abs() < 1e-5, "{:?}", s.coverage);
    // MASK at 0.5: alpha 0.8·(1 − 0.75·w) for the weight w of the third corner reaches the
    // cutoff where w ≤ 1/2, all but the corner triangle of a quarter of the area: 0.75, to
    // the 16-part lattice's resolution (its bands are 1/16 of the triangle's height).
    d.materials[0]["alphaMode"] = json!("MASK");
    let s = Scene::load(&d.write(dir.path(), "mask.gltf", &[n])).unwrap();
    assert!((s.coverage[0] - 0.75).abs() < 0.07, "{:?}", s.coverage);
    // OPAQUE: no coverage.
    d.materials[0]["alphaMode"] = json!("OPAQUE");
    let s = Scene::load(&d.write(dir.path(), "opaque.gltf", &[n])).unwrap();
    assert!(s.coverage.is_empty(), "{:?}", s.coverage);
}

/// `KHR_texture_transform` moves the UVs before the texture is sampled (offset, rotation,
/// scale as the extension's specification composes them; its `texCoord` picks the set); a
/// non-finite one is refused.
#[test]
fn texture_transform_moves_the_uvs() {
    let dir = tempfile::tempdir().unwrap();
    // Black on the left half (u < 0.5), white on the right.
    let png = black_white_png();
    let build = |transform: Value| {
        let mut d = Doc::default();
        d.materials.push(
            json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0],
            "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": transform}}}}),
        );
        d.extra.insert(
            "images".into(),
            json!([{"uri": format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(&png))}]),
        );
        d.extra.insert("textures".into(), json!([{"source": 0}]));
        d.extra
            .insert("extensionsUsed".into(), json!(["KHR_texture_transform"]));
        let p = d.positions(&[[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]]);
        // Every corner at (0.25, 0.5): the black texel's centre.
        let uv = d.texcoords(&[[0.25, 0.5]; 3]);
        let uv1 = d.texcoords(&[[0.75, 0.5]; 3]);
        let mut t = prim(p, None, 4);
        t["attributes"]["TEXCOORD_0"] = json!(uv);
        t["attributes"]["TEXCOORD_1"] = json!(uv1);
        t["material"] = json!(0);
        let m = d.mesh(None, vec![t]);
        let n = d.node(json!({"mesh": m}));
        d.json(&[n]).to_string()
    };
    let whole = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let red = |transform: Value, name: &str| {
        let s = Scene::load(&write(dir.path(), name, &build(transform))).unwrap();
        assert!(
            !s.report
                .warnings
                .iter()
                .any(|w| w.contains("KHR_texture_transform")),
            "{:?}",
            s.report.warnings
        );
        s.reflectance_over(0, whole)[0]
    };
    assert!(
        red(json!({}), "none.gltf") < 1e-3,
        "the black texel as given"
    );
    assert!((red(json!({"offset": [0.5, 0.0]}), "offset.gltf") - 0.8).abs() < 1e-3);
    // A half turn about the origin: (0.25, 0.5) to (-0.25, -0.5), wrapped to (0.75, 0.5).
    let half = json!({"rotation": std::f64::consts::PI});
    assert!((red(half, "rotation.gltf") - 0.8).abs() < 1e-3);
    // Scale 3 in u: 0.75, white; texCoord 1 picks the set at u = 0.75, white too. At a
    // texel's centre the bilinear sample is that texel alone; 1e-3 covers f32 UVs.
    assert!((red(json!({"scale": [3.0, 1.0]}), "scale.gltf") - 0.8).abs() < 1e-3);
    assert!((red(json!({"texCoord": 1}), "set.gltf") - 0.8).abs() < 1e-3);
    // Malformed: the file is refused, naming it.
    let e = load_err(&write(
        dir.path(),
        "bad.gltf",
        &build(json!({"offset": "left"})),
    ));
    assert!(e.contains("bad.gltf"), "{e}");
}

/// `alphaMode`: MASK keeps the fraction of each triangle at or above `alphaCutoff`, BLEND its
/// mean alpha; a triangle of coverage 0 is left out with one warning; an opaque scene has no
/// coverage at all; a bad `alphaCutoff` is one error line.
#[test]
fn alpha_mask_and_blend_coverage() {
    let dir = tempfile::tempdir().unwrap();
    // A 2×1 RGBA PNG: white, alpha 0 on the left texel, 1 on the right.
    let mut png = Vec::new();
    image::RgbaImage::from_raw(2, 1, vec![255, 255, 255, 0, 255, 255, 255, 255])
        .unwrap()
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let mut d = Doc::default();
    d.materials.push(json!({"name": "leaf", "alphaMode": "MASK",
        "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0,
            "baseColorTexture": {"index": 0}}}));
    d.materials.push(json!({"name": "solid",
        "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0}}));
    d.extra.insert(
        "images".into(),
        json!([{"uri": format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(&png))}]),
    );
    d.extra.insert("textures".into(), json!([{"source": 0}]));
    let p = d.positions(&[[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]]);
    let i = d.indices(&[0, 1, 2, 0, 2, 3]);
    let uv = d.texcoords(&[[0., 0.], [1., 0.], [1., 1.], [0., 1.]]);
    let mut sheet = prim(p, Some(i), 4);
    sheet["attributes"]["TEXCOORD_0"] = json!(uv);
    sheet["material"] = json!(0);
    let solid_p = d.positions(&[[0., 0., 2.], [1., 0., 2.], [0., 1., 2.]]);
    let mut solid = prim(solid_p, None, 4);
    solid["material"] = json!(1);
    let m = d.mesh(None, vec![sheet, solid]);
    let n = d.node(json!({"mesh": m}));

    let s = Scene::load(&d.write(dir.path(), "mask.gltf", &[n])).unwrap();
    assert_eq!(s.triangles.len(), 3);
    assert_eq!(s.coverage.len(), 3, "aligned with the triangles");
    // The right half of the square is kept: 3/4 of the lower-right triangle, 1/4 of the other,
    // a half in all, to the sampling lattice's resolution (64 per side, 3%).
    let (a, b) = (f64::from(s.coverage[0]), f64::from(s.coverage[1]));
    assert!(
        (a - 0.75).abs() < 0.03 && (b - 0.25).abs() < 0.03,
        "{a} {b}"
    );
    assert_eq!(s.coverage[2], 1.0, "the opaque triangle");
    // Partial coverage is baked as such (light passes by the share cut out): no warning.
    assert!(
        !s.report.warnings.iter().any(|w| w.contains("cut out")),
        "{:?}",
        s.report.warnings
    );

    // BLEND: the mean alpha, a half over the square (bilinear alpha, symmetric about u = ½).
    d.materials[0]["alphaMode"] = json!("BLEND");
    let s = Scene::load(&d.write(dir.path(), "blend.gltf", &[n])).unwrap();
    let mean = 0.5 * f64::from(s.coverage[0] + s.coverage[1]);
    assert!((mean - 0.5).abs() < 0.03, "{mean}");

    // MASK with a factor alpha under the cutoff: the whole sheet is cut out and left out.
    d.materials[0]["alphaMode"] = json!("MASK");
    d.materials[0]["alphaCutoff"] = json!(0.8);
    d.materials[0]["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.5, 0.5, 0.5, 0.7]);
    let s = Scene::load(&d.write(dir.path(), "gone.gltf", &[n])).unwrap();
    assert_eq!(s.triangles.len(), 1, "only the opaque triangle");
    assert!(s.coverage.is_empty(), "what is left is opaque");
    let said: Vec<&String> = s
        .report
        .warnings
        .iter()
        .filter(|w| w.contains("cut out"))
        .collect();
    assert_eq!(said.len(), 1, "{said:?}");
    assert!(said[0].contains("2 triangle(s) wholly cut out"), "{said:?}");

    // OPAQUE (the default): no coverage, as before.
    d.materials[0].as_object_mut().unwrap().remove("alphaMode");
    let s = Scene::load(&d.write(dir.path(), "opaque.gltf", &[n])).unwrap();
    assert_eq!(s.triangles.len(), 3);
    assert!(s.coverage.is_empty());

    // A negative alphaCutoff: one error line naming it.
    d.materials[0]["alphaMode"] = json!("MASK");
    d.materials[0]["alphaCutoff"] = json!(-1.0);
    let e = load_err(&d.write(dir.path(), "bad.gltf", &[n]));
    assert!(e.contains("alphaCutoff -1"), "{e}");
}
