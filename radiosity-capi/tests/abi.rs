//! The exported functions called from Rust as a C host would: results equal to the crates
//! behind them, zero-copy patches, copies where promised, in-place calls, refusals.

use radiosity_capi::*;
use radiosity_core::{DecodeMode, Format, Gather, RadFile, ReferenceGather, Rgb};
use radiosity_tests::fixtures::{exitance, sample_file};
use std::ffi::{CStr, c_char};
use std::ptr::{null, null_mut};

fn last_error() -> String {
    // SAFETY: rad_last_error never returns NULL; the string lives until this thread's next call.
    unsafe { CStr::from_ptr(rad_last_error()) }
        .to_string_lossy()
        .into_owned()
}

fn c_str<'a>(p: *const c_char) -> &'a str {
    assert!(!p.is_null(), "NULL string: {}", last_error());
    // SAFETY: non-NULL strings from the library are NUL-terminated and live as long as their
    // owner, which outlives every use in these tests.
    unsafe { CStr::from_ptr(p) }.to_str().unwrap()
}

/// A scene parsed from `file`'s bytes, the bytes dropped before the scene is used.
fn scene_of(file: &RadFile<'_>) -> *mut RadScene {
    let bytes = file.to_bytes().unwrap();
    let mut scene = null_mut();
    // SAFETY: `bytes` is a live slice and `scene` a writable pointer.
    let code = unsafe { rad_scene_from_bytes(bytes.as_ptr(), bytes.len(), &mut scene) };
    assert_eq!(code, RAD_OK, "{}", last_error());
    drop(bytes);
    scene
}

fn as_rad(v: &[Rgb]) -> &[RadRgb] {
    bytemuck::cast_slice(v)
}

fn as_rad_mut(v: &mut [Rgb]) -> &mut [RadRgb] {
    bytemuck::cast_slice_mut(v)
}

#[test]
fn scene_reads_as_the_file() {
    let file = sample_file(70, 3, Format::Bc1, 32);
    let scene = scene_of(&file);
    // SAFETY (this and every call below): `scene` is live until rad_scene_free at the end and
    // every array passed has the length given.
    unsafe {
        assert_eq!(rad_scene_patch_count(scene), 70);
        let patches = std::slice::from_raw_parts(rad_scene_patches(scene), 70);
        for (p, q) in patches.iter().zip(file.patches.iter()) {
            assert_eq!(bytemuck::bytes_of(p), bytemuck::bytes_of(q));
        }
        // The same array every time: owned by the scene, not copied per call.
        assert_eq!(rad_scene_patches(scene), rad_scene_patches(scene));
        assert_eq!(rad_scene_object_count(scene), 2);
        assert_eq!(c_str(rad_scene_object_name(scene, 0)), "floor");
        assert_eq!(c_str(rad_scene_object_name(scene, 1)), "wall ünïcode");
        assert!(rad_scene_object_name(scene, 2).is_null());
        assert!(last_error().contains("past the end"), "{}", last_error());
        let mesh = file.mesh.as_ref().unwrap();
        assert_eq!(rad_scene_triangle_count(scene), mesh.triangles.len());
        assert_eq!(rad_scene_vertex_count(scene), mesh.positions.len());
        let tris = std::slice::from_raw_parts(rad_scene_triangles(scene), mesh.triangles.len());
        assert_eq!(tris[1].vertices, mesh.triangles[1].vertices);
        let verts = std::slice::from_raw_parts(rad_scene_vertices(scene), 3 * mesh.positions.len());
        assert_eq!(&verts[6..9], &mesh.positions[2]);
        rad_scene_free(scene);
    }
}

