//! Materials and their base-colour textures: glTF's metallic-roughness material read as a
//! Lambertian reflectance and an emission.

use super::Loader;
use super::accessor::read_uri;
use crate::checks::{checked_emission, checked_reflectance, exitance};
use crate::{DEFAULT_REFLECTANCE, Material, SceneError, Texture};
use radiosity_core::Rgb;

/// A material's decoded `baseColorTexture` and how its texture coordinates are read.
struct BaseColourTexture {
    /// Index into the scene's textures.
    texture: u32,
    /// The TEXCOORD_n set.
    tex_coord: u32,
    /// `KHR_texture_transform` as the rows of a 2 × 3 affine map of glTF UVs.
    transform: Option<[[f64; 3]; 2]>,
}

impl Loader<'_> {
    /// The decoded texture of glTF image `image` (cached; `None` if it failed without
    /// `validate_materials`).
    fn texture(&mut self, image: &::gltf::Image<'_>) -> Result<Option<u32>, SceneError> {
        if let Some(&t) = self.images.get(&image.index()) {
            return Ok(t);
        }
        let what = format!("image {}: ", image.index());
        let decoded = match image.source() {
            ::gltf::image::Source::View { view, .. } => {
                let buffer = &self.buffers.0[view.buffer().index()];
                match view
                    .offset()
                    .checked_add(view.length())
                    .filter(|&e| e <= buffer.len())
                {
                    Some(end) => Texture::decode(&buffer[view.offset()..end], self.path, &what),
                    None => Err(self.err(format!(
                        "{what}buffer view {} runs past the end of buffer {}",
                        view.index(),
                        view.buffer().index()
                    ))),
                }
            }
            ::gltf::image::Source::Uri { uri, .. } => match read_uri(&self.dir, uri) {
                Ok(bytes) => {
                    let shown = if uri.starts_with("data:") {
                        self.path.to_path_buf()
                    } else {
                        self.dir.join(uri)
                    };
                    Texture::decode(&bytes, &shown, &what)
                }
                Err((Some(file), m)) => Err(SceneError::Texture {
                    path: file,
                    message: m,
                }),
                Err((None, m)) => Err(self.err(format!("{what}{m}"))),
            },
        };
        let t = match decoded {
            Ok(t) => {
                self.scene.textures.push(t);
                Some((self.scene.textures.len() - 1) as u32)
            }
            Err(e) if !self.options.validate_materials => {
                self.scene
                    .report
                    .warnings
                    .push(format!("{e}; texture ignored"));
                None
            }
            Err(e) => return Err(e),
        };
        self.images.insert(image.index(), t);
        Ok(t)
    }

    /// The scene material of a glTF material (made on first use).
    pub(super) fn material(&mut self, m: &::gltf::Material<'_>) -> Result<u32, SceneError> {
        let Some(index) = m.index() else {
            return Ok(self.no_material());
        };
        if let Some(i) = self.materials[index] {
            return Ok(i);
        }
        let name = m
            .name()
            .filter(|n| !n.is_empty())
            .map(str::to_owned)
            .unwrap_or_else(|| format!("material{index}"));
        let path = self.path;
        let bad = |message: String| SceneError::Material {
            path: path.into(),
            line: None,
            material: name.clone(),
            message,
        };
        let pbr = m.pbr_metallic_roughness();
        let f = pbr.base_color_factor();
        let kd = [f[0], f[1], f[2]].map(f64::from);
        // At or above 1 (× the texture) is lowered where the triangle shows it
        // (`Scene::limit_reflectance`).
        let kd = checked_reflectance(
            "baseColorFactor",
            kd,
            self.options,
            &mut self.scene.report,
            bad,
        )?;
        let strength = m.emissive_strength().map_or(1.0, f64::from);
        let ke = m.emissive_factor().map(|c| f64::from(c) * strength);
        let ke = checked_emission(
            "emission (emissiveFactor × emissiveStrength)",
            "L",
            ke,
            self.options,
            &mut self.scene.report,
            bad,
        )?;
        let texture = match pbr.base_color_texture() {
            Some(info) => self.base_colour_texture(&info, bad)?,
            None => None,
        };
        self.note_ignored(m);
        let alpha = alpha_mode(m, f[3], bad)?;
        self.scene.materials.push(Material {
            name,
            reflectance: Rgb::new(kd[0] as f32, kd[1] as f32, kd[2] as f32),
            emission: exitance(ke),
            texture: texture.as_ref().map(|t| t.texture),
        });
        let i = (self.scene.materials.len() - 1) as u32;
        self.tex_coord_of
            .insert(i, texture.as_ref().map_or(0, |t| t.tex_coord));
        if let Some(m) = texture.and_then(|t| t.transform) {
            self.tex_transform_of.insert(i, m);
        }
        if let Some(a) = alpha {
            self.alpha_of.insert(i, a);
        }
        self.materials[index] = Some(i);
        Ok(i)
    }

    /// The material of a primitive without one: glTF's default material is white metal, not
    /// a diffuse reflectance, so the OBJ fallback (grey 0.5) is used, as for a face without
    /// material, with one warning.
    fn no_material(&mut self) -> u32 {
        if let Some(i) = self.no_material {
            return i;
        }
        self.scene.report.warnings.push(format!(
            "{}: primitive(s) without a material use grey {DEFAULT_REFLECTANCE}",
            self.path.display()
        ));
        self.no_material = Some(0);
        0
    }

    /// A material's `baseColorTexture`: the decoded image (`None` if it failed without
    /// `validate_materials`), the TEXCOORD set and the `KHR_texture_transform` it is read
    /// through; wrap modes other than REPEAT are noted as ignored.
    fn base_colour_texture(
        &mut self,
        info: &::gltf::texture::Info<'_>,
        bad: impl Fn(String) -> SceneError,
    ) -> Result<Option<BaseColourTexture>, SceneError> {
        let texture = self.texture(&info.texture().source())?;
        let s = info.texture().sampler();
        if s.wrap_s() != ::gltf::texture::WrappingMode::Repeat
            || s.wrap_t() != ::gltf::texture::WrappingMode::Repeat
        {
            self.ignored
                .insert("texture wrap modes other than REPEAT (read as REPEAT)");
        }
        let mut tex_coord = info.tex_coord();
        let mut transform = None;
        if let Some(tt) = info.texture_transform() {
            transform = Some(texture_transform(&tt, bad)?);
            tex_coord = tt.tex_coord().unwrap_or(tex_coord);
        }
        Ok(texture.map(|texture| BaseColourTexture {
            texture,
            tex_coord,
            transform,
        }))
    }

    /// Notes what of material `m` is not read: its emissive texture, metallic and roughness,
    /// normal and occlusion textures.
    fn note_ignored(&mut self, m: &::gltf::Material<'_>) {
        let pbr = m.pbr_metallic_roughness();
        if m.emissive_texture().is_some() {
            self.ignored
                .insert("emissiveTexture (the emission is emissiveFactor × emissiveStrength)");
        }
        if pbr.metallic_roughness_texture().is_some()
            || pbr.metallic_factor() != 0.0
            || pbr.roughness_factor() != 1.0
        {
            self.ignored
                .insert("metallic/roughness (surfaces are Lambertian)");
        }
        if m.normal_texture().is_some() || m.occlusion_texture().is_some() {
            self.ignored.insert("normal and occlusion textures");
        }
    }
}

