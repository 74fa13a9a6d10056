"""Sensor files read with NumPy alone: point clouds (PLY, PCD, ``.npy``) and depth images (PNG, ``.npy``).

- **PLY** (``format ascii 1.0``, ``binary_little_endian 1.0`` or ``binary_big_endian 1.0``): the
  ``vertex`` element's ``x``, ``y``, ``z`` properties (any numeric type; other properties are
  skipped). Elements before ``vertex`` must have no list properties (their size is then known).
- **PCD** (``DATA ascii`` or ``DATA binary``): the ``x``, ``y``, ``z`` fields (``FIELDS``,
  ``SIZE``, ``TYPE``, ``COUNT`` say where they are in a point); ``binary_compressed`` is refused.
- **.npy**: an ``N x 3`` array of numbers.
- **Depth images**: a ``.npy`` ``H x W`` array, or a single-channel PNG (8 or 16 bit, read
  with Pillow, which Matplotlib already requires); the raw values, scaled by the caller.

Every failure is an :class:`~forte.exceptions.InvalidInputError` whose message starts with the
file's name and says what was expected; a cloud with no points or with a NaN or infinite
coordinate is refused too (a depth image's NaN is a pixel without a return, kept for the caller).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from forte.exceptions import InvalidInputError
from forte.validation import FloatArray

#: The point cloud formats, by suffix.
CLOUD_SUFFIXES = (".ply", ".pcd", ".npy")
#: The depth image formats, by suffix.
DEPTH_SUFFIXES = (".png", ".npy")

_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_PCD_TYPES = {("F", 4): "f4", ("F", 8): "f8", ("I", 1): "i1", ("I", 2): "i2", ("I", 4): "i4", ("I", 8): "i8",
              ("U", 1): "u1", ("U", 2): "u2", ("U", 4): "u4", ("U", 8): "u8"}


def _existing(path: Path, suffixes: tuple[str, ...], kind: str) -> tuple[Path, str]:
    """``path`` and its lower-case suffix, or one line: no such file, or not a ``kind`` file."""
    path = Path(path)
    if not path.is_file():
        raise InvalidInputError(f"{path}: no such file")
    suffix = path.suffix.lower()
    if suffix not in suffixes:
        raise InvalidInputError(f"{path.name}: expected a {kind} file ({', '.join(suffixes)})")
    return path, suffix


def read_points(path: Path) -> FloatArray:
    """The points (N x 3, float) of a ``.ply``, ``.pcd`` or ``.npy`` file (module docstring)."""
    path, suffix = _existing(path, CLOUD_SUFFIXES, "point cloud")
    try:
        if suffix == ".npy":
            points = _npy(path, 2)
        else:
            points = _ply(path) if suffix == ".ply" else _pcd(path)
    except InvalidInputError:
        raise
    except (ValueError, IndexError, KeyError, OSError, UnicodeDecodeError) as exc:
        raise InvalidInputError(f"{path.name}: cannot read it as a {suffix[1:].upper()} point cloud: "
                                f"{str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from exc
    if points.ndim != 2 or points.shape[1] != 3:
        raise InvalidInputError(f"{path.name}: expected N x 3 points, got an array of shape {points.shape}")
    if len(points) == 0:
        raise InvalidInputError(f"{path.name}: the cloud has no points")
    bad = np.flatnonzero(~np.all(np.isfinite(points), axis=1))
    if len(bad):
        raise InvalidInputError(f"{path.name}: {len(bad)} of {len(points)} points are NaN or infinite "
                                f"(the first is point {int(bad[0])}); remove them before planning")
    return points


def read_depth(path: Path) -> FloatArray:
    """The raw values (H x W, float; NaN kept) of a depth image ``.png`` or ``.npy``."""
    path, suffix = _existing(path, DEPTH_SUFFIXES, "depth image")
    try:
        image = _npy(path, 2) if suffix == ".npy" else _png(path)
    except InvalidInputError:
        raise
    except (ValueError, OSError) as exc:
        raise InvalidInputError(f"{path.name}: cannot read it as a depth image: {str(exc).splitlines()[0]}") from exc
    if image.ndim != 2 or min(image.shape) == 0:
        raise InvalidInputError(f"{path.name}: expected a single-channel H x W image, got shape {image.shape}")
    return image


def _npy(path: Path, ndim: int) -> FloatArray:
    array = np.load(path, allow_pickle=False)
    if array.dtype.kind not in "iuf" or array.ndim != ndim:
        raise InvalidInputError(f"{path.name}: expected a {ndim}-D array of numbers, got {array.ndim}-D "
                                f"{array.dtype}")
    return np.asarray(array, dtype=float)


def _png(path: Path) -> FloatArray:
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as image:
            if image.mode not in ("L", "I", "I;16", "I;16B", "F"):
                raise InvalidInputError(f"{path.name}: expected a single-channel (grey) depth PNG, got mode "
                                        f"{image.mode}")
            return np.asarray(image, dtype=float)
    except UnidentifiedImageError as exc:
        raise InvalidInputError(f"{path.name}: not a PNG image") from exc


def _header(data: bytes, end: bytes, path: Path) -> tuple[list[str], int]:
    """The header's lines (text) and the offset of the data after them."""
    at = data.find(end)
    if at < 0:
        raise InvalidInputError(f"{path.name}: no {end.decode().strip()!r} line ending the header")
    stop = data.find(b"\n", at) + 1 or len(data)
    return data[:stop].decode("ascii").splitlines(), stop


