//! The node hierarchy: checked to be a forest, walked depth first with transforms in f64.

use super::Loader;
use crate::SceneError;
use glam::{DMat4, DQuat, DVec3};

/// The node graph: each node's children and parent, checked to form trees.
pub(super) struct NodeTree {
    pub(super) children: Vec<Vec<usize>>,
    pub(super) parent: Vec<Option<usize>>,
}

impl NodeTree {
    /// The node graph of `doc`, or the message of the first problem: a node with two parents
    /// (or listed twice by one) or a cycle (the crate's validation does not look for one).
    pub(super) fn of(doc: &::gltf::Document) -> Result<Self, String> {
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
                    return Err(if q == p {
                        format!("node {p} lists node {c} as a child twice")
                    } else {
                        format!(
                            "node {c} has two parents (nodes {q} and {p}); glTF nodes form trees"
                        )
                    });
                }
            }
        }
        check_acyclic(&children)?;
        Ok(Self { children, parent })
    }
}

/// Depth-first search with an explicit stack: an error naming a node that is its own ancestor.
fn check_acyclic(children: &[Vec<usize>]) -> Result<(), String> {
    let n = children.len();
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
                            return Err(format!(
                                "the node graph has a cycle: node {c} is its own ancestor (through node {node})"
                            ));
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
    Ok(())
}

impl Loader<'_> {
    /// The root nodes: the default scene's, else the first scene's; a file without scenes
    /// contributes its root nodes (with a warning).
    pub(super) fn roots(&mut self, tree: &NodeTree) -> Vec<usize> {
        let doc = self.doc;
        match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(s) => s.nodes().map(|n| n.index()).collect(),
            None => {
                let n = tree.parent.len();
                if n > 0 {
                    self.scene.report.warnings.push(format!(
                        "{}: no scene; the root nodes are used",
                        self.path.display()
                    ));
                }
                (0..n).filter(|&i| tree.parent[i].is_none()).collect()
            }
        }
    }

    /// Adds every mesh instance under `roots`: depth first, children in order, with an
    /// explicit stack (deep hierarchies are fine).
    pub(super) fn walk(&mut self, roots: &[usize], tree: &NodeTree) -> Result<(), SceneError> {
        let doc = self.doc;
        let mut stack: Vec<(usize, DMat4)> =
            roots.iter().rev().map(|&r| (r, DMat4::IDENTITY)).collect();
        let nodes: Vec<::gltf::Node<'_>> = doc.nodes().collect();
        while let Some((i, parent)) = stack.pop() {
            let node = &nodes[i];
            let world = parent * local_transform(node);
            if let Some(mesh) = node.mesh() {
                self.mesh_instance(node, &mesh, &world)?;
            }
            if node.skin().is_some() {
                self.ignored.insert("skins");
            }
            if node.camera().is_some() {
                self.ignored.insert("cameras");
            }
            for &c in tree.children[i].iter().rev() {
                stack.push((c, world));
            }
        }
        Ok(())
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
