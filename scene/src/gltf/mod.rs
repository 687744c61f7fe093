//! The glTF 2.0 reader (`.gltf` with external or data-URI buffers, `.glb`).
//!
//! The `gltf` crate parses and validates the JSON (and the GLB container); every byte of a
//! buffer is read here through bounds-checked code, since accessor reading in the crate can
//! panic on a short buffer. Positions are transformed to world space in f64 with the full node
//! transform; a transform with negative determinant flips the winding so that the front stays
//! counter-clockwise in world space. Conventions are those of the OBJ path (`docs/contract.md`).

mod accessor;
mod material;
mod mesh;
mod nodes;

use crate::SceneError;
use crate::checks::TriangleFilter;
use crate::{LoadOptions, LoadReport, Material, Scene};
use accessor::{Buffers, read_uri};
use nodes::NodeTree;
use std::collections::{BTreeSet, HashMap, HashSet};
use std::path::{Path, PathBuf};

/// Extensions read by this loader: a file that requires any other is refused.
const SUPPORTED_EXTENSIONS: &[&str] = &["KHR_materials_emissive_strength", "KHR_texture_transform"];

/// Everything the loader needs while walking the nodes.
struct Loader<'a> {
    path: &'a Path,
    dir: PathBuf,
    doc: &'a ::gltf::Document,
    buffers: Buffers,
    options: &'a LoadOptions,
    scene: Scene,
    filter: TriangleFilter,
    /// Scene material of each glTF material (filled lazily) and of the missing material.
    materials: Vec<Option<u32>>,
    no_material: Option<u32>,
    /// Scene texture of each glTF image (`None` inside: it failed and was dropped).
    images: HashMap<usize, Option<u32>>,
    /// The TEXCOORD_n set of each scene material's texture.
    tex_coord_of: HashMap<u32, u32>,
    /// Each textured material's `KHR_texture_transform` as the rows of a 2 × 3 affine map of
    /// glTF UVs (`offset + R·S·uv`), absent for none.
    tex_transform_of: HashMap<u32, [[f64; 3]; 2]>,
    /// Each scene material with `alphaMode` MASK or BLEND: `(baseColorFactor` alpha,
    /// `alphaCutoff` for MASK`)`.
    alpha_of: HashMap<u32, (f64, Option<f64>)>,
    /// Triangles left out because their alpha coverage is 0 (wholly cut out or transparent).
    cut_out_triangles: usize,
    /// Object names used so far, for `name#2`.
    names: HashSet<String>,
    ignored: BTreeSet<&'static str>,
    skipped_primitives: usize,
    missing_texcoords: usize,
    closed_double_sided: usize,
    /// The scene has no root node.
    no_nodes: bool,
}

/// Loads a glTF 2.0 file (`.gltf` with its buffers and images, or `.glb`): the default scene
/// (else the first) with its node hierarchy; see `docs/contract.md` for what is read and what
/// is ignored. The reader of the glTF row of [`crate::format::FORMATS`].
///
/// Errors (never panics) for malformed JSON or GLB, a missing or short buffer, an accessor or
/// index out of range, NaN or infinite positions (also after the node transforms), a cycle in
/// the node graph, an unsupported required extension, an invalid material, or a scene without
/// any usable triangle.
pub(crate) fn load(path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.into(),
        source,
    })?;
    let (doc, blob) = parse(path, &bytes)?;
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let buffers = read_buffers(path, &dir, &doc, blob)?;
    let tree = NodeTree::of(&doc).map_err(|m| gltf_error(path, m))?;
    let mut loader = Loader {
        path,
        dir,
        doc: &doc,
        buffers: Buffers(buffers),
        options,
        scene: Scene {
            path: path.into(),
            materials: vec![Material::default_grey()],
            ..Default::default()
        },
        filter: TriangleFilter::default(),
        materials: vec![None; doc.materials().len()],
        no_material: None,
        images: HashMap::new(),
        tex_coord_of: HashMap::new(),
        tex_transform_of: HashMap::new(),
        alpha_of: HashMap::new(),
        cut_out_triangles: 0,
        names: HashSet::new(),
        ignored: BTreeSet::new(),
        skipped_primitives: 0,
        missing_texcoords: 0,
        closed_double_sided: 0,
        no_nodes: false,
    };
    let roots = loader.roots(&tree);
    loader.no_nodes = roots.is_empty();
    loader.walk(&roots, &tree)?;
    loader.finish()
}

