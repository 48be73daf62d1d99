"""Candela scene JSON (docs/scene-format.md, version 1) → Mitsuba 3 scene dict for `mi.load_dict`.

`build_scene` translates camera, film, render settings, lights and environment here; objects go
through ref_shapes.py and materials through ref_materials.py. Raises Untranslatable (exit 2) or
SceneError (exit 1).
"""
import math

import drjit as dr
import mitsuba as mi

from ref_common import (SceneError, Untranslatable, check_fields, length, normalize, num,
                        resolve, rgb, sub, vec3)
from ref_materials import Textures
from ref_shapes import Shapes

T4 = mi.ScalarTransform4f
TOP = {"version", "camera", "film", "materials", "objects", "lights", "environment", "render"}


def look_at(origin, target, up, path):
    d = normalize(sub(target, origin), f"{path}: look direction")
    u = normalize(up, f"{path}.up")
    if abs(sum(a * b for a, b in zip(d, u))) > 1 - 1e-9:
        raise SceneError(f"{path}.up: parallel to the view direction")
    return T4().look_at(origin=origin, target=target, up=up)


def env_to_world(rotate_y):
    """candela: a world direction d (after R_y(-rotate_y)) reads u = 0.5 + atan2(d.x, -d.z)/2π,
    v = acos(d.y)/π. Mitsuba's envmap reads u = atan2(l.x, -l.z)/2π, v = acos(l.y)/π of the local
    l = to_world⁻¹·d. R_y(180°) maps (x, y, z) → (-x, y, -z), which shifts u by exactly 1/2,
    so to_world⁻¹ = R_y(180°)·R_y(-rotate_y), i.e. to_world = R_y(rotate_y - 180°)."""
    return T4().rotate([0, 1, 0], rotate_y - 180.0)


