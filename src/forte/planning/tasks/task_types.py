"""The words of :mod:`forte.planning.tasks.task_fields`: a field's type (its words on the reference page,
its JSON Schema fragment, its allowed range in words), the field itself, and the types, units and
variants that several of its sections share."""

from __future__ import annotations

from typing import Any, NamedTuple

from forte.validation import MAX_DURATION_S, MAX_MASS_KG


class Prose(str):
    """A default said in words (the reference page shows it; the JSON Schema gives none)."""


class Type(NamedTuple):
    """A field's type: ``words`` (the page), ``schema`` (a JSON Schema fragment), ``range`` (words)."""

    words: str
    schema: dict[str, Any]
    range: str = ""


class Field(NamedTuple):
    """One field of a task file (see :mod:`forte.planning.tasks.task_fields` for ``path`` and ``when``)."""

    path: str
    type: Type
    doc: str
    unit: str = ""
    default: Any = None  # a value (the JSON Schema's default) or a Prose note; None: no default
    required: bool = False
    when: tuple[str, str] | None = None
    needs: tuple[str, ...] = ()  # sibling fields this one requires

    @property
    def parent(self) -> str:
        """The mapping that holds the field (``""``: the top level; ``a[]``: the items of list ``a``)."""
        return self.path.rpartition(".")[0]

    @property
    def name(self) -> str:
        return self.path.rpartition(".")[2]


def _g(x: float) -> str:
    return f"{x:g}"


def number(low: float | None = None, high: float | None = None, above: float | None = None,
           below: float | None = None) -> Type:
    """A finite number, ``>= low`` or ``> above``, ``<= high`` or ``< below``."""
    schema: dict[str, Any] = {"type": "number"}
    words = []
    for key, bound, sign in (("minimum", low, ">="), ("exclusiveMinimum", above, ">"),
                             ("maximum", high, "<="), ("exclusiveMaximum", below, "<")):
        if bound is not None:
            schema[key] = bound
            words.append(f"{sign} {_g(bound)}")
    return Type("number", schema, ", ".join(words))


def integer(low: int, high: int) -> Type:
    return Type("integer", {"type": "integer", "minimum": low, "maximum": high}, f"{low} to {high:g}")


BOOL = Type("true or false", {"type": "boolean"})
STRING = Type("string", {"type": "string"})
MAPPING = Type("mapping", {"type": "object"})
ROTATION = Type("mapping", {"type": "object", "anyOf": [{"required": ["rpy"]}, {"required": ["quaternion"]},
                                                       {"required": ["matrix"]}]}, "rpy, quaternion or matrix")


def choice(values: tuple[str, ...] | list[str]) -> Type:
    return Type("string", {"enum": list(values)}, ", ".join(values))


def vector(size: int | None = None, low: float | None = None, high: float | None = None,
           above: float | None = None, of: Type | None = None, norm: float | None = None) -> Type:
    """A list of ``size`` (``None``: any number of) numbers in the bounds, or of ``of``'s values;
    ``norm``: a length of at most ``norm`` (the schema bounds each entry by it)."""
    item = of or number(low if norm is None else -norm, high if norm is None else norm, above)
    schema: dict[str, Any] = {"type": "array", "items": item.schema}
    if size is not None:
        schema |= {"minItems": size, "maxItems": size}
    what = "numbers" if of is None else f"{of.words}s"
    words = f"list of {size} {what}" if size else f"list of {what}"
    if norm is not None:
        return Type(words, schema, f"length <= {_g(norm)}")
    return Type(words, schema, f"each {item.range}" if item.range else "")


def matrix(rows: int, cols: int) -> Type:
    row = vector(cols)
    return Type(f"{rows} x {cols} matrix", {"type": "array", "items": row.schema, "minItems": rows, "maxItems": rows})


INERTIA = Type("3 numbers or a 3 x 3 matrix", {"anyOf": [vector(3).schema, matrix(3, 3).schema]},
               "principal moments or the matrix")


def nullable(t: Type) -> Type:
    schema = dict(t.schema)
    if isinstance(schema.get("type"), str) and "anyOf" not in schema and "enum" not in schema:
        schema["type"] = [schema["type"], "null"]
    else:
        schema = {"anyOf": [schema, {"type": "null"}]}
    return Type(f"{t.words} or null", schema, t.range)


def either(*types: Type) -> Type:
    return Type(" or ".join(t.words for t in types), {"anyOf": [t.schema for t in types]},
                "; ".join(t.range for t in types if t.range))


def items_of(min_items: int | None = None, exactly_one: tuple[str, ...] = ()) -> Type:
    """A list of mappings (their fields are ``LIST[].FIELD``); ``exactly_one``: keys of which each
    item holds exactly one."""
    item: dict[str, Any] = {"type": "object"}
    if exactly_one:
        item["oneOf"] = [{"required": [k]} for k in exactly_one]
    schema: dict[str, Any] = {"type": "array", "items": item}
    words = []
    if min_items:
        schema["minItems"] = min_items
        words.append(f"at least {min_items}")
    if exactly_one:
        words.append(f"each with one of {', '.join(exactly_one)}")
    return Type("list of mappings", schema, "; ".join(words))


def joint_values(above: float | None = None, low: float | None = None) -> Type:
    """One number per joint: a list in the robot's order, or ``{joint name: value}``."""
    by_name = Type("mapping", {"type": "object", "additionalProperties": number(low, None, above).schema},
                   "joint name: value")
    return either(vector(low=low, above=above), by_name)


# -- shared by the sections of task_fields (path_fields, world_fields, task_fields) --------------
MASS = number(above=0, high=MAX_MASS_KG)
DURATION = number(above=0, high=MAX_DURATION_S)
VEC3 = vector(3)
ZERO3 = [0.0, 0.0, 0.0]
PER_ARM = "one per arm joint"
PER_DOF = "x, y, yaw, then one per arm joint"
#: The windowed-sine variant (of ``path`` and of ``force``).
SINE = ("kind", "windowed-sine")
