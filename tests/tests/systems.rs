//! Cutting a level into systems (`radiosity_bake::systems`): the cut follows the walls where
//! light does not cross, within each system's capacity.

use radiosity_bake::form_factor::{
    FormFactorParams, ManyPieces, SparseFormFactors, form_factors_sparse,
};
use radiosity_bake::patch::Patches;
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::{VoxelParams, simplify};
use radiosity_bake::systems::{Region, Split, partition, partition_regions};
use radiosity_bake::transfer::{BounceSpec, Dense, transfer_matrix};
use radiosity_core::systems::Systems;
use radiosity_core::{Gather, GatherError, Rgb};
use radiosity_tests::scenes::{Material, Quad, closed_box, resting_blocks_room, write_scene};

/// Two closed rooms side by side, a 1 m cube and a 2 m one 0.5 m beside it along x: no light
/// passes between them, and the larger holds about four fifths of the surface.
fn two_rooms(dir: &std::path::Path) -> Scene {
    let mut quads: Vec<Quad> = Vec::new();
    for (name, size, shift) in [("small", 1.0, 0.0), ("large", 2.0, 1.5)] {
        for mut q in closed_box(size, 4, |_, _, _| "grey".into()) {
            q.object = format!("{name}-{}", q.object);
            for c in &mut q.corners {
                c[0] += shift;
            }
            quads.push(q);
        }
    }
    let mats = [Material::new("grey", [0.6; 3], [0.0; 3])];
    Scene::load_obj(&write_scene(dir, "rooms", &quads, &mats)).unwrap()
}

/// `scene` cut into about `patches` patches and their ray-cast form factors (1024 rays a
/// patch), sparse: what a systems bake starts from.
fn ray_cast_rows(scene: &Scene, patches: usize) -> (Patches, SparseFormFactors) {
    let p = simplify(scene, &VoxelParams::with_patches(patches)).unwrap();
    let params = FormFactorParams {
        exact_pieces: 0,
        many_pieces: ManyPieces::Rays { per_patch: 1024 },
        ..FormFactorParams::default()
    };
    let ff = form_factors_sparse(&p, Some(&scene.occluders()), &params, None).unwrap();
    (p, ff)
}

#[test]
fn systems_are_cut_between_rooms_not_through_them() {
    let dir = tempfile::tempdir().unwrap();
    let scene = two_rooms(dir.path());
    let (patches, ff) = ray_cast_rows(&scene, 300);
    let n = patches.len();
    let small = (0..n)
        .filter(|&i| patches.patches[i].centre.x < 1.25)
        .count();
    assert!(
        small * 3 < n,
        "the small room is the smaller share: {small} of {n}"
    );
    // Capacity for 90% of the patches: two systems, and the only cut that passes no light is
    // the gap between the rooms (a split by patch count would go through the large one).
    let max = n * 9 / 10;
    let p = partition(&patches, &ff, max);
    assert_eq!(p.count, 2);
    let members = p.members();
    assert!(members.iter().all(|m| m.len() <= max));
    for m in &members {
        let rooms: std::collections::BTreeSet<bool> = m
            .iter()
            .map(|&i| patches.patches[i as usize].centre.x < 1.25)
            .collect();
        assert_eq!(rooms.len(), 1, "a system holds one room");
    }
    assert_eq!(p.crossing_share(&patches, &ff), 0.0);
    // Smaller systems must cut the large room too; each stays within its capacity, and the
    // crossing light, though no longer zero, stays a minority of the exchange.
    let p = partition(&patches, &ff, n / 5);
    assert!(p.count >= 5);
    assert!(
        p.members()
            .iter()
            .all(|m| !m.is_empty() && m.len() <= n / 5)
    );
    let share = p.crossing_share(&patches, &ff);
    assert!(share > 0.0 && share < 0.9, "{share}");
}

