//! MTL libraries, read through tobj: `Kd` (times `map_Kd`) as the reflectance, `Ke` as the
//! emitted radiance.

use crate::checks::{checked_emission, checked_reflectance, exitance};
use crate::{DEFAULT_REFLECTANCE, LoadOptions, Material, Scene, SceneError, Texture};
use radiosity_core::Rgb;
use std::path::Path;

impl Scene {
    /// Reads one MTL file into `self.materials` and `by_name` (a later definition of a name
    /// replaces the earlier one); a missing file is a warning, a bad value an error.
    pub(super) fn load_mtl(
        &mut self,
        mtl_path: &Path,
        obj_path: &Path,
        obj_line: usize,
        options: &LoadOptions,
        by_name: &mut Vec<(String, u32)>,
    ) -> Result<(), SceneError> {
        let text = match std::fs::read(mtl_path) {
            Ok(b) => String::from_utf8_lossy(&b).into_owned(),
            Err(e) => {
                self.report.warnings.push(format!(
                    "{}:{obj_line}: cannot read material library {}: {e}; its materials are grey {DEFAULT_REFLECTANCE}",
                    obj_path.display(),
                    mtl_path.display()
                ));
                return Ok(());
            }
        };
        let (mats, _) =
            tobj::load_mtl_buf(&mut text.as_bytes()).map_err(|e| SceneError::Material {
                path: mtl_path.into(),
                line: None,
                material: String::new(),
                message: e.to_string(),
            })?;
        for m in mats {
            let material = self.mtl_material(&m, mtl_path, &text, options)?;
            self.materials.push(material);
            let idx = (self.materials.len() - 1) as u32;
            match by_name.iter_mut().find(|(n, _)| *n == m.name) {
                Some(entry) => entry.1 = idx,
                None => by_name.push((m.name.clone(), idx)),
            }
        }
        Ok(())
    }

    /// The scene material of MTL material `m` from `mtl_path` (whose text is `text`), its
    /// `map_Kd` decoded into `self.textures`.
    fn mtl_material(
        &mut self,
        m: &tobj::Material,
        mtl_path: &Path,
        text: &str,
        options: &LoadOptions,
    ) -> Result<Material, SceneError> {
        let bad = |message: String| SceneError::Material {
            path: mtl_path.into(),
            line: newmtl_line(text, &m.name),
            material: m.name.clone(),
            message,
        };
        let kd = m
            .diffuse
            .map(|d| d.map(f64::from))
            .unwrap_or([DEFAULT_REFLECTANCE as f64; 3]);
        // At or above 1 is lowered where the triangle shows it (`limit_reflectance`).
        let kd = checked_reflectance("Kd", kd, options, &mut self.report, bad)?;
        let ke = m.emissive.map(|d| d.map(f64::from)).unwrap_or([0.0; 3]);
        let ke = checked_emission("Ke", "Ke", ke, options, &mut self.report, bad)?;
        let dir = mtl_path.parent().unwrap_or(Path::new("."));
        let texture = match &m.diffuse_texture {
            Some(spec) => self.mtl_texture(dir, spec, options)?,
            None => None,
        };
        Ok(Material {
            name: m.name.clone(),
            reflectance: Rgb::new(kd[0] as f32, kd[1] as f32, kd[2] as f32),
            emission: exitance(ke),
            texture,
        })
    }

    /// The `map_Kd` statement `spec` (options such as `-bm 1` before the file name, relative
    /// to `dir`) decoded into `self.textures`: its index, or `None` when it cannot be decoded
    /// under geometry-only loading (with a warning).
    fn mtl_texture(
        &mut self,
        dir: &Path,
        spec: &str,
        options: &LoadOptions,
    ) -> Result<Option<u32>, SceneError> {
        let file = spec.split_whitespace().last().unwrap_or(spec);
        match Texture::load(&dir.join(file)) {
            Ok(t) => {
                self.textures.push(t);
                Ok(Some((self.textures.len() - 1) as u32))
            }
            Err(e) if !options.validate_materials => {
                self.report.warnings.push(format!("{e}; texture ignored"));
                Ok(None)
            }
            Err(e) => Err(e),
        }
    }
}

/// The line of `newmtl NAME` in an MTL text, for messages.
fn newmtl_line(text: &str, name: &str) -> Option<usize> {
    text.lines()
        .position(|l| {
            let mut t = l.split_whitespace();
            t.next() == Some("newmtl") && t.collect::<Vec<_>>().join(" ") == name
        })
        .map(|i| i + 1)
}
