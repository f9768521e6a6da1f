"""The layout's rules, checked on the source: no import cycle among jointrig's modules (imports
inside functions count: they only hide a cycle), and the layers import only downwards:
``vocab`` (the law, plant and records both sides share) below ``identify`` (mathematics) and
``measured`` (readers), below ``rig`` (the simulator), below
``studies`` (what is run with it), below ``present`` (what people read), below the commands."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = {"rig": "jointrig.rig", "identify": "jointrig.identify", "measured": "jointrig.measured",
            "studies": "jointrig.studies", "present": "jointrig.present", "jointrig": "jointrig"}


def _modules() -> dict[str, Path]:
    out = {}
    for folder, name in PACKAGES.items():
        for f in (ROOT / folder).rglob("*.py"):
            parts = [p for p in f.relative_to(ROOT / folder).with_suffix("").parts if p != "__init__"]
            out[".".join([name] + parts)] = f
    return out


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    graph = {m: set() for m in mods}
    for m, f in mods.items():
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = m.split(".") if f.name == "__init__.py" else m.split(".")[:-1]
                    base = base[: len(base) - (node.level - 1)]
                    mod = ".".join(base + ([node.module] if node.module else []))
                else:
                    mod = node.module
                names = [mod] + [f"{mod}.{a.name}" for a in node.names]
            else:
                continue
            graph[m].update(n for n in names if n in mods and n != m)
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
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

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle_among_jointrigs_modules():
    graph = _graph()
    assert len(graph) > 50  # the walk found the package
    assert _cycles(graph) == []


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_identify_never_imports_rig():
    graph = _graph()
    bad = {m: sorted(x for x in deps if x.startswith("jointrig.rig")) for m, deps in graph.items()
           if m.startswith("jointrig.identify")}
    assert {m: d for m, d in bad.items() if d} == {}


#: Each layer and the packages it must not import (anything above it). The shared vocabulary
#: (law, plant, records) is at the bottom: the identifier and the rig both use it, it uses neither.
ABOVE = {
    "jointrig.vocab": ("jointrig.identify", "jointrig.measured", "jointrig.rig", "jointrig.studies",
                       "jointrig.present", "jointrig.commands", "jointrig.cli", "jointrig.files", "jointrig.parallel"),
    "jointrig.identify": ("jointrig.measured", "jointrig.rig", "jointrig.studies", "jointrig.present",
                          "jointrig.commands", "jointrig.cli"),
    "jointrig.measured": ("jointrig.rig", "jointrig.studies", "jointrig.present", "jointrig.commands", "jointrig.cli"),
    "jointrig.rig": ("jointrig.studies", "jointrig.present", "jointrig.commands", "jointrig.cli"),
    "jointrig.studies": ("jointrig.present", "jointrig.commands", "jointrig.cli"),
    "jointrig.present": ("jointrig.commands", "jointrig.cli"),
}


def _upward(graph: dict[str, set[str]]) -> dict[str, list[str]]:
    """Each module that imports a layer above its own (``ABOVE``), with those imports."""
    bad = {}
    for layer, above in ABOVE.items():
        for m, deps in graph.items():
            if m == layer or m.startswith(layer + "."):
                up = sorted(d for d in deps if d.startswith(above))
                if up:
                    bad[m] = up
    return bad


def test_layers_import_only_downwards():
    graph = _graph()
    assert any(m.startswith("jointrig.studies.") for m in graph) and any(m.startswith("jointrig.present.") for m in graph)
    assert _upward(graph) == {}


def test_the_layer_check_sees_an_upward_import():
    graph = {"jointrig.rig.simulate": {"jointrig.studies.sweep", "jointrig.vocab.law"},
             "jointrig.vocab.law": {"jointrig.present.recording"}, "jointrig.present.recording": {"jointrig.rig.model"}}
    assert _upward(graph) == {"jointrig.rig.simulate": ["jointrig.studies.sweep"],
                              "jointrig.vocab.law": ["jointrig.present.recording"]}


def _coordinate_branches(source: str) -> list[int]:
    """Lines of ``source`` that compare something with the word "hinge" or "slide" (== / !=)."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare) and any(isinstance(op, (ast.Eq, ast.NotEq)) for op in node.ops):
            words = [c.value for c in [node.left, *node.comparators] if isinstance(c, ast.Constant)]
            if any(w in ("hinge", "slide") for w in words):
                out.append(node.lineno)
    return out


def test_no_module_branches_on_how_the_bodies_move():
    # issue 53: a body on a hinge or a slide is a vocab.params.Coordinate that knows its names,
    # units and words; a comparison with the word elsewhere is a ladder that the next kind of
    # coordinate would have to find in every file.
    found = {name: lines for name, f in _modules().items()
             if (lines := _coordinate_branches(f.read_text(encoding="utf-8")))}
    assert found == {}, found
    assert _coordinate_branches('if kind == "slide":\n    pass\nx = "hinge" != k') == [1, 3]


#: Where a bench's shape (two flywheels, their relative angle, a train, a model file's format) may
#: be told apart: the reader of measured runs and the model loader. Everything after them sees one
#: record (identify.chain.ChainRecord) and one rig (rig.chain.ChainRig).
SHAPE_READERS = {"jointrig.measured.runs", "jointrig.rig.chain", "jointrig.rig.model"}
#: the types a branch on the bench's shape would test for
SHAPE_TYPES = {"SteadyStateRecord", "ChainRecord", "RigModel", "ChainRig"}


def _shape_branches(source: str) -> list[int]:
    """Lines that branch on a bench's shape: ``.is_train``/``.has_both_angles``, ``hasattr(x,
    "n_flywheels")``, or an ``if`` on ``isinstance(x, <a record or rig type>)`` that does more than
    refuse the wrong type."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and node.attr in ("is_train", "has_both_angles"):
            out.append(node.lineno)
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "hasattr"
              and len(node.args) == 2 and isinstance(node.args[1], ast.Constant) and node.args[1].value == "n_flywheels"):
            out.append(node.lineno)
        elif isinstance(node, (ast.If, ast.IfExp)):
            tested = {n.id for c in ast.walk(node.test) if isinstance(c, ast.Call) and isinstance(c.func, ast.Name)
                      and c.func.id == "isinstance" for a in c.args[1:] for n in ast.walk(a) if isinstance(n, ast.Name)}
            refuses = isinstance(node, ast.If) and len(node.body) == 1 and isinstance(node.body[0], ast.Raise)
            if tested & SHAPE_TYPES and not refuses:
                out.append(node.lineno)
    return out


def test_only_the_reader_and_the_model_loader_tell_benches_apart():
    # issue 53: two flywheels are a line of two bodies, their relative angle alone one body tied
    # to the frame, from the reader up; no module after it converts or branches on the shape.
    found = {name: lines for name, f in _modules().items()
             if name not in SHAPE_READERS and (lines := _shape_branches(f.read_text(encoding="utf-8")))}
    assert found == {}, found
    assert _shape_branches("if runs.is_train:\n    pass\nx = hasattr(m, 'n_flywheels')\n"
                           "y = a if isinstance(r, ChainRecord) else b\n"
                           "if not isinstance(r, ChainRecord):\n    raise TypeError(r)\n") == [1, 3, 4]
