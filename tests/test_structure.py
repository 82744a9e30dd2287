"""The structure the design asks for: every service speaks the protocol in ``shared/`` and imports no other
service, and ``shared/`` imports no service. Read from the source's own import statements (``ast``), so a
lazy import inside a function counts as much as one at the top."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SERVICES = sorted(p.name for p in (ROOT / "services").iterdir() if (p / "__init__.py").is_file())


def _imported_modules(path: Path) -> list[tuple[int, str]]:
    """``(line, dotted module)`` of every import in ``path``, relative imports resolved to ``bimbot.…``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    relative_to = ROOT
    package = ["bimbot", *path.parent.relative_to(relative_to).parts]
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.extend((node.lineno, alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                module = ".".join([*base, node.module] if node.module else base)
            else:
                module = node.module or ""
            found.append((node.lineno, module))
    return found


def _service_of(module: str) -> str | None:
    parts = module.split(".")
    if len(parts) >= 3 and parts[:2] == ["bimbot", "services"] and parts[2] in SERVICES:
        return parts[2]
    return None


def test_no_service_imports_another_service() -> None:
    crossings = []
    for service in SERVICES:
        for path in sorted((ROOT / "services" / service).rglob("*.py")):
            for line, module in _imported_modules(path):
                other = _service_of(module)
                if other is not None and other != service:
                    crossings.append(f"{path.relative_to(ROOT)}:{line} imports {module}")
    assert crossings == []


def test_shared_imports_no_service_and_nothing_above_it() -> None:
    upward = []
    for path in sorted((ROOT / "shared").rglob("*.py")):
        for line, module in _imported_modules(path):
            if module.startswith("bimbot.") and not module.startswith("bimbot.shared"):
                upward.append(f"{path.relative_to(ROOT)}:{line} imports {module}")
    assert upward == []


def test_services_import_nothing_of_the_command_line_package_above_them() -> None:
    upward = []
    for path in sorted((ROOT / "services").rglob("*.py")):
        for line, module in _imported_modules(path):
            if module.startswith("bimbot.") and not module.startswith(("bimbot.shared", "bimbot.services")):
                upward.append(f"{path.relative_to(ROOT)}:{line} imports {module}")
    assert upward == []


KIND_FLAGS = ("is_crane", "is_ground", "is_carrier", "is_husky", "is_tower_crane", "is_pump", "is_layer")


def test_services_ask_for_capabilities_never_for_a_kind_of_robot() -> None:
    """A robot kind is a fleet entry: no service tests a kind flag or compares a type's name."""
    found = []
    for folder in ("services", "shared", "bimbot"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            for node in ast.walk(tree):
                if isinstance(node, ast.Attribute) and node.attr in KIND_FLAGS:
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno} .{node.attr}")
                if isinstance(node, ast.Compare) and any(
                    isinstance(side, ast.Constant) and side.value in ("tower_crane", "carrier", "husky")
                    for side in (node.left, *node.comparators)
                ):
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno} compares a robot type's name")
    assert found == []
