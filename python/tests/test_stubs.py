"""The committed type stubs (python/posekit.pyi) are what make_stubs.py writes for the built module,
and every function, class, method and property in them has a docstring."""
import ast
import importlib.util
from pathlib import Path

import posekit

ROOT = Path(__file__).resolve().parents[2]


def _make_stubs():
    spec = importlib.util.spec_from_file_location("make_stubs", ROOT / "python" / "packaging" / "make_stubs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.stubs()


def test_the_stubs_follow_the_module():
    committed = (ROOT / "python" / "posekit.pyi").read_text()
    assert _make_stubs() == committed, "python/posekit.pyi is stale: run python3 python/packaging/make_stubs.py"


def test_everything_in_the_stubs_has_a_docstring():
    tree = ast.parse((ROOT / "python" / "posekit.pyi").read_text())
    undocumented = [node.name for node in ast.walk(tree)
                    if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and ast.get_docstring(node) is None]
    assert undocumented == []
    public = {n for n in dir(posekit) if not n.startswith("_")}
    stubbed = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    stubbed |= {n.target.id for n in tree.body if isinstance(n, ast.AnnAssign)}
    assert public <= stubbed, public - stubbed
