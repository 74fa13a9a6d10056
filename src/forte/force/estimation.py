"""Payload mass estimation from an image and a task description (paper, Section 4.1).

The paper's desired task force is ``f_k = m_hat (a_k - g)`` where ``m_hat = Phi_VLM(I, D)`` is the
mass of the object the end effector will carry, inferred by a vision-language model from an RGB
image ``I`` and a task description ``D``. This module produces ``m_hat`` together with an
interval ``[low, high]`` that states its uncertainty, from one of three sources:

* ``user``: a mass given explicitly always wins (interval of zero width);
* ``vlm``: any OpenAI-compatible chat-completions server (GPT-4o as in the paper, a local Ollama
  or vLLM) through the official ``openai`` client, see :class:`VLMEstimator`;
* ``offline``: quantities stated in the description ("two 1.5 L bottles", "a 2 kg dumbbell")
  read with a small documented table, see :class:`OfflineEstimator`.

The interval becomes the radius of the force uncertainty ball with :func:`radius_from_estimate`.
"""

from __future__ import annotations

import base64
import hashlib
import io
import json
import logging
import math
import os
import re
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable
from urllib.parse import urlparse

import numpy as np

from forte.exceptions import EstimationError, InvalidInputError
from forte.validation import FloatArray, as_array, as_positive

log = logging.getLogger(__name__)

#: Bumped whenever the prompt or the answer schema changes; part of every cache key.
PROMPT_VERSION = "forte-payload-mass-v1"
#: Plausible payload masses (kg): answers outside are rejected as hallucinations.
MIN_MASS_KG = 1e-3
MAX_MASS_KG = 500.0
#: Gravity used by the paper (m/s^2), pointing along -z.
GRAVITY = np.array([0.0, 0.0, -9.81])
#: The paper's uncertainty radius (N), kept as the floor of :func:`radius_from_estimate`.
DEFAULT_R_MIN = 10.0

ImageInput = str | Path | np.ndarray


@dataclass(frozen=True)
class MassEstimate:
    """A payload mass ``mass_kg`` with its plausible interval ``low_kg <= mass_kg <= high_kg``.

    ``source`` names the estimator and, for a VLM, the model (``"vlm:gpt-4o"``); ``rationale`` is
    a short human-readable justification; ``cached`` is true when a VLM answer came from disk.
    """

    mass_kg: float
    low_kg: float
    high_kg: float
    source: str
    rationale: str = ""
    cached: bool = False

    def __post_init__(self) -> None:
        for name in ("mass_kg", "low_kg", "high_kg"):
            value = getattr(self, name)
            if not isinstance(value, int | float) or isinstance(value, bool) or not math.isfinite(value):
                raise EstimationError(f"{name}: expected a finite number, got {value!r}")
            if value <= 0:
                raise EstimationError(f"{name}: expected a positive mass, got {value!r} kg")
        if not self.low_kg <= self.mass_kg <= self.high_kg:
            raise EstimationError(
                f"expected low_kg <= mass_kg <= high_kg, got {self.low_kg!r} <= {self.mass_kg!r} "
                f"<= {self.high_kg!r}"
            )

    @property
    def half_width_kg(self) -> float:
        """``(high - low) / 2``: the mass uncertainty that sets the force-ball radius."""
        return 0.5 * (self.high_kg - self.low_kg)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@runtime_checkable
class MassEstimator(Protocol):
    """Anything that turns a task description and an image into a :class:`MassEstimate`."""

    name: str

    def estimate(self, description: str | None, image: ImageInput | None) -> MassEstimate:
        """Estimate the payload mass; raise :class:`EstimationError` when it cannot."""
        ...


# --------------------------------------------------------------------------------------------
# Images
# --------------------------------------------------------------------------------------------

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


