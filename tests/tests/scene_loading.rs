//! OBJ + MTL loading: the real scene files with their quirks, and bad input that must be a
//! clear error naming the file and line.

use radiosity_bake::scene::{DEFAULT_REFLECTANCE, LoadOptions, Scene, SceneError};
use std::path::{Path, PathBuf};

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes")
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// CornellBox-Original: CRLF line ends, `g` after the faces it was meant for, and each block's
/// "bottom face" repeating a side face. The duplicates are dropped (4 triangles: two quads), the
/// object names follow the file literally (`g` names, each once).
#[test]
fn mcguire_cornell_box_loads_with_its_quirks() {
    let s = Scene::load_obj(&scenes().join("cornell-box/CornellBox-Original.obj")).unwrap();
    assert_eq!(s.report.duplicate_triangles, 4, "{:?}", s.report);
    assert_eq!(s.report.degenerate_triangles, 0);
    assert_eq!(
        s.objects,
        [
            "floor",
            "ceiling",
            "backWall",
            "rightWall",
            "leftWall",
            "shortBox",
            "light"
        ]
    );
    // 8 quads of walls/light + 2 blocks × 5 distinct quads = 18 quads = 36 triangles, minus
    // nothing else: 32 after the 4 duplicates.
    assert_eq!(s.triangles.len(), 32);
    let light = s.materials.iter().find(|m| m.name == "light").unwrap();
    let pi = std::f32::consts::PI;
    assert!(
        (light.emission.r - 17.0 * pi).abs() < 1e-4,
        "exitance is π·Ke: {:?}",
        light.emission
    );
    assert!((light.reflectance.g - 0.78).abs() < 1e-6);
    // The room is about 2 m: total area of the six walls' worth of quads.
    let total: f64 = s.object_areas().iter().sum();
    assert!(total > 20.0 && total < 30.0, "total area {total}");
}

#[test]
fn other_cornell_files_load() {
    for f in [
        "cornell-box/CornellBox-Empty-RG.obj",
        "cornell-original/cornell_box_data.obj",
    ] {
        let s = Scene::load_obj(&scenes().join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert!(
            s.triangles.len() >= 10,
            "{f}: {} triangles",
            s.triangles.len()
        );
        assert!(
            s.materials
                .iter()
                .all(|m| m.reflectance.max_channel() < 1.0)
        );
    }
    // CornellBox-Empty-White's walls and tinyobjloader's boxes have Kd 1 1 1: a perfect
    // reflector (the multi-bounce series would not converge), which every triangle shows
    // lowered to 0.95, with one warning naming the materials and the share of the surface.
    let whole = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for f in [
        "cornell-box/CornellBox-Empty-White.obj",
        "tinyobjloader/cornell_box.obj",
        "tinyobjloader/cornell_box_multimaterial.obj",
    ] {
        let s = Scene::load_obj(&scenes().join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        let said: Vec<&String> = s
            .report
            .warnings
            .iter()
            .filter(|w| w.contains("lowered to 0.95"))
            .collect();
        assert_eq!(said.len(), 1, "{f}: {:?}", s.report.warnings);
        assert!(said[0].contains("% of the surface"), "{said:?}");
        assert!(
            (0..s.triangles.len()).all(|t| s.reflectance_over(t, whole).iter().all(|&c| c < 1.0)),
            "{f}"
        );
    }
    let s = Scene::load_obj(&scenes().join("cornell-original/cornell_box_data.obj")).unwrap();
    assert!(s.objects.iter().any(|o| o == "light"));
}

#[test]
fn bad_input_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: [(&str, &str, &str); 5] = [
        (
            "nan.obj",
            "v 0 0 0\nv 1 0 0\nv 0 NaN 0\nf 1 2 3\n",
            "nan.obj:3:",
        ),
        (
            "inf.obj",
            "v 0 0 0\nv 1e400 0 0\nv 0 1 0\nf 1 2 3\n",
            "inf.obj:2:",
        ),
        (
            "range.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
            "range.obj:4:",
        ),
        ("neg.obj", "v 0 0 0\nv 1 0 0\nf -1 -2 -3\n", "neg.obj:3:"),
        ("garbage.obj", "v 0 0 zero\n", "garbage.obj:1:"),
    ];
    for (name, text, want) in cases {
        let p = write(d, name, text);
        let e = Scene::load_obj(&p).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains(want),
            "{name}: message `{msg}` should name `{want}`"
        );
        assert!(matches!(e, SceneError::Parse { .. }), "{name}: {e:?}");
    }
    // Missing file.
    let e = Scene::load_obj(&d.join("nope.obj")).unwrap_err();
    assert!(
        matches!(e, SceneError::Io { .. }) && e.to_string().contains("nope.obj"),
        "{e}"
    );
    // Reflectance below 0 names the MTL file and the `newmtl` line.
    write(
        d,
        "dark.mtl",
        "# c\nnewmtl ok\nKd 0.5 0.5 0.5\n\nnewmtl hole\nKd -1 0.2 0.2\n",
    );
    let p = write(
        d,
        "dark.obj",
        "mtllib dark.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl hole\nf 1 2 3\n",
    );
    let e = Scene::load_obj(&p).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("dark.mtl:5") && msg.contains("hole"), "{msg}");
    // Negative emission.
    write(d, "neg.mtl", "newmtl lamp\nKd 0.5 0.5 0.5\nKe -1 0 0\n");
    let p = write(
        d,
        "negke.obj",
        "mtllib neg.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl lamp\nf 1 2 3\n",
    );
    assert!(Scene::load_obj(&p).unwrap_err().to_string().contains("Ke"));
    // Only degenerate triangles: nothing to bake.
    let p = write(d, "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
    assert!(matches!(
        Scene::load_obj(&p).unwrap_err(),
        SceneError::EmptyScene { .. }
    ));
}

