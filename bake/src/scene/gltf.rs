//! The glTF 2.0 reader (`.gltf` with external or data-URI buffers, `.glb`).
//!
//! The `gltf` crate parses and validates the JSON (and the GLB container); every byte of a
//! buffer is read here through bounds-checked code, since accessor reading in the crate can
//! panic on a short buffer. Positions are transformed to world space in f64 with the full node
//! transform; a transform with negative determinant flips the winding so that the front stays
//! counter-clockwise in world space. Conventions are those of the OBJ path (`docs/contract.md`).

use super::{
    DEFAULT_REFLECTANCE, LoadOptions, LoadReport, Material, Scene, Texture, Triangle,
    TriangleFilter,
};
use crate::error::BakeError;
use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::{Mode, Semantic};
use base64::Engine as _;
use glam::{DMat4, DQuat, DVec3};
use radiosity_core::Rgb;
use std::collections::{BTreeSet, HashMap, HashSet};
use std::path::{Path, PathBuf};

/// Extensions read by this loader: a file that requires any other is refused.
const SUPPORTED_EXTENSIONS: &[&str] = &["KHR_materials_emissive_strength"];

/// The buffers of a file, each cut to its `byteLength`.
struct Buffers(Vec<Vec<u8>>);

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
    /// Object names used so far, for `name#2`.
    names: HashSet<String>,
    ignored: BTreeSet<&'static str>,
    skipped_primitives: usize,
    missing_texcoords: usize,
    closed_double_sided: usize,
}

/// A view of an accessor's elements in a buffer, checked to lie inside it.
struct Elements<'b> {
    /// From the accessor's first byte to the end of its buffer view.
    bytes: &'b [u8],
    count: usize,
    stride: usize,
    component: usize,
    data_type: DataType,
}

impl Elements<'_> {
    /// Component `k` of element `i` as f64 (normalised integers mapped to `[0, 1]`).
    fn get(&self, i: usize, k: usize, normalized: bool) -> f64 {
        let at = i * self.stride + k * self.component;
        let b = &self.bytes[at..at + self.component];
        match self.data_type {
            DataType::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            DataType::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            DataType::U16 => {
                let v = f64::from(u16::from_le_bytes([b[0], b[1]]));
                if normalized { v / 65535.0 } else { v }
            }
            DataType::U8 => {
                let v = f64::from(b[0]);
                if normalized { v / 255.0 } else { v }
            }
            DataType::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            DataType::I8 => f64::from(b[0] as i8),
        }
    }

    /// Element `i` as an index (for U8, U16 and U32 scalars).
    fn index(&self, i: usize) -> u32 {
        let bytes = self.bytes;
        let at = i * self.stride;
        match self.data_type {
            DataType::U8 => u32::from(bytes[at]),
            DataType::U16 => u32::from(u16::from_le_bytes([bytes[at], bytes[at + 1]])),
            _ => u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]),
        }
    }
}

fn data_type_name(t: DataType) -> &'static str {
    match t {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    }
}

fn dimensions_of(d: Dimensions) -> (usize, &'static str) {
    match d {
        Dimensions::Scalar => (1, "SCALAR"),
        Dimensions::Vec2 => (2, "VEC2"),
        Dimensions::Vec3 => (3, "VEC3"),
        Dimensions::Vec4 => (4, "VEC4"),
        Dimensions::Mat2 => (4, "MAT2"),
        Dimensions::Mat3 => (9, "MAT3"),
        Dimensions::Mat4 => (16, "MAT4"),
    }
}

/// Decodes a `data:` URI (base64 only), or `None` when `uri` is not one.
fn data_uri(uri: &str) -> Option<Result<Vec<u8>, String>> {
    let rest = uri.strip_prefix("data:")?;
    let Some((head, payload)) = rest.split_once(',') else {
        return Some(Err("data URI without a `,`".into()));
    };
    if !head.ends_with(";base64") {
        return Some(Err("data URI is not base64-encoded".into()));
    }
    Some(
        base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map_err(|e| format!("data URI: bad base64: {e}")),
    )
}

/// The bytes of a URI: a data URI, else a file relative to the glTF file's folder
/// (percent-encoded as URIs are).
fn read_uri(dir: &Path, uri: &str) -> Result<Vec<u8>, (Option<PathBuf>, String)> {
    if let Some(d) = data_uri(uri) {
        return d.map_err(|m| (None, m));
    }
    if uri.contains("://") {
        return Err((None, format!("URI `{uri}` is not a relative file path")));
    }
    let name = percent_encoding::percent_decode_str(uri).decode_utf8_lossy();
    let file = dir.join(name.as_ref());
    std::fs::read(&file).map_err(|e| (Some(file), e.to_string()))
}

