"""What the VLM is asked (system prompt, answer schema) and how its answer is validated.

As in the authors' setup, the model lists every object of the payload, occluded ones included,
each with description, material, mass_kg, mass_kg_range = [low, high], confidence and occluded;
the total is summed here (:meth:`~forte.force.estimate.MassEstimate.from_objects`), never taken
from the model, and the request runs at temperature 0. The older single-object answer
(``object``, ``mass_kg``, ``low_kg``, ``high_kg``, ``rationale``) is still accepted.
"""

from __future__ import annotations

import json
import math
import re
from typing import Any

from forte.exceptions import EstimationError
from forte.force.mass import CONFIDENCE_LEVELS, MAX_MASS_KG, MIN_MASS_KG, MassEstimate, ObjectEstimate

#: Bumped whenever the prompt or the answer schema changes; part of every cache key.
PROMPT_VERSION = "forte-payload-mass-v2"

SYSTEM_PROMPT = (
    "You are the perception module of a mobile manipulator. From the task description and the "
    "image, list every object that makes up the payload the robot's end effector will carry: every "
    "object in the image and in its basket, bag or box, including objects partly or fully hidden "
    "behind others (reason from the visible layers, fill levels and the container's size about "
    "what is occluded). Count each instance separately. When the description does not single out "
    "objects, count every object in the image. A filled container is one object: its contents plus "
    "its packaging. Do not list the robot, its gripper, the basket or tray it carries things in, "
    "the table or the floor. For each object think about its size, material and fill level, then "
    "give: description (what it is and its size), material, mass_kg (best estimate in kilograms), "
    "mass_kg_range ([low, high] with low <= mass_kg <= high), confidence (low, medium or high) and "
    "occluded (true when it is not fully visible). Do not add the masses up: the total is computed "
    "from your list. Answer with JSON only, with the list as objects and one short sentence as "
    "reasoning."
)

_OBJECT_SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {
        "description": {"type": "string"},
        "material": {"type": "string"},
        "mass_kg": {"type": "number"},
        # two numbers; length limits are left out of the schema (strict mode rejects them) and checked here
        "mass_kg_range": {"type": "array", "items": {"type": "number"}},
        "confidence": {"type": "string", "enum": list(CONFIDENCE_LEVELS)},
        "occluded": {"type": "boolean"},
    },
    "required": ["description", "material", "mass_kg", "mass_kg_range", "confidence", "occluded"],
    "additionalProperties": False,
}
#: JSON schema of the answer (strict structured output): the objects, no total.
ANSWER_SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {"objects": {"type": "array", "items": _OBJECT_SCHEMA}, "reasoning": {"type": "string"}},
    "required": ["objects", "reasoning"],
    "additionalProperties": False,
}
RESPONSE_FORMAT: dict[str, Any] = {
    "type": "json_schema",
    "json_schema": {"name": "payload_objects", "strict": True, "schema": ANSWER_SCHEMA},
}
DEFAULT_DESCRIPTION = "Carry the objects shown in the image."
_OBJECT_FIELDS = tuple(_OBJECT_SCHEMA["required"])


def parse_answer(content: str | None, source: str) -> MassEstimate:
    """Validate the model's JSON answer and turn it into a :class:`MassEstimate`.

    An answer with ``objects`` is summed with :meth:`MassEstimate.from_objects` (a total given by
    the model is ignored); an answer without is read as the single-object shape.

    Raises:
        EstimationError: one line naming the offending field: content not a JSON object, a
            field missing or of the wrong type, a mass not positive and finite, a range not
            ``[low, high]`` around the mass, or a total outside [MIN_MASS_KG, MAX_MASS_KG].
    """
    answer = _decode(content)
    if "objects" not in answer:
        return _single_object(answer, source)
    objects = answer["objects"]
    if not isinstance(objects, list) or not objects:
        raise EstimationError(f"VLM answer: objects: expected a non-empty list of objects, got {_show(objects)}")
    parsed = [_parse_object(obj, i) for i, obj in enumerate(objects)]
    estimate = MassEstimate.from_objects(parsed, source, _rationale(parsed, answer.get("reasoning")))
    if not MIN_MASS_KG <= estimate.mass_kg <= MAX_MASS_KG:
        raise EstimationError(
            f"VLM answer: the objects add up to {estimate.mass_kg:g} kg, outside the plausible payload "
            f"range [{MIN_MASS_KG:g}, {MAX_MASS_KG:g}] kg"
        )
    return estimate


