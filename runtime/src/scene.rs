//! Lighting around the gather (`docs/contract.md`, "Conventions", runtime per frame):
//! analytic lights → direct irradiance per patch with shadow rays through a BVH over the
//! file's full-detail mesh → first exitance → gather → total irradiance and radiosity, and
//! indirect light interpolated to any point of the mesh.

use glam::{DVec3, Vec3};
use radiosity_core::{Gather, Light, Mesh, RadFile, Rgb, finish_frame, first_exitance};
use radiosity_geometry::Occluders;

/// A baked scene ready to light: the file, and the BVH over its mesh when it has one.
pub struct BakedScene {
    /// The parsed file (its patches, matrix, mesh and probes).
    pub file: RadFile<'static>,
    occluders: Option<Occluders>,
    /// The file's probes decoded for the CPU frame (`None` without probes).
    probes: Option<radiosity_core::DecodedProbes>,
}

/// One frame's per-patch quantities (matrix numbering).
#[derive(Clone, Debug, Default)]
pub struct Frame {
    /// Direct irradiance from the analytic lights, H_d.
    pub direct: Vec<Rgb>,
    /// The correction of the first bounce for where each patch's rays land on its senders, Δ
    /// (the file's BOUNCE rows, [`radiosity_core::bounce`]; zero without them).
    pub bounce: Vec<Rgb>,
    /// First exitance x = s·E + ρ∘(H_d + Δ).
    pub exitance: Vec<Rgb>,
    /// Gathered (indirect, and emitter-direct) irradiance y = M·x.
    pub gathered: Vec<Rgb>,
    /// Total irradiance H = H_d + Δ + y.
    pub irradiance: Vec<Rgb>,
    /// Radiosity B = s·E + ρ∘H.
    pub radiosity: Vec<Rgb>,
}

impl BakedScene {
    /// Wraps a file, building the BVH over its mesh (if any).
    pub fn new(file: RadFile<'static>) -> Self {
        let occluders = file.mesh.as_ref().map(|m| {
            let tris: Vec<[DVec3; 3]> = (0..m.triangles.len())
                .map(|t| m.corners(t).map(|c| Vec3::from(c).as_dvec3()))
                .collect();
            let coverage = file
                .coverage
                .as_deref()
                .map_or_else(Vec::new, <[f32]>::to_vec);
            Occluders::from_triangles(&tris).with_coverage(coverage)
        });
        let probes = file.probes.as_ref().map(radiosity_core::DecodedProbes::new);
        Self {
            file,
            occluders,
            probes,
        }
    }

    /// The file's probes, decoded for the CPU frame.
    pub fn decoded_probes(&self) -> Option<&radiosity_core::DecodedProbes> {
        self.probes.as_ref()
    }

    /// Patches.
    pub fn n(&self) -> usize {
        self.file.n()
    }

