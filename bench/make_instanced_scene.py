"""Writes an instanced scene of about a billion triangles (by default) into a folder: a Cornell
box whose floor holds a grid of rotated copies of one bumpy sphere of T triangles (binary PLY,
written once), each an `instance` of one definition (docs/scene-format.md). Only T triangles are
stored; the scene renders T x N. For benchmarking instancing (docs/accel.md, "Instancing")
without committing a large file.

usage: python3 bench/make_instanced_scene.py OUT_DIR [--triangles 2000000] [--instances 500]
  scaled down for lavapipe: --triangles 2000 --instances 64
"""
import argparse
import json
import math
import os
import struct
import sys


def sphere(triangles):
    """A bumpy UV sphere of about `triangles` triangles, radius about 1, centred at the origin."""
    nv = max(4, int(math.sqrt(triangles / 4)))
    nu = 2 * nv
    verts = bytearray()
    for j in range(nv + 1):
        th = math.pi * j / nv
        st, ct = math.sin(th), math.cos(th)
        for i in range(nu + 1):
            ph = 2 * math.pi * i / nu
            r = 1 + 0.04 * math.sin(9 * th) * math.sin(11 * ph)
            verts += struct.pack("<3f", r * st * math.cos(ph), r * ct, r * st * math.sin(ph))
    faces = bytearray()
    count = 0
    for j in range(nv):
        for i in range(nu):
            a0 = j * (nu + 1) + i
            b0, c0, d0 = a0 + 1, a0 + nu + 2, a0 + nu + 1
            if j != 0:
                faces += struct.pack("<B3i", 3, a0, b0, c0)
                count += 1
            if j != nv - 1:
                faces += struct.pack("<B3i", 3, a0, c0, d0)
                count += 1
    return (nv + 1) * (nu + 1), verts, count, faces


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--triangles", type=int, default=2_000_000, help="triangles of the one mesh")
    ap.add_argument("--instances", type=int, default=500, help="copies placed")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    # Step 1: the mesh, once.
    nverts, verts, nfaces, faces = sphere(a.triangles)
    with open(os.path.join(a.out, "bumpy.ply"), "wb") as f:
        f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
                 "property float z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n"
                 % (nverts, nfaces)).encode())
        f.write(verts)
        f.write(faces)
    # Step 2: the Cornell box (walls and light of scenes/cornell.json) and a grid of instances
    # on its floor, each scaled to its cell, rotated about y and tilted, some with another
    # material.
    here = os.path.dirname(os.path.abspath(__file__))
    scene = json.load(open(os.path.join(here, "..", "scenes", "cornell.json")))
    scene["objects"] = [o for o in scene["objects"] if o["type"] != "box"]
    scene["materials"]["blue"] = {"type": "diffuse", "reflectance": [0.1, 0.2, 0.6]}
    scene["definitions"] = {
        "bumpy": {"type": "mesh", "file": "bumpy.ply", "material": "white", "smooth": False}
    }
    side = math.ceil(math.sqrt(a.instances))
    cell = 1.9 / side
    for k in range(a.instances):
        i, j = k % side, k // side
        r = 0.45 * cell
        scene["objects"].append({
            "type": "instance",
            "definition": "bumpy",
            **({"material": "blue"} if k % 3 == 1 else {}),
            "transform": {
                "matrix": matrix(r, (k * 37) % 360, 15 * math.sin(k), -0.95 + cell * (i + 0.5),
                                 -1 + r * 1.05, -0.95 + cell * (j + 0.5)),
            },
        })
    path = os.path.join(a.out, "instanced.json")
    json.dump(scene, open(path, "w"))
    print(json.dumps({"mesh_triangles": nfaces, "instances": a.instances,
                      "rendered_triangles": nfaces * a.instances, "scene": path}))


def matrix(s, yaw, tilt, tx, ty, tz):
    """Row-major 4x4: translate · rotate_y(yaw) · rotate_x(tilt) · scale(s, 1.1 s, s)."""
    cy, sy = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
    cx, sx = math.cos(math.radians(tilt)), math.sin(math.radians(tilt))
    ry = [[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]]
    rx = [[1, 0, 0], [0, cx, -sx], [0, sx, cx]]
    rot = [[sum(ry[r][k] * rx[k][c] for k in range(3)) for c in range(3)] for r in range(3)]
    scale = [s, 1.1 * s, s]
    m = [[rot[r][c] * scale[c] for c in range(3)] for r in range(3)]
    return [m[0][0], m[0][1], m[0][2], tx, m[1][0], m[1][1], m[1][2], ty,
            m[2][0], m[2][1], m[2][2], tz, 0, 0, 0, 1]


if __name__ == "__main__":
    sys.exit(main())
