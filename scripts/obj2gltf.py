#!/usr/bin/env python3
"""Converts an OBJ + MTL scene into glTF 2.0: `NAME.gltf` with `NAME.bin`, and `NAME.glb`.

Usage: scripts/obj2gltf.py SCENE.obj OUT_DIR

Only the Python standard library. The conversion follows the project's OBJ rules
(docs/contract.md) so that the glTF copy loads to the same world geometry, objects and
materials as the OBJ:

- a face belongs to the object of the `o` line in force, else the `g` line, else `default`;
  each object becomes one node with one mesh, one indexed TRIANGLES primitive per material;
- faces are fan-triangulated from their first corner; a triangle with the same corners in the
  same cyclic order as an earlier one (anywhere in the file) is dropped, as the OBJ loader
  drops it;
- `Kd` becomes `baseColorFactor` (metallic 0, roughness 1: a diffuse surface) and `Ke` the
  emission as `emissiveFactor` × `KHR_materials_emissive_strength` (the factor's largest
  channel 1);
- the object nodes hang under a hierarchy that undoes itself: a TRS node (translate, rotate
  180° about y, scale 2), a matrix node holding its exact inverse, a mirror node (scale
  -1 1 1), and each object node mirrored back. Every factor is a power of two or ±1, so the
  composed world transform is exactly the identity in floating point and the positions are
  the OBJ's, rounded to f32 as glTF stores them.

Texture coordinates and normals are not written (the scenes converted with it have none).
"""

import json
import struct
import sys
from pathlib import Path


def parse_mtl(path):
    mats = {}
    cur = None
    if not path.exists():
        return mats
    for line in path.read_text(errors="replace").splitlines():
        t = line.split("#")[0].split()
        if not t:
            continue
        if t[0] == "newmtl":
            cur = " ".join(t[1:])
            mats[cur] = {"Kd": [0.5, 0.5, 0.5], "Ke": [0.0, 0.0, 0.0]}
        elif cur is not None and t[0] in ("Kd", "Ke"):
            mats[cur][t[0]] = [float(x) for x in t[1:4]]
    return mats