    /// The mesh, or an error saying why it is needed.
    pub fn mesh(&self, why: &str) -> crate::Result<&Mesh<'static>> {
        self.file
            .mesh
            .as_ref()
            .ok_or_else(|| crate::Error::NoMesh(why.to_owned()))
    }

    /// The bounding box of the mesh's vertices, if the file has a mesh with any.
    pub fn mesh_bounds(&self) -> Option<(DVec3, DVec3)> {
        let mesh = self.file.mesh.as_ref()?;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for p in mesh.positions.iter() {
            let p = Vec3::from(*p).as_dvec3();
            lo = lo.min(p);
            hi = hi.max(p);
        }
        lo.cmple(hi).all().then_some((lo, hi))
    }

    /// The BVH over the mesh, if the file has one.
    pub fn occluders(&self) -> Option<&Occluders> {
        self.occluders.as_ref()
    }

    /// Makes the mesh's occluders answer rays independently of the tree's shape
    /// ([`Occluders::robust`]), as a planned bake measures with them.
    pub fn make_occluders_robust(&mut self) {
        self.occluders = self.occluders.take().map(Occluders::robust);
    }

    /// Direct irradiance at a point with unit `normal` from every light, shadow rays through
    /// the mesh (or unshadowed when the file has no mesh — callers refuse that case first).
    pub fn direct_at(&self, lights: &[Light], point: DVec3, normal: DVec3) -> Rgb {
        let mut h = Rgb::ZERO;
        for l in lights {
            let Some((e, ray)) = l.irradiance_at(point.as_vec3(), normal.as_vec3()) else {
                continue;
            };
            // The share of the light that gets through: 0 or 1, or between for triangles of
            // partial coverage on the way.
            let visible = match &self.occluders {
                None => 1.0,
                Some(occ) => {
                    // A directional light's segment runs past the scene's far side.
                    let dist = if ray.distance.is_finite() {
                        f64::from(ray.distance)
                    } else {
                        2.0 * occ.extent() + (point.length())
                    };
                    let end = point + ray.direction.as_dvec3() * dist;
                    occ.segment_transmittance(point, end)
                }
            };
            if visible > 0.0 {
                h += e * visible as f32;
            }
        }
        h
    }

    /// The sky's irradiance per patch (file numbering) from the sky and environment lights
    /// among `lights` and the file's sky visibility (`radiosity_core::sky`), `None` when
    /// there is no such light. An error when there is one and the file holds no sky
    /// visibility (baked with `--sky off`): lighting it would leave the sky out silently.
    pub fn sky_irradiance(&self, lights: &[Light]) -> crate::Result<Option<Vec<Rgb>>> {
        let Some(sh) = radiosity_core::sky_sh_of(lights) else {
            return Ok(None);
        };
        let Some(vis) = &self.file.sky else {
            invalid!(
                "the file holds no sky visibility (baked with --sky off), so a sky or environment light cannot light it: bake it again with --sky on"
            );
        };
        Ok(Some(
            (0..self.n())
                .map(|p| radiosity_core::sky_irradiance(&vis.entry(p), &sh))
                .collect(),
        ))
    }

    /// The per-patch `H_d` a frame is built from (`x = E + ρ∘H_d`, `H = H_d + y`): the
    /// direct irradiance, the area-weighted mean over the patch's samples (one per piece of
    /// the full-detail surface inside the patch), so that a shadow edge crossing a patch dims
    /// it in proportion, plus the sky's ([`BakedScene::sky_irradiance`]), plus the correction
    /// of the patch's first bounce for where its rays land on its senders where the file has
    /// BOUNCE rows ([`BakedScene::first_bounce`]). This is what an engine passes on to
    /// `first_exitance` and `finish_frame`; the direct light alone is
    /// [`BakedScene::direct_with_samples`]'s.
    pub fn direct(&self, lights: &[Light]) -> crate::Result<Vec<Rgb>> {
        let (direct, at) = self.direct_with_samples(lights)?;
        Ok(self.sent(&direct, &at))
    }

    /// `H_d + Δ`: the patches' direct irradiance and each sample's
    /// ([`BakedScene::direct_with_samples`]) made into what the frame sends on
    /// ([`BakedScene::direct`]).
    pub fn sent(&self, direct: &[Rgb], at_samples: &[Rgb]) -> Vec<Rgb> {
        let bounce = self.first_bounce(direct, at_samples);
        direct.iter().zip(&bounce).map(|(d, b)| *d + *b).collect()
    }

    /// Each patch's correction of its first bounce, `Δ` ([`radiosity_core::first_bounce`]),
    /// from the patches' direct irradiance and each mesh sample's
    /// ([`BakedScene::direct_with_samples`]); zero where the file has no BOUNCE rows or no
    /// light (`at_samples` empty).
    pub fn first_bounce(&self, direct: &[Rgb], at_samples: &[Rgb]) -> Vec<Rgb> {
        let mut out = vec![Rgb::ZERO; self.n()];
        let (Some(rows), Some(mesh)) = (&self.file.bounce, &self.file.mesh) else {
            return out;
        };
        if at_samples.len() != mesh.samples.len() || direct.len() != out.len() {
            return out;
        }
        radiosity_core::first_bounce(
            rows,
            &self.file.patches,
            &mesh.sample_rows,
            direct,
            at_samples,
            &mut out,
        );
        out
    }

    /// [`BakedScene::direct`], with the direct irradiance at every sample of the mesh (its sample
    /// order; empty without lights). A sample's sky light is its patch's.
    pub fn direct_with_samples(&self, lights: &[Light]) -> crate::Result<(Vec<Rgb>, Vec<Rgb>)> {
        let n = self.n();
        if lights.is_empty() {
            return Ok((vec![Rgb::ZERO; n], Vec::new()));
        }
        let mesh = self.mesh("lighting from a lights file")?;
        use rayon::prelude::*;
        let mut at: Vec<Rgb> = mesh
            .samples
            .par_iter()
            .map(|s| {
                let pos = Vec3::from(s.position).as_dvec3();
                let nrm = Vec3::from(s.normal).as_dvec3();
                self.direct_at(lights, pos, nrm)
            })
            .collect();
        if let Some(sky) = &self.sky_irradiance(lights)? {
            for (p, s) in sky.iter().enumerate() {
                let rows = mesh.sample_rows[p] as usize..mesh.sample_rows[p + 1] as usize;
                for a in &mut at[rows] {
                    *a += *s;
                }
            }
        }
        let direct: Vec<Rgb> = (0..n)
            .into_par_iter()
            .map(|p| {
                let mut acc = Rgb::ZERO;
                let mut area = 0.0f32;
                let start = mesh.sample_rows[p] as usize;
                for (k, s) in mesh.samples_of(p).iter().enumerate() {
                    acc += at[start + k] * s.area;
                    area += s.area;
                }
                if area > 0.0 { acc * (1.0 / area) } else { acc }
            })
            .collect();
        if let Some(p) = direct
            .iter()
            .position(|v| !v.to_array().iter().all(|c| c.is_finite()))
        {
            overflow!(
                "patch {p}: the direct irradiance from the lights overflows f32 (a light too intense or too close)"
            );
        }
        Ok((direct, at))
    }

    /// A whole frame: direct light, first exitance (emitters scaled by `emission`), gather,
    /// totals.
    pub fn frame(
        &self,
        gather: &mut dyn Gather,
        lights: &[Light],
        emission: f32,
    ) -> crate::Result<(Frame, f64)> {
        if !(emission.is_finite() && emission >= 0.0) {
            invalid!("emission scale must be finite and non-negative, not {emission}");
        }
        let (direct, at) = self.direct_with_samples(lights)?;
        let bounce = self.first_bounce(&direct, &at);
        self.frame_with_direct(gather, direct, bounce, emission)
    }

    /// [`BakedScene::frame`] from direct irradiance and the first bounce's correction already
    /// computed ([`BakedScene::direct_with_samples`], [`BakedScene::first_bounce`]) for the
    /// frame's lights, for a caller that needed them first.
    pub fn frame_with_direct(
        &self,
        gather: &mut dyn Gather,
        direct: Vec<Rgb>,
        bounce: Vec<Rgb>,
        emission: f32,
    ) -> crate::Result<(Frame, f64)> {
        if !(emission.is_finite() && emission >= 0.0) {
            invalid!("emission scale must be finite and non-negative, not {emission}");
        }
        let n = self.n();
        let scaled: Vec<radiosity_core::Patch>;
        let patches: &[radiosity_core::Patch] = if emission == 1.0 {
            &self.file.patches
        } else {
            scaled = self
                .file
                .patches
                .iter()
                .map(|p| radiosity_core::Patch {
                    emission: p.emission * emission,
                    ..*p
                })
                .collect();
            &scaled
        };
        if bounce.len() != n {
            invalid!("{} first-bounce corrections for {n} patches", bounce.len());
        }
        // What the matrix sends on: the direct light and the first bounce's correction.
        let sent: Vec<Rgb> = direct.iter().zip(&bounce).map(|(d, b)| *d + *b).collect();
        let mut f = Frame {
            direct,
            bounce,
            exitance: vec![Rgb::ZERO; n],
            gathered: vec![Rgb::ZERO; n],
            irradiance: vec![Rgb::ZERO; n],
            radiosity: vec![Rgb::ZERO; n],
        };
        first_exitance(patches, &sent, &mut f.exitance);
        let t = std::time::Instant::now();
        gather.gather(&f.exitance, &mut f.gathered)?;
        let gather_ms = t.elapsed().as_secs_f64() * 1e3;
        finish_frame(
            patches,
            &sent,
            &f.gathered,
            &mut f.irradiance,
            &mut f.radiosity,
        );
        ensure_finite(&f.irradiance, &f.radiosity)?;
        Ok((f, gather_ms))
    }
}

