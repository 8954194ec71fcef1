# SPDX-License-Identifier: MIT
"""python/hybrid_broadphase.pyi against the module: the same public names, the
same parameters, and a docstring on every public function, method, property
and class of the module."""
import ast
import inspect
import pathlib
import re

import hybrid_broadphase as hbp

STUB = pathlib.Path(__file__).resolve().parents[1] / "hybrid_broadphase.pyi"
STUB_ONLY = {"BoxLike", "Vec3Like", "HandlesLike", "Stats"}  # type aliases of the stub
# CudaPairs and CudaFrame are in the module only when it is built with the
# CUDA room.
CUDA_ONLY = {"CudaPairs", "CudaFrame"}
CLASSES = ("BroadPhase", "UpdateResult") + (("CudaPairs", "CudaFrame") if hasattr(hbp, "CudaPairs") else ())


def stub_tree():
    return ast.parse(STUB.read_text())


def stub_functions(body):
    return {n.name: n for n in body if isinstance(n, ast.FunctionDef)}


def stub_class(tree, name):
    return next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == name)


def public(names):
    return {n for n in names if not n.startswith("__") or n in ("__version__",)}


def module_members(cls):
    """The class's own members; __init__ only when Python code can construct it
    (pybind11 gives a class without a constructor an __init__ that raises)."""
    own = set(vars(cls)) - {"__doc__", "__module__", "__dict__", "__weakref__"}
    members = {n for n in own if not (n.startswith("__") and n.endswith("__")) or n in
               ("__init__", "__iter__", "__len__", "__contains__")}
    if "__init__" in members and not (cls.__init__.__doc__ or "").startswith("__init__("):
        members.discard("__init__")
    return members


def test_stub_names_are_the_module_names():
    tree = stub_tree()
    declared = set()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            declared.add(node.name)
        elif isinstance(node, ast.AnnAssign):
            declared.add(node.target.id)
        elif isinstance(node, ast.Assign):
            declared.update(t.id for t in node.targets)
    module_names = public(n for n in dir(hbp) if not n.startswith("__") or n == "__version__")
    assert declared - STUB_ONLY - (CUDA_ONLY - module_names) == module_names
    for cls in CLASSES:
        in_stub = {n.name for n in stub_class(tree, cls).body if isinstance(n, ast.FunctionDef)}
        assert in_stub == module_members(getattr(hbp, cls)), cls


def pybind_parameters(fn):
    """Parameter names from pybind11's signature line, e.g. 'add(self: ..., boxes: ..., *, static: ...)'."""
    first = fn.__doc__.splitlines()[0]
    inside = first[first.index("(") + 1:first.rindex(") ->")]
    names = []
    for part in re.split(r",\s*(?![^\[]*\])", inside):
        name = part.split(":")[0].strip()
        if name:
            names.append(name)
    return names


def stub_parameters(node):
    a = node.args
    names = [p.arg for p in a.posonlyargs + a.args]
    if a.kwonlyargs:
        names += ["*"] + [p.arg for p in a.kwonlyargs]
    return names


def test_stub_parameters_are_the_module_parameters():
    tree = stub_tree()
    checked = 0
    for name, node in stub_functions(tree.body).items():
        assert pybind_parameters(getattr(hbp, name)) == stub_parameters(node), name
        checked += 1
    for cls in CLASSES:
        for name, node in stub_functions(stub_class(tree, cls).body).items():
            member = getattr(getattr(hbp, cls), name)
            if isinstance(member, property):
                continue
            assert pybind_parameters(member) == stub_parameters(node), f"{cls}.{name}"
            checked += 1
    assert checked >= 20


def test_every_public_name_has_a_docstring():
    missing = []
    for name in public(dir(hbp)):
        obj = getattr(hbp, name)
        if inspect.isclass(obj) or callable(obj):
            doc = obj.__doc__ or ""
            # pybind11 puts the signature on the first line: the text must follow it.
            if len(doc.strip().splitlines()) < (1 if inspect.isclass(obj) else 2):
                missing.append(name)
    for cls in CLASSES:
        for name in module_members(getattr(hbp, cls)):
            doc = getattr(getattr(hbp, cls), name).__doc__ or ""
            lines = [line for line in doc.strip().splitlines() if line.strip()]
            is_property = isinstance(getattr(getattr(hbp, cls), name), property)
            if len(lines) < (1 if is_property else 2):
                missing.append(f"{cls}.{name}")
    assert missing == []
    assert "Applies every edit since the last update" in hbp.BroadPhase.update.__doc__