def parse_obj(path):
    positions, faces = [], []  # faces: (object name, material name or None, [vertex indices])
    objects = []
    cur_o = cur_g = cur_m = None
    mtls = {}
    for line in path.read_text(errors="replace").splitlines():
        t = line.split("#")[0].split()
        if not t:
            continue
        rest = " ".join(t[1:])
        if t[0] == "v":
            positions.append([float(x) for x in t[1:4]])
        elif t[0] == "f":
            idx = []
            for c in t[1:]:
                k = int(c.split("/")[0])
                idx.append(k - 1 if k > 0 else len(positions) + k)
            if len(idx) < 3:
                continue
            if cur_o is None and cur_g is None and not objects:
                cur_g = "default"
                objects.append("default")
            faces.append((cur_o or cur_g, cur_m, idx))
        elif t[0] in ("o", "g"):
            name = rest or "default"
            if name not in objects:
                objects.append(name)
            if t[0] == "o":
                cur_o = name
            else:
                cur_g = name
        elif t[0] == "usemtl":
            cur_m = rest or None
        elif t[0] == "mtllib" and rest:
            mtls.update(parse_mtl(path.parent / rest))
    return positions, faces, objects, mtls


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def convert(obj_path, out_dir):
    positions, faces, objects, mtls = parse_obj(obj_path)
    # Triangles per (object, material), in file order, duplicates dropped.
    seen = set()
    groups = {}  # object -> {material -> [tri]}
    for obj, mat, idx in faces:
        for k in range(1, len(idx) - 1):
            tri = [idx[0], idx[k], idx[k + 1]]
            p = [tuple(positions[i]) for i in tri]
            s = min(range(3), key=lambda a: p[a])
            key = tuple(p[(s + j) % 3] for j in range(3))
            if key in seen:
                continue
            seen.add(key)
            groups.setdefault(obj, {}).setdefault(mat, []).append(tri)

    bin_data = bytearray()
    gl = {
        "asset": {"version": "2.0", "generator": "radiosity scripts/obj2gltf.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"name": obj_path.stem, "nodes": [0]}],
        "nodes": [],
        "meshes": [],
        "materials": [],
        "accessors": [],
        "bufferViews": [],
        "buffers": [],
    }
    mat_index = {}

    def material(name):
        if name in mat_index:
            return mat_index[name]
        m = mtls.get(name, {"Kd": [0.5, 0.5, 0.5], "Ke": [0.0, 0.0, 0.0]})
        g = {
            "name": name or "default",
            "pbrMetallicRoughness": {
                "baseColorFactor": m["Kd"] + [1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            },
        }
        peak = max(m["Ke"])
        if peak > 0:
            g["emissiveFactor"] = [c / peak for c in m["Ke"]]
            if peak != 1.0:
                g["extensions"] = {
                    "KHR_materials_emissive_strength": {"emissiveStrength": peak}
                }
        gl["materials"].append(g)
        mat_index[name] = len(gl["materials"]) - 1
        return mat_index[name]

    def view(data, target):
        while len(bin_data) % 4:
            bin_data.append(0)
        gl["bufferViews"].append(
            {"buffer": 0, "byteOffset": len(bin_data), "byteLength": len(data), "target": target}
        )
        bin_data.extend(data)
        return len(gl["bufferViews"]) - 1

    # The hierarchy: TRS root, its exact inverse as a matrix, a mirror; objects mirrored back.
    t = [0.5, -0.25, 1.0]
    gl["nodes"].append(
        {
            "name": "placed",
            "translation": t,
            "rotation": [0.0, 1.0, 0.0, 0.0],
            "scale": [2.0, 2.0, 2.0],
            "children": [1],
        }
    )
    # (T·R·S)⁻¹ = S⁻¹·R⁻¹·T⁻¹ with R = diag(-1, 1, -1): column-major.
    inv_t = [0.5 * -1 * -t[0], 0.5 * 1 * -t[1], 0.5 * -1 * -t[2]]
    gl["nodes"].append(
        {
            "name": "unplaced",
            "matrix": [-0.5, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, -0.5, 0] + inv_t + [1.0],
            "children": [2],
        }
    )
    gl["nodes"].append({"name": "mirror", "scale": [-1.0, 1.0, 1.0], "children": []})

    for obj in objects:
        if obj not in groups:
            continue
        prims = []
        for mat, tris in groups[obj].items():
            used = sorted({i for tri in tris for i in tri})
            local = {v: k for k, v in enumerate(used)}
            pts = [[f32(c) for c in positions[v]] for v in used]
            pos = b"".join(struct.pack("<3f", *p) for p in pts)
            ind = b"".join(struct.pack("<3I", *(local[i] for i in tri)) for tri in tris)
            gl["accessors"].append(
                {
                    "bufferView": view(pos, 34962),
                    "componentType": 5126,
                    "count": len(pts),
                    "type": "VEC3",
                    "min": [min(p[c] for p in pts) for c in range(3)],
                    "max": [max(p[c] for p in pts) for c in range(3)],
                }
            )
            pa = len(gl["accessors"]) - 1
            gl["accessors"].append(
                {
                    "bufferView": view(ind, 34963),
                    "componentType": 5125,
                    "count": 3 * len(tris),
                    "type": "SCALAR",
                }
            )
            prims.append(
                {
                    "attributes": {"POSITION": pa},
                    "indices": len(gl["accessors"]) - 1,
                    "material": material(mat),
                    "mode": 4,
                }
            )
        gl["meshes"].append({"name": obj, "primitives": prims})
        gl["nodes"].append(
            {"name": obj, "mesh": len(gl["meshes"]) - 1, "scale": [-1.0, 1.0, 1.0]}
        )
        gl["nodes"][2]["children"].append(len(gl["nodes"]) - 1)

    while len(bin_data) % 4:
        bin_data.append(0)
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = obj_path.stem
    gl["buffers"] = [{"uri": stem + ".bin", "byteLength": len(bin_data)}]
    (out_dir / (stem + ".gltf")).write_text(json.dumps(gl, indent=1) + "\n")
    (out_dir / (stem + ".bin")).write_bytes(bytes(bin_data))

    gl["buffers"] = [{"byteLength": len(bin_data)}]
    js = json.dumps(gl, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    total = 12 + 8 + len(js) + 8 + len(bin_data)
    glb = struct.pack("<4sII", b"glTF", 2, total)
    glb += struct.pack("<I4s", len(js), b"JSON") + js
    glb += struct.pack("<I4s", len(bin_data), b"BIN\0") + bytes(bin_data)
    (out_dir / (stem + ".glb")).write_bytes(glb)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: obj2gltf.py SCENE.obj OUT_DIR")
    convert(Path(sys.argv[1]), Path(sys.argv[2]))
