"""The public surface of ``jaxgwo`` and what importing it costs."""

import ast
import subprocess
import sys
from pathlib import Path

import jaxgwo


def test_every_public_name_resolves():
    for name in jaxgwo.__all__:
        assert getattr(jaxgwo, name) is not None, name
    assert set(jaxgwo.__all__) <= set(dir(jaxgwo))


def test_type_checking_imports_match_the_lazy_table():
    # the TYPE_CHECKING block (for type checkers) and _EXPORTS (at run time) list the
    # same names from the same modules
    tree = ast.parse(Path(jaxgwo.__file__).read_text())
    block = next(n for n in tree.body if isinstance(n, ast.If)
                 and getattr(n.test, "id", None) == "TYPE_CHECKING")
    typed = {(imp.module, a.name) for imp in block.body for a in imp.names}
    lazy = {(module, name) for module, names in jaxgwo._EXPORTS.items() for name in names}
    assert typed == lazy


def test_unknown_attribute_is_an_attribute_error():
    try:
        jaxgwo.no_such_name  # noqa: B018
    except AttributeError as err:
        assert "no_such_name" in str(err)
    else:
        raise AssertionError("expected AttributeError")


def _modules_after(code: str) -> set[str]:
    out = subprocess.run(
        [sys.executable, "-c", code + "\nimport sys; print(' '.join(sorted(sys.modules)))"],
        capture_output=True, text=True, check=True,
    ).stdout.split()
    return set(out)


def test_import_loads_only_jax():
    mods = _modules_after("import jaxgwo")
    assert not {m for m in mods if m.startswith("jaxgwo.")} - {"jaxgwo._config"}
    assert "jax" in mods
