"""Docstrings of the public API: numpydoc validation and units (after python-control's docstrings_test.py).

The public API is every public module of berryshaker (no part of its dotted name starts with ``_``) and, in each,
every public function and class defined there (not imported) with the public methods and properties its class
body defines.  Each is validated by ``numpydoc.validate.validate`` against ``RULES``, and every numeric parameter,
return and attribute (typed float, array or ndarray) must state its unit: SI inside the package, ``(1)`` or
"dimensionless" when it has none.  A class may document its constructor's parameters as Attributes (a
dataclass; a subclass documents the fields it adds, its base class the rest); a pydantic model's fields are documented in the annotated reference descriptions instead
(:func:`_fields_documented_elsewhere`).

Every public module is checked; none is exempt.  ``python tests/test_docstrings.py [MODULE ...]`` prints the
problems in full.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import sys
from functools import cache

import pytest

numpydoc_validate = pytest.importorskip("numpydoc.validate", reason="the docs extra: pip install -e '.[docs]'")
from numpydoc.docscrape import ClassDoc, FunctionDoc  # noqa: E402
from pydantic import BaseModel  # noqa: E402

import berryshaker  # noqa: E402

#: numpydoc checks that every public docstring must pass
RULES = {
    "GL08": "the object has a docstring",
    "SS01": "it has a summary line",
    "PR01": "every parameter is documented",
    "PR02": "no parameter is documented that the signature does not have",
    "PR07": "every documented parameter has a description",
    "PR10": "'name : type' with a space before the colon",
    "RT01": "a function that returns something has a Returns section",
    "RT03": "every return value has a description",
    "YD01": "a generator has a Yields section",
}

# a numeric parameter or return (its type names a float or an array) must state its unit
_NUMERIC_TYPE = re.compile(r"\b(float|floats|array|arrays|ndarray|array_like|array-like)\b")
_COUNT_TYPE = re.compile(r"\b(of|or) (int|bool|str)\b")  # an array of level codes or flags has no unit
_UNIT_ATOM = (r"(m|mm|um|µm|s|ms|rad|deg|degrees?|°|N|kN|kg|g|Pa|kPa|MPa|GPa|J|kJ|W|kW|Hz|rpm|min|h|hours?|K|"
              r"1|SI|percent|%|m2|m3)")
_UNIT_GROUP = re.compile(r"[(\[]([^()\[\]]*)[)\]]")
_UNIT_WORDS = re.compile(r"\b(dimensionless|unitless|SI|same units? as|units? of|(its|their|any) units?|\w+'s units?|fractions?|ratios?)\b",
                         re.I)
_COMPOUND_UNIT = re.compile(rf"(?<![\w.]){_UNIT_ATOM}\s?[/*^·]\s?\(?{_UNIT_ATOM}?")  # m/s, rad/s^2, N*m, m^2
_IN_UNIT = re.compile(rf"\bin {_UNIT_ATOM}(?![\w])")  # "in m", "in rad"


def public_modules() -> list[str]:
    """Every public module of berryshaker, the package itself included, sorted."""
    names = [m.name for m in pkgutil.walk_packages(berryshaker.__path__, "berryshaker.")]
    return ["berryshaker"] + sorted(n for n in names if not any(p.startswith("_") for p in n.split(".")))


def public_objects(modname: str) -> list[tuple[str, object]]:
    """(dotted name, object) of every public function and class defined in the module, with their methods."""
    mod = importlib.import_module(modname)
    found = []
    for name, obj in vars(mod).items():
        func = getattr(obj, "py_func", obj)  # a numba dispatcher documents its Python function
        if callable(func) and hasattr(func, "__wrapped__"):  # functools.cache, lru_cache, wraps
            func = inspect.unwrap(func)
        if name.startswith("_") or not (inspect.isclass(obj) or inspect.isfunction(func)):
            continue
        if getattr(obj, "__module__", None) != modname:
            continue
        found.append((f"{modname}.{name}", obj))
        if inspect.isclass(obj):
            for mname, member in vars(obj).items():
                raw = member.__func__ if isinstance(member, (staticmethod, classmethod)) else member
                if not mname.startswith("_") and (inspect.isfunction(raw) or isinstance(raw, property)):
                    found.append((f"{modname}.{name}.{mname}", raw))
    return found


def _states_unit(text: str) -> bool:
    if _UNIT_WORDS.search(text) or _COMPOUND_UNIT.search(text) or _IN_UNIT.search(text):
        return True
    for group in _UNIT_GROUP.findall(text):
        if re.search(rf"(?<![\w.]){_UNIT_ATOM}(?![\w])", group):
            return True
    return False


def unit_problems(qualname: str, obj) -> list[str]:
    """Numeric parameters and returns of ``obj``'s docstring that state no unit."""
    if not inspect.getdoc(obj):
        return []
    try:
        doc = ClassDoc(obj, config={"show_class_members": False}) if inspect.isclass(obj) else FunctionDoc(
            getattr(obj, "fget", None) or getattr(obj, "py_func", obj), config={})
    except Exception:  # numpydoc's parser failing is reported by the rules above
        return []
    out = []
    for section in ("Parameters", "Returns", "Attributes"):
        for entry in doc[section]:
            if _NUMERIC_TYPE.search(entry.type) and not _COUNT_TYPE.search(entry.type) and not _states_unit(entry.type + " " + " ".join(entry.desc)):
                out.append(f"{qualname}: UNIT {section[:-1].lower()} {entry.name or entry.type!r} states no unit "
                           "(SI, or '(1)' / 'dimensionless')")
    return out