def env_bitmap(full, resample):
    """Load an env map as linear RGB float. Mitsuba reads rows at v·(H-1) (row centres at the
    poles), candela at v·H - 0.5 (texel centres, clamped). With resample, insert the midpoint rows
    and repeat the pole rows: H → 2H + 1 rows, whose Mitsuba lookup equals candela's bilinear
    lookup exactly (columns already agree: both read u·W - 0.5, wrapping)."""
    bmp = mi.Bitmap(full).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
    if not resample:
        return bmp
    w, h = bmp.width(), bmp.height()
    src = dr.scalar.TensorXf(bmp).array
    k = dr.arange(dr.scalar.ArrayXu, (2 * h + 1) * w * 3)
    j, rem = k // (w * 3), k % (w * 3)
    ra = (dr.maximum(j, 1) - 1) // 2
    rb = dr.minimum(j // 2, h - 1)
    out = 0.5 * (dr.gather(dr.scalar.ArrayXf, src, ra * (w * 3) + rem)
                 + dr.gather(dr.scalar.ArrayXf, src, rb * (w * 3) + rem))
    return mi.Bitmap(dr.scalar.TensorXf(out, (2 * h + 1, w, 3)))


def light(i, l):
    path = f"lights[{i}]"
    kind = l.get("type") if isinstance(l, dict) else None
    known = {"point": {"position", "intensity"},
             "spot": {"position", "look_at", "intensity", "cutoff_angle", "beam_width"},
             "directional": {"direction", "irradiance"}}
    if kind not in known:
        raise Untranslatable(f"{path}.type: unknown light type {kind!r}")
    req = tuple(sorted(known[kind] - {"cutoff_angle", "beam_width"}))
    check_fields(l, path, known[kind] | {"type"}, required=req)
    if kind == "point":
        return {"type": "point", "position": vec3(l["position"], f"{path}.position"),
                "intensity": {"type": "rgb", "value": rgb(l["intensity"], f"{path}.intensity")}}
    if kind == "directional":
        return {"type": "directional",
                "direction": normalize(vec3(l["direction"], f"{path}.direction")),
                "irradiance": {"type": "rgb", "value": rgb(l["irradiance"], f"{path}.irradiance")}}
    p, t = vec3(l["position"], f"{path}.position"), vec3(l["look_at"], f"{path}.look_at")
    d = normalize(sub(t, p), f"{path}: look direction")
    up = [0, 1, 0] if abs(d[1]) < 0.9 else [1, 0, 0]  # Mitsuba's spot shines along local +Z
    cutoff = num(l.get("cutoff_angle", 20.0), f"{path}.cutoff_angle")
    beam = num(l.get("beam_width", 0.75 * cutoff), f"{path}.beam_width")
    return {"type": "spot", "to_world": T4().look_at(origin=p, target=t, up=up),
            "intensity": {"type": "rgb", "value": rgb(l["intensity"], f"{path}.intensity")},
            "cutoff_angle": cutoff, "beam_width": beam}


def environment(e, scene_dir, resample):
    path = "environment"
    kind = e.get("type") if isinstance(e, dict) else None
    if kind == "constant":
        check_fields(e, path, {"type", "radiance"}, required=("radiance",))
        return {"type": "constant",
                "radiance": {"type": "rgb", "value": rgb(e["radiance"], f"{path}.radiance")}}
    if kind == "map":
        check_fields(e, path, {"type", "file", "scale", "rotate_y"}, required=("file",))
        full = resolve(scene_dir, e["file"], f"{path}.file")
        return {"type": "envmap", "bitmap": env_bitmap(full, resample),
                "scale": num(e.get("scale", 1.0), f"{path}.scale"),
                "to_world": env_to_world(num(e.get("rotate_y", 0.0), f"{path}.rotate_y"))}
    raise Untranslatable(f"{path}.type: unknown environment type {kind!r}")


def sensor(cam, film, opts, far):
    check_fields(cam, "camera", {"position", "look_at", "up", "fov_y", "aperture_radius",
                                 "focus_distance"}, required=("position", "look_at"))
    check_fields(film, "film", {"width", "height", "filter", "exposure", "tonemap"})
    pos, tgt = vec3(cam["position"], "camera.position"), vec3(cam["look_at"], "camera.look_at")
    up = vec3(cam.get("up", [0, 1, 0]), "camera.up")
    width = opts.get("width") or int(num(film.get("width", 512), "film.width"))
    height = opts.get("height") or int(num(film.get("height", 512), "film.height"))
    f = film.get("filter", "box")
    if f == "box":
        rfilter = {"type": "box"}
    elif isinstance(f, dict) and f.get("type") == "gaussian":
        check_fields(f, "film.filter", {"type", "stddev"})
        rfilter = {"type": "gaussian", "stddev": num(f.get("stddev", 0.5), "film.filter.stddev")}
    else:
        raise Untranslatable(f"film.filter: unknown filter {f!r}")
    s = {"type": "perspective", "fov": num(cam.get("fov_y", 40.0), "camera.fov_y"),
         "fov_axis": "y", "to_world": look_at(pos, tgt, up, "camera"),
         # candela has no clip planes: keep Mitsuba's out of the way of the scene
         "near_clip": min(1e-2, 1e-6 * max(far, 1.0)), "far_clip": max(1e4, 2.0 * far),
         "film": {"type": "hdrfilm", "width": width, "height": height, "pixel_format": "rgb",
                  "component_format": "float32", "rfilter": rfilter},
         "sampler": {"type": "independent", "sample_count": opts["spp"]}}
    aperture = num(cam.get("aperture_radius", 0.0), "camera.aperture_radius")
    if aperture > 0:
        s["type"] = "thinlens"
        s["aperture_radius"] = aperture
        s["focus_distance"] = num(cam.get("focus_distance", length(sub(tgt, pos))),
                                  "camera.focus_distance")
    return s


def build_scene(scene, scene_dir, tmp_dir, opts):
    """Returns (scene dict for mi.load_dict, settings dict). opts: spp, seed, max_depth, rr_depth,
    width, height (None = scene/default), env_resample (bool)."""
    check_fields(scene, "scene", TOP, required=("camera", "objects"))
    if scene.get("version", 1) != 1:
        raise Untranslatable(f"version: unsupported scene version {scene.get('version')!r}")
    render = scene.get("render") or {}  # job settings: unknown keys do not change the scene
    if not isinstance(render, dict):
        raise SceneError("render: expected an object")
    opts = dict(opts)
    if opts.get("spp") is None:
        opts["spp"] = int(render.get("spp", 256))
    if opts.get("max_depth") is None:
        opts["max_depth"] = int(render.get("max_depth", 6))
    shapes = Shapes(scene, scene_dir, tmp_dir, Textures(scene_dir))
    objects = scene.get("objects")
    if not isinstance(objects, list):
        raise SceneError("objects: expected an array")
    d = {"type": "scene"}
    lo, hi = [math.inf] * 3, [-math.inf] * 3  # scene bounds, for the clip range
    for i, o in enumerate(objects):
        shape = shapes.shape(i, o)
        b = shape.bbox()
        lo = [min(lo[a], float(b.min[a])) for a in range(3)]
        hi = [max(hi[a], float(b.max[a])) for a in range(3)]
        d[f"object_{i}"] = shape
    for i, l in enumerate(scene.get("lights") or []):
        d[f"light_{i}"] = light(i, l)
    if scene.get("environment") is not None:
        d["environment"] = environment(scene["environment"], scene_dir, opts["env_resample"])
    cam = scene["camera"]
    far = 0.0
    if lo[0] <= hi[0] and isinstance(cam, dict) and "position" in cam:
        p = vec3(cam["position"], "camera.position")
        far = max(length(sub([(lo, hi)[(k >> a) & 1][a] for a in range(3)], p)) for k in range(8))
    d["sensor"] = sensor(cam, scene.get("film") or {}, opts, far)
    # Mitsuba's `path` traces shadow rays as opaque through `mask` (cut-outs would block light)
    # and counts null crossings as bounces; `volpath` handles both, and equals `path` otherwise.
    integ = "volpath" if shapes.uses_mask else "path"
    d["integrator"] = {"type": integ, "max_depth": opts["max_depth"],
                       "rr_depth": 5 if opts.get("rr_depth") is None else opts["rr_depth"],
                       "hide_emitters": False}
    settings = {"spp": opts["spp"], "seed": opts.get("seed", 0), "integrator": integ,
                "max_depth": opts["max_depth"], "rr_depth": d["integrator"]["rr_depth"],
                "width": d["sensor"]["film"]["width"], "height": d["sensor"]["film"]["height"]}
    return d, settings
