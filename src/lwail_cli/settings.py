"""The machinery of settings: how a config field is declared, checked, recorded, read back and overridden.

A field is declared with ``setting(default, doc, ...)``: the doc is the field's one-line comment (and what
``lwail defaults STAGE`` prints beside it), the bounds are checked in ``Validated.__post_init__``, so a config
holding a bad value cannot exist and nothing is written before the check. ``to_dict``/``from_dict`` record a config
in a manifest and read it back; ``with_overrides`` applies ``--set section.field=value`` assignments. The stage
configs themselves live in ``config.py``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import typing
from dataclasses import field

from .errors import LwailError


def setting(default, doc: str, *, low=None, high=None, below=None, choices=None, aliases=None, resume_may_change=False,
            used_when: tuple[str, tuple] | None = None, since: str | None = None):
    """A config field: its default, a one-line doc, and the bounds checked on every construction
    (``low``/``high`` inclusive, ``below`` exclusive, ``choices`` a set of allowed values). ``aliases`` maps
    values an older lwail recorded (or a plan still spells) to the value they mean now. ``resume_may_change``: a
    killed run may be resumed with another value, because the field sets only the budget or how the run is watched
    (logged, evaluated, checkpointed) and draws no training randomness; a resume that changes any other field is
    refused (tests/test_lwail.py checks both bit for bit). ``used_when`` and ``since``: as for ``section``."""
    return field(default=default, metadata={"doc": doc, "low": low, "high": high, "below": below, "choices": choices,
                                            "aliases": aliases or {}, "resume_may_change": resume_may_change,
                                            "used_when": used_when, "since": since})


def section(factory, doc: str, *, used_when: tuple[str, tuple] | None = None, since: str | None = None):
    """A nested config (e.g. the TD3 settings inside the imitation config). ``used_when = (field, values)``: read
    only when the config's ``field`` (e.g. ``method``) is one of ``values``; otherwise it is left out of the record,
    so a run's record (its manifest, its resume check, a sweep's fingerprint) holds only what the run reads and stays
    the same when another method's or embedding's section is added. ``since``: the lwail version that added the field,
    for every field added after 0.3 (whose records held every field; ``recorded_by_0_3``)."""
    return field(default_factory=factory, metadata={"doc": doc, "used_when": used_when, "since": since})


class Validated:
    """Checks every field's type and bounds after construction (and after each ``--set``)."""

    def __post_init__(self) -> None:
        hints = typing.get_type_hints(type(self))
        for f in dataclasses.fields(self):
            value = vars(self)[f.name]
            if isinstance(value, typing.Hashable) and value in f.metadata.get("aliases", {}):
                object.__setattr__(self, f.name, f.metadata["aliases"][value])  # frozen: the one place a field is rewritten
            _check(type(self).__name__, f, hints[f.name], vars(self)[f.name])
        self.check()

    def check(self) -> None:
        """Constraints between fields; a config overrides this (reading fields through ``vars``)."""


def _check(owner: str, f: dataclasses.Field, hint, value) -> None:
    name = f"{owner.removesuffix('Config').lower()}.{f.name}"
    if dataclasses.is_dataclass(hint):
        if not isinstance(value, hint):
            raise LwailError(f"{name} must be a {hint.__name__} section")
        return
    values = value if typing.get_origin(hint) is tuple else (value,)
    kind = typing.get_args(hint)[0] if typing.get_origin(hint) is tuple else hint
    if typing.get_origin(hint) is tuple and not isinstance(value, tuple):
        raise LwailError(f"{name} must be a tuple of {kind.__name__}s, got {value!r}")
    meta = f.metadata
    for item in values:
        if kind is bool and not isinstance(item, bool) or kind is int and (isinstance(item, bool) or not isinstance(item, int)):
            raise LwailError(f"{name} must be {kind.__name__}, got {item!r}")
        if kind is float:
            if isinstance(item, bool) or not isinstance(item, (int, float)):
                raise LwailError(f"{name} must be a number, got {item!r}")
            if not math.isfinite(item):
                raise LwailError(f"{name} must be finite, got {item!r}")
        if kind is str and not isinstance(item, str):
            raise LwailError(f"{name} must be text, got {item!r}")
        if meta.get("choices") is not None and item not in meta["choices"]:
            raise LwailError(f"{name} must be one of {', '.join(map(str, meta['choices']))}, got {item!r}")
        if meta.get("low") is not None and item < meta["low"]:
            raise LwailError(f"{name} must be at least {meta['low']}, got {item!r}")
        if meta.get("high") is not None and item > meta["high"]:
            raise LwailError(f"{name} must be at most {meta['high']}, got {item!r}")
        if meta.get("below") is not None and item >= meta["below"]:
            raise LwailError(f"{name} must be below {meta['below']}, got {item!r}")


