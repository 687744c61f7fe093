//! The OBJ statement reader.
//!
//! tobj reads the MTL files (`mtl`); the OBJ statements are read here because the
//! contract needs three things tobj does not give: the line of every error, the `o`-before-`g`
//! object rule (tobj treats both alike), and the file's own vertex numbering (tobj renumbers per
//! model), which the per-vertex interpolation weights are expressed in.

use crate::SceneError;
use std::path::Path;

/// One polygonal face as written, indices resolved to 0-based and range-checked.
#[derive(Clone, Debug)]
pub(crate) struct RawFace {
    /// Position indices.
    pub(crate) v: Vec<u32>,
    /// Texture-coordinate indices, when every corner has one.
    pub(crate) vt: Option<Vec<u32>>,
    /// Index into [`RawObj::objects`].
    pub(crate) object: u32,
    /// The `usemtl` name in force, if any.
    pub(crate) material: Option<u32>,
    /// 1-based line.
    pub(crate) line: u32,
}

/// The statements of an OBJ file that matter for radiosity.
#[derive(Debug, Default)]
pub(crate) struct RawObj {
    pub(crate) positions: Vec<[f64; 3]>,
    pub(crate) texcoords: Vec<[f64; 2]>,
    pub(crate) faces: Vec<RawFace>,
    /// Object names in order of first appearance (`o`, else `g`, else `default`).
    pub(crate) objects: Vec<String>,
    /// `usemtl` names in order of first appearance.
    pub(crate) material_names: Vec<String>,
    /// `mtllib` arguments with their lines.
    pub(crate) mtllibs: Vec<(String, usize)>,
    /// Faces with fewer than three corners (skipped).
    pub(crate) short_faces: usize,
}

fn parse_err(path: &Path, line: usize, message: impl Into<String>) -> SceneError {
    SceneError::Parse {
        path: path.into(),
        line,
        message: message.into(),
    }
}

fn intern(names: &mut Vec<String>, name: &str) -> u32 {
    match names.iter().position(|n| n == name) {
        Some(i) => i as u32,
        None => {
            names.push(name.to_owned());
            (names.len() - 1) as u32
        }
    }
}

fn parse_f64(path: &Path, line: usize, tok: Option<&str>, what: &str) -> Result<f64, SceneError> {
    let tok = tok.ok_or_else(|| parse_err(path, line, format!("missing {what}")))?;
    let x: f64 = tok
        .parse()
        .map_err(|_| parse_err(path, line, format!("bad {what} `{tok}`")))?;
    if !x.is_finite() {
        return Err(parse_err(
            path,
            line,
            format!("{what} `{tok}` is not finite"),
        ));
    }
    Ok(x)
}

/// Resolves a 1-based or negative (relative) OBJ index; `count` is the number defined so far.
fn resolve(
    path: &Path,
    line: usize,
    tok: &str,
    count: usize,
    what: &str,
) -> Result<u32, SceneError> {
    let k: i64 = tok
        .parse()
        .map_err(|_| parse_err(path, line, format!("bad {what} index `{tok}`")))?;
    let i = if k > 0 {
        k - 1
    } else if k < 0 {
        count as i64 + k
    } else {
        return Err(parse_err(
            path,
            line,
            format!("{what} index 0 is invalid (OBJ indices start at 1)"),
        ));
    };
    if i < 0 || i as usize >= count || i > u32::MAX as i64 {
        return Err(parse_err(
            path,
            line,
            format!("{what} index {k} is out of range ({count} defined so far)"),
        ));
    }
    Ok(i as u32)
}

/// Reads the statements of `text`; `path` is only used in messages.
pub(crate) fn parse(path: &Path, text: &str) -> Result<RawObj, SceneError> {
    let mut obj = RawObj::default();
    let mut current_o: Option<u32> = None;
    let mut current_g: Option<u32> = None;
    let mut current_mtl: Option<u32> = None;
    for (i, raw_line) in text.lines().enumerate() {
        let line = i + 1;
        let content = raw_line.split('#').next().unwrap_or("").trim();
        let mut toks = content.split_whitespace();
        let Some(keyword) = toks.next() else { continue };
        let rest = || content[keyword.len()..].trim();
        match keyword {
            "v" => {
                let x = parse_f64(path, line, toks.next(), "x coordinate")?;
                let y = parse_f64(path, line, toks.next(), "y coordinate")?;
                let z = parse_f64(path, line, toks.next(), "z coordinate")?;
                obj.positions.push([x, y, z]);
            }
            "vt" => {
                let u = parse_f64(path, line, toks.next(), "u texture coordinate")?;
                let v = match toks.next() {
                    Some(t) => parse_f64(path, line, Some(t), "v texture coordinate")?,
                    None => 0.0,
                };
                obj.texcoords.push([u, v]);
            }
            "f" => {
                let mut v = Vec::new();
                let mut vt = Vec::new();
                let mut all_vt = true;
                for tok in toks {
                    let mut parts = tok.split('/');
                    let p = parts.next().unwrap_or("");
                    v.push(resolve(path, line, p, obj.positions.len(), "vertex")?);
                    match parts.next() {
                        Some(t) if !t.is_empty() => vt.push(resolve(
                            path,
                            line,
                            t,
                            obj.texcoords.len(),
                            "texture coordinate",
                        )?),
                        _ => all_vt = false,
                    }
                }
                if v.len() < 3 {
                    obj.short_faces += 1;
                    continue;
                }
                if obj.objects.is_empty() && current_o.is_none() && current_g.is_none() {
                    current_g = Some(intern(&mut obj.objects, "default"));
                }
                let object = current_o.or(current_g).expect("set above");
                obj.faces.push(RawFace {
                    v,
                    vt: all_vt.then_some(vt),
                    object,
                    material: current_mtl,
                    line: line as u32,
                });
            }
            "o" => {
                let name = if rest().is_empty() { "default" } else { rest() };
                current_o = Some(intern(&mut obj.objects, name));
            }
            "g" => {
                let name = if rest().is_empty() { "default" } else { rest() };
                current_g = Some(intern(&mut obj.objects, name));
            }
            "usemtl" => {
                let name = rest();
                current_mtl = (!name.is_empty()).then(|| intern(&mut obj.material_names, name));
            }
            "mtllib" if !rest().is_empty() => {
                obj.mtllibs.push((rest().to_owned(), line));
            }
            // Normals come from the winding; smoothing groups, lines, points and free-form
            // geometry carry nothing for radiosity.
            _ => {}
        }
    }
    Ok(obj)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn o_wins_over_g_and_names_are_unique() {
        let text = "o box\nv 0 0 0\nv 1 0 0\nv 0 1 0\ng side\nf 1 2 3\no lid\nf 1 2 3\no box\nf -3 -2 -1\n";
        let obj = parse(Path::new("t.obj"), text).unwrap();
        assert_eq!(obj.objects, ["box", "side", "lid"]);
        let objs: Vec<u32> = obj.faces.iter().map(|f| f.object).collect();
        assert_eq!(objs, [0, 2, 0]);
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse(Path::new("t.obj"), "v 0 0 0\nv 1 nan 0\n").unwrap_err();
        assert!(e.to_string().starts_with("t.obj:2:"), "{e}");
        let e = parse(Path::new("t.obj"), "v 0 0 0\n\nf 1 2 3\n").unwrap_err();
        assert!(
            e.to_string().starts_with("t.obj:3:") && e.to_string().contains("out of range"),
            "{e}"
        );
    }
}