fn gltf_error(path: &Path, message: String) -> SceneError {
    SceneError::Gltf {
        path: path.into(),
        message,
    }
}

/// Refuses a glTF 1.0 file by name (its maps where 2.0 has arrays would otherwise be a serde
/// type error), and gives a scene without `nodes` (optional in glTF 2.0, required by the gltf
/// crate) an empty list: `Some(bytes)` when the JSON was changed.
fn normalised_json(path: &Path, bytes: &[u8]) -> Result<Option<Vec<u8>>, SceneError> {
    let old = |version: &str| {
        gltf_error(
            path,
            format!("glTF {version} is not supported (only glTF 2.0; convert the file first)"),
        )
    };
    if bytes.starts_with(b"glTF") {
        let version = bytes
            .get(4..8)
            .map(|v| u32::from_le_bytes([v[0], v[1], v[2], v[3]]));
        return match version {
            Some(1) => Err(old("1.0")),
            _ => Ok(None),
        };
    }
    let Ok(mut json) = serde_json::from_slice::<serde_json::Value>(bytes) else {
        return Ok(None); // the gltf crate says what is wrong
    };
    if let Some(v) = json["asset"]["version"].as_str()
        && !v.starts_with('2')
    {
        return Err(old(v));
    }
    let mut changed = false;
    if let Some(scenes) = json.get_mut("scenes").and_then(|s| s.as_array_mut()) {
        for scene in scenes.iter_mut().filter_map(|s| s.as_object_mut()) {
            if !scene.contains_key("nodes") {
                scene.insert("nodes".into(), serde_json::Value::Array(Vec::new()));
                changed = true;
            }
        }
    }
    Ok(changed.then(|| serde_json::to_vec(&json).expect("a JSON value serialises")))
}

/// The document of a glTF JSON or GLB file, validated (but for accessor bounds), and its GLB
/// binary chunk.
fn parse(path: &Path, bytes: &[u8]) -> Result<(::gltf::Document, Option<Vec<u8>>), SceneError> {
    let gerr = |message: String| gltf_error(path, message);
    let what = if bytes.starts_with(b"glTF") {
        "GLB"
    } else {
        "glTF JSON"
    };
    let patched = normalised_json(path, bytes)?;
    let bytes = patched.as_deref().unwrap_or(bytes);
    let parsed = ::gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| gerr(format!("not a valid {what} file: {e}")))?;
    // Required extensions first: a Draco-compressed file fails validation for reasons that
    // only the extension explains.
    if let Some(ext) = parsed
        .document
        .extensions_required()
        .find(|e| !SUPPORTED_EXTENSIONS.contains(e))
    {
        return Err(SceneError::UnsupportedExtension {
            path: path.into(),
            extension: ext.to_owned(),
        });
    }
    let blob = parsed.blob;
    let json = parsed.document.into_json();
    let mut errors = Vec::new();
    {
        use ::gltf::json::validation::Validate;
        json.validate(&json, ::gltf::json::Path::new, &mut |at, e| {
            errors.push((at(), e))
        });
    }
    // Accessor `min`/`max` (required on POSITION by the specification) are never read here.
    errors.retain(|(at, _)| {
        let at = at.as_str();
        !(at.ends_with(".min") || at.ends_with(".max"))
    });
    if let Some((at, what)) = errors.first() {
        let more = if errors.len() > 1 {
            format!(" (and {} more problem(s))", errors.len() - 1)
        } else {
            String::new()
        };
        return Err(gerr(format!("invalid glTF: {at}: {what}{more}")));
    }
    Ok((::gltf::Document::from_json_without_validation(json), blob))
}

