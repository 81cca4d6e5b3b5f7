"""The record types of the TOML key reference (:mod:`casrecon.io.config_reference`): a
:class:`Key` per key, grouped in :class:`Table` and :class:`FileKind`, and the numpydoc parsing
that takes a key's meaning from its dataclass docstring."""

from __future__ import annotations

import dataclasses
import inspect
import re
from dataclasses import dataclass


class _Required:
    """Marker of a key without a default."""

    def __repr__(self) -> str:
        return "REQUIRED"


#: Default of a key that must be given.
REQUIRED = _Required()
#: Default of a key whose default is read from its dataclass field.
FROM_FIELD = object()


@dataclass(frozen=True)
class Key:
    """One key of a TOML table.

    Parameters
    ----------
    key : str
        The key as written in the file.
    type : str
        TOML type (``float``, ``int``, ``bool``, ``string``, ``path``, ``[float; 3]`` ...).
    unit : str
        Physical unit ("" for none).
    meaning : str or None
        What the key does; None: the numpydoc entry of ``source`` for the field.
    default : object
        :data:`REQUIRED`, :data:`FROM_FIELD` (read from ``source``), a value, or a string in
        angle brackets describing a computed default (``"<pi d^2 / 4>"``).
    source : type or None
        Dataclass whose field (named ``field`` or ``key``) receives the value unchanged.
    field : str or None
        Field name in ``source`` when it differs from ``key``.
    attr : str or None
        Dotted attribute path of the value in the loaded object (the test checks the parser's
        default against :attr:`resolved_default` through it).
    """

    key: str
    type: str
    unit: str
    meaning: str | None
    default: object = FROM_FIELD
    source: type | None = None
    field: str | None = None
    attr: str | None = None

    @property
    def field_name(self) -> str:
        return self.field or self.key

    @property
    def resolved_default(self) -> object:
        """The default: the dataclass field's when it has one, else the one written here."""
        if self.default is not FROM_FIELD:
            return self.default
        for f in dataclasses.fields(self.source):
            if f.name == self.field_name:
                if f.default is dataclasses.MISSING:
                    raise ValueError(f"{self.source.__name__}.{f.name} has no default")
                return f.default
        raise ValueError(f"{self.source.__name__} has no field {self.field_name}")

    @property
    def resolved_type(self) -> str:
        """The type, with the allowed values when the field's docstring lists them (``{"a", "b"}``)."""
        if self.source is not None and self.meaning is None:
            doc_type = docstring_types(self.source).get(self.field_name, "")
            if doc_type.startswith("{"):
                return f"{self.type}: one of {doc_type[1:doc_type.index('}')]}"
        return self.type

    @property
    def resolved_meaning(self) -> str:
        text = self.meaning if self.meaning is not None else docstring_entries(self.source)[self.field_name]
        text = re.sub(r":\w+:`~?([^`]+)`", r"`\1`", text)   # reST roles to Markdown code
        return text.replace("``", "`")


@dataclass(frozen=True)
class Table:
    """A TOML table (``name`` "" is the file's top level), its keys, and whether the file must hold it."""

    name: str
    keys: tuple[Key, ...]
    note: str = ""
    required: bool = False


@dataclass(frozen=True)
class FileKind:
    """One kind of TOML file: its title, how it is read, and its tables."""

    title: str
    intro: str
    tables: tuple[Table, ...]

    def table(self, name: str) -> Table:
        return next(t for t in self.tables if t.name == name)


def docstring_types(cls: type) -> dict[str, str]:
    """Types of the numpydoc ``Parameters``/``Attributes`` entries of ``cls``: name -> type text."""
    out: dict[str, str] = {}
    for line in _section_lines(cls):
        if line and not line.startswith(" ") and " : " in line:
            names, type_ = line.split(" : ", 1)
            out.update({n.strip(): type_.strip() for n in names.split(",")})
    return out


def _section_lines(cls: type) -> list[str]:
    lines, inside = [], False
    for line in inspect.cleandoc(cls.__doc__ or "").splitlines():
        if line.strip() in ("Parameters", "Attributes"):
            inside = True
        elif inside and line and not line.startswith(" ") and " : " not in line and not re.fullmatch(r"-+", line):
            inside = False
        elif inside and not re.fullmatch(r"-+", line.strip()):
            lines.append(line)
    return lines


def docstring_entries(cls: type) -> dict[str, str]:
    """Entries of the numpydoc ``Parameters``/``Attributes`` section of ``cls``: name -> description
    (one line; a ``a, b : type`` entry gives the same description to ``a`` and ``b``)."""
    out: dict[str, str] = {}
    names: list[str] = []
    for line in _section_lines(cls):
        if line and not line.startswith(" "):
            names = [n.strip() for n in line.split(" : ")[0].split(",")]
            out.update({n: "" for n in names})
        elif line.strip():
            for n in names:
                out[n] = (out[n] + " " + line.strip()).strip()
    return out
