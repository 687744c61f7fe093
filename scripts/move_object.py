#!/usr/bin/env python3
"""Moves objects of an OBJ file, as an editor would: the edit a rebake (`radiosity bake
--plan PLAN --reuse OLD.rad`) is measured on.

    python3 scripts/move_object.py IN.obj OUT.obj NAME DX DY DZ [NAME DX DY DZ ...]

Every vertex listed under `o NAME` (up to the next `o`) is shifted by (DX, DY, DZ); a NAME
ending in `*` moves every object whose name starts with the rest (`b_2_1_0*` moves a building
and its tower). The MTL file the OBJ names is copied beside OUT.obj. The vertices must belong
to the objects they follow (as `scripts/city.py` writes them): a vertex shared with an object
that does not move is refused.
"""

import shutil
import sys
from pathlib import Path


def main(argv):
    if len(argv) < 7 or (len(argv) - 3) % 4:
        print("usage: move_object.py IN.obj OUT.obj NAME DX DY DZ [NAME DX DY DZ ...]", file=sys.stderr)
        return 2
    src, dst = Path(argv[1]), Path(argv[2])
    moves = []
    for k in range(3, len(argv), 4):
        try:
            offset = tuple(float(v) for v in argv[k + 1 : k + 4])
        except ValueError:
            print(f"error: offsets must be numbers, not {argv[k + 1 : k + 4]}", file=sys.stderr)
            return 2
        moves.append((argv[k], offset))

    def offset_of(name):
        for pattern, offset in moves:
            if name == pattern or (pattern.endswith("*") and name.startswith(pattern[:-1])):
                return offset
        return None

    lines = src.read_text().splitlines()
    owner = []  # offset of the object each vertex was listed under (None: stays)
    current = None
    moved_objects = set()
    out = []
    for line in lines:
        if line.startswith("o "):
            name = line[2:].strip()
            current = offset_of(name)
            if current is not None:
                moved_objects.add(name)
        if line.startswith("v "):
            owner.append(current)
            if current is not None:
                x, y, z = (float(v) for v in line.split()[1:4])
                line = f"v {x + current[0]:.4f} {y + current[1]:.4f} {z + current[2]:.4f}"
        if line.startswith("f ") and current is None:
            for ref in line.split()[1:]:
                v = int(ref.split("/")[0])
                v = v - 1 if v > 0 else len(owner) + v
                if owner[v] is not None:
                    print(f"error: a face of an unmoved object uses vertex {v + 1} of a moved one", file=sys.stderr)
                    return 1
        out.append(line)
    missing = [p for p, _ in moves if not any(offset_of(o) is not None for o in moved_objects)]
    if not moved_objects or missing:
        print(f"error: no object named {[p for p, _ in moves]} in {src}", file=sys.stderr)
        return 1
    dst.parent.mkdir(parents=True, exist_ok=True)
    dst.write_text("\n".join(out) + "\n")
    for line in lines:
        if line.startswith("mtllib "):
            mtl = src.parent / line.split(maxsplit=1)[1].strip()
            if mtl.exists() and mtl.resolve() != (dst.parent / mtl.name).resolve():
                shutil.copy(mtl, dst.parent / mtl.name)
    print(f"moved {len(moved_objects)} object(s): {', '.join(sorted(moved_objects))}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
