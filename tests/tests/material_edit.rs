//! Reflectance edits at run time (`radiosity_core::ReflectanceEdit`, `EditedGather`): the row
//! decode they rest on against the dense decode, and an edited frame against the transfer
//! matrix of the edited scene, computed from scratch, on the CPU and on every GPU adapter.

mod gpu_support;

use radiosity_bake::encode::{EncodeParams, encode_dense};
use radiosity_bake::transfer::{BounceSpec, transfer_matrix};
use radiosity_core::{
    DecodeMode, EditError, EditedGather, Format, Gather, Patch, ReferenceGather, ReflectanceEdit,
    Rgb, TransferMatrix,
};
use radiosity_tests::fixtures::{FORMAT_CASES, cornell_form_factors, exitance, sample_file};
use std::sync::Mutex;

/// GPU devices are opened one test at a time (see `wgpu_host.rs`).
static DEVICES: Mutex<()> = Mutex::new(());

#[test]
fn decoded_rows_equal_the_dense_decode() {
    for (format, channels) in FORMAT_CASES {
        // 37 patches with tiles of 16: several tiles across and down, a padded last block.
        let file = sample_file(37, channels, format, 16);
        let m = &file.matrix;
        let dense = m.decode_dense(DecodeMode::D3d10);
        let rows = [0u32, 5, 36, 17, 5];
        let got = m.decode_rows(DecodeMode::D3d10, &rows);
        let w = 37 * channels;
        for (a, &r) in rows.iter().enumerate() {
            // The same decode, corrections and sparse entries added in the same order: equal
            // bit for bit.
            assert_eq!(
                &got[a * w..(a + 1) * w],
                &dense[r as usize * w..(r as usize + 1) * w],
                "{format:?} × {channels}: row {r}"
            );
        }
    }
}

/// The Cornell box's patches, F and an edit: the patches of the objects of the first and the
/// last patch take new reflectances (one darker, one brighter and coloured).
struct Case {
    patches: Vec<Patch>,
    n: usize,
    /// M of the scene as baked, and of the edited scene, dense f32 RGB.
    m: Vec<f32>,
    m_edited: Vec<f32>,
    edits: Vec<(u32, Rgb)>,
    edited_patches: Vec<Patch>,
}

fn case(patches: usize) -> Case {
    let (core, f) = cornell_form_factors(patches);
    let n = core.len();
    let (first, last) = (core[0].object, core[n - 1].object);
    let edits: Vec<(u32, Rgb)> = core
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let rho = if p.object == first {
                Rgb::new(0.1, 0.15, 0.05)
            } else if p.object == last {
                Rgb::new(0.3, 0.85, 0.6)
            } else {
                return None;
            };
            Some((i as u32, rho))
        })
        .collect();
    let mut edited_patches = core.clone();
    for &(i, rho) in &edits {
        edited_patches[i as usize].reflectance = rho;
    }
    let rho = |ps: &[Patch]| -> Vec<[f64; 3]> {
        ps.iter()
            .map(|p| p.reflectance.to_array().map(f64::from))
            .collect()
    };
    let (m, _) = transfer_matrix(&f, &rho(&core), 3, BounceSpec::Infinite).unwrap();
    let (m_edited, _) =
        transfer_matrix(&f, &rho(&edited_patches), 3, BounceSpec::Infinite).unwrap();
    Case {
        patches: core,
        n,
        m,
        m_edited,
        edits,
        edited_patches,
    }
}

/// `M·x` in f64 from a dense RGB matrix.
fn dense_gather(m: &[f32], n: usize, x: &[Rgb]) -> Vec<[f64; 3]> {
    (0..n)
        .map(|i| {
            [0, 1, 2].map(|c| {
                (0..n)
                    .map(|j| f64::from(m[(i * n + j) * 3 + c]) * f64::from(x[j].channel(c)))
                    .sum()
            })
        })
        .collect()
}

fn relative_l2(y: &[Rgb], exact: &[[f64; 3]]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (a, e) in y.iter().zip(exact) {
        for c in 0..3 {
            num += (f64::from(a.channel(c)) - e[c]).powi(2);
            den += e[c] * e[c];
        }
    }
    (num / den).sqrt()
}

fn encoded(m: &[f32], n: usize, format: Format) -> TransferMatrix<'static> {
    encode_dense(n, 3, m, &EncodeParams::for_format(format)).unwrap()
}