# ------------------------------------------------------------------------------ dicts and overrides
def to_dict(config) -> dict:
    """The config as plain data for a manifest (read through ``vars`` so recording is not "using"), without the fields
    its selectors leave unread (``used_when``); ``from_dict`` gives those their defaults."""
    return {f.name: _plain(vars(config)[f.name]) for f in dataclasses.fields(config) if _read(config, f)}


def _plain(value):
    return to_dict(value) if dataclasses.is_dataclass(value) else (list(value) if isinstance(value, tuple) else value)


def _read(config, f: dataclasses.Field) -> bool:
    """Whether ``config`` reads field ``f``: always, unless its ``used_when`` selector picks other values."""
    selector = f.metadata.get("used_when")
    return selector is None or vars(config)[selector[0]] in selector[1]


def recorded_by_0_3(config) -> dict | None:
    """The config as lwail 0.3 recorded it (its manifests, checkpoints and sweep ledgers): every field, read or not,
    less those added since. None when a field added since is read and holds another value than its default: no 0.3
    run could have been made with it."""
    recorded = {}
    for f in dataclasses.fields(config):
        value = vars(config)[f.name]
        if f.metadata.get("since") is not None:
            if _read(config, f) and value != (f.default_factory() if f.default is dataclasses.MISSING else f.default):
                return None
            continue
        recorded[f.name] = recorded_by_0_3(value) if dataclasses.is_dataclass(value) else _plain(value)
        if recorded[f.name] is None:
            return None
    return recorded


def from_dict(cls, data: dict):
    """Rebuild a (possibly nested) config from the dict stored in a manifest."""
    hints = typing.get_type_hints(cls)
    kwargs = {}
    for f in dataclasses.fields(cls):
        if f.name not in data:
            continue
        value = data[f.name]
        hint = hints[f.name]
        if dataclasses.is_dataclass(hint):
            value = from_dict(hint, value)
        elif typing.get_origin(hint) is tuple:
            value = tuple(value)
        kwargs[f.name] = value
    return cls(**kwargs)


def _parse(text: str, hint, key: str):
    try:
        if hint is bool:
            lowered = text.strip().lower()
            if lowered not in ("true", "false", "1", "0", "yes", "no"):
                raise ValueError(text)
            return lowered in ("true", "1", "yes")
        if typing.get_origin(hint) is tuple:
            return _parse_list(text)
        if hint is int:
            number = float(text) if "e" in text.lower() else int(text)
            if isinstance(number, float) and not number.is_integer():
                raise ValueError(text)
            return int(number)
        return hint(text)
    except (ValueError, OverflowError):
        raise LwailError(f"--set {key}: cannot read {text!r} as {getattr(hint, '__name__', hint)}") from None


_LIST = re.compile(r"\s*(?:\[(?P<square>[^][()]*)\]|\((?P<round>[^][()]*)\)|(?P<bare>[^][()]*))\s*")


def _parse_list(text: str) -> tuple[int, ...]:
    """``256,256``, ``[256, 256]`` or ``(256, 256)``, one trailing comma allowed (Python's ``(32,)``); ``[]``, ``()`` or
    nothing is the empty list (as widths: no hidden layer, a linear map). Anything else is refused, not guessed at:
    an unclosed bracket (``[32``), an empty item (``1,,2``), a space inside a number (``3 2``)."""
    match = _LIST.fullmatch(text)
    if match is None:
        raise ValueError(text)
    items = [item.strip() for item in next(group for group in match.groups() if group is not None).split(",")]
    if len(items) > 1 and items[-1] == "" and items[-2] != "":
        items.pop()
    if items == [""]:
        return ()
    return tuple(int(item) for item in items)  # int("") and int("3 2") raise ValueError


