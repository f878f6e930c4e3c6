"""The registry of swept parameters: every key of a study's grid, derived from the schema.

A study can sweep every numeric, boolean or enumerated key of the ``model``, ``solver`` and
``analysis`` sections (``sweep: {model.cage_stiffness: [1e4, 1e5], solver.dt: [...]}``); a
model key may also be written without its section (``clearance``, ``mu``, ``omega0``, ``e_N``,
``cage_stiffness``). Nothing here lists keys: the registry reads them from the configuration
schema, so a key added to the schema can be swept with no code. For each key it gives what the
files need (:class:`Parameter`):

- ``name``: the coordinate, dimension and file-name token of the axis: the key itself for a
  model key (``clearance``, ``cage_stiffness``), ``solver_<key>`` and ``analysis_<key>``
  otherwise (CF names have no dots); ``model.contact_model`` is the study's ``model`` axis;
- ``units`` (UDUNITS) and ``long_name``, from the key's description in the schema, whose first
  bracket holds the unit (``"cage spring stiffness between neighbouring balls [N/m]"``);
- for an enumerated or boolean key (``model.bearing``: the catalogue's names,
  :func:`with_data_names`), its ``categories``: coordinates store the category's
  position (int8) with CF ``flag_values``/``flag_meanings``; file names carry the category.

:func:`sweep_properties` turns the registry into the ``sweep`` section of the schema, so that
a sweep is validated by the same rules as the key it sweeps.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, Iterable, Mapping

#: sections whose keys can be swept, in the order of a study's axes
SECTIONS = ("model", "solver", "analysis")
#: the paper's four study parameters: axes of every study (length 1 where not swept)
BASE_AXES = ("model.clearance", "model.mu", "model.omega0", "model.e_N")
#: coordinate names that differ from the rule of :func:`coordinate_name`
SPECIAL_NAMES = {"model.contact_model": "model"}
#: keys refused as sweep axes, and why (in the message): keys that a study sets itself, and
#: settings that users reach for as an axis although they are not in the registry (the schema
#: refuses those; its error gives the reason here)
NOT_SWEPT = {
    "model.contact_model": "every grid point runs with each model of study.models",
    "solver.output_dt": "the study sets it (a nonsmooth run writes every step, its compliant "
                        "twin every nonsmooth step)",
}
#: longest file name a run gets before its tail is replaced by a hash [characters]
MAX_NAME = 200

_UNIT_WORDS = {"-": "1", "revolutions": "1", "revolution": "1"}


@dataclass(frozen=True)
class Parameter:
    """One sweepable key and how the files carry it."""

    key: str                          # "model.cage_stiffness"
    name: str                         # coordinate / dimension / file-name token
    long_name: str
    units: str | None                 # UDUNITS; None for categories
    kind: str                         # "number", "integer" or "category"
    categories: tuple = field(default=())   # allowed values of a category (code = position)

    @property
    def section(self) -> str:
        return self.key.split(".", 1)[0]

    @property
    def setting(self) -> str:
        """The key within its section (``cage_stiffness``)."""
        return self.key.split(".", 1)[1]

    def plain(self, value):
        """``value`` as the configuration holds it (float, int, str or bool); a category's
        value not among its categories, or a non-whole number of an integer key, raises
        ValueError."""
        if self.kind == "category":
            for category in self.categories:
                if category == value and type(category) is type(value):
                    return category
            raise ValueError(f"sweep.{self.key}: {value!r} is not allowed; allowed: one of "
                             + ", ".join(repr(c) for c in self.categories))
        if self.kind == "integer":
            number = int(value)
            if not isinstance(value, str) and float(value) != number:  # not cut to 8 from 8.5
                raise ValueError(f"sweep.{self.key}: {float(value)!r} is not allowed; allowed: a "
                                 "whole number")
            return number
        return tidy(value)

    def code(self, value) -> int:
        """Position of a category value (its coordinate value)."""
        return self.categories.index(self.plain(value))

    def token(self, value) -> str:
        """``name~value`` for a file name: a number as Python writes the rounded float
        (``clearance~0.0004``, ``cage_stiffness~100000.0``), an integer as an integer, a
        category by its value; characters outside ``[A-Za-z0-9.+-]`` are %-escaped."""
        value = self.plain(value)
        text = str(value).lower() if isinstance(value, bool) else str(value)
        safe = re.sub(r"[^A-Za-z0-9.+\-]", lambda m: "%{:02X}".format(ord(m.group())), text)
        return f"{self.name}~{safe}"

    def attrs(self) -> dict:
        """CF attributes of the coordinate."""
        if self.kind == "category":
            meanings = " ".join(str(c).lower() if isinstance(c, bool) else str(c)
                                for c in self.categories)
            import numpy as np

            return {"units": "1", "long_name": self.long_name,
                    "flag_values": np.arange(len(self.categories), dtype=np.int8),
                    "flag_meanings": meanings, "sweep_key": self.key}
        return {"units": self.units, "long_name": self.long_name, "sweep_key": self.key}

    def stored(self, value):
        """The coordinate value: the float, the integer, or the category's int8 code."""
        import numpy as np

        if self.kind == "category":
            return np.int8(self.code(value))
        if self.kind == "integer":
            return np.int64(self.plain(value))
        return float(self.plain(value))