def _fields_documented_elsewhere(obj, code: str, msg: str) -> bool:
    """A class's constructor parameters may be documented as its Attributes (a dataclass's fields); a pydantic
    model's fields are the keys of a machine description, documented with their units in the annotated
    reference descriptions (``drives/*/reference.toml``, ``berryshaker config show``) and typed by dimension
    (``Length``, ``Mass``...: a value without its unit is refused), so PR01/PR02 do not apply to them."""
    if not inspect.isclass(obj) or code not in ("PR01", "PR02"):
        return False
    if issubclass(obj, BaseModel):
        return True
    if code != "PR01":
        return False
    missing = set(re.findall(r"'([^']+)'", msg))
    attributes = {n.strip() for cls in obj.__mro__ if cls is not object and inspect.getdoc(cls)
                  for entry in ClassDoc(cls, config={"show_class_members": False})["Attributes"]
                  for n in entry.name.split(",")}  # a subclass's inherited fields are its base class's Attributes
    return missing <= attributes


@cache
def problems(modname: str) -> tuple[str, ...]:
    """Every docstring problem of a module: numpydoc ``RULES`` and units, one line each."""
    out = []
    for qualname, obj in public_objects(modname):
        try:
            result = numpydoc_validate.validate(qualname)
        except Exception as exc:  # numpydoc cannot find its source (e.g. an attribute made by a decorator)
            out.append(f"{qualname}: numpydoc cannot read it ({type(exc).__name__} {exc})")
            continue
        out += [f"{qualname}: {code} {msg}" for code, msg in result["errors"]
                if code in RULES and not _fields_documented_elsewhere(obj, code, msg)]
        out += unit_problems(qualname, obj)
    return tuple(out)


MODULES = public_modules()


@pytest.mark.parametrize("modname", MODULES)
def test_docstrings(modname):
    """Every public docstring of the module passes RULES and states its units."""
    found = problems(modname)
    assert not found, f"{len(found)} docstring problems in {modname}:\n" + "\n".join(found)


if __name__ == "__main__":  # print the problems of the named modules (default: all)
    for name in sys.argv[1:] or MODULES:
        found = problems(name)
        print(f"{len(found):4d} {name}")
        for line in found:
            print("       " + line)
