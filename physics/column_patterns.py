"""The column names of a marker table (physics.importers): patterns with placeholders, and node labels.

A pattern is a ``str.format`` template. Node columns may use ``{node}`` (0..11), ``{label}`` (the
node's label), ``{axis}`` (x, y, z) and ``{AXIS}`` (X, Y, Z); one of ``{node}``/``{label}`` and one
of ``{axis}``/``{AXIS}`` are needed so that the 36 columns have names of their own. Cable columns
(commanded and measured rest lengths) may use ``{cable}`` (physics.geometry.CABLE_NAMES, e.g.
``c00_04``) and ``{a}``, ``{b}``: the labels of the cable's two end nodes (CABLE_NODES), which come
together, and which a file may write in either order (``motor_A1_C1`` or ``motor_C1_A1``).

``labels`` name nodes 0..11 in order (rod i joins nodes 2i and 2i+1): 12 non-empty names, unique
without case (columns are matched without case and surrounding spaces). Without labels a node's
label is its number as text, so ``{a}``/``{b}`` are numbers. Every mistake in a layout is an
:class:`ImportFormatError` of one line raised when the layout is made, before any file is touched.
"""
from __future__ import annotations

import string
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

from physics.errors import ImportFormatError
from physics.geometry import CABLE_NAMES, CABLE_NODES, N_NODES

__all__ = ["NODE_FIELDS", "CABLE_FIELDS", "ColumnLayout", "layout_from_options", "parse_labels"]

#: Placeholders of a node pattern.
NODE_FIELDS = ("node", "label", "axis", "AXIS")
#: Placeholders of a cable pattern (controls and measured rest lengths).
CABLE_FIELDS = ("cable", "a", "b")
_AXES = ("x", "y", "z")
PatternKind = Literal["node", "cable"]


def parse_labels(text: str) -> tuple[str, ...]:
    """The comma-separated labels of the command line (``--labels A1,A2,...``), spaces around each dropped;
    empty entries are kept so that :class:`ColumnLayout` can name them."""
    return tuple(part.strip() for part in text.split(","))


def _check_labels(labels: tuple[str, ...]) -> None:
    """ImportFormatError unless ``labels`` are N_NODES non-empty names, unique without case."""
    if isinstance(labels, str) or not all(isinstance(label, str) for label in labels):
        raise ImportFormatError(f"labels must be a sequence of {N_NODES} names (strings), got {labels!r}; "
                                "on the command line: --labels A1,A2,... .")
    if len(labels) != N_NODES:
        raise ImportFormatError(f"labels: {len(labels)} given ({', '.join(labels)}), {N_NODES} needed: one per node "
                                "0..11 in order, rod i joining nodes 2i and 2i+1.")
    empty = [n for n, label in enumerate(labels) if not label.strip()]
    if empty:
        raise ImportFormatError(f"labels: the label of node {empty[0]} is empty; give every node 0..11 a name.")
    seen: dict[str, int] = {}
    for node, label in enumerate(labels):
        key = label.strip().lower()
        if key in seen:
            first = labels[seen[key]]
            same = f"{first!r} twice" if first == label else f"{first!r} and {label!r}, the same without case,"
            raise ImportFormatError(f"labels: duplicate label: {same} for nodes {seen[key]} and {node}; give each "
                                    "node its own label.")
        seen[key] = node


def _fields(pattern: str, option: str) -> set[str]:
    """The placeholder names of ``pattern``; ImportFormatError for a malformed pattern or an unnamed ``{}``."""
    if not isinstance(pattern, str) or not pattern.strip():
        raise ImportFormatError(f"{option} must be a non-empty pattern, got {pattern!r}.")
    try:
        names = {field for _, field, _, _ in string.Formatter().parse(pattern) if field is not None}
    except ValueError as exc:
        raise ImportFormatError(f"{option} {pattern!r} is not a pattern ({exc}); write a literal brace as "
                                "{{ or }}.") from None
    if any(not name or name.isdigit() for name in names):
        raise ImportFormatError(f"{option} {pattern!r} has an unnamed placeholder; name it, e.g. {{label}}.")
    return names


def _check_pattern(pattern: str, option: str, kind: PatternKind) -> None:
    """ImportFormatError unless ``pattern`` uses only the placeholders of ``kind`` and enough of them to
    give every node-axis (or cable) a name of its own."""
    allowed = NODE_FIELDS if kind == "node" else CABLE_FIELDS
    names = _fields(pattern, option)
    listed = ", ".join("{" + field + "}" for field in allowed)
    unknown = sorted(names - set(allowed))
    if unknown:
        raise ImportFormatError(f"{option} {pattern!r}: the placeholder {{{unknown[0]}}} is unknown in a {kind} "
                                f"pattern; it may use {listed}.")
    if kind == "node" and not names & {"node", "label"}:
        raise ImportFormatError(f"{option} {pattern!r} needs {{node}} or {{label}} to tell the 12 nodes apart.")
    if kind == "node" and not names & {"axis", "AXIS"}:
        raise ImportFormatError(f"{option} {pattern!r} needs {{axis}} or {{AXIS}} to tell the 3 axes apart.")
    if kind == "cable" and len(names & {"a", "b"}) == 1:
        given, other = ("a", "b") if "a" in names else ("b", "a")
        raise ImportFormatError(f"{option} {pattern!r} uses {{{given}}} without {{{other}}}: a cable is named by "
                                "both its end labels, e.g. motor_{a}_{b}, or by {cable}.")
    if kind == "cable" and not names & {"cable", "a"}:
        raise ImportFormatError(f"{option} {pattern!r} needs {{cable}}, or {{a}} and {{b}}, to tell the 24 cables "
                                "apart.")


