"""Images for the VLM: encoded bytes, MIME type and the data URL of OpenAI-compatible servers.

Files are sent as they are (PNG, JPEG, WebP or GIF, recognised by suffix or magic bytes); numpy
arrays are encoded to PNG first. Nothing is resized or re-encoded, so the cache key (sha256 of the
bytes) names exactly what the server saw.
"""

from __future__ import annotations

import base64
import io
from pathlib import Path
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError

ImageInput = str | Path | np.ndarray

_MIME_BY_SUFFIX = {
    ".png": "image/png",
    ".jpg": "image/jpeg",
    ".jpeg": "image/jpeg",
    ".webp": "image/webp",
    ".gif": "image/gif",
}
_MAGIC = (
    (b"\x89PNG\r\n\x1a\n", "image/png"),
    (b"\xff\xd8\xff", "image/jpeg"),
    (b"GIF8", "image/gif"),
)


#: Largest image file read (bytes) and image array encoded (pixels).
MAX_IMAGE_BYTES = 32 * 2**20
MAX_IMAGE_PIXELS = 50_000_000


def image_bytes(image: ImageInput, option: str = "image") -> tuple[bytes, str]:
    """The encoded bytes and MIME type of ``image``.

    Files are sent as they are (PNG, JPEG, WebP, GIF, recognised by suffix or magic bytes); a
    numpy array (H x W grey, H x W x 3 RGB or H x W x 4 RGBA; uint8 or floats in [0, 1]) is
    encoded to PNG with matplotlib.
    """
    if isinstance(image, np.ndarray):
        if image.size > MAX_IMAGE_PIXELS * 4:
            raise InvalidInputError(f"{option}: {image.shape} is larger than {MAX_IMAGE_PIXELS} pixels")
        return _encode_array(image), "image/png"
    path = Path(image)
    try:
        if not path.is_file():
            raise InvalidInputError(f"{option} {str(path)!r}: cannot be read (no such file; expected a PNG, "
                                    "JPEG, WebP or GIF image)")
        size = path.stat().st_size
        if size > MAX_IMAGE_BYTES:
            raise InvalidInputError(f"{option} {str(path)!r}: {size} bytes; expected at most {MAX_IMAGE_BYTES}")
        data = path.read_bytes()
    except OSError as exc:
        raise InvalidInputError(f"{option} {str(path)!r}: cannot be read ({exc.strerror or exc})") from None
    mime = _MIME_BY_SUFFIX.get(path.suffix.lower()) or _sniff_mime(data)
    if mime is None:
        raise InvalidInputError(f"{option} {str(path)!r}: expected a PNG, JPEG, WebP or GIF file")
    if not data:
        raise InvalidInputError(f"{option} {str(path)!r}: the file is empty")
    return data, mime


def _sniff_mime(data: bytes) -> str | None:
    """The MIME type announced by the first bytes of an image file, or None."""
    mime = next((m for magic, m in _MAGIC if data.startswith(magic)), None)
    if mime is None and data[:4] == b"RIFF" and data[8:12] == b"WEBP":
        mime = "image/webp"
    return mime


def _encode_array(array: np.ndarray) -> bytes:
    import matplotlib.image as mpimg  # deferred: matplotlib import is slow and not always needed

    ok_shape = array.ndim == 2 or (array.ndim == 3 and array.shape[2] in (3, 4))
    if not ok_shape or min(array.shape[:2]) < 1:
        raise InvalidInputError(f"image: expected an H x W, H x W x 3 or H x W x 4 array, got {array.shape}")
    if array.dtype == np.uint8:
        data = array
    else:
        data = np.asarray(array, dtype=float)
        if not np.all(np.isfinite(data)) or data.min() < 0.0 or data.max() > 1.0:
            raise InvalidInputError("image: expected uint8 values or finite floats in [0, 1]")
    buf = io.BytesIO()
    kwargs: dict[str, Any] = {"cmap": "gray", "vmin": 0, "vmax": 255 if data.dtype == np.uint8 else 1}
    mpimg.imsave(buf, data, format="png", **(kwargs if data.ndim == 2 else {}))
    return buf.getvalue()


def data_url(data: bytes, mime: str) -> str:
    """``data:<mime>;base64,<payload>``, the form OpenAI-compatible servers accept for images."""
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"
