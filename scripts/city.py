#!/usr/bin/env python3
"""A sunlit city of box buildings on a ground of tiles, with its lights files.

    scripts/city.py OUT_DIR [BLOCKS]

Writes OUT_DIR/city.obj, city.mtl, sun.json (one directional light, 1000 W/m² on a surface
facing it, 35° above the horizon) and sun_sky.json (the same sun and a uniform sky of 30
W/(m²·sr)). The ground is a BLOCKS × BLOCKS grid of 40 m tiles (default 12: 480 m), each tile
its own object of two triangles, so that a tile's mean irradiance depends on where the
buildings' shadows fall across it. On each tile stand two to four buildings (boxes of 8–16 m
side, 6–40 m tall, on the tile's inner 32 m: streets between tiles), the taller ones with a
setback tower on top; every building and tower its own object, of one of eight coloured
materials. With the default 12 blocks: 709 objects. Only the Python standard library; the
layout comes from a fixed seed.
"""

import random
import sys
from pathlib import Path

TILE = 40.0  # side of a ground tile, metres
STREET = 4.0  # free margin inside each tile's edge


def box(lo, hi):
    """The six faces of an axis-aligned box as quads, counter-clockwise seen from outside."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    return [
        [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)],  # -x
        [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)],  # +x
        [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],  # -y
        [(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)],  # +y
        [(x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0)],  # -z
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],  # +z
    ]


def overlaps(a, b, gap):
    """Whether two footprints (x0, z0, x1, z1) come closer than `gap`."""
    return not (a[2] + gap <= b[0] or b[2] + gap <= a[0] or a[3] + gap <= b[1] or b[3] + gap <= a[1])


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    out = Path(sys.argv[1])
    blocks = int(sys.argv[2]) if len(sys.argv) == 3 else 12
    if blocks < 1:
        sys.exit("BLOCKS must be at least 1")
    out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(20261206)
    colours = [
        (0.62, 0.58, 0.52), (0.72, 0.45, 0.35), (0.45, 0.50, 0.58), (0.80, 0.78, 0.70),
        (0.55, 0.62, 0.48), (0.68, 0.66, 0.72), (0.40, 0.38, 0.36), (0.75, 0.60, 0.42),
    ]
    objects = []  # (name, material, quads)
    half = blocks * TILE / 2.0
    for i in range(blocks):
        for j in range(blocks):
            x0, z0 = -half + i * TILE, -half + j * TILE
            objects.append(
                (f"tile_{i}_{j}", "ground", [[(x0, 0, z0), (x0, 0, z0 + TILE), (x0 + TILE, 0, z0 + TILE), (x0 + TILE, 0, z0)]])
            )
            placed = []
            for k in range(rng.randint(2, 4)):
                for _ in range(40):
                    w, d = rng.uniform(8, 16), rng.uniform(8, 16)
                    bx = rng.uniform(x0 + STREET, x0 + TILE - STREET - w)
                    bz = rng.uniform(z0 + STREET, z0 + TILE - STREET - d)
                    fp = (bx, bz, bx + w, bz + d)
                    if not any(overlaps(fp, p, 2.0) for p in placed):
                        break
                else:
                    continue
                placed.append(fp)
                h = rng.uniform(6, 40)
                mat = f"wall{rng.randrange(len(colours))}"
                name = f"b_{i}_{j}_{k}"
                objects.append((name, mat, box((bx, 0, bz), (bx + w, h, bz + d))))
                if h > 18:
                    s = rng.uniform(0.2, 0.35)
                    th = rng.uniform(6, 20)
                    lo = (bx + s * w, h, bz + s * d)
                    hi = (bx + (1 - s) * w, h + th, bz + (1 - s) * d)
                    objects.append((f"{name}_tower", mat, box(lo, hi)))
    lines = ["mtllib city.mtl"]
    verts = 0
    for name, mat, quads in objects:
        lines += [f"o {name}", f"usemtl {mat}"]
        for q in quads:
            for v in q:
                lines.append("v %.4f %.4f %.4f" % v)
            lines.append(f"f {verts + 1} {verts + 2} {verts + 3} {verts + 4}")
            verts += 4
    (out / "city.obj").write_text("\n".join(lines) + "\n")
    mtl = ["newmtl ground", "Kd 0.35 0.34 0.32"]
    for k, c in enumerate(colours):
        mtl += [f"newmtl wall{k}", "Kd %.2f %.2f %.2f" % c]
    (out / "city.mtl").write_text("\n".join(mtl) + "\n")
    # A sun 35° above the horizon, from the south-west.
    import math

    el, az = math.radians(35), math.radians(220)
    d = (-math.cos(el) * math.sin(az), -math.sin(el), -math.cos(el) * math.cos(az))
    sun = '{"type": "directional", "direction": [%.6f, %.6f, %.6f], "irradiance": [1000, 1000, 1000]}' % d
    (out / "sun.json").write_text('{"lights": [%s]}\n' % sun)
    sky = '{"type": "sky", "radiance": [30, 30, 30]}'
    (out / "sun_sky.json").write_text('{"lights": [%s, %s]}\n' % (sun, sky))
    print(f"{len(objects)} objects, {verts // 4} quads in {out}/city.obj")


if __name__ == "__main__":
    main()
