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
    // Part and first-bounce rows name the mesh's samples, coverage its triangles: a file
    // without a mesh has none of them.
    file.parts = None;
    file.bounce = None;
    file.coverage = None;
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

/// A visibility callback for `rad_probe_irradiance`: `user` points at a probe position that
/// is out of sight; every other probe is in sight. Counts its calls in the position's
/// fourth float.
unsafe extern "C" fn hides_one(
    user: *mut std::ffi::c_void,
    from: *const f32,
    to: *const f32,
) -> bool {
    // SAFETY: the tests pass a live `[f32; 4]` as `user`; `from` and `to` are 3 floats each
    // (the library's promise).
    unsafe {
        let hidden = &mut *user.cast::<[f32; 4]>();
        hidden[3] += 1.0;
        let (_from, to) = (
            std::slice::from_raw_parts(from, 3),
            std::slice::from_raw_parts(to, 3),
        );
        to != &hidden[..3]
    }
}

#[test]
fn probes_through_the_abi_equal_the_core() {
    use radiosity_core::{DecodedProbes, SH_COEFFICIENTS, sh_irradiance};
    let file = sample_file(70, 3, Format::Bc1, 32);
    let probes = file.probes.as_ref().unwrap();
    let m = probes.len();
    let scene = scene_of(&file);
    let h: Vec<Rgb> = (0..70)
        .map(|i| Rgb::new(1.0 + i as f32, 2.0, 0.5 * i as f32))
        .collect();
    // SAFETY (this and every call below): `scene` is live until rad_scene_free; every array
    // passed has the length given.
    unsafe {
        assert_eq!(rad_scene_probe_count(scene), m);
        let positions = std::slice::from_raw_parts(rad_scene_probe_positions(scene), 3 * m);
        assert_eq!(positions, probes.positions.as_flattened());

        let mut sh = vec![Rgb::ZERO; SH_COEFFICIENTS * m];
        let code = rad_scene_probes_frame(
            scene,
            as_rad(&h).as_ptr(),
            70,
            as_rad_mut(&mut sh).as_mut_ptr(),
            sh.len(),
        );
        assert_eq!(code, RAD_OK, "{}", last_error());
        // The frame is the core's P·(ρ∘H), bit for bit: the same decoded weights, the same
        // order of sums.
        let reflected: Vec<Rgb> = h
            .iter()
            .zip(file.patches.iter())
            .map(|(h, p)| p.reflectance * *h)
            .collect();
        let decoded = DecodedProbes::new(probes);
        for p in 0..m {
            assert_eq!(
                sh[SH_COEFFICIENTS * p..SH_COEFFICIENTS * (p + 1)],
                decoded.gather_probe(p, &reflected)
            );
        }
        assert_ne!(sh[0], Rgb::ZERO, "the first probe weighs two patches");

        // Between the two probes, both in sight, then the second hidden by the host's callback.
        let point = [0.4f32, 0.6, 0.5];
        let normal = [0.0f32, 0.0, 1.0];
        let irradiance_of = |visible: &dyn Fn(usize) -> bool| {
            let mut w = Vec::new();
            assert!(probes.interpolation_weights(point, Some(normal), visible, &mut w));
            w.iter().fold(Rgb::ZERO, |e, &(i, w)| {
                let c = sh[SH_COEFFICIENTS * i..SH_COEFFICIENTS * (i + 1)]
                    .try_into()
                    .unwrap();
                e + sh_irradiance(c, normal) * w
            })
        };
        let mut out = RadRgb {
            r: 0.0,
            g: 0.0,
            b: 0.0,
        };
        let ask = |visible: RadProbeVisible, user: *mut std::ffi::c_void, out: &mut RadRgb| {
            rad_probe_irradiance(
                scene,
                as_rad(&sh).as_ptr(),
                sh.len(),
                point.as_ptr(),
                normal.as_ptr(),
                visible,
                user,
                out,
            )
        };
        assert_eq!(ask(None, null_mut(), &mut out), RAD_OK, "{}", last_error());
        assert_eq!(bytemuck::cast::<RadRgb, Rgb>(out), irradiance_of(&|_| true));

        let mut hidden = [
            probes.positions[1][0],
            probes.positions[1][1],
            probes.positions[1][2],
            0.0,
        ];
        let user = (&mut hidden as *mut [f32; 4]).cast();
        assert_eq!(
            ask(Some(hides_one), user, &mut out),
            RAD_OK,
            "{}",
            last_error()
        );
        assert_eq!(
            hidden[3], 2.0,
            "the callback asked once a probe of the cell"
        );
        let alone = irradiance_of(&|i| i != 1);
        assert_eq!(bytemuck::cast::<RadRgb, Rgb>(out), alone);
        assert_ne!(
            alone,
            irradiance_of(&|_| true),
            "hiding a probe changes the answer"
        );

        // Both hidden: the point is answered with what it is, not a number.
        unsafe extern "C" fn none_in_sight(
            _: *mut std::ffi::c_void,
            _: *const f32,
            _: *const f32,
        ) -> bool {
            false
        }
        out = RadRgb {
            r: -1.0,
            g: -1.0,
            b: -1.0,
        };
        assert_eq!(
            ask(Some(none_in_sight), null_mut(), &mut out),
            RAD_ERR_NO_PROBES
        );
        assert!(
            last_error().contains("no probe around the point is in sight"),
            "{}",
            last_error()
        );
        assert_eq!(out.r, -1.0, "nothing written by a refused call");
        rad_scene_free(scene);
    }
}