def image_bytes(image: ImageInput) -> tuple[bytes, str]:
    """The encoded bytes and MIME type of ``image``.

    Files are sent as they are (PNG, JPEG, WebP, GIF, recognised by suffix or magic bytes); a
    numpy array (H x W grey, H x W x 3 RGB or H x W x 4 RGBA; uint8 or floats in [0, 1]) is
    encoded to PNG with matplotlib.
    """
    if isinstance(image, np.ndarray):
        return _encode_array(image), "image/png"
    path = Path(image)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InvalidInputError(f"image {str(path)!r}: cannot be read ({exc.strerror or exc})") from exc
    mime = _MIME_BY_SUFFIX.get(path.suffix.lower())
    if mime is None:
        mime = next((m for magic, m in _MAGIC if data.startswith(magic)), None)
    if mime is None and data[:4] == b"RIFF" and data[8:12] == b"WEBP":
        mime = "image/webp"
    if mime is None:
        raise InvalidInputError(f"image {str(path)!r}: expected a PNG, JPEG, WebP or GIF file")
    if not data:
        raise InvalidInputError(f"image {str(path)!r}: the file is empty")
    return data, mime


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


# --------------------------------------------------------------------------------------------
# User-given mass
# --------------------------------------------------------------------------------------------


def user_estimate(mass: float) -> MassEstimate:
    """A mass given by the user, taken as exact (``low = mass = high``)."""
    m = float(as_positive(mass, "mass"))
    return MassEstimate(m, m, m, "user", "mass given explicitly")


# --------------------------------------------------------------------------------------------
# Offline estimator: stated quantities and a density table
# --------------------------------------------------------------------------------------------

#: Mass units -> kg.
MASS_UNITS: dict[str, float] = {
    "mg": 1e-6,
    "g": 1e-3, "gr": 1e-3, "gram": 1e-3, "grams": 1e-3, "gramme": 1e-3, "grammes": 1e-3,
    "kg": 1.0, "kgs": 1.0, "kilo": 1.0, "kilos": 1.0, "kilogram": 1.0, "kilograms": 1.0,
    "lb": 0.45359237, "lbs": 0.45359237, "pound": 0.45359237, "pounds": 0.45359237,
    "oz": 0.028349523125, "ounce": 0.028349523125, "ounces": 0.028349523125,
}  # fmt: skip
#: Volume units -> litres.
VOLUME_UNITS: dict[str, float] = {
    "ml": 1e-3, "millilitre": 1e-3, "millilitres": 1e-3, "milliliter": 1e-3, "milliliters": 1e-3,
    "cc": 1e-3, "cl": 1e-2, "dl": 0.1,
    "l": 1.0, "litre": 1.0, "litres": 1.0, "liter": 1.0, "liters": 1.0, "ltr": 1.0,
    "fl oz": 0.0295735295625, "gal": 3.785411784, "gallon": 3.785411784, "gallons": 3.785411784,
}  # fmt: skip


@dataclass(frozen=True)
class Density:
    """Density of a liquid (kg/L), with the range used as its uncertainty."""

    keywords: tuple[str, ...]
    kg_per_l: float
    low: float
    high: float


#: Densities near 20 C, first match wins; the last row is the fallback for unnamed contents.
DENSITIES: tuple[Density, ...] = (
    Density(("honey",), 1.42, 1.38, 1.45),
    Density(("syrup",), 1.33, 1.25, 1.37),
    Density(("oil",), 0.92, 0.91, 0.93),
    Density(("milk", "yogurt", "yoghurt"), 1.03, 1.02, 1.04),
    Density(("juice",), 1.05, 1.03, 1.07),
    Density(("soda", "cola", "coke", "lemonade", "soft drink", "tonic"), 1.04, 1.00, 1.05),
    Density(("beer",), 1.01, 1.00, 1.02),
    Density(("wine",), 0.99, 0.98, 1.00),
    Density(("detergent", "soap", "shampoo"), 1.03, 1.00, 1.10),
    Density(("water",), 1.00, 0.997, 1.003),
    Density(("beverage", "drink", "liquid"), 1.02, 0.99, 1.05),
    Density((), 1.00, 0.50, 1.50),  # unknown contents, e.g. "a 2 L box"
)


