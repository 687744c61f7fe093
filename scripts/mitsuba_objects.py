#!/usr/bin/env python3
"""Independent per-object irradiance reference made with Mitsuba 3, to check `radiosity pathtrace`.

Needs `pip install mitsuba numpy`; compares with `radiosity pathtrace --json` on the same OBJ
scene and lights file.

    python3 scripts/mitsuba_objects.py SCENE.obj LIGHTS.json [--spp N] [--batches K]
                                       [--seed S] [--max-depth D] [--json OUT]
    python3 scripts/mitsuba_objects.py --check

The scene is read here (plain OBJ + MTL: `o`/`g`, `v`, `f`, `usemtl`, `mtllib`; polygons as
fans) with the conventions of docs/contract.md: one-sided triangles, the front counter-clockwise
(Mitsuba's `diffuse` is one-sided too: a back face reflects nothing, and every face blocks from
both sides); MTL `Kd` the diffuse reflectance (a channel at or above 1 lowered to 0.95, no
material grey 0.5), `Ke` emitted radiance (an `area` emitter, front only); a face's object is
the `o` line in force, else the `g` line, else `default`; degenerate triangles and exact
duplicates (same corners, same cyclic order) are skipped as the loader skips them. Each object
(one Mitsuba shape per object and material) carries its own `irradiancemeter`, which averages
the irradiance over the shape's whole surface, uniformly by area, so buried surface counts as
the (near) zero it receives: the contract's per-object `area` and `irradiance`.

Lights (docs/contract.md, "The lights file"): only what the house needs; any other type is
refused.
- `directional`: `direction` the way the light travels, `irradiance` W/m² on a plane facing it.
  The irradiancemeter cannot see a delta light from its own surface, so the meter gives the
  sun's bounced light only, and the sun's direct term is added here: the mean over the shape
  (uniform by area, `--spp` points) of irradiance·max(0, n·(−d)) times a shadow ray
  (`scene.ray_test`, from the front, offset as Mitsuba's `spawn_ray` does).
- `sky`: `radiance` W/(m²·sr), the same from every direction: Mitsuba's `constant` emitter.
  The contract's uniform sky is the whole sphere (`Light::sky_radiance` answers every
  direction): an open face reads π·L at any tilt, even facing down; a face tilted by θ reads
  π·L·(1 + cos θ)/2 only over a ground that hides the lower half.

Per object: irradiance = meter (`path` integrator, no depth limit, Russian roulette) + direct
sun, per channel. The meter runs in `--batches` independent batches (seeds) of
`--spp / --batches` samples, its standard error that of the batch means; the direct term's comes
from its samples; the two add in quadrature; a shape per material, combined by area.

Coplanar triangles facing opposite ways (a two-sided sheet, or two objects pressed face to face)
are each moved a hair (4e-6 of the scene's largest coordinate) along their own normal: Mitsuba
reports either of two coincident triangles and a one-sided `diffuse` is black from the back, so
an unmoved two-sided sheet reads dark from both sides (a 3 m sheet over a box read its lower
side 4% low and the box face under it 18% low), where `radiosity pathtrace` shows the near front
as the contract says. Pressed faces move into each other's solid, so no gap opens. Left as
Mitsuba sees it: a face pressed from behind against a one-sided surface with open space beyond
(a block standing on a one-sided ground sheet) sees through it (the block's underside gets the
sky below), where the contract calls it buried, 0. The house has none: its ground has a hole
where the floor slab is.

Output (stdout, or `--json OUT`): the objects of `radiosity pathtrace --json`,
`{"samples_per_object", "objects": [{"name", "area", "irradiance", "stderr", "radiosity"}], ...}`,
no `exposed_area` (a meter sees the whole surface), so that
`python3 scripts/compare_objects.py OURS.json MITSUBA.json` compares them. `--check` runs the
closed-form scenes of `check()` (open quads under the sky and the sun, a tilted quad over a
ground) and exits 1 if one is off. See docs/decisions/mitsuba-house-check.md.
"""

