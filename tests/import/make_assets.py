#!/usr/bin/env python3
"""Writes the small binary assets of the import test scenes (run once; the outputs are committed):
mitsuba/grad.png (16x16 RGB, red rising to the right, green rising downwards: any mirrored u or v
shows), mitsuba/mask.png (16x16 binary L-shaped cut-out), mitsuba/quad_uv.ply (a textured unit
quad, binary little-endian) and mitsuba/pyramid.serialized (Mitsuba's serialized format, v4).
Standard library only."""
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))


def png(path, w, h, pixel):
    raw = b"".join(b"\0" + bytes(c for x in range(w) for c in pixel(x, y)) for y in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def main():
    d = os.path.join(HERE, "mitsuba")
    png(os.path.join(d, "grad.png"), 16, 16, lambda x, y: (40 + 13 * x, 40 + 13 * y, 90))
    png(os.path.join(d, "mask.png"), 16, 16,
        lambda x, y: (255,) * 3 if (x < 6 or y >= 10) else (0,) * 3)
    # A unit quad in the xy plane facing +z, uv (0,0) at (-1,-1) as Mitsuba's rectangle.
    verts = [(-1, -1, 0, 0, 0), (1, -1, 0, 1, 0), (1, 1, 0, 1, 1), (-1, 1, 0, 0, 1)]
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
            "property float y\nproperty float z\nproperty float u\nproperty float v\n"
            "element face 2\nproperty list uchar int vertex_indices\nend_header\n").encode()
    body = b"".join(struct.pack("<5f", *v) for v in verts)
    body += struct.pack("<B3i", 3, 0, 1, 2) + struct.pack("<B3i", 3, 0, 2, 3)
    with open(os.path.join(d, "quad_uv.ply"), "wb") as f:
        f.write(head + body)
    # A square pyramid (apex +y), flat-shaded, with uvs.
    pos = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1), (0, 1.5, 0)]
    uvs = [(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0.5)]
    tris = [(0, 1, 2), (0, 2, 3), (0, 4, 1), (1, 4, 2), (2, 4, 3), (3, 4, 0)]
    flags = 0x0002 | 0x0010 | 0x1000  # texcoords, face normals, single precision
    data = struct.pack("<I", flags) + b"pyramid\0" + struct.pack("<QQ", len(pos), len(tris))
    data += b"".join(struct.pack("<3f", *p) for p in pos)
    data += b"".join(struct.pack("<2f", *t) for t in uvs)
    data += b"".join(struct.pack("<3I", *t) for t in tris)
    blob = struct.pack("<HH", 0x041C, 4) + zlib.compress(data)
    blob += struct.pack("<Q", 0) + struct.pack("<I", 1)
    with open(os.path.join(d, "pyramid.serialized"), "wb") as f:
        f.write(blob)


if __name__ == "__main__":
    main()