#[test]
fn a_plans_regions_hold_the_systems_they_were_cut_into() {
    let dir = tempfile::tempdir().unwrap();
    let scene = two_rooms(dir.path());
    let (patches, ff) = ray_cast_rows(&scene, 300);
    let n = patches.len();
    let centres: Vec<_> = patches.patches.iter().map(|p| p.centre).collect();
    let areas: Vec<f64> = patches.patches.iter().map(|p| p.area).collect();
    for max in [n * 9 / 10, n / 5, n / 7] {
        let (p, regions) = partition_regions(&centres, &areas, &ff, max);
        assert!(regions.is_well_formed());
        assert_eq!(regions.count(), p.count);
        // Each patch's centre lies in the region of its own system: the planes fall between
        // centres, never through a row of patches at one coordinate.
        for (i, c) in centres.iter().enumerate() {
            assert_eq!(regions.system_of(*c), p.system[i], "patch {i}, max {max}");
        }
        // Within capacity where a plane between centres allows it; where none does (a box's
        // faces hold rows of patches at one coordinate) the plane nearest the share, so a
        // system may go over by about one such row: here up to half again.
        let sizes: Vec<usize> = p.members().iter().map(Vec::len).collect();
        assert!(
            sizes.iter().all(|&m| m > 0 && 2 * m <= 3 * max),
            "{sizes:?} max {max}"
        );
        assert_eq!(sizes.iter().sum::<usize>(), n);
    }
    // Two systems: the gap between the rooms, as the cut without regions finds it.
    let (p, regions) = partition_regions(&centres, &areas, &ff, n * 9 / 10);
    assert_eq!(p.crossing_share(&patches, &ff), 0.0);
    match regions {
        Region::Cut { axis, at, .. } => {
            assert_eq!(axis, 0);
            assert!(
                (1.0..=1.5).contains(&at),
                "the plane lies in the gap: x = {at}"
            );
        }
        Region::System { .. } => panic!("two systems"),
    }
    // A plan read back: a point moved off every centre still finds a region.
    let text = serde_json::to_string(&regions).unwrap();
    let back: Region = serde_json::from_str(&text).unwrap();
    assert_eq!(back, regions);
    assert!(back.system_of(glam::DVec3::new(1e9, -1e9, 0.0)) < 2);
}

/// A grey transfer matrix held dense: `y = M·x` on each channel.
struct DenseGather {
    n: usize,
    m: Vec<f32>,
}

impl Gather for DenseGather {
    fn name(&self) -> &str {
        "dense"
    }

    fn patches(&self) -> usize {
        self.n
    }

    fn gather(&mut self, x: &[Rgb], y: &mut [Rgb]) -> Result<(), GatherError> {
        for (i, out) in y.iter_mut().enumerate() {
            let row = &self.m[i * self.n..(i + 1) * self.n];
            *out = row
                .iter()
                .zip(x)
                .fold(Rgb::ZERO, |acc, (&m, &v)| acc + v * m);
        }
        Ok(())
    }
}

/// One room with blocks resting in it (reflectance 0.5), cut into four systems through open
/// space, where most light crosses the cuts: the hardest case for the light between systems.
/// Each system's own transfer from its own block of F, the coupling the rest; the whole
/// room's one-matrix transfer beside it. In the level's numbering (system by system).
struct RoomLevel {
    level: Systems<DenseGather>,
    whole: DenseGather,
    /// Each position's patch area.
    area: Vec<f64>,
    /// Each position's reflectance.
    rho: Vec<f64>,
    crossing: f64,
}