import argparse
import json
import math
import os
import sys
import tempfile
import time

import numpy as np


RENDER_SPP = 4096  # samples a render call at most (the film's f32 sum)
# The CPU variant that runs everywhere (2^20 samples an object on the house: under 7 minutes on
# one core). `llvm_ad_rgb` aborts with Debian 12's LLVM 15 ("Cannot select ... fmaximum").
VARIANT = "scalar_rgb"


def fail(msg):
    sys.exit(f"error: {msg}")


# ---------------------------------------------------------------- scene


def parse_mtl(path):
    """{material: {"Kd": [r, g, b] or None, "Ke": [r, g, b] or None}}."""
    mats, cur = {}, None
    try:
        lines = open(path, encoding="utf-8", errors="replace").read().splitlines()
    except OSError as e:
        fail(f"{path}: {e.strerror}")
    for n, line in enumerate(lines, 1):
        t = line.split("#", 1)[0].split()
        if not t:
            continue
        if t[0] == "newmtl":
            cur = " ".join(t[1:])
            mats[cur] = {"Kd": None, "Ke": None}
        elif t[0] in ("Kd", "Ke") and cur is not None:
            try:
                v = [float(x) for x in t[1:4]]
            except ValueError:
                fail(f"{path}:{n}: {t[0]} needs three numbers")
            if len(v) == 1:
                v = v * 3
            if len(v) != 3 or not all(math.isfinite(x) and x >= 0 for x in v):
                fail(f"{path}:{n}: {t[0]} must be three finite non-negative numbers")
            mats[cur][t[0]] = v
    return mats


def parse_obj(path):
    """Vertices (float64, n×3), and the triangles in file order as (corner indices, object,
    material) with the objects in order of first appearance."""
    verts, tris, mtllibs = [], [], []
    o_name = g_name = None
    mtl = None
    try:
        f = open(path, encoding="utf-8", errors="replace")
    except OSError as e:
        fail(f"{path}: {e.strerror}")
    with f:
        for n, line in enumerate(f, 1):
            t = line.split("#", 1)[0].split()
            if not t:
                continue
            k = t[0]
            if k == "v":
                try:
                    p = [float(x) for x in t[1:4]]
                except ValueError:
                    fail(f"{path}:{n}: bad vertex")
                if len(p) != 3 or not all(math.isfinite(x) for x in p):
                    fail(f"{path}:{n}: a vertex needs three finite coordinates")
                verts.append(p)
            elif k == "f":
                idx = []
                for c in t[1:]:
                    try:
                        i = int(c.split("/")[0])
                    except ValueError:
                        fail(f"{path}:{n}: bad face corner {c!r}")
                    i = i - 1 if i > 0 else len(verts) + i
                    if not 0 <= i < len(verts):
                        fail(f"{path}:{n}: face corner {c} names no vertex")
                    idx.append(i)
                if len(idx) < 3:
                    fail(f"{path}:{n}: a face needs three corners")
                name = o_name or g_name or "default"
                for j in range(1, len(idx) - 1):  # a polygon as a fan
                    tris.append(((idx[0], idx[j], idx[j + 1]), name, mtl))
            elif k == "o":
                o_name = " ".join(t[1:]) or None
            elif k == "g":
                g_name = " ".join(t[1:]) or None
            elif k == "usemtl":
                mtl = " ".join(t[1:])
            elif k == "mtllib":
                mtllibs.append(" ".join(t[1:]))
    if not tris:
        fail(f"{path}: no faces")
    return np.array(verts, dtype=np.float64), tris, mtllibs


def is_degenerate(p):
    a2 = np.linalg.norm(np.cross(p[1] - p[0], p[2] - p[0]))
    e2 = max(np.sum((p[1] - p[0]) ** 2), np.sum((p[2] - p[1]) ** 2), np.sum((p[0] - p[2]) ** 2))
    return not a2 > 1e-12 * e2


