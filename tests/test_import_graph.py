"""The package's import graph flows one way: no module imports, directly or through others,
a module that imports it (imports inside functions count; annotation-only imports under
``if TYPE_CHECKING`` do not)."""

import ast
from pathlib import Path

from conftest import ROOT

PACKAGE = ROOT / "src" / "mechfmu"


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _annotation_only(node: ast.AST, parents: dict) -> bool:
    """Whether ``node`` sits under ``if TYPE_CHECKING:``."""
    while node in parents:
        node = parents[node]
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            return True
    return False


def imports(path: Path, modules: set) -> set:
    """The package modules that the module at ``path`` imports."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    found = set()
    for node in ast.walk(tree):
        if not isinstance(node, (ast.Import, ast.ImportFrom)) or _annotation_only(node, parents):
            continue
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        else:
            base = package
            for _ in range(node.level - 1):
                base = base.rpartition(".")[0]
            stem = ".".join(
                part for part in (base if node.level else "", node.module or "") if part
            )
            # "from .x import y": y is a module of x when there is one, else a name in x
            targets = [
                f"{stem}.{alias.name}" if f"{stem}.{alias.name}" in modules else stem
                for alias in node.names
            ]
        found |= {target for target in targets if target in modules and target != name}
    return found


def import_graph() -> dict:
    paths = [path for path in PACKAGE.rglob("*.py") if "__pycache__" not in path.parts]
    modules = {module_name(path) for path in paths}
    return {module_name(path): imports(path, modules) for path in paths}


def circles(graph: dict) -> list:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in graph.get(node, ()):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_the_import_graph_has_no_circles():
    graph = import_graph()
    assert len(graph) > 80 and "mechfmu.cosim.run" in graph["mechfmu.api"]
    assert circles(graph) == []


def test_the_circle_finder_finds_a_circle():
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_the_api_runs_a_scene_through_one_cosim_entry_and_cosim_imports_no_host_tools():
    graph = import_graph()
    cosim = {name for name in graph if name.startswith("mechfmu.cosim")}
    api = graph["mechfmu.api"] & cosim
    assert "mechfmu.cosim.master" not in api or "mechfmu.cosim.run" in api
    for name in cosim:
        above = {t for t in graph[name] if not t.startswith(("mechfmu.cosim", "mechfmu.runtime"))}
        assert above <= {"mechfmu"}, (name, above)  # mechfmu: its __version__