@dataclass(frozen=True)
class Container:
    """Container mass as a fraction of its contents' mass, with the range used as uncertainty."""

    keywords: tuple[str, ...]
    fraction: float
    low: float
    high: float
    holds_drink: bool = False  # unnamed contents of a bottle or can are taken as a beverage


#: Typical packaging: 15 g can for 330 g of drink, 30-40 g PET per 1.5 L, 0.5 kg glass per 0.75 L.
CONTAINERS: tuple[Container, ...] = (
    Container(("glass bottle", "wine bottle", "beer bottle"), 0.60, 0.40, 0.80, True),
    Container(("glass jar", "jar"), 0.40, 0.25, 0.60),
    Container(("can", "cans", "tin", "tins"), 0.045, 0.03, 0.06, True),
    Container(("bottle", "bottles", "pet"), 0.025, 0.015, 0.05, True),
    Container(("carton", "cartons", "tetra", "pouch"), 0.03, 0.02, 0.05, True),
    Container(("jug", "jugs", "jerrycan", "canister", "gallon"), 0.05, 0.03, 0.08, True),
    Container((), 0.03, 0.0, 0.10),  # container not named
)

#: Count words before a quantity ("two 1.5 L bottles", "a six-pack of 330 mL cans").
COUNT_WORDS: dict[str, int] = {
    "a": 1, "an": 1, "one": 1, "single": 1, "two": 2, "pair of": 2, "a pair of": 2, "couple of": 2,
    "a couple of": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8,
    "nine": 9, "ten": 10, "eleven": 11, "twelve": 12, "dozen": 12, "a dozen": 12,
    "six-pack of": 6, "a six-pack of": 6, "four-pack of": 4, "a four-pack of": 4,
}  # fmt: skip
#: Words that widen the interval of the quantity they precede (stated values are approximate).
HEDGES = ("about", "approximately", "approx", "around", "roughly", "nearly", "almost", "~", "ca.", "circa")
#: Relative half-width of a stated mass, and of any hedged quantity.
STATED_MASS_TOLERANCE = 0.05
HEDGE_TOLERANCE = 0.20

_UNIT_ALT = "|".join(
    sorted(
        (re.escape(u).replace(r"\ ", r"\s*") for u in {**MASS_UNITS, **VOLUME_UNITS}), key=len, reverse=True
    )
)
_COUNT_ALT = "|".join(sorted((re.escape(w) for w in COUNT_WORDS), key=len, reverse=True))
_QUANTITY = re.compile(
    rf"(?:(?P<nx>\d+)\s*[x×*]\s*|\b(?P<word>{_COUNT_ALT})\s+)?"
    rf"(?P<num>\d+(?:\.\d+)?|\.\d+)\s*-?\s*(?P<unit>{_UNIT_ALT})(?![a-z])",
    re.IGNORECASE,
)
_CLAUSE_END = re.compile(r"[.;,:()]|\band\b|\bwith\b|\bplus\b", re.IGNORECASE)


def _has_word(text: str, keywords: tuple[str, ...]) -> str | None:
    for kw in keywords:
        if re.search(rf"(?<![a-z]){re.escape(kw)}(?![a-z])", text):
            return kw
    return None


@dataclass(frozen=True)
class Quantity:
    """One stated quantity: ``count`` items of ``value`` ``unit`` each, and its mass interval."""

    text: str
    count: int
    mass_kg: float
    low_kg: float
    high_kg: float
    explanation: str


