"""The architecture of the product, measured on its source: imports run one way.

The layers, lowest first (each may import only those before it):

    planner   generic optimal control on CasADi systems; knows no linkage
    model     the linkage: its complex-variable Lagrange model, its System for the planner
              (``model.linkage_system``), its trajectories and drawings
    problems  the ready problems and the command line

Why the model sits above the planner and not beside it: the product has one error class a
user catches (``planner.errors.AnthropoidError``), which both packages raise, so one of them
imports the other's errors at least; the planner, generic, cannot know linkages; and the
adapter that makes a linkage a System (names, roles, inverse-dynamics guesses, the linkage's
trajectory type) needs the linkage's internals, so it lives with the linkage, and
``OCP(dynamics)`` keeps working through ``Dynamics.as_system`` (``planner.SystemSource``)
without the planner importing anything of the model.

Read from every ``import`` statement of model/, planner/ and problems/ (module level,
inside functions and under ``if TYPE_CHECKING:`` alike: an import inside a function only
defers a circle to the first call, and a type-only import still ties two modules together):

* planner imports nothing from model or problems, model nothing from problems;
* the graph of imports among all modules has no circle;
* no function in planner or model imports a module of the product (problems defers its
  optional heavy imports, matplotlib and MuJoCo, by importing inside the commands that
  draw or simulate);
* inside problems, the plans never import the way to a robot: ``problems.walking`` (the step
  and the step on feet) imports nothing of ``problems.control`` (the simulation, the LQR, the
  laws, MuJoCo), which reads the plans;
* the planner spells no name of the linkage convention (``psi_``, ``M_``, ...): those live
  in ``model.linkage_naming``.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: The packages, lowest layer first: a package may import only the ones before it.
LAYERS = ("planner", "model", "problems")


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {
    module_name(path): path for package in LAYERS for path in sorted((ROOT / package).rglob("*.py"))
}
PACKAGES = {name for name, path in MODULES.items() if path.name == "__init__.py"}


def owning_module(name: str) -> str | None:
    """The product module an imported dotted name loads (``planner.ocp.OCP`` -> planner.ocp),
    or None for a name outside the product."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def imported(node: ast.Import | ast.ImportFrom, here: str) -> list[str]:
    """The product modules an import statement in module ``here`` loads: ``from planner.x
    import y`` loads planner.x.y when that is a module (a submodule), else planner.x."""
    if isinstance(node, ast.Import):
        found = [owning_module(alias.name) for alias in node.names]
        return [name for name in found if name]
    if node.level:  # relative: resolve against the importing module's package
        package = here if here in PACKAGES else here.rsplit(".", 1)[0]
        for _ in range(node.level - 1):
            package = package.rsplit(".", 1)[0]
        base = package + (f".{node.module}" if node.module else "")
    else:
        base = node.module or ""
    found = []
    for alias in node.names:
        submodule = f"{base}.{alias.name}"
        found.append(submodule if submodule in MODULES else owning_module(base))
    return [name for name in found if name]


