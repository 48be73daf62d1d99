"""Candela materials and textures → Mitsuba 3 BSDF / texture dicts (docs/scene-format.md, "materials").

Colour textures become `bitmap` textures read by Mitsuba itself. Scalar textures (candela uses the
red channel) are decoded here and handed to `bitmap` as a one-channel Bitmap, optionally passed
through a function (roughness → GGX alpha). Works in any Mitsuba variant (uses drjit.scalar).
"""
import math

import drjit as dr
import mitsuba as mi

from ref_common import (SceneError, Untranslatable, check_fields, is_texture, num, resolve, rgb)

COMMON = {"type", "emission", "alpha_mask", "two_sided"}
FIELDS = {
    "diffuse": {"reflectance"},
    "conductor": {"reflectance", "roughness", "anisotropy", "eta", "k"},
    "dielectric": {"ior", "roughness", "transmittance", "reflectance"},
    "principled": {"base_color", "metallic", "roughness", "specular", "spec_tint", "anisotropic",
                   "sheen", "sheen_tint", "spec_trans", "ior", "subsurface", "clearcoat",
                   "clearcoat_gloss"},
    "phong": {"diffuse", "specular", "exponent"},
}


class Textures:
    """Turns candela colour / scalar parameters into Mitsuba texture values."""

    def __init__(self, scene_dir):
        self.scene_dir = scene_dir

    def _tex(self, t, path):
        check_fields(t, path, {"texture", "srgb", "scale", "channel"}, required=("texture",))
        full = resolve(self.scene_dir, t["texture"], f"{path}.texture")
        # candela's default, for colour and scalar fields alike: sRGB for 8-bit formats only.
        srgb = t.get("srgb", full.lower().endswith((".png", ".jpg", ".jpeg")))
        if not isinstance(srgb, bool):
            raise SceneError(f"{path}.srgb: expected true or false")
        s = t.get("scale", [1.0, 1.0])
        s = [num(s, f"{path}.scale")] * 2 if not isinstance(s, list) else s
        if len(s) != 2:
            raise SceneError(f"{path}.scale: expected [su, sv]")
        su, sv = num(s[0], f"{path}.scale[0]"), num(s[1], f"{path}.scale[1]")
        channel = t.get("channel")
        if channel not in (None, "r", "g", "b", "a", "luminance"):
            raise SceneError(f"{path}.channel: expected r, g, b, a or luminance")
        # Mitsuba's uv has v = 0 on the top row (candela's 1 − v): candela's row 1 − sv·v is
        # Mitsuba's sv·(1 − v) shifted by 1 − sv.
        to_uv = mi.ScalarTransform3f().translate([0.0, 1.0 - sv]) @ mi.ScalarTransform3f().scale([su, sv])
        return full, srgb, to_uv, channel

    def color(self, v, path):
        """Colour field: number / [r,g,b] → `rgb`; texture → `bitmap` (bilinear, repeat); a
        texture with a `channel` → a one-channel bitmap of that channel (grey)."""
        if not is_texture(v):
            return {"type": "rgb", "value": rgb(v, path)}
        full, srgb, to_uv, channel = self._tex(v, path)
        if channel is not None:
            r, w, h, to_uv = self.red(v, path)
            return {"type": "bitmap", "bitmap": mi.Bitmap(dr.scalar.TensorXf(r, (h, w, 1))),
                    "raw": True, "filter_type": "bilinear", "wrap_mode": "repeat", "to_uv": to_uv}
        return {"type": "bitmap", "filename": full, "raw": not srgb, "filter_type": "bilinear",
                "wrap_mode": "repeat", "to_uv": to_uv}

    def red(self, v, path):
        """The channel a scalar reads (`channel`, default red), linear →
        (drjit.scalar.ArrayXf, width, height, to_uv)."""
        full, srgb, to_uv, channel = self._tex(v, path)
        bmp = mi.Bitmap(full)
        if not srgb:
            bmp.set_srgb_gamma(False)  # raw: take stored values as they are
        bmp = bmp.convert(mi.Bitmap.PixelFormat.RGBA, mi.Struct.Type.Float32, False)
        data = dr.scalar.TensorXf(bmp).array
        w, h = bmp.width(), bmp.height()
        base = dr.arange(dr.scalar.ArrayXu, w * h) * 4
        pick = lambda k: dr.gather(dr.scalar.ArrayXf, data, base + k)
        if channel == "luminance":
            return 0.2126 * pick(0) + 0.7152 * pick(1) + 0.0722 * pick(2), w, h, to_uv
        return pick({"r": 0, "g": 1, "b": 2, "a": 3}[channel or "r"]), w, h, to_uv

    def scalar(self, v, path, fn=None):
        """Scalar field: number → float; texture → one-channel `bitmap` of fn(red channel).
        candela applies fn (roughness → alpha) to the bilinearly filtered value, Mitsuba filters
        the bitmap it is given: a bitmap of fn(texel) would blend fn's values between texel
        centres where candela blends the texels before fn (the random-scene audit's seed 132: a
        rough dielectric floor with a checker roughness, 44× the noise). So the bitmap holds
        fn(candela's bilinear lookup) on a grid k× finer (k odd, so that every texel centre, where
        the blend has a kink, is a centre of the finer grid too), which Mitsuba's bilinear filter
        follows to within about (1/k)² of the blend's curvature."""
        if not is_texture(v):
            x = num(v, path)
            return fn(x) if fn else x
        r, w, h, to_uv = self.red(v, path)
        if fn:
            k = refinement(w, h, (7, 5, 3))
            r, w, h = fn(upsampled_bilinear(r, w, h, k)), w * k, h * k
        bmp = mi.Bitmap(dr.scalar.TensorXf(r, (h, w, 1)))
        return {"type": "bitmap", "bitmap": bmp, "raw": True, "filter_type": "bilinear",
                "wrap_mode": "repeat", "to_uv": to_uv}

    def mask(self, v, path):
        """Alpha mask: candela cuts where bilinear(red) < 0.5, Mitsuba's `mask` blends. For a binary
        mask, nearest filtering puts the cut where candela's 0.5 contour crosses between texel
        centres (texel edges), but the contour rounds every corner of a hole off, and there a
        texel's worth of floor showed in candela where the reference had a hole (the random-scene
        audit's seed 212: 39× the noise on an H200, a hole's corner near the camera). So the bitmap holds
        candela's cut, bilinear(red) ≥ 0.5, at the centres of a grid k× finer (k odd: the texel
        edges stay edges of the finer grid, so straight edges stay exact), which nearest filtering
        follows to within half a fine texel at the corners."""
        if not is_texture(v):
            raise SceneError(f"{path}: expected a texture")
        r, w, h, to_uv = self.red(v, path)
        if not dr.all((r == 0) | (r == 1)):
            raise Untranslatable(f"{path}: non-binary alpha mask (Mitsuba's mask blends, candela "
                                 "cuts at 0.5)")
        k = refinement(w, h, (15, 7, 5, 3))
        r = dr.select(upsampled_bilinear(r, w, h, k) < 0.5, 0.0, 1.0)
        w, h = w * k, h * k
        bmp = mi.Bitmap(dr.scalar.TensorXf(r, (h, w, 1)))
        return {"type": "bitmap", "bitmap": bmp, "raw": True, "filter_type": "nearest",
                "wrap_mode": "repeat", "to_uv": to_uv}


