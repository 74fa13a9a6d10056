"""What a task description says about the payload's mass, read with small documented tables.

* stated quantities ("two 1.5 L bottles", "a 2 kg dumbbell"): a stated mass is taken as it is, a
  stated volume becomes contents times density plus packaging (:data:`DENSITIES`,
  :data:`CONTAINERS`), see :func:`parse_quantities`;
* named objects of a known class with their count ("four apples", "the dumbbell"): a typical
  mass per item from :data:`ITEM_CLASSES`, see :func:`parse_items`.

Every result carries an interval that states its uncertainty.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

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
    span: tuple[int, int] = (0, 0)  # characters of the description that describe it


def states_mass(description: str) -> bool:
    """True when ``description`` states a mass (g, kg, lb, oz ...), which would give the answer away."""
    return any(re.sub(r"\s+", " ", m["unit"]) in MASS_UNITS for m in _QUANTITY.finditer(description.lower()))


def parse_quantities(description: str, stated_masses: bool = True) -> list[Quantity]:
    """Every mass or volume stated in ``description`` converted to a mass interval.

    * stated mass ``m`` (g, kg, lb, oz): ``[m (1 - 0.05), m (1 + 0.05)]``;
    * stated volume ``V`` (mL, cL, L, fl oz, gal): contents ``V rho`` with ``rho`` and its range
      from :data:`DENSITIES` (keyword after the quantity, else the whole description, else a
      beverage for a bottle, can, carton or jug, else 1 kg/L within [0.5, 1.5]), plus a
      container ``c V rho`` from :data:`CONTAINERS`, i.e. ``m = V rho (1 + c)`` with
      ``low = V rho_low (1 + c_low)`` and ``high = V rho_high (1 + c_high)``;
    * a count before the quantity ("two", "3 x", "a six-pack of") multiplies everything;
    * a hedge before it ("about 2 kg") widens the interval to at least +-20 %;
    * with ``stated_masses=False`` stated masses are skipped as if absent (a benchmark whose
      descriptions state the answer would otherwise score the reading of it).
    """
    text = description.lower()
    matches = [
        m for m in _QUANTITY.finditer(text) if stated_masses or re.sub(r"\s+", " ", m["unit"]) not in MASS_UNITS
    ]
    out: list[Quantity] = []
    for i, match in enumerate(matches):
        count = _count(match)
        if count <= 0 or float(match["num"]) <= 0:
            continue
        # the words describing this quantity: up to the next quantity or the end of the clause
        stop = matches[i + 1].start() if i + 1 < len(matches) else len(text)
        tail = text[match.end() : stop]
        end = _CLAUSE_END.search(tail)
        context = tail[: end.start()] if end else tail
        hedged = any(h in text[max(0, match.start() - 16) : match.start()] for h in HEDGES)
        value, unit = float(match["num"]), re.sub(r"\s+", " ", match["unit"])
        if unit in MASS_UNITS:
            m, low, high, why = _stated_mass(value, unit, hedged)
        else:
            m, low, high, why = _stated_volume(value, unit, context, text, hedged)
        prefix = f"{count} x " if count > 1 else ""
        span = (match.start(), match.end() + len(context))
        out.append(Quantity(match.group(0).strip(), count, count * m, count * low, count * high, prefix + why, span))
    return out


def _count(match: re.Match[str]) -> int:
    """The count before a quantity: digits before ``x``, a count word, else one."""
    if match["nx"]:
        return int(match["nx"])
    return COUNT_WORDS.get(re.sub(r"\s+", " ", match["word"] or "a"), 1)


def _stated_mass(value: float, unit: str, hedged: bool) -> tuple[float, float, float, str]:
    """A stated mass and its interval, +-5 % (+-20 % when hedged)."""
    m = value * MASS_UNITS[unit]
    tol = HEDGE_TOLERANCE if hedged else STATED_MASS_TOLERANCE
    return m, m * (1 - tol), m * (1 + tol), f"{value:g} {unit} stated"


def _stated_volume(
    value: float, unit: str, context: str, text: str, hedged: bool
) -> tuple[float, float, float, str]:
    """Contents ``V rho`` plus the container ``c V rho``, with their intervals (see parse_quantities)."""
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
    box = f"{cont.keywords[0]} +{cont.fraction:.1%}" if cont.keywords else f"container +{cont.fraction:.0%}"
    return m, low, high, f"{value:g} {unit} {what} ({dens.kg_per_l:g} kg/L), {box}"


@dataclass(frozen=True)
class ItemClass:
    """Typical mass of one item of a class (kg), with the range of common sizes as uncertainty."""

    singular: tuple[str, ...]
    plural: tuple[str, ...]
    kg: float
    low: float
    high: float


#: Typical retail items; only classes whose name pins the mass to a factor of a few. Bottles,
#: cans and boxes are left out: without a stated volume their mass spans orders of magnitude.
ITEM_CLASSES: tuple[ItemClass, ...] = (
    ItemClass(("apple",), ("apples",), 0.18, 0.10, 0.30),
    ItemClass(("orange",), ("oranges",), 0.15, 0.10, 0.25),
    ItemClass(("banana",), ("bananas",), 0.12, 0.08, 0.20),
    ItemClass(("egg",), ("eggs",), 0.06, 0.045, 0.075),
    ItemClass(("book",), ("books",), 0.5, 0.15, 1.5),
    ItemClass(("laptop",), ("laptops",), 1.8, 1.0, 3.0),
    ItemClass(("mug",), ("mugs",), 0.3, 0.2, 0.5),
    ItemClass(("smartphone", "phone"), ("smartphones", "phones"), 0.19, 0.13, 0.25),
    ItemClass(("brick",), ("bricks",), 2.5, 1.8, 3.5),
    ItemClass(("dumbbell",), ("dumbbells",), 5.0, 1.0, 20.0),
    ItemClass(("bag of rice", "rice bag"), ("bags of rice", "rice bags"), 1.0, 0.5, 5.0),
    ItemClass(("bag of flour", "flour bag"), ("bags of flour", "flour bags"), 1.0, 0.5, 2.5),
    ItemClass(("bag of sugar", "sugar bag"), ("bags of sugar", "sugar bags"), 1.0, 0.5, 2.0),
)

#: A count right before a noun, up to two words in between ("four red apples", "3 small books").
_COUNT_BEFORE = re.compile(rf"(?:(?<![\d.])(?P<num>\d+)|\b(?P<word>{_COUNT_ALT}))\s+(?:[\w.-]+\s+){{0,2}}$")


def parse_items(description: str, exclude: list[tuple[int, int]] | None = None) -> list[Quantity]:
    """Every named object of a class in :data:`ITEM_CLASSES`, with its count, as a mass interval.

    ``n`` items of a class weigh ``n kg`` within ``[n low, n high]``. The count is the number or
    count word up to two words before the name ("four red apples", "3 x" is a stated quantity);
    a singular name without a count is one item; a plural name without a count is skipped (it
    says nothing about how many). Names inside ``exclude`` (the spans of stated quantities,
    "a 500 g book") are skipped so that nothing is counted twice.
    """
    text = description.lower()
    taken = list(exclude or [])
    out: list[Quantity] = []
    for cls in ITEM_CLASSES:
        names = [(n, False) for n in cls.singular] + [(n, True) for n in cls.plural]
        for name, plural in sorted(names, key=lambda x: -len(x[0])):  # "bags of rice" before "bag of rice"
            for match in re.finditer(rf"(?<![a-z]){re.escape(name)}(?![a-z])", text):
                if any(a < match.end() and match.start() < b for a, b in taken):
                    continue
                count = _count_before(text[max(0, match.start() - 40) : match.start()])
                if count is None and plural:
                    continue
                n = count or 1
                taken.append(match.span())
                why = f"{n} x {cls.singular[0]}" if n > 1 else cls.singular[0]
                why += f" (typical {cls.kg:g} kg, {cls.low:g}-{cls.high:g} kg each)"
                out.append(Quantity(match.group(0), n, n * cls.kg, n * cls.low, n * cls.high, why, match.span()))
    return sorted(out, key=lambda q: q.span)


def _count_before(window: str) -> int | None:
    """The count that ends ``window`` (the text before a name), or None."""
    match = _COUNT_BEFORE.search(window)
    if match is None:
        return None
    if match["num"]:
        return int(match["num"])
    return COUNT_WORDS[re.sub(r"\s+", " ", match["word"])]
