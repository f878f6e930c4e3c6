"""Configuration: one JSON schema for runs and the study, defaults, overrides, clear errors.

The schema (``simcore/schema/config.schema.json``) is the single source of the keys, their
defaults, units and allowed ranges; the Snakemake workflow validates against the same file.
"""

from __future__ import annotations

import copy
import json
import math
import re
from pathlib import Path
from typing import Any, Iterable, Mapping

import yaml

SCHEMA_PATH = Path(__file__).parent / "schema" / "config.schema.json"


class _Loader(yaml.SafeLoader):
    """SafeLoader that reads ``1.0e5`` as a float (YAML 1.2), not as the string PyYAML makes."""


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


def read_yaml(path: str | Path):
    """Read a YAML file with floats such as ``1.0e5`` understood as numbers."""
    with open(path, encoding="utf-8") as fh:
        return yaml.load(fh, Loader=_Loader)


class ConfigError(ValueError):
    """A configuration value is missing, unknown or out of range; the message names the key."""


def load_schema() -> dict:
    """Return the configuration JSON schema as a dict."""
    with open(SCHEMA_PATH, encoding="utf-8") as fh:
        return json.load(fh)


def _allowed(schema: Mapping[str, Any]) -> str:
    """Describe in words what a schema node allows (for one-line error messages)."""
    if "enum" in schema:
        return "one of " + ", ".join(repr(v) for v in schema["enum"])
    parts = []
    kind = schema.get("type")
    if kind in ("number", "integer"):
        parts.append("an integer" if kind == "integer" else "a number")
    elif kind == "array":
        parts.append("a non-empty list")
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


def _format_error(error, root: Mapping[str, Any]) -> str:
    path = ".".join(str(p) for p in error.absolute_path) or "<config>"
    if error.validator == "additionalProperties":
        allowed = sorted(error.schema.get("properties", {}))
        extra = sorted(set(error.instance) - set(allowed))
        where = path + "." if path != "<config>" else ""
        return (f"{where}{extra[0]}: unknown key; allowed keys here: " + ", ".join(allowed))
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
    _fill_defaults(cfg, schema)
    _check_finite(cfg, "")
    validator = jsonschema.Draft7Validator(schema)
    errors = sorted(validator.iter_errors(cfg), key=lambda e: (len(e.absolute_path), str(e.path)))
    if errors:
        raise ConfigError(_format_error(errors[0], schema))
    _check_consistency(cfg)
    return cfg


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
    if model["contact_model"] == "compliant" and model["damping_law"] == "flores":
        e_values = list(cfg.get("sweep", {}).get("e_N", [])) + [model["e_N"]]
        if min(e_values) <= 0.0:
            raise ConfigError("model.e_N: 0 is not allowed with model.damping_law = flores in "
                              "the compliant model (chi = 8 (1 - e) / (5 e) is infinite); "
                              "allowed: (0, 1], or damping_law hunt_crossley or "
                              "lankarani_nikravesh")
    clearances = list(cfg.get("sweep", {}).get("clearance", [])) + [model["clearance"]]
    for g in clearances:
        pitch = model["inner_radius"] + model["ball_radius"] + 0.5 * g
        chord = 2.0 * pitch * math.sin(math.pi / model["n_balls"])
        if chord <= 2.0 * model["ball_radius"]:
            n_max = int(math.pi / math.asin(min(1.0, model["ball_radius"] / pitch)))
            raise ConfigError(
                f"model.n_balls: {model['n_balls']!r} is not allowed; allowed: balls must fit "
                f"on the pitch circle, at most {n_max} for ball_radius={model['ball_radius']} "
                f"and inner_radius={model['inner_radius']}")


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
    if len(path) < 2:
        raise ConfigError(f"{key}: an override must name a section and a key, e.g. model.mu=0")
    try:
        value = yaml.load(raw, Loader=_Loader)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{key}: cannot parse value {raw!r}: {exc}") from None
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
        except yaml.YAMLError as exc:
            raise ConfigError(f"--config: {path} is not valid YAML: {exc}") from None
        if not isinstance(cfg, dict):
            raise ConfigError(f"--config: {path} must hold a mapping of sections")
    for item in overrides:
        keys, value = parse_override(item)
        node = cfg
        for k in keys[:-1]:
            node = node.setdefault(k, {})
            if not isinstance(node, dict):
                raise ConfigError(f"{'.'.join(keys)}: {k} is not a section")
        node[keys[-1]] = value
    return validate_config(cfg)