def parse_quantities(description: str) -> list[Quantity]:
    """Every mass or volume stated in ``description`` converted to a mass interval.

    * stated mass ``m`` (g, kg, lb, oz): ``[m (1 - 0.05), m (1 + 0.05)]``;
    * stated volume ``V`` (mL, cL, L, fl oz, gal): contents ``V rho`` with ``rho`` and its range
      from :data:`DENSITIES` (keyword after the quantity, else the whole description, else a
      beverage for a bottle, can, carton or jug, else 1 kg/L within [0.5, 1.5]), plus a
      container ``c V rho`` from :data:`CONTAINERS`, i.e. ``m = V rho (1 + c)`` with
      ``low = V rho_low (1 + c_low)`` and ``high = V rho_high (1 + c_high)``;
    * a count before the quantity ("two", "3 x", "a six-pack of") multiplies everything;
    * a hedge before it ("about 2 kg") widens the interval to at least +-20 %.
    """
    text = description.lower()
    matches = list(_QUANTITY.finditer(text))
    out: list[Quantity] = []
    for i, match in enumerate(matches):
        count = (
            int(match["nx"]) if match["nx"] else COUNT_WORDS.get(re.sub(r"\s+", " ", match["word"] or "a"), 1)
        )
        if count <= 0:
            continue
        value = float(match["num"])
        unit = re.sub(r"\s+", " ", match["unit"])
        # the words describing this quantity: up to the next quantity or the end of the clause
        stop = matches[i + 1].start() if i + 1 < len(matches) else len(text)
        tail = text[match.end() : stop]
        end = _CLAUSE_END.search(tail)
        context = tail[: end.start()] if end else tail
        before = text[max(0, match.start() - 16) : match.start()]
        hedged = any(h in before for h in HEDGES)
        if unit in MASS_UNITS:
            m = value * MASS_UNITS[unit]
            tol = HEDGE_TOLERANCE if hedged else STATED_MASS_TOLERANCE
            low, high = m * (1 - tol), m * (1 + tol)
            why = f"{value:g} {unit} stated"
        else:
            litres = value * VOLUME_UNITS[unit]
            dens = next(d for d in DENSITIES if not d.keywords or _has_word(context, d.keywords))
            if not dens.keywords:  # nothing named right after the quantity: look at the whole text
                dens = next(d for d in DENSITIES if not d.keywords or _has_word(text, d.keywords))
            cont = next(c for c in CONTAINERS if not c.keywords or _has_word(context, c.keywords))
            if not dens.keywords and cont.holds_drink:
                dens = next(d for d in DENSITIES if "beverage" in d.keywords)
            m = litres * dens.kg_per_l * (1 + cont.fraction)
            low = litres * dens.low * (1 + cont.low)
            high = litres * dens.high * (1 + cont.high)
            if hedged:
                low, high = min(low, m * (1 - HEDGE_TOLERANCE)), max(high, m * (1 + HEDGE_TOLERANCE))
            what = dens.keywords[0] if dens.keywords else "contents of unknown density"
            box = (
                f"{cont.keywords[0]} +{cont.fraction:.1%}"
                if cont.keywords
                else f"container +{cont.fraction:.0%}"
            )
            why = f"{value:g} {unit} {what} ({dens.kg_per_l:g} kg/L), {box}"
        prefix = f"{count} x " if count > 1 else ""
        out.append(
            Quantity(match.group(0).strip(), count, count * m, count * low, count * high, prefix + why)
        )
    return out


class OfflineEstimator:
    """Payload mass from quantities stated in the description; the image is not used.

    The estimate is the sum over the stated quantities (see :func:`parse_quantities`) and so is
    its interval. When nothing can be inferred it refuses with :class:`EstimationError` rather
    than guess.
    """

    name = "offline"
    version = "quantity-table-v1"

    def estimate(self, description: str | None, image: ImageInput | None = None) -> MassEstimate:
        if not description or not description.strip():
            raise EstimationError(
                "the offline estimator needs a task description with a stated quantity "
                "(e.g. 'two 1.5 L bottles'); give the mass with --mass or configure a VLM"
            )
        quantities = parse_quantities(description)
        if not quantities:
            raise EstimationError(
                f"no mass or volume stated in the description {description!r} (looked for g, kg, lb, "
                "oz, mL, L, fl oz, gal); give the mass with --mass or configure a VLM (--vlm-base-url)"
            )
        mass = sum(q.mass_kg for q in quantities)
        low = sum(q.low_kg for q in quantities)
        high = sum(q.high_kg for q in quantities)
        if not MIN_MASS_KG <= mass <= MAX_MASS_KG:
            raise EstimationError(
                f"the stated quantities add up to {mass:g} kg, outside the plausible payload range "
                f"[{MIN_MASS_KG:g}, {MAX_MASS_KG:g}] kg; give the mass with --mass"
            )
        rationale = "; ".join(q.explanation for q in quantities)
        return MassEstimate(mass, low, high, f"{self.name}:{self.version}", rationale)


