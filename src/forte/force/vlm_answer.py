"""What the VLM is asked (system prompt, answer schema) and how its answer is validated."""

from __future__ import annotations

import json
import math
import re
from typing import Any

from forte.exceptions import EstimationError
from forte.force.estimate import MAX_MASS_KG, MIN_MASS_KG, MassEstimate

#: Bumped whenever the prompt or the answer schema changes; part of every cache key.
PROMPT_VERSION = "forte-payload-mass-v1"

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
