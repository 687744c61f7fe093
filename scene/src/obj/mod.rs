//! The OBJ + MTL reader: the OBJ statements by `parse` (line numbers, `o` before `g`, the
//! file's own vertex numbering), the MTL libraries through tobj (`mtl`), and the faces
//! fan-triangulated into the scene.

mod mtl;
mod parse;

use crate::checks::TriangleFilter;
use crate::{DEFAULT_REFLECTANCE, LoadOptions, Material, Scene, SceneError, Triangle};
use glam::DVec3;
use parse::RawObj;
use std::path::Path;

/// Loads an OBJ file and the MTL files it names: the reader of the OBJ row of
/// [`crate::format::FORMATS`].
pub(crate) fn load(path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    Scene::load_obj_with(path, options)
}

impl Scene {
    /// Loads an OBJ file and the MTL files it names.
    ///
    /// Errors (never panics) for a missing or unreadable file, a malformed statement, NaN or
    /// infinite coordinates, out-of-range indices, reflectance outside `[0, 1)`, negative or
    /// non-finite emission, an undecodable texture, or a scene without any usable triangle.
    /// A missing MTL file or unknown material falls back to grey 0.5 with a warning.
    pub fn load_obj(path: &Path) -> Result<Self, SceneError> {
        Self::load_obj_with(path, &LoadOptions::default())
    }

    /// [`Self::load_obj`] with options.
    pub fn load_obj_with(path: &Path, options: &LoadOptions) -> Result<Self, SceneError> {
        let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
            path: path.into(),
            source,
        })?;
        Self::from_obj_str_with(path, &String::from_utf8_lossy(&bytes), options)
    }

    /// Loads OBJ text; `path` names it in messages, and MTL files are looked up beside it.
    pub fn from_obj_str(path: &Path, text: &str) -> Result<Self, SceneError> {
        Self::from_obj_str_with(path, text, &LoadOptions::default())
    }

    /// [`Self::from_obj_str`] with options.
    fn from_obj_str_with(
        path: &Path,
        text: &str,
        options: &LoadOptions,
    ) -> Result<Self, SceneError> {
        let raw = parse::parse(path, text)?;
        let mut scene = Self::obj_vertices(path, &raw);
        let by_name = scene.load_mtl_libraries(path, &raw, options)?;
        let mat_of_name = scene.obj_materials(path, &raw, &by_name);
        scene.add_obj_faces(&raw, &mat_of_name);
        scene.report.warn_skipped(path);
        scene.warn_no_material_library(path, &raw);
        if scene.triangles.is_empty() {
            return Err(SceneError::EmptyScene {
                path: path.into(),
                why: String::new(),
            });
        }
        scene.limit_reflectance(options);
        Ok(scene)
    }

    /// A scene of the OBJ's vertices and texture coordinates with the grey fallback material
    /// only, and the warning for its short faces.
    fn obj_vertices(path: &Path, raw: &RawObj) -> Self {
        let mut scene = Scene {
            path: path.into(),
            positions: raw
                .positions
                .iter()
                .map(|&p| DVec3::from_array(p))
                .collect(),
            texcoords: raw.texcoords.clone(),
            objects: Vec::new(),
            materials: vec![Material::default_grey()],
            ..Default::default()
        };
        scene.report.short_faces = raw.short_faces;
        if raw.short_faces > 0 {
            scene.report.warnings.push(format!(
                "{}: skipped {} face(s) with fewer than three corners",
                path.display(),
                raw.short_faces
            ));
        }
        scene
    }

    /// Reads every `mtllib` beside the OBJ, later definitions of a name replacing earlier
    /// ones: each material name with its index in `self.materials`.
    fn load_mtl_libraries(
        &mut self,
        path: &Path,
        raw: &RawObj,
        options: &LoadOptions,
    ) -> Result<Vec<(String, u32)>, SceneError> {
        let dir = path.parent().unwrap_or(Path::new("."));
        let mut by_name: Vec<(String, u32)> = Vec::new();
        for (lib, line) in &raw.mtllibs {
            let lib_path = dir.join(lib);
            let parts: Vec<&str> = lib.split_whitespace().collect();
            if !lib_path.exists() && parts.len() > 1 {
                // `mtllib a.mtl b.mtl`: several files on one line.
                for p in parts {
                    self.load_mtl(&dir.join(p), path, *line, options, &mut by_name)?;
                }
            } else {
                self.load_mtl(&lib_path, path, *line, options, &mut by_name)?;
            }
        }
        Ok(by_name)
    }

    /// The scene material of each `usemtl` name (in the order of `raw.material_names`): its
    /// definition in `by_name`, else the grey fallback with a warning.
    fn obj_materials(&mut self, path: &Path, raw: &RawObj, by_name: &[(String, u32)]) -> Vec<u32> {
        let mut mat_of_name = Vec::with_capacity(raw.material_names.len());
        for name in &raw.material_names {
            match by_name.iter().find(|(n, _)| n == name) {
                Some(&(_, i)) => mat_of_name.push(i),
                None => {
                    self.report.warnings.push(format!(
                        "{}: material `{name}` is not defined; using grey {DEFAULT_REFLECTANCE}",
                        path.display()
                    ));
                    mat_of_name.push(0);
                }
            }
        }
        mat_of_name
    }

    /// Fan-triangulates the faces, skipping degenerate and duplicate triangles; an object
    /// joins `self.objects` with its first triangle kept.
    fn add_obj_faces(&mut self, raw: &RawObj, mat_of_name: &[u32]) {
        let mut filter = TriangleFilter::default();
        let mut object_remap: Vec<Option<u32>> = vec![None; raw.objects.len()];
        for face in &raw.faces {
            for k in 1..face.v.len() - 1 {
                let vi = [face.v[0], face.v[k], face.v[k + 1]];
                let p = vi.map(|i| self.positions[i as usize]);
                if !filter.admit(p, &mut self.report) {
                    continue;
                }
                let object = *object_remap[face.object as usize].get_or_insert_with(|| {
                    self.objects.push(raw.objects[face.object as usize].clone());
                    (self.objects.len() - 1) as u32
                });
                let material = face.material.map_or(0, |m| mat_of_name[m as usize]);
                self.triangles.push(Triangle {
                    vertices: vi,
                    texcoords: face.vt.as_ref().map(|t| [t[0], t[k], t[k + 1]]),
                    object,
                    material,
                    line: face.line,
                });
            }
        }
    }

    /// Warns when an OBJ without any `mtllib` has faces without `usemtl` left grey.
    fn warn_no_material_library(&mut self, path: &Path, raw: &RawObj) {
        if raw.faces.iter().any(|f| f.material.is_none()) && !self.triangles.is_empty() {
            let n = self.triangles.iter().filter(|t| t.material == 0).count();
            if n > 0 && raw.mtllibs.is_empty() {
                self.report.warnings.push(format!(
                    "{}: no material library; {n} triangle(s) use grey {DEFAULT_REFLECTANCE}",
                    path.display()
                ));
            }
        }
    }
}
