//! The patch-to-patch form-factor matrix F (n × n, f64 accumulation, f32 storage).
//!
//! `F_ij = (1/A_i) ∫_{A_i} Σ_{t ∈ pieces(j)} F(x → t) · V(x, t) dA(x)`:
//! - the inner factor `F(x → t)` is the exact point-to-polygon kernel ([`crate::kernel`]), so
//!   neighbours that share an edge or nearly touch are as accurate as distant ones;
//! - the outer integral is an adaptive quadrature ([`crate::quadrature`]) that subdivides the
//!   source where it is large compared with its distance to the target;
//! - `V` is the visible fraction of `t` seen from `x`, from shadow rays against the full-detail
//!   triangles ([`Visibility`]).
//!
//! Each unordered pair is integrated once, over the patch of smaller area (the better
//! conditioned direction), giving the exchange `G = A_i F_ij = A_j F_ji`; reciprocity therefore
//! holds to rounding and the row sums are the honest accuracy check.

use crate::bvh::Occluders;
use crate::kernel::point_to_polygon;
use crate::polygon::point_polygon_distance;
use crate::quadrature::{Adaptive, Rule, integrate};
use crate::voxel::{Patches, Piece};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// How visibility between a source point and a target piece is found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Visibility {
    /// No rays: every pair sees every other unoccluded (exact for convex enclosures, and what
    /// a caller that already knows nothing occludes asks for).
    Off,
    /// Shadow rays against the full-detail triangles.
    Rays {
        /// Rays per quadrature point and target piece, to distinct points of the piece.
        /// More: smoother penumbrae, proportionally slower.
        per_sample: u32,
        /// Skip the rays for piece pairs that no triangle can come between (a conservative
        /// plane-and-box test per pair of full-detail triangles, cached when the scene has at
        /// most 2048 triangles). Exact, and much faster in mostly open scenes.
        skip_unblockable: bool,
    },
}

/// Parameters of [`form_factors`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FormFactorParams {
    /// Source-side quadrature.
    pub quadrature: Adaptive,
    /// Shadow rays.
    pub visibility: Visibility,
}

impl Default for FormFactorParams {
    fn default() -> Self {
        Self {
            quadrature: Adaptive {
                rule: Rule::Centroid,
                ratio: 0.5,
                max_depth: 5,
            },
            visibility: Visibility::Rays {
                per_sample: 1,
                skip_unblockable: true,
            },
        }
    }
}

impl FormFactorParams {
    /// Coarser quadrature: previews.
    pub fn fast() -> Self {
        Self {
            quadrature: Adaptive {
                rule: Rule::Centroid,
                ratio: 1.0,
                max_depth: 3,
            },
            ..Self::default()
        }
    }

    /// Finer quadrature and four rays per sample: final bakes.
    pub fn high_quality() -> Self {
        Self {
            quadrature: Adaptive {
                rule: Rule::Degree2,
                ratio: 0.5,
                max_depth: 6,
            },
            visibility: Visibility::Rays {
                per_sample: 4,
                skip_unblockable: true,
            },
        }
    }

    /// The default with visibility rays switched off.
    pub fn unoccluded() -> Self {
        Self {
            visibility: Visibility::Off,
            ..Self::default()
        }
    }
}

/// The computed matrix and its diagnostics.
#[derive(Clone, Debug)]
pub struct FormFactors {
    /// Number of patches.
    pub n: usize,
    /// Row-major `F_ij`, `n × n`.
    pub matrix: Vec<f32>,
    /// Shadow rays cast.
    pub rays_cast: u64,
    /// Row sums `Σ_j F_ij` (f64 sums of the stored values); 1 for a closed scene.
    pub row_sums: Vec<f64>,
    /// Largest `|A_i F_ij − A_j F_ji| / max(A_i F_ij, A_j F_ji)` over the stored matrix (f32
    /// rounding only: the exchange is computed once per pair).
    pub reciprocity_error: f64,
}

impl FormFactors {
    /// `F_ij`.
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f32 {
        self.matrix[i * self.n + j]
    }
}

/// Progress callback: `(rows done, rows in all)`, called from worker threads.
pub type Progress<'a> = &'a (dyn Fn(usize, usize) + Sync);

