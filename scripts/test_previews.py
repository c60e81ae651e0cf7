#!/usr/bin/env python3
"""Every part and assembly of a build has a preview: a PNG of the stated size that shows something
(not one flat colour). Reads the build folder given as the first argument (default out.test)."""
import json
import struct
import sys
import zlib
from pathlib import Path

WIDTH, HEIGHT = 960, 480


def read_png(path):
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat = 8, b""
    w = h = None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h = struct.unpack(">II", body[:8])
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    return w, h, zlib.decompress(idat)


def main(root):
    root = Path(root)
    man = json.loads((root / "manifest.json").read_text())
    names = list(man["parts"]) + [Path(r["assembly"]).stem for r in man.get("rigs", {}).values()]
    names += [Path(m["assembly"]).stem for m in man.get("molds", {}).values() if "assembly" in m]
    failed = 0
    for name in names:
        p = root / f"{name}.png"
        try:
            w, h, raw = read_png(p)
            assert (w, h) == (WIDTH, HEIGHT), f"size {w}x{h}"
            distinct = len(set(raw[i:i + 3] for i in range(1, len(raw) - 3, 997)))
            assert distinct > 5, f"only {distinct} colours sampled: empty image"
            print(f"ok   {p.name} {w}x{h}, {distinct} colours sampled")
        except Exception as e:  # noqa: BLE001 - every failure is reported with its file
            failed += 1
            print(f"FAIL {p}: {e}")
    print(f"{len(names) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "out.test"))