impl RoomLevel {
    fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        let (quads, mats, _) = resting_blocks_room(0.5);
        let scene = Scene::load_obj(&write_scene(dir.path(), "room", &quads, &mats)).unwrap();
        let (patches, ff) = ray_cast_rows(&scene, 400);
        let n = ff.n;
        let part = partition(&patches, &ff, n.div_ceil(4));
        assert_eq!(part.count, 4);
        let split = Split::new(&ff, &part);
        let at = |k: usize| &patches.patches[split.order[k] as usize];
        let rho: Vec<f64> = (0..n).map(|k| f64::from(at(k).reflectance.r)).collect();
        let grey = |r: &[f64]| r.iter().map(|&v| [v; 3]).collect::<Vec<_>>();
        // The whole room's F in the level's numbering.
        let mut position = vec![0usize; n];
        for (k, &i) in split.order.iter().enumerate() {
            position[i as usize] = k;
        }
        let mut f = vec![0.0; n * n];
        for i in 0..n {
            for (j, v) in ff.row(i) {
                f[position[i] * n + position[j]] = f64::from(v);
            }
        }
        let (m, _) =
            transfer_matrix(&Dense::new(n, f), &grey(&rho), 1, BounceSpec::Infinite).unwrap();
        let whole = DenseGather { n, m };
        let gathers = (0..part.count)
            .map(|s| {
                let f = split.own_block(&ff, s);
                let r = split.ranges[s].clone();
                let (m, _) = transfer_matrix(&f, &grey(&rho[r]), 1, BounceSpec::Infinite).unwrap();
                DenseGather { n: f.n, m }
            })
            .collect();
        let reflectance = rho.iter().map(|&r| Rgb::splat(r as f32)).collect();
        let level = Systems::new(gathers, split.ranges, split.coupling, reflectance).unwrap();
        Self {
            level,
            whole,
            area: (0..n).map(|k| at(k).area).collect(),
            rho,
            crossing: part.crossing_share(&patches, &ff),
        }
    }

    /// A first exitance `ρ·H_d` with an uneven direct light, `scale` in system `lit`'s patches.
    fn first(&self, lit: usize, scale: f32) -> Vec<Rgb> {
        let r = self.level.range(lit);
        (0..self.rho.len())
            .map(|k| {
                let s = if r.contains(&k) { scale } else { 1.0 };
                Rgb::splat((self.rho[k] * (1 + k % 7) as f64) as f32 * s)
            })
            .collect()
    }

    /// The area-weighted error of the level's gathered light against the one-matrix answer.
    fn error(&mut self, first: &[Rgb]) -> f64 {
        let mut want = vec![Rgb::ZERO; first.len()];
        self.whole.gather(first, &mut want).unwrap();
        let (mut e, mut w) = (0.0, 0.0);
        for (k, want) in want.iter().enumerate() {
            e += self.area[k] * f64::from((self.level.gathered()[k].r - want.r).abs());
            w += self.area[k] * f64::from(want.r);
        }
        e / w
    }
}

#[test]
fn systems_light_converges_to_the_one_matrix_answer() {
    let mut room = RoomLevel::new();
    let first = room.first(0, 1.0);
    let mut errors = Vec::new();
    for _ in 0..12 {
        room.level.frame(&first).unwrap();
        errors.push(room.error(&first));
    }
    eprintln!(
        "crossing {:.1}% of the exchange; error after each frame {errors:?}",
        100.0 * room.crossing
    );
    // Block Gauss–Seidel converges to the one-matrix answer: measured (45% of the exchange
    // crossing cuts) 0.39, 0.055, 0.0069, 8.6e-4, 1.1e-4, 1.4e-5, 1.7e-6, then 2.4e-7 from the
    // ninth frame on, the f32 rounding of the two routes. Bounds: the error falls every frame
    // until it reaches rounding, and ends below 1e-5.
    assert!(errors.windows(2).take(7).all(|w| w[1] < w[0]), "{errors:?}");
    assert!(errors[11] < 1e-5, "{errors:?}");
}

/// A budget of `n` system updates.
fn updates(n: usize) -> impl FnMut() -> bool {
    let mut left = n;
    move || {
        let go = left > 0;
        left = left.saturating_sub(1);
        go
    }
}

#[test]
fn a_budget_updates_the_systems_in_need_first() {
    let mut room = RoomLevel::new();
    let first = room.first(2, 1.0);
    for _ in 0..12 {
        room.level.frame(&first).unwrap();
    }
    // The light in system 2 doubles: it alone needs an update, and a budget of one takes it.
    let brighter = room.first(2, 2.0);
    let mut one = {
        let mut left = 1;
        move || {
            left -= 1;
            left >= 0
        }
    };
    assert_eq!(
        room.level.update_within(&brighter, &mut one).unwrap(),
        vec![2]
    );
    // Its change now reaches the others; the one that matters most (priority) goes next,
    // even if another needs more.
    let need = room.level.need().to_vec();
    assert_eq!(need[2], 0.0);
    assert!([0, 1, 3].iter().all(|&s| need[s] > 0.0), "{need:?}");
    let least = [0, 1, 3]
        .into_iter()
        .min_by(|&a, &b| need[a].total_cmp(&need[b]))
        .unwrap();
    assert!(room.level.set_priority(least, 1e6));
    assert!(!room.level.set_priority(least, f32::NAN), "refused");
    assert_eq!(
        room.level
            .update_within(&brighter, &mut updates(1))
            .unwrap(),
        vec![least]
    );
    // Two systems a frame: the light still settles to the one-matrix answer, to f32
    // rounding (measured 2.5e-7 after 30 such frames).
    for _ in 0..30 {
        room.level
            .update_within(&brighter, &mut updates(2))
            .unwrap();
    }
    let e = room.error(&brighter);
    eprintln!("after 30 budgeted frames: {e:e}");
    assert!(e < 1e-5, "{e}");
}

