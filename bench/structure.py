"""The code's structure in figures: modules, import arrows between them, and the arrows that point back up.

Read from the source's own import statements (``ast``, lazy imports inside functions included), with the
installed names (``bimbot/`` → ``bimbot``, ``services/`` → ``bimbot.services``, ``shared/`` →
``bimbot.shared``). Printed:

* ``modules``: the ``.py`` files of the three packages;
* ``import arrows``: distinct (importer, imported) pairs of bimbot's own modules;
* ``cross-package arrows``: arrows whose two ends lie in different packages (folders);
* ``upward arrows``: arrows against the layers ``shared`` < ``services`` < the command-line package
  (``bimbot/``): shared code that imports a service or the command line, a service that imports the
  command line;
* ``service → service arrows``: arrows from one service into another;
* ``modules in import cycles``: modules on a cycle of arrows (strongly connected, more than one module).

``python bench/structure.py [--list]`` (``--list`` prints every upward arrow).
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections.abc import Iterator
from pathlib import Path

import networkx as nx

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = {"bimbot": "bimbot", "services": "bimbot.services", "shared": "bimbot.shared"}


def _modules() -> dict[str, Path]:
    """Dotted module name → file, for every module of the three packages."""
    found = {}
    for folder, dotted in FOLDERS.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = list(path.relative_to(ROOT / folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join([dotted, *parts])] = path
    return found


def _package_of(module: str, path: Path) -> str:
    return module if path.name == "__init__.py" else module.rpartition(".")[0]


def _imports(module: str, path: Path, known: dict[str, Path]) -> Iterator[str]:
    """The known modules ``module`` imports (``from a import b`` is ``a.b`` when that is a module)."""
    package = _package_of(module, path).split(".")
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                source = ".".join([*base, node.module] if node.module else base)
            else:
                source = node.module or ""
            names = [f"{source}.{alias.name}" for alias in node.names]
            names = [name if name in known else source for name in names]
        else:
            continue
        for name in names:
            target = name
            while target and target not in known:
                target = target.rpartition(".")[0]
            if target and target != module:
                yield target


def _layer(module: str) -> int:
    if module.startswith("bimbot.shared"):
        return 0
    if module.startswith("bimbot.services"):
        return 1
    return 2


def _service(module: str) -> str | None:
    parts = module.split(".")
    return parts[2] if len(parts) > 3 and parts[1] == "services" else None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--list", action="store_true", help="print every upward arrow")
    args = parser.parse_args(argv)
    known = _modules()
    packages = {module: _package_of(module, path) for module, path in known.items()}
    graph: nx.DiGraph = nx.DiGraph()
    graph.add_nodes_from(known)
    for module, path in known.items():
        graph.add_edges_from((module, target) for target in _imports(module, path, known))
    cross = [(a, b) for a, b in graph.edges if packages[a] != packages[b]]
    upward = [(a, b) for a, b in graph.edges if _layer(a) < _layer(b)]
    services = [(a, b) for a, b in graph.edges if _service(a) and _service(b) and _service(a) != _service(b)]
    cyclic = sum(len(c) for c in nx.strongly_connected_components(graph) if len(c) > 1)
    print(f"modules                    {len(known)}")
    print(f"import arrows              {graph.number_of_edges()}")
    print(f"cross-package arrows       {len(cross)}")
    print(f"upward arrows              {len(upward)}")
    print(f"service → service arrows   {len(services)}")
    print(f"modules in import cycles   {cyclic}")
    if args.list:
        for a, b in sorted(upward):
            print(f"  up: {a} → {b}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
