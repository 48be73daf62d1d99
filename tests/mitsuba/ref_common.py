"""Shared helpers for the Mitsuba 3 reference translator (see README.md).

Errors (two kinds, so tests can tell "skip" from "broken"), strict field checks, value parsing,
safe path resolution and the little vector algebra the translation needs. No Mitsuba import here.
"""
import math
import os


class Untranslatable(Exception):
    """The scene uses a feature Mitsuba 3 cannot express exactly: exit code 2 (tests skip)."""


class SceneError(Exception):
    """The scene is invalid (missing field, bad value, bad path): exit code 1."""


def check_fields(obj, path, known, required=()):
    """Reject non-objects, unknown fields (exit 2: maybe a newer format) and missing ones."""
    if not isinstance(obj, dict):
        raise SceneError(f"{path}: expected an object")
    for key in obj:
        if key not in known:
            raise Untranslatable(f"{path}.{key}: unknown field")
    for key in required:
        if key not in obj:
            raise SceneError(f"{path}.{key}: required field missing")


def num(v, path):
    """A JSON number as float."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise SceneError(f"{path}: expected a number")
    return float(v)


def vec3(v, path):
    """`[x, y, z]` as a list of 3 floats."""
    if not isinstance(v, list) or len(v) != 3:
        raise SceneError(f"{path}: expected [x, y, z]")
    return [num(x, f"{path}[{i}]") for i, x in enumerate(v)]


def rgb(v, path):
    """A constant colour: `[r, g, b]` or a number (grey)."""
    if isinstance(v, dict):
        raise Untranslatable(f"{path}: a texture is not supported here")
    if isinstance(v, list):
        return vec3(v, path)
    x = num(v, path)
    return [x, x, x]


def is_texture(v):
    return isinstance(v, dict)


def resolve(scene_dir, rel, path):
    """Resolve a relative asset path against the scene folder; reject escapes."""
    if not isinstance(rel, str) or not rel:
        raise SceneError(f"{path}: expected a relative file path")
    parts = rel.replace("\\", "/").split("/")
    if os.path.isabs(rel) or ".." in parts:
        raise SceneError(f"{path}: path {rel!r} escapes the scene folder")
    full = os.path.join(scene_dir, *parts)
    if not os.path.isfile(full):
        raise SceneError(f"{path}: file {rel!r} not found")
    return full


def flat(v, n, path):
    """Flat `[a, b, ...]` or nested `[[a, b], ...]` number list → list of n-tuples."""
    if not isinstance(v, list):
        raise SceneError(f"{path}: expected an array")
    if v and isinstance(v[0], list):
        if any(not isinstance(t, list) or len(t) != n for t in v):
            raise SceneError(f"{path}: expected arrays of {n} numbers")
        return [tuple(num(x, path) for x in t) for t in v]
    if len(v) % n:
        raise SceneError(f"{path}: length {len(v)} is not a multiple of {n}")
    vals = [num(x, path) for x in v]
    return [tuple(vals[i:i + n]) for i in range(0, len(vals), n)]


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def add(a, b):
    return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]


def mul(a, s):
    return [a[0] * s, a[1] * s, a[2] * s]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def length(a):
    return math.sqrt(dot(a, a))


def normalize(a, path="vector"):
    n = length(a)
    if not n > 0:
        raise SceneError(f"{path}: zero-length vector")
    return mul(a, 1.0 / n)