def _decode(content: str | None) -> dict[str, Any]:
    """The JSON object in ``content`` (a markdown fence around it is tolerated)."""
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
        raise EstimationError(f"VLM answer: not valid JSON ({exc.msg} at char {exc.pos}): {snippet!r}") from exc
    if not isinstance(answer, dict):
        raise EstimationError(f"VLM answer: expected a JSON object, got {type(answer).__name__}")
    return answer


def _show(value: Any) -> str:
    """A short one-line rendering of a bad value for an error message."""
    text = json.dumps(value) if not isinstance(value, float) or math.isfinite(value) else repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise EstimationError(f"VLM answer: {where} must be a number, got {_show(value)}")
    if not math.isfinite(value):
        raise EstimationError(f"VLM answer: {where} must be finite, got {value!r}")
    if value <= 0:
        raise EstimationError(f"VLM answer: {where} must be positive, got {value!r} kg")
    return float(value)


def _parse_object(obj: Any, i: int) -> ObjectEstimate:
    """One entry of ``objects``, every field checked; errors name ``objects[i].field``."""
    where = f"objects[{i}]"
    if not isinstance(obj, dict):
        raise EstimationError(f"VLM answer: {where}: expected an object, got {_show(obj)}")
    missing = [name for name in _OBJECT_FIELDS if name not in obj]
    if missing:
        raise EstimationError(f"VLM answer: {where}: field {missing[0]!r} is missing (got fields {sorted(obj)})")
    for name in ("description", "material"):
        if not isinstance(obj[name], str):
            raise EstimationError(f"VLM answer: {where}.{name} must be a string, got {_show(obj[name])}")
    mass = _number(obj["mass_kg"], f"{where}.mass_kg")
    bounds = obj["mass_kg_range"]
    if not isinstance(bounds, list) or len(bounds) != 2:
        raise EstimationError(f"VLM answer: {where}.mass_kg_range must be [low, high], got {_show(bounds)}")
    low, high = (_number(b, f"{where}.mass_kg_range") for b in bounds)
    if not low <= mass <= high:
        raise EstimationError(
            f"VLM answer: {where}: expected mass_kg_range[0] <= mass_kg <= mass_kg_range[1], "
            f"got {low!r} <= {mass!r} <= {high!r}"
        )
    confidence = obj["confidence"].strip().lower() if isinstance(obj["confidence"], str) else obj["confidence"]
    if confidence not in CONFIDENCE_LEVELS:
        raise EstimationError(f"VLM answer: {where}.confidence must be low, medium or high, got {_show(confidence)}")
    if not isinstance(obj["occluded"], bool):
        raise EstimationError(f"VLM answer: {where}.occluded must be true or false, got {_show(obj['occluded'])}")
    return ObjectEstimate(obj["description"].strip(), obj["material"].strip(), mass, low, high, confidence,
                          obj["occluded"])  # fmt: skip


def _rationale(objects: list[ObjectEstimate], reasoning: Any) -> str:
    """``desc (m kg[, occluded]); ... - reasoning``, capped at 500 characters."""
    listed = "; ".join(f"{o.description} ({o.mass_kg:.3g} kg{', occluded' if o.occluded else ''})" for o in objects)
    why = str(reasoning or "").strip()
    return (f"{listed} - {why}" if why else listed)[:500]


def _float_field(answer: dict[str, Any], name: str) -> float:
    if name not in answer:
        raise EstimationError(f"VLM answer: field {name!r} is missing (got fields {sorted(answer)})")
    value = _number(answer[name], name)
    if not MIN_MASS_KG <= value <= MAX_MASS_KG:
        raise EstimationError(
            f"VLM answer: {name} = {value!r} kg is outside the plausible payload range "
            f"[{MIN_MASS_KG:g}, {MAX_MASS_KG:g}] kg"
        )
    return value


def _single_object(answer: dict[str, Any], source: str) -> MassEstimate:
    """The single-object answer of prompt v1: ``object``, ``mass_kg``, ``low_kg``, ``high_kg``, ``rationale``."""
    mass, low, high = (_float_field(answer, k) for k in ("mass_kg", "low_kg", "high_kg"))
    if not low <= mass <= high:
        raise EstimationError(f"VLM answer: expected low_kg <= mass_kg <= high_kg, got {low!r}, {mass!r}, {high!r}")
    obj = str(answer.get("object", "")).strip()
    why = str(answer.get("rationale", "")).strip()
    rationale = f"{obj}: {why}" if obj and why else obj or why
    single = ObjectEstimate(obj or "payload", "", mass, low, high)
    return MassEstimate(mass, low, high, source, rationale[:500], objects=(single,))
