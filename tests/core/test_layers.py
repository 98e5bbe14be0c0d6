"""The add-on's imports point down the layers and form no cycle (walked from the source, no bpy needed)."""

import ast
from pathlib import Path

ADDON = Path(__file__).resolve().parents[2] / "addon"
# lower numbers sit lower: a module may import its own layer or lower ones only
LAYERS = {
    "errors": 0,
    "user_files": 0,
    "user_json": 0,
    "geometry": 1,
    "formats": 1,
    "mpeg4": 2,
    "deform": 2,
    "speech": 3,
    "fitting": 3,
    "elastic": 3,
    "arkit": 3,
    "placement": 3,
    "blender": 4,
}


def _module(path: Path) -> str:
    parts = path.relative_to(ADDON.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports() -> dict[str, set[str]]:
    """addon module -> the addon modules it imports (relative imports resolved, function-level ones too)."""
    graph = {}
    for path in ADDON.rglob("*.py"):
        name = _module(path)
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        found = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join([*base, node.module] if node.module else base)
                names = [f"{target}.{a.name}" for a in node.names]
                found.update(
                    n if (ADDON.parent / n.replace(".", "/")).with_suffix(".py").exists() else target for n in names
                )
            elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("addon"):
                found.add(node.module)
        graph[name] = {m for m in found if m != name}
    return graph


def _layer(module: str) -> int:
    parts = module.split(".")
    return LAYERS.get(parts[1], -1) if len(parts) > 1 else 99


def test_every_package_has_a_layer():
    assert {p.name for p in ADDON.iterdir() if p.is_dir() and p.name != "__pycache__"} <= LAYERS.keys()


def test_imports_only_point_down():
    wrong = [
        f"{module} -> {target}"
        for module, targets in _imports().items()
        for target in targets
        if _layer(target) > _layer(module)
    ]
    assert wrong == []


def test_no_import_cycle():
    graph = _imports()
    state: dict[str, int] = {}
    cycles = []

    def visit(node, stack):
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if nxt == node.rpartition(".")[0]:
                continue  # a module may use its own package's __init__
            if state.get(nxt) == 1:
                cycles.append(" -> ".join([*stack[stack.index(nxt) :], nxt]))
            elif nxt not in state:
                visit(nxt, [*stack, nxt])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    assert cycles == []


def test_the_walk_sees_the_known_edges():
    graph = _imports()
    assert "addon.errors" in graph["addon.mpeg4.fap_file"]
    assert "addon.blender.binding_store" in graph["addon.blender.live"]
    assert "addon.geometry.face_axes" in graph["addon.geometry.cylindrical"]
