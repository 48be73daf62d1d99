#!/usr/bin/env python3
"""Smoke test of the Mitsuba reference translator (a few seconds, scalar_rgb).

Checks numerically: image orientation (+X right, +Y up), the environment-map convention
(exact per-direction agreement with candela's lookup, and a rendered patch), quad/box/transform
placement, inline-triangle uvs, the anisotropy mapping, a 16×16 4 spp render of a scene using every
translatable feature, and that untranslatable features exit with code 2. Ends with
"N passed, M failed"; exit code 1 if any failed.
"""
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

mi.set_variant("scalar_rgb")
from ref_common import Untranslatable  # noqa: E402
from ref_materials import Textures, translate_material  # noqa: E402
from ref_scene import build_scene  # noqa: E402
from ref_shapes import Shapes, object_transform  # noqa: E402

CHECKS = []
TMP = tempfile.mkdtemp(prefix="candela_mi_selftest_")


def check(fn):
    CHECKS.append(fn)
    return fn


def write_image(name, w, h, pixel, fmt="exr"):
    """pixel(x, y) -> (r, g, b) linear; PNGs are stored sRGB 8-bit."""
    vals = [c for y in range(h) for x in range(w) for c in pixel(x, y)]
    bmp = mi.Bitmap(dr.scalar.TensorXf(vals, (h, w, 3)))
    if fmt == "png":
        bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, True)
    path = os.path.join(TMP, name)
    bmp.write(path)
    return name


def pixels(img):
    """TensorXf / Bitmap (H, W, 3) -> (H, W, getter(x, y) -> (r, g, b))."""
    t = dr.scalar.TensorXf(img)
    h, w, _ = t.shape
    a = t.array
    return h, w, lambda x, y: tuple(a[(y * w + x) * 3 + c] for c in range(3))


def render(scene, spp=4, **opts):
    o = {"spp": spp, "seed": 0, "max_depth": None, "rr_depth": None, "width": None,
         "height": None, "env_resample": True}
    o.update(opts)
    d, settings = build_scene(scene, TMP, TMP, o)
    return mi.render(mi.load_dict(d), spp=spp), settings


def centroid(img, channel):
    h, w, px = pixels(img)
    pts = [(x + 0.5, y + 0.5) for y in range(h) for x in range(w) if px(x, y)[channel] > 0.5]
    assert pts, "feature not visible"
    return sum(p[0] for p in pts) / len(pts) / w, sum(p[1] for p in pts) / len(pts) / h


CAM = {"version": 1, "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_y": 40},
       "film": {"width": 16, "height": 16},
       "materials": {"red": {"type": "diffuse", "reflectance": 0, "emission": [1, 0, 0]},
                     "green": {"type": "diffuse", "reflectance": 0, "emission": [0, 1, 0]}},
       "objects": [{"type": "sphere", "center": [1, 0, 0], "radius": 0.3, "material": "red"},
                   {"type": "sphere", "center": [0, 1, 0], "radius": 0.3, "material": "green"}]}


