#!/usr/bin/env python3
"""Prints the CRC-32 of every section of .rad files (the container layout is the module doc of
radiosity-core/src/container/mod.rs), to compare two bakes section by section. The REPORT
section holds timings, so it is left out of the verdict.

    scripts/rad_crc.py A.rad [B.rad]
"""
import struct
import sys
import zlib

NAMES = {
    1: "META", 2: "PATCHES", 3: "ORDER", 4: "SCALES", 5: "BLOCKS", 6: "SPARSE_ROWS",
    7: "SPARSE_COLS", 8: "SPARSE_VALUES", 9: "OBJECTS", 10: "REPORT", 11: "MESH",
    12: "CORRECTION_ROWS", 13: "CORRECTION_COLS", 14: "CORRECTION_EXPONENTS",
    15: "CORRECTION_CODES",
}


def sections(path):
    data = open(path, "rb").read()
    magic, _version, count, _length, _crc, _ = struct.unpack_from("<8sIIQII", data, 0)
    if magic != b"\x89RAD\r\n\x1a\n":
        sys.exit(f"error: {path}: not a .rad file")
    out = {}
    for k in range(count):
        kind, _, offset, length, _stored, _ = struct.unpack_from("<IIQQII", data, 32 + 32 * k)
        out[NAMES.get(kind, str(kind))] = (length, zlib.crc32(data[offset:offset + length]))
    return out


def main():
    files = [sections(p) for p in sys.argv[1:]]
    names = sorted({n for f in files for n in f}, key=lambda n: list(NAMES.values()).index(n)
                   if n in NAMES.values() else 99)
    same = True
    for name in names:
        cells = [f"{f[name][0]:>10} {f[name][1]:08x}" if name in f else f"{'-':>19}" for f in files]
        differ = len({f.get(name) for f in files}) > 1
        if differ and name != "REPORT":
            same = False
        print(f"{name:<22} " + "  ".join(cells) + ("  differs" if differ else ""))
    if len(files) > 1:
        print("same bits (REPORT aside)" if same else "DIFFERENT")
        sys.exit(0 if same else 1)


main()
