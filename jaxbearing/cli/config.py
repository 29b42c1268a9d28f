"""Configuration files: parameter overrides of the paper's case for ``jaxbearing xu2014 --config``.

A TOML file (read with the standard library's `tomllib`: data only, nothing in it is evaluated
or imported) with up to four tables; every key is optional and overrides one keyword argument
of `jaxbearing.cases.xu2014`:

    # overrides.toml: all numbers in SI units (m, s, N, rad/s); unit strings are not accepted
    [bearing]
    clearance = 60e-6        # P_d, diametral clearance [m]             -> clearance
    damping = 300.0          # C_b, per-ball damping [N s/m]           -> bearing_damping
    cage = "kinematic"       # "kinematic" or "constant"               -> cage
    ball_force = "paper"     # "paper" or "smooth"                     -> ball_force
    designation = "98205"    # a catalogue bearing: "98205" (the paper's),  -> bearing
                             # "NU205-estimated", "NU206" or "209" (cylindrical roller bearings)

    [impact]
    restitution = 0.8        # e_c, in (0, 1]                          -> restitution
    friction = 0.1           # mu of the slider-target contact [-]     -> friction
    contact_on = 0.05        # time the contact is switched on [s]     -> contact_on

    [crank]
    speed = 62.83            # crank speed [rad/s]                     -> crank_speed

    [metrics]
    window_start = 0.04      # the metrics' default window starts [s]  -> window_start

Rules, each broken one raising a `ConfigError` that names the file and the key:

- only the keys above, inside their tables (the message lists the allowed keys);
- numbers are TOML integers or floats, finite, in SI units; strings (``"40 um"``), booleans,
  arrays, tables and dates are refused where a number is expected;
- ``designation``, ``cage`` and ``ball_force`` are one of the strings listed;
- the physical rules (clearance from -0.01 to 0.1 of the ball diameter, restitution in (0, 1], ...) are those of the model's
  constructors, applied when the case is built (`xu2014_models`).
"""

from __future__ import annotations

import math
import tomllib
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import NamedTuple

from ..params import CATALOGUE, ROLLER_CATALOGUE, BallForce, CageMode

__all__ = [
    "XU2014",
    "ConfigError",
    "allowed_keys",
    "check_overrides",
    "read_overrides",
    "xu2014_kwargs",
    "xu2014_models",
]


class ConfigError(ValueError):
    """A configuration file that cannot be used; the message names the file and the key."""


class Number(NamedTuple):
    """A numeric override: the `cases.xu2014` keyword it sets and its SI unit."""

    keyword: str
    unit: str


class Choice(NamedTuple):
    """A string override: the `cases.xu2014` keyword it sets and the allowed strings."""

    keyword: str
    choices: tuple[str, ...]


XU2014: dict[str, dict[str, Number | Choice]] = {
    "bearing": {
        "clearance": Number("clearance", "m"),
        "damping": Number("bearing_damping", "N s/m"),
        "cage": Choice("cage", typing.get_args(CageMode)),
        "ball_force": Choice("ball_force", typing.get_args(BallForce)),
        "designation": Choice("bearing", tuple(CATALOGUE) + tuple(ROLLER_CATALOGUE)),
    },
    "impact": {
        "restitution": Number("restitution", "-"),
        "friction": Number("friction", "-"),
        "contact_on": Number("contact_on", "s"),
    },
    "crank": {"speed": Number("crank_speed", "rad/s")},
    "metrics": {"window_start": Number("window_start", "s")},
}
"""The schema: table -> key -> what it overrides (see the module doc)."""


def allowed_keys() -> list[str]:
    """``table.key`` of every accepted override."""
    return [f"{table}.{key}" for table, keys in XU2014.items() for key in keys]