# --------------------------------------------------------------------------------------------
# VLM estimator
# --------------------------------------------------------------------------------------------

SYSTEM_PROMPT = (
    "You are the perception module of a mobile manipulator. From the task description and the "
    "image, estimate the mass in kilograms of the payload the robot's end effector will carry: "
    "the manipulated objects and their contents and packaging, not the robot, its gripper, "
    "basket or tray, nor the table. Think about the objects' size, material and fill level. "
    "Answer with JSON only: mass_kg (best estimate), low_kg and high_kg (a plausible range with "
    "low_kg <= mass_kg <= high_kg), object (what you think is carried) and rationale (one short "
    "sentence)."
)

#: JSON schema of the answer (strict structured output).
ANSWER_SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {
        "object": {"type": "string"},
        "mass_kg": {"type": "number"},
        "low_kg": {"type": "number"},
        "high_kg": {"type": "number"},
        "rationale": {"type": "string"},
    },
    "required": ["object", "mass_kg", "low_kg", "high_kg", "rationale"],
    "additionalProperties": False,
}
RESPONSE_FORMAT: dict[str, Any] = {
    "type": "json_schema",
    "json_schema": {"name": "payload_mass", "strict": True, "schema": ANSWER_SCHEMA},
}
DEFAULT_DESCRIPTION = "Carry the object shown in the image."
_PLACEHOLDER_KEY = "unused"  # local servers (Ollama, vLLM) accept any key but the client needs one


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/forte/vlm`` (``~/.cache/forte/vlm`` by default)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "forte" / "vlm"


@dataclass(frozen=True)
class VLMConfig:
    """How to reach an OpenAI-compatible chat-completions server.

    Attributes:
        base_url: server root including ``/v1`` (OpenAI, ``http://localhost:11434/v1`` for Ollama,
            ``http://host:8000/v1`` for vLLM).
        model: model name (the paper uses ``gpt-4o``).
        api_key_env: name of the environment variable holding the key; the key itself is never
            stored here, logged or cached. When the variable is unset a placeholder is sent, which
            local servers accept; ``api.openai.com`` then fails with a clear error.
        timeout_s: per-request timeout.
        max_retries: retries after the first attempt on HTTP 429, 5xx, timeouts and connection
            errors; other failures are not retried.
        backoff_base_s, backoff_max_s: the wait before retry ``k`` (0-based) is
            ``min(backoff_max_s, backoff_base_s 2^k)``, or the server's ``Retry-After`` if longer.
        max_tokens: cap on the answer length (``None`` to leave it to the server).
    """

    base_url: str = "https://api.openai.com/v1"
    model: str = "gpt-4o"
    api_key_env: str = "OPENAI_API_KEY"
    timeout_s: float = 60.0
    max_retries: int = 3
    backoff_base_s: float = 1.0
    backoff_max_s: float = 30.0
    max_tokens: int | None = 300

    def __post_init__(self) -> None:
        url = urlparse(self.base_url)
        if url.scheme not in ("http", "https") or not url.netloc:
            raise InvalidInputError(f"base_url: expected an http(s) URL, got {self.base_url!r}")
        if not self.model.strip():
            raise InvalidInputError("model: expected a model name, got an empty string")
        if not (math.isfinite(self.timeout_s) and self.timeout_s > 0):
            raise InvalidInputError(
                f"timeout_s: expected a positive number of seconds, got {self.timeout_s!r}"
            )
        if self.max_retries < 0:
            raise InvalidInputError(f"max_retries: expected >= 0, got {self.max_retries!r}")
        if self.backoff_base_s < 0 or self.backoff_max_s < 0:
            raise InvalidInputError("backoff_base_s, backoff_max_s: expected >= 0 seconds")

    def backoff(self, attempt: int) -> float:
        """Seconds to wait before retry ``attempt`` (0-based): ``min(max, base 2^attempt)``."""
        return min(self.backoff_max_s, self.backoff_base_s * 2.0**attempt)


