#!/usr/bin/env python3
"""Convert an IFC building (here the KIT FZK-Haus) into one Wavefront OBJ + MTL for diffuse GI.

Source of the model this was written for: `AC20-FZK-Haus.ifc`, the "FZK-Haus" of the
Institute for Automation and Applied Informatics (IAI), Karlsruhe Institute of Technology
(KIT), author Karl-Heinz Haefele ("KHH"); published in the KIT IFC examples
(https://www.ifcwiki.org/index.php?title=KIT_IFC_Examples). The copy converted here was taken
from https://github.com/ThatOpen/engine_web-ifc, tests/ifcfiles/public/AC20-FZK-Haus.ifc
(blob 396dbcd268b67189a46fbcd3a255b1a500d7697f, added in commit 3ee1084bf580, read at commit
233e3aa7118d7364606dcb171206a89b3ed62657). See README.md next to this script.

Usage:
    python convert.py AC20-FZK-Haus.ifc OUTDIR [--name house] [--ground-size 60]
                      [--sun-elevation 35] [--skip IFCCLASS ...]

Needs `ifcopenshell` (tested with 0.9.0.post1 from PyPI) and numpy. Writes OUTDIR/NAME.obj and
OUTDIR/NAME.mtl and prints the statistics quoted in README.md.

Frame of the output: metres, **Y up**. An IFC world point (X, Y, Z) (Z up) is written as
(x, y, z) = (X, Z, -Y): a proper rotation, so the outward winding IfcOpenShell produces is
kept. IFC +Y (project "north", not true north) becomes OBJ -Z.

What is kept and what is left out:
- one `o` per IFC product with a body; name `<IfcClass>_<Name>_<n>` (ASCII, `_` for anything
  outside [A-Za-z0-9._-], n counts repeats of the same class and name from 1);
- glass is left out face by face (faces styled with an IfcSurfaceStyle named like glass, or
  with transparency >= 0.5), so window and glazed-door frames stay and the sun comes in
  through the wall openings, which IfcOpenShell has already cut;
- IfcSpace, IfcOpeningElement, IfcAnnotation, IfcVirtualElement and the spatial structure
  (IfcSite, IfcBuilding, IfcBuildingStorey) are left out; the IfcSite terrain is replaced by
  `ground`, a flat square at the terrain's top level with a hole where the base slab is;
- triangles of zero area (after rounding to the written precision) are dropped.
"""
import argparse
import math
import re
import sys
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np
import ifcopenshell
import ifcopenshell.geom

# Diffuse reflectance (MTL Kd) per material kind.
MATERIALS = {
    "wall": (0.6, 0.6, 0.6),
    "slab": (0.4, 0.4, 0.4),
    "roof": (0.45, 0.2, 0.15),
    "wood": (0.45, 0.3, 0.2),
    "metal": (0.5, 0.5, 0.5),
    "furniture": (0.5, 0.5, 0.5),
    "ground": (0.25, 0.25, 0.2),
    "other": (0.5, 0.5, 0.5),
}

SKIP_CLASSES = (
    "IfcSpace",
    "IfcOpeningElement",
    "IfcAnnotation",
    "IfcVirtualElement",
    "IfcSite",
    "IfcBuilding",
    "IfcBuildingStorey",
    "IfcGrid",
)

GLASS_STYLE = re.compile(r"glas|glass|glazing|verglasung", re.I)
METAL_STYLE = re.compile(r"kupfer|copper|stahl|steel|metal|alu|chrom|messing|brass", re.I)
WOOD_NAME = re.compile(r"holz|wood|timber|kiefer|pine|oak|eiche|fichte|buche", re.I)
CONCRETE_NAME = re.compile(r"beton|concrete|stein|brick|ziegel|mauer|masonry", re.I)

DIGITS = 5  # decimals written for coordinates (10 µm)
MIN_AREA = 1e-9  # m²; smaller triangles are dropped


def ascii_name(text):
    text = (text or "").strip()
    for a, b in (("ä", "ae"), ("ö", "oe"), ("ü", "ue"), ("Ä", "Ae"), ("Ö", "Oe"), ("Ü", "Ue"), ("ß", "ss")):
        text = text.replace(a, b)
    text = re.sub(r"[^A-Za-z0-9._-]", "_", text)
    return text or "unnamed"


def material_names(product):
    """Names of the IFC materials associated with a product (for the wood/concrete guess)."""
    names = []
    try:
        import ifcopenshell.util.element as ue

        mat = ue.get_material(product, should_skip_usage=True)
    except Exception:
        mat = None
    if mat is None:
        return names
    for attr in ("Name",):
        if getattr(mat, attr, None):
            names.append(mat.Name)
    for layer in getattr(mat, "MaterialLayers", None) or []:
        if layer.Material is not None:
            names.append(layer.Material.Name or "")
    for m in getattr(mat, "Materials", None) or []:
        names.append(m.Name or "")
    return names


