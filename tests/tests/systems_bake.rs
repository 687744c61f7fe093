//! `--systems`: a bake cut into systems lights, at its steady state, as the one-matrix bake of
//! the same patches does; `off` leaves the bake as it was.

use radiosity_bake::form_factor::FormFactorParams;
use radiosity_bake::pipeline::{
    BakeParams, FormatChoice, Hooks, SystemsChoice, bake, bake_discretised, discretise,
};
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::VoxelParams;
use radiosity_core::systems::Systems;
use radiosity_core::{DecodeMode, Format, Gather, RadFile, ReferenceGather, Rgb};
use radiosity_tests::scenes::{Material, block, closed_box, write_scene};

/// A closed 2 m room lit by its ceiling, with a block standing in it: light crosses any cut
/// (a hard case for the coupling: nothing escapes, every bounce counts).
fn lit_room(dir: &std::path::Path) -> Scene {
    let mut quads = closed_box(2.0, 4, |face, _, _| {
        if face == "ceiling" { "lamp" } else { "wall" }.into()
    });
    quads.extend(block([0.3, 0.0, 0.4], [0.9, 0.7, 1.0], "block", "red"));
    let mats = [
        Material::new("wall", [0.7; 3], [0.0; 3]),
        Material::new("red", [0.7, 0.2, 0.1], [0.0; 3]),
        Material::new("lamp", [0.5; 3], [2.0; 3]),
    ];
    Scene::load_obj(&write_scene(dir, "room", &quads, &mats)).unwrap()
}

fn params(systems: SystemsChoice) -> BakeParams {
    BakeParams {
        voxel: VoxelParams::with_patches(300),
        // Exact storage: the two files then differ only by the cut, not by compression.
        format: FormatChoice::Fixed(Format::F32),
        systems,
        ..BakeParams::default()
    }
}

/// The gathered irradiance of each bake patch (indexed by the file's `order`) under the
/// scene's own emission.
fn one_matrix(file: &RadFile<'_>) -> Vec<Rgb> {
    let n = file.n();
    let x: Vec<Rgb> = file.patches.iter().map(|p| p.emission).collect();
    let mut y = vec![Rgb::ZERO; n];
    ReferenceGather::new(file.matrix.clone(), DecodeMode::D3d10)
        .gather(&x, &mut y)
        .unwrap();
    let mut out = vec![Rgb::ZERO; n];
    for (k, &b) in file.order.iter().enumerate() {
        out[b as usize] = y[k];
    }
    out
}

#[test]
fn systems_reach_the_one_matrix_light_and_off_is_the_old_bake() {
    let dir = tempfile::tempdir().unwrap();
    let scene = lit_room(dir.path());
    let single = bake(&scene, &params(SystemsChoice::Off), Hooks::default()).unwrap();
    // `auto` keeps one matrix at this size: the same bytes as `off` but for the timings.
    let auto = bake(&scene, &params(SystemsChoice::Auto), Hooks::default()).unwrap();
    assert!(single.file.systems.is_none() && auto.file.systems.is_none());
    assert_eq!(single.file.matrix, auto.file.matrix);
    assert_eq!(single.file.patches, auto.file.patches);

    let cut = bake(&scene, &params(SystemsChoice::Count(3)), Hooks::default()).unwrap();
    let level = &cut.file;
    let systems = level.systems.as_ref().expect("a level file");
    assert_eq!(systems.count(), 3);
    assert_eq!(level.n(), single.file.n());
    let report = cut.report.systems.as_ref().unwrap();
    assert!(
        report.crossing_share > 0.05,
        "light crosses the cuts: {report:?}"
    );
    assert_eq!(report.dropped_share, 0.0);
    // Written and read back, the level is the same.
    let bytes = level.to_bytes().unwrap();
    let back = RadFile::parse(&bytes).unwrap();
    let systems = back.systems.as_ref().unwrap();

    let gathers: Vec<ReferenceGather<'_>> = (0..systems.count())
        .map(|s| {
            let f = systems.system(&back, s).unwrap();
            ReferenceGather::new(f.matrix.into_owned(), DecodeMode::D3d10)
        })
        .collect();
    let reflectance: Vec<Rgb> = back.patches.iter().map(|p| p.reflectance).collect();
    let first: Vec<Rgb> = back.patches.iter().map(|p| p.emission).collect();
    let mut light = Systems::new(
        gathers,
        systems.ranges(),
        systems.coupling.clone().into_owned(),
        reflectance,
    )
    .unwrap();
    for _ in 0..80 {
        light.frame(&first).unwrap();
    }
    let want = one_matrix(&single.file);
    let mut got = vec![Rgb::ZERO; back.n()];
    for (k, &b) in back.order.iter().enumerate() {
        got[b as usize] = light.gathered()[k];
    }
    let areas: Vec<f64> = back.patches.iter().map(|p| f64::from(p.area)).collect();
    let mut area_of = vec![0.0; back.n()];
    for (k, &b) in back.order.iter().enumerate() {
        area_of[b as usize] = areas[k];
    }
    let h = |v: Rgb| f64::from(v.r + v.g + v.b);
    let (mut e, mut w) = (0.0, 0.0);
    for i in 0..want.len() {
        e += area_of[i] * (h(got[i]) - h(want[i])).abs();
        w += area_of[i] * h(want[i]);
    }
    // Both are the exact infinite-bounce light of the same F in f32: after 80 block
    // Gauss–Seidel frames of a closed room (reflectance 0.7, the error shrinking by about
    // 0.7× a frame at worst) only f32 rounding of two routes through 300 patches remains.
    assert!(w > 0.0);
    assert!(
        e / w < 1e-4,
        "steady state {:.2e} off the one matrix",
        e / w
    );
}

