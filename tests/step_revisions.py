"""A STEP file's next revision, edited as text: one solid's points shifted (tests/test_regress_diff.py).

STEP shapes outside an assembly carry their position in their own coordinates; moving one
means moving every CARTESIAN_POINT its B-rep reaches (directions and vectors stay)."""

from __future__ import annotations

import re
from collections import deque
from pathlib import Path

_ENTITY = re.compile(r"^#(\d+)\s*=\s*(.*?);\s*$", re.M | re.S)
_XYZ = re.compile(r"\(\s*([-0-9.eE+]+)\s*,\s*([-0-9.eE+]+)\s*,\s*([-0-9.eE+]+)\s*\)")


def _reached(entities: dict, root: str) -> set:
    seen, todo = set(), deque([root])
    while todo:
        number = todo.popleft()
        if number in seen or number not in entities:
            continue
        seen.add(number)
        todo.extend(re.findall(r"#(\d+)", entities[number]))
    return seen


def shift_solid(path: Path, out: Path, name: str, offset) -> None:
    """Write ``path`` to ``out`` with the MANIFOLD_SOLID_BREP named ``name`` moved by ``offset``
    (in the file's length unit)."""
    text = path.read_text()
    entities = dict(_ENTITY.findall(text))
    root = next(n for n, body in entities.items() if body.startswith(f"MANIFOLD_SOLID_BREP( '{name}'"))
    reached = _reached(entities, root)

    def shifted(match):
        number, body = match.group(1), match.group(2)
        if number in reached and body.lstrip().startswith("CARTESIAN_POINT"):
            xyz = _XYZ.search(body)
            values = ", ".join(repr(float(v) + d) for v, d in zip(xyz.groups(), offset))
            body = f"{body[: xyz.start()]}( {values} ){body[xyz.end() :]}"
        return f"#{number} = {body};"

    out.write_text(_ENTITY.sub(shifted, text))