/// Points on a polygon for shadow rays: the `k`-th point of a deterministic low-discrepancy
/// sequence (Roberts' R3), mapped to the fan triangles by area.
pub(crate) fn polygon_point(v: &[DVec3], k: u64) -> DVec3 {
    const G: f64 = 1.220_744_084_605_759_5; // plastic-like constant for 3-D
    let a = [1.0 / G, 1.0 / (G * G), 1.0 / (G * G * G)];
    let u = [0, 1, 2].map(|d| (0.5 + a[d] * (k as f64 + 1.0)).fract());
    let m = v.len();
    let mut total = 0.0;
    for i in 1..m - 1 {
        total += (v[i] - v[0]).cross(v[i + 1] - v[0]).length();
    }
    let mut pick = u[0] * total;
    let mut i = 1;
    while i < m - 2 {
        let w = (v[i] - v[0]).cross(v[i + 1] - v[0]).length();
        if pick < w {
            break;
        }
        pick -= w;
        i += 1;
    }
    let (mut s, mut t) = (u[1], u[2]);
    if s + t > 1.0 {
        s = 1.0 - s;
        t = 1.0 - t;
    }
    v[0] + (v[i] - v[0]) * s + (v[i + 1] - v[0]) * t
}

/// Whether piece `t` can receive anything from piece `s` at all: some of `t` strictly in front
/// of `s`'s plane and some of `s` strictly in front of `t`'s.
pub(crate) fn facing(s: &[DVec3], ns: DVec3, t: &[DVec3], nt: DVec3, tol: f64) -> bool {
    let ds = ns.dot(s[0]);
    let dt = nt.dot(t[0]);
    t.iter().any(|p| ns.dot(*p) - ds > tol) && s.iter().any(|p| nt.dot(*p) - dt > tol)
}

/// Cache of [`Occluders::may_block`] per pair of full-detail triangles.
struct BlockCache {
    n: usize,
    bits: Vec<bool>,
}

impl BlockCache {
    const MAX_TRIANGLES: usize = 2048;

    fn new(patches: &Patches, occ: &Occluders, tris: &[[DVec3; 3]]) -> Option<Self> {
        let n = tris.len();
        if n > Self::MAX_TRIANGLES || patches.is_empty() {
            return None;
        }
        let normal = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
        let bits = (0..n * n)
            .into_par_iter()
            .map(|k| {
                let (a, b) = (&tris[k / n], &tris[k % n]);
                occ.may_block(a, normal(a), b, normal(b))
            })
            .collect();
        Some(Self { n, bits })
    }

    fn may_block(&self, a: u32, b: u32) -> bool {
        self.bits[a as usize * self.n + b as usize]
    }
}

/// The exchange `A_src·F(src → dst)` by integrating over `src`.
#[allow(clippy::too_many_arguments)] // internal kernel: splitting the context into a struct buys nothing
fn exchange(
    src: &[Piece],
    dst: &[Piece],
    occ: Option<&Occluders>,
    cache: Option<&BlockCache>,
    params: &FormFactorParams,
    tol: f64,
    rays: &mut u64,
    live: &mut Vec<(usize, bool)>,
) -> f64 {
    let mut total = 0.0;
    for s in src {
        let sv = s.polygon.vertices();
        live.clear();
        for (k, t) in dst.iter().enumerate() {
            if !facing(sv, s.normal, t.polygon.vertices(), t.normal, tol) {
                continue;
            }
            let need_rays = match (params.visibility, occ) {
                (Visibility::Off, _) | (_, None) => false,
                (
                    Visibility::Rays {
                        skip_unblockable, ..
                    },
                    Some(o),
                ) => {
                    !skip_unblockable
                        || match cache {
                            Some(c) => c.may_block(s.triangle, t.triangle),
                            None => o.may_block(sv, s.normal, t.polygon.vertices(), t.normal),
                        }
                }
            };
            live.push((k, need_rays));
        }
        if live.is_empty() {
            continue;
        }
        let per_sample = match params.visibility {
            Visibility::Rays { per_sample, .. } => per_sample.max(1),
            Visibility::Off => 0,
        };
        let dist = |x: DVec3| {
            live.iter()
                .map(|&(k, _)| point_polygon_distance(x, dst[k].polygon.vertices(), dst[k].normal))
                .fold(f64::INFINITY, f64::min)
        };
        let mut sample_index: u64 = 0;
        for i in 1..sv.len() - 1 {
            integrate(
                [sv[0], sv[i], sv[i + 1]],
                &params.quadrature,
                &dist,
                &mut |q| {
                    for &(k, need_rays) in live.iter() {
                        let t = &dst[k];
                        let f = point_to_polygon(q.x, s.normal, &t.polygon, t.normal);
                        if f <= 0.0 {
                            continue;
                        }
                        let vis = if need_rays {
                            let o = occ.expect("rays need occluders");
                            let mut seen = 0u32;
                            for r in 0..per_sample {
                                let y = polygon_point(
                                    t.polygon.vertices(),
                                    sample_index * per_sample as u64 + r as u64,
                                );
                                seen += o.segment_visible(q.x, y) as u32;
                            }
                            *rays += per_sample as u64;
                            seen as f64 / per_sample as f64
                        } else {
                            1.0
                        };
                        total += q.w * f * vis;
                    }
                    sample_index += 1;
                },
            );
        }
    }
    total
}