def kind_of(product):
    """The MTL material for a product's faces that carry no overriding style."""
    cls = product.is_a()
    mats = " ".join(material_names(product))
    if product.is_a("IfcSlab"):
        return "roof" if str(product.PredefinedType) == "ROOF" else "slab"
    if product.is_a("IfcRoof"):
        return "roof"
    if product.is_a("IfcWall") or product.is_a("IfcColumn") or product.is_a("IfcFooting"):
        return "wall"
    if product.is_a("IfcDoor") or product.is_a("IfcWindow"):
        return "wood"
    if cls in ("IfcStair", "IfcStairFlight", "IfcBeam", "IfcMember", "IfcPlate", "IfcRamp", "IfcRampFlight"):
        if CONCRETE_NAME.search(mats) and not WOOD_NAME.search(mats):
            return "slab"
        return "wood"
    if product.is_a("IfcRailing"):
        return "metal"
    if product.is_a("IfcFurnishingElement") or cls == "IfcFurniture":
        return "furniture"
    if product.is_a("IfcCovering"):
        return "slab"
    return "other"


def style_info(ifc, geom_material):
    """(name, transparency) of the IfcSurfaceStyle behind an IfcOpenShell material."""
    name = geom_material.name or ""
    try:
        entity = ifc.by_id(geom_material.instance_id())
        if entity is not None and getattr(entity, "Name", None):
            name = entity.Name
    except Exception:
        pass
    try:
        transparency = float(geom_material.transparency)
    except Exception:
        transparency = 0.0
    if not math.isfinite(transparency):
        transparency = 0.0
    return name, transparency


def to_obj_frame(p):
    """IFC world (X, Y, Z), Z up -> OBJ (X, Z, -Y), Y up."""
    p = np.asarray(p, dtype=float)
    return np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)


