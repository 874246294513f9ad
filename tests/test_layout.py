"""The package's layout rules (docs/layout.md): a folder per stage, data flowing down the list of
stages and never back, no import circle, no module over 600 lines."""

from __future__ import annotations

import ast

from helpers import ROOT

#: Stages in the order data flows through them; a module may import its own stage, earlier
#: stages and the foundations at the package's top level, never a later stage.
STAGES = ("physics", "scene", "trace", "signal", "sensors", "recon", "evaluation", "data",
          "design", "cli")
MAX_LINES = 600


def _modules() -> dict:
    """{dotted module name: (path, imported mitsonar modules, of which at module level)}."""
    out = {}
    for path in sorted((ROOT / "mitsonar").rglob("*.py")):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        imports, top_level = set(), set()
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("mitsonar"):
                names = {node.module}
            elif isinstance(node, ast.Import):
                names = {a.name for a in node.names if a.name.startswith("mitsonar")}
            else:
                continue
            imports |= names
            if node in tree.body:
                top_level |= names
        out[name] = (path, imports, top_level)
    return out


def _stage(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in STAGES else None


def test_no_module_is_over_600_lines():
    too_long = {str(path.relative_to(ROOT)): n for path, _, _ in _modules().values()
                if (n := len(path.read_text().splitlines())) > MAX_LINES}
    assert not too_long, f"modules over {MAX_LINES} lines: {too_long}"


def test_data_flows_down_the_stages():
    upward = []
    for module, (_, imports, _) in _modules().items():
        if module in ("mitsonar", "mitsonar.__main__"):  # the public API and the entry point
            continue
        mine = _stage(module)
        for target in imports:
            theirs = _stage(target)
            if theirs is None:
                continue
            if mine is None or STAGES.index(theirs) > STAGES.index(mine):
                upward.append(f"{module} -> {target}")
    assert not upward, "imports against the flow of stages: " + ", ".join(sorted(upward))


def test_no_import_circle():
    modules = _modules()
    graph = {m: {t for t in top if t in modules and t != m and not t.startswith(m + ".")}
             for m, (_, _, top) in modules.items()}
    state: dict = {}

    def visit(node, trail):
        state[node] = "open"
        for nxt in graph[node]:
            if state.get(nxt) == "open":
                raise AssertionError("import circle: " + " -> ".join(trail + [node, nxt]))
            if nxt not in state:
                visit(nxt, trail + [node])
        state[node] = "done"

    for node in graph:
        if node not in state:
            visit(node, [])


def test_the_receiver_never_calls_the_synthesizer():
    _, imports, _ = _modules()["mitsonar.signal.receiver"]
    assert "mitsonar.signal.synthesis" not in imports