def _format(pattern: str, option: str, values: Mapping[str, str | int]) -> str:
    """``pattern`` filled with ``values``; ImportFormatError for a format spec that does not fit (e.g. {label:03d})."""
    try:
        return pattern.format_map(values)
    except (ValueError, TypeError, KeyError, IndexError, AttributeError) as exc:
        raise ImportFormatError(f"{option} {pattern!r} cannot be filled in ({type(exc).__name__}: {exc}); "
                                "check the format spec after ':' in its placeholders.") from None


@dataclass(frozen=True)
class ColumnLayout:
    """The names of a marker table's columns (module docstring): the time column's literal name, the
    node, control and measured rest-length patterns, and the node labels (None: the node numbers).
    Validated when made, including that no two columns would share a name."""

    time_column: str = "time"
    node_columns: str = "node{node}_{axis}"
    control_columns: str = "{cable}"
    rest_length_columns: str = "rest_{cable}"
    labels: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        if self.labels is not None:
            _check_labels(self.labels)
        if not isinstance(self.time_column, str) or not self.time_column.strip():
            raise ImportFormatError(f"time_column must be a non-empty column name, got {self.time_column!r}.")
        _check_pattern(self.node_columns, "node_columns", "node")
        _check_pattern(self.control_columns, "control_columns", "cable")
        _check_pattern(self.rest_length_columns, "rest_length_columns", "cable")
        self._check_distinct()

    def uses_labels(self) -> bool:
        """Whether a pattern has {label}, {a} or {b} (node numbers when ``labels`` is None)."""
        patterns = (self.node_columns, self.control_columns, self.rest_length_columns)
        return any(field in ("label", "a", "b") for p in patterns for field in _fields(p, "pattern"))

    def label(self, node: int) -> str:
        """The label of ``node`` (0..11): its entry of ``labels``, or its number as text."""
        return str(node) if self.labels is None else self.labels[node]

    def node_names(self) -> tuple[str, ...]:
        """The 36 node column names, node by node, axes x, y, z of the file's frame."""
        return tuple(_format(self.node_columns, "node_columns",
                             {"node": n, "label": self.label(n), "axis": axis, "AXIS": axis.upper()})
                     for n in range(N_NODES) for axis in _AXES)

    def control_names(self) -> tuple[tuple[str, ...], ...]:
        """Per cable (CABLE_NAMES order), the names its control column may have: ends in either order."""
        return self._cable_names(self.control_columns, "control_columns")

    def rest_length_names(self) -> tuple[tuple[str, ...], ...]:
        """Per cable, the names its measured rest-length column may have (as :meth:`control_names`)."""
        return self._cable_names(self.rest_length_columns, "rest_length_columns")

    def _cable_names(self, pattern: str, option: str) -> tuple[tuple[str, ...], ...]:
        out = []
        for cable, (a, b) in zip(CABLE_NAMES, CABLE_NODES.tolist(), strict=True):
            names = [_format(pattern, option, {"cable": cable, "a": self.label(x), "b": self.label(y)})
                     for x, y in ((a, b), (b, a))]
            out.append(tuple(dict.fromkeys(names)))
        return tuple(out)

    def _check_distinct(self) -> None:
        """ImportFormatError when two columns would have the same name (compared as the importer does)."""
        owners: list[tuple[str, str]] = [(self.time_column, "the time column")]
        owners += [(name, f"node {i // 3} {_AXES[i % 3]}") for i, name in enumerate(self.node_names())]
        for what, groups in (("control", self.control_names()), ("rest length", self.rest_length_names())):
            owners += [(name, f"the {what} of {cable}") for cable, names in zip(CABLE_NAMES, groups, strict=True)
                       for name in names]
        seen: dict[str, str] = {}
        for name, owner in owners:
            key = name.strip().lower()
            if key in seen:
                raise ImportFormatError(f"the column name {name!r} would stand for both {seen[key]} and {owner}; "
                                        "choose patterns and labels that keep them apart (e.g. a separator "
                                        "between {a} and {b}).")
            seen[key] = owner


def layout_from_options(*, time_column: str, node_columns: str, control_columns: str, rest_length_columns: str,
                        labels: Sequence[str] | None) -> ColumnLayout:
    """A :class:`ColumnLayout` from the importer's keyword options (``labels`` any sequence of names)."""
    if isinstance(labels, str):
        raise ImportFormatError(f"labels must be a sequence of {N_NODES} names, got the string {labels!r}; "
                                "split it, e.g. parse_labels('A1,A2,...').")
    return ColumnLayout(time_column=time_column, node_columns=node_columns, control_columns=control_columns,
                        rest_length_columns=rest_length_columns, labels=None if labels is None else tuple(labels))
