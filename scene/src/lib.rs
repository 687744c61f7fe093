//! `radiosity-scene`: scenes loaded into full-detail triangles with objects, materials and
//! textures, for the bake and the path tracer.
//!
//! The model is here: [`Scene`] (positions, [`Triangle`]s, object names, [`Material`]s,
//! [`Texture`]s, vertex colours, alpha coverage, the [`LoadReport`]) with its geometric
//! queries and [`Scene::occluders`]. The readers are one module per format, chosen by
//! extension from the one table in [`format`]: `obj/` (OBJ statements by its own reader, MTL
//! through tobj) and `gltf/` (glTF 2.0, `.gltf` and `.glb`); `texture` decodes their albedo
//! images. `checks` holds what every reader checks the same way (reflectance, emission,
//! degenerate and duplicate triangles). Every failure is a [`SceneError`] whose one-line
//! message names the file, and the line or item where one is known; nothing panics on input.
//!
//! Conventions (`docs/contract.md`): `Kd` is the diffuse reflectance ρ (each channel in `[0, 1)`),
//! multiplied by the mean of `map_Kd` where one is given; `Ke` is emitted radiance L and the
//! stored emission is the exitance π·L. Triangles are one-sided, front = counter-clockwise.
//! glTF (`gltf/`) maps `baseColorFactor` × `baseColorTexture` and `emissiveFactor` ×
//! `emissiveStrength` onto the same conventions.
//!
//! # Adding a scene format
//!
//! 1. A module `src/<format>/` with `pub(crate) fn load(path: &Path, options: &LoadOptions)
//!    -> Result<Scene, SceneError>`: positions in scene units, counter-clockwise fronts,
//!    material 0 the grey fallback (`Material::default_grey`), reflectance through
//!    `checks::checked_reflectance`, emission through `checks::checked_emission`, triangles
//!    through `checks::TriangleFilter`, then `LoadReport::warn_skipped` and
//!    `Scene::limit_reflectance`; no triangle left is [`SceneError::EmptyScene`].
//! 2. A row in [`format::FORMATS`] with its extensions (lower case) and that reader, and a
//!    [`format::FormatKind`] variant; the extension tests in `format` name the new ones.
//! 3. Errors: the existing [`SceneError`] variants where they fit (an unreadable file is
//!    `Io`, a bad material `Material`, a bad image `Texture`); a new variant for a failure of
//!    the format's own, with a message that names the file and the item.
//! 4. Tests: unit tests beside the reader for its own parsing; a loading test in the
//!    workspace's `tests/tests/` (as `scene_loading.rs`, `gltf_loading.rs`) that loads a small
//!    file, checks its triangles, materials and objects against the same scene in OBJ, and
//!    checks that each malformed input gives its one-line error.
#![deny(missing_docs)]

pub use error::SceneError;
use glam::DVec3;
use radiosity_core::Rgb;
use radiosity_geometry::Occluders;
use std::path::{Path, PathBuf};
pub use texture::Texture;

mod checks;
mod error;
pub mod format;
mod gltf;
mod obj;
mod texture;

/// Reflectance used where a face has no material (no MTL, unknown `usemtl`, no `Kd`).
pub const DEFAULT_REFLECTANCE: f32 = 0.5;

/// A surface material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name from `newmtl` (`default` for the fallback).
    pub name: String,
    /// Diffuse reflectance ρ from `Kd`, each channel in `[0, 1)`.
    pub reflectance: Rgb,
    /// Emitted exitance E = π·`Ke` (W/m²).
    pub emission: Rgb,
    /// Index into [`Scene::textures`] of the `map_Kd` texture that multiplies `reflectance`.
    pub texture: Option<u32>,
}

impl Material {
    /// The fallback material: grey 0.5, no emission.
    pub(crate) fn default_grey() -> Self {
        Self {
            name: "default".into(),
            reflectance: Rgb::splat(DEFAULT_REFLECTANCE),
            emission: Rgb::ZERO,
            texture: None,
        }
    }
}