#[test]
fn bad_probe_calls_are_refused_with_a_message() {
    use radiosity_core::SH_COEFFICIENTS;
    let file = sample_file(40, 1, Format::Bc4, 16);
    let scene = scene_of(&file);
    let mut bare = sample_file(40, 1, Format::Bc4, 16);
    bare.probes = None;
    // The sample's sky visibility has an entry per probe too: without probes it must go.
    bare.sky = None;
    let bare = scene_of(&bare);
    let h = vec![Rgb::ONE; 40];
    let mut sh = vec![Rgb::ZERO; SH_COEFFICIENTS * 2];
    let (hp, shp) = (as_rad(&h).as_ptr(), as_rad_mut(&mut sh).as_mut_ptr());
    let mut nan = h.clone();
    nan[7].g = f32::NAN;
    let point = [0.5f32, 0.5, 0.5];
    let up = [0.0f32, 0.0, 1.0];
    let zero = [0.0f32; 3];
    let far = [f32::INFINITY, 0.0, 0.0];
    let mut out = RadRgb {
        r: 0.0,
        g: 0.0,
        b: 0.0,
    };
    // SAFETY (this and every call below): the scenes are live until freed at the end; every
    // array passed is at least as long as given, except where the call is meant to be refused
    // for its length before reading.
    unsafe {
        assert_eq!(rad_scene_probe_count(bare), 0);
        assert!(rad_scene_probe_positions(bare).is_null());
        let irr = |s, p: &[f32; 3], n: &[f32; 3], len, out: &mut RadRgb| {
            rad_probe_irradiance(s, shp, len, p.as_ptr(), n.as_ptr(), None, null_mut(), out)
        };
        // Each call's code and the start of its message, checked before the next call
        // replaces the thread's last error.
        let check = |case: &str, got: i32, want: i32, says: &str| {
            assert_eq!(got, want, "{case}: {}", last_error());
            assert!(last_error().contains(says), "{case}: {}", last_error());
        };
        check(
            "no probes, frame",
            rad_scene_probes_frame(bare, hp, 40, shp, 18),
            RAD_ERR_NO_PROBES,
            "no light probes",
        );
        check(
            "no probes, point",
            irr(bare, &point, &up, 18, &mut out),
            RAD_ERR_NO_PROBES,
            "no light probes",
        );
        check(
            "short n",
            rad_scene_probes_frame(scene, hp, 39, shp, 18),
            RAD_ERR_LENGTH,
            "39",
        );
        check(
            "short sh",
            rad_scene_probes_frame(scene, hp, 40, shp, 17),
            RAD_ERR_LENGTH,
            "sh_len = 17",
        );
        check(
            "NULL irradiance",
            rad_scene_probes_frame(scene, null(), 40, shp, 18),
            RAD_ERR_POINTER,
            "irradiance",
        );
        check(
            "NaN irradiance",
            rad_scene_probes_frame(scene, as_rad(&nan).as_ptr(), 40, shp, 18),
            RAD_ERR_VALUE,
            "patch 7",
        );
        check(
            "zero normal",
            irr(scene, &point, &zero, 18, &mut out),
            RAD_ERR_VALUE,
            "normal has length 0",
        );
        check(
            "infinite point",
            irr(scene, &far, &up, 18, &mut out),
            RAD_ERR_VALUE,
            "point is not finite",
        );
        check(
            "short sh, point",
            irr(scene, &point, &up, 9, &mut out),
            RAD_ERR_LENGTH,
            "sh_len = 9",
        );
        check(
            "NULL out",
            rad_probe_irradiance(
                scene,
                shp,
                18,
                point.as_ptr(),
                up.as_ptr(),
                None,
                null_mut(),
                null_mut(),
            ),
            RAD_ERR_POINTER,
            "out",
        );
        assert_eq!(sh, vec![Rgb::ZERO; 18], "nothing written by refused calls");
        assert_eq!(rad_scene_probe_count(null()), 0);
        assert!(last_error().contains("NULL"), "{}", last_error());
        rad_scene_free(bare);
        rad_scene_free(scene);
    }
}

