"""The JSON reports' shapes, declared once: each report's ``to_dict`` writes through its :class:`Record`, and
``nlobs schema COMMAND`` prints the same declaration as a JSON Schema (draft 2020-12).

A :class:`Record` is a JSON object with named keys. Its :meth:`Record.emit` is the last step of a ``to_dict``:
it returns the mapping as a ``dict`` after checking that its keys are exactly the declared ones (the optional
ones may be absent), so a key written without being declared, or declared and never written, stops the report
instead of reaching a user unannounced. The values' types are checked by validating real outputs against
:func:`document_schema` in the test suite (they are NumPy values until :func:`nlobs._io.jsonable` turns them
into JSON, so they are not checked at run time).

Numbers are declared as ``number`` or ``null`` throughout: a non-finite float is written as ``null``.

Examples
--------
>>> point = Record("Point", {"x": NUMBER, "label": nullable(STRING)}, optional={"label"})
>>> point.emit({"x": 1.5})
{'x': 1.5}
>>> point.emit({"x": 1.5, "y": 2.0})
Traceback (most recent call last):
...
nlobs._schema.ReportSchemaError: Point: keys not declared in its schema: ['y']
>>> document_schema(point, "point")["required"]
['schema_version', 'x']
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = [
    "ANY",
    "BOOLEAN",
    "BOX",
    "INTEGER",
    "MATRIX",
    "NUMBER",
    "OBJECT",
    "STRING",
    "Node",
    "Record",
    "ReportSchemaError",
    "array",
    "document_schema",
    "enum",
    "mapping",
    "nullable",
    "one_of",
]

DIALECT = "https://json-schema.org/draft/2020-12/schema"


class ReportSchemaError(RuntimeError):
    """A report's keys differ from its declared schema: a defect of nlobs, never of the user's input."""


@dataclass(frozen=True)
class Node:
    """One JSON value's shape: a fixed JSON Schema fragment, or a combination of nodes.

    Attributes
    ----------
    fragment : Mapping[str, Any]
        The JSON Schema keywords of a leaf (``{"type": "integer"}``); empty for an unconstrained value.
    items : tuple[Node, ...]
        The nodes this one combines (the item of an array, the alternatives of ``anyOf``, a mapping's value).
    kind : str
        ``"leaf"``, ``"array"``, ``"anyOf"`` or ``"mapping"``.
    description : str
        Said in the schema's ``description``.
    """

    fragment: Mapping[str, Any] = field(default_factory=dict)
    items: tuple[Node, ...] = ()
    kind: str = "leaf"
    description: str = ""

    def schema(self, defs: dict[str, Any]) -> dict[str, Any]:
        """The JSON Schema of this node, adding the records it uses to ``defs``.

        Parameters
        ----------
        defs : dict
            The document's ``$defs``, filled in place.

        Returns
        -------
        dict
            The schema fragment.
        """
        if self.kind == "array":
            out: dict[str, Any] = {"type": "array", "items": self.items[0].schema(defs)}
        elif self.kind == "anyOf":
            out = {"anyOf": [i.schema(defs) for i in self.items]}
        elif self.kind == "mapping":
            out = {"type": "object", "additionalProperties": self.items[0].schema(defs)}
        else:
            out = dict(self.fragment)
        if self.description:
            out["description"] = self.description
        return out

    def about(self, description: str) -> Node:
        """The same node with a description (``NUMBER.about("seconds per step")``).

        Parameters
        ----------
        description : str
            Said in the schema.

        Returns
        -------
        Node
        """
        return Node(self.fragment, self.items, self.kind, description)


NUMBER = Node({"type": ["number", "null"]})
INTEGER = Node({"type": "integer"})
STRING = Node({"type": "string"})
BOOLEAN = Node({"type": "boolean"})
NULL = Node({"type": "null"})
ANY = Node({})
#: A matrix, row by row.
MATRIX = Node(items=(Node(items=(NUMBER,), kind="array"),), kind="array")

#: An object whose keys are not declared here (a part whose keys depend on the method or the paper).
OBJECT = Node({"type": "object"})


def array(item: Node, description: str = "") -> Node:
    """A JSON array whose items are all ``item``.

    Parameters
    ----------
    item : Node
        The shape of every item.
    description : str
        Said in the schema.
    """
    return Node(items=(item,), kind="array", description=description)


def one_of(*nodes: Node, description: str = "") -> Node:
    """A value of any of ``nodes`` (``anyOf``).

    Parameters
    ----------
    *nodes : Node
        The alternatives.
    description : str
        Said in the schema.

    Examples
    --------
    A sensor channel given by its index or by its name:

    >>> channel = one_of(INTEGER, STRING, description="an output index or name")
    >>> channel.kind, channel.schema({})
    ('anyOf', {'anyOf': [{'type': 'integer'}, {'type': 'string'}], 'description': 'an output index or name'})
    """
    return Node(items=tuple(nodes), kind="anyOf", description=description)


def nullable(node: Node, description: str = "") -> Node:
    """``node`` or ``null``.

    Parameters
    ----------
    node : Node
        The shape when not null.
    description : str
        Said in the schema.
    """
    return one_of(node, NULL, description=description)


def mapping(value: Node, description: str = "") -> Node:
    """An object with any keys (names of observers, parameters, ...), each holding a ``value``.

    Parameters
    ----------
    value : Node
        The shape of every value.
    description : str
        Said in the schema.
    """
    return Node(items=(value,), kind="mapping", description=description)


def enum(*values: Any, description: str = "") -> Node:
    """One of the given JSON values.

    Parameters
    ----------
    *values : Any
        The values allowed.
    description : str
        Said in the schema.
    """
    return Node({"enum": list(values)}, description=description)


@dataclass(frozen=True)
class Record(Node):
    """A JSON object with declared keys, the shape of one report (or one part of it).

    Parameters
    ----------
    title : str
        Its name in the schema's ``$defs`` (unique among the records of one document).
    fields : Mapping[str, Node]
        Each key with its node, in the order the report writes them.
    optional : iterable of str
        Keys that may be absent.
    closed : bool
        No key but the declared ones.
    description : str
        Said in the schema.

    Attributes
    ----------
    title : str
        Its name in the schema's ``$defs`` (unique among the records of one document).
    fields : Mapping[str, Node]
        Each key with its node, in the order the report writes them.
    optional : frozenset of str
        Keys that may be absent.
    closed : bool
        No key but the declared ones (``additionalProperties: false``); an open record lists the keys it
        always has and allows others (parts whose keys depend on the method, e.g. a design's parameters).
    """

    title: str = ""
    fields: Mapping[str, Node] = field(default_factory=dict)
    optional: frozenset[str] = frozenset()
    closed: bool = True

    def __init__(self, title: str, fields: Mapping[str, Node], *, optional: Iterable[str] = (), closed: bool = True,
                 description: str = "") -> None:
        object.__setattr__(self, "fragment", {})
        object.__setattr__(self, "items", ())
        object.__setattr__(self, "kind", "record")
        object.__setattr__(self, "description", description)
        object.__setattr__(self, "title", title)
        object.__setattr__(self, "fields", dict(fields))
        object.__setattr__(self, "optional", frozenset(optional))
        object.__setattr__(self, "closed", closed)
        unknown = self.optional - set(self.fields)
        if unknown:
            raise ReportSchemaError(f"{title}: optional keys not declared: {sorted(unknown)}")

    def __hash__(self) -> int:
        return hash(self.title)

    def about(self, description: str) -> Node:
        """A reference to this record with a description of its use.

        Parameters
        ----------
        description : str
            Said in the schema beside the ``$ref``.

        Returns
        -------
        Node
        """
        return _Described(self, description)

    def extend(self, title: str, fields: Mapping[str, Node], *, optional: Iterable[str] = (),
               closed: bool | None = None, description: str = "") -> Record:
        """A record with this one's keys followed by ``fields`` (a report that adds keys to another's).

        Parameters
        ----------
        title : str
            The new record's name.
        fields : Mapping[str, Node]
            The keys added.
        optional : iterable of str
            Added keys that may be absent.
        closed : bool, optional
            Default: as this record.
        description : str
            Default: this record's.

        Returns
        -------
        Record
        """
        return Record(title, {**self.fields, **fields}, optional=self.optional | frozenset(optional),
                      closed=self.closed if closed is None else closed, description=description or self.description)

    def emit(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """The report as a ``dict``, its keys checked against the declaration.

        Parameters
        ----------
        values : Mapping
            The report's keys and values, in the order they are written.

        Returns
        -------
        dict
            ``values`` as a plain ``dict`` (the same order).

        Raises
        ------
        ReportSchemaError
            A key is not declared (closed records), or a required key is missing.
        """
        keys = set(values)
        unknown = sorted(keys - set(self.fields)) if self.closed else []
        if unknown:
            raise ReportSchemaError(f"{self.title}: keys not declared in its schema: {unknown}")
        missing = [k for k in self.fields if k not in keys and k not in self.optional]
        if missing:
            raise ReportSchemaError(f"{self.title}: declared keys missing from the report: {missing}")
        return dict(values)

    def body(self, defs: dict[str, Any]) -> dict[str, Any]:
        """This record's own JSON Schema (not a reference), its records added to ``defs``.

        Parameters
        ----------
        defs : dict
            The document's ``$defs``, filled in place.

        Returns
        -------
        dict
        """
        out: dict[str, Any] = {"type": "object", "title": self.title}
        if self.description:
            out["description"] = self.description
        out["properties"] = {k: v.schema(defs) for k, v in self.fields.items()}
        out["required"] = [k for k in self.fields if k not in self.optional]
        out["additionalProperties"] = not self.closed
        return out

    def schema(self, defs: dict[str, Any]) -> dict[str, Any]:
        """A ``$ref`` to this record, whose body goes into ``defs`` (once per title).

        Parameters
        ----------
        defs : dict
            The document's ``$defs``, filled in place.

        Returns
        -------
        dict
            ``{"$ref": "#/$defs/<title>"}``.
        """
        if self.title not in defs:
            defs[self.title] = {}  # placed first: a record that contains itself refers to it
            defs[self.title] = self.body(defs)
        return {"$ref": f"#/$defs/{self.title}"}


@dataclass(frozen=True)
class _Described(Node):
    """A record used with a description of its role (a ``$ref`` beside a ``description``)."""

    record: Record | None = None

    def __init__(self, record: Record, description: str) -> None:
        object.__setattr__(self, "fragment", {})
        object.__setattr__(self, "items", ())
        object.__setattr__(self, "kind", "described")
        object.__setattr__(self, "description", description)
        object.__setattr__(self, "record", record)

    def schema(self, defs: dict[str, Any]) -> dict[str, Any]:
        assert self.record is not None
        return {**self.record.schema(defs), "description": self.description}


#: A box ``{lower, upper}`` (a region of the state space).
BOX = Record("Box", {"lower": array(NUMBER), "upper": array(NUMBER)},
             description="An axis-aligned box: lower and upper corner, one entry per state.")


def document_schema(node: Node, command: str, *, versioned: bool = True, description: str = "") -> dict[str, Any]:
    """The JSON Schema document (draft 2020-12) of a command's JSON output.

    Parameters
    ----------
    node : Node
        The output's shape: a :class:`Record` (an object report) or an array of records (a list output).
    command : str
        The command, e.g. ``"analyze"`` or ``"design drift"`` (the schema's ``title`` and ``$id``).
    versioned : bool
        An object report that starts with ``schema_version`` (:data:`nlobs._io.SCHEMA_VERSION`).
    description : str
        The document's ``description``.

    Returns
    -------
    dict
        A JSON-serialisable schema with its records under ``$defs``.

    Examples
    --------
    An object report starts with ``schema_version`` (required, the constant
    :data:`nlobs._io.SCHEMA_VERSION`); a list output refers to its items' record under ``$defs``:

    >>> point = Record("Point", {"x": NUMBER, "label": nullable(STRING)}, optional={"label"})
    >>> doc = document_schema(point, "design drift")
    >>> doc["$id"], doc["title"]
    ('urn:nlobs:schema:design-drift', 'nlobs design drift: JSON output')
    >>> doc["required"], doc["properties"]["schema_version"], doc["additionalProperties"]
    (['schema_version', 'x'], {'const': 1}, False)
    >>> listing = document_schema(array(point), "models", versioned=False)
    >>> listing["type"], listing["items"], sorted(listing["$defs"])
    ('array', {'$ref': '#/$defs/Point'}, ['Point'])

    The keys of a real report, a :class:`~nlobs.checks.Check` written as JSON, are those its document declares:

    >>> from nlobs._io import with_schema
    >>> from nlobs.checks import CHECK_JSON, Check, CheckKind
    >>> report = with_schema(Check.compare("‖H‖∞ < γ", 0.8, 1.0, kind=CheckKind.NORM).to_dict())
    >>> list(report) == list(document_schema(CHECK_JSON, "check")["properties"])
    True
    """
    from nlobs._io import SCHEMA_VERSION

    defs: dict[str, Any] = {}

    def versioned_body(rec: Record) -> dict[str, Any]:
        return Record(rec.title, {"schema_version": Node({"const": SCHEMA_VERSION}), **rec.fields},
                      optional=rec.optional, closed=rec.closed, description=rec.description).body(defs)

    if versioned and isinstance(node, Record):
        body = versioned_body(node)
    elif versioned and node.kind == "anyOf" and all(isinstance(i, Record) for i in node.items):
        body = {"anyOf": [versioned_body(i) for i in node.items if isinstance(i, Record)]}
    else:
        body = node.schema(defs)
    out: dict[str, Any] = {"$schema": DIALECT, "$id": f"urn:nlobs:schema:{command.replace(' ', '-')}",
                           "title": f"nlobs {command}: JSON output"}
    out.update(body)
    out["title"] = f"nlobs {command}: JSON output"
    if description:
        out["description"] = description
    if defs:
        out["$defs"] = defs
    return out