impl BakedScene {
    /// Whether nothing lights the scene under `lights`: no patch emits and no light is given,
    /// so every irradiance is zero (a caller warns: an image would be black).
    pub fn is_unlit(&self, lights: &[Light]) -> bool {
        lights.is_empty()
            && !self
                .file
                .patches
                .iter()
                .any(|p| p.emission.max_channel() > 0.0)
    }
}

/// Refuses a frame whose irradiance or radiosity overflowed f32 (emission or light intensities
/// near f32's limit, amplified by the bounces): an error, never `inf` or `null` in the output.
pub fn ensure_finite(irradiance: &[Rgb], radiosity: &[Rgb]) -> crate::Result<()> {
    let finite = |v: &Rgb| v.to_array().iter().all(|c| c.is_finite());
    match irradiance
        .iter()
        .zip(radiosity)
        .position(|(h, b)| !(finite(h) && finite(b)))
    {
        Some(i) => overflow!(
            "patch {i}: the irradiance or radiosity overflows f32 (emission or light intensities too large)"
        ),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use radiosity_core::{
        BlockCorrections, Bounces, CornerWeight, DEFAULT_MAX_TILE, Format, MatrixLayout,
        MeshTriangle, PatchSample, SparseRows, TransferMatrix,
    };
    use std::borrow::Cow;

    /// One patch: a unit floor quad at y = 0 facing up, with a zero matrix; optionally a
    /// blocker quad at y = 1 (facing down) over half of it.
    fn floor(blocker: bool) -> BakedScene {
        let layout = MatrixLayout::new(1, 1, Format::F32, DEFAULT_MAX_TILE).unwrap();
        let mut positions = vec![[0., 0., 0.], [0., 0., 1.], [1., 0., 1.], [1., 0., 0.]];
        let mut triangles = vec![[0u32, 1, 2], [0, 2, 3]];
        if blocker {
            positions.extend([[0., 1., 0.], [0.5, 1., 0.], [0.5, 1., 1.], [0., 1., 1.]]);
            triangles.extend([[4u32, 5, 6], [4, 6, 7]]);
        }
        let nt = triangles.len();
        let mesh = Mesh {
            positions: Cow::Owned(positions),
            triangles: Cow::Owned(
                triangles
                    .into_iter()
                    .map(|vertices| MeshTriangle {
                        vertices,
                        object: 0,
                        reflectance: Rgb::splat(0.5),
                        emission: Rgb::ZERO,
                    })
                    .collect(),
            ),
            corner_rows: Cow::Owned((0..=3 * nt as u32).collect()),
            corner_weights: Cow::Owned(vec![
                CornerWeight {
                    patch: 0,
                    weight: 1.0
                };
                3 * nt
            ]),
            sample_rows: Cow::Owned(vec![0, 2]),
            samples: Cow::Owned(vec![
                PatchSample {
                    position: [0.25, 0.0, 0.5],
                    normal: [0.0, 1.0, 0.0],
                    area: 0.5,
                },
                PatchSample {
                    position: [0.75, 0.0, 0.5],
                    normal: [0.0, 1.0, 0.0],
                    area: 0.5,
                },
            ]),
        };
        let file = RadFile {
            mesh: Some(mesh),
            ..RadFile::new(
                Cow::Owned(vec![radiosity_core::Patch {
                    centre: [0.5, 0.0, 0.5],
                    area: 1.0,
                    normal: [0.0, 1.0, 0.0],
                    object: 0,
                    reflectance: Rgb::splat(0.5),
                    emission: Rgb::ZERO,
                }]),
                Cow::Owned(vec![0]),
                TransferMatrix {
                    layout,
                    scales: Cow::Owned(vec![]),
                    blocks: Cow::Owned(vec![0; 64]),
                    sparse: SparseRows::empty(1),
                    corrections: BlockCorrections::empty(1),
                },
                vec![Cow::Borrowed("floor")],
                Bounces::Infinite,
            )
        };
        file.validate().unwrap();
        BakedScene::new(file)
    }

    #[test]
    fn direct_light_follows_the_inverse_square_law_and_shadows_halve_it() {
        let light = [Light::Point {
            position: Vec3::new(0.5, 2.0, 0.5),
            intensity: Rgb::splat(8.0),
        }];
        let open = floor(false).direct(&light).unwrap()[0];
        // Samples at horizontal distance 0.25, height 2: E = I·cos/r² = I·h/r³.
        let r2: f32 = 0.25 * 0.25 + 4.0;
        let expect = 8.0 * 2.0 / (r2 * r2.sqrt());
        assert!(
            (open.r - expect).abs() < 1e-5 * expect,
            "{open:?} vs {expect}"
        );
        // The blocker (x < 0.5 at y = 1) shadows exactly the sample at x = 0.25.
        let shadowed = floor(true).direct(&light).unwrap()[0];
        assert!(
            (shadowed.r - expect / 2.0).abs() < 1e-5 * expect,
            "{shadowed:?}"
        );
    }

    #[test]
    fn lights_need_a_mesh() {
        let mut rt = floor(false);
        rt.file.mesh = None;
        let rt = BakedScene::new(rt.file);
        let light = [Light::Directional {
            direction: Vec3::NEG_Y,
            irradiance: Rgb::splat(1.0),
        }];
        let err = rt.direct(&light).unwrap_err().to_string();
        assert!(err.contains("no mesh section"), "{err}");
        assert_eq!(rt.direct(&[]).unwrap(), vec![Rgb::ZERO]);
    }
}
