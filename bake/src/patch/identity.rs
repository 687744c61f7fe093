//! A patch's seeds and identity: the seed of its ray streams from its index (a bake without a
//! plan) or from its identity, a hash of its pieces (a planned bake, so that its rays stay the
//! same when other patches are renumbered).

use super::Patches;
use crate::scene::Scene;
use rayon::prelude::*;

/// The seed of patch `i`'s ray streams ([`crate::patch::BakePatch::seed`]) in a bake
/// without a plan.
pub(crate) fn index_seed(i: usize) -> u64 {
    (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// Each patch's identity: BLAKE3 (first 16 bytes) of its pieces (polygons, normals, areas,
/// the corners of their triangles and their objects' names).
pub fn patch_keys(scene: &Scene, patches: &Patches) -> Vec<[u8; 16]> {
    (0..patches.len())
        .into_par_iter()
        .map(|i| {
            let mut h = blake3::Hasher::new();
            for q in patches.pieces_of(i) {
                let mut f = |v: f64| {
                    h.update(&v.to_bits().to_le_bytes());
                };
                for p in q.polygon.vertices() {
                    p.to_array().into_iter().for_each(&mut f);
                }
                q.normal.to_array().into_iter().for_each(&mut f);
                f(q.area);
                for p in patches.triangles[q.triangle as usize] {
                    p.to_array().into_iter().for_each(&mut f);
                }
                h.update(scene.objects[q.object as usize].as_bytes());
                h.update(&[0xff]);
            }
            let mut key = [0u8; 16];
            key.copy_from_slice(&h.finalize().as_bytes()[..16]);
            key
        })
        .collect()
}

/// Seeds every patch's rays by its identity ([`patch_keys`]), as a plan's bake does;
/// returns the identities.
pub(crate) fn seed_patches(scene: &Scene, patches: &mut Patches) -> Vec<[u8; 16]> {
    let keys = patch_keys(scene, patches);
    for (p, k) in patches.patches.iter_mut().zip(&keys) {
        p.seed = u64::from_le_bytes(k[..8].try_into().expect("8 bytes"));
    }
    keys
}