def tidy(value) -> float:
    """A number rounded to 10 significant digits: file names carry no float noise
    (``0.30000000000000004`` -> ``0.3``)."""
    return float(f"{float(value):.10g}")


def coordinate_name(key: str) -> str:
    """The coordinate name of ``section.key``: the key for a model key, ``section_key``
    otherwise (see :data:`SPECIAL_NAMES`)."""
    if key in SPECIAL_NAMES:
        return SPECIAL_NAMES[key]
    section, name = key.split(".", 1)
    return name if section == "model" else f"{section}_{name}"


def udunits(text: str) -> str:
    """A unit as the schema's descriptions write it (``N s/m``, ``m/s^2``, ``kg m^2``, ``-``)
    in UDUNITS form (``N s m-1``, ``m s-2``, ``kg m2``, ``1``)."""
    text = text.strip()
    if text in _UNIT_WORDS:
        return _UNIT_WORDS[text]
    numerator, _, denominator = text.partition("/")
    parts = []
    for sign, group in ((1, numerator), (-1, denominator)):
        for token in group.split():
            base, _, power = token.partition("^")
            exponent = sign * (float(power) if power else 1.0)
            if not re.fullmatch(r"[A-Za-z]+", base):
                raise ValueError(f"unit {text!r}: cannot read {token!r}")
            written = f"{exponent:g}" if exponent != 1 else ""
            parts.append(f"{base}{written}")
    return " ".join(parts) or "1"


_UNIT = re.compile(r"\[([^\[\]]+)\]")


def _describe(key: str, node: Mapping[str, Any], kind: str) -> tuple[str, str | None]:
    """(long_name, units) of a schema property: ``title`` if given, else the description up
    to its first unit bracket (or its first ``;``); units from that bracket (``1`` without)."""
    text = " ".join(str(node.get("description", "")).split())
    units = None
    match = None
    for candidate in _UNIT.finditer(text):
        try:
            units = udunits(candidate.group(1))
        except ValueError:
            continue
        match = candidate
        break
    if match is not None:
        long_name = text[:match.start()]
    else:
        long_name = text.split(";")[0]
    long_name = str(node.get("title") or long_name).strip(" ,:;.")
    if kind == "category":
        enum = node.get("enum", ())
        if not long_name or any(long_name.startswith(f"{v}:") for v in enum):
            long_name = key.split(".", 1)[1].replace("_", " ")
        return long_name, None
    if not long_name:
        long_name = key.split(".", 1)[1].replace("_", " ")
    return long_name, units or "1"


def _types(node: Mapping[str, Any]) -> set:
    """JSON types a schema property accepts (through ``type``, ``enum``, ``oneOf``/``anyOf``)."""
    kinds = set()
    declared = node.get("type")
    if isinstance(declared, str):
        kinds.add(declared)
    elif isinstance(declared, list):
        kinds.update(declared)
    for value in node.get("enum", ()):
        kinds.add({bool: "boolean", int: "integer", float: "number", str: "string",
                   type(None): "null"}.get(type(value), "other"))
    for branch in list(node.get("oneOf", ())) + list(node.get("anyOf", ())):
        kinds |= _types(branch)
    return kinds


def _kind(node: Mapping[str, Any]) -> str | None:
    """number, integer, category, or None (not sweepable: arrays, free strings, objects)."""
    kinds = _types(node) - {"null"}
    if not kinds:
        return None
    if kinds <= {"number", "integer"}:
        return "integer" if kinds == {"integer"} else "number"
    if "enum" in node and kinds <= {"string", "boolean", "integer", "number"}:
        return "category"
    if kinds == {"boolean"}:
        return "category"
    return None


def build_registry(schema: Mapping[str, Any]) -> dict[str, Parameter]:
    """Every sweepable key of ``schema`` (sections :data:`SECTIONS`), in schema order.

    Raises
    ------
    ValueError
        When two keys would get the same coordinate name (a schema that needs a new rule).
    """
    out: dict[str, Parameter] = {}
    names: dict[str, str] = {}
    for section in SECTIONS:
        props = schema["properties"][section].get("properties", {})
        for field_name, node in props.items():
            kind = _kind(node)
            if kind is None:
                continue
            key = f"{section}.{field_name}"
            long_name, units = _describe(key, node, kind)
            categories = ()
            if kind == "category":
                categories = tuple(node.get("enum", (False, True)))
            name = coordinate_name(key)
            if name in names:
                raise ValueError(f"sweep keys {names[name]} and {key} share the coordinate "
                                 f"name {name!r}")
            names[name] = key
            out[key] = Parameter(key, name, long_name, units, kind, categories)
    return out


