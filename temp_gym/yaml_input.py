"""YAML that users hand temp-gym (robot descriptions, MoveIt scenes): read safely and bounded.

* **Numbers as YAML 1.2 reads them.** PyYAML follows YAML 1.1, whose floats need a dot:
  ``tolerance: 6e-3`` or a ROS tool's ``1e-05`` would come back as strings and be refused as
  "not a number". `load_yaml` reads them as the floats they are; nothing else changes
  (``'6e-3'`` in quotes stays a string).
* **Keys once.** A key given twice in one mapping is refused (PyYAML would keep the last one
  silently); keys a merge (``<<``) brings in may be overridden, as YAML intends.
* **Bounded.** Aliases may share a node, but not make a node contain itself, nor expand into
  more than `MAX_YAML_NODES` nodes (a few aliases nested can stand for billions, which a
  reader walking the tree would never finish), nor nest a branch deeper than `MAX_YAML_DEPTH`
  (`check_tree`). A document without anchors has no aliases: it is a plain tree no larger than
  its text, nested no deeper than libyaml's parser allows (1,000 levels), and readers walk it
  without recursion. Past these limits, and on invalid YAML, `load_yaml` raises a one-line
  `ValueError` naming the file.

Only safe YAML is read: PyYAML's safe loader, which builds plain mappings, lists, strings and
numbers, never Python objects; libyaml's build of it where PyYAML has one (ten times faster:
MotionBenchMaker's 1,400 files take seconds instead of most of a minute).
"""

from __future__ import annotations

import re

import yaml

from temp_gym.limits import MAX_YAML_DEPTH, MAX_YAML_NODES

_BASE = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class _Loader(_BASE):  # type: ignore[misc, valid-type]
    """``yaml.safe_load``'s loader, reading YAML 1.2's numbers and refusing repeated keys.

    PyYAML keeps the last of a key given twice in one mapping silently; YAML says keys are
    unique.
    """

    def construct_mapping(self, node, deep=False):  # noqa: D102  (PyYAML's hook)
        if isinstance(node, yaml.MappingNode):
            seen = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":  # "<<": merged keys may repeat
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    repeated = key in seen
                except TypeError:  # an unhashable key: PyYAML's own error follows
                    continue
                if repeated:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"found the key {key!r} twice", key_node.start_mark
                    )
                seen.add(key)
        return super().construct_mapping(node, deep=deep)


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+.0123456789"),
)


def load_yaml(data: str | bytes, name: str, anchors: bool = True) -> object:
    """The document in ``data`` (module docstring); ``name`` names it in errors.

    ``anchors=False`` refuses any anchor or alias, as the parser reads them: an ``&`` in a
    comment or a quoted string is no anchor.

    Raises:
        ValueError: invalid YAML, an anchor or alias where ``anchors`` is False, or a document
            that contains itself, expands too far or nests too deep (one line:
            ``name: reason``).
    """
    if not anchors:
        _refuse_anchors(data, name)
    try:
        document = yaml.load(data, Loader=_Loader)  # noqa: S506  (a safe loader)
    except yaml.reader.ReaderError as error:  # bytes that are no text in any encoding YAML reads
        encoding = error.encoding if error.encoding not in (None, "?") else "UTF-8"
        raise ValueError(
            f"{name}: not valid YAML: not {encoding} text at byte {error.position} ({error.reason})"
        ) from None
    except yaml.YAMLError as error:
        problem = getattr(error, "problem", None) or type(error).__name__
        mark = getattr(error, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise ValueError(f"{name}: not valid YAML{where}: {problem}") from None
    except RecursionError:
        raise ValueError(f"{name}: nested more than {MAX_YAML_DEPTH} levels deep") from None
    # Without an anchor there is no alias: the document is a plain tree no larger than its
    # text, nested no deeper than the parser allows. Walking it would cost a tenth of reading.
    if ("&" if isinstance(data, str) else b"&") in data:
        check_tree(document, name)
    return document


def _refuse_anchors(data: str | bytes, name: str) -> None:
    """Raise a `ValueError` if the parser meets an anchor or an alias in ``data``."""
    if ("&" if isinstance(data, str) else b"&") not in data:  # no anchor, so no alias either
        return
    try:
        for event in yaml.parse(data, Loader=_BASE):
            anchor = getattr(event, "anchor", None)
            if anchor is not None:
                raise ValueError(f"{name}: YAML anchors and aliases are not accepted "
                                 f"(&{anchor} / *{anchor}); write the value out")  # fmt: skip
    except yaml.YAMLError:
        return  # `load_yaml` names the defect


def check_tree(document: object, name: str) -> None:
    """Refuse a document that contains itself, expands too far or nests too deep.

    Walks each distinct mapping and list once (without recursion), keeping how many nodes it
    expands to and how deep it nests; a node met again while its own walk is under way
    contains itself, and a node met again elsewhere adds its depth to that place's.
    """
    sizes: dict[int, tuple[int, int]] = {}  # id -> (nodes it expands to, levels it nests)
    under_way: set[int] = set()
    stack: list[tuple[object, int, bool]] = [(document, 1, False)]
    while stack:
        node, depth, done = stack.pop()
        children = _children(node)
        if children is None:
            continue
        key = id(node)
        if done:
            under_way.discard(key)
            walked = [sizes[id(child)] for child in children if id(child) in sizes]
            count = 1 + len(children) - len(walked) + sum(size for size, _ in walked)
            sizes[key] = (count, 1 + max((levels for _, levels in walked), default=0))
            if count > MAX_YAML_NODES:
                raise ValueError(f"{name}: expands to more than {MAX_YAML_NODES:,} values "
                                 "(through aliases)")  # fmt: skip
            continue
        if key in sizes:
            depth += sizes[key][1] - 1
        elif key in under_way:
            raise ValueError(f"{name}: an alias makes a value contain itself")
        if depth > MAX_YAML_DEPTH:
            raise ValueError(f"{name}: nested more than {MAX_YAML_DEPTH} levels deep")
        if key in sizes:
            continue
        under_way.add(key)
        stack.append((node, depth, True))
        stack.extend((child, depth + 1, False) for child in children)


def _children(node: object) -> list | None:
    """A mapping's values or a list's items; None for anything else."""
    if isinstance(node, dict):
        return list(node.values())
    if isinstance(node, list):
        return node
    return None


__all__ = ["check_tree", "load_yaml"]
