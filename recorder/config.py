"""One config mechanism for every component (docs/decisions.md, "Configuration"): a typed dataclass holds the
defaults, once; a YAML file and then command-line flags override them; pydantic validates the result against the
dataclass' type hints, so an unknown key, a wrong type or an out-of-range value is one line naming the file and
the key. The argparse flags of a command are generated from the same fields (``add_arguments``), with their
help and their defaults, so they cannot drift from the dataclass.

A field's metadata (``setting(default, help, ...)``) says how it appears on the command line: ``flag`` (another
name than --field-name; a bool field's flag sets it True, or False when the flag starts with --no-),
``sets`` (the value a bool's flag sets, when its name does not say), ``negation`` (a second flag that sets a
bool False, exclusive with the first), ``aliases`` (the flag's old names, still taken for a release: hidden
from --help, each use notes the new name on stderr; see ``add_option``), ``check`` (a function that raises
ValueError for a bad value: argparse reports it), ``cli=False`` (YAML only), ``flags`` (for a nested dataclass
field: {nested field: flag}, or {nested field: (flag, *old names)}). Ranges and choices live in the type hints:
``Annotated[int, Gt(0)]``, ``Literal["joint", "ik"]``. A nested dataclass may define ``decode_text(text) -> dict``
to be given as a string (``glove: serial:/dev/ttyACM0``).
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import sys
import types
import typing
from pathlib import Path
from typing import Annotated, Any, Literal

import annotated_types as at
import yaml
from pydantic import ConfigDict, TypeAdapter, ValidationError

from recorder import GloverecError
from recorder.argtypes import number


class ConfigError(GloverecError, ValueError):
    """A config that cannot be used: one line naming the file (or flag) and the key."""


STRICT = ConfigDict(extra="forbid")  # a config dataclass' ``__pydantic_config__``: unknown keys are errors
Positive = at.Gt(0)
NonNegative = at.Ge(0)


def setting(default=dataclasses.MISSING, help: str = "", *, default_factory=dataclasses.MISSING, **cli):
    """A dataclass field with its help text and how it appears on the command line (see the module docstring)."""
    return dataclasses.field(default=default, default_factory=default_factory, metadata={"help": help, **cli})


# ---------------------------------------------------------------- loading


def load(cls, path: str | Path | None = None, *, overrides: dict | None = None, required: bool = True):
    """``cls``'s defaults, then the YAML file ``path`` (missing is fine unless ``required``), then ``overrides``
    (flag values, keyword arguments; dotted keys reach into nested sections); validated."""
    values = read_yaml(path, required) if path is not None else {}
    where = str(path) if path is not None else cls.__name__
    if overrides:
        values = merge(cls, values, overrides)
    return build(cls, values, where)


def read_yaml(path: str | Path, required: bool = True) -> dict:
    """The mapping in a YAML file ({} for a missing file unless ``required``); one-line ConfigError otherwise."""
    path = Path(path)
    if not path.is_file():
        if required:
            raise ConfigError(f"no such config file: {path}")
        return {}
    try:
        values = yaml.safe_load(path.read_text())
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read {path}: {getattr(exc, 'strerror', None) or exc}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
    if values is None:
        return {}
    if not isinstance(values, dict):
        raise ConfigError(f"{path}: expected a mapping of settings, got {type(values).__name__}")
    return values


def merge(cls, base: dict, overrides: dict) -> dict:
    """``base`` with ``overrides`` on top (nested sections merged key by key; a dotted key reaches into one;
    None values ignored). A string given for a nested dataclass with ``decode_text`` is decoded first."""
    out = _decoded(cls, dict(base))
    for key, value in overrides.items():
        if value is None:
            continue
        head, _, rest = key.partition(".")
        sub = _nested(cls, head)
        if rest:
            value = {rest: value}
        if sub is not None and isinstance(value, dict):
            out[head] = merge(sub, out.get(head) or {}, value)
        elif sub is not None and isinstance(value, str) and hasattr(sub, "decode_text"):
            out[head] = merge(sub, out.get(head) or {}, sub.decode_text(value))
        else:
            out[head] = value
    return out


def build(cls, values: dict, where: str, prefix: str = ""):
    """``cls(**values)`` validated: ConfigError "WHERE: key.sub: what is wrong" for the first problem
    (``prefix``: where these values sit in their file, e.g. "retarget")."""
    try:
        return _adapter(cls).validate_python(_decoded(cls, values))
    except ValidationError as exc:
        err = exc.errors()[0]
        key = ".".join(str(k) for k in ([prefix] if prefix else []) + list(err["loc"]))
        msg = err["msg"]
        if err["type"] == "unexpected_keyword_argument":
            valid = _valid_keys(cls, err["loc"][:-1])
            msg = f"unknown key; valid: {', '.join(valid)}" if valid else "unknown key"
        if msg.startswith("Value error, "):
            msg = msg[len("Value error, ") :]
        if err["type"] == "missing_argument":
            msg = "missing"
        raise ConfigError(f"{where}: {key}: {msg}" if key else f"{where}: {msg}") from None


def _valid_keys(cls, loc) -> list[str]:
    """The field names of the dataclass found at ``loc`` inside ``cls`` (through fields, dict values and tuple
    items); [] when there is none."""
    hint = cls
    for part in loc:
        base = _base(hint)[0]
        if dataclasses.is_dataclass(base):
            hint = _hints(base).get(part)
        elif typing.get_origin(base) in (dict, tuple):
            hint = typing.get_args(base)[-1]
        if hint is None:
            return []
    base = _base(hint)[0]
    return [f.name for f in dataclasses.fields(base)] if dataclasses.is_dataclass(base) else []


@functools.cache
def _adapter(cls) -> TypeAdapter:
    return TypeAdapter(cls)


def _decoded(cls, values: dict) -> dict:
    """Strings given for nested dataclass sections that can decode them, as mappings."""
    out = dict(values)
    for key, value in values.items():
        sub = _nested(cls, key) if isinstance(key, str) else None
        if sub is not None and isinstance(value, str) and hasattr(sub, "decode_text"):
            out[key] = sub.decode_text(value)
    return out


def _nested(cls, name: str):
    """The dataclass type of field ``name`` of ``cls`` (None if it is not a nested section)."""
    hint = _hints(cls).get(name)
    base = _base(hint)[0] if hint is not None else None
    return base if dataclasses.is_dataclass(base) else None


@functools.cache
def _hints(cls) -> dict:
    return typing.get_type_hints(cls, include_extras=True)


def _base(hint) -> tuple[Any, list, bool]:
    """(the type under Annotated and Optional, the Annotated constraints, whether None is allowed)."""
    constraints, optional = [], False
    while True:
        if typing.get_origin(hint) is Annotated:
            hint, *extra = typing.get_args(hint)
            constraints += extra
        elif typing.get_origin(hint) in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(hint) if a is not type(None)]
            optional = optional or len(args) < len(typing.get_args(hint))
            if len(args) != 1:
                return hint, constraints, optional
            hint = args[0]
        else:
            return hint, constraints, optional


# ---------------------------------------------------------------- the command line


def add_arguments(parser: argparse.ArgumentParser, cls, *, include=None, required=()) -> None:
    """Flags for the fields of ``cls`` (see the module docstring; ``include``: only these fields; ``required``:
    these flags must be given). Each stores under "<class>:<dotted field name>", apart from the command's own
    flags, and defaults to None (not given); ``overrides(args, cls)`` collects what was given."""
    defaults = cls()
    for f in dataclasses.fields(cls):
        if include is not None and f.name not in include or not f.metadata.get("cli", True):
            continue
        dest = f"{cls.__name__}:{f.name}"
        aliases = tuple(f.metadata.get("aliases", ()))
        _add_flag(parser, f, _hints(cls)[f.name], getattr(defaults, f.name), dest, None, aliases, f.name in required)
        sub = _nested(cls, f.name)
        for name, flag in f.metadata.get("flags", {}).items():
            flag, *old = (flag,) if isinstance(flag, str) else flag
            nf = next(x for x in dataclasses.fields(sub) if x.name == name)
            nested_default = getattr(getattr(defaults, f.name), name)
            _add_flag(parser, nf, _hints(sub)[name], nested_default, f"{dest}.{name}", flag, tuple(old))


def overrides(args: argparse.Namespace, cls) -> dict:
    """The values of ``cls``'s flags that were given on the command line, by dotted field name."""
    prefix = f"{cls.__name__}:"
    return {k[len(prefix) :]: v for k, v in vars(args).items() if k.startswith(prefix) and v is not None}


