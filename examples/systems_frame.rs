//! The frame probe of `docs/decisions/systems.md`: a level file (`radiosity bake … --systems
//! auto|N`) lit through `radiosity_runtime::systems::Level` with the CPU backend's gather per
//! system. Prints the time of a frame (every system updated once) and, after a sun jumps
//! from one direction to another, how far each frame's light is from the new steady state.
//!
//!     cargo run --release --example systems_frame -- LEVEL.rad
use radiosity_backend_cpu::CpuGather;
use radiosity_core::{RadFile, Rgb};
use radiosity_runtime::systems::Level;
use std::time::Instant;

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: systems_frame LEVEL.rad");
    let bytes = std::fs::read(&path).expect("cannot read the level");
    let file = RadFile::parse(&bytes).expect("not a .rad file");
    assert!(file.systems.is_some(), "{path} is not a level (no systems)");
    let mut level = Level::new(&file, |_, one| {
        Ok::<_, std::convert::Infallible>(CpuGather::new(one.matrix.clone().into_owned()))
    })
    .expect("the level's systems");
    let n = file.n();
    // A sun's first exitance, patch by patch: reflectance × cos of the patch to the sun
    // (unshadowed; what the probe times is the frame, not the direct light).
    let sun = |d: [f32; 3]| -> Vec<Rgb> {
        file.patches
            .iter()
            .map(|q| {
                let c = -(q.normal[0] * d[0] + q.normal[1] * d[1] + q.normal[2] * d[2]);
                q.reflectance * c.max(0.0)
            })
            .collect()
    };
    let (xa, xb) = (sun([0.3, -0.8, 0.52]), sun([-0.6, -0.5, -0.62]));
    let settle = |level: &mut Level<CpuGather<'_>>, x: &[Rgb]| {
        level.steady(x, 1e-6, 200).expect("the level settles")
    };
    settle(&mut level, &xb);
    let want: Vec<Rgb> = level.gathered().to_vec();
    settle(&mut level, &xa);
    let area: Vec<f64> = file.patches.iter().map(|p| f64::from(p.area)).collect();
    let (mut times, mut errs) = (Vec::new(), Vec::new());
    for _ in 0..6 {
        let t = Instant::now();
        level.systems_mut().frame(&xb).expect("a frame");
        times.push(t.elapsed().as_secs_f64() * 1e3);
        // Relative error of the radiosity B = x + ρ·y, area-weighted over the level.
        let h = |v: Rgb| f64::from(v.r + v.g + v.b);
        let (mut e, mut w) = (0.0, 0.0);
        for k in 0..n {
            let rho = file.patches[k].reflectance;
            let got = h(xb[k] + rho * level.gathered()[k]);
            let exact = h(xb[k] + rho * want[k]);
            e += area[k] * (got - exact).abs();
            w += area[k] * exact;
        }
        errs.push(100.0 * e / w);
    }
    println!(
        "{n} patches, {} systems; frame ms: {times:.1?}",
        level.count()
    );
    // Where a frame's time goes: the coupling product over every patch, and every system's
    // gather, each timed alone (best of three).
    let sys = file.systems.as_ref().expect("a level");
    let coupling = sys.coupling.clone().into_owned();
    let exitance: Vec<Rgb> = xb.clone();
    let mut out = vec![Rgb::ZERO; n];
    let best = |f: &mut dyn FnMut()| {
        (0..3)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_secs_f64() * 1e3
            })
            .fold(f64::INFINITY, f64::min)
    };
    let coupling_ms = best(&mut || {
        radiosity_runtime::systems::parallel_incoming(&coupling, 0..n, &exitance, &mut out)
    });
    let mut gathers: Vec<(CpuGather<'_>, std::ops::Range<usize>)> = (0..sys.count())
        .map(|s| {
            let one = sys.system(&file, s).expect("a system");
            (CpuGather::new(one.matrix.into_owned()), sys.range(s))
        })
        .collect();
    let gather_ms = best(&mut || {
        for (g, r) in &mut gathers {
            let mut y = vec![Rgb::ZERO; r.len()];
            radiosity_core::Gather::gather(g, &exitance[r.clone()], &mut y).expect("a gather");
        }
    });
    println!(
        "coupling product ({} entries) {coupling_ms:.1} ms, the systems' gathers {gather_ms:.1} ms",
        coupling.cols.len()
    );
    println!("after the sun jumps, % off the steady radiosity per frame: {errs:.3?}");
}