#[test]
fn sky_light_through_the_abi_equals_the_runtime() {
    let file = sample_file(64, 3, Format::Bc1, 16);
    let n = file.n();
    let radiance = RadRgb {
        r: 0.5,
        g: 1.0,
        b: 2.0,
    };
    let sky = RadLight {
        kind: RAD_LIGHT_SKY,
        value: radiance,
        ..RadLight::default()
    };
    let rt = radiosity_runtime::BakedScene::new(file.clone().into_owned());
    let want = rt
        .direct(&[radiosity_core::Light::Sky {
            radiance: Rgb::new(0.5, 1.0, 2.0),
        }])
        .unwrap();
    // The sample's sky visibility grows with the patch index: the last patch is lit.
    assert!(want[n - 1].g > 0.0);
    let scene = scene_of(&file);
    let mut got = vec![Rgb::ZERO; n];
    // SAFETY: `scene` is live until freed below; `sky` is one light; `got` holds n values.
    let code = unsafe { rad_scene_direct(scene, &sky, 1, as_rad_mut(&mut got).as_mut_ptr(), n) };
    assert_eq!(code, RAD_OK, "{}", last_error());
    assert_eq!(got, want);
    // SAFETY: freed once, not used after.
    unsafe { rad_scene_free(scene) };

    // A file baked without sky visibility refuses the sky rather than leaving it out.
    let mut bare = sample_file(64, 3, Format::Bc1, 16);
    bare.sky = None;
    let scene = scene_of(&bare);
    let mut untouched = vec![Rgb::ONE; n];
    // SAFETY: as above.
    let code =
        unsafe { rad_scene_direct(scene, &sky, 1, as_rad_mut(&mut untouched).as_mut_ptr(), n) };
    assert_eq!(code, RAD_ERR_VALUE);
    assert!(last_error().contains("--sky on"), "{}", last_error());
    assert_eq!(untouched, vec![Rgb::ONE; n], "nothing written when refused");
    // SAFETY: freed once, not used after.
    unsafe { rad_scene_free(scene) };
}