/// A reflectance cap lowers Kd 1 1 1 (CornellBox-Empty-White's walls) to the cap, channel by
/// channel, with a warning naming the MTL line; channels below the cap stay as they are.
#[test]
fn a_reflectance_cap_lowers_white_instead_of_refusing_it() {
    let path = scenes().join("cornell-box/CornellBox-Empty-White.obj");
    let whole = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for (cap, threshold, lowered) in [(Some(0.8), 0.8, 0.8), (None, 1.0, 0.95)] {
        let options = LoadOptions {
            max_reflectance: cap,
            ..LoadOptions::default()
        };
        let s = Scene::load_obj_with(&path, &options).unwrap();
        let said: Vec<&String> = s
            .report
            .warnings
            .iter()
            .filter(|w| w.contains("lowered to"))
            .collect();
        assert_eq!(said.len(), 1, "one warning: {:?}", s.report.warnings);
        assert!(
            said[0].contains(&format!("lowered to {lowered} on")),
            "{said:?}"
        );
        // Every triangle shows its material's Kd, each channel at or above the threshold
        // lowered to the cap, the others as they are.
        for t in 0..s.triangles.len() {
            let kd = s.materials[s.triangles[t].material as usize].reflectance;
            let got = s.reflectance_over(t, whole);
            for k in 0..3 {
                let was = f64::from(kd.channel(k));
                let want = if was >= threshold { lowered } else { was };
                assert_eq!(got[k], want, "triangle {t} channel {k}");
            }
        }
        assert!((0..s.triangles.len()).any(|t| s.reflectance_over(t, whole)[0] == lowered));
    }
}

#[test]
fn missing_mtl_is_grey_with_a_warning_and_degenerates_are_counted() {
    let dir = tempfile::tempdir().unwrap();
    let text =
        "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nusemtl red\nf 1 2 3\nf 1 2 4\n";
    let p = write(dir.path(), "grey.obj", text);
    let s = Scene::load_obj(&p).unwrap();
    assert_eq!(s.triangles.len(), 1);
    assert_eq!(s.report.degenerate_triangles, 1);
    assert!(
        s.report.warnings.iter().any(|w| w.contains("gone.mtl")),
        "{:?}",
        s.report.warnings
    );
    let m = &s.materials[s.triangles[0].material as usize];
    assert_eq!(m.reflectance.r, DEFAULT_REFLECTANCE);
}

#[test]
fn objects_polygons_and_opposite_windings() {
    let dir = tempfile::tempdir().unwrap();
    // `o` wins over `g`; a name used twice is one object; a pentagon becomes three triangles;
    // the same quad with opposite winding is a two-sided sheet, not a duplicate.
    let text = "o a\ng part\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -0.5 0.5 0\nf 1 2 3 4 5\no b\nf 4 3 2 1\no a\nf 1 2 3\n";
    let s = Scene::load_obj(&write(dir.path(), "objs.obj", text)).unwrap();
    assert_eq!(s.objects, ["a", "b"]);
    assert_eq!(
        s.report.duplicate_triangles, 1,
        "the last face repeats the pentagon's first triangle"
    );
    assert_eq!(s.triangles.len(), 5);
    let areas = s.object_areas();
    // Pentagon area 1 + 0.25, quad area 1.
    assert!(
        (areas[0] - 1.25).abs() < 1e-12 && (areas[1] - 1.0).abs() < 1e-12,
        "{areas:?}"
    );
    assert!(s.triangle_normal(0).z > 0.99 && s.triangle_normal(3).z < -0.99);
}

/// `map_Kd` multiplies `Kd` by the texture's mean over each patch (after sRGB decoding).
#[test]
fn texture_is_averaged() {
    let dir = tempfile::tempdir().unwrap();
    // 2×1 texture: left texel sRGB 255 (linear 1), right texel 0.
    let img = image::RgbImage::from_raw(2, 1, vec![255, 255, 255, 0, 0, 0]).unwrap();
    img.save(dir.path().join("half.png")).unwrap();
    write(
        dir.path(),
        "t.mtl",
        "newmtl tex\nKd 0.8 0.8 0.8\nmap_Kd half.png\n",
    );
    let text = "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl tex\nf 1/1 2/2 3/3 4/4\n";
    let s = Scene::load_obj(&write(dir.path(), "t.obj", text)).unwrap();
    let p = radiosity_bake::simplify::simplify(
        &s,
        &radiosity_bake::simplify::VoxelParams::with_cell_size(10.0),
    )
    .unwrap();
    assert_eq!(p.len(), 1);
    let r = p.patches[0].reflectance.r;
    // Mean of the texture over the whole square is 0.5 (bilinear wrap keeps it symmetric), so
    // ρ = 0.8·0.5; 2% for the sampling lattice.
    assert!((r - 0.4).abs() < 0.008, "textured reflectance {r}");
}