def cache_key(image_sha256: str, description: str, model: str) -> str:
    """sha256 over the prompt version, the model, the description and the image's sha256."""
    payload = json.dumps([PROMPT_VERSION, model, description, image_sha256], ensure_ascii=True)
    return hashlib.sha256(payload.encode("utf-8")).hexdigest()


def _float_field(answer: dict[str, Any], name: str) -> float:
    if name not in answer:
        raise EstimationError(f"VLM answer: field {name!r} is missing (got fields {sorted(answer)})")
    value = answer[name]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise EstimationError(f"VLM answer: {name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise EstimationError(f"VLM answer: {name} must be finite, got {value!r}")
    if value <= 0:
        raise EstimationError(f"VLM answer: {name} must be positive, got {value!r} kg")
    if not MIN_MASS_KG <= value <= MAX_MASS_KG:
        raise EstimationError(
            f"VLM answer: {name} = {value!r} kg is outside the plausible payload range "
            f"[{MIN_MASS_KG:g}, {MAX_MASS_KG:g}] kg"
        )
    return value


def parse_answer(content: str | None, source: str) -> MassEstimate:
    """Validate the model's JSON answer and turn it into a :class:`MassEstimate`.

    Raises:
        EstimationError: content not a JSON object, a field missing or not a finite number, a
            mass not positive or outside [MIN_MASS_KG, MAX_MASS_KG], or not low <= mass <= high.
    """
    if not content or not content.strip():
        raise EstimationError("VLM answer: empty content")
    # servers that ignore the schema (some Ollama models) may wrap the JSON in a markdown fence
    fenced = re.fullmatch(r"\s*```(?:json)?\s*(.*?)\s*```\s*", content, re.DOTALL)
    if fenced:
        content = fenced.group(1)
    try:
        answer = json.loads(content)
    except json.JSONDecodeError as exc:
        snippet = content[:80].replace("\n", " ")
        raise EstimationError(
            f"VLM answer: not valid JSON ({exc.msg} at char {exc.pos}): {snippet!r}"
        ) from exc
    if not isinstance(answer, dict):
        raise EstimationError(f"VLM answer: expected a JSON object, got {type(answer).__name__}")
    mass, low, high = (_float_field(answer, k) for k in ("mass_kg", "low_kg", "high_kg"))
    if not low <= mass <= high:
        raise EstimationError(
            f"VLM answer: expected low_kg <= mass_kg <= high_kg, got {low!r}, {mass!r}, {high!r}"
        )
    obj = str(answer.get("object", "")).strip()
    why = str(answer.get("rationale", "")).strip()
    rationale = f"{obj}: {why}" if obj and why else obj or why
    return MassEstimate(mass, low, high, source, rationale[:500])


def _redact(text: str, secret: str | None) -> str:
    return text.replace(secret, "***") if secret else text


@dataclass
class VLMEstimator:
    """Payload mass from an OpenAI-compatible vision chat model (the paper's ``Phi_VLM(I, D)``).

    One request per (image, description, model): the image goes as a base64 data URL, the
    answer is constrained by :data:`RESPONSE_FORMAT` at temperature 0 and validated with
    :func:`parse_answer`. Valid answers are cached under ``cache_dir`` as
    ``<cache_key>.json``; invalid answers are neither retried nor cached. The client's own
    retries are disabled so that the retry policy is the one of :class:`VLMConfig`.
    """

    config: VLMConfig
    cache_dir: Path | None = None
    sleep: Callable[[float], None] = field(default=time.sleep, repr=False)
    name: str = "vlm"

    def __post_init__(self) -> None:
        import openai  # deferred: only a VLM run needs it

        self._openai = openai
        key = os.environ.get(self.config.api_key_env, "")
        host = urlparse(self.config.base_url).hostname or ""
        if not key and host.endswith("openai.com"):
            raise EstimationError(
                f"no API key: set the environment variable {self.config.api_key_env} "
                f"(or choose another one with --api-key-env)"
            )
        self._key = key or None
        self._client = openai.OpenAI(
            api_key=key or _PLACEHOLDER_KEY,
            base_url=self.config.base_url,
            timeout=self.config.timeout_s,
            max_retries=0,
        )

    @property
    def source(self) -> str:
        return f"{self.name}:{self.config.model}"

    def estimate(self, description: str | None, image: ImageInput | None) -> MassEstimate:
        text = (description or "").strip() or DEFAULT_DESCRIPTION
        if image is None and not (description and description.strip()):
            raise InvalidInputError("give an image, a description or both")
        data, mime = image_bytes(image) if image is not None else (b"", "")
        key = cache_key(hashlib.sha256(data).hexdigest(), text, self.config.model)
        cached = self._cache_read(key)
        if cached is not None:
            return cached
        content: list[dict[str, Any]] = [{"type": "text", "text": f"Task description: {text}"}]
        if data:
            content.append({"type": "image_url", "image_url": {"url": data_url(data, mime)}})
        messages = [{"role": "system", "content": SYSTEM_PROMPT}, {"role": "user", "content": content}]
        answer = self._request(messages)
        estimate = parse_answer(answer, self.source)
        self._cache_write(key, estimate, text)
        return estimate

    def _request(self, messages: list[dict[str, Any]]) -> str | None:
        oa = self._openai
        extra: dict[str, Any] = {}
        if self.config.max_tokens is not None:
            extra["max_tokens"] = self.config.max_tokens
        attempts = self.config.max_retries + 1
        last = ""
        for attempt in range(attempts):
            try:
                response = self._client.chat.completions.create(
                    model=self.config.model,
                    messages=messages,  # type: ignore[arg-type]
                    temperature=0,
                    response_format=RESPONSE_FORMAT,  # type: ignore[arg-type]
                    **extra,
                )
            except (
                oa.RateLimitError,
                oa.InternalServerError,
                oa.APITimeoutError,
                oa.APIConnectionError,
            ) as exc:
                last = self._describe(exc)
                if attempt + 1 >= attempts:
                    break
                wait = max(self.config.backoff(attempt), self._retry_after(exc))
                log.warning(
                    "VLM request %d/%d failed (%s); retrying in %.3g s", attempt + 1, attempts, last, wait
                )
                self.sleep(wait)
                continue
            except oa.APIStatusError as exc:  # 400, 401, 404 ...: retrying cannot help
                raise EstimationError(f"VLM server {self.config.base_url}: {self._describe(exc)}") from None
            except oa.OpenAIError as exc:
                raise EstimationError(f"VLM request failed: {self._describe(exc)}") from None
            return self._content(response)
        raise EstimationError(
            f"VLM server {self.config.base_url}: no valid response after {attempts} attempt(s), last: {last}"
        )

    def _content(self, response: Any) -> str | None:
        try:
            choice = response.choices[0]
        except (AttributeError, IndexError, TypeError):
            raise EstimationError("VLM answer: the response has no choices") from None
        if choice.finish_reason == "length":
            raise EstimationError("VLM answer: truncated (finish_reason 'length'); raise max_tokens")
        refusal = getattr(choice.message, "refusal", None)
        if refusal:
            raise EstimationError(f"VLM refused: {str(refusal)[:200]}")
        return choice.message.content

    def _describe(self, exc: Exception) -> str:
        oa = self._openai
        if isinstance(exc, oa.APITimeoutError):
            text = f"timed out after {self.config.timeout_s:g} s"
        elif isinstance(exc, oa.APIStatusError):
            text = f"HTTP {exc.status_code}: {str(exc.message)[:200]}"
        elif isinstance(exc, oa.APIConnectionError):
            text = f"connection failed ({exc.__cause__ or exc})"
        else:
            text = f"{type(exc).__name__}: {str(exc)[:200]}"
        return _redact(text, self._key)  # servers may echo the key in error messages

    @staticmethod
    def _retry_after(exc: Exception) -> float:
        response = getattr(exc, "response", None)
        value = response.headers.get("retry-after") if response is not None else None
        try:
            return max(0.0, float(value)) if value is not None else 0.0
        except ValueError:
            return 0.0

    # -- cache --------------------------------------------------------------------------------

    def _cache_path(self, key: str) -> Path | None:
        return None if self.cache_dir is None else Path(self.cache_dir) / f"{key}.json"

    def _cache_read(self, key: str) -> MassEstimate | None:
        path = self._cache_path(key)
        if path is None or not path.is_file():
            return None
        try:
            entry = json.loads(path.read_text(encoding="utf-8"))
            est = entry["estimate"]
            result = MassEstimate(
                float(est["mass_kg"]), float(est["low_kg"]), float(est["high_kg"]),
                str(est["source"]), str(est.get("rationale", "")), cached=True,
            )  # fmt: skip
        except (OSError, ValueError, KeyError, TypeError, EstimationError) as exc:
            log.warning("ignoring unreadable cache entry %s (%s)", path, exc)
            return None
        log.info("VLM estimate for cache key %s read from %s", key[:12], path)
        return result

    def _cache_write(self, key: str, estimate: MassEstimate, description: str) -> None:
        path = self._cache_path(key)
        if path is None:
            return
        # only public facts go to disk: never the key, nor the name of its variable's value
        entry = {
            "prompt_version": PROMPT_VERSION,
            "model": self.config.model,
            "description": description,
            "estimate": {k: v for k, v in estimate.to_dict().items() if k != "cached"},
        }
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            # write then rename, so concurrent workers never read a half-written entry
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".json")
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                json.dump(entry, fh, indent=2)
            os.replace(tmp, path)
        except OSError as exc:
            log.warning("could not write the VLM cache entry %s (%s)", path, exc)