#[test]
fn an_edited_frame_equals_the_edited_scenes_transfer() {
    let c = case(150);
    assert!(
        c.edits.len() > 10 && c.edits.len() < c.n / 2,
        "{} of {} patches edited",
        c.edits.len(),
        c.n
    );
    let x = exitance(c.n, 5);
    let exact = dense_gather(&c.m_edited, c.n, &x);
    // f32 storage: the edit works from M's own f32 entries, so only their rounding and the
    // f32 sums of the two gathers remain (about 1e-7 each, amplified by I − M_SS·D's
    // condition, under 10 for reflectances below 0.9): 1e-5 leaves a wide margin.
    let m = encoded(&c.m, c.n, Format::F32);
    let edit = ReflectanceEdit::new(&m, DecodeMode::D3d10, &c.patches, &c.edits).unwrap();
    assert_eq!(edit.len(), c.edits.len());
    let mut patches = c.patches.clone();
    edit.apply_to(&mut patches);
    assert_eq!(patches, c.edited_patches);
    let mut g = EditedGather::new(ReferenceGather::new(m, DecodeMode::D3d10), edit).unwrap();
    let mut y = vec![Rgb::ZERO; c.n];
    g.gather(&x, &mut y).unwrap();
    let err = relative_l2(&y, &exact);
    eprintln!(
        "f32: {} of {} patches edited, error {err:.2e}",
        c.edits.len(),
        c.n
    );
    assert!(
        err < 1e-5,
        "f32 edit against the edited transfer: {err:.2e}"
    );
    // The edit is what moves the answer: the unedited matrix is far off.
    let plain = relative_l2(
        &dense_gather(&c.m, c.n, &x)
            .iter()
            .map(|v| Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32))
            .collect::<Vec<_>>(),
        &exact,
    );
    eprintln!("unedited: {plain:.2e}");
    assert!(
        plain > 0.02,
        "the edit changes the light by only {plain:.2e}"
    );
}

#[test]
fn an_edit_of_a_compressed_matrix_stays_within_its_compression_error() {
    let c = case(150);
    let x = exitance(c.n, 9);
    let exact = dense_gather(&c.m_edited, c.n, &x);
    for format in [Format::Bc1, Format::U8] {
        let m = encoded(&c.m, c.n, format);
        // The re-bake: the edited scene's M encoded in the same format.
        let mut rebaked =
            ReferenceGather::new(encoded(&c.m_edited, c.n, format), DecodeMode::D3d10);
        let mut y_rebake = vec![Rgb::ZERO; c.n];
        rebaked.gather(&x, &mut y_rebake).unwrap();
        let rebake_err = relative_l2(&y_rebake, &exact);
        let edit = ReflectanceEdit::new(&m, DecodeMode::D3d10, &c.patches, &c.edits).unwrap();
        let mut g = EditedGather::new(ReferenceGather::new(m, DecodeMode::D3d10), edit).unwrap();
        let mut y = vec![Rgb::ZERO; c.n];
        g.gather(&x, &mut y).unwrap();
        let err = relative_l2(&y, &exact);
        eprintln!("{format:?}: edit {err:.2e}, re-bake {rebake_err:.2e}");
        // The edit gathers the compressed M twice and solves with its compressed M_SS, so the
        // compression error enters about twice; a re-bake's enters once. 3× the re-bake's
        // error plus 1e-4 (f32 sums) bounds it.
        assert!(
            err <= 3.0 * rebake_err + 1e-4,
            "{format:?}: edit {err:.2e}, re-bake {rebake_err:.2e}"
        );
    }
}

#[test]
fn an_edited_frame_on_the_gpu_equals_the_cpus() {
    use radiosity_backend_wgpu::{GpuOptions, WgpuGather};
    let c = case(100);
    let x = exitance(c.n, 3);
    let m = encoded(&c.m, c.n, Format::Bc1);
    let edit = ReflectanceEdit::new(&m, DecodeMode::D3d10, &c.patches, &c.edits).unwrap();
    let mut cpu = EditedGather::new(
        ReferenceGather::new(m.clone(), DecodeMode::D3d10),
        edit.clone(),
    )
    .unwrap();
    let mut y_cpu = vec![Rgb::ZERO; c.n];
    cpu.gather(&x, &mut y_cpu).unwrap();
    let _one = DEVICES.lock().unwrap_or_else(|e| e.into_inner());
    for adapter in gpu_support::gpu_adapters() {
        // The shader's software decode under D3D10 rules: the same entries as the CPU's.
        let options = GpuOptions {
            path: radiosity_backend_wgpu::DecodePath::Software,
            software_mode: DecodeMode::D3d10,
            ..GpuOptions::default()
        };
        let gpu = WgpuGather::on_adapter(&m, &adapter, &options).unwrap();
        let mut g = EditedGather::new(gpu, edit.clone()).unwrap();
        let mut y = vec![Rgb::ZERO; c.n];
        g.gather(&x, &mut y).unwrap();
        let exact: Vec<[f64; 3]> = y_cpu.iter().map(|v| v.to_array().map(f64::from)).collect();
        // Only f32 summation order differs (n = 100 terms a row, twice): 1e-5 relative.
        let err = relative_l2(&y, &exact);
        eprintln!("{}: {err:.2e} from the CPU's", adapter.info);
        assert!(err < 1e-5, "{}: {err:.2e}", adapter.info);
    }
}