def add_option(parser, flag: str, *aliases: str, required: bool = False, **kw) -> argparse.Action:
    """``parser.add_argument(flag, **kw)``, and ``aliases``: the flag's old names, still taken for a release. An
    old name does what the flag does, after a one-line note on stderr (stdout is left alone: a --json command's
    output stays one JSON object); --help and usage errors show only the new name. The one way a renamed flag
    is kept, for generated flags and hand-written ones alike (docs/decisions.md, "One idea, one flag name")."""
    if not aliases:
        return parser.add_argument(flag, required=required, **kw)
    # required: one of the names must be given, so argparse's own check sees the flag under an old name too
    target = parser.add_mutually_exclusive_group(required=True) if required else parser
    action = target.add_argument(flag, **kw)
    for old in aliases:
        target.add_argument(old, action=_Renamed, dest=action.dest, renamed=action, help=argparse.SUPPRESS)
    return action


class _Renamed(argparse.Action):
    """An old name of a flag (``add_option``): parses and stores as the flag does, and says the new name."""

    def __init__(self, option_strings, dest, renamed: argparse.Action, help=None, **_):
        super().__init__(option_strings, dest, nargs=renamed.nargs, const=renamed.const, default=argparse.SUPPRESS,
                         type=renamed.type, choices=renamed.choices, help=help, metavar=renamed.metavar)  # fmt: skip
        self.renamed = renamed

    def __call__(self, parser, namespace, values, option_string=None):
        new = self.renamed.option_strings[0]
        print(f"{parser.prog}: note: {option_string} is now {new}; {option_string} goes in a later release",
              file=sys.stderr)  # fmt: skip
        self.renamed(parser, namespace, values, new)