def nudge_facing_planes(groups):
    """Moves each triangle that lies in the plane of a triangle facing the other way (the
    contract's two-sided sheet, two triangles of the same corners wound both ways, however
    triangulated; or two objects pressed face to face) a hair along its own front normal, in
    place. Mitsuba reports either of two coincident triangles, and a one-sided `diffuse` seen
    from the back is black, so an unmoved sheet would be black from either side about half the
    time; moved apart, a ray meets the front that faces it, as the contract says (each side
    receives and reflects, and neither buries the other; `radiosity pathtrace` shows the near
    one's front). Pressed faces move into each other's solid, so no gap opens between them.
    The hair is 4e-6 of (1 + the largest coordinate): tens of f32 steps. Returns the count."""
    tris = [p for parts in groups.values() for ps in parts.values() for p in ps]
    extent = 1 + max(float(np.abs(p).max()) for p in tris)
    hair = 4e-6 * extent

    def plane(p, sign=1):
        n = np.cross(p[1] - p[0], p[2] - p[0])
        n = sign * n / np.linalg.norm(n)
        d = float(n @ p.mean(axis=0))
        return tuple(np.round(n * 1e5).astype(int)) + (round(d / (1e-5 * extent)),)

    planes = {plane(p) for p in tris}
    moved = 0
    for parts in groups.values():
        for ps in parts.values():
            for i, p in enumerate(ps):
                if plane(p, -1) in planes:
                    n = np.cross(p[1] - p[0], p[2] - p[0])
                    ps[i] = p + hair * n / np.linalg.norm(n)
                    moved += 1
    if moved:
        print(f"mitsuba: {moved} triangles in a plane shared with triangles facing the other "
              f"way moved {hair:.2g} along their normals", file=sys.stderr)
    return moved


def load_scene(path):
    """[(object, [parts])], each part {"material", "rho", "ke", "p" (m×3×3 float64)}."""
    verts, tris, mtllibs = parse_obj(path)
    mats = {}
    for lib in mtllibs:
        mats.update(parse_mtl(os.path.join(os.path.dirname(path), lib)))
    seen, skipped = set(), [0, 0]
    groups, order = {}, []
    for corners, name, mtl in tris:
        p = verts[list(corners)]
        if is_degenerate(p):
            skipped[0] += 1
            continue
        s = min(range(3), key=lambda a: tuple(p[a]))
        key = tuple(tuple(p[(s + j) % 3]) for j in range(3))
        if key in seen:
            skipped[1] += 1
            continue
        seen.add(key)
        if name not in groups:
            groups[name] = {}
            order.append(name)
        groups[name].setdefault(mtl, []).append(p)
    if skipped[0] or skipped[1]:
        print(f"warning: {path}: skipped {skipped[0]} degenerate and {skipped[1]} duplicate "
              f"triangle(s)", file=sys.stderr)
    nudge_facing_planes(groups)
    lowered, grey = set(), set()
    objects = []
    for name in order:
        parts = []
        for mtl, ps in groups[name].items():
            m = mats.get(mtl) if mtl is not None else None
            kd = m["Kd"] if m else None
            if kd is None:
                grey.add(str(mtl))
                kd = [0.5] * 3
            if any(c >= 1 for c in kd):
                lowered.add(mtl)
                kd = [0.95 if c >= 1 else c for c in kd]
            ke = (m or {}).get("Ke") or [0.0] * 3
            parts.append({"material": mtl, "rho": kd, "ke": ke, "p": np.array(ps)})
        objects.append((name, parts))
    if grey:
        print(f"warning: faces without a usable material (grey 0.5): {sorted(grey)}",
              file=sys.stderr)
    if lowered:
        print(f"warning: reflectance at or above 1 lowered to 0.95: {sorted(lowered)}",
              file=sys.stderr)
    return objects