/// Whether a triangle list is a closed surface: every edge (by exact corner positions) is
/// shared by exactly two triangles that run it in opposite directions.
fn is_closed(tris: &[[DVec3; 3]]) -> bool {
    if tris.is_empty() {
        return false;
    }
    let key = |p: DVec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    // For each undirected edge: (uses, forward − backward).
    let mut edges: HashMap<([u64; 3], [u64; 3]), (u32, i32)> = HashMap::new();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (key(t[k]), key(t[(k + 1) % 3]));
            let (lo, hi, dir) = if a < b { (a, b, 1) } else { (b, a, -1) };
            let e = edges.entry((lo, hi)).or_insert((0, 0));
            e.0 += 1;
            e.1 += dir;
        }
    }
    edges.values().all(|&(n, d)| n == 2 && d == 0)
}

impl Loader<'_> {
    fn err(&self, message: impl Into<String>) -> BakeError {
        BakeError::Gltf {
            path: self.path.into(),
            message: message.into(),
        }
    }

    /// The elements of accessor `acc`, checked: its type, and that every byte it covers lies
    /// inside its buffer view and the view inside its buffer.
    fn elements(
        &self,
        acc: &::gltf::Accessor<'_>,
        what: &str,
        types: &[DataType],
        dims: Dimensions,
    ) -> Result<Elements<'_>, BakeError> {
        let i = acc.index();
        let (n, dim_name) = dimensions_of(acc.dimensions());
        if acc.dimensions() != dims || !types.contains(&acc.data_type()) {
            let want: Vec<&str> = types.iter().map(|&t| data_type_name(t)).collect();
            return Err(self.err(format!(
                "accessor {i} ({what}) is {dim_name} {}, expected {} {}",
                data_type_name(acc.data_type()),
                dimensions_of(dims).1,
                want.join(" or ")
            )));
        }
        if acc.sparse().is_some() {
            return Err(self.err(format!(
                "accessor {i} ({what}) is sparse, which is not supported"
            )));
        }
        let component = acc.data_type().size();
        let elem = component * n;
        let count = acc.count();
        let Some(view) = acc.view() else {
            // All zeros by the specification: no surface, and a count nothing bounds.
            return Err(self.err(format!(
                "accessor {i} ({what}) has no bufferView (zero-filled accessors are not supported)"
            )));
        };
        let buffer = &self.buffers.0[view.buffer().index()];
        let v = view.index();
        let view_end = view.offset().checked_add(view.length());
        if view_end.is_none_or(|e| e > buffer.len()) {
            return Err(self.err(format!(
                "buffer view {v} (bytes {}..+{}) runs past the end of buffer {} ({} bytes)",
                view.offset(),
                view.length(),
                view.buffer().index(),
                buffer.len()
            )));
        }
        let view_bytes = &buffer[view.offset()..view.offset() + view.length()];
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(self.err(format!(
                "buffer view {v}: byteStride {stride} is smaller than the {elem}-byte elements of accessor {i}"
            )));
        }
        if count > 0 {
            let end = (count - 1)
                .checked_mul(stride)
                .and_then(|x| x.checked_add(elem))
                .and_then(|x| x.checked_add(acc.offset()));
            if end.is_none_or(|e| e > view_bytes.len()) {
                return Err(self.err(format!(
                    "accessor {i} ({what}): {count} elements from byte {} run past the end of buffer view {v} ({} bytes)",
                    acc.offset(),
                    view_bytes.len()
                )));
            }
        }
        Ok(Elements {
            bytes: &view_bytes[acc.offset().min(view_bytes.len())..],
            count,
            stride,
            component,
            data_type: acc.data_type(),
        })
    }

    /// The scene object for node `node`: its name, else its mesh's, else `node<i>`, made
    /// unique with `#2`, `#3` …
    fn object_name(&mut self, node: &::gltf::Node<'_>) -> String {
        let base = node
            .name()
            .filter(|n| !n.is_empty())
            .or_else(|| node.mesh().and_then(|m| m.name()).filter(|n| !n.is_empty()))
            .map(str::to_owned)
            .unwrap_or_else(|| format!("node{}", node.index()));
        let mut name = base.clone();
        let mut k = 1;
        while self.names.contains(&name) {
            k += 1;
            name = format!("{base}#{k}");
        }
        self.names.insert(name.clone());
        name
    }

    /// The decoded texture of glTF image `image` (cached; `None` if it failed without
    /// `validate_materials`).
    fn texture(&mut self, image: &::gltf::Image<'_>) -> Result<Option<u32>, BakeError> {
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
                Err((Some(file), m)) => Err(BakeError::Texture {
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
    fn material(&mut self, m: &::gltf::Material<'_>) -> Result<u32, BakeError> {
        let Some(index) = m.index() else {
            // glTF's default material is white metal: not a diffuse reflectance. The OBJ
            // fallback (grey 0.5) is used, as for a face without material.
            if let Some(i) = self.no_material {
                return Ok(i);
            }
            self.scene.report.warnings.push(format!(
                "{}: primitive(s) without a material use grey {DEFAULT_REFLECTANCE}",
                self.path.display()
            ));
            self.no_material = Some(0);
            return Ok(0);
        };
        if let Some(i) = self.materials[index] {
            return Ok(i);
        }
        let name = m
            .name()
            .filter(|n| !n.is_empty())
            .map(str::to_owned)
            .unwrap_or_else(|| format!("material{index}"));
        let bad = |message: String| BakeError::Material {
            path: self.path.into(),
            line: None,
            material: name.clone(),
            message,
        };
        let pbr = m.pbr_metallic_roughness();
        let f = pbr.base_color_factor();
        let mut kd = [f[0], f[1], f[2]].map(f64::from);
        if let Some(cap) = self.options.max_reflectance
            && kd.iter().any(|c| c.is_finite() && *c >= cap)
        {
            let lowered = kd.map(|c| if c.is_finite() { c.min(cap) } else { c });
            let said = bad(format!(
                "baseColorFactor {} {} {} lowered to {} {} {} (reflectance cap {cap})",
                kd[0], kd[1], kd[2], lowered[0], lowered[1], lowered[2]
            ));
            self.scene.report.warnings.push(said.to_string());
            kd = lowered;
        }
        if kd.iter().any(|c| !c.is_finite() || *c < 0.0 || *c >= 1.0) {
            let e = bad(format!(
                "baseColorFactor {} {} {} is not a reflectance in [0, 1) (a surface cannot reflect all the light it receives)",
                kd[0], kd[1], kd[2]
            ));
            if self.options.validate_materials {
                return Err(e);
            }
            self.scene
                .report
                .warnings
                .push(format!("{e}; clamped to [0, 0.999]"));
            kd = kd.map(|c| {
                if c.is_finite() {
                    c.clamp(0.0, 0.999)
                } else {
                    f64::from(DEFAULT_REFLECTANCE)
                }
            });
        }
        let strength = m.emissive_strength().map_or(1.0, f64::from);
        let mut ke = m.emissive_factor().map(|c| f64::from(c) * strength);
        let exitance_fits = |c: f64| ((std::f64::consts::PI * c) as f32).is_finite();
        if ke
            .iter()
            .any(|c| !c.is_finite() || *c < 0.0 || !exitance_fits(*c))
        {
            let e = bad(format!(
                "emission (emissiveFactor × emissiveStrength) {} {} {} must be finite and non-negative, with an exitance π·L below 3.4e38",
                ke[0], ke[1], ke[2]
            ));
            if self.options.validate_materials {
                return Err(e);
            }
            self.scene
                .report
                .warnings
                .push(format!("{e}; emission dropped"));
            ke = [0.0; 3];
        }
        let texture = match pbr.base_color_texture() {
            Some(info) => {
                let t = self.texture(&info.texture().source())?;
                let s = info.texture().sampler();
                if s.wrap_s() != ::gltf::texture::WrappingMode::Repeat
                    || s.wrap_t() != ::gltf::texture::WrappingMode::Repeat
                {
                    self.ignored
                        .insert("texture wrap modes other than REPEAT (read as REPEAT)");
                }
                t.map(|t| (t, info.tex_coord()))
            }
            None => None,
        };
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
        if m.alpha_mode() != ::gltf::material::AlphaMode::Opaque {
            self.ignored.insert("alphaMode (surfaces are opaque)");
        }
        let pi = std::f64::consts::PI;
        self.scene.materials.push(Material {
            name,
            reflectance: Rgb::new(kd[0] as f32, kd[1] as f32, kd[2] as f32),
            emission: Rgb::new(
                (pi * ke[0]) as f32,
                (pi * ke[1]) as f32,
                (pi * ke[2]) as f32,
            ),
            texture: texture.map(|(t, _)| t),
        });
        let i = (self.scene.materials.len() - 1) as u32;
        self.tex_coord_of.insert(i, texture.map_or(0, |(_, c)| c));
        self.materials[index] = Some(i);
        Ok(i)
    }
}

/// The local transform of a node in f64 (column-major matrix, or T·R·S).
fn local_transform(node: &::gltf::Node<'_>) -> DMat4 {
    match node.transform() {
        ::gltf::scene::Transform::Matrix { matrix } => {
            DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)))
        }
        ::gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let [x, y, z, w] = rotation.map(f64::from);
            let q = DQuat::from_xyzw(x, y, z, w);
            // glTF rotations are unit quaternions, written in f32: renormalised in f64. A zero
            // or non-finite one stays as is and makes the positions non-finite (an error).
            let q = if q.length() > 0.0 { q.normalize() } else { q };
            DMat4::from_scale_rotation_translation(
                DVec3::from_array(scale.map(f64::from)),
                q,
                DVec3::from_array(translation.map(f64::from)),
            )
        }
    }
}

