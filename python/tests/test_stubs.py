"""The type stubs (workbench/_workbench.pyi) list exactly the module's public names, with the
runtime signatures' parameter names and defaults."""

import ast
import inspect
import pathlib

import workbench as wb
from workbench import _workbench

STUB = pathlib.Path(wb.__file__).with_name("_workbench.pyi")


def stub_tree():
    return ast.parse(STUB.read_text(encoding="utf-8"))


def stub_functions(body):
    return {n.name: n for n in body if isinstance(n, ast.FunctionDef)}


def public(obj):
    return {n for n in dir(obj) if not n.startswith("_")}


def test_stub_names_are_the_module_names():
    tree = stub_tree()
    names = set(stub_functions(tree.body)) | {n.name for n in tree.body if isinstance(n, ast.ClassDef)}
    names |= {n.target.id for n in tree.body if isinstance(n, ast.AnnAssign)}
    runtime = public(_workbench) | {"__version__"}
    assert runtime <= names | {"__version__"}, runtime - names
    aliases = {"Points", "Values", "Kernel", "MethodName", "WeightedMethod", "DesignName", "ScaleName", "KernelMean"}
    assert names - aliases - {"__version__"} <= runtime, names - runtime
    assert set(wb.__all__) == public(_workbench) | {"__version__"}


def parameters(node: ast.FunctionDef):
    a = node.args
    names = [p.arg for p in a.posonlyargs + a.args + a.kwonlyargs if p.arg != "self"]
    return names


def check(runtime, node):
    sig = inspect.signature(runtime)
    # Methods read from the class carry `self`; the stub's parameters leave it out.
    names = [p for p in sig.parameters if p != "self"]
    assert names == parameters(node), node.name
    kinds = {p.name: p.kind for p in sig.parameters.values()}
    for p in node.args.kwonlyargs:
        assert kinds[p.arg] == inspect.Parameter.KEYWORD_ONLY, (node.name, p.arg)
    # Defaults: the stub's literal defaults are the runtime's.
    args = node.args
    positional = args.posonlyargs + args.args
    for p, d in zip(positional[len(positional) - len(args.defaults):], args.defaults):
        assert sig.parameters[p.arg].default == ast.literal_eval(d), (node.name, p.arg)
    for p, d in zip(args.kwonlyargs, args.kw_defaults):
        if d is not None:
            assert sig.parameters[p.arg].default == ast.literal_eval(d), (node.name, p.arg)


def test_stub_signatures_are_the_runtime_signatures():
    tree = stub_tree()
    for name, node in stub_functions(tree.body).items():
        check(getattr(_workbench, name), node)
    for cls in [n for n in tree.body if isinstance(n, ast.ClassDef)]:
        runtime = getattr(_workbench, cls.name)
        for name, node in stub_functions(cls.body).items():
            if name == "__init__":
                check(runtime, node)
            elif name.startswith("__"):
                continue
            elif any(isinstance(d, ast.Name) and d.id == "property" for d in node.decorator_list):
                assert isinstance(inspect.getattr_static(runtime, name), type(wb.Rule.n)), (cls.name, name)
            else:
                check(getattr(runtime, name), node)


def test_everything_public_has_a_docstring():
    for name in public(_workbench):
        obj = getattr(_workbench, name)
        if callable(obj):
            assert (obj.__doc__ or "").strip(), name


def test_runtime_docstrings_are_the_stubs():
    """``help(wb.Rule)`` says what the stubs say: every docstring of the stubs (functions,
    classes, methods and properties) is the runtime object's, word for word."""
    tree = stub_tree()
    checked = 0
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and ast.get_docstring(node):
            assert inspect.getdoc(getattr(_workbench, node.name)) == ast.get_docstring(node), node.name
            checked += 1
        if isinstance(node, ast.ClassDef):
            runtime = getattr(_workbench, node.name)
            for m in node.body:
                if isinstance(m, ast.FunctionDef) and not m.name.startswith("__") and ast.get_docstring(m):
                    got = inspect.getdoc(inspect.getattr_static(runtime, m.name))
                    assert got == ast.get_docstring(m), f"{node.name}.{m.name}"
                    checked += 1
    assert checked >= 20