#[test]
fn the_parallel_coupling_product_gives_the_same_light_bit_for_bit() {
    // `radiosity_runtime::systems::parallel_incoming` sums each row as the core does, only on
    // other threads: three frames give identical light.
    let mut serial = RoomLevel::new();
    let mut parallel = RoomLevel::new();
    parallel
        .level
        .set_incoming(radiosity_runtime::systems::parallel_incoming);
    let first = serial.first(1, 1.0);
    for _ in 0..3 {
        serial.level.frame(&first).unwrap();
        parallel.level.frame(&first).unwrap();
    }
    let bits = |l: &Systems<DenseGather>| -> Vec<u32> {
        l.gathered()
            .iter()
            .flat_map(|v| [v.r.to_bits(), v.g.to_bits(), v.b.to_bits()])
            .collect()
    };
    assert_eq!(bits(&serial.level), bits(&parallel.level));
}

/// The block system of a level solved directly, per channel in f64: with `M` the systems'
/// decoded transfers (block diagonal), `F` the coupling and `C = diag(ρ)`, the fixed point of
/// `g = F·(x + C·y)`, `y = g + M·(x + C·g)` is
/// `(I − F·C − M·C·F·C)·y = F·x + M·x + M·C·F·x`, solved by Gaussian elimination with
/// partial pivoting. `coupled = false` leaves the coupling out (each system alone).
fn level_direct(level: &radiosity_core::RadFile<'_>, x: &[Rgb], coupled: bool) -> Vec<[f64; 3]> {
    use radiosity_core::DecodeMode;
    let sys = level.systems.as_ref().unwrap();
    let n = level.n();
    let ch = |v: Rgb, c: usize| f64::from([v.r, v.g, v.b][c]);
    let mut y = vec![[0.0f64; 3]; n];
    for c in 0..3 {
        // Dense M (block diagonal) and F over the level's patches.
        let mut m = vec![0.0f64; n * n];
        for s in 0..sys.count() {
            let one = sys.system(level, s).unwrap();
            let r = sys.range(s);
            let k = r.len();
            let ch_count = one.matrix.layout.channels();
            let d = one.matrix.decode_dense(DecodeMode::D3d10);
            for i in 0..k {
                for j in 0..k {
                    m[(r.start + i) * n + r.start + j] = f64::from(d[(i * k + j) * ch_count + c]);
                }
            }
        }
        let mut f = vec![0.0f64; n * n];
        if coupled {
            let cp = &sys.coupling;
            for i in 0..n {
                for e in cp.row_ptr[i] as usize..cp.row_ptr[i + 1] as usize {
                    f[i * n + cp.cols[e] as usize] += f64::from(cp.values[e]);
                }
            }
        }
        let rho: Vec<f64> = level.patches.iter().map(|p| ch(p.reflectance, c)).collect();
        let xc: Vec<f64> = x.iter().map(|&v| ch(v, c)).collect();
        let mul = |a: &[f64], v: &[f64]| -> Vec<f64> {
            (0..n)
                .map(|i| (0..n).map(|j| a[i * n + j] * v[j]).sum())
                .collect()
        };
        // b = F·x + M·(x + C·F·x)
        let fx = mul(&f, &xc);
        let inner: Vec<f64> = (0..n).map(|i| xc[i] + rho[i] * fx[i]).collect();
        let mi = mul(&m, &inner);
        let mut b: Vec<f64> = (0..n).map(|i| fx[i] + mi[i]).collect();
        // A = I − F·C − M·C·F·C, column by column.
        let mut a = vec![0.0f64; n * n];
        for j in 0..n {
            let fc: Vec<f64> = (0..n).map(|i| f[i * n + j] * rho[j]).collect();
            let cfc: Vec<f64> = (0..n).map(|i| rho[i] * fc[i]).collect();
            let mcfc = mul(&m, &cfc);
            for i in 0..n {
                a[i * n + j] = f64::from(u8::from(i == j)) - fc[i] - mcfc[i];
            }
        }
        for col in 0..n {
            let p = (col..n)
                .max_by(|&u, &v| a[u * n + col].abs().total_cmp(&a[v * n + col].abs()))
                .unwrap();
            for k in 0..n {
                a.swap(col * n + k, p * n + k);
            }
            b.swap(col, p);
            for r in col + 1..n {
                let q = a[r * n + col] / a[col * n + col];
                for k in col..n {
                    a[r * n + k] -= q * a[col * n + k];
                }
                b[r] -= q * b[col];
            }
        }
        for r in (0..n).rev() {
            let s: f64 = (r + 1..n).map(|k| a[r * n + k] * y[k][c]).sum();
            y[r][c] = (b[r] - s) / a[r * n + r];
        }
    }
    y
}