def read_overrides(path) -> dict[str, dict[str, object]]:
    """Read and check a configuration file; returns its overrides as ``{table: {key: value}}``
    (numbers as floats), the form `xu2014_kwargs` takes and ``summary.json`` records."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except OSError as err:
        raise ConfigError(f"cannot read the configuration file {path}: {err.strerror}.") from None
    except UnicodeDecodeError as err:
        byte = err.object[err.start : err.start + 1]
        raise ConfigError(
            f"{path} is not UTF-8 text (byte {err.start} is {byte!r}): a TOML file must be "
            "UTF-8; save it with that encoding."
        ) from None
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{path} is not valid TOML: {err}.") from None
    return check_overrides(data, source=str(path))


def check_overrides(data: Mapping, source: str = "configuration") -> dict[str, dict[str, object]]:
    """Check parsed TOML data against `XU2014` (see the module doc for the rules)."""
    allowed = ", ".join(allowed_keys())
    checked: dict[str, dict[str, object]] = {}
    for table, entries in data.items():
        if table not in XU2014:
            where = "table" if isinstance(entries, Mapping) else "top-level key"
            raise ConfigError(
                f"{source}: unknown {where} {_echo(table)}; the allowed keys are {allowed} "
                "(each inside its table, e.g. [bearing] clearance = 4e-5)."
            )
        if not isinstance(entries, Mapping):
            raise ConfigError(
                f"{source}: {table!r} must be a table ([{table}]) of keys; got "
                f"{_kind(entries)} {_echo(entries)}."
            )
        checked[table] = {}
        for key, value in entries.items():
            option = XU2014[table].get(key)
            if option is None:
                name = _echo(key, quote=False)
                raise ConfigError(
                    f"{source}: unknown key {table}.{name}; the allowed keys are {allowed}."
                )
            checked[table][key] = _value(f"{source}: {table}.{key}", option, value)
    return checked


def _value(name, option, value):
    if isinstance(option, Choice):
        if not isinstance(value, str) or value not in option.choices:
            raise ConfigError(
                f"{name} must be one of {', '.join(repr(c) for c in option.choices)}; got "
                f"{_kind(value)} {_echo(value)}."
            )
        return value
    if isinstance(value, str):
        raise ConfigError(
            f"{name} must be a number in SI units [{option.unit}]; got the string {_echo(value)} "
            "(unit strings are not accepted: write the number itself, converted to SI)."
        )
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(
            f"{name} must be a single number in SI units [{option.unit}]; got {_kind(value)} "
            f"{_echo(value)}."
        )
    number = float(value) if abs(value) < 1e308 else math.inf  # huge TOML integers
    if not math.isfinite(number):
        raise ConfigError(f"{name} must be a finite number [{option.unit}]; got {_echo(value)}.")
    return number


ECHO_LIMIT = 80  # characters of a value echoed in a message


def _echo(value, quote=True) -> str:
    """``repr(value)`` (``str`` without ``quote``), cut to `ECHO_LIMIT` characters with its length
    said: a 20 MB string in a file is named, not printed."""
    text = repr(value) if quote else str(value)
    if len(text) <= ECHO_LIMIT:
        return text
    return f"{text[:ECHO_LIMIT]}... ({len(text)} characters)"


def _kind(value) -> str:
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, Mapping):
        return "a table"
    if isinstance(value, str):
        return "the string"
    if isinstance(value, (int, float)):
        return "the number"
    return f"a {type(value).__name__}"


def xu2014_kwargs(overrides: Mapping[str, Mapping[str, object]]) -> dict[str, object]:
    """The `cases.xu2014` keyword arguments of checked overrides (`read_overrides`)."""
    return {XU2014[table][key].keyword: value for table, keys in overrides.items()
            for key, value in keys.items()}  # fmt: skip


def xu2014_models(overrides: Mapping[str, Mapping[str, object]], source="configuration"):
    """The paper's case with and without impact, built with the overrides: a dict
    ``{True: model with impact, False: model without}``. A value that breaks a rule of the
    model's constructors raises a `ConfigError` with ``source`` and the constructor's message
    (the parameter, the value and what is allowed)."""
    from ..cases import xu2014

    kwargs = xu2014_kwargs(overrides)
    try:
        return {impact: xu2014(impact=impact, **kwargs) for impact in (True, False)}
    except ValueError as err:
        raise ConfigError(f"{source}: {err}") from None