@check
def camera_orientation_via_cli():
    scene, out = os.path.join(TMP, "cam.json"), os.path.join(TMP, "cam.exr")
    with open(scene, "w") as f:
        json.dump(CAM, f)
    r = subprocess.run([sys.executable, os.path.join(HERE, "render_reference.py"), scene, out,
                        "--spp", "4"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout.strip().splitlines()[-1])
    assert info["spp"] == 4 and "render_time_s" in info, info
    bmp = mi.Bitmap(out)
    assert bmp.pixel_format() == mi.Bitmap.PixelFormat.RGB, bmp.pixel_format()
    assert bmp.component_format() == mi.Struct.Type.Float32 and bmp.width() == 16
    rx, ry = centroid(bmp, 0)
    gx, gy = centroid(bmp, 1)
    assert rx > 0.6 and abs(ry - 0.5) < 0.1, ("+X sphere should be right of centre", rx, ry)
    assert gy < 0.4 and abs(gx - 0.5) < 0.1, ("+Y sphere should be above centre", gx, gy)


def candela_dir(u, v, rot_deg):
    """Inverse of candela's lookup: map (u, v) -> world direction, after rotate_y."""
    th, ph = v * math.pi, (u - 0.5) * 2 * math.pi
    d = [math.sin(th) * math.sin(ph), math.cos(th), -math.sin(th) * math.cos(ph)]
    a = math.radians(rot_deg)  # world = R_y(a)·d
    return [d[0] * math.cos(a) + d[2] * math.sin(a), d[1], -d[0] * math.sin(a) + d[2] * math.cos(a)]


def candela_lookup(px, w, h, d, rot_deg):
    """candela's convention: d' = R_y(-rot)·d, u = 0.5 + atan2(x, -z)/2π, v = acos(y)/π;
    bilinear at column u·W - 0.5 (wrap), row v·H - 0.5 (clamp)."""
    a = math.radians(-rot_deg)
    c, s = math.cos(a), math.sin(a)
    x, y, z = d[0] * c + d[2] * s, d[1], -d[0] * s + d[2] * c
    u = 0.5 + math.atan2(x, -z) / (2 * math.pi)
    v = math.acos(max(-1.0, min(1.0, y))) / math.pi
    cx, cy = u * w - 0.5, min(max(v * h - 0.5, 0.0), h - 1.0)
    x0, y0 = math.floor(cx), min(math.floor(cy), h - 2)
    fx, fy = cx - x0, cy - y0
    out = [0.0, 0.0, 0.0]
    for (xx, yy, wt) in ((x0, y0, (1 - fx) * (1 - fy)), (x0 + 1, y0, fx * (1 - fy)),
                         (x0, y0 + 1, (1 - fx) * fy), (x0 + 1, y0 + 1, fx * fy)):
        p = px(xx % w, yy)
        out = [o + wt * c for o, c in zip(out, p)]
    return out


@check
def envmap_matches_candela_convention_exactly():
    w, h = 16, 8
    val = lambda x, y: (x + 1.0, y + 1.0, ((x * 7 + y * 3) % 5) + 0.5)  # noqa: E731
    name = write_image("env_grid.exr", w, h, val)
    px = lambda x, y: val(x, y)  # noqa: E731
    for rot in (0.0, 90.0, -37.5):
        scene = {"camera": CAM["camera"], "objects": [],
                 "environment": {"type": "map", "file": name, "rotate_y": rot}}
        d, _ = build_scene(scene, TMP, TMP, {"spp": 1, "env_resample": True})
        emitter = mi.load_dict(d).emitters()[0]
        si = dr.zeros(mi.SurfaceInteraction3f)
        worst = 0.0
        for i in range(300):  # deterministic spread of directions, poles included
            u, v = (i * 0.6180339887) % 1.0, (i + 0.5) / 300 if i > 1 else float(i)
            dd = candela_dir(u, v, rot)
            si.wi = -mi.Vector3f(dd)
            got = emitter.eval(si)
            want = candela_lookup(px, w, h, dd, rot)
            worst = max(worst, max(abs(got[c] - want[c]) for c in range(3)))
        assert worst < 2e-3, (rot, worst)


@check
def envmap_rendered_patch_lands_where_convention_says():
    w, h = 32, 16  # red patch at texel (24, 4), green at the centre column/row (looks down -Z)
    centre = ((15, 7), (16, 7), (15, 8), (16, 8))
    name = write_image("env_patch.exr", w, h, lambda x, y: (
        (50.0, 0, 0) if (x, y) == (24, 4) else (0, 50.0, 0) if (x, y) in centre else (0, 0, 0)))
    for rot in (0.0, 90.0):
        for (u, v, ch) in ((24.5 / w, 4.5 / h, 0), (0.5, 0.5, 1)):
            dd = candela_dir(u, v, rot)
            up = [0, 1, 0] if abs(dd[1]) < 0.9 else [1, 0, 0]
            scene = {"camera": {"position": [0, 0, 0], "look_at": dd, "up": up, "fov_y": 2},
                     "film": {"width": 8, "height": 8}, "objects": [],
                     "environment": {"type": "map", "file": name, "rotate_y": rot}}
            img, _ = render(scene)
            _, _, px = pixels(img)
            c = px(4, 4)
            assert c[ch] > 10 and c[1 - ch] < 1e-3, (rot, u, v, c)


@check
def quad_box_and_transform_placement():
    p = object_transform({"scale": 2, "rotate": {"axis": [0, 0, 1], "angle": 90},
                          "translate": [1, 0, 0]}, "t") @ mi.ScalarPoint3f(1, 0, 0)
    assert max(abs(a - b) for a, b in zip(p, (1, 2, 0))) < 1e-6, p
    p = object_transform({"matrix": [1, 0, 0, 5, 0, 1, 0, 6, 0, 0, 1, 7, 0, 0, 0, 1]}, "t") \
        @ mi.ScalarPoint3f(0, 0, 0)
    assert tuple(p) == (5, 6, 7), p
    scene = {"materials": {"m": {"type": "diffuse"}}}
    shapes = Shapes(scene, TMP, TMP, Textures(TMP))
    org, eu, ev = [1, 2, 3], [2, 0, 0], [0.5, 0, -1]  # front normal: eu × ev = (0, 2, 0) → +Y
    q = shapes.shape(0, {"type": "quad", "origin": org, "edge_u": eu, "edge_v": ev,
                         "material": "m"})
    s = mi.load_dict({"type": "scene", "q": q})
    target = [org[k] + 0.25 * eu[k] + 0.75 * ev[k] for k in range(3)]
    si = s.ray_intersect(mi.Ray3f([target[0], 5, target[2]], [0, -1, 0]))
    assert si.is_valid() and abs(si.p[1] - 2) < 1e-5, si.p
    assert abs(si.uv[0] - 0.25) < 1e-5 and abs(si.uv[1] - 0.75) < 1e-5, si.uv
    assert si.n[1] > 0.9999, si.n
    outside = [org[k] + 1.05 * eu[k] + 0.5 * ev[k] for k in range(3)]
    assert not s.ray_intersect(mi.Ray3f([outside[0], 5, outside[2]], [0, -1, 0])).is_valid()
    b = shapes.shape(1, {"type": "box", "min": [-1, 0, 2], "max": [3, 1, 2.5], "material": "m",
                         "transform": {"translate": [0, 10, 0]}}).bbox()
    assert [round(float(x), 5) for x in (*b.min, *b.max)] == [-1, 10, 2, 3, 11, 2.5], b


@check
def triangle_uvs_and_anisotropy_mapping():
    scene = {"materials": {"m": {"type": "diffuse"}}}
    shapes = Shapes(scene, TMP, TMP, Textures(TMP))
    t = shapes.shape(0, {"type": "triangles", "positions": [0, 0, 0, 1, 0, 0, 0, 1, 0],
                         "indices": [[0, 1, 2]], "uvs": [[0, 0], [1, 0], [0, 1]],
                         "normals": [0, 0, 1, 0, 0, 1, 0, 0, 1], "material": "m"})
    s = mi.load_dict({"type": "scene", "t": t})
    si = s.ray_intersect(mi.Ray3f([0.2, 0.3, 1], [0, 0, -1]))
    # candela's texel row = (1 - v)·H; Mitsuba's is v_mitsuba·H, so v_mitsuba = 1 - v
    assert abs(si.uv[0] - 0.2) < 1e-5 and abs(si.uv[1] - 0.7) < 1e-5, si.uv
    bsdf, _, _ = translate_material({"type": "conductor", "roughness": 0.5, "anisotropy": 0.5},
                                    "m", Textures(TMP))
    inner = bsdf["bsdf"]
    aspect = math.sqrt(1 - 0.9 * 0.5)
    assert bsdf["type"] == "twosided" and inner["material"] == "none", bsdf
    assert abs(inner["alpha_u"] - 0.25 / aspect) < 1e-9, inner
    assert abs(inner["alpha_v"] - 0.25 * aspect) < 1e-9, inner


@check
def derived_scalar_textures_filter_before_fn():
    # candela squares the filtered roughness; the derived alpha bitmap must follow that between
    # texel centres (a bitmap of squared texels gives 0.5 halfway between 0 and 1, not 0.25).
    name = write_image("ramp.exr", 2, 1, lambda x, y: (float(x),) * 3)
    d = Textures(TMP).scalar({"texture": name}, "m.roughness", lambda x: x * x)
    t = mi.load_dict(d)
    si = dr.zeros(mi.SurfaceInteraction3f)
    for u, want in ((0.5, 0.25), (0.375, 0.0625), (0.25, 0.0), (0.75, 1.0)):
        si.uv = [u, 0.5]
        got = t.eval_1(si)
        assert abs(got - want) < 0.01, (u, got, want)


@check
def mask_corners_follow_candelas_cut():
    # candela keeps a masked point where bilinear(red) >= 0.5, which rounds a hole's corner off;
    # the reference's nearest-filtered bitmap must follow that contour, not the texel's square.
    hole = lambda x, y: (0.0,) * 3 if (x, y) == (0, 0) else (1.0,) * 3
    name = write_image("corner.png", 2, 2, hole, "png")
    d = Textures(TMP).mask({"texture": name}, "m.alpha_mask")
    t = mi.load_dict(d)
    si = dr.zeros(mi.SurfaceInteraction3f)

    def candela_keeps(u, v):
        # candela's bilinear lookup (texel centres at half-integers, repeat), v = 0 on the top row
        # in Mitsuba's uv, so the hole (texel 0, 0) is at small u and small Mitsuba v.
        fx, fy = u * 2 - 0.5, v * 2 - 0.5
        x0, y0 = math.floor(fx), math.floor(fy)
        ax, ay = fx - x0, fy - y0
        at = lambda x, y: 0.0 if (x % 2, y % 2) == (0, 0) else 1.0
        top = at(x0, y0) * (1 - ax) + at(x0 + 1, y0) * ax
        bottom = at(x0, y0 + 1) * (1 - ax) + at(x0 + 1, y0 + 1) * ax
        return top * (1 - ay) + bottom * ay >= 0.5

    wrong, square = 0, 0
    n = 64
    for i in range(n):
        for j in range(n):
            u, v = (i + 0.5) / n, (j + 0.5) / n
            si.uv = [u, v]
            wrong += (t.eval_1(si) > 0.5) != candela_keeps(u, v)
            square += (not (u < 0.5 and v < 0.5)) != candela_keeps(u, v)
    # Only points within half a fine texel of the contour may differ (44 of 4096 when written),
    # where the texel's square (the unrefined bitmap) misses 396.
    assert wrong * 4 <= square, (wrong, square)


def feature_scene():
    write_image("checker.png", 4, 4,
                lambda x, y: (0.8, 0.2, 0.1) if (x + y) % 2 else (0.1, 0.5, 0.9), "png")
    write_image("rough.png", 4, 4, lambda x, y: ((x + 1) / 5.0,) * 3, "png")
    write_image("mask.png", 4, 4, lambda x, y: (1.0,) * 3 if x < 3 else (0.0,) * 3, "png")
    write_image("sky.exr", 16, 8, lambda x, y: (0.2 + y / 8, 0.3, 0.5 + x / 32))
    with open(os.path.join(TMP, "tri.obj"), "w") as f:
        f.write("v -1 0 -1\nv 1 0 -1\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0.5 1\nvn 0 1 0\n"
                "usemtl wood\nf 1/1/1 3/3/1 2/2/1\n")
    from ref_shapes import write_ply
    write_ply(os.path.join(TMP, "tri.ply"), [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 1, 2)],
              None, None)
    tex = {"texture": "checker.png", "srgb": True, "scale": [2, 2]}
    return {
        "version": 1,
        "camera": {"position": [0, 1.5, 6], "look_at": [0, 0.5, 0], "fov_y": 45,
                   "aperture_radius": 0.01, "focus_distance": 6},
        "film": {"width": 16, "height": 16, "filter": {"type": "gaussian", "stddev": 0.5},
                 "exposure": 0, "tonemap": "aces"},
        "materials": {
            "wood": {"type": "diffuse", "reflectance": tex},
            "mirror": {"type": "conductor"},
            "brushed": {"type": "conductor", "roughness": {"texture": "rough.png"},
                        "anisotropy": 0.6, "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.2],
                        "reflectance": 0.9},
            "glass": {"type": "dielectric", "ior": 1.5},
            "frosted": {"type": "dielectric", "ior": 1.33, "roughness": {"texture": "rough.png"},
                        "transmittance": [0.9, 1, 0.9], "reflectance": 1},
            "plastic": {"type": "principled", "base_color": tex, "metallic": 0.2,
                        "roughness": {"texture": "rough.png"}, "specular": 0.5,
                        "spec_tint": 0.1, "anisotropic": 0.3, "sheen": 0.2,
                        "sheen_tint": 0.5, "clearcoat": 0.4, "clearcoat_gloss": 0.8},
            "clear": {"type": "principled", "spec_trans": 0.8, "ior": 1.45, "roughness": 0.1},
            "leaf": {"type": "diffuse", "reflectance": [0.2, 0.6, 0.1],
                     "alpha_mask": {"texture": "mask.png", "srgb": False}, "two_sided": False},
            "lamp": {"type": "diffuse", "reflectance": 0, "emission": [4, 4, 3]},
        },
        "objects": [
            {"type": "quad", "origin": [-3, 0, 3], "edge_u": [6, 0, 0], "edge_v": [0, 0, -6],
             "material": "wood"},
            {"type": "sphere", "center": [-1.2, 0.5, 0], "radius": 0.5, "material": "glass"},
            {"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "plastic",
             "transform": {"scale": 0.5, "translate": [0, 0.5, 0]}},
            {"type": "box", "min": [0.8, 0, -0.5], "max": [1.6, 0.8, 0.3], "material": "brushed",
             "transform": {"rotate": {"axis": [0, 1, 0], "angle": 30}}},
            {"type": "triangles", "positions": [[-1, 1.2, -1], [1, 1.2, -1], [0, 2.2, -1]],
             "indices": [0, 1, 2], "uvs": [0, 0, 1, 0, 0.5, 1], "material": "leaf"},
            {"type": "mesh", "file": "tri.obj", "transform": {"translate": [0, 0.01, -2]}},
            {"type": "mesh", "file": "tri.ply", "smooth": False, "material": "frosted",
             "transform": {"matrix": [1, 0, 0, 1.5, 0, 1, 0, 1, 0, 0, 1, -1, 0, 0, 0, 1]}},
            {"type": "sphere", "center": [0, 1.2, 1.2], "radius": 0.2, "material": "clear"},
            {"type": "sphere", "center": [-1.5, 2, -1.5], "radius": 0.15, "material": "mirror"},
            {"type": "quad", "origin": [-0.5, 3, -0.5], "edge_u": [0, 0, 1], "edge_v": [1, 0, 0],
             "material": "lamp"},
        ],
        "lights": [
            {"type": "point", "position": [2, 3, 2], "intensity": [5, 5, 5]},
            {"type": "spot", "position": [-2, 3, 2], "look_at": [0, 0, 0], "intensity": 10,
             "cutoff_angle": 25},
            {"type": "directional", "direction": [-1, -2, -1], "irradiance": [1, 0.9, 0.8]},
        ],
        "environment": {"type": "map", "file": "sky.exr", "scale": 0.5, "rotate_y": 30},
        "render": {"integrator": "nee", "max_depth": 8, "spp": 64},
    }