/// `KHR_texture_transform` as the rows of a 2 × 3 affine map of glTF UVs, `offset + R·S·uv`
/// (R the specification's rotation, counter-clockwise in UV space); each value must be
/// finite.
fn texture_transform(
    tt: &::gltf::texture::TextureTransform<'_>,
    bad: impl Fn(String) -> SceneError,
) -> Result<[[f64; 3]; 2], SceneError> {
    let (o, r, sc) = (tt.offset(), tt.rotation(), tt.scale());
    if !o.iter().chain(&sc).chain([&r]).all(|v| v.is_finite()) {
        return Err(bad(format!(
            "KHR_texture_transform offset {o:?}, rotation {r}, scale {sc:?} must be finite"
        )));
    }
    let (c, s) = (f64::from(r).cos(), f64::from(r).sin());
    let (sx, sy) = (f64::from(sc[0]), f64::from(sc[1]));
    Ok([
        [c * sx, -s * sy, f64::from(o[0])],
        [s * sx, c * sy, f64::from(o[1])],
    ])
}

/// Material `m`'s `alphaMode` with `baseColorFactor` alpha `alpha`: `None` for OPAQUE, else
/// `(alpha, alphaCutoff for MASK)`; the cutoff finite and not negative, the alpha in `[0, 1]`.
fn alpha_mode(
    m: &::gltf::Material<'_>,
    alpha: f32,
    bad: impl Fn(String) -> SceneError,
) -> Result<Option<(f64, Option<f64>)>, SceneError> {
    let mode = match m.alpha_mode() {
        ::gltf::material::AlphaMode::Opaque => None,
        ::gltf::material::AlphaMode::Blend => Some((f64::from(alpha), None)),
        ::gltf::material::AlphaMode::Mask => {
            let cutoff = m.alpha_cutoff().unwrap_or(0.5);
            if !cutoff.is_finite() || cutoff < 0.0 {
                return Err(bad(format!(
                    "alphaCutoff {cutoff} must be finite and not negative"
                )));
            }
            Some((f64::from(alpha), Some(f64::from(cutoff))))
        }
    };
    if let Some((a, _)) = mode
        && !(a.is_finite() && (0.0..=1.0).contains(&a))
    {
        return Err(bad(format!("baseColorFactor alpha {a} must be in [0, 1]")));
    }
    Ok(mode)
}