/// One full-detail triangle (front = counter-clockwise).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Indices into [`Scene::positions`] (the OBJ's own vertex numbering, 0-based).
    pub vertices: [u32; 3],
    /// Indices into [`Scene::texcoords`], when the face has them.
    pub texcoords: Option<[u32; 3]>,
    /// Index into [`Scene::objects`].
    pub object: u32,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// The OBJ line of the face it came from (0 for glTF files and scenes built in code).
    pub line: u32,
}

/// What the loader fixed or skipped, for the caller to show.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadReport {
    /// Human-readable warnings (missing MTL, unknown material, skipped faces …).
    pub warnings: Vec<String>,
    /// Zero-area triangles skipped.
    pub degenerate_triangles: usize,
    /// Triangles skipped because an identical one (same corners, same winding) came earlier.
    pub duplicate_triangles: usize,
    /// `f` statements with fewer than three corners, skipped.
    pub short_faces: usize,
}

/// Options of [`Scene::load_obj_with`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadOptions {
    /// Invalid materials (reflectance outside `[0, 1)`, bad emission, an unreadable texture)
    /// are errors. `false` turns them into warnings and repairs them (reflectance clamped to
    /// `[0, 0.999]`, emission and texture dropped): for geometry-only uses such as view
    /// factors, where materials do not matter.
    pub validate_materials: bool,
    /// A reflectance cap in `(0, 1)`: reflectance channels (MTL `Kd`, glTF `baseColorFactor`,
    /// each times its texture's mean over a triangle) at or above it are lowered to it, with
    /// one warning. `None` (the default) lowers those at or above 1 (a white the exporter did
    /// not measure; no surface reflects all the light it receives) to
    /// [`DEFAULT_MAX_REFLECTANCE`].
    pub max_reflectance: Option<f64>,
}

/// What a reflectance at or above 1 is lowered to when no cap is given: the reflectance of
/// bright white paint (0.8–0.9 measured; 0.95 keeps a white exporter's intent and a closed
/// room's bounces finite, docs/decisions/max-reflectance.md).
pub const DEFAULT_MAX_REFLECTANCE: f64 = 0.95;

impl LoadOptions {
    /// `(threshold, cap)`: channels at or above `threshold` are lowered to `cap`.
    pub fn reflectance_limit(&self) -> (f64, f64) {
        match self.max_reflectance {
            Some(r) => (r, r),
            None => (1.0, DEFAULT_MAX_REFLECTANCE),
        }
    }
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            validate_materials: true,
            max_reflectance: None,
        }
    }
}

impl LoadOptions {
    /// For geometry-only uses: materials are repaired with a warning instead of refused.
    pub fn geometry_only() -> Self {
        Self {
            validate_materials: false,
            max_reflectance: None,
        }
    }
}

/// A loaded scene: every triangle at full detail, with its object and material.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Where it came from (empty for built scenes).
    pub path: PathBuf,
    /// Every OBJ `v`, in file order: the "original vertices".
    pub positions: Vec<DVec3>,
    /// Every OBJ `vt`.
    pub texcoords: Vec<[f64; 2]>,
    /// Non-degenerate, de-duplicated triangles.
    pub triangles: Vec<Triangle>,
    /// Object names (`o`, else `g`), each name once, in order of first appearance.
    pub objects: Vec<String>,
    /// Materials; index 0 is always the grey fallback.
    pub materials: Vec<Material>,
    /// Decoded `map_Kd` textures.
    pub textures: Vec<Texture>,
    /// What the loader skipped or guessed.
    pub report: LoadReport,
    /// Per-vertex colour (glTF `COLOR_0`), aligned with `positions`, multiplying the
    /// reflectance; empty when no vertex has one.
    pub vertex_colours: Vec<[f64; 3]>,
    /// `(threshold, cap)` of [`LoadOptions::reflectance_limit`]: the reflectance a triangle
    /// shows ([`Self::reflectance_over`]) has each channel at or above `threshold` lowered to
    /// `cap`. `None` for built scenes: reflectance as given.
    pub reflectance_limit: Option<(f64, f64)>,
    /// Per-triangle alpha coverage in `[0, 1]` (glTF `alphaMode` MASK: the fraction of the
    /// triangle at or above `alphaCutoff`; BLEND: its mean alpha), aligned with `triangles`;
    /// empty when every triangle is opaque (coverage 1). Triangles of coverage 0 are not
    /// loaded (see docs/decisions/alpha-coverage.md).
    pub coverage: Vec<f32>,
}