@check
def every_feature_renders():
    img, settings = render(feature_scene(), spp=4)
    assert settings["integrator"] == "volpath" and settings["max_depth"] == 8, settings
    h, w, px = pixels(img)
    vals = [c for y in range(h) for x in range(w) for c in px(x, y)]
    assert (h, w) == (16, 16) and all(math.isfinite(v) and v >= 0 for v in vals)
    assert sum(vals) / len(vals) > 0.01, sum(vals) / len(vals)
    scene = feature_scene()
    scene["environment"] = {"type": "constant", "radiance": 0.5}
    scene["materials"]["leaf"].pop("alpha_mask")
    img, settings = render(scene, spp=4, max_depth=-1)
    assert settings["integrator"] == "path" and settings["max_depth"] == -1, settings


def expect_untranslatable(scene, what):
    try:
        render(scene, spp=1)
    except Untranslatable as e:
        assert what in str(e), (what, str(e))
        return
    raise AssertionError(f"expected Untranslatable for {what}")


@check
def white_furnace_is_one():
    scene = {"camera": CAM["camera"], "film": {"width": 16, "height": 16},
             "materials": {"white": {"type": "diffuse", "reflectance": 1}},
             "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1.5,
                          "material": "white"}],
             "environment": {"type": "constant", "radiance": 1}}
    img, _ = render(scene, spp=16, max_depth=-1)
    h, w, px = pixels(img)
    vals = [c for y in range(h) for x in range(w) for c in px(x, y)]
    mean = sum(vals) / len(vals)
    assert abs(mean - 1) < 0.02 and max(abs(px(8, 8)[c] - 1) for c in range(3)) < 0.5, mean