/// Computes the form-factor matrix of `patches`. `occluders` is needed for
/// [`Visibility::Rays`] (ignored otherwise); `progress` is told about finished rows.
pub fn form_factors(
    patches: &Patches,
    occluders: Option<&Occluders>,
    params: &FormFactorParams,
    progress: Option<Progress<'_>>,
) -> FormFactors {
    let n = patches.len();
    let extent = {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in &patches.pieces {
            for v in p.polygon.vertices() {
                lo = lo.min(*v);
                hi = hi.max(*v);
            }
        }
        if patches.pieces.is_empty() {
            1.0
        } else {
            (hi - lo).length()
        }
    };
    let tol = 1e-9 * extent;
    let occ = match params.visibility {
        Visibility::Off => None,
        Visibility::Rays { .. } => occluders,
    };
    let cache = match (params.visibility, occ) {
        (
            Visibility::Rays {
                skip_unblockable: true,
                ..
            },
            Some(o),
        ) => BlockCache::new(patches, o, &patches.triangles),
        _ => None,
    };
    let done = AtomicUsize::new(0);
    let rows: Vec<(Vec<f64>, u64)> = (0..n)
        .into_par_iter()
        .map_init(Vec::new, |live, i| {
            let mut rays = 0u64;
            let pi = &patches.patches[i];
            let row: Vec<f64> = (i..n)
                .map(|j| {
                    let pj = &patches.patches[j];
                    // Integrate over the smaller patch. Equal areas (regular grids) take the
                    // lower index: deciding ties by the rounding of the areas would integrate a
                    // pair from one side at one scale and from the other side at another, and
                    // the two quadratures differ by their error (measured 1e-4 to 5e-3 of the
                    // irradiance between a scene and the same scene ×3).
                    let tie = (pi.area - pj.area).abs() <= 1e-9 * pi.area.max(pj.area);
                    let (a, b) = if tie || pi.area < pj.area {
                        (i, j)
                    } else {
                        (j, i)
                    };
                    exchange(
                        patches.pieces_of(a),
                        patches.pieces_of(b),
                        occ,
                        cache.as_ref(),
                        params,
                        tol,
                        &mut rays,
                        live,
                    )
                })
                .collect();
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            if let Some(p) = progress {
                p(d, n);
            }
            (row, rays)
        })
        .collect();
    let mut matrix = vec![0f32; n * n];
    let mut rays_cast = 0;
    for (i, (row, rays)) in rows.iter().enumerate() {
        rays_cast += rays;
        let ai = patches.patches[i].area;
        for (k, &g) in row.iter().enumerate() {
            let j = i + k;
            let aj = patches.patches[j].area;
            matrix[i * n + j] = (g / ai) as f32;
            matrix[j * n + i] = (g / aj) as f32;
        }
    }
    let row_sums: Vec<f64> = (0..n)
        .map(|i| matrix[i * n..(i + 1) * n].iter().map(|&f| f as f64).sum())
        .collect();
    let mut reciprocity_error: f64 = 0.0;
    for i in 0..n {
        for j in i + 1..n {
            let a = patches.patches[i].area * matrix[i * n + j] as f64;
            let b = patches.patches[j].area * matrix[j * n + i] as f64;
            let m = a.max(b);
            if m > 0.0 {
                reciprocity_error = reciprocity_error.max((a - b).abs() / m);
            }
        }
    }
    FormFactors {
        n,
        matrix,
        rays_cast,
        row_sums,
        reciprocity_error,
    }
}