def tri_areas(p):
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def write_ply(path, p):
    """Binary PLY of the triangles p (m×3×3), unshared corners, the winding kept."""
    m = len(p)
    v = p.reshape(-1, 3).astype("<f4")
    faces = np.zeros(m, dtype=[("n", "u1"), ("i", "<i4", (3,))])
    faces["n"] = 3
    faces["i"] = np.arange(3 * m, dtype="<i4").reshape(m, 3)
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {3 * m}\n"
            "property float x\nproperty float y\nproperty float z\n"
            f"element face {m}\nproperty list uchar int vertex_indices\nend_header\n")
    with open(path, "wb") as f:
        f.write(head.encode("ascii"))
        f.write(v.tobytes())
        f.write(faces.tobytes())


# ---------------------------------------------------------------- lights


def load_lights(path):
    try:
        doc = json.load(open(path))
    except OSError as e:
        fail(f"{path}: {e.strerror}")
    except json.JSONDecodeError as e:
        fail(f"{path}: not JSON: {e}")
    if not isinstance(doc, dict) or not isinstance(doc.get("lights"), list):
        fail(f'{path}: expected {{"lights": [...]}}')
    suns, skies = [], []

    def vec(light, i, key, nonneg):
        v = light.get(key)
        if (not isinstance(v, list) or len(v) != 3
                or not all(isinstance(x, (int, float)) and math.isfinite(x) for x in v)):
            fail(f"{path}: light {i}: {key!r} must be three finite numbers")
        if nonneg and min(v) < 0:
            fail(f"{path}: light {i}: {key!r} must not be negative")
        return [float(x) for x in v]

    for i, light in enumerate(doc["lights"]):
        kind = light.get("type") if isinstance(light, dict) else None
        if kind == "directional":
            extra = set(light) - {"type", "direction", "irradiance"}
            if extra:
                fail(f"{path}: light {i}: unknown field(s) {sorted(extra)}")
            d = np.array(vec(light, i, "direction", False))
            if not np.linalg.norm(d) > 0:
                fail(f"{path}: light {i}: direction has zero length")
            suns.append((d / np.linalg.norm(d), vec(light, i, "irradiance", True)))
        elif kind == "sky":
            extra = set(light) - {"type", "radiance"}
            if extra:
                fail(f"{path}: light {i}: unknown field(s) {sorted(extra)}")
            skies.append(vec(light, i, "radiance", True))
        else:
            fail(f"{path}: light {i}: type {kind!r} is not supported here "
                 "(only 'directional' and 'sky')")
    return suns, skies


# ---------------------------------------------------------------- Mitsuba