/// The document's buffers, each checked to hold its byteLength and cut to it.
fn read_buffers(
    path: &Path,
    dir: &Path,
    doc: &::gltf::Document,
    blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, SceneError> {
    let gerr = |message: String| gltf_error(path, message);
    let mut buffers = Vec::new();
    for b in doc.buffers() {
        let i = b.index();
        let data = match b.source() {
            ::gltf::buffer::Source::Bin => blob.clone().ok_or_else(|| {
                gerr(format!(
                    "buffer {i} refers to the GLB binary chunk, which this file does not have"
                ))
            })?,
            ::gltf::buffer::Source::Uri(uri) => read_uri(dir, uri).map_err(|(file, m)| {
                gerr(match file {
                    Some(f) => format!("buffer {i}: cannot read {}: {m}", f.display()),
                    None => format!("buffer {i}: {m}"),
                })
            })?,
        };
        if data.len() < b.length() {
            return Err(gerr(format!(
                "buffer {i} holds {} bytes, fewer than its byteLength {}",
                data.len(),
                b.length()
            )));
        }
        let mut data = data;
        data.truncate(b.length());
        buffers.push(data);
    }
    Ok(buffers)
}

impl Loader<'_> {
    /// An error about this file.
    fn err(&self, message: impl Into<String>) -> SceneError {
        SceneError::Gltf {
            path: self.path.into(),
            message: message.into(),
        }
    }

    /// The report's warnings, and the scene (an error if it has no triangle).
    fn finish(mut self) -> Result<Scene, SceneError> {
        let path = self.path;
        let doc = self.doc;
        if doc.animations().next().is_some() {
            self.ignored.insert("animations");
        }
        if doc.skins().next().is_some() {
            self.ignored.insert("skins");
        }
        if doc.cameras().next().is_some() {
            self.ignored.insert("cameras");
        }
        let report: &mut LoadReport = &mut self.scene.report;
        if self.skipped_primitives > 0 {
            report.warnings.push(format!(
                "{}: skipped {} point or line primitive(s) (only triangles are surfaces)",
                path.display(),
                self.skipped_primitives
            ));
        }
        if self.missing_texcoords > 0 {
            report.warnings.push(format!(
                "{}: {} primitive(s) lack the TEXCOORD set their material's baseColorTexture uses; their reflectance is baseColorFactor alone",
                path.display(),
                self.missing_texcoords
            ));
        }
        if self.cut_out_triangles > 0 {
            report.warnings.push(format!(
                "{}: {} triangle(s) wholly cut out or transparent (alphaMode, coverage 0) left out",
                path.display(),
                self.cut_out_triangles
            ));
        }
        if self.closed_double_sided > 0 {
            report.warnings.push(format!(
                "{}: {} doubleSided primitive(s) are closed surfaces: only their outside is surface",
                path.display(),
                self.closed_double_sided
            ));
        }
        let unused_ext: Vec<&str> = doc
            .extensions_used()
            .filter(|e| !SUPPORTED_EXTENSIONS.contains(e))
            .collect();
        if !unused_ext.is_empty() {
            report.warnings.push(format!(
                "{}: ignored extension(s): {}",
                path.display(),
                unused_ext.join(", ")
            ));
        }
        if !self.ignored.is_empty() {
            let list: Vec<&str> = self.ignored.iter().copied().collect();
            report
                .warnings
                .push(format!("{}: ignored: {}", path.display(), list.join("; ")));
        }
        report.warn_skipped(path);
        if self.scene.triangles.is_empty() {
            // Say what the file holds instead: an engine user's first question.
            let why = if self.skipped_primitives > 0 {
                format!(
                    ": its {} primitive(s) are points or lines, which have no surface",
                    self.skipped_primitives
                )
            } else if self.no_nodes {
                ": its scene has no nodes".to_string()
            } else {
                String::new()
            };
            return Err(SceneError::EmptyScene {
                path: path.into(),
                why,
            });
        }
        let options = self.options;
        self.scene.limit_reflectance(options);
        Ok(self.scene)
    }
}