def with_data_names(schema: dict) -> dict:
    """``schema`` (changed in place) with the names the package's data define as the
    enumeration of the key that takes them: the bearing catalogue's entries
    (``simcore/data/bearings.yaml``, in its order) for ``model.bearing``, which is thus checked
    and swept like any enumerated key."""
    from ..model.bearing import catalogue

    schema["properties"]["model"]["properties"]["bearing"]["enum"] = list(catalogue())
    return schema


@lru_cache(maxsize=1)
def _registry_of_file(path: str, stamp: float) -> dict[str, Parameter]:
    with open(path, encoding="utf-8") as fh:
        return build_registry(with_data_names(json.load(fh)))


def registry() -> dict[str, Parameter]:
    """The registry of the package's schema (``simcore/config/schema/config.schema.json``)."""
    from . import SCHEMA_PATH

    return _registry_of_file(str(SCHEMA_PATH), SCHEMA_PATH.stat().st_mtime)


def canonical(key: str, params: Mapping[str, Parameter] | None = None) -> str | None:
    """``section.key`` of a sweep key, a short model key or a coordinate name (None if none)."""
    params = registry() if params is None else params
    if key in params:
        return key
    if f"model.{key}" in params:
        return f"model.{key}"
    for parameter in params.values():
        if parameter.name == key:
            return parameter.key
    return None


def parameter(key: str) -> Parameter:
    """The :class:`Parameter` of a sweep key, short model key or coordinate name.

    Raises
    ------
    KeyError
        For a key that is not a sweepable key of the schema.
    """
    params = registry()
    full = canonical(key, params)
    if full is None:
        raise KeyError(key)
    return params[full]


def sweep_properties(schema: Mapping[str, Any]) -> dict:
    """The ``properties`` of the schema's ``sweep`` section: for every sweepable key, as
    ``section.key`` and (model keys) as its short name, a non-empty list whose items are
    validated by the key's own schema (``$ref``), without null."""
    props = {}
    for key, param in build_registry(schema).items():
        section, name = key.split(".", 1)
        items = {"allOf": [{"$ref": f"#/properties/{section}/properties/{name}"},
                           {"not": {"type": "null"}}]}
        entry = {"type": "array", "minItems": 1, "items": items,
                 "description": f"values of {key} ({param.long_name})"}
        props[key] = entry
        if section == "model":
            props[name] = dict(entry, description=f"short for {key}")
    return props


def sweep_axes(sweep: Mapping[str, Iterable]) -> dict[str, list]:
    """The swept keys of a validated ``sweep`` section as ``{section.key: values}``, in the
    registry's order; values as the configuration holds them.

    Raises
    ------
    ValueError
        One line naming the key: a key given twice (short and long), a key the study sets
        itself (:data:`NOT_SWEPT`), a value given twice (after rounding to 10 significant
        digits).
    """
    params = registry()
    given: dict[str, tuple[str, list]] = {}
    for written, values in sweep.items():
        key = canonical(written, params)
        if key is None:
            raise ValueError(f"sweep.{written}: unknown key; allowed: a numeric, boolean or "
                             "enumerated key of model, solver or analysis (section.key, or a "
                             "model key alone)")
        if key in given:
            raise ValueError(f"sweep.{written}: the same key as sweep.{given[key][0]}; allowed: "
                             "each key once")
        if key in NOT_SWEPT:
            raise ValueError(f"sweep.{written}: not allowed as a sweep axis: "
                             f"{NOT_SWEPT[key]}")
        given[key] = (written, list(values))
    axes = {}
    for key, param in params.items():
        if key not in given:
            continue
        written, values = given[key]
        plain = [param.plain(v) for v in values]
        seen = set()
        for value in plain:
            marker = (type(value), value)
            if marker in seen:
                raise ValueError(f"sweep.{written}: {values!r} holds the same value twice "
                                 "(after rounding to 10 significant digits); allowed: "
                                 "distinct values")
            seen.add(marker)
        axes[key] = plain
    return axes


def run_name(point: Mapping[str, Any]) -> str:
    """File name (without ``.nc``) of a grid point ``{section.key: value}``: its tokens
    joined by ``_`` in the point's order, e.g. ``clearance~0.0004_mu~0.01_omega0~50.0_e_N~0.9``.
    A name longer than :data:`MAX_NAME` characters keeps its first part and ends with a hash
    of the whole: unique, and short enough for every file system."""
    params = registry()
    name = "_".join(params[key].token(value) for key, value in point.items())
    if len(name) > MAX_NAME:
        digest = hashlib.sha1(name.encode()).hexdigest()[:16]
        name = f"{name[:MAX_NAME - 18]}_h{digest}"
    return name