impl LoadReport {
    /// The warnings for the degenerate and duplicate triangles counted so far (none when
    /// there are none).
    pub(crate) fn warn_skipped(&mut self, path: &Path) {
        if self.degenerate_triangles > 0 {
            self.warnings.push(format!(
                "{}: skipped {} degenerate (zero-area) triangle(s)",
                path.display(),
                self.degenerate_triangles
            ));
        }
        if self.duplicate_triangles > 0 {
            self.warnings.push(format!(
                "{}: skipped {} duplicate triangle(s) (same corners, same winding as an earlier one)",
                path.display(),
                self.duplicate_triangles
            ));
        }
    }
}

impl Scene {
    /// Loads a scene file with the reader its extension names in [`format::FORMATS`]: glTF
    /// 2.0 for `.gltf` and `.glb`, OBJ + MTL ([`Self::load_obj_with`]) for anything else.
    ///
    /// Errors (never panics) for a missing or unreadable file, a malformed file, an invalid
    /// material or texture, or a scene without any usable triangle (see [`SceneError`]).
    pub fn load_with(path: &Path, options: &LoadOptions) -> Result<Self, SceneError> {
        format::of(path).read(path, options)
    }

    /// [`Self::load_with`] with the default options.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        Self::load_with(path, &LoadOptions::default())
    }

    /// A scene built in code: triangles as corner positions, each with an object index into
    /// `objects`, all grey 0.5. Degenerate triangles are skipped and counted as when loading.
    pub fn from_triangles(objects: Vec<String>, triangles: &[([DVec3; 3], u32)]) -> Self {
        let mut s = Scene {
            objects,
            materials: vec![Material::default_grey()],
            ..Default::default()
        };
        for (p, object) in triangles {
            assert!(
                (*object as usize) < s.objects.len(),
                "object index out of range"
            );
            if checks::is_degenerate(*p) {
                s.report.degenerate_triangles += 1;
                continue;
            }
            let base = s.positions.len() as u32;
            s.positions.extend_from_slice(p);
            s.triangles.push(Triangle {
                vertices: [base, base + 1, base + 2],
                texcoords: None,
                object: *object,
                material: 0,
                line: 0,
            });
        }
        s
    }

    /// Corner positions of triangle `t`.
    #[inline]
    pub fn corners(&self, t: usize) -> [DVec3; 3] {
        self.triangles[t]
            .vertices
            .map(|i| self.positions[i as usize])
    }

    /// Sets the reflectance limit of `options` and warns, in one line, where it lowers the
    /// reflectance: the share of the surface and the materials (each triangle's whole mean,
    /// texture included).
    pub(crate) fn limit_reflectance(&mut self, options: &LoadOptions) {
        let (threshold, cap) = options.reflectance_limit();
        self.reflectance_limit = Some((threshold, cap));
        let whole = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let (mut lowered, mut total) = (0.0, 0.0);
        let mut materials: std::collections::BTreeMap<u32, [f64; 3]> = Default::default();
        for t in 0..self.triangles.len() {
            let a = self.triangle_area(t);
            total += a;
            let raw = self.raw_reflectance_over(t, whole);
            if raw.iter().any(|&c| c >= threshold) {
                lowered += a;
                let m = materials
                    .entry(self.triangles[t].material)
                    .or_insert([0.0; 3]);
                for k in 0..3 {
                    m[k] = m[k].max(raw[k]);
                }
            }
        }
        if lowered == 0.0 {
            return;
        }
        let names: Vec<String> = materials
            .iter()
            .take(8)
            .map(|(&m, top)| {
                let mat = &self.materials[m as usize];
                let textured = if mat.texture.is_some() {
                    " × texture"
                } else {
                    ""
                };
                format!(
                    "`{}` (up to {:.3} {:.3} {:.3}{textured})",
                    mat.name, top[0], top[1], top[2]
                )
            })
            .collect();
        let more = materials.len().saturating_sub(8);
        let more = if more > 0 {
            format!(" and {more} more")
        } else {
            String::new()
        };
        let how = match options.max_reflectance {
            Some(_) => "--max-reflectance".to_owned(),
            None => "--max-reflectance R lowers from R instead".to_owned(),
        };
        self.report.warnings.push(format!(
            "{}: reflectance at or above {threshold} lowered to {cap} on {:.1}% of the surface ({lowered:.6} of {total:.6} scene units²): {}{more}; {how}",
            self.path.display(),
            100.0 * lowered / total.max(f64::MIN_POSITIVE),
            names.join(", ")
        ));
    }

    /// The occlusion BVH over every triangle, with each triangle's emission flag (an emitter
    /// drawn on a surface covers it: [`Occluders::covered`]) and its alpha coverage
    /// ([`Occluders::with_coverage`]: rays go through a triangle of coverage c with
    /// probability 1 − c).
    pub fn occluders(&self) -> Occluders {
        let corners: Vec<[DVec3; 3]> = (0..self.triangles.len()).map(|t| self.corners(t)).collect();
        let emits = self
            .triangles
            .iter()
            .map(|t| self.materials[t.material as usize].emission.mean() > 0.0)
            .collect();
        Occluders::with_emitters(&corners, emits).with_coverage(self.coverage.clone())
    }

    /// Area of triangle `t`.
    pub fn triangle_area(&self, t: usize) -> f64 {
        let p = self.corners(t);
        0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
    }

    /// Unit front normal of triangle `t` (counter-clockwise winding).
    pub fn triangle_normal(&self, t: usize) -> DVec3 {
        let p = self.corners(t);
        (p[1] - p[0]).cross(p[2] - p[0]).normalize()
    }

    /// Total area of each object.
    pub fn object_areas(&self) -> Vec<f64> {
        let mut a = vec![0.0; self.objects.len()];
        for t in 0..self.triangles.len() {
            a[self.triangles[t].object as usize] += self.triangle_area(t);
        }
        a
    }

    /// Axis-aligned bounds of the triangles (min, max).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in 0..self.triangles.len() {
            for p in self.corners(t) {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        (lo, hi)
    }

    /// Mean reflectance of triangle `t` over the sub-region given by barycentric corners
    /// (`Kd` times the mean of `map_Kd` over that region; `Kd` alone without a texture).
    pub fn reflectance_over(&self, t: usize, bary: [[f64; 3]; 3]) -> [f64; 3] {
        self.limited(self.raw_reflectance_over(t, bary))
    }

    /// A reflectance under [`Self::reflectance_limit`].
    pub fn limited(&self, rho: [f64; 3]) -> [f64; 3] {
        match self.reflectance_limit {
            Some((threshold, cap)) => rho.map(|c| if c >= threshold { cap } else { c }),
            None => rho,
        }
    }

    /// [`Self::reflectance_over`] before the limit: `Kd` (or `baseColorFactor`) times the
    /// texture's mean, times the vertex colours' mean.
    fn raw_reflectance_over(&self, t: usize, bary: [[f64; 3]; 3]) -> [f64; 3] {
        let rho = self.material_reflectance_over(t, bary);
        if self.vertex_colours.is_empty() {
            return rho;
        }
        // Linear over the triangle: its mean over the sub-triangle is the mean at its corners.
        let v = self.triangles[t].vertices;
        let c = v.map(|i| {
            self.vertex_colours
                .get(i as usize)
                .copied()
                .unwrap_or([1.0; 3])
        });
        let mut mean = [0.0; 3];
        for b in bary {
            for k in 0..3 {
                mean[k] += (b[0] * c[0][k] + b[1] * c[1][k] + b[2] * c[2][k]) / 3.0;
            }
        }
        [rho[0] * mean[0], rho[1] * mean[1], rho[2] * mean[2]]
    }

    /// The material's reflectance over a sub-triangle: `Kd` times the texture's mean.
    fn material_reflectance_over(&self, t: usize, bary: [[f64; 3]; 3]) -> [f64; 3] {
        let tri = &self.triangles[t];
        let mat = &self.materials[tri.material as usize];
        let kd = mat.reflectance.to_array().map(f64::from);
        match (mat.texture, tri.texcoords) {
            (Some(tex), Some(vt)) => {
                let uv = vt.map(|i| self.texcoords[i as usize]);
                let at = |b: [f64; 3]| {
                    [
                        b[0] * uv[0][0] + b[1] * uv[1][0] + b[2] * uv[2][0],
                        b[0] * uv[0][1] + b[1] * uv[1][1] + b[2] * uv[2][1],
                    ]
                };
                let m = self.textures[tex as usize].mean_over_triangle(bary.map(at));
                [kd[0] * m[0], kd[1] * m[1], kd[2] * m[2]]
            }
            _ => kd,
        }
    }
}