def tri_areas_normals(v, f):
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    cr = np.cross(b - a, c - a)
    area = 0.5 * np.linalg.norm(cr, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        n = cr / (2.0 * area[:, None])
    return area, n


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("ifc", type=Path)
    ap.add_argument("outdir", type=Path)
    ap.add_argument("--name", default="house")
    ap.add_argument("--ground-size", type=float, default=60.0, help="side of the ground square, m")
    ap.add_argument("--sun-elevation", type=float, default=35.0, help="for the suggested sun vector, degrees")
    ap.add_argument("--skip", action="append", default=[], metavar="IFCCLASS",
                    help="leave out this IFC class too (repeatable), e.g. IfcMember for the rafters "
                         "buried in the FZK-Haus roof slabs")
    args = ap.parse_args()

    ifc = ifcopenshell.open(str(args.ifc))
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    settings.set("weld-vertices", True)
    settings.set("disable-opening-subtractions", False)
    settings.set("apply-default-materials", True)

    products = sorted(ifc.by_type("IfcProduct"), key=lambda p: p.id())
    objects = []  # (name, kind-per-face list, V (n,3) IFC frame, F (m,3))
    kept, skipped = Counter(), Counter()
    glass_faces = []  # (product, V, F) of the glass left out
    name_count = Counter()
    used_names = set()
    site_top = None
    slabs = []  # (zmin, zmax, xmin, xmax, ymin, ymax)
    dropped_degenerate = 0

    for p in products:
        cls = p.is_a()
        if p.is_a("IfcSite") and p.Representation is not None:
            try:
                sh = ifcopenshell.geom.create_shape(settings, p)
                v = np.array(sh.geometry.verts, dtype=float).reshape(-1, 3)
                if len(v):
                    site_top = float(v[:, 2].max())
            except Exception:
                pass
        if any(p.is_a(c) for c in SKIP_CLASSES + tuple(args.skip)) or p.Representation is None:
            skipped[cls] += 1
            continue
        try:
            sh = ifcopenshell.geom.create_shape(settings, p)
        except Exception as e:  # no body representation (e.g. only an axis)
            print(f"note: {cls} #{p.id()} {p.Name!r}: no shape ({e})", file=sys.stderr)
            skipped[cls] += 1
            continue
        g = sh.geometry
        v = np.array(g.verts, dtype=float).reshape(-1, 3)
        f = np.array(g.faces, dtype=np.int64).reshape(-1, 3)
        mids = np.array(g.material_ids, dtype=np.int64) if len(g.material_ids) else np.full(len(f), -1)
        styles = [style_info(ifc, m) for m in g.materials]
        base = kind_of(p)
        face_kind = []
        is_glass = np.zeros(len(f), dtype=bool)
        for i, mid in enumerate(mids):
            sname, transp = styles[mid] if 0 <= mid < len(styles) else ("", 0.0)
            if GLASS_STYLE.search(sname) or transp >= 0.5:
                is_glass[i] = True
                face_kind.append(None)
            elif METAL_STYLE.search(sname):
                face_kind.append("metal")
            else:
                face_kind.append(base)
        if is_glass.any():
            glass_faces.append((p, v, f[is_glass]))
        keep = ~is_glass
        f = f[keep]
        face_kind = [k for k, s in zip(face_kind, keep) if s]
        if len(f) == 0:
            skipped[cls + " (glass only)"] += 1
            continue
        if p.is_a("IfcSlab"):
            slabs.append((v[:, 2].min(), v[:, 2].max(), v[:, 0].min(), v[:, 0].max(), v[:, 1].min(), v[:, 1].max()))
        # Round to the written precision, drop zero-area triangles and unused vertices.
        vr = np.round(to_obj_frame(v), DIGITS)
        area, _ = tri_areas_normals(vr, f)
        ok = (area > MIN_AREA) & (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
        dropped_degenerate += int((~ok).sum())
        f = f[ok]
        face_kind = [k for k, s in zip(face_kind, ok) if s]
        used = np.unique(f)
        remap = np.full(len(vr), -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        vr, f = vr[used], remap[f]
        stem = f"{cls}_{ascii_name(p.Name)}"
        name_count[stem] += 1
        name = f"{stem}_{name_count[stem]}"
        while name in used_names:
            name_count[stem] += 1
            name = f"{stem}_{name_count[stem]}"
        used_names.add(name)
        objects.append((name, face_kind, vr, f))
        kept[cls] += 1

    # Ground: flat square at the terrain's top (IfcSite) or 1 cm under the lowest slab, with a
    # rectangular hole where a slab straddles that level (the base slab, whose top is the
    # ground floor) so that the ground does not cover the floor.
    allv = np.concatenate([o[2] for o in objects])  # OBJ frame
    if site_top is not None:
        gz = site_top
        ground_note = f"IfcSite terrain top, IFC Z = {gz:g}"
    else:
        gz = min(s[0] for s in slabs) - 0.01 if slabs else float(allv[:, 1].min()) - 0.01
        ground_note = f"1 cm under the lowest slab, IFC Z = {gz:g}"
    hole = None
    for zmin, zmax, x0, x1, y0, y1 in slabs:
        if zmin < gz <= zmax + 1e-6:
            h = (float(x0), float(x1), float(y0), float(y1))
            hole = h if hole is None else (min(hole[0], x0), max(hole[1], x1), min(hole[2], y0), max(hole[3], y1))
    # house footprint centre in IFC XY
    cx = 0.5 * (allv[:, 0].min() + allv[:, 0].max())
    cy = 0.5 * (-allv[:, 2].min() + -allv[:, 2].max())
    half = args.ground_size / 2
    outer = [(cx - half, cy - half), (cx + half, cy - half), (cx + half, cy + half), (cx - half, cy + half)]
    if hole is not None:
        x0, x1, y0, y1 = hole
        inner = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
        gv = np.array([(x, y, gz) for x, y in outer + inner])
        gf = []
        for k in range(4):
            o0, o1, i0, i1 = k, (k + 1) % 4, 4 + k, 4 + (k + 1) % 4
            gf += [(o0, o1, i1), (o0, i1, i0)]  # counter-clockwise seen from +Z: normal up
        gf = np.array(gf)
    else:
        gv = np.array([(x, y, gz) for x, y in outer])
        gf = np.array([(0, 1, 2), (0, 2, 3)])
    gvr = np.round(to_obj_frame(gv), DIGITS)
    objects.append(("ground", ["ground"] * len(gf), gvr, gf))

    # Write OBJ + MTL.
    args.outdir.mkdir(parents=True, exist_ok=True)
    obj_path = args.outdir / f"{args.name}.obj"
    mtl_path = args.outdir / f"{args.name}.mtl"
    used_kinds = sorted({k for o in objects for k in o[1]})
    with open(mtl_path, "w", newline="\n") as m:
        m.write(f"# {args.name}.mtl: diffuse reflectance per material kind (convert.py)\n")
        for k in used_kinds:
            m.write(f"\nnewmtl {k}\nKd {MATERIALS[k][0]:g} {MATERIALS[k][1]:g} {MATERIALS[k][2]:g}\n")

    def fmt(x):
        s = f"{x:.{DIGITS}f}".rstrip("0").rstrip(".")
        return "0" if s in ("-0", "") else s

    n_tris = 0
    with open(obj_path, "w", newline="\n") as out:
        out.write(f"# {args.name}.obj, converted by convert.py with IfcOpenShell {ifcopenshell.version}\n")
        out.write(f"# from {args.ifc.name}: FZK-Haus, KIT Institute for Automation and Applied Informatics (IAI)\n")
        out.write("# metres, Y up: OBJ (x, y, z) = IFC (X, Z, -Y); glass left out; see README.md\n")
        out.write(f"mtllib {mtl_path.name}\n")
        base = 1
        for name, kinds, v, f in objects:
            out.write(f"o {name}\n")
            for p in v:
                out.write(f"v {fmt(p[0])} {fmt(p[1])} {fmt(p[2])}\n")
            order = sorted(range(len(f)), key=lambda i: used_kinds.index(kinds[i]))
            cur = None
            for i in order:
                if kinds[i] != cur:
                    cur = kinds[i]
                    out.write(f"usemtl {cur}\n")
                a, b, c = f[i] + base
                out.write(f"f {a} {b} {c}\n")
            base += len(v)
            n_tris += len(f)

    # Statistics and the facade with the most glazing (glass faces facing outward).
    lo, hi = allv.min(0), allv.max(0)
    lo = np.minimum(lo, gvr.min(0))
    hi = np.maximum(hi, gvr.max(0))
    print(f"wrote {obj_path} ({obj_path.stat().st_size} bytes) and {mtl_path}")
    print(f"objects: {len(objects)} (incl. ground), triangles: {n_tris}, vertices: {base - 1}")
    print(f"degenerate triangles dropped: {dropped_degenerate}")
    print(f"bounding box (OBJ, Y up): min {lo.tolist()} max {hi.tolist()}")
    print(f"ground: {ground_note}; hole {hole}")
    print("kept:", dict(sorted(kept.items())))
    print("skipped:", dict(sorted(skipped.items())))
    print("materials:", dict(Counter(k for o in objects for k in o[1])))

    bx0, bx1 = allv[:, 0].min(), allv[:, 0].max()
    by0, by1 = -allv[:, 2].max(), -allv[:, 2].min()
    facades = {"-X": np.array([-1.0, 0, 0]), "+X": np.array([1.0, 0, 0]), "-Y": np.array([0, -1.0, 0]), "+Y": np.array([0, 1.0, 0])}
    glass_area = defaultdict(float)
    opening_area = defaultdict(float)
    members = defaultdict(list)
    for p, v, f in glass_faces:
        c = v.mean(0)
        d = {"-X": c[0] - bx0, "+X": bx1 - c[0], "-Y": c[1] - by0, "+Y": by1 - c[1]}
        side = min(d, key=d.get)
        area, n = tri_areas_normals(v, f)
        out_facing = (n @ facades[side]) > 0.9
        glass_area[side] += float(area[out_facing].sum())
        w = getattr(p, "OverallWidth", None) or 0.0
        h = getattr(p, "OverallHeight", None) or 0.0
        opening_area[side] += float(w) * float(h)
        members[side].append(p.Name)
    for side in facades:
        print(f"facade {side}: glass {glass_area[side]:.2f} m2, window/door size {opening_area[side]:.2f} m2: {members[side]}")
    best = max(facades, key=lambda s: glass_area[s])
    n_ifc = facades[best]
    e = math.radians(args.sun_elevation)
    sun_ifc = np.array([n_ifc[0] * math.cos(e), n_ifc[1] * math.cos(e), math.sin(e)])
    sun_obj = to_obj_frame(sun_ifc)
    print(f"most glazing: IFC {best} facade, outward normal IFC {n_ifc.tolist()} = OBJ {to_obj_frame(n_ifc).tolist()}")
    print(f"towards the sun at {args.sun_elevation:g} deg: IFC {np.round(sun_ifc, 4).tolist()} = OBJ {np.round(sun_obj, 4).tolist()}")
    # project azimuth convention of radiosity_runtime::daylight: (cos h sin a, sin h, -cos h cos a)
    az = math.degrees(math.atan2(sun_obj[0], -sun_obj[2])) % 360
    print(f"  = daylight azimuth {az:.1f} deg (0 along -Z, 90 along +X), elevation {args.sun_elevation:g}")
    for ctx in ifc.by_type("IfcGeometricRepresentationContext"):
        tn = getattr(ctx, "TrueNorth", None)
        if tn is not None and ctx.ContextType == "Model":
            t = tn.DirectionRatios
            north = math.degrees(math.atan2(t[1], t[0]))
            bearing = (north - math.degrees(math.atan2(n_ifc[1], n_ifc[0]))) % 360
            print(f"TrueNorth (IFC XY) {tuple(round(x, 4) for x in t[:2])}: that facade faces compass bearing {bearing:.0f} deg")
            break


if __name__ == "__main__":
    main()