#[test]
fn gathers_and_corner_light_equal_the_crates() {
    let file = sample_file(70, 3, Format::Bc1, 32);
    let n = file.n();
    let scene = scene_of(&file);
    let x = exitance(n, 5);
    let mut want = vec![Rgb::ZERO; n];
    ReferenceGather::new(file.matrix.clone(), DecodeMode::D3d10)
        .gather(&x, &mut want)
        .unwrap();
    // SAFETY (this and every call below): `scene` and each gather are live until freed at the
    // end, and every array passed has the length given.
    unsafe {
        let mut reference = null_mut();
        assert_eq!(
            rad_gather_new(scene, c"reference".as_ptr(), &mut reference),
            RAD_OK
        );
        assert_eq!(c_str(rad_gather_name(reference)), "reference");
        assert_eq!(c_str(rad_gather_backend(reference)), "reference");
        let mut y = vec![Rgb::ZERO; n];
        let code = rad_gather_run(
            reference,
            as_rad(&x).as_ptr(),
            as_rad_mut(&mut y).as_mut_ptr(),
            n,
        );
        assert_eq!(code, RAD_OK, "{}", last_error());
        assert_eq!(y, want);

        // In place: x and y the same array.
        let mut inout = x.clone();
        let p = as_rad_mut(&mut inout).as_mut_ptr();
        assert_eq!(rad_gather_run(reference, p, p, n), RAD_OK);
        assert_eq!(inout, want);

        let mut cpu = null_mut();
        assert_eq!(rad_gather_new(scene, c"cpu".as_ptr(), &mut cpu), RAD_OK);
        assert_eq!(c_str(rad_gather_name(cpu)), "cpu-bc1");
        let mut y_cpu = vec![Rgb::ZERO; n];
        assert_eq!(
            rad_gather_run(
                cpu,
                as_rad(&x).as_ptr(),
                as_rad_mut(&mut y_cpu).as_mut_ptr(),
                n
            ),
            RAD_OK
        );
        let mut want_cpu = vec![Rgb::ZERO; n];
        radiosity_backend_cpu::CpuGather::new(file.matrix.clone())
            .gather(&x, &mut want_cpu)
            .unwrap();
        assert_eq!(y_cpu, want_cpu);

        // "auto" chooses as the CLI does: the GPU only where auto_gather finds a hardware one.
        let mut auto = null_mut();
        assert_eq!(rad_gather_new(scene, c"auto".as_ptr(), &mut auto), RAD_OK);
        let gpu_ok = radiosity_backend_wgpu::auto_gather(
            &file.matrix,
            &radiosity_backend_wgpu::GpuOptions::default(),
        )
        .is_ok();
        assert_eq!(
            c_str(rad_gather_backend(auto)),
            if gpu_ok { "gpu" } else { "cpu" }
        );

        // Corner light equals the core's, bit for bit, also written over y itself.
        let mesh = file.mesh.as_ref().unwrap();
        let corners = mesh.corner_count();
        let mut want_corners = vec![Rgb::ZERO; corners];
        mesh.corner_indirect(&want, &mut want_corners).unwrap();
        let mut got = vec![Rgb::ZERO; corners];
        let code = rad_scene_corner_indirect(
            scene,
            as_rad(&want).as_ptr(),
            n,
            as_rad_mut(&mut got).as_mut_ptr(),
            corners,
        );
        assert_eq!(code, RAD_OK, "{}", last_error());
        assert_eq!(got, want_corners);
        let mut shared = want.clone();
        let p = as_rad_mut(&mut shared).as_mut_ptr();
        assert_eq!(rad_scene_corner_indirect(scene, p, n, p, corners), RAD_OK);
        assert_eq!(&shared[..corners], &want_corners[..]);

        // First exitance equals the core's, in place too.
        let direct = exitance(n, 9);
        let mut want_x = vec![Rgb::ZERO; n];
        radiosity_core::first_exitance(&file.patches, &direct, &mut want_x);
        let mut got_x = direct.clone();
        let p = as_rad_mut(&mut got_x).as_mut_ptr();
        assert_eq!(rad_first_exitance(scene, p, p, n), RAD_OK);
        assert_eq!(got_x, want_x);

        rad_gather_free(auto);
        rad_gather_free(cpu);
        rad_gather_free(reference);
        rad_scene_free(scene);
    }
}

#[test]
fn bad_input_is_refused_with_a_message() {
    let mut file = sample_file(40, 1, Format::Bc4, 16);
    file.mesh = None;
    let n = file.n();
    let scene = scene_of(&file);
    // SAFETY (this and every call below): `scene` and `gather` are live until freed at the
    // end; every array passed is at least as long as given, except where the call is meant to
    // be refused for its length before reading.
    unsafe {
        let mut gather = null_mut();
        assert_eq!(rad_gather_new(scene, c"cpu".as_ptr(), &mut gather), RAD_OK);
        let x = vec![Rgb::ONE; n + 1];
        let mut y = vec![Rgb::ZERO; n + 1];
        let (xp, yp) = (as_rad(&x).as_ptr(), as_rad_mut(&mut y).as_mut_ptr());
        let cases: [(i32, i32); 8] = [
            (rad_gather_run(gather, xp, yp, n + 1), RAD_ERR_LENGTH),
            (rad_gather_run(gather, null(), yp, n), RAD_ERR_POINTER),
            // Misaligned: one byte into the array.
            (
                rad_gather_run(gather, xp.cast::<u8>().add(1).cast(), yp, n),
                RAD_ERR_POINTER,
            ),
            (
                rad_scene_corner_indirect(scene, xp, n, yp, 0),
                RAD_ERR_NO_MESH,
            ),
            (
                rad_gather_new(scene, c"metal".as_ptr(), &mut null_mut()),
                RAD_ERR_BACKEND,
            ),
            (
                rad_gather_new(scene, c"\xff".as_ptr(), &mut null_mut()),
                RAD_ERR_VALUE,
            ),
            (
                rad_scene_open(c"/nonexistent/x.rad".as_ptr(), &mut null_mut()),
                RAD_ERR_IO,
            ),
            (
                rad_scene_from_bytes(b"RADIOSITY?".as_ptr(), 10, &mut null_mut()),
                RAD_ERR_FORMAT,
            ),
        ];
        for (i, (got, want)) in cases.into_iter().enumerate() {
            assert_eq!(got, want, "case {i}");
        }
        assert_eq!(rad_scene_triangle_count(scene), 0);
        assert!(rad_scene_triangles(scene).is_null());
        assert!(last_error().starts_with("rad_scene_triangles: the scene has no full-detail mesh"));
        assert_eq!(
            y,
            vec![Rgb::ZERO; n + 1],
            "nothing written by refused calls"
        );
        rad_gather_free(gather);
        rad_scene_free(scene);
    }
}