def _ply(path: Path) -> FloatArray:
    data = path.read_bytes()
    if not data.startswith(b"ply"):
        raise InvalidInputError(f"{path.name}: not a PLY file (no 'ply' on its first line)")
    lines, start = _header(data, b"end_header", path)
    fmt, elements = None, []  # elements: [name, count, [(property, dtype)], has a list]
    for line in lines:
        words = line.split()
        if words[:1] == ["format"]:
            fmt = words[1]
        elif words[:1] == ["element"]:
            elements.append([words[1], int(words[2]), [], False])
        elif words[:1] == ["property"] and elements:
            if words[1] == "list":
                elements[-1][3] = True
            elif words[1] in _PLY_TYPES:
                elements[-1][2].append((words[2], _PLY_TYPES[words[1]]))
            else:
                raise InvalidInputError(f"{path.name}: unknown PLY property type {words[1]!r}")
    names = [e[0] for e in elements]
    if "vertex" not in names:
        raise InvalidInputError(f"{path.name}: no 'element vertex' in the header")
    vertex = elements[names.index("vertex")]
    if vertex[3] or any(e[3] for e in elements[:names.index("vertex")]):
        raise InvalidInputError(f"{path.name}: list properties before or in the vertex element are not read")
    props = [p for p, _ in vertex[2]]
    if not {"x", "y", "z"} <= set(props):
        raise InvalidInputError(f"{path.name}: the vertex element has no x, y and z properties (has {props})")
    if fmt == "ascii":
        return _ply_ascii(data[start:], elements, names.index("vertex"), props, path)
    order = {"binary_little_endian": "<", "binary_big_endian": ">"}.get(fmt or "")
    if order is None:
        raise InvalidInputError(f"{path.name}: expected format ascii, binary_little_endian or "
                                f"binary_big_endian, got {fmt}")
    offset = start
    for e in elements[:names.index("vertex")]:
        offset += e[1] * np.dtype([(p, order + t) for p, t in e[2]]).itemsize
    dtype = np.dtype([(p, order + t) for p, t in vertex[2]])
    if len(data) < offset + vertex[1] * dtype.itemsize:
        raise InvalidInputError(f"{path.name}: the file ends before its {vertex[1]} vertices")
    rows = np.frombuffer(data, dtype=dtype, count=vertex[1], offset=offset)
    return np.column_stack([rows[a].astype(float) for a in "xyz"])


def _ply_ascii(body: bytes, elements: list, index: int, props: list[str], path: Path) -> FloatArray:
    lines = body.decode("ascii").splitlines()
    lines = [ln for ln in lines if ln.strip()]
    skip = sum(e[1] for e in elements[:index])
    count = elements[index][1]
    rows = lines[skip:skip + count]
    if len(rows) < count:
        raise InvalidInputError(f"{path.name}: the file ends before its {count} vertices")
    table = np.array([r.split()[:len(props)] for r in rows], dtype=float).reshape(count, len(props))
    return table[:, [props.index(a) for a in "xyz"]]


def _pcd(path: Path) -> FloatArray:
    data = path.read_bytes()
    at = data.find(b"DATA")
    if at < 0:
        raise InvalidInputError(f"{path.name}: no DATA line in the PCD header")
    stop = data.find(b"\n", at) + 1 or len(data)
    head = {}
    for line in data[:stop].decode("ascii").splitlines():
        words = line.split()
        if words and not words[0].startswith("#"):
            head[words[0].upper()] = words[1:]
    fields = head.get("FIELDS", [])
    if not {"x", "y", "z"} <= set(fields):
        raise InvalidInputError(f"{path.name}: the PCD has no x, y and z FIELDS (has {fields})")
    n = len(fields)
    sizes = [int(s) for s in head.get("SIZE", ["4"] * n)]
    types = head.get("TYPE", ["F"] * n)
    counts = [int(c) for c in head.get("COUNT", ["1"] * n)]
    points = int(head.get("POINTS", [int(head["WIDTH"][0]) * int(head.get("HEIGHT", ["1"])[0])])[0])
    kind = head["DATA"][0].lower()
    if kind == "ascii":
        values = np.array(data[stop:].decode("ascii").split(), dtype=float)
        width = sum(counts)
        if values.size < points * width:
            raise InvalidInputError(f"{path.name}: the file ends before its {points} points")
        table = values[:points * width].reshape(points, width)
        starts = np.cumsum([0, *counts[:-1]])
        return table[:, [int(starts[fields.index(a)]) for a in "xyz"]]
    if kind != "binary":
        raise InvalidInputError(f"{path.name}: expected DATA ascii or binary, got {kind} (save it uncompressed)")
    try:
        dtype = np.dtype([(f, "<" + _PCD_TYPES[(t.upper(), s)], (c,) if c > 1 else ())
                          for f, s, t, c in zip(fields, sizes, types, counts, strict=True)])
    except KeyError as exc:
        raise InvalidInputError(f"{path.name}: unknown PCD TYPE/SIZE {exc.args[0]}") from None
    if len(data) < stop + points * dtype.itemsize:
        raise InvalidInputError(f"{path.name}: the file ends before its {points} points")
    rows = np.frombuffer(data, dtype=dtype, count=points, offset=stop)
    return np.column_stack([rows[a].astype(float) for a in "xyz"])
