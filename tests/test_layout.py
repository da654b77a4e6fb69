"""Package layout: the subpackages form the layers of :data:`LAYERS` (a module imports only from
its own part or from lower layers), no import cycles between modules of quadmodes
(function-level imports included: a lazy import that hides a cycle is still a cycle), no
oversized module or function unless listed below with its reason."""

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "quadmodes"

MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 80

#: The layers of the package, low to high: the top-level modules and subpackages of quadmodes
#: ("quadmodes" is the lazy public API of ``quadmodes/__init__.py``). A module may import from
#: its own part and from lower layers only; the parts within one layer are independent (neither
#: imports the other: the full order and the runs stand side by side on the model room).
#: ``experimental`` (research prototypes) may import anything, nothing in the product imports it.
#: docs/architecture.md draws these layers.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("_version", "errors"),
    ("limits",),
    ("rotations", "signals", "linalg", "case"),
    ("io",),
    ("mesh",),
    ("fe",),
    ("structure",),
    ("rom",),
    ("models",),
    ("fullorder", "runs"),
    ("analysis",),
    ("sweeps", "validation"),
    ("api",),
    ("cli",),
    ("quadmodes", "__main__"),
    ("experimental",),
)

# module (dotted) -> why it may exceed MAX_MODULE_LINES
LONG_MODULES: dict[str, str] = {
    "quadmodes.rom.midpoint_kernel": "numba checks only this file's time stamp before loading "
    "the cached compiled loop, so all the loop's compiled pieces (each function under 80 lines) "
    "stay in this one file to be recompiled whenever any of them changes",
    "quadmodes.rom.manifold_kernel": "formulation QM's compiled loop, for the same reason as "
    "midpoint_kernel (one file, recompiled whenever any of its pieces changes)",
}

# "module.function" -> why it may exceed MAX_FUNCTION_LINES
LONG_FUNCTIONS: dict[str, str] = {}


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(SRC).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


MODULES = _modules()


def _package_of(name: str, path: Path) -> str:
    return name if path.name == "__init__.py" else name.rpartition(".")[0]


def _imports(name: str, path: Path) -> set[str]:
    """Modules of quadmodes that ``name`` imports, anywhere in its body."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            bases = [a.name for a in node.names]
            targets = bases
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                pkg = _package_of(name, path).split(".")
                base = ".".join(pkg[: len(pkg) - node.level + 1] + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            # ``from pkg import mod`` imports the submodule when there is one
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base for a in node.names]
        else:
            continue
        for t in targets:
            while t and t not in MODULES:  # ``import a.b.c`` where only a.b is a module of ours
                t = t.rpartition(".")[0]
            if t and t != name:
                found.add(t)
                # importing a.b.c runs a/__init__ and a/b/__init__ first, except the packages
                # that hold ``name`` (they are initialised before ``name`` runs)
                parent = t.rpartition(".")[0]
                while parent and parent != "quadmodes":
                    if parent in MODULES and not f"{name}.".startswith(f"{parent}."):
                        found.add(parent)
                    parent = parent.rpartition(".")[0]
    return found


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycles():
    graph = {name: _imports(name, path) for name, path in MODULES.items()}
    assert _cycles(graph) == []


def test_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def _part(module: str) -> str:
    """The layer part of a dotted module: its top-level module or subpackage under quadmodes
    ("quadmodes" for the package's own ``__init__``)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def _layer_violations(graph: dict[str, set[str]], layers) -> list[str]:
    """One line per import of ``graph`` (module -> modules it imports) that goes up the
    ``layers`` (low to high) or across to an independent part of the same layer. Parts that no
    layer names are left to :func:`test_every_part_is_in_a_layer`."""
    rank = {part: i for i, layer in enumerate(layers) for part in layer}
    found = []
    for module, targets in sorted(graph.items()):
        a = _part(module)
        for target in sorted(targets):
            b = _part(target)
            if a == b or a not in rank or b not in rank:
                continue
            if rank[b] > rank[a]:
                found.append(f"{module} imports {target}: layer {a!r} is below {b!r} (LAYERS)")
            elif rank[b] == rank[a]:
                found.append(f"{module} imports {target}: {a!r} and {b!r} are independent "
                             "parts of one layer (LAYERS)")  # fmt: skip
    return found


def test_layers():
    graph = {name: _imports(name, path) for name, path in MODULES.items()}
    found = _layer_violations(graph, LAYERS)
    assert not found, "imports against the layers:\n" + "\n".join(found)


def test_every_part_is_in_a_layer():
    placed = {part for layer in LAYERS for part in layer}
    assert sorted({_part(name) for name in MODULES} - placed) == []
    assert len(placed) == sum(len(layer) for layer in LAYERS), "a part is named twice"


def test_layer_checker_finds_inverted_and_sibling_imports():
    layers = (("rom",), ("fullorder", "runs"), ("analysis",))
    graph = {
        "quadmodes.rom.reduced": {"quadmodes.rom.system", "quadmodes.runs.simulate"},  # up
        "quadmodes.fullorder.damping": {"quadmodes.runs", "quadmodes.rom.reduced"},  # across
        "quadmodes.analysis.compare": {"quadmodes.fullorder", "quadmodes.runs.simulate"},  # down
    }
    assert _layer_violations(graph, layers) == [
        "quadmodes.fullorder.damping imports quadmodes.runs: 'fullorder' and 'runs' are "
        "independent parts of one layer (LAYERS)",
        "quadmodes.rom.reduced imports quadmodes.runs.simulate: layer 'rom' is below 'runs' "
        "(LAYERS)",
    ]


def test_no_import_cycles_between_parts():
    graph: dict[str, set[str]] = {}
    for name, path in MODULES.items():
        graph.setdefault(_part(name), set()).update(
            _part(t) for t in _imports(name, path) if _part(t) != _part(name)
        )
    assert _cycles(graph) == []


def test_module_sizes():
    too_long = {
        name: n
        for name, path in MODULES.items()
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES
        and name not in LONG_MODULES
    }
    assert too_long == {}


def _functions(path: Path):
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            yield node.name, node.end_lineno - node.lineno + 1


def test_function_sizes():
    too_long = {
        f"{name}.{fn}": n
        for name, path in MODULES.items()
        for fn, n in _functions(path)
        if n > MAX_FUNCTION_LINES and f"{name}.{fn}" not in LONG_FUNCTIONS
    }
    assert too_long == {}


@pytest.mark.parametrize("table", [LONG_MODULES, LONG_FUNCTIONS])
def test_exemptions_are_short_reasoned_and_still_needed(table):
    assert len(table) <= 5
    for key, why in table.items():
        assert len(why.split()) >= 5, f"{key}: say why it is exempt"
        module = key if table is LONG_MODULES else key.rpartition(".")[0]
        assert module in MODULES, f"{key}: no such module (remove the entry)"


def test_product_does_not_import_experimental():
    """Research prototypes stay in their own room: no module of quadmodes outside
    quadmodes.experimental imports it (function-level imports included); tests and
    benchmarks/studies may."""
    room = "quadmodes.experimental"

    def inside(module: str) -> bool:
        return module == room or module.startswith(f"{room}.")

    assert room in MODULES, "quadmodes.experimental is gone: remove this test"
    offenders = {
        name: sorted(t for t in _imports(name, path) if inside(t))
        for name, path in MODULES.items()
        if not inside(name)
    }
    assert {k: v for k, v in offenders.items() if v} == {}
