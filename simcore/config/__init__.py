"""Configuration: one JSON schema for runs and the study, defaults, overrides, clear errors.

The schema (``simcore/config/schema/config.schema.json``) is the single source of the keys, their
defaults, units and allowed ranges; the Snakemake workflow validates against the same file.
"""

from __future__ import annotations

import copy
import json
import math
import re
import warnings
from functools import lru_cache
from pathlib import Path
from typing import Any, Iterable, Mapping

import yaml

SCHEMA_PATH = Path(__file__).parent / "schema" / "config.schema.json"


# Limits of what a configuration may be: a config is a few dozen numbers, so anything far
# bigger is a mistake or an attack, refused before it can cost time or memory.
MAX_FILE_BYTES = 1_000_000   # size of a configuration file
MAX_DEPTH = 8                # nesting of mappings and lists (the schema needs 3)
MAX_SCALAR_CHARS = 1000      # length of one value (a number, a name, a path)
MAX_ITEMS = 10_000           # entries of one mapping or list

# Magnitudes of the model's numbers (SI units): a nonzero value outside these bounds is refused
# in one line, before products such as m L^2, k / m or E sqrt(R) can overflow or underflow in
# the model's construction (a ball of 1e-300 kg, a rod of 1e308 m).
MIN_MAGNITUDE = 1e-30
MAX_MAGNITUDE = 1e30


class ConfigError(ValueError):
    """A configuration value is missing, unknown or out of range; the message names the key."""


