#!/usr/bin/env python3
"""An outdoor scene lit by the sun: a ground plane, three identical buildings in a row, a tower,
a long wall and a yard of small parts (benches, posts), with its lights file.

    scripts/town.py OUT_DIR [PARTS]

Writes OUT_DIR/town.obj, town.mtl and sun.json (one directional light, 1000 W/m² on a surface
facing it, travelling down at 50° from the horizon). PARTS (default 200) is the number of small
parts in the yard: each a closed box of its own object, so the scene tests both the bake's
accuracy where shadows fall and `--patches N` on a scene of many separate parts. Each part
stands in a cell of its own (the yard cut into PARTS cells), so parts never overlap; past about
330 they shrink to fit.

Every building is a closed box standing on the ground (its bottom face buried against it). The
ground is two triangles: the bake, not the modeller, has to place patches where the light
varies. Only the Python standard library; the parts' positions come from a fixed seed.
"""

import math
import random
import sys
from pathlib import Path

GROUND = 40.0  # half-width of the ground, metres


def box(lo, hi):
    """The six faces of an axis-aligned box as quads, counter-clockwise seen from outside."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    return [
        [(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)],  # top (+y)
        [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],  # bottom (-y)
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],  # +z
        [(x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)],  # -z
        [(x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1)],  # +x
        [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)],  # -x
    ]


def main():
    out = Path(sys.argv[1])
    parts = int(sys.argv[2]) if len(sys.argv) > 2 else 200
    out.mkdir(parents=True, exist_ok=True)
    objects = []  # (name, material, quads)
    g = GROUND
    objects.append(("ground", "asphalt", [[(-g, 0, -g), (-g, 0, g), (g, 0, g), (g, 0, -g)]]))
    for i, x in enumerate((-14.0, -2.0, 10.0)):
        objects.append((f"building{i + 1}", "plaster", box((x, 0, -12), (x + 6, 9, -4))))
    objects.append(("tower", "brick", box((-4, 0, 6), (0, 20, 10))))
    objects.append(("wall", "concrete", box((4, 0, 4), (24, 2.5, 4.6))))
    # The yard (x in [-30, 30], z in [12, 30]) is cut into one cell per part, each part a box
    # inside its cell at a random place: parts never overlap, and they shrink as they crowd.
    rng = random.Random(7)
    cols = max(1, round(math.sqrt(parts * 60.0 / 18.0)))
    rows = -(-parts // cols)
    cw, cd = 60.0 / cols, 18.0 / rows
    scale = min(1.0, cw / 1.8, cd / 1.0)
    for k in range(parts):
        w, d = rng.uniform(0.2, 1.6) * scale, rng.uniform(0.2, 0.8) * scale
        h = rng.uniform(0.3, 1.2) * max(scale, 0.3)
        x = -30.0 + (k % cols) * cw + rng.uniform(0.0, cw - w)
        z = 12.0 + (k // cols) * cd + rng.uniform(0.0, cd - d)
        objects.append((f"part{k}", "wood" if k % 2 else "steel", box((x, 0, z), (x + w, h, z + d))))

    mtl = {
        "asphalt": (0.25, 0.25, 0.25),
        "plaster": (0.7, 0.68, 0.62),
        "brick": (0.45, 0.22, 0.15),
        "concrete": (0.55, 0.55, 0.55),
        "wood": (0.5, 0.35, 0.2),
        "steel": (0.4, 0.42, 0.45),
    }
    with open(out / "town.mtl", "w") as f:
        f.write("# scripts/town.py\n")
        for name, kd in mtl.items():
            f.write(f"newmtl {name}\nKd {kd[0]} {kd[1]} {kd[2]}\n\n")
    with open(out / "town.obj", "w") as f:
        f.write(f"# scripts/town.py: {len(objects)} objects\nmtllib town.mtl\n")
        nv = 0
        for name, mat, quads in objects:
            f.write(f"o {name}\nusemtl {mat}\n")
            for q in quads:
                for p in q:
                    f.write("v {:.6f} {:.6f} {:.6f}\n".format(*p))
                f.write("f {} {} {} {}\n".format(nv + 1, nv + 2, nv + 3, nv + 4))
                nv += 4
    elevation = math.radians(50.0)
    azimuth = math.radians(30.0)
    d = (
        -math.cos(elevation) * math.sin(azimuth),
        -math.sin(elevation),
        -math.cos(elevation) * math.cos(azimuth),
    )
    with open(out / "sun.json", "w") as f:
        f.write(
            '{"lights": [{"type": "directional", "direction": [%.6f, %.6f, %.6f], '
            '"irradiance": [1000, 1000, 1000]}]}\n' % d
        )


if __name__ == "__main__":
    main()
