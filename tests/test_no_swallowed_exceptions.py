"""No bare ``except:`` and no swallowed exception in the package (read with ``ast``):

* a bare ``except:`` (it also catches KeyboardInterrupt and SystemExit);
* a handler whose body does nothing (``pass`` or ``...``);
* a broad ``except Exception`` / ``except BaseException`` that never raises (it hides
  bugs; catch the exceptions meant, or re-raise).

A retry loop's ``continue`` is allowed: the loop's own outcome reports the failure.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "sarjax"
BROAD = {"Exception", "BaseException"}
# (file, function): a handler that does nothing but is a documented fallback
KNOWN: set = set()


def _names(node):
    if node is None:
        return set()
    parts = node.elts if isinstance(node, ast.Tuple) else [node]
    return {ast.unparse(p).rsplit(".", 1)[-1] for p in parts}


def _does_nothing(body):
    return all(isinstance(s, ast.Pass) or (isinstance(s, ast.Expr)
                                           and isinstance(s.value, ast.Constant))
               for s in body)


def _problems(source, filename):
    tree = ast.parse(source, filename)
    found = []

    def visit(node, function):
        for child in ast.iter_child_nodes(node):
            inner = child.name if isinstance(child, (ast.FunctionDef,
                                                     ast.AsyncFunctionDef)) else function
            if isinstance(child, ast.ExceptHandler):
                where = f"{filename}:{child.lineno} ({function or 'module'})"
                if child.type is None:
                    found.append(f"{where}: bare except")
                elif _does_nothing(child.body) and (Path(filename).name, function) not in KNOWN:
                    found.append(f"{where}: except {ast.unparse(child.type)}: pass")
                elif _names(child.type) & BROAD and not any(
                        isinstance(n, ast.Raise) for n in ast.walk(child)):
                    found.append(f"{where}: except {ast.unparse(child.type)} never raises")
            visit(child, inner)

    visit(tree, None)
    return found


def test_the_checker_finds_each_kind():
    source = """
def f():
    try:
        g()
    except:
        h()
    try:
        g()
    except (KeyError, ValueError):
        pass
    try:
        g()
    except Exception:
        return None
    try:
        g()
    except ValueError:
        ...
def fine():
    for attempt in range(3):
        try:
            return g()
        except ValueError:
            continue
    try:
        g()
    except Exception as err:
        raise RuntimeError("context") from err
"""
    found = _problems(source, "example.py")
    assert [p.split(": ", 1)[1] for p in found] == [
        "bare except", "except (KeyError, ValueError): pass",
        "except Exception never raises", "except ValueError: pass"]
    assert all("(f)" in p for p in found)


def test_no_bare_or_swallowing_handlers_in_the_package():
    files = sorted(PACKAGE.rglob("*.py"))
    assert len(files) > 20
    found = [p for f in files for p in _problems(f.read_text(), str(f.relative_to(PACKAGE)))]
    assert not found, "\n".join(found)