class _Loader(yaml.SafeLoader):
    """SafeLoader for configurations.

    - reads ``1.0e5`` as a float (YAML 1.2), not as the string PyYAML makes;
    - refuses anchors and aliases (a few hundred bytes of aliases expand to billions of nodes);
    - refuses a key given twice in one mapping (PyYAML keeps the last one silently);
    - bounds the nesting depth, the length of a value and the number of items of a collection.
    """

    def compose_node(self, parent, index):
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None) is not None:
            raise ConfigError(f"line {event.start_mark.line + 1}: YAML anchors and aliases "
                              "(&name, *name) are not allowed in a configuration")
        if isinstance(event, yaml.ScalarEvent) and len(event.value) > MAX_SCALAR_CHARS:
            raise ConfigError(f"line {event.start_mark.line + 1}: a value of "
                              f"{len(event.value)} characters is not allowed; allowed: at most "
                              f"{MAX_SCALAR_CHARS}")
        depth = getattr(self, "_depth", 0)
        if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            if depth >= MAX_DEPTH:
                raise ConfigError(f"line {event.start_mark.line + 1}: nesting deeper than "
                                  f"{MAX_DEPTH} levels is not allowed in a configuration")
            self._depth = depth + 1
            try:
                node = super().compose_node(parent, index)
            finally:
                self._depth = depth
            if len(node.value) > MAX_ITEMS:
                raise ConfigError(f"line {event.start_mark.line + 1}: a collection of "
                                  f"{len(node.value)} items is not allowed; allowed: at most "
                                  f"{MAX_ITEMS}")
            return node
        return super().compose_node(parent, index)

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            try:
                duplicate = key in seen
            except TypeError:  # an unhashable key: PyYAML says so itself
                break
            if duplicate:
                raise ConfigError(f"line {key_node.start_mark.line + 1}: key {key!r} is given "
                                  "twice in the same mapping")
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
        |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
        |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
        |[-+]?\.(?:inf|Inf|INF)
        |\.(?:nan|NaN|NAN))$""",
        re.X,
    ),
    list("-+0123456789."),
)


def _yaml_problem(exc: yaml.YAMLError) -> str:
    """A YAML error in one line: what is wrong and where."""
    problem = getattr(exc, "problem", None) or getattr(exc, "context", None)
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    text = str(problem) if problem else str(exc)
    if mark is not None:
        text = f"line {mark.line + 1}, column {mark.column + 1}: {text}"
    return " ".join(text.split())


def parse_yaml_text(text: str):
    """Parse YAML text with the configuration loader.

    Raises
    ------
    ConfigError
        For anchors/aliases, duplicate keys, too deep nesting, too long values and YAML syntax
        errors, in one line (without the file name; the caller adds where the text came from).
    """
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506  (_Loader is a SafeLoader)
    except yaml.YAMLError as exc:
        raise ConfigError(_yaml_problem(exc)) from None
    except RecursionError:
        raise ConfigError(f"nesting deeper than {MAX_DEPTH} levels is not allowed") from None


def read_yaml(path: str | Path):
    """Read a YAML configuration file: UTF-8, at most ``MAX_FILE_BYTES``, with the safety rules
    of the configuration loader (no aliases, no duplicate keys, bounded depth and values) and
    floats such as ``1.0e5`` understood as numbers.

    Raises
    ------
    OSError
        When the file cannot be read.
    ConfigError
        One line naming the file and the problem.
    """
    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"--config: {path} is a directory, not a YAML file")
    with open(path, "rb") as fh:
        raw = fh.read(MAX_FILE_BYTES + 1)
    if len(raw) > MAX_FILE_BYTES:
        raise ConfigError(f"--config: {path} is larger than {MAX_FILE_BYTES} bytes; a "
                          "configuration is a few dozen keys")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"--config: {path} is not UTF-8 text (byte {exc.start}: "
                          f"0x{raw[exc.start]:02x})") from None
    if "\x00" in text:
        raise ConfigError(f"--config: {path} is a binary file (it holds NUL bytes), not YAML")
    try:
        return parse_yaml_text(text)
    except ConfigError as exc:
        raise ConfigError(f"--config: {path}: {exc}") from None


def load_schema() -> dict:
    """Return the configuration JSON schema as a dict, with the bearing catalogue's names
    (:func:`simcore.config.parameters.with_data_names`) and the ``sweep`` section's keys
    generated from the model, solver and analysis sections
    (:func:`simcore.config.parameters.sweep_properties`)."""
    from .parameters import sweep_properties, with_data_names

    with open(SCHEMA_PATH, encoding="utf-8") as fh:
        schema = with_data_names(json.load(fh))
    schema["properties"]["sweep"]["properties"] = sweep_properties(schema)
    return schema


def schema_default(section: str, key: str):
    """The default of the setting ``section.key`` as the schema gives it (e.g.
    ``schema_default("model", "bearing")``)."""
    return load_schema()["properties"][section]["properties"][key]["default"]


@lru_cache(maxsize=None)
def _setting_validator(key: str):
    """The validator of the schema node of the setting ``key`` (``section.name``), and the
    node; KeyError for a key the schema lacks."""
    import jsonschema

    root = load_schema()
    section, name = key.split(".", 1)
    node = _resolve(root["properties"][section]["properties"][name], root)
    return jsonschema.Draft7Validator(node), node


def check_setting(key: str, value):
    """``value`` of the setting ``key`` (``section.name``) as a configuration holds it, checked
    against the schema as a configuration's value is: a NumPy scalar as a Python one, then as
    :func:`_coerce_scalars` stores it (a whole float of an integer key as an int, 0 and 1 of a
    boolean key as false and true).

    Raises
    ------
    ConfigError
        Naming the key and what the schema allows, for a value the schema refuses or one that
        is not finite.
    """
    validator, node = _setting_validator(key)
    plain = value.item() if type(value).__module__ == "numpy" else value
    _check_finite(plain, key)
    plain = _coerced(node, plain)
    if not validator.is_valid(plain):
        raise ConfigError(f"{key}: {plain!r} is not allowed; allowed: {_allowed(node)}")
    return plain


def check_section(section: str, values: Mapping[str, Any]) -> dict:
    """The settings ``values`` of the configuration section ``section`` (``"model"``, ...),
    each checked and stored by :func:`check_setting`; a key the section lacks is refused.
    The checks that need several keys at once are the whole configuration's
    (:func:`validate_config`).

    Raises
    ------
    ConfigError
        Naming the first offending key and what is allowed.
    """
    checked = {}
    for key, value in values.items():
        try:
            checked[key] = check_setting(f"{section}.{key}", value)
        except KeyError:
            allowed = sorted(load_schema()["properties"][section]["properties"])
            raise ConfigError(_unknown_key(f"{section}.{key}", allowed)) from None
    return checked


def _unknown_key(name: str, allowed: Iterable[str]) -> str:
    """The message that refuses the key ``name`` (as written, with its section) where only
    the keys ``allowed`` are."""
    return f"{name}: unknown key; allowed keys here: " + ", ".join(allowed)


def _list_words(schema: Mapping[str, Any]) -> str:
    """What a list node of the schema allows, in words ("a list of 1 to 4 distinct names")."""
    lo, hi = schema.get("minItems"), schema.get("maxItems")
    items = schema.get("items", {})
    what = {"string": "names", "number": "numbers", "integer": "integers"}.get(
        items.get("type"), "values")
    distinct = "distinct " if schema.get("uniqueItems") else ""
    of = (" from " + ", ".join(_yaml_value(v) for v in items["enum"])) if "enum" in items else ""
    if lo is not None and hi is not None:
        return f"a list of {lo} to {hi} {distinct}{what}{of}"
    return f"a {'non-empty ' if lo else ''}list of {distinct}{what}{of}"


def _yaml_value(value) -> str:
    """A schema's allowed value as a YAML file or ``--set`` writes it: ``null``, ``true``,
    ``'C3'`` (not Python's ``None``, ``True``)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def _allowed(schema: Mapping[str, Any]) -> str:
    """Describe in words what a schema node allows (for one-line error messages)."""
    if "enum" in schema:
        return "one of " + ", ".join(_yaml_value(v) for v in schema["enum"])
    parts = []
    kind = schema.get("type")
    if kind in ("number", "integer"):
        parts.append("an integer" if kind == "integer" else "a number")
    elif kind == "array" or kind == ["array", "null"]:
        parts.append(("null or " if kind != "array" else "") + _list_words(schema))
    elif kind is not None:
        parts.append(f"a {kind}" if isinstance(kind, str) else "one of types " + "/".join(kind))
    lo, xlo = schema.get("minimum"), schema.get("exclusiveMinimum")
    hi, xhi = schema.get("maximum"), schema.get("exclusiveMaximum")
    left = f"[{lo}" if lo is not None else (f"({xlo}" if xlo is not None else None)
    right = f"{hi}]" if hi is not None else (f"{xhi})" if xhi is not None else None)
    if left and right:
        parts.append(f"in {left}, {right}")
    elif left:
        parts.append(("> " if left[0] == "(" else ">= ") + left[1:])
    elif right:
        parts.append(("< " if right[-1] == ")" else "<= ") + right[:-1])
    if "pattern" in schema:  # the schema's words for what the pattern asks
        parts.append(f"({schema.get('description', 'matching ' + schema['pattern'])})")
    return " ".join(parts) if parts else "see the schema"


def _resolve(schema: Mapping[str, Any], root: Mapping[str, Any]) -> Mapping[str, Any]:
    ref = schema.get("$ref")
    if ref is None:
        return schema
    node: Any = root
    for part in ref.lstrip("#/").split("/"):
        node = node[part]
    return node


def _fill_defaults(config: dict, schema: Mapping[str, Any]) -> None:
    for key, sub in schema.get("properties", {}).items():
        if key not in config and "default" in sub:
            config[key] = copy.deepcopy(sub["default"])
        if isinstance(config.get(key), dict) and sub.get("type") == "object":
            _fill_defaults(config[key], sub)


def _is_setting(name: str, root: Mapping[str, Any]) -> bool:
    """Whether ``name`` (``section.key``, or a ``model`` key alone) is a key of the
    configuration's sections."""
    section, _, key = name.rpartition(".")
    props = root.get("properties", {}).get(section or "model", {}).get("properties", {})
    return key in props


def _format_error(error, root: Mapping[str, Any]) -> str:
    path = ".".join(str(p) for p in error.absolute_path) or "<config>"
    if error.validator == "additionalProperties":
        allowed = sorted(error.schema.get("properties", {}))
        # keys of any type (a YAML mapping may have numbers as keys): compared as given,
        # sorted by their text
        extra = sorted((k for k in error.instance if k not in allowed), key=str)
        where = path + "." if path != "<config>" else ""
        if path == "sweep":
            from .parameters import NOT_SWEPT

            name = str(extra[0]) if "." in str(extra[0]) else f"model.{extra[0]}"
            if name in NOT_SWEPT:
                return f"sweep.{extra[0]}: not allowed as a sweep axis: {NOT_SWEPT[name]}"
            what = ("not allowed as a sweep axis (a setting that is not a number, a boolean or "
                    "one of a set of names)" if _is_setting(str(extra[0]), root)
                    else "unknown key")
            return (f"sweep.{extra[0]}: {what}; allowed: a numeric, boolean or enumerated "
                    "key of model, solver or analysis as section.key (e.g. "
                    "model.cage_stiffness, solver.dt), or a model key alone (e.g. clearance)")
        return _unknown_key(f"{where}{extra[0]}", allowed)
    node = _resolve(error.schema, root)
    value = error.instance
    return f"{path}: {value!r} is not allowed; allowed: {_allowed(node)}"


def validate_config(config: Mapping[str, Any]) -> dict:
    """Fill defaults and validate a configuration.

    Parameters
    ----------
    config : mapping
        Possibly partial configuration (sections ``model``, ``solver``, ``sweep``, ``analysis``,
        ``study``).

    Returns
    -------
    dict
        A new, complete configuration.

    Raises
    ------
    ConfigError
        With a one-line message naming the first offending key and what is allowed.
    """
    import jsonschema

    schema = load_schema()
    if not isinstance(config, Mapping):
        raise ConfigError("<config>: the configuration must be a mapping of sections")
    cfg = copy.deepcopy(dict(config))
    given = cfg.get("model")
    explicit = set(given) if isinstance(given, Mapping) else set()  # (before the defaults)
    _fill_defaults(cfg, schema)
    _coerce_scalars(cfg, schema)
    _check_finite(cfg, "")
    validator = jsonschema.Draft7Validator(schema)
    errors = sorted(validator.iter_errors(cfg), key=lambda e: (len(e.absolute_path), str(e.path)))
    if errors:
        raise ConfigError(_format_error(errors[0], schema))
    _check_bearing_sweep(cfg, explicit)
    _resolve_bearing(cfg, explicit)
    _check_magnitudes(cfg)
    _check_consistency(cfg)
    return cfg


def _check_bearing_sweep(cfg: Mapping[str, Any], explicit: set) -> None:
    """Refuse a model key that a catalogue entry sets (radii, ball count, masses, groove
    conformities) given or swept beside a sweep of ``model.bearing``: each grid point takes
    them from its own bearing's entry (:func:`simcore.study.plan.run_config`), so one value
    for all would build every bearing alike, and a swept one would label runs with values
    they did not run at."""
    from ..model.bearing import SET_BY_ENTRY
    from .parameters import canonical

    sweep = cfg.get("sweep", {})
    if not any(canonical(str(k)) == "model.bearing" for k in sweep):
        return
    swept = {canonical(str(k)): f"sweep.{k}" for k in sweep}
    for key in SET_BY_ENTRY:
        name = f"model.{key}" if key in explicit else swept.get(f"model.{key}")
        if name is not None:
            raise ConfigError(f"{name}: not allowed while sweep.model.bearing gives each "
                              "grid point its bearing's value; allowed: leave it out, or one "
                              "study per bearing with model.bearing set")


def _resolve_bearing(cfg: dict, explicit: set) -> None:
    """The catalogue entry ``model.bearing`` and ``model.clearance_class`` applied to the
    ``model`` section (:func:`simcore.model.bearing.resolve_model`); ``explicit``: the model
    keys the configuration gave."""
    from ..model.bearing import resolve_model

    try:
        cfg["model"] = resolve_model(cfg["model"], explicit)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None


def _coerced(node: Mapping[str, Any], value):
    """``value`` of a key with schema ``node`` as :func:`_coerce_scalars` stores it."""
    if node.get("type") == "integer" and isinstance(value, float) and value.is_integer():
        return int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        return value
    if node.get("type") == "boolean" and value in (0, 1):
        return bool(value)
    return str(value) if node.get("type") == "string" else value


def _coerce_scalars(cfg: dict, schema: Mapping[str, Any]) -> None:
    """0 and 1 as false and true for the boolean keys of the sections (a run file's netCDF
    attributes store the booleans of its configuration as integers), a whole number as its
    text for the keys that take a name (YAML reads the catalogue name 6012 as a number; in a
    sweep's list too, :func:`_coerce_swept_names`), and a whole float as an int for the
    integer keys (``n_balls: 8.0`` is stored as 8, as the schema's type says)."""
    for section, node in schema.get("properties", {}).items():
        values = cfg.get(section)
        if not isinstance(values, dict):
            continue
        for key, sub in node.get("properties", {}).items():
            if key in values:
                values[key] = _coerced(sub, values[key])
    _coerce_swept_names(cfg.get("sweep"), schema)
    study = cfg.get("study")
    if isinstance(study, dict):  # a held value of a category axis too: figure_fixed.bearing
        _coerce_swept_names(study.get("figure_fixed"), schema, lists=False)


def _coerce_swept_names(sweep, schema: Mapping[str, Any], lists: bool = True) -> None:
    """A whole number as its text in the list of a swept key that takes a name
    (``sweep: {bearing: [6012, 6205]}``), as :func:`_coerce_scalars` does for the key itself
    (``lists`` False: in the value of each key, ``study.figure_fixed: {bearing: 6205}``)."""
    from .parameters import canonical

    if not isinstance(sweep, dict):
        return
    for written, values in sweep.items():
        key = canonical(str(written))
        if key is None or (lists and not isinstance(values, list)):
            continue
        section, name = key.split(".", 1)
        node = schema["properties"][section]["properties"][name]
        if node.get("type") == "string":
            sweep[written] = ([_coerced(node, v) for v in values] if lists
                              else _coerced(node, values))


def _check_magnitudes(cfg: Mapping[str, Any]) -> None:
    """Refuse a nonzero number of a model key without an upper bound in the schema (masses,
    inertias, lengths, radii, stiffnesses, the modulus), or of a sweep over such a key, whose
    magnitude is outside [MIN_MAGNITUDE, MAX_MAGNITUDE]."""
    unbounded = {key for key, node in load_schema()["properties"]["model"]["properties"].items()
                 if node.get("type") == "number" and "maximum" not in node
                 and "exclusiveMaximum" not in node}
    items = [(f"model.{key}", cfg["model"][key]) for key in sorted(unbounded)
             if key in cfg["model"]]
    for key, values in cfg.get("sweep", {}).items():
        if key.removeprefix("model.") in unbounded and isinstance(values, list):
            items += [(f"sweep.{key}", value) for value in values]
    for key, value in items:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value == 0:
            continue
        if not MIN_MAGNITUDE <= abs(value) <= MAX_MAGNITUDE:
            raise ConfigError(f"{key}: {value!r} is not allowed; allowed: a magnitude between "
                              f"{MIN_MAGNITUDE:g} and {MAX_MAGNITUDE:g} in SI units (beyond, "
                              "the model's products such as m L^2 or k / m overflow), or 0 "
                              "where the key's range has it")


def _check_finite(node: Any, path: str) -> None:
    """Refuse NaN and infinities anywhere: JSON-schema range checks are false for NaN."""
    if isinstance(node, Mapping):
        for key, value in node.items():
            _check_finite(value, f"{path}.{key}" if path else str(key))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            _check_finite(value, f"{path}.{i}")
    elif isinstance(node, float) and not math.isfinite(node):
        raise ConfigError(f"{path}: {node!r} is not allowed; allowed: a finite number")


def _swept(cfg: Mapping[str, Any], key: str) -> list:
    """Values of the model key ``key`` in the sweep section (short or long name)."""
    sweep = cfg.get("sweep", {}) or {}
    return list(sweep.get(key, [])) + list(sweep.get(f"model.{key}", []))


def replaced_clearance(given: Mapping[str, Any], full: Mapping[str, Any],
                       base: Mapping[str, Any] | None = None) -> list[str]:
    """Warnings for a clearance that ``model.clearance_class`` replaces: a ``model.clearance``
    or a swept clearance the configuration gives beside a class set or swept (each run takes
    its class's clearance: :func:`simcore.model.bearing.resolve_model`,
    :data:`simcore.study.plan.DETERMINED`), as for a ball count given against the catalogue.

    Parameters
    ----------
    given : mapping
        The configuration as its sources give it (before :func:`validate_config`).
    full : mapping
        The same validated (its clearance, for a class set, is the class's).
    base : mapping, optional
        Settings that count as not given where ``given`` holds the same value: a study's base
        configuration (``config/config.yaml``, whose clearance and clearance list a smaller
        study takes unless it gives its own). None: every value given counts.

    Returns
    -------
    list of str
        One line per replaced setting, naming it and the class's key.
    """
    from .parameters import canonical

    def setting(cfg):
        return (cfg.get("model") or {}).get("clearance")

    def swept(cfg, key):
        return {w: v for w, v in (cfg.get("sweep") or {}).items() if canonical(str(w)) == key}

    model = full["model"]
    classes = swept(given, "model.clearance_class")
    per_bearing = "each run takes its class's clearance for its bearing's bore"
    if classes:
        by = f"sweep.{next(iter(classes))} ({per_bearing})"
    elif model.get("clearance_class") is None:
        return []
    elif swept(given, "model.bearing"):
        by = f"model.clearance_class = {model['clearance_class']!r} ({per_bearing})"
    else:
        by = (f"model.clearance_class = {model['clearance_class']!r} ({model['clearance']:g} m "
              f"for bearing {model['bearing']!r})")
    items = [("model.clearance", setting(given), setting(base or {}))]
    before = list(swept(base or {}, "model.clearance").values())
    items += [(f"sweep.{w}", v, before[0] if before else None)
              for w, v in swept(given, "model.clearance").items()]
    return [f"{key} = {value} is given and replaced by {by}; leave one of them out"
            for key, value, default in items
            if value is not None and (base is None or value != default)]


def check_consistency(cfg: Mapping[str, Any]) -> None:
    """The checks of :func:`validate_config` that need several keys at once, for a complete
    configuration whose keys are each valid (e.g. one grid point of a study).

    Raises
    ------
    ConfigError
        One line naming the key.
    """
    _check_consistency(cfg)


def _check_consistency(cfg: Mapping[str, Any]) -> None:
    """Checks that need several keys at once."""
    model, solver = cfg["model"], cfg["solver"]
    if solver["t_end"] < solver["dt"]:
        raise ConfigError(f"solver.t_end: {solver['t_end']!r} is not allowed; "
                          f"allowed: >= solver.dt ({solver['dt']})")
    if model["crank_length"] >= model["rod_length"]:
        raise ConfigError(
            f"model.crank_length: {model['crank_length']!r} is not allowed; allowed: "
            f"< model.rod_length ({model['rod_length']}) so that the crank turns fully")
    dt, out_dt = solver["dt"], solver.get("output_dt")
    if out_dt is not None:
        ratio = out_dt / dt
        if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-9 * ratio:
            raise ConfigError(f"solver.output_dt: {out_dt!r} is not allowed; allowed: a whole "
                              f"multiple of solver.dt ({dt})")
        if model["contact_model"] == "nonsmooth" and round(ratio) != 1:
            raise ConfigError(f"solver.output_dt: {out_dt!r} is not allowed; allowed: "
                              f"solver.dt ({dt}) or null with model.contact_model = nonsmooth "
                              "(the impulse filter needs every step)")
    if solver["adaptive"]:
        if model["contact_model"] != "compliant":
            raise ConfigError("solver.adaptive: true is not allowed with model.contact_model = "
                              f"{model['contact_model']}; allowed: false (adaptive steps are for "
                              "the compliant model)")
        if solver["dt_min"] > dt:
            raise ConfigError(f"solver.dt_min: {solver['dt_min']!r} is not allowed; allowed: "
                              f"<= solver.dt ({dt}), the largest adaptive step")
    if model["contact_model"] == "compliant" and model["damping_law"] == "flores":
        e_values = _swept(cfg, "e_N") + [model["e_N"]]
        if min(e_values) <= 0.0:
            raise ConfigError("model.e_N: 0 is not allowed with model.damping_law = flores in "
                              "the compliant model (chi = 8 (1 - e) / (5 e) is infinite); "
                              "allowed: (0, 1], or damping_law hunt_crossley or "
                              "lankarani_nikravesh")
    from ..model.bearing import BearingGeometry

    clearances = _swept(cfg, "clearance") + [model["clearance"]]
    for g in clearances:
        geometry = BearingGeometry.from_model({**model, "clearance": g})
        if not geometry.balls_fit():
            raise ConfigError(
                f"model.n_balls: {model['n_balls']!r} is not allowed; allowed: balls must fit "
                f"on the pitch circle, at most {geometry.max_balls()} for ball_radius="
                f"{model['ball_radius']} and inner_radius={model['inner_radius']}")


def output_every(cfg: Mapping[str, Any]) -> int:
    """Steps per output sample of a validated configuration (solver.output_dt / solver.dt)."""
    solver = cfg["solver"]
    if solver.get("output_dt") is None:
        return 1
    return int(round(solver["output_dt"] / solver["dt"]))


def parse_override(item: str) -> tuple[list[str], Any]:
    """Split ``section.key=value`` into a key path and a YAML-parsed value."""
    if "=" not in item:
        raise ConfigError(f"{item}: an override must look like section.key=value")
    key, raw = item.split("=", 1)
    path = [p for p in key.strip().split(".") if p]
    if path[:1] == ["sweep"] and len(path) > 2:  # sweep.model.cage_stiffness: one sweep key
        path = ["sweep", ".".join(path[1:])]
    if len(path) < 2:
        raise ConfigError(f"{key}: an override must name a section and a key, e.g. model.mu=0")
    if len(path) > MAX_DEPTH:
        raise ConfigError(f"{key}: a key path of more than {MAX_DEPTH} parts is not allowed")
    try:
        value = parse_yaml_text(raw)
    except ConfigError as exc:
        raise ConfigError(f"{key.strip()}: cannot parse value {raw[:60]!r}: {exc}") from None
    return path, value


def load_config(path: str | Path | None = None, overrides: Iterable[str] = ()) -> dict:
    """Read, complete and validate a configuration.

    Parameters
    ----------
    path : str or Path, optional
        YAML file. Without it, the defaults (the paper's case) are used.
    overrides : iterable of str
        ``section.key=value`` items applied after the file (values are parsed as YAML).

    Returns
    -------
    dict
        The validated configuration with every default filled in.
    """
    cfg: dict = {}
    if path is not None:
        try:
            cfg = read_yaml(path) or {}
        except OSError as exc:
            raise ConfigError(f"--config: cannot read {path}: {exc.strerror}") from None
        if not isinstance(cfg, dict):
            raise ConfigError(f"--config: {path} must hold a mapping of sections")
    cfg = apply_overrides(cfg, overrides)
    full = validate_config(cfg)
    # (one run reads no sweep: simcore.cli.check_sweep says so)
    for text in replaced_clearance({k: v for k, v in cfg.items() if k != "sweep"}, full):
        warnings.warn(text, UserWarning, stacklevel=2)
    return full


def apply_overrides(cfg: dict, overrides: Iterable[str]) -> dict:
    """Set each ``section.key=value`` of ``overrides`` (:func:`parse_override`) in ``cfg``, in
    place; returns ``cfg``.

    Raises
    ------
    ConfigError
        One line naming the key: a value that cannot be parsed, or a key path through a
        setting that is not a section (``model.mu.x``).
    """
    for item in overrides:
        keys, value = parse_override(item)
        node = cfg
        for i, k in enumerate(keys[:-1]):
            node = node.setdefault(k, {})
            if not isinstance(node, dict):
                raise ConfigError(f"{'.'.join(keys)}: not allowed ({k} is a setting, not a "
                                  "section); allowed: section.key=value, e.g. "
                                  f"{'.'.join(keys[:i + 1])}=VALUE")
        node[keys[-1]] = value
    return cfg


def _merge(base: dict, over: Mapping[str, Any]) -> dict:
    """Recursive update of mappings (as Snakemake merges configuration files)."""
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(base.get(key), dict):
            _merge(base[key], value)
        else:
            base[key] = copy.deepcopy(value)
    return base


def read_study_config(files: Iterable[str | Path], command_line: Mapping[str, Any] = ()) -> dict:
    """The study's configuration, read with the same loader and types as the CLI.

    Snakemake reads ``--configfile`` with YAML 1.1 (``1.0e5`` becomes a string) and
    ``--config`` with all values as strings, so a quoted ``"0.2"`` cannot be told from a
    number once Snakemake has read it. This re-reads the files with :func:`read_yaml` (a quoted
    value stays a string and is refused by the schema, as on the command line) and merges them
    in order, then the ``--config`` values, whose number-looking strings are read as numbers;
    a later source's sweep axis replaces an earlier one's, whatever the spelling of each
    (``mu`` or ``model.mu``).

    Parameters
    ----------
    files : iterable of path
        Configuration files, in the order Snakemake merges them.
    command_line : mapping
        Snakemake's ``--config`` values (strings).

    Returns
    -------
    dict
        The merged, not yet validated, configuration.

    Raises
    ------
    ConfigError
        One line naming the file.
    """
    merged: dict = {}
    for path in files:
        try:
            node = read_yaml(path) or {}
        except OSError as exc:
            raise ConfigError(f"--configfile: cannot read {path}: {exc.strerror}") from None
        except ConfigError as exc:
            raise ConfigError(str(exc).replace("--config:", "--configfile:", 1)) from None
        if not isinstance(node, dict):
            raise ConfigError(f"--configfile: {path} must hold a mapping of sections")
        _merge_source(merged, node)
    return _merge_source(merged, _strings_to_numbers(dict(command_line)))


def _merge_source(merged: dict, node: Mapping[str, Any]) -> dict:
    """:func:`_merge` of one source (a file, the command line) over the earlier ones, where a
    sweep axis it gives replaces the earlier sources' list of that axis whatever the spelling
    of each (``sweep.model.mu`` over a file's ``sweep.mu``), as a later value replaces an
    earlier one; both spellings within one source stay, and are refused
    (:func:`simcore.config.parameters.sweep_axes`)."""
    from .parameters import canonical

    sweep, earlier = node.get("sweep"), merged.get("sweep")
    if isinstance(sweep, Mapping) and isinstance(earlier, dict):
        axes = {canonical(str(key)) for key in sweep} - {None}
        for key in [k for k in earlier if k not in sweep and canonical(str(k)) in axes]:
            del earlier[key]
    return _merge(merged, node)


_INT_TEXT = re.compile(r"^[-+]?\d+$")
_FLOAT_TEXT = re.compile(r"^[-+]?(?:\d[\d_]*\.?[\d_]*|\.\d[\d_]*)(?:[eE][-+]?\d+)?$")


def _strings_to_numbers(node):
    """Number-looking strings as numbers, "null" as None, "true"/"false" as booleans
    (Snakemake's --config values)."""
    if isinstance(node, Mapping):
        return {key: _strings_to_numbers(value) for key, value in node.items()}
    if isinstance(node, (list, tuple)):
        return [_strings_to_numbers(value) for value in node]
    if isinstance(node, str):
        text = node.strip()
        if _INT_TEXT.match(text):
            return int(text)
        if _FLOAT_TEXT.match(text):
            return float(text.replace("_", ""))
        if text in ("null", "Null", "NULL", "~"):
            return None
        if text in ("true", "True", "TRUE", "false", "False", "FALSE"):  # YAML's booleans
            return text.lower() == "true"
    return node
