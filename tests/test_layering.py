"""The import arrows point one way: criticism -> belief -> embeddings -> physics, planners -> belief.

Every module of the five library packages is parsed with ``ast`` (not imported), so every import
counts: at module level, inside functions, under ``if TYPE_CHECKING:``, and
``importlib.import_module("...")`` / ``__import__("...")`` with a literal name. An import of a
library package outside the allowed set below fails the test with its file:line.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: package -> the other library packages it may import.
ALLOWED: dict[str, frozenset[str]] = {
    "physics": frozenset(),
    "embeddings": frozenset({"physics"}),
    "belief": frozenset({"embeddings", "physics"}),
    "planners": frozenset({"belief", "embeddings", "physics"}),
    "criticism": frozenset({"belief", "embeddings", "physics"}),
}
_DYNAMIC = {"import_module", "__import__"}


def _imported_names(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import in ``tree``; relative imports stay in their package
    and are skipped."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append((node.lineno, node.module))
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant):
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if name in _DYNAMIC and isinstance(node.args[0].value, str):
                found.append((node.lineno, node.args[0].value))
    return sorted(found)


def layering_violations(root: Path, allowed: dict[str, frozenset[str]] = ALLOWED) -> list[str]:
    """"file:line: package imports module (allowed: ...)" for every import that breaks ``allowed``."""
    out = []
    for package, may in allowed.items():
        for path in sorted((root / package).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
            for line, module in _imported_names(tree):
                target = module.split(".")[0]
                if target in allowed and target != package and target not in may:
                    out.append(f"{path.relative_to(root)}:{line}: {package} imports {module} "
                               f"(allowed: {', '.join(sorted(may)) or 'no other library package'})")
    return out


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_each_package_imports_only_the_packages_below_it(package: str) -> None:
    modules = list((ROOT / package).rglob("*.py"))
    assert modules, f"no modules found under {ROOT / package}"
    bad = [v for v in layering_violations(ROOT) if v.startswith(f"{package}/")]
    assert not bad, "imports against the layering:\n" + "\n".join(bad)


def test_the_check_sees_imports_in_functions_under_type_checking_and_by_name(tmp_path: Path) -> None:
    """A planted violation of each kind is reported with its file and line."""
    for package in ALLOWED:
        (tmp_path / package).mkdir()
    (tmp_path / "belief" / "bad.py").write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n"
        "    from criticism.search import Criticism\n"
        "def f():\n"
        "    import planners.robust\n"
        "    return importlib.import_module('criticism')\n"
        "from . import posterior\n")
    (tmp_path / "physics" / "ok.py").write_text("import numpy\nfrom physics.errors import TensegridError\n")
    assert layering_violations(tmp_path) == [
        "belief/bad.py:3: belief imports criticism.search (allowed: embeddings, physics)",
        "belief/bad.py:5: belief imports planners.robust (allowed: embeddings, physics)",
        "belief/bad.py:6: belief imports criticism (allowed: embeddings, physics)",
    ]