# --------------------------------------------------------------------------------------------
# Entry points
# --------------------------------------------------------------------------------------------


def estimate_payload(
    description: str | None,
    image: ImageInput | None,
    mass: float | None = None,
    vlm: VLMConfig | None = None,
    cache_dir: Path | None = None,
) -> MassEstimate:
    """The payload mass to use for the task force.

    Priority: an explicit ``mass`` (source ``user``) always wins; otherwise the VLM when ``vlm``
    is given (answers cached under ``cache_dir`` when given); otherwise the offline estimator.

    Raises:
        EstimationError: no estimate could be obtained or the answer failed validation.
        InvalidInputError: a non-positive ``mass`` or an unreadable image.
    """
    if mass is not None:
        return user_estimate(mass)
    if vlm is not None:
        return VLMEstimator(vlm, cache_dir).estimate(description, image)
    return OfflineEstimator().estimate(description, image)


def radius_from_estimate(acc: Any, estimate: MassEstimate, r_min: float = DEFAULT_R_MIN) -> FloatArray:
    """Force-ball radii from the mass interval: ``r_k = max(r_min, |a_k - g| (high - low) / 2)``.

    The task force is ``f_k = m (a_k - g)`` with ``g = [0, 0, -9.81]``, so a mass known to within
    ``+-(high - low) / 2`` moves ``f_k`` by at most ``|a_k - g| (high - low) / 2``; ``r_min``
    (10 N in the paper) keeps the margin for everything else (model error, contacts). With a
    user-given mass the interval is empty and ``r_k = r_min``.

    Args:
        acc: end-effector accelerations, N x 3 (m/s^2, world frame).
        estimate: the mass estimate.
        r_min: floor of the radius (N), >= 0.
    """
    a = as_array(acc, "acc", (None, 3))
    floor = float(as_positive(r_min, "r_min", allow_zero=True))
    return np.maximum(floor, np.linalg.norm(a - GRAVITY, axis=1) * estimate.half_width_kg)
