use radiosity_bake::bvh::Occluders;
use radiosity_bake::pipeline::{BakeParams, Hooks, discretise};
use radiosity_bake::scene::Scene;
use radiosity_bake::voxel::VoxelParams;
fn main() {
    let scene = Scene::load_obj(std::path::Path::new(
        "scenes/cornell-box/CornellBox-Original.obj",
    ))
    .unwrap();
    let p = BakeParams {
        voxel: VoxelParams::with_patches(4096),
        ..BakeParams::default()
    };
    let d = discretise(&scene, &p, Hooks::default()).unwrap();
    let occ = Occluders::new(&scene);
    for (k, &i) in d.live.iter().enumerate() {
        let b = d.exposure.share[i];
        if b <= 0.0 {
            continue;
        }
        let s: f64 = d.f.row(k).iter().sum();
        if s < 0.5 {
            let q = &d.patches.patches[i];
            println!(
                "patch {i} share {b:.3} row {s:.3} centre {:.3?} normal {:.2?} obj {}",
                q.centre, q.normal, scene.objects[q.object as usize]
            );
            // which rays make sample points not buried
            for piece in d.patches.pieces_of(i) {
                let v = piece.polygon.vertices();
                let c = v.iter().copied().sum::<glam::DVec3>() / v.len() as f64;
                let n = piece.normal;
                let (t1, t2) = n.any_orthonormal_pair();
                let mut desc = String::new();
                for t in [
                    glam::DVec3::ZERO,
                    t1,
                    -t1,
                    t2,
                    -t2,
                    t1 * 5.67,
                    -t1 * 5.67,
                    t2 * 5.67,
                    -t2 * 5.67,
                ] {
                    let dd = n + t;
                    match occ.closest_hit_from_surface(c, dd, 100.0) {
                        None => desc += " none",
                        Some(h) => {
                            desc += &format!(
                                " {}{}",
                                if scene.triangle_normal(h.triangle as usize).dot(dd) >= 0.0 {
                                    "B"
                                } else {
                                    "F"
                                },
                                scene.triangles[h.triangle as usize].object
                            )
                        }
                    }
                }
                println!(
                    "   piece c {:.3?} area {:.4} buried {} rays:{desc}",
                    c,
                    piece.area,
                    occ.buried(c, n)
                );
            }
        }
    }
}