@check
def untranslatable_features_are_refused():
    base = feature_scene()
    cases = [
        ("materials", "wood", {"type": "phong"}, "phong"),
        ("materials", "wood", {"type": "principled", "subsurface": 0.3}, "subsurface"),
        ("materials", "wood", {"type": "diffuse", "alpha_mask": {"texture": "rough.png"}},
         "non-binary"),
        ("materials", "wood", {"type": "diffuse", "sparkle": 1}, "unknown field"),
        ("materials", "wood", {"type": "diffuse", "emission": 1,
                               "alpha_mask": {"texture": "mask.png"}}, "emission with alpha"),
        ("materials", "wood", {"type": "principled", "specular": 0.9, "ior": 1.5}, "disagree"),
    ]
    for section, key, value, what in cases:
        scene = json.loads(json.dumps(base))
        scene[section][key] = value
        expect_untranslatable(scene, what)
    scene = json.loads(json.dumps(base))
    del scene["objects"][5]["transform"]
    with open(os.path.join(TMP, "multi.obj"), "w") as f:
        f.write("v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\nusemtl b\nf 1 3 2\n")
    scene["objects"][5]["file"] = "multi.obj"
    expect_untranslatable(scene, "usemtl")
    scene = json.loads(json.dumps(base))
    scene["objects"][1]["transform"] = {"scale": [1, 2, 1]}
    expect_untranslatable(scene, "non-uniform")


@check
def cli_exit_code_2():
    scene = json.loads(json.dumps(CAM))
    scene["materials"]["red"] = {"type": "phong"}
    path = os.path.join(TMP, "phong.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    r = subprocess.run([sys.executable, os.path.join(HERE, "render_reference.py"), path,
                        os.path.join(TMP, "phong.exr")], capture_output=True, text=True)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert r.stderr.strip().count("\n") == 0 and "phong" in r.stderr, r.stderr


def main():
    passed = failed = 0
    for fn in CHECKS:
        try:
            fn()
            passed += 1
            print(f"ok   {fn.__name__}")
        except Exception:
            failed += 1
            print(f"FAIL {fn.__name__}\n{traceback.format_exc()}")
    shutil.rmtree(TMP, ignore_errors=True)
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