/// A level's form factors are kept as sparse rows where they are ray-cast (a dense n² matrix
/// of 65 536 patches would not fit): burial, closure and dark patches corrected on those rows
/// give the level the dense matrix gives, bit for bit.
#[test]
fn sparse_rows_bake_the_level_the_dense_matrix_does() {
    let dir = tempfile::tempdir().unwrap();
    let scene = lit_room(dir.path());
    // Ray-cast rows even for this small room (more pieces than exact pairs allow).
    let ray_cast = |systems| BakeParams {
        form_factors: FormFactorParams {
            exact_pieces: 0,
            ..FormFactorParams::default()
        },
        ..params(systems)
    };
    let sparse = bake(&scene, &ray_cast(SystemsChoice::Count(3)), Hooks::default()).unwrap();
    let system = discretise(&scene, &ray_cast(SystemsChoice::Off), Hooks::default()).unwrap();
    assert!(system.sparse.is_none() && system.f.n == system.len());
    let dense = bake_discretised(
        &scene,
        &system,
        &ray_cast(SystemsChoice::Count(3)),
        Hooks::default(),
    )
    .unwrap();
    assert!(sparse.report.effects["ray_cast"].on);
    let (a, b) = (&sparse.file, &dense.file);
    assert!(a.systems.is_some());
    assert_eq!(a.patches, b.patches);
    assert_eq!(a.order, b.order);
    assert_eq!(a.systems, b.systems);
    assert_eq!(a.parts, b.parts);
    assert_eq!(sparse.report.closure, dense.report.closure);
    assert_eq!(
        sparse.report.reciprocity_error.to_bits(),
        dense.report.reciprocity_error.to_bits()
    );
}

/// A level's probes: the probes pass runs over the level's file as over one matrix's, so each
/// probe sees the same patches and, lit by the level's steady state, gives the light the
/// one-matrix bake's probes give.
#[test]
fn a_level_has_probes_lit_as_the_one_matrix_probes() {
    use radiosity_bake::passes::probes::ProbeSpec;
    use radiosity_runtime::BakedScene;
    let dir = tempfile::tempdir().unwrap();
    let scene = lit_room(dir.path());
    let with_probes = |systems| BakeParams {
        probes: ProbeSpec::Spacing(0.5),
        ..params(systems)
    };
    let single = bake(&scene, &with_probes(SystemsChoice::Off), Hooks::default()).unwrap();
    let cut = bake(
        &scene,
        &with_probes(SystemsChoice::Count(3)),
        Hooks::default(),
    )
    .unwrap();
    let (a, b) = (&single.report.probes, &cut.report.probes);
    let (a, b) = (
        a.as_ref().expect("probes"),
        b.as_ref().expect("a level's probes"),
    );
    assert!(b.placed > 0 && b.placed == a.placed, "{a:?} {b:?}");
    assert!(cut.file.systems.is_some());

    // The level's steady state (as in the test above) and the one matrix's light, each in
    // its own file numbering, reflected off the patches and gathered by each file's probes.
    let level = BakedScene::new(cut.file.clone());
    let systems = cut.file.systems.as_ref().unwrap();
    let gathers: Vec<ReferenceGather<'_>> = (0..systems.count())
        .map(|s| {
            let f = systems.system(&cut.file, s).unwrap();
            ReferenceGather::new(f.matrix.into_owned(), DecodeMode::D3d10)
        })
        .collect();
    let rho: Vec<Rgb> = cut.file.patches.iter().map(|p| p.reflectance).collect();
    let first: Vec<Rgb> = cut.file.patches.iter().map(|p| p.emission).collect();
    let coupling = systems.coupling.clone().into_owned();
    let mut light = Systems::new(gathers, systems.ranges(), coupling, rho.clone()).unwrap();
    for _ in 0..80 {
        light.frame(&first).unwrap();
    }
    let reflected =
        |h: &[Rgb], rho: &[Rgb]| -> Vec<Rgb> { h.iter().zip(rho).map(|(h, r)| *r * *h).collect() };
    let got = radiosity_runtime::probes::gather_all(
        level.decoded_probes().unwrap(),
        &reflected(light.gathered(), &rho),
    );
    let one = BakedScene::new(single.file.clone());
    let x: Vec<Rgb> = single.file.patches.iter().map(|p| p.emission).collect();
    let mut y = vec![Rgb::ZERO; x.len()];
    ReferenceGather::new(single.file.matrix.clone(), DecodeMode::D3d10)
        .gather(&x, &mut y)
        .unwrap();
    let rho1: Vec<Rgb> = single.file.patches.iter().map(|p| p.reflectance).collect();
    let want =
        radiosity_runtime::probes::gather_all(one.decoded_probes().unwrap(), &reflected(&y, &rho1));
    let dc = |sh: &[Rgb; 9]| f64::from(sh[0].r + sh[0].g + sh[0].b);
    let (e, w): (f64, f64) = got.iter().zip(&want).fold((0.0, 0.0), |(e, w), (g, t)| {
        (e + (dc(g) - dc(t)).abs(), w + dc(t))
    });
    // The same rays meet the same patches in both files (the probes' weights are binary16 in
    // either); the light differs by the steady state's f32 rounding (1e-4 above) and the
    // weights' rounding (2⁻¹¹ relative) only.
    assert!(w > 0.0);
    assert!(
        e / w < 2e-3,
        "level probes {:.2e} off the one matrix's",
        e / w
    );
}