# The most texels of a derived bitmap (scalar() and mask() pick their refinement k within this).
FINE_TEXELS = 1 << 22


def refinement(w, h, choices):
    """The first of `choices` (odd factors, largest first) by which a w × h texture may be refined
    within FINE_TEXELS texels, else 1."""
    return next((k for k in choices if w * h * k * k <= FINE_TEXELS), 1)


def upsampled_bilinear(r, w, h, k):
    """Texels r (w×h, row 0 at the top) looked up bilinearly with repeat wrapping, as candela's
    texture_eval does (texel centres at half-integers), at the centres of a grid k× finer."""
    if k == 1:
        return r
    i = dr.arange(dr.scalar.ArrayXu, w * k * h * k)
    fx = dr.scalar.ArrayXf(i % (w * k)) / k + (0.5 / k - 0.5)
    fy = dr.scalar.ArrayXf(i // (w * k)) / k + (0.5 / k - 0.5)
    x0, y0 = dr.floor(fx), dr.floor(fy)
    ax, ay = fx - x0, fy - y0
    wrap = lambda a, n: dr.scalar.ArrayXu(((dr.scalar.ArrayXi(a) % n) + n) % n)
    xa, xb = wrap(x0, w), wrap(x0 + 1, w)
    ya, yb = wrap(y0, h), wrap(y0 + 1, h)
    at = lambda x, y: dr.gather(dr.scalar.ArrayXf, r, y * w + x)
    top = at(xa, ya) * (1 - ax) + at(xb, ya) * ax
    bottom = at(xa, yb) * (1 - ax) + at(xb, yb) * ax
    return top * (1 - ay) + bottom * ay


def _nonzero(v):
    return is_texture(v) or v != 0


def _conductor(m, path, tex):
    r, a = m.get("roughness", 0.0), m.get("anisotropy", 0.0)
    if is_texture(a):
        raise Untranslatable(f"{path}.anisotropy: textured anisotropy")
    a = num(a, f"{path}.anisotropy")
    if not is_texture(r) and num(r, f"{path}.roughness") == 0:
        bsdf = {"type": "conductor"}
    elif a == 0:
        bsdf = {"type": "roughconductor", "distribution": "ggx",
                "alpha": tex.scalar(r, f"{path}.roughness", lambda x: x * x)}
    else:
        # candela's anisotropy convention is Mitsuba principled's `anisotropic` mapping:
        # aspect = sqrt(1 - 0.9 a), alpha_u = alpha / aspect, alpha_v = alpha * aspect, alpha = r².
        if 1 - 0.9 * a <= 0:
            raise SceneError(f"{path}.anisotropy: must be < 1/0.9")
        aspect = math.sqrt(1 - 0.9 * a)
        bsdf = {"type": "roughconductor", "distribution": "ggx",
                "alpha_u": tex.scalar(r, f"{path}.roughness", lambda x: x * x / aspect),
                "alpha_v": tex.scalar(r, f"{path}.roughness", lambda x: x * x * aspect)}
    if "eta" in m or "k" in m:  # Mitsuba's defaults for a missing one: eta 0, k 1
        for key in ("eta", "k"):
            if key in m:
                bsdf[key] = {"type": "rgb", "value": rgb(m[key], f"{path}.{key}")}
    else:
        bsdf["material"] = "none"  # Fresnel = 1
    bsdf["specular_reflectance"] = tex.color(m.get("reflectance", 1.0), f"{path}.reflectance")
    return bsdf


def _dielectric(m, path, tex):
    ior = m.get("ior", 1.5)
    if is_texture(ior):
        raise Untranslatable(f"{path}.ior: textured ior")
    r = m.get("roughness", 0.0)
    if not is_texture(r) and num(r, f"{path}.roughness") == 0:
        bsdf = {"type": "dielectric"}
    else:
        bsdf = {"type": "roughdielectric", "distribution": "ggx",
                "alpha": tex.scalar(r, f"{path}.roughness", lambda x: x * x)}
    bsdf.update({"int_ior": num(ior, f"{path}.ior"), "ext_ior": 1.0,
                 "specular_transmittance": tex.color(m.get("transmittance", 1.0),
                                                     f"{path}.transmittance"),
                 "specular_reflectance": tex.color(m.get("reflectance", 1.0),
                                                   f"{path}.reflectance")})
    return bsdf


def _principled(m, path, tex):
    ss = m.get("subsurface", 0.0)
    if is_texture(ss) or num(ss, f"{path}.subsurface") != 0:
        raise Untranslatable(f"{path}.subsurface: nonzero principled subsurface")
    if is_texture(m.get("spec_trans", 0.0)):
        raise Untranslatable(f"{path}.spec_trans: textured spec_trans (two-sidedness undefined)")
    bsdf = {"type": "principled",
            "base_color": tex.color(m.get("base_color", 0.8), f"{path}.base_color"),
            "roughness": tex.scalar(m.get("roughness", 0.5), f"{path}.roughness"),
            "clearcoat_gloss": tex.scalar(m.get("clearcoat_gloss", 1.0),
                                          f"{path}.clearcoat_gloss")}
    # Mitsuba switches these lobes on by presence; pass them only when they matter.
    for key, default in (("metallic", 0.0), ("spec_tint", 0.0), ("anisotropic", 0.0),
                         ("sheen", 0.0), ("sheen_tint", 0.5), ("spec_trans", 0.0),
                         ("clearcoat", 0.0)):
        v = m.get(key, default)
        if _nonzero(v):
            bsdf[key] = tex.scalar(v, f"{path}.{key}")
    # Mitsuba has one Fresnel parameter: `eta` or `specular` (one determines the other).
    if is_texture(m.get("specular", 0.0)) or is_texture(m.get("ior", 0.0)):
        raise Untranslatable(f"{path}: textured specular / ior")
    if "specular" in m and "ior" not in m:
        bsdf["specular"] = num(m["specular"], f"{path}.specular")
    else:
        eta = num(m.get("ior", 1.5), f"{path}.ior")
        if "specular" in m:
            spec = num(m["specular"], f"{path}.specular")
            if abs(spec - ((eta - 1) / (eta + 1)) ** 2 / 0.08) > 1e-4:
                raise Untranslatable(f"{path}: specular and ior disagree (Mitsuba derives one "
                                     "from the other)")
        bsdf["eta"] = eta
    return bsdf


def translate_material(m, path, tex):
    """Returns (bsdf dict, emission [r,g,b] or None, uses_mask)."""
    if not isinstance(m, dict) or m.get("type") not in FIELDS:
        raise Untranslatable(f"{path}.type: unknown material type {m.get('type')!r}"
                             if isinstance(m, dict) else f"{path}: expected an object")
    kind = m["type"]
    check_fields(m, path, COMMON | FIELDS[kind])
    if kind == "phong":
        raise Untranslatable(f"{path}: phong material (no Mitsuba 3 equivalent)")
    if kind == "diffuse":
        bsdf = {"type": "diffuse",
                "reflectance": tex.color(m.get("reflectance", 0.5), f"{path}.reflectance")}
    elif kind == "conductor":
        bsdf = _conductor(m, path, tex)
    elif kind == "dielectric":
        bsdf = _dielectric(m, path, tex)
    else:
        bsdf = _principled(m, path, tex)
    two_sided = m.get("two_sided", True)
    if not isinstance(two_sided, bool):
        raise SceneError(f"{path}.two_sided: expected true or false")
    transmissive = kind == "dielectric" or (kind == "principled" and "spec_trans" in bsdf)
    if two_sided and not transmissive:
        bsdf = {"type": "twosided", "bsdf": bsdf}
    emission = rgb(m.get("emission", 0.0), f"{path}.emission")
    emission = emission if any(emission) else None
    uses_mask = "alpha_mask" in m
    if uses_mask:
        if emission:
            raise Untranslatable(f"{path}: emission with alpha_mask (Mitsuba's area emitter "
                                 "ignores the mask)")
        bsdf = {"type": "mask", "opacity": tex.mask(m["alpha_mask"], f"{path}.alpha_mask"),
                "bsdf": bsdf}
    return bsdf, emission, uses_mask