def _add_flag(
    parser,
    f: dataclasses.Field,
    hint,
    default,
    dest: str,
    flag: str | None = None,
    aliases: tuple[str, ...] = (),
    required: bool = False,
) -> None:
    flag = flag or f.metadata.get("flag") or "--" + f.name.replace("_", "-")
    help_ = f.metadata.get("help", "")
    base, constraints, _ = _base(hint)
    if base is bool:
        negation = f.metadata.get("negation")
        if negation:
            group = parser.add_mutually_exclusive_group()
            add_option(group, flag, *aliases, dest=dest, action="store_true", default=None, help=help_)
            group.add_argument(negation, dest=dest, action="store_false", help=f.metadata.get("negation_help"))
        elif f.metadata.get("flag"):
            sets = f.metadata.get("sets", not flag.startswith("--no-"))
            action = "store_true" if sets else "store_false"
            add_option(parser, flag, *aliases, dest=dest, action=action, default=None, help=help_)
        else:
            add_option(parser, flag, *aliases, dest=dest, action=argparse.BooleanOptionalAction, default=None,
                       help=_with_default(help_, default))  # fmt: skip
        return
    kw: dict = {"dest": dest, "default": None, "help": help_ if required else _with_default(help_, default)}
    if typing.get_origin(base) is Literal:
        kw["choices"] = typing.get_args(base)
    elif typing.get_origin(base) is tuple:
        kw["type"] = _listed(typing.get_args(base))
        kw["metavar"] = f.metadata.get("metavar") or "A,B"
    elif base in (int, float):
        kw["type"] = number(base, *constraints)
    if "check" in f.metadata:  # a flag-level check: argparse reports its error (exit 2)
        kw["type"] = _checked(f.metadata["check"])
    if "metavar" in f.metadata:
        kw["metavar"] = f.metadata["metavar"]
    elif "choices" not in kw and "metavar" not in kw:
        kw["metavar"] = dest.rsplit(".", 1)[-1].rsplit(":", 1)[-1].upper()
    add_option(parser, flag, *aliases, required=required, **kw)


def _with_default(help_: str, default) -> str:
    if default is None or default == ():
        return help_
    if dataclasses.is_dataclass(default) and type(default).__str__ is object.__str__:
        return help_
    shown = ",".join(map(str, default)) if isinstance(default, tuple) else default
    return f"{help_} (default: {shown})" if help_ else f"default: {shown}"


def _checked(check):
    def parse(text: str):
        try:
            check(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return text

    return parse


def _listed(item_types):
    """A comma-separated list (empty items dropped), each item of the tuple's item type."""
    kind = item_types[0] if item_types else str
    kind = kind if kind in (int, float) else str

    def parse(text: str):
        try:
            return tuple(kind(x) for x in text.split(",") if x.strip())
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a comma-separated list, got {text!r}") from None

    return parse
