"""The runtime modules one FMU needs: the import closure of its model's module (host side).

``mechfmu build`` copies into each FMU only the files of ``mechfmu.runtime`` that its model
imports, directly or through other runtime modules (and the ``__init__.py`` of every package
on the way), read from the sources with ``ast``: a landing gear does not carry the valve
spring's physics. The FMI binding is the one of the FMU's version (fmi2.py or fmi3.py, which
the FMU's own fmi/binding.py names).
"""

import ast
from pathlib import Path

RUNTIME_PACKAGE = "mechfmu.runtime"
_RUNTIME_PARTS = tuple(RUNTIME_PACKAGE.split("."))


def _module_file(root: Path, parts: tuple[str, ...]) -> Path | None:
    """The file of runtime module ``parts`` (relative to the runtime package), or None."""
    base = root.joinpath(*parts)
    if base.with_suffix(".py").is_file():
        return base.with_suffix(".py")
    if (base / "__init__.py").is_file():
        return base / "__init__.py"
    return None


def _package_of(root: Path, source: Path) -> tuple[str, ...]:
    """The package (as parts relative to the runtime) that ``source`` belongs to."""
    relative = source.relative_to(root).with_suffix("")
    parts = relative.parts
    return parts[:-1]


def _imported(root: Path, source: Path) -> set[tuple[str, ...]]:
    """Runtime modules (or names in them) ``source`` imports, as parts relative to the
    runtime package; names that are not modules are dropped by the caller."""
    package = _package_of(root, source)
    found: set[tuple[str, ...]] = set()
    for node in ast.walk(ast.parse(source.read_text(), str(source))):
        if isinstance(node, ast.Import):
            found.update(
                tuple(alias.name.split(".")[len(_RUNTIME_PARTS) :])
                for alias in node.names
                if alias.name.startswith(RUNTIME_PACKAGE + ".")
            )
            continue
        if not isinstance(node, ast.ImportFrom):
            continue
        named = tuple(node.module.split(".")) if node.module else ()
        if node.level:  # relative: level 1 is the package itself
            if node.level - 1 > len(package):
                continue
            module = package[: len(package) - (node.level - 1)] + named
        elif named[: len(_RUNTIME_PARTS)] == _RUNTIME_PARTS:
            module = named[len(_RUNTIME_PARTS) :]
        else:
            continue
        found.add(module)
        found.update((*module, alias.name) for alias in node.names)  # "from . import x"
    return found


def runtime_closure(root: Path, module: str, binding: str) -> list[Path]:
    """The files (relative to the runtime folder ``root``) that ``module`` (a dotted name
    under mechfmu.runtime) needs, with ``binding`` (``fmi2`` or ``fmi3``) as the FMI
    binding; every package's ``__init__.py`` on the way included."""
    start = tuple(module[len(RUNTIME_PACKAGE) + 1 :].split("."))
    pending = [start, ("fmi", binding)]
    files: set[Path] = {root / "__init__.py"}
    seen: set[tuple[str, ...]] = set()
    while pending:
        parts = pending.pop()
        if parts in seen:
            continue
        seen.add(parts)
        source = _module_file(root, parts)
        if source is None:
            continue  # a name imported from a module, not a module
        files.add(source)
        for depth in range(1, len(parts)):
            init = root.joinpath(*parts[:depth], "__init__.py")
            if init.is_file() and init not in files:
                files.add(init)
                pending.append(parts[:depth])
        imported = _imported(root, source)
        if parts == ("fmi", "binding"):  # the FMU's own binding names the version's
            imported = {("fmi", binding)}
        pending.extend(imported - seen)
    return sorted(path.relative_to(root) for path in files)