/// Loads a `.gltf` or `.glb` file into a scene.
pub(crate) fn load(path: &Path, options: &LoadOptions) -> Result<Scene, BakeError> {
    let bytes = std::fs::read(path).map_err(|source| BakeError::Io {
        path: path.into(),
        source,
    })?;
    let gerr = |message: String| BakeError::Gltf {
        path: path.into(),
        message,
    };
    let what = if bytes.starts_with(b"glTF") {
        "GLB"
    } else {
        "glTF JSON"
    };
    let parsed = ::gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| gerr(format!("not a valid {what} file: {e}")))?;
    // Required extensions first: a Draco-compressed file fails validation for reasons that
    // only the extension explains.
    if let Some(ext) = parsed
        .document
        .extensions_required()
        .find(|e| !SUPPORTED_EXTENSIONS.contains(e))
    {
        return Err(BakeError::UnsupportedExtension {
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
    let doc = ::gltf::Document::from_json_without_validation(json);
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();

    // Buffers, each checked to hold its byteLength.
    let mut buffers = Vec::new();
    for b in doc.buffers() {
        let i = b.index();
        let data = match b.source() {
            ::gltf::buffer::Source::Bin => blob.clone().ok_or_else(|| {
                gerr(format!(
                    "buffer {i} refers to the GLB binary chunk, which this file does not have"
                ))
            })?,
            ::gltf::buffer::Source::Uri(uri) => read_uri(&dir, uri).map_err(|(file, m)| {
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

    // A cycle in the node graph (the crate's validation does not look for one).
    let children: Vec<Vec<usize>> = doc
        .nodes()
        .map(|node| node.children().map(|c| c.index()).collect())
        .collect();
    let n = children.len();
    // At most one parent each (a node shared by two parents is instanced twice, and a chain
    // of such nodes doubles at every level).
    let mut parent: Vec<Option<usize>> = vec![None; n];
    for (p, cs) in children.iter().enumerate() {
        for &c in cs {
            if let Some(q) = parent[c].replace(p) {
                return Err(gerr(if q == p {
                    format!("node {p} lists node {c} as a child twice")
                } else {
                    format!("node {c} has two parents (nodes {q} and {p}); glTF nodes form trees")
                }));
            }
        }
    }
    let mut state = vec![0u8; n]; // 0 unvisited, 1 on the stack, 2 done
    for start in 0..n {
        if state[start] != 0 {
            continue;
        }
        let mut stack: Vec<(usize, usize)> = vec![(start, 0)];
        state[start] = 1;
        while let Some(top) = stack.last_mut() {
            let (node, next) = *top;
            match children[node].get(next) {
                Some(&c) => {
                    top.1 += 1;
                    match state[c] {
                        1 => {
                            return Err(gerr(format!(
                                "the node graph has a cycle: node {c} is its own ancestor (through node {node})"
                            )));
                        }
                        0 => {
                            state[c] = 1;
                            stack.push((c, 0));
                        }
                        _ => {}
                    }
                }
                None => {
                    state[node] = 2;
                    stack.pop();
                }
            }
        }
    }

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
        names: HashSet::new(),
        ignored: BTreeSet::new(),
        skipped_primitives: 0,
        missing_texcoords: 0,
        closed_double_sided: 0,
    };

    // The default scene, else the first; a file without scenes contributes its root nodes.
    let roots: Vec<usize> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => s.nodes().map(|n| n.index()).collect(),
        None => {
            let is_child: Vec<bool> = parent.iter().map(Option::is_some).collect();
            if n > 0 {
                loader.scene.report.warnings.push(format!(
                    "{}: no scene; the root nodes are used",
                    path.display()
                ));
            }
            (0..n).filter(|&i| !is_child[i]).collect()
        }
    };
    // Depth first, children in order, with an explicit stack (deep hierarchies are fine).
    let mut stack: Vec<(usize, DMat4)> =
        roots.iter().rev().map(|&r| (r, DMat4::IDENTITY)).collect();
    let nodes: Vec<::gltf::Node<'_>> = doc.nodes().collect();
    while let Some((i, parent)) = stack.pop() {
        let node = &nodes[i];
        let world = parent * local_transform(node);
        if let Some(mesh) = node.mesh() {
            loader.mesh_instance(node, &mesh, &world)?;
        }
        if node.skin().is_some() {
            loader.ignored.insert("skins");
        }
        if node.camera().is_some() {
            loader.ignored.insert("cameras");
        }
        for &c in children[i].iter().rev() {
            stack.push((c, world));
        }
    }
    loader.finish()
}

impl Loader<'_> {
    /// Adds the triangles of `mesh` placed by `world` as one object.
    fn mesh_instance(
        &mut self,
        node: &::gltf::Node<'_>,
        mesh: &::gltf::Mesh<'_>,
        world: &DMat4,
    ) -> Result<(), BakeError> {
        let flip = world.determinant() < 0.0;
        let label = match node.name() {
            Some(n) if !n.is_empty() => format!("node {} (`{n}`)", node.index()),
            _ => format!("node {}", node.index()),
        };
        let mut object: Option<u32> = None;
        if mesh.weights().is_some() || node.weights().is_some() {
            self.ignored.insert("morph targets");
        }
        for prim in mesh.primitives() {
            if prim.morph_targets().next().is_some() {
                self.ignored.insert("morph targets");
            }
            let mode = prim.mode();
            if matches!(
                mode,
                Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip
            ) {
                self.skipped_primitives += 1;
                continue;
            }
            for (sem, _) in prim.attributes() {
                match sem {
                    Semantic::Normals => {
                        self.ignored
                            .insert("normals (the front is the counter-clockwise side)");
                    }
                    Semantic::Tangents => {
                        self.ignored.insert("tangents");
                    }
                    _ => {}
                }
            }
            let pwhat = format!("{label}, mesh {} primitive {}", mesh.index(), prim.index());
            let Some(pos_acc) = prim.get(&Semantic::Positions) else {
                return Err(self.err(format!("{pwhat} has no POSITION attribute")));
            };
            let material = self.material(&prim.material())?;
            let mut lacks_uv = false;
            let (world_pos, uv) = {
                let pos =
                    self.elements(&pos_acc, "POSITION", &[DataType::F32], Dimensions::Vec3)?;
                let mut world_pos = Vec::with_capacity(pos.count);
                for v in 0..pos.count {
                    let p = DVec3::new(
                        pos.get(v, 0, false),
                        pos.get(v, 1, false),
                        pos.get(v, 2, false),
                    );
                    if !p.is_finite() {
                        return Err(self.err(format!(
                            "{pwhat}: POSITION accessor {} vertex {v} is not finite ({} {} {})",
                            pos_acc.index(),
                            p.x,
                            p.y,
                            p.z
                        )));
                    }
                    let w = world.transform_point3(p);
                    if !w.is_finite() {
                        return Err(self.err(format!(
                            "{pwhat}: vertex {v} is not finite after the node transforms ({} {} {})",
                            w.x, w.y, w.z
                        )));
                    }
                    world_pos.push(w);
                }
                // Texture coordinates, only where the material has a texture.
                let uv = match self.scene.materials[material as usize].texture {
                    Some(_) => {
                        let set = self.tex_coord_of[&material];
                        match prim.get(&Semantic::TexCoords(set)) {
                            Some(acc) => {
                                let e = self.elements(
                                    &acc,
                                    &format!("TEXCOORD_{set}"),
                                    &[DataType::F32, DataType::U8, DataType::U16],
                                    Dimensions::Vec2,
                                )?;
                                if e.count != pos.count {
                                    return Err(self.err(format!(
                                        "{pwhat}: TEXCOORD_{set} has {} elements for {} vertices",
                                        e.count, pos.count
                                    )));
                                }
                                let norm = acc.normalized();
                                // glTF's v runs down the image, OBJ's (and Texture's) up.
                                Some(
                                    (0..e.count)
                                        .map(|v| [e.get(v, 0, norm), 1.0 - e.get(v, 1, norm)])
                                        .collect::<Vec<_>>(),
                                )
                            }
                            None => {
                                lacks_uv = true;
                                None
                            }
                        }
                    }
                    None => None,
                };
                (world_pos, uv)
            };
            self.missing_texcoords += usize::from(lacks_uv);
            let nverts = world_pos.len();
            let indices: Vec<u32> = match prim.indices() {
                Some(acc) => {
                    let e = self.elements(
                        &acc,
                        "indices",
                        &[DataType::U8, DataType::U16, DataType::U32],
                        Dimensions::Scalar,
                    )?;
                    let mut out = Vec::with_capacity(e.count);
                    for k in 0..e.count {
                        let v = e.index(k);
                        if v as usize >= nverts {
                            return Err(self.err(format!(
                                "{pwhat}: index {v} (element {k} of accessor {}) is past the {nverts} vertices",
                                acc.index()
                            )));
                        }
                        out.push(v);
                    }
                    out
                }
                None => (0..nverts as u32).collect(),
            };
            let corners: Vec<[u32; 3]> = match mode {
                Mode::Triangles => indices
                    .chunks_exact(3)
                    .map(|c| [c[0], c[1], c[2]])
                    .collect(),
                Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
                    .map(|i| {
                        if i % 2 == 0 {
                            [indices[i], indices[i + 1], indices[i + 2]]
                        } else {
                            [indices[i + 1], indices[i], indices[i + 2]]
                        }
                    })
                    .collect(),
                _ => (1..indices.len().saturating_sub(1))
                    .map(|i| [indices[0], indices[i], indices[i + 1]])
                    .collect(),
            };
            let base = self.scene.positions.len() as u32;
            self.scene.positions.extend_from_slice(&world_pos);
            let uv_base = self.scene.texcoords.len() as u32;
            let has_uv = uv.is_some();
            if let Some(uv) = uv {
                self.scene.texcoords.extend_from_slice(&uv);
            }
            let double_sided = prim.material().double_sided();
            let mut kept: Vec<[u32; 3]> = Vec::new();
            for mut c in corners {
                if flip {
                    c.swap(1, 2);
                }
                let p = c.map(|v| world_pos[v as usize]);
                if self.filter.admit(p, &mut self.scene.report) {
                    kept.push(c);
                }
            }
            // doubleSided: the back of an open surface is surface too, a reversed copy of each
            // triangle; a closed one's back faces its own inside, which no light reaches.
            let mut all = kept.clone();
            if double_sided && !kept.is_empty() {
                let tris: Vec<[DVec3; 3]> = kept
                    .iter()
                    .map(|c| c.map(|v| world_pos[v as usize]))
                    .collect();
                if is_closed(&tris) {
                    self.closed_double_sided += 1;
                } else {
                    for c in &kept {
                        let r = [c[0], c[2], c[1]];
                        if self
                            .filter
                            .admit(r.map(|v| world_pos[v as usize]), &mut self.scene.report)
                        {
                            all.push(r);
                        }
                    }
                }
            }
            for c in all {
                let obj = match object {
                    Some(o) => o,
                    None => {
                        let name = self.object_name(node);
                        self.scene.objects.push(name);
                        let o = (self.scene.objects.len() - 1) as u32;
                        object = Some(o);
                        o
                    }
                };
                self.scene.triangles.push(Triangle {
                    vertices: c.map(|v| base + v),
                    texcoords: has_uv.then(|| c.map(|v| uv_base + v)),
                    object: obj,
                    material,
                    line: 0,
                });
            }
        }
        Ok(())
    }

    /// The report's warnings, and the scene (an error if it has no triangle).
    fn finish(mut self) -> Result<Scene, BakeError> {
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
            return Err(BakeError::EmptyScene { path: path.into() });
        }
        Ok(self.scene)
    }
}