def import_nodes(path: Path) -> list[tuple[ast.Import | ast.ImportFrom, bool]]:
    """Every import statement of a file, with whether it sits inside a function."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    inside = set()
    for function in ast.walk(tree):
        if isinstance(function, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda):
            inside.update(id(node) for node in ast.walk(function))
    return [
        (node, id(node) in inside)
        for node in ast.walk(tree)
        if isinstance(node, ast.Import | ast.ImportFrom)
    ]


def module_graph(modules: dict[str, Path] = MODULES) -> dict[str, set[str]]:
    """Module -> the product modules any of its imports loads (not its own packages: a
    submodule loads its parents first, which is Python's doing, not a dependency)."""
    graph = {}
    for name, path in modules.items():
        targets = {t for node, _ in import_nodes(path) for t in imported(node, name)}
        ancestors = {".".join(name.split(".")[:i]) for i in range(1, name.count(".") + 1)}
        graph[name] = {t for t in targets if t not in ancestors and t != name}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import circle of ``graph`` as a path a -> b -> ... -> a, or None."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for target in sorted(graph.get(node, ())):
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
            if cycle:
                return cycle
    return None


def layer_violations(graph: dict[str, set[str]]) -> list[str]:
    """Imports of a higher layer by a lower one: "a -> b"."""
    rank = {package: i for i, package in enumerate(LAYERS)}
    return [
        f"{source} -> {target}"
        for source, targets in sorted(graph.items())
        for target in sorted(targets)
        if rank[target.split(".")[0]] > rank[source.split(".")[0]]
    ]


def test_the_scan_sees_every_package_and_every_kind_of_import(tmp_path):
    # the guard: the scan finds the modules and reads module-level, function-local and
    # type-only imports alike
    assert {
        "planner.ocp",
        "planner.trajectory.value",
        "model.dynamics",
        "problems.cli.walk",
    } <= set(MODULES)
    edges = module_graph()
    assert "planner.ocp" in edges["planner.transcription"]
    assert "model.linkage_system" in edges["model.dynamics"]
    assert "problems.walking.plots" in edges["problems.cli.walk"]  # imported inside a command
    sample = tmp_path / "sample.py"
    sample.write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    from model.dynamics import Dynamics\n"
        "def f():\n    from problems import cli\n",
        encoding="utf-8",
    )
    nodes = [(node, local) for node, local in import_nodes(sample) if node.module != "typing"]
    assert [imported(node, "planner.sample") for node, _ in nodes] == [
        ["model.dynamics"],
        ["problems.cli"],
    ]
    assert [local for _, local in nodes] == [False, True]


def test_layers_import_only_the_layers_below():
    violations = layer_violations(module_graph())
    assert not violations, f"imports against the layers {LAYERS}: {violations}"
    # the guard: a planner import of the model is caught
    assert layer_violations({"planner.ocp": {"model.dynamics"}, "model.dynamics": set()}) == [
        "planner.ocp -> model.dynamics"
    ]


def test_no_import_circle():
    cycle = find_cycle(module_graph())
    assert cycle is None, f"import circle: {' -> '.join(cycle)}"
    # the guard: a circle through a function-local or type-only import is one
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def package_violations(graph: dict[str, set[str]], lower: str, upper: str) -> list[str]:
    """Imports of package ``upper`` by modules of package ``lower``: "a -> b"."""
    return [
        f"{source} -> {target}"
        for source, targets in sorted(graph.items())
        if source == lower or source.startswith(lower + ".")
        for target in sorted(targets)
        if target == upper or target.startswith(upper + ".")
    ]


def test_the_plans_do_not_import_the_control():
    graph = module_graph()
    violations = package_violations(graph, "problems.walking", "problems.control")
    assert not violations, f"the walking plans import the control: {violations}"
    # the guard: the control does read the plans, and a plan importing it would be caught
    assert package_violations(graph, "problems.control", "problems.walking")
    assert package_violations(
        {"problems.walking.step": {"problems.control.lqr"}}, "problems.walking", "problems.control"
    ) == ["problems.walking.step -> problems.control.lqr"]


def test_no_function_local_import_in_planner_or_model():
    found = [
        f"{path.relative_to(ROOT)}:{node.lineno}"
        for name, path in MODULES.items()
        if name.split(".")[0] in ("planner", "model")
        for node, local in import_nodes(path)
        if local and imported(node, name)
    ]
    assert not found, f"function-local imports of product modules: {found}"


#: The linkage naming convention's prefixes, which the planner never spells.
LINKAGE_PREFIXES = ("psi_", "dpsi_", "ddpsi_", "M_")


def spelled_prefixes(source: str, where: str) -> list[str]:
    """Where a string literal of ``source`` (docstrings aside: they may give examples) holds
    a linkage prefix: "where:line 'literal'"."""
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


def test_the_planner_spells_no_linkage_name():
    found = [
        place
        for name, path in MODULES.items()
        if name.split(".")[0] == "planner"
        for place in spelled_prefixes(path.read_text(encoding="utf-8"), name)
    ]
    assert not found, f"linkage names spelled in the planner: {found}"
    # the guard: the scan finds a prefix in a literal and an f-string, not in a docstring
    sample = '''"""psi_<link> documented."""
names = ["M_" + link for link in links]
label = f"ddpsi_{link}"
'''
    assert sorted(place.split()[0] for place in spelled_prefixes(sample, "s")) == ["s:2", "s:3"]
