"""Stand-ins for ``simulation_interfaces`` 1.5.1, built from its own definitions.

The pip wheels have no ``simulation_interfaces``. :func:`build` reads the ``.msg`` and ``.srv``
files in ``test/data/simulation_interfaces/`` (copied unchanged from the jazzy branch) and makes
Python classes with exactly their constants, fields and defaults, shaped as rosidl's generated
Python is: a message is a class with its constants as class attributes and its fields as
attributes (``__slots__``, so a misspelt field name is an AttributeError, as in rosidl); a
service is a class with ``Request`` and ``Response``, each holding the constants of its part.
Nested types of the package are stand-ins too; ``std_msgs/Header`` and ``geometry_msgs/*`` are
the real messages. :func:`install` puts them in ``sys.modules`` (with pytest's monkeypatch), so
``from simulation_interfaces import msg, srv`` works as in a full ROS install.
"""
from __future__ import annotations

import importlib
import re
import sys
import types
from pathlib import Path

DEFINITIONS = Path(__file__).parent / "data" / "simulation_interfaces"
_CONST = re.compile(r"^(?P<type>\w+)\s+(?P<name>[A-Z][A-Z0-9_]*)\s*=\s*(?P<value>\S+)$")
_FIELD = re.compile(r"^(?P<type>[\w/]+)(?P<array>\[\])?\s+(?P<name>[a-z]\w*)(\s+(?P<default>\S+))?$")
_NUMBER = {"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32",
           "int64", "uint64"}


def _lines(text: str) -> list[str]:
    return [ln.split("#", 1)[0].strip() for ln in text.splitlines()]


def _scalar(kind: str, text: str | None):
    if kind == "string":
        return "" if text is None else text.strip("\"'")
    if kind in ("float32", "float64"):
        return 0.0 if text is None else float(text)
    if kind == "bool":
        return False if text is None else text.lower() == "true"
    return 0 if text is None else int(text)


def _message_class(name: str, lines: list[str], resolve) -> type:
    consts: dict[str, object] = {}
    fields: list[tuple[str, object]] = []        # (name, factory)
    for ln in lines:
        if not ln:
            continue
        c = _CONST.match(ln)
        if c:
            consts[c["name"]] = _scalar(c["type"], c["value"])
            continue
        f = _FIELD.match(ln)
        if f is None:
            raise ValueError(f"{name}: cannot read the line {ln!r}")
        kind, default = f["type"], f["default"]
        if f["array"]:
            factory = list
        elif kind in _NUMBER or kind in ("string", "float32", "float64"):
            factory = (lambda k=kind, d=default: _scalar(k, d))
        else:
            factory = resolve(kind)
        fields.append((f["name"], factory))

    def __init__(self, **kwargs):
        for fname, make in fields:
            setattr(self, fname, kwargs.pop(fname) if fname in kwargs else make())
        if kwargs:
            raise TypeError(f"{name}: no field(s) {sorted(kwargs)}")

    attrs = dict(consts, __slots__=tuple(f for f, _ in fields), __init__=__init__,
                 FIELDS=tuple(f for f, _ in fields), CONSTANTS=dict(consts))
    return type(name, (), attrs)


def build() -> tuple[types.ModuleType, types.ModuleType, types.ModuleType]:
    """(simulation_interfaces, .msg, .srv) stand-in modules from the 1.5.1 definitions."""
    pkg = types.ModuleType("simulation_interfaces")
    msg = types.ModuleType("simulation_interfaces.msg")
    srv = types.ModuleType("simulation_interfaces.srv")
    pkg.msg, pkg.srv = msg, srv

    def resolve(kind: str):
        if "/" in kind:                               # std_msgs/Header, geometry_msgs/Pose
            package, cls = kind.split("/")
            return getattr(importlib.import_module(f"{package}.msg"), cls)
        if not hasattr(msg, kind):
            define_message(kind)
        return getattr(msg, kind)

    def define_message(kind: str) -> None:
        text = (DEFINITIONS / f"{kind}.msg").read_text()
        setattr(msg, kind, _message_class(kind, _lines(text), resolve))

    for path in sorted(DEFINITIONS.glob("*.msg")):
        if not hasattr(msg, path.stem):
            define_message(path.stem)
    for path in sorted(DEFINITIONS.glob("*.srv")):
        lines = _lines(path.read_text())
        cut = lines.index("---")
        request = _message_class(f"{path.stem}_Request", lines[:cut], resolve)
        response = _message_class(f"{path.stem}_Response", lines[cut + 1:], resolve)
        setattr(srv, path.stem, type(path.stem, (), {"Request": request, "Response": response}))
    return pkg, msg, srv


def install(monkeypatch) -> tuple[types.ModuleType, types.ModuleType]:
    """Make ``simulation_interfaces`` importable (stand-ins) for one test; returns (msg, srv)."""
    pkg, msg, srv = build()
    monkeypatch.setitem(sys.modules, "simulation_interfaces", pkg)
    monkeypatch.setitem(sys.modules, "simulation_interfaces.msg", msg)
    monkeypatch.setitem(sys.modules, "simulation_interfaces.srv", srv)
    return msg, srv
