"""The type stubs ship beside the module (nanobind's stubgen) and cover all of it."""

import ast
from pathlib import Path

import lamina
from lamina import _lamina


def test_stubs_name_every_function_and_class():
    folder = Path(_lamina.__file__).parent
    assert (folder / "py.typed").exists()
    tree = ast.parse((folder / "_lamina.pyi").read_text())
    stubbed = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    public = {n for n in dir(_lamina) if not n.startswith("__") and callable(getattr(_lamina, n))}
    assert public and public <= stubbed, public - stubbed
    brdf = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "brdf")
    assert [a.arg for a in brdf.args.args] == ["stack", "options", "table", "state"]


def test_brdf_signature_is_the_option_table():
    # lamina.brdf's keywords and defaults are the rows of lamina brdf's option table.
    import inspect
    params = inspect.signature(lamina.brdf).parameters
    rows = _lamina.brdf_options()
    assert [name for name, *_ in rows] == [p for p in params if p not in ("stack", "table", "progress")]
    for name, default, help, required in rows:
        assert required or params[name].default == default, name
        assert help in lamina.brdf.__doc__


def test_package_functions_are_annotated():
    import inspect
    for name in ("brdf", "fit", "render", "compare", "denoise"):
        sig = inspect.signature(getattr(lamina, name))
        assert sig.return_annotation is not inspect.Signature.empty, name
