"""The architecture of planner/, measured on its source: imports run one way.

* No function-local import of a planner module (an import inside a function hides a cycle
  and defers its failure to the first call). Deferring matplotlib, an optional heavy import,
  is allowed: planner/plots.py (matplotlib.animation) and planner/trajectory/plot.py do.
* The graph of module-level imports among planner's modules (imports under
  ``if TYPE_CHECKING:`` are for type checkers only and do not run) has no cycle.
"""

from __future__ import annotations

import ast
from pathlib import Path

PLANNER = Path(__file__).resolve().parent.parent / "planner"


def module_name(path: Path) -> str:
    parts = path.relative_to(PLANNER.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(path): path for path in sorted(PLANNER.rglob("*.py"))}


def imported(node: ast.Import | ast.ImportFrom, here: str) -> list[str]:
    """The planner modules an import statement loads: ``from planner.x import y`` loads
    planner.x.y when that is a module (a submodule), else planner.x."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names if alias.name.split(".")[0] == "planner"]
    if node.level:  # relative: resolve against the importing module's package
        package = here if here in PACKAGES else here.rsplit(".", 1)[0]
        for _ in range(node.level - 1):
            package = package.rsplit(".", 1)[0]
        base = package + (f".{node.module}" if node.module else "")
    else:
        base = node.module or ""
    if base.split(".")[0] != "planner":
        return []
    out = []
    for alias in node.names:
        submodule = f"{base}.{alias.name}"
        out.append(submodule if submodule in MODULES else base)
    return out


PACKAGES = {name for name, path in MODULES.items() if path.name == "__init__.py"}


def is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def test_the_scan_sees_the_modules_and_their_imports():
    # the guard: the scan finds planner's modules and reads their imports
    assert {"planner.ocp", "planner.transcription", "planner.solver", "planner.problem"} <= set(
        MODULES
    )
    assert "planner.trajectory.value" in MODULES and "planner.trajectory" in PACKAGES
    edges = module_graph()
    assert "planner.ocp" in edges["planner.transcription"]
    assert "planner.solver" in edges["planner.problem"]


def test_no_function_local_import_of_a_planner_module():
    found = []
    for name, path in MODULES.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for function in ast.walk(tree):
            if not isinstance(function, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda):
                continue
            for node in ast.walk(function):
                if isinstance(node, ast.Import | ast.ImportFrom) and imported(node, name):
                    found.append(f"{path.relative_to(PLANNER.parent)}:{node.lineno}")
    assert not found, f"function-local imports of planner modules: {found}"


def module_graph() -> dict[str, set[str]]:
    """Module -> the planner modules its module-level code imports (not its own packages)."""
    graph = {}
    for name, path in MODULES.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        targets: set[str] = set()
        statements = list(tree.body)
        while statements:
            node = statements.pop()
            if isinstance(node, ast.If) and is_type_checking(node):
                statements.extend(node.orelse)
                continue
            if isinstance(node, ast.If | ast.Try | ast.With):
                for block in ("body", "orelse", "finalbody", "handlers"):
                    statements.extend(getattr(node, block, []) or [])
                continue
            if isinstance(node, ast.ExceptHandler):
                statements.extend(node.body)
                continue
            if isinstance(node, ast.Import | ast.ImportFrom):
                targets.update(imported(node, name))
        # a submodule loads its parent packages first: that is Python's, not a dependency
        ancestors = {".".join(name.split(".")[:i]) for i in range(1, name.count(".") + 1)}
        graph[name] = {t for t in targets if t in MODULES and t not in ancestors and t != name}
    return graph


def test_imports_inside_planner_run_one_way():
    graph = module_graph()
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for target in sorted(graph[node]):
            if state.get(target) == 1:
                return [*path[path.index(target) :], target]
            if target not in state:
                cycle = visit(target)
                if cycle:
                    return cycle
        path.pop()
        state[node] = 2
        return None

    for module in sorted(graph):
        if module not in state:
            cycle = visit(module)
            assert cycle is None, f"import cycle: {' -> '.join(cycle)}"


#: The linkage naming convention's prefixes, which only the linkage adapter may spell.
LINKAGE_PREFIXES = ("psi_", "dpsi_", "ddpsi_", "M_")
ADAPTER = "planner.linkage_system"


def spelled_prefixes(source: str, where: str) -> list[str]:
    """Where a string literal of ``source`` (docstrings aside: they document the convention)
    holds a linkage prefix: "where:line 'literal'"."""
    tree = ast.parse(source)
    docstrings = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                docstrings.add(id(body[0].value))
    found = []
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Constant)
            and isinstance(node.value, str)
            and id(node) not in docstrings
            and any(prefix in node.value for prefix in LINKAGE_PREFIXES)
        ):
            found.append(f"{where}:{node.lineno} {node.value!r}")
    return found


def test_no_linkage_name_is_spelled_outside_the_linkage_adapter():
    found = [
        place
        for name, path in MODULES.items()
        if name != ADAPTER
        for place in spelled_prefixes(path.read_text(encoding="utf-8"), name)
    ]
    assert not found, f"linkage names spelled outside {ADAPTER}: {found}"
    # the guard: the scan finds a prefix in a literal and an f-string, not in a docstring
    sample = '''"""psi_<link> documented."""
names = ["M_" + link for link in links]
label = f"ddpsi_{link}"
'''
    assert sorted(place.split()[0] for place in spelled_prefixes(sample, "s")) == ["s:2", "s:3"]
