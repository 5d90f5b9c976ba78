"""Every module the code imports is the standard library's, the project's own, or from a
distribution that pyproject.toml names itself: nothing works only because a package was
left on the machine or came in as another package's dependency (``make lint``).

Usage: ``python scripts/check_deps.py`` (exit code 1 and the offending imports).
"""

from __future__ import annotations

import ast
import importlib.metadata as md
import re
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TREES = ("backend", "tests", "scripts")
OWN = {"elab", "tests", "scripts", "wire_schema"}  # wire_schema: scripts/ on a test's path


def declared() -> set[str]:
    """The distributions pyproject.toml asks for (normalised names)."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    reqs = list(project["dependencies"])
    for extra in project.get("optional-dependencies", {}).values():
        reqs += extra
    return {_norm(re.split(r"[\s<>=!~;\[]", r, maxsplit=1)[0]) for r in reqs}


def imported() -> dict[str, list[str]]:
    """Top-level modules imported anywhere in the trees, with where."""
    found: dict[str, list[str]] = {}
    for tree in TREES:
        for path in sorted((ROOT / tree).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module]
                else:
                    continue
                for name in names:
                    top = name.split(".")[0]
                    found.setdefault(top, []).append(f"{path.relative_to(ROOT)}:{node.lineno}")
    return found


def _norm(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def main() -> int:
    want, dists = declared(), md.packages_distributions()
    problems = []
    for module, where in sorted(imported().items()):
        if module in sys.stdlib_module_names or module in OWN:
            continue
        owners = {_norm(d) for d in dists.get(module, [])}
        if not owners:
            problems.append(f"{module}: not installed ({where[0]})")
        elif not owners & want:
            problems.append(
                f"{module}: from {', '.join(sorted(owners))}, which pyproject.toml does not "
                f"name ({where[0]}); add it to the dependencies"
            )
    for p in problems:
        print(p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