def with_overrides(config, *layers: list[str]):
    """Apply ``section.field=value`` assignments to a frozen config, all together: every name and value is read
    first, then each changed section is built (and checked) once, so a check across fields (td3.learning_starts
    against td3.batch_size) sees every assignment and their order never matters. Within a layer a key is given once;
    a later layer (a sweep variant's overrides after its plan's) overrides an earlier one."""
    values: dict[str, object] = {}
    for layer in layers:
        values.update(read_assignments(config, layer))
    return with_values(config, values)


def read_assignments(config, assignments: list[str]) -> dict[str, object]:
    """The value each ``section.field=value`` of one layer gives its key, read against ``config`` (names and types
    checked here, bounds when the config is built); a key given twice with two values is refused."""
    given: dict[str, object] = {}
    for assignment in assignments:
        key, sep, text = assignment.partition("=")
        if not sep:
            raise LwailError(f"--set expects section.field=value, got {assignment!r}")
        key = key.strip()
        value = _read_setting(config, key.split("."), text, key)
        if key in given and given[key] != value:
            raise LwailError(f"--set {key} is given twice ({given[key]!r} and {value!r}); give it once")
        given[key] = value
    return given


def with_values(config, values: dict[str, object]):
    """``config`` with each ``section.field`` key set to its (already read) value, each changed section built once."""
    changes: dict = {}
    for key, value in values.items():
        *sections, name = key.split(".")
        node = changes
        for part in sections:
            node = node.setdefault(part, {})
        node[name] = value
    return _rebuilt(config, changes)


def _read_setting(config, path: list[str], text: str, key: str):
    """The value ``text`` gives the setting at ``path`` (its name and type checked; its bounds when the config is built)."""
    names = {f.name for f in dataclasses.fields(config)}
    if path[0] not in names:
        raise LwailError(f"--set {key}: unknown setting {path[0]!r}; known: {', '.join(sorted(names))}")
    current = vars(config)[path[0]]
    if len(path) > 1:
        if not dataclasses.is_dataclass(current):
            raise LwailError(f"--set {key}: {path[0]!r} has no sub-settings")
        return _read_setting(current, path[1:], text, key)
    if dataclasses.is_dataclass(current):
        raise LwailError(f"--set {key}: {path[0]!r} is a section; name one of its fields")
    return _parse(text, typing.get_type_hints(type(config))[path[0]], key)


def _rebuilt(config, changes: dict):
    """``config`` with ``changes`` (nested dicts for sections), each changed section built once, innermost first."""
    if not changes:
        return config
    return dataclasses.replace(config, **{
        name: _rebuilt(vars(config)[name], value) if dataclasses.is_dataclass(vars(config)[name]) else value
        for name, value in changes.items()
    })


def describe(config, indent: str = "") -> str:
    """Each setting with its default and its one-line doc, as ``--set`` names it."""
    lines = []
    for f in dataclasses.fields(config):
        value = vars(config)[f.name]
        if dataclasses.is_dataclass(value):
            lines.append(f"{indent}{f.name}:  # {f.metadata['doc']}")
            lines.append(describe(value, indent + "  "))
        else:
            shown = json.dumps(list(value) if isinstance(value, tuple) else value)
            lines.append(f"{indent}{f.name} = {shown}  # {f.metadata['doc']}")
    return "\n".join(lines)


def resume_may_change(config_class: type, prefix: str = "") -> tuple[str, ...]:
    """The settings (``section.field``, as ``--set`` names them) a resumed run may change: those declared with
    ``resume_may_change=True``, in every section."""
    hints = typing.get_type_hints(config_class)
    keys: list[str] = []
    for f in dataclasses.fields(config_class):
        if dataclasses.is_dataclass(hints[f.name]):
            keys += resume_may_change(hints[f.name], f"{prefix}{f.name}.")
        elif f.metadata.get("resume_may_change"):
            keys.append(f"{prefix}{f.name}")
    return tuple(keys)