#[test]
fn a_level_lit_to_the_steady_state_is_its_block_system_solved_directly() {
    use radiosity_backend_cpu::CpuGather;
    use radiosity_runtime::systems::Level;
    let level = radiosity_tests::fixtures::sample_level(&[9, 14, 5]);
    let n = level.n();
    assert_eq!(n, 28);
    // The first exitance: the emitter plus some direct light on every patch.
    let x: Vec<Rgb> = level
        .patches
        .iter()
        .enumerate()
        .map(|(i, p)| p.emission + p.reflectance * (1.0 + (i % 5) as f32))
        .collect();
    let mut lit = Level::new(&level, |_, one| {
        Ok::<_, std::convert::Infallible>(CpuGather::new(one.matrix.clone().into_owned()))
    })
    .unwrap();
    assert_eq!((lit.count(), lit.patches()), (3, n));
    let frames = lit.steady(&x, 1e-6, 200).unwrap();
    assert!(frames > 1 && frames < 200, "{frames} frames");
    assert!(lit.change() <= 1e-6, "relative change {}", lit.change());

    let want = level_direct(&level, &x, true);
    let alone = level_direct(&level, &x, false);
    let scale = want.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.1, "the level is lit: {scale}");
    let err = |a: &[[f64; 3]]| {
        lit.gathered()
            .iter()
            .zip(a)
            .map(|(g, w)| {
                (f64::from(g.r) - w[0])
                    .abs()
                    .max((f64::from(g.g) - w[1]).abs())
                    .max((f64::from(g.b) - w[2]).abs())
            })
            .fold(0.0f64, f64::max)
            / scale
    };
    // f32 sums of at most 28 terms (≈ 28 · 6e-8 ≈ 2e-6 relative) and frames stopped at a
    // 1e-6 relative change, contracting by well under one half a frame (the coupling's rows
    // sum to ~0.03): 1e-4 of the largest irradiance is ample, and a hundred times below what
    // leaving the coupling out costs (checked below, so the comparison can tell them apart).
    let tol = 1e-4;
    let e = err(&want);
    assert!(e < tol, "max error {e:e} of the largest irradiance");
    let e_alone = err(&alone);
    assert!(
        e_alone > 100.0 * tol,
        "the coupling matters in this level: {e_alone:e}"
    );
}

#[test]
fn a_one_matrix_file_is_not_a_level() {
    use radiosity_backend_cpu::CpuGather;
    use radiosity_runtime::systems::{Level, LevelError};
    let file = radiosity_tests::fixtures::sample_file(12, 3, radiosity_core::Format::Bc1, 16);
    let r = Level::new(&file, |_, one| {
        Ok::<_, std::convert::Infallible>(CpuGather::new(one.matrix.clone().into_owned()))
    });
    assert!(matches!(r, Err(LevelError::NotALevel)));
    // A constructor's error is passed on with its system.
    let level = radiosity_tests::fixtures::sample_level(&[4, 6]);
    let r = Level::<CpuGather<'static>>::new(
        &level,
        |s, _| if s == 1 { Err("no") } else { Err("first") },
    );
    assert!(matches!(r, Err(LevelError::Gather(0, "first"))));
    let mut lit = Level::new(&level, |_, one| {
        Ok::<_, std::convert::Infallible>(CpuGather::new(one.matrix.clone().into_owned()))
    })
    .unwrap();
    // The wrong number of first exitances is an error, not a panic.
    assert!(lit.steady(&[Rgb::ZERO; 3], 1e-4, 10).is_err());
}