/// The edited frame on a device the host owns (`EditedHostGather`): two host gathers and the
/// correction as a `k × k` product on the device, against the CPU's edited frame.
#[test]
fn an_edited_frame_on_the_hosts_device_equals_the_cpus() {
    use radiosity_backend_wgpu::{EditedHostGather, GpuOptions, HostGatherBuffers};
    use wgpu::BufferUsages as U;
    let c = case(100);
    let x = exitance(c.n, 3);
    let m = encoded(&c.m, c.n, Format::Bc1);
    let edit = ReflectanceEdit::new(&m, DecodeMode::D3d10, &c.patches, &c.edits).unwrap();
    let mut cpu = EditedGather::new(
        ReferenceGather::new(m.clone(), DecodeMode::D3d10),
        edit.clone(),
    )
    .unwrap();
    let mut y_cpu = vec![Rgb::ZERO; c.n];
    cpu.gather(&x, &mut y_cpu).unwrap();
    let exact: Vec<[f64; 3]> = y_cpu.iter().map(|v| v.to_array().map(f64::from)).collect();
    // Without the correction the frame is the unedited one, far off: the bound below tells
    // an applied edit from a skipped one.
    let mut unedited = vec![Rgb::ZERO; c.n];
    cpu.into_inner().gather(&x, &mut unedited).unwrap();
    assert!(relative_l2(&unedited, &exact) > 1e-3);
    let _one = DEVICES.lock().unwrap_or_else(|e| e.into_inner());
    for adapter in gpu_support::gpu_adapters() {
        let (device, queue) = pollster::block_on(adapter.wgpu_adapter().request_device(
            &wgpu::DeviceDescriptor {
                label: Some("host"),
                required_limits: adapter.wgpu_adapter().limits(),
                ..Default::default()
            },
        ))
        .unwrap();
        let bytes = 12 * c.n as u64;
        let buffer = |usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: None,
                size: bytes,
                usage,
                mapped_at_creation: false,
            })
        };
        let (xb, yb) = (
            buffer(U::COPY_DST | U::COPY_SRC),
            buffer(U::STORAGE | U::COPY_SRC),
        );
        let read = buffer(U::MAP_READ | U::COPY_DST);
        let buffers = HostGatherBuffers { x: &xb, y: &yb };
        let g = EditedHostGather::new(&device, &queue, &m, &GpuOptions::default(), &edit, buffers)
            .unwrap_or_else(|e| panic!("{}: {e}", adapter.info));
        assert_eq!(g.edited(), c.edits.len());
        queue.write_buffer(&xb, 0, bytemuck::cast_slice(&x));
        let mut e = device.create_command_encoder(&Default::default());
        g.record(&mut e);
        e.copy_buffer_to_buffer(&yb, 0, &read, 0, bytes);
        queue.submit([e.finish()]);
        read.map_async(wgpu::MapMode::Read, .., |r| r.expect("maps"));
        device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
        let y: Vec<Rgb> = bytemuck::cast_slice(&read.get_mapped_range(..).unwrap()).to_vec();
        // The gathers differ from the CPU's by f32 summation order (n = 100 terms a row,
        // twice), the correction by its f32 product against the CPU's f64 solve: 1e-5.
        let err = relative_l2(&y, &exact);
        eprintln!("{} (host device): {err:.2e} from the CPU's", adapter.info);
        assert!(err < 1e-5, "{}: {err:.2e}", adapter.info);
    }
}

#[test]
fn bad_edits_are_refused_with_the_reason() {
    let file = sample_file(8, 3, Format::F32, 16);
    let m = &file.matrix;
    let p = &file.patches;
    let new = |e: &[(u32, Rgb)]| ReflectanceEdit::new(m, DecodeMode::D3d10, p, e).unwrap_err();
    assert_eq!(
        new(&[(8, Rgb::splat(0.5))]),
        EditError::Patch {
            index: 8,
            patches: 8
        }
    );
    assert_eq!(
        new(&[(2, Rgb::splat(0.5)), (2, Rgb::splat(0.4))]),
        EditError::Duplicate(2)
    );
    assert!(matches!(
        new(&[(1, Rgb::new(0.5, 1.0, 0.5))]),
        EditError::Reflectance { patch: 1, .. }
    ));
    assert!(matches!(
        new(&[(1, Rgb::new(f32::NAN, 0.5, 0.5))]),
        EditError::Reflectance { patch: 1, .. }
    ));
    assert_eq!(
        ReflectanceEdit::new(m, DecodeMode::D3d10, &p[..7], &[]).unwrap_err(),
        EditError::Length {
            expected: 8,
            found: 7
        }
    );
    // An empty edit gathers as the matrix does.
    let edit = ReflectanceEdit::new(m, DecodeMode::D3d10, p, &[]).unwrap();
    let mut plain = ReferenceGather::new(m.clone(), DecodeMode::D3d10);
    let mut g =
        EditedGather::new(ReferenceGather::new(m.clone(), DecodeMode::D3d10), edit).unwrap();
    let x = exitance(8, 1);
    let (mut a, mut b) = (vec![Rgb::ZERO; 8], vec![Rgb::ZERO; 8]);
    plain.gather(&x, &mut a).unwrap();
    g.gather(&x, &mut b).unwrap();
    assert_eq!(a, b);
}