def build_scene(mi, objects, suns, skies, spp, tmp, max_depth):
    d = {"type": "scene", "integrator": {"type": "path", "max_depth": max_depth}}
    for k, (dirn, e) in enumerate(suns):
        d[f"sun{k}"] = {"type": "directional", "direction": dirn.tolist(),
                        "irradiance": {"type": "rgb", "value": e}}
    if skies:
        d["sky"] = {"type": "constant",
                    "radiance": {"type": "rgb", "value": np.sum(skies, axis=0).tolist()}}
    ids = []
    for oi, (_, parts) in enumerate(objects):
        for pi, part in enumerate(parts):
            key = f"o{oi}_p{pi}"
            ply = os.path.join(tmp, key + ".ply")
            write_ply(ply, part["p"])
            shape = {
                "type": "ply", "filename": ply, "face_normals": True,
                "bsdf": {"type": "diffuse",
                         "reflectance": {"type": "rgb", "value": part["rho"]}},
                "sensor": {
                    "type": "irradiancemeter", "id": f"meter_{key}",  # unique: not merged
                    "film": {"type": "hdrfilm", "width": 1, "height": 1,
                             "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                    "sampler": {"type": "independent", "sample_count": spp},
                },
            }
            if max(part["ke"]) > 0:
                shape["emitter"] = {"type": "area",
                                    "radiance": {"type": "rgb", "value": part["ke"]}}
            d[key] = shape
            ids.append((key, oi, pi))
    # optimize=False: the parser would merge the identical meters (and like shapes) into one.
    try:
        return mi.load_dict(d, optimize=False), ids
    except RuntimeError as e:
        fail(f"Mitsuba could not load the scene: {str(e).splitlines()[0]}")


def sample_surface(rng, p, n):
    """n points uniform by area on the triangles p, and their unit front normals."""
    a = tri_areas(p)
    t = rng.choice(len(p), size=n, p=a / a.sum())
    u, v = rng.random(n), rng.random(n)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    q = p[t]
    x = q[:, 0] + u[:, None] * (q[:, 1] - q[:, 0]) + v[:, None] * (q[:, 2] - q[:, 0])
    nrm = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    return x, nrm


def direct_sun(mi, scene, rng, p, suns, n):
    """Per-sample direct irradiance (n×3) of the directional lights on the triangles p."""
    x, nrm = sample_surface(rng, p, n)
    out = np.zeros((n, 3))
    eps = float(mi.math.RayEpsilon)
    for dirn, e in suns:
        to_sun = -dirn
        cos = nrm @ to_sun
        lit = cos > 0
        if not lit.any():
            continue
        # Mitsuba's spawn_ray offset: (1 + max|p|)·RayEpsilon along the front normal.
        mag = (1 + np.abs(x[lit]).max(axis=1)) * eps
        o = x[lit] + nrm[lit] * mag[:, None]
        d = mi.Vector3f(*to_sun)
        blocked = np.array([bool(scene.ray_test(mi.Ray3f(mi.Point3f(*oo), d))) for oo in o])
        w = np.zeros(n)
        w[np.flatnonzero(lit)[~blocked]] = cos[lit][~blocked]
        out += w[:, None] * np.array(e)[None, :]
    return out


def reference(mi, scene_path, lights_path, spp, batches, seed, max_depth):
    """The per-object JSON document (see the module's docstring)."""
    t0 = time.time()
    suns, skies = load_lights(lights_path)
    objects = load_scene(scene_path)
    per_batch = spp // batches
    with tempfile.TemporaryDirectory() as tmp:
        scene, ids = build_scene(mi, objects, suns, skies, per_batch, tmp, max_depth)
    t_load = time.time() - t0

    sensors = {s.id(): i for i, s in enumerate(scene.sensors())}
    rng = np.random.default_rng(seed)
    parts = {}  # (object, part) -> (mean, stderr) of meter + direct
    t1 = time.time()
    for n, (key, oi, pi) in enumerate(ids):
        si = sensors[f"meter_{key}"]
        batch = []
        for b in range(batches):
            # The film sums its samples in f32: a render of 2^16 samples of a constant reads
            # 0.03% low, of 2^12 samples 3e-6. So at most 4096 a render, summed here in f64.
            acc, done = np.zeros(3), 0
            while done < per_batch:
                k = min(RENDER_SPP, per_batch - done)
                img = mi.render(scene, sensor=si, spp=k,
                                seed=(seed * 1_000_003 + b * 65_537 + done // RENDER_SPP)
                                & 0x7FFFFFFF)
                acc += k * np.array(img, dtype=np.float64).reshape(-1)[:3]
                done += k
            batch.append(acc / per_batch)
        batch = np.array(batch)
        m_mean = batch.mean(axis=0)
        m_se = batch.std(axis=0, ddof=1) / math.sqrt(batches)
        d_mean, d_se = np.zeros(3), np.zeros(3)
        if suns:
            dsun = direct_sun(mi, scene, rng, objects[oi][1][pi]["p"], suns, spp)
            d_mean = dsun.mean(axis=0)
            d_se = dsun.std(axis=0, ddof=1) / math.sqrt(spp)
        parts[(oi, pi)] = (m_mean + d_mean, np.sqrt(m_se ** 2 + d_se ** 2))
        if (n + 1) % 10 == 0 or n + 1 == len(ids):
            print(f"mitsuba: {n + 1}/{len(ids)} shapes, {time.time() - t1:.0f} s",
                  file=sys.stderr)
    t_run = time.time() - t1

    out = []
    for oi, (name, prts) in enumerate(objects):
        areas = np.array([tri_areas(p["p"]).sum() for p in prts])
        total = areas.sum()
        w = areas / total
        h = sum(w[k] * parts[(oi, k)][0] for k in range(len(prts)))
        se = np.sqrt(sum((w[k] * parts[(oi, k)][1]) ** 2 for k in range(len(prts))))
        b = sum(w[k] * (math.pi * np.array(prts[k]["ke"]) + np.array(prts[k]["rho"])
                        * parts[(oi, k)][0]) for k in range(len(prts)))
        out.append({"name": name, "area": float(total),
                    "irradiance": [float(v) for v in h], "stderr": [float(v) for v in se],
                    "radiosity": [float(v) for v in b]})
    return {
        "samples_per_object": spp,
        "batches": batches,
        "seed": seed,
        "reference": f"mitsuba {mi.__version__} {VARIANT}, path integrator max_depth "
                     f"{max_depth}, irradiancemeter per object + direct sun",
        "lights": {"directional": len(suns), "sky": len(skies)},
        "objects": out,
        "timings_s": {"load": round(t_load, 2), "objects": round(t_run, 2)},
    }


def write_obj(path, objects):
    """objects: [(name, [quad corners, counter-clockwise from the front])], all Kd 0 (black)."""
    with open(path, "w") as f:
        f.write("mtllib black.mtl\n")
        k = 1
        for name, quads in objects:
            f.write(f"o {name}\nusemtl black\n")
            for q in quads:
                for p in q:
                    f.write("v %r %r %r\n" % tuple(float(c) for c in p))
                f.write(f"f {k} {k + 1} {k + 2}\nf {k} {k + 2} {k + 3}\n")
                k += 4
    with open(os.path.join(os.path.dirname(path), "black.mtl"), "w") as f:
        f.write("newmtl black\nKd 0 0 0\n")


def check(mi):
    """The conventions on scenes with a known answer: black open unit quads (up, tilted 60°,
    vertical, down) far apart, and a quad tilted 60° 1 m over a black ground 4 km wide; under a
    uniform sky of radiance 1 alone, and under a sun alone (direction (0.3, −0.8, 0.2), irradiance
    (1, 2, 3)). Prints each figure against its closed form; exit status 1 if one is off by more
    than four standard errors plus 0.1% (0.2% for the tilted quads, whose meter rays, offset
    along the ray in f32, meet their own surface a little: −0.04% at the origin, −0.3% 200 m
    out)."""
    def rotz(deg):
        c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
        return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])

    unit = np.array([(-.5, 0, -.5), (-.5, 0, .5), (.5, 0, .5), (.5, 0, -.5)])  # faces +y
    tilts = {"up": 0, "tilt60": -60, "vertical": -90, "down": 180}
    open_quads = [(n, [unit @ rotz(t).T + [40 * i, i, 0]]) for i, (n, t) in enumerate(tilts.items())]
    ground = [("ground", [4000 * unit]),
                             ("tilt60_over_ground", [unit @ rotz(-60).T + [0, 1, 0]])]
    sun_d = np.array([0.3, -0.8, 0.2]) / np.linalg.norm([0.3, -0.8, 0.2])
    normal = {n: np.array([0, 1, 0]) @ rotz(t).T for n, t in tilts.items()}
    cos = {n: max(0.0, float(-sun_d @ normal[n])) for n in tilts}
    pi = math.pi
    cases = [
        ("open quads, sky", open_quads, {"type": "sky", "radiance": [1, 1, 1]},
         {n: [pi] * 3 for n in tilts}),
        ("open quads, sun", open_quads,
         {"type": "directional", "direction": [0.3, -0.8, 0.2], "irradiance": [1, 2, 3]},
         {n: [cos[n] * e for e in (1, 2, 3)] for n in tilts}),
        ("over a ground, sky", ground, {"type": "sky", "radiance": [1, 1, 1]},
         {"ground": [pi] * 3, "tilt60_over_ground": [pi * (1 + 0.5) / 2] * 3}),
    ]
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        for title, objs, light, want in cases:
            write_obj(os.path.join(tmp, "s.obj"), objs)
            with open(os.path.join(tmp, "l.json"), "w") as f:
                json.dump({"lights": [light]}, f)
            doc = reference(mi, os.path.join(tmp, "s.obj"), os.path.join(tmp, "l.json"),
                            1 << 16, 8, 1, -1)
            print(title)
            for o in doc["objects"]:
                w, h, se = want[o["name"]], o["irradiance"], o["stderr"]
                tol = 0.002 if "tilt" in o["name"] else 0.001
                ok = all(abs(x - y) <= 4 * e + tol * max(y, 1e-9) + 1e-6
                         for x, y, e in zip(h, w, se))
                bad += not ok
                print(f"  {o['name']:<20} {' '.join(f'{x:8.4f}' for x in h)}   closed form "
                      f"{' '.join(f'{y:8.4f}' for y in w)}   {'ok' if ok else 'OFF'}")
    print("all as the closed forms" if not bad else f"{bad} figure(s) off")
    return bad == 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene", nargs="?", help="OBJ file (+ its MTL)")
    ap.add_argument("lights", nargs="?", help="lights file (directional and sky only)")
    ap.add_argument("--spp", type=int, default=16384,
                    help="meter samples per object, over all batches, and as many direct-sun "
                         "points (default 16384)")
    ap.add_argument("--batches", type=int, default=8,
                    help="independent meter batches, for the standard error (default 8)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--max-depth", type=int, default=-1,
                    help="the path integrator's max_depth (default -1: no limit, Russian roulette)")
    ap.add_argument("--json", metavar="OUT", help="write the JSON here instead of stdout")
    ap.add_argument("--check", action="store_true",
                    help="only check the conventions on scenes with a closed form, and exit")
    a = ap.parse_args()
    if not a.check and (a.scene is None or a.lights is None):
        fail("give SCENE.obj and LIGHTS.json, or --check (see --help)")
    if a.spp < 2 or a.batches < 2 or a.spp % a.batches:
        fail("--spp must be a multiple of --batches, and both at least 2")
    if a.json:
        folder = os.path.dirname(os.path.abspath(a.json))
        if not os.path.isdir(folder):
            fail(f"{a.json}: folder does not exist")
    if not a.check:
        if not os.path.isfile(a.scene):
            fail(f"{a.scene}: no such file")
        if a.scene.lower().endswith((".gltf", ".glb")):
            fail(f"{a.scene}: only OBJ scenes are read here")
    try:
        import mitsuba as mi
    except ImportError:
        fail("Mitsuba 3 is not installed (pip install mitsuba)")
    try:
        mi.set_variant(VARIANT)
    except Exception as e:  # noqa: BLE001
        fail(f"Mitsuba variant {VARIANT} is not available here: {e}")
    if a.check:
        sys.exit(0 if check(mi) else 1)

    doc = reference(mi, a.scene, a.lights, a.spp, a.batches, a.seed, a.max_depth)
    text = json.dumps(doc, indent=1)
    if a.json:
        with open(a.json, "w") as f:
            f.write(text + "\n")
    else:
        print(text)
    t = doc["timings_s"]
    print(f"mitsuba: {len(doc['objects'])} objects, {a.spp} samples each, "
          f"{t['load'] + t['objects']:.0f} s", file=sys.stderr)


if __name__ == "__main__":
    main()
