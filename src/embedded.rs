//! The scene built into the program: the Cornell box of Morgan McGuire's Computer Graphics
//! Archive (`scenes/cornell-box/CornellBox-Original.obj`, CC BY 3.0, see
//! `scenes/cornell-box/copyright.txt`), used by `demo` and `bench` so that they run on a fresh
//! machine with no data.

use anyhow::Context;
use radiosity_bake::scene::Scene;

/// The OBJ text, unchanged from the archive.
pub(crate) const CORNELL_OBJ: &str = include_str!("../scenes/cornell-box/CornellBox-Original.obj");
/// Its MTL text.
pub(crate) const CORNELL_MTL: &str = include_str!("../scenes/cornell-box/CornellBox-Original.mtl");
/// The licence note that travels with it.
pub(crate) const CORNELL_COPYRIGHT: &str = include_str!("../scenes/cornell-box/copyright.txt");

/// Writes the embedded Cornell box (OBJ, MTL and licence note) into `dir` and loads it.
pub(crate) fn cornell_box_in(dir: &std::path::Path) -> anyhow::Result<Scene> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let obj = dir.join("CornellBox-Original.obj");
    for (name, text) in [
        ("CornellBox-Original.obj", CORNELL_OBJ),
        ("CornellBox-Original.mtl", CORNELL_MTL),
        ("copyright.txt", CORNELL_COPYRIGHT),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text).with_context(|| format!("cannot write {}", p.display()))?;
    }
    Ok(Scene::load_obj(&obj)?)
}

/// Loads the embedded Cornell box through a temporary directory that is removed afterwards.
pub(crate) fn cornell_box() -> anyhow::Result<Scene> {
    let dir = tempfile::tempdir().context("cannot create a temporary directory")?;
    cornell_box_in(dir.path())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_embedded_box_loads_with_its_light() {
        let s = super::cornell_box().unwrap();
        assert!(s.objects.iter().any(|o| o == "light"), "{:?}", s.objects);
        assert!(s.triangles.len() >= 30, "{}", s.triangles.len());
    }
}
