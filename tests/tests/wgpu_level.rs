//! A level lit on the GPU (`WgpuLevel`: every system's gather and the coupling on one device)
//! against the runtime's `Level` over CPU gathers: one frame, the steady state, a reset.
//! With no adapter the test prints why and passes, except under `CI=true`.

#[path = "gpu_support/mod.rs"]
mod gpu_support;

use gpu_support::gpu_adapters;
use radiosity_backend_cpu::CpuGather;
use radiosity_backend_wgpu::{GpuError, GpuOptions, WgpuLevel};
use radiosity_core::Rgb;
use radiosity_runtime::systems::Level;
use radiosity_tests::fixtures::{exitance, sample_file, sample_level};

/// Largest relative difference per patch over the channel sums.
fn worst(a: &[Rgb], b: &[Rgb]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(a, b)| {
            let (a, b) = (a.r + a.g + a.b, b.r + b.g + b.b);
            (a - b).abs() / b.abs().max(1e-3)
        })
        .fold(0.0, f32::max)
}

#[test]
fn a_level_on_the_gpu_lights_as_the_cpu_level() {
    let file = sample_level(&[30, 40, 25]);
    let n = file.n();
    let x = exitance(n, 7);
    let cpu = || {
        Level::new(&file, |_, one| {
            Ok::<_, std::convert::Infallible>(CpuGather::new(one.matrix.clone().into_owned()))
        })
        .unwrap()
    };
    let mut one = cpu();
    one.systems_mut().frame(&x).unwrap();
    let mut steady = cpu();
    steady.steady(&x, 1e-6, 200).unwrap();
    for adapter in gpu_adapters() {
        let mut gpu = WgpuLevel::on_adapter(&file, &adapter, &GpuOptions::default())
            .unwrap_or_else(|e| panic!("{}: {e}", adapter.info));
        assert_eq!(gpu.count(), 3);
        // The shader decodes BC1 as the CPU does; the sums run in the GPU's own order and
        // may fuse multiply-adds: f32 rounding, a few ulps an entry over ≤ 95 terms.
        gpu.frame(&x).unwrap();
        let e = worst(gpu.gathered(), one.gathered());
        assert!(
            e < 1e-5,
            "{}: first frame {e:.2e} off the CPU level",
            adapter.info
        );
        let frames = gpu.steady(&x, 1e-6, 200).unwrap();
        assert!(frames > 1 && gpu.change() <= 1e-6, "{frames} frames");
        let e = worst(gpu.gathered(), steady.gathered());
        // Both within 1e-6 a frame of the same fixed point.
        assert!(
            e < 2e-5,
            "{}: steady state {e:.2e} off the CPU level",
            adapter.info
        );
        // Dark again, the next frame is the first frame again.
        gpu.reset();
        gpu.frame(&x).unwrap();
        assert!(worst(gpu.gathered(), one.gathered()) < 1e-5);
        // A first exitance of the wrong length is refused.
        assert!(gpu.frame(&x[1..]).is_err());
        // A one-matrix file is not a level.
        let plain = sample_file(20, 3, radiosity_core::Format::Bc1, 32);
        match WgpuLevel::on_adapter(&plain, &adapter, &GpuOptions::default()) {
            Err(GpuError::Unsupported(why)) => assert!(why.contains("not a level"), "{why}"),
            other => panic!("{other:?}"),
        }
    }
}