#[cfg(test)]
mod occluder_tests {
    use super::{Material, Scene, Triangle};
    use glam::dvec3;

    /// A light drawn in the plane of the ceiling it overlaps (the Cornell page's box): a ray from
    /// the floor reaches the light whichever of the two coincident faces the BVH meets first, and
    /// the ceiling under the light is covered (hidden from the floor, buried to the bake).
    #[test]
    fn an_emitter_in_the_plane_of_a_surface_covers_it() {
        // Facing down (−y): corners counter-clockwise seen from below.
        let square = |lo: f64, hi: f64| {
            [
                dvec3(lo, 1.0, lo),
                dvec3(hi, 1.0, lo),
                dvec3(hi, 1.0, hi),
                dvec3(lo, 1.0, hi),
            ]
        };
        let mut positions = square(0.0, 1.0).to_vec();
        positions.extend(square(0.4, 0.6));
        let tri = |v: [u32; 3], material: u32| Triangle {
            vertices: v,
            texcoords: None,
            object: material,
            material,
            line: 0,
        };
        let light = Material {
            name: "light".into(),
            reflectance: radiosity_core::Rgb::splat(0.5),
            emission: radiosity_core::Rgb::splat(10.0),
            texture: None,
        };
        let scene = Scene {
            positions,
            triangles: vec![
                tri([0, 1, 2], 0),
                tri([0, 2, 3], 0),
                tri([4, 5, 6], 1),
                tri([4, 6, 7], 1),
            ],
            objects: vec!["ceiling".into(), "light".into()],
            materials: vec![Material::default_grey(), light],
            ..Default::default()
        };
        let occ = scene.occluders();
        let floor = dvec3(0.5, 0.0, 0.45);
        // (0.55, 1, 0.5) lies in triangle 0 of the ceiling and triangle 2 of the light.
        let under = dvec3(0.55, 1.0, 0.5);
        assert!(occ.reaches(floor, under, 2), "the light is seen");
        assert!(!occ.reaches(floor, under, 0), "the ceiling under it is not");
        assert!(occ.covered(0, under) && !occ.covered(2, under));
        let beside = dvec3(0.8, 1.0, 0.3);
        assert!(occ.reaches(floor, beside, 0) && !occ.covered(0, beside));
    }
}
