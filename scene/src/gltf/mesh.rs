//! Mesh instances: a node's mesh placed in world space, its primitives cut into triangles.

use super::Loader;
use crate::SceneError;
use crate::Triangle;
use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::{Mode, Semantic};
use glam::{DMat4, DVec3};
use std::collections::HashMap;

/// One placement of a mesh: the node, its world transform, and the object its triangles
/// join (made with the first triangle kept).
struct Instance<'a, 'n> {
    node: &'a ::gltf::Node<'n>,
    world: &'a DMat4,
    /// A transform with negative determinant: the winding is flipped so that the front stays
    /// counter-clockwise in world space.
    flip: bool,
    /// The node as error messages name it.
    label: String,
    object: Option<u32>,
}

impl Loader<'_> {
    /// Adds the triangles of `mesh` placed by `world` as one object.
    pub(super) fn mesh_instance(
        &mut self,
        node: &::gltf::Node<'_>,
        mesh: &::gltf::Mesh<'_>,
        world: &DMat4,
    ) -> Result<(), SceneError> {
        let mut instance = Instance {
            node,
            world,
            flip: world.determinant() < 0.0,
            label: match node.name() {
                Some(n) if !n.is_empty() => format!("node {} (`{n}`)", node.index()),
                _ => format!("node {}", node.index()),
            },
            object: None,
        };
        if mesh.weights().is_some() || node.weights().is_some() {
            self.ignored.insert("morph targets");
        }
        for prim in mesh.primitives() {
            self.primitive(&mut instance, mesh, &prim)?;
        }
        Ok(())
    }

    /// Adds the triangles of one primitive of an instance's mesh (none for points and lines).
    fn primitive(
        &mut self,
        instance: &mut Instance<'_, '_>,
        mesh: &::gltf::Mesh<'_>,
        prim: &::gltf::Primitive<'_>,
    ) -> Result<(), SceneError> {
        if prim.morph_targets().next().is_some() {
            self.ignored.insert("morph targets");
        }
        let mode = prim.mode();
        if matches!(
            mode,
            Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip
        ) {
            self.skipped_primitives += 1;
            return Ok(());
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
        let pwhat = format!(
            "{}, mesh {} primitive {}",
            instance.label,
            mesh.index(),
            prim.index()
        );
        let Some(pos_acc) = prim.get(&Semantic::Positions) else {
            return Err(self.err(format!("{pwhat} has no POSITION attribute")));
        };
        let material = self.material(&prim.material())?;
        let world_pos = self.world_positions(&pos_acc, instance.world, &pwhat)?;
        let uv = self.texcoords(prim, material, world_pos.len(), &pwhat)?;
        let (colours, alpha) = self.colours(prim, world_pos.len(), &pwhat)?;
        let indices = self.indices(prim, world_pos.len(), &pwhat)?;
        if mode == Mode::Triangles && !indices.len().is_multiple_of(3) {
            self.scene.report.warnings.push(format!(
                "{}: {pwhat}: TRIANGLES with {} indices (not a multiple of 3): the last {} ignored",
                self.path.display(),
                indices.len(),
                indices.len() % 3
            ));
        }
        let corners = triangle_corners(mode, &indices);
        self.add_colours(world_pos.len(), colours);
        self.add_triangles(instance, prim, material, &corners, &world_pos, uv, alpha);
        Ok(())
    }

    /// The POSITION accessor's vertices in world space, each checked to be finite.
    fn world_positions(
        &self,
        pos_acc: &::gltf::Accessor<'_>,
        world: &DMat4,
        pwhat: &str,
    ) -> Result<Vec<DVec3>, SceneError> {
        let pos = self.elements(pos_acc, "POSITION", &[DataType::F32], Dimensions::Vec3)?;
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
        Ok(world_pos)
    }

    /// Texture coordinates of the `nverts` vertices, only where the material has a texture
    /// (`None` also when the primitive lacks the material's TEXCOORD set, which is counted).
    fn texcoords(
        &mut self,
        prim: &::gltf::Primitive<'_>,
        material: u32,
        nverts: usize,
        pwhat: &str,
    ) -> Result<Option<Vec<[f64; 2]>>, SceneError> {
        if self.scene.materials[material as usize].texture.is_none() {
            return Ok(None);
        }
        let set = self.tex_coord_of[&material];
        let Some(acc) = prim.get(&Semantic::TexCoords(set)) else {
            self.missing_texcoords += 1;
            return Ok(None);
        };
        let e = self.elements(
            &acc,
            &format!("TEXCOORD_{set}"),
            &[DataType::F32, DataType::U8, DataType::U16],
            Dimensions::Vec2,
        )?;
        if e.count != nverts {
            return Err(self.err(format!(
                "{pwhat}: TEXCOORD_{set} has {} elements for {} vertices",
                e.count, nverts
            )));
        }
        let norm = acc.normalized();
        let m = self.tex_transform_of.get(&material).copied();
        // `KHR_texture_transform` in glTF's UV space; then glTF's v, which runs down the image,
        // to OBJ's (and Texture's), which runs up.
        Ok(Some(
            (0..e.count)
                .map(|v| {
                    let (u, w) = (e.get(v, 0, norm), e.get(v, 1, norm));
                    let (u, w) = match m {
                        Some(m) => (
                            m[0][0] * u + m[0][1] * w + m[0][2],
                            m[1][0] * u + m[1][1] * w + m[1][2],
                        ),
                        None => (u, w),
                    };
                    [u, 1.0 - w]
                })
                .collect(),
        ))
    }

    /// The primitive's `COLOR_0` RGB, which multiplies the base colour, and the alpha of a
    /// VEC4 one, which multiplies `baseColorFactor` alpha (used under `alphaMode` MASK and
    /// BLEND), each `None` without. Each value finite and not negative.
    #[allow(clippy::type_complexity)]
    fn colours(
        &mut self,
        prim: &::gltf::Primitive<'_>,
        nverts: usize,
        pwhat: &str,
    ) -> Result<(Option<Vec<[f64; 3]>>, Option<Vec<f64>>), SceneError> {
        let Some(acc) = prim.get(&Semantic::Colors(0)) else {
            return Ok((None, None));
        };
        let dims = match acc.dimensions() {
            Dimensions::Vec4 => Dimensions::Vec4,
            _ => Dimensions::Vec3,
        };
        let e = self.elements(
            &acc,
            "COLOR_0",
            &[DataType::F32, DataType::U8, DataType::U16],
            dims,
        )?;
        if e.count != nverts {
            return Err(self.err(format!(
                "{pwhat}: COLOR_0 has {} elements for {} vertices",
                e.count, nverts
            )));
        }
        let norm = acc.normalized() || acc.data_type() != DataType::F32;
        let mut out = Vec::with_capacity(e.count);
        let mut alpha = (dims == Dimensions::Vec4).then(|| Vec::with_capacity(e.count));
        for v in 0..e.count {
            let c = [0, 1, 2].map(|k| e.get(v, k, norm));
            if c.iter().any(|x| !x.is_finite() || *x < 0.0) {
                return Err(self.err(format!(
                    "{pwhat}: COLOR_0 of vertex {v} is {} {} {}, not a colour (finite, not negative)",
                    c[0], c[1], c[2]
                )));
            }
            out.push(c);
            if let Some(alpha) = &mut alpha {
                let a = e.get(v, 3, norm);
                if !(a.is_finite() && a >= 0.0) {
                    return Err(self.err(format!(
                        "{pwhat}: COLOR_0 alpha of vertex {v} is {a}, not an alpha (finite, not negative)"
                    )));
                }
                alpha.push(a);
            }
        }
        Ok((Some(out), alpha))
    }

    /// Keeps `Scene::vertex_colours` aligned with the positions once any primitive has colours:
    /// this primitive's `nverts` colours, or white.
    fn add_colours(&mut self, nverts: usize, colours: Option<Vec<[f64; 3]>>) {
        let scene = &mut self.scene;
        if colours.is_none() && scene.vertex_colours.is_empty() {
            return;
        }
        scene.vertex_colours.resize(scene.positions.len(), [1.0; 3]);
        match colours {
            Some(c) => scene.vertex_colours.extend(c),
            None => scene
                .vertex_colours
                .resize(scene.positions.len() + nverts, [1.0; 3]),
        }
    }

    /// The primitive's vertex indices (each checked to be below `nverts`), or `0..nverts`
    /// without an index accessor.
    fn indices(
        &self,
        prim: &::gltf::Primitive<'_>,
        nverts: usize,
        pwhat: &str,
    ) -> Result<Vec<u32>, SceneError> {
        let Some(acc) = prim.indices() else {
            return Ok((0..nverts as u32).collect());
        };
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
        Ok(out)
    }

    /// Adds a primitive's vertices and the triangles the filter admits (with the reversed
    /// copies of a doubleSided open surface) to the instance's object.
    fn add_triangles(
        &mut self,
        instance: &mut Instance<'_, '_>,
        prim: &::gltf::Primitive<'_>,
        material: u32,
        corners: &[[u32; 3]],
        world_pos: &[DVec3],
        uv: Option<Vec<[f64; 2]>>,
        alpha: Option<Vec<f64>>,
    ) {
        let base = self.scene.positions.len() as u32;
        self.scene.positions.extend_from_slice(world_pos);
        let uv_base = self.scene.texcoords.len() as u32;
        let has_uv = uv.is_some();
        if let Some(uv) = uv {
            self.scene.texcoords.extend_from_slice(&uv);
        }
        let double_sided = prim.material().double_sided();
        let mut kept: Vec<[u32; 3]> = Vec::new();
        for &c in corners {
            let mut c = c;
            if instance.flip {
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
            let texcoords = has_uv.then(|| c.map(|v| uv_base + v));
            let corner_alpha = alpha.as_ref().map(|a| c.map(|v| a[v as usize]));
            let coverage = self.coverage(material, texcoords, corner_alpha);
            if coverage <= 0.0 {
                self.cut_out_triangles += 1;
                continue;
            }
            let obj = match instance.object {
                Some(o) => o,
                None => {
                    let name = self.object_name(instance.node);
                    self.scene.objects.push(name);
                    let o = (self.scene.objects.len() - 1) as u32;
                    instance.object = Some(o);
                    o
                }
            };
            if coverage < 1.0 && self.scene.coverage.is_empty() {
                self.scene.coverage = vec![1.0; self.scene.triangles.len()];
            }
            if coverage < 1.0 || !self.scene.coverage.is_empty() {
                self.scene.coverage.push(coverage as f32);
            }
            self.scene.triangles.push(Triangle {
                vertices: c.map(|v| base + v),
                texcoords,
                object: obj,
                material,
                line: 0,
            });
        }
    }

    /// The alpha coverage of a triangle of `material` with texture coordinates `texcoords`
    /// (indices into the scene's) and `COLOR_0` alpha `corner_alpha` at its corners: 1 for
    /// an opaque material; for MASK the fraction of the triangle whose alpha (texture ×
    /// `baseColorFactor` alpha × `COLOR_0` alpha, the last interpolated) is at or above
    /// `alphaCutoff`; for BLEND its mean alpha (clamped to 1: `COLOR_0` may exceed it).
    fn coverage(
        &self,
        material: u32,
        texcoords: Option<[u32; 3]>,
        corner_alpha: Option<[f64; 3]>,
    ) -> f64 {
        let Some(&(factor, cutoff)) = self.alpha_of.get(&material) else {
            return 1.0;
        };
        let factor = corner_alpha.map_or([factor; 3], |a| a.map(|a| a * factor));
        let texture = self.scene.materials[material as usize]
            .texture
            .map(|t| &self.scene.textures[t as usize]);
        let c = match (texture, texcoords) {
            (Some(t), Some(tc)) if t.has_alpha() => {
                let uv = tc.map(|i| self.scene.texcoords[i as usize]);
                t.coverage_over_triangle(uv, factor, cutoff)
            }
            // No alpha texture: alpha is linear over the triangle. Uniform alpha gives the
            // exact answer at once; a varying one is sampled on a 16-part lattice (256
            // points: a MASK edge crossing the triangle is placed within 1/16 of it).
            _ if factor[0] == factor[1] && factor[1] == factor[2] => match cutoff {
                Some(c) => f64::from(u8::from(factor[0] >= c)),
                None => factor[0],
            },
            _ => {
                let (mut acc, mut n) = (0.0, 0.0);
                crate::texture::barycentric_lattice(16, |w| {
                    let a = w[0] * factor[0] + w[1] * factor[1] + w[2] * factor[2];
                    acc += cutoff.map_or(a, |c| f64::from(u8::from(a >= c)));
                    n += 1.0;
                });
                acc / n
            }
        };
        c.min(1.0)
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
}

/// The corners of a primitive's triangles, by mode: a list, a strip (every other triangle
/// reversed to keep the winding) or a fan.
fn triangle_corners(mode: Mode, indices: &[u32]) -> Vec<[u32; 3]> {
    match mode {
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
    }
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