/// A level file (its transfer cut into systems) through the ABI: rad_gather_run lights it to
/// the steady state and rad_gather_frame runs one frame, each equal to the runtime's `Level`
/// over the same CPU gathers; the GPU refuses it with a message.
#[test]
fn a_level_gathers_through_the_abi_as_the_runtime_lights_it() {
    use radiosity_backend_cpu::CpuGather;
    use radiosity_runtime::systems::Level;
    let file = radiosity_tests::fixtures::sample_level(&[30, 40, 25]);
    let n = file.n();
    let scene = scene_of(&file);
    let x = exitance(n, 7);
    let cpu_level = || {
        Level::new(&file, |_, one| {
            Ok::<_, std::convert::Infallible>(CpuGather::new(one.matrix.clone().into_owned()))
        })
        .unwrap()
    };
    let mut steady = cpu_level();
    let frames = steady.steady(&x, 1e-4, 100).unwrap();
    assert!(frames > 1, "light crosses the systems: {frames} frame(s)");
    let mut one_frame = cpu_level();
    one_frame.systems_mut().frame(&x).unwrap();
    // SAFETY (every call below): `scene` and the gathers are live until freed at the end, and
    // every array passed has the length given.
    unsafe {
        let mut g = null_mut();
        assert_eq!(
            rad_gather_new(scene, c"cpu".as_ptr(), &mut g),
            RAD_OK,
            "{}",
            last_error()
        );
        assert_eq!(rad_gather_systems(g), 3);
        assert_eq!(c_str(rad_gather_backend(g)), "cpu");
        assert!(c_str(rad_gather_name(g)).ends_with("-systems"));
        let mut y = vec![Rgb::ZERO; n];
        let code = rad_gather_run(g, as_rad(&x).as_ptr(), as_rad_mut(&mut y).as_mut_ptr(), n);
        assert_eq!(code, RAD_OK, "{}", last_error());
        // The same gathers, the same frames in the same order: the same floats.
        assert_eq!(y, steady.gathered());
        rad_gather_free(g);

        let mut g = null_mut();
        assert_eq!(rad_gather_new(scene, c"auto".as_ptr(), &mut g), RAD_OK);
        let code = rad_gather_frame(g, as_rad(&x).as_ptr(), as_rad_mut(&mut y).as_mut_ptr(), n);
        assert_eq!(code, RAD_OK, "{}", last_error());
        assert_eq!(y, one_frame.gathered());
        assert_ne!(
            y,
            steady.gathered(),
            "one frame is not yet the steady state"
        );
        assert_eq!(
            rad_gather_frame(
                g,
                as_rad(&x).as_ptr(),
                as_rad_mut(&mut y).as_mut_ptr(),
                n + 1
            ),
            RAD_ERR_LENGTH
        );
        rad_gather_free(g);

        // Under a budget, with a priority: the systems are those of the file.
        let mut g = null_mut();
        assert_eq!(rad_gather_new(scene, c"cpu".as_ptr(), &mut g), RAD_OK);
        let (mut start, mut count) = (0usize, 0usize);
        for (s, want) in [(0, 0..30), (1, 30..70), (2, 70..95)] {
            assert_eq!(
                rad_gather_system_range(g, s, &mut start, &mut count),
                RAD_OK
            );
            assert_eq!(start..start + count, want);
        }
        assert_eq!(
            rad_gather_system_range(g, 3, &mut start, &mut count),
            RAD_ERR_VALUE
        );
        assert_eq!(rad_gather_set_priority(g, 2, 5.0), RAD_OK);
        assert_eq!(rad_gather_set_priority(g, 1, f32::NAN), RAD_ERR_VALUE);
        assert_eq!(rad_gather_set_priority(g, 3, 1.0), RAD_ERR_VALUE);
        let mut updated = 0usize;
        // A budget no update fits in still updates the most needed system once: a frame
        // always moves.
        let code = rad_gather_update_within(
            g,
            as_rad(&x).as_ptr(),
            as_rad_mut(&mut y).as_mut_ptr(),
            n,
            1e-9,
            &mut updated,
        );
        assert_eq!(code, RAD_OK, "{}", last_error());
        assert_eq!(updated, 1);
        let mut first = cpu_level();
        first.systems_mut().set_priority(2, 5.0);
        first.systems_mut().update(2, &x).unwrap();
        assert_eq!(y, first.gathered(), "the prioritised system went first");
        // A generous budget runs until no system needs light: the steady state's fixed point.
        let code = rad_gather_update_within(
            g,
            as_rad(&x).as_ptr(),
            as_rad_mut(&mut y).as_mut_ptr(),
            n,
            1e4,
            &mut updated,
        );
        assert_eq!(code, RAD_OK);
        assert!(updated > 3, "{updated} updates");
        let area: Vec<f64> = file.patches.iter().map(|p| f64::from(p.area)).collect();
        let h = |v: &Rgb| f64::from(v.r + v.g + v.b);
        let (e, w) = y
            .iter()
            .zip(steady.gathered())
            .zip(&area)
            .fold((0.0, 0.0), |(e, w), ((a, b), s)| {
                (e + s * (h(a) - h(b)).abs(), w + s * h(b))
            });
        // Both within 1e-4 of the fixed point (steady's tolerance), so within 2e-4 of each other.
        assert!(e / w < 2e-4, "{}", e / w);
        assert_eq!(
            rad_gather_update_within(
                g,
                as_rad(&x).as_ptr(),
                as_rad_mut(&mut y).as_mut_ptr(),
                n,
                -1.0,
                null_mut()
            ),
            RAD_ERR_VALUE
        );
        rad_gather_free(g);

        // On the GPU (each system on a device of its own), where an adapter is found: CI
        // installs a software one (scripts/test.sh), so there it must be.
        let mut g = null_mut();
        match rad_gather_new(scene, c"gpu".as_ptr(), &mut g) {
            RAD_OK => {
                assert_eq!(c_str(rad_gather_backend(g)), "gpu");
                assert_eq!(rad_gather_systems(g), 3);
                let code =
                    rad_gather_run(g, as_rad(&x).as_ptr(), as_rad_mut(&mut y).as_mut_ptr(), n);
                assert_eq!(code, RAD_OK, "{}", last_error());
                // The GPU sums each row in its own order: f32 rounding apart (a few ulps a
                // gather, over a handful of frames), then the steady tolerance of both, 1e-4.
                for (a, b) in y.iter().zip(steady.gathered()) {
                    let (a, b) = (a.r + a.g + a.b, b.r + b.g + b.b);
                    assert!((a - b).abs() <= 2e-4 * b.abs().max(1e-3), "{a} vs {b}");
                }
                rad_gather_free(g);
            }
            code => {
                assert_eq!(code, RAD_ERR_UNAVAILABLE, "{}", last_error());
                assert!(g.is_null());
                assert_ne!(
                    std::env::var("CI").as_deref(),
                    Ok("true"),
                    "CI has a software adapter: {}",
                    last_error()
                );
            }
        }
        assert_eq!(rad_gather_systems(null()), 0);
        rad_scene_free(scene);
    }
}
