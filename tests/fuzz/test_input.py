"""Fuzzing (hypothesis) of the classes of bad input of issue #42, "Nothing silently misread": a bare number
where a unit belongs, unit text that pint's expression evaluator would compute (or hang on), values outside
physical bounds, NaN on the way to an output, a byte-order mark, and messages that echo or decorate the
input.  Same mechanism as tests/fuzz/test_field_sheet_fuzz.py: fixed derandomised examples in CI, ``BERRYSHAKER_FUZZ_EXAMPLES=5000``
explores with random seeds.  About 30 s in all."""

from __future__ import annotations

import contextlib
import json
import math
import re

import pint
import pytest
from fuzzing import REFERENCE, fuzz, toml_leaves, work_dir
from hypothesis import given
from hypothesis import strategies as st
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.config import load_machine, machine_from_dict, validate_machine
from berryshaker.drives import get_drive
from berryshaker.errors import ConfigError, GeometryError
from berryshaker.experiment.field_sheet import parse_factor, plan_table, read_results
from berryshaker.quantity_fields import field_dimension, field_info_at
from berryshaker.units import LIMITS, parse_quantity

runner = CliRunner()
WORK = work_dir("input")


def _dimension(drive: str, key: str) -> str | None:
    cls = get_drive(drive).machine_class
    parts = key.split(".")
    if parts[0] == "driveline" and len(parts) == 3 and parts[1] == "motor":
        from berryshaker.drives.driveline import InductionMotor

        return field_dimension(InductionMotor.model_fields[parts[2]])
    try:
        return field_dimension(field_info_at(cls, key))
    except ConfigError:
        return None


#: (drive, line, dotted key, value text, dimension) of every scalar leaf with a unit / a plain number
LEAVES = [(d, i, k, v, _dimension(d, k)) for d, t in REFERENCE.items()
          for i, k, v in toml_leaves(t, scalars_only=True)]
DIMENSIONAL = [leaf for leaf in LEAVES if leaf[4] not in (None, "dimensionless") and leaf[3].startswith('"')]
PLAIN = [leaf for leaf in LEAVES if leaf[4] == "dimensionless" and re.fullmatch(r"[-+0-9.eE]+", leaf[3])]


def _with(drive: str, line: int, value: str) -> str:
    lines = REFERENCE[drive].splitlines()
    name = lines[line].split("=", 1)[0]
    lines[line] = f"{name}= {value}"
    return "\n".join(lines) + "\n"


def _load_text(text: str, name: str = "m.toml", encoding: str = "utf-8"):
    path = WORK / name
    path.write_bytes(text.encode(encoding))
    return load_machine(path)


def test_the_leaf_tables_cover_the_machine():
    assert len(DIMENSIONAL) >= 60 and len(PLAIN) >= 15
    assert any(k == "harvest.ripe_pull" for _, _, k, _, _ in DIMENSIONAL)  # the harvest section's quantities are read
    assert any(k == "driveline.motor.rated_power" for _, _, k, _, _ in DIMENSIONAL)


# ---- silent misreading: a bare number where a unit belongs ------------------------------------------------
@fuzz(40)
@given(leaf=st.sampled_from(DIMENSIONAL),
       number=st.one_of(st.floats(min_value=1e-3, max_value=1e4), st.integers(1, 10_000),
                        st.sampled_from([120, 30, 1.8, 0.1, 1.5, -2.0])))
def test_a_bare_number_in_a_dimensional_field_is_an_error_with_the_fix(leaf, number):
    drive, line, key, _, _ = leaf
    with pytest.raises(ConfigError) as exc:
        _load_text(_with(drive, line, repr(number)))
    msg = str(exc.value)
    name = key.rsplit(".", 1)[1]
    assert "is a bare number; give a unit, e.g. " + name + ' = "' in msg, msg
    assert key.split(".")[0] in msg


@fuzz(20)
@given(leaf=st.sampled_from(PLAIN), scale=st.sampled_from([1.0, 0.5, 0.999]))
def test_dimensionless_fields_stay_plain_numbers(leaf, scale):
    drive, line, key, value, _ = leaf
    number = float(value) * scale
    if float(value) > 1 and float(value).is_integer():
        number = int(float(value))  # counts stay whole
    try:
        m = _load_text(_with(drive, line, repr(number)))
    except ConfigError as exc:  # a legitimate relation (e.g. replicates >= 2) but never about units
        assert "bare number" not in str(exc) and "unit" not in str(exc).split(":", 1)[-1][:40]
        return
    loaded = m
    for part in key.split("."):  # read back as written: no unit scaling of a plain number
        loaded = loaded[part] if isinstance(loaded, dict) else getattr(loaded, part)
    assert loaded == number and type(loaded) is not bool, (key, number, loaded)


# ---- pint expressions and hangs: only the strict grammar reads unit text ----------------------------------
EXPRESSIONS = ["* 1000", "*1000", "**9**9", "** 9 ** 9 ** 9", "^99", "/0", "+ 1 kW", ", 5", "(kW", "kW)",
               "*(2)", " 1e999", " kW kW kW kW kW kW kW kW kW", "*1e3", "**(1/2)"]


@contextlib.contextmanager
def no_pint_expressions():
    """pint asked only to look up single unit names: a call of its expression parser, or a unit lookup of
    anything but one name, fails the test (recorded, so a broad ``except`` in the code cannot hide it)."""
    calls: list[str] = []
    original = pint.UnitRegistry.parse_units

    def refuse(self, text, *a, **kw):
        calls.append(f"parse_expression({text!r})")
        raise pint.errors.UndefinedUnitError(str(text))

    def one_name(self, text, *a, **kw):
        if not re.fullmatch(r"[A-Za-z_µμΩ°%]*", str(text)):
            calls.append(f"parse_units({text!r})")
            raise pint.errors.UndefinedUnitError(str(text))
        return original(self, text, *a, **kw)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(pint.UnitRegistry, "parse_expression", refuse)
        mp.setattr(pint.UnitRegistry, "parse_units", one_name)
        yield
    assert not calls, f"pint evaluated user text: {calls}"


@fuzz(40)
@given(number=st.sampled_from(["1.5", "1,5", "9", "1e3", "-2"]), unit=st.sampled_from(["kW", "W", "hp", "mm", ""]),
       tail=st.sampled_from(EXPRESSIONS))
def test_unit_expressions_are_refused_at_once_everywhere(number, unit, tail):
    text = f"{number} {unit}{tail}"
    i = next(i for d, i, k, _, _ in DIMENSIONAL if d == "groove_cam" and k == "driveline.motor.rated_power")
    with no_pint_expressions():
        with pytest.raises(ConfigError):
            parse_quantity(text, "power", "rated_power")
        with pytest.raises(ConfigError, match="rated_power"):
            _load_text(_with("groove_cam", i, json.dumps(text)))
        with pytest.raises(ConfigError, match="--factor"):
            parse_factor(f"A=1,2,3{unit}{tail.replace(',', '').replace(' ', '')}")


@fuzz(20)
@given(tail=st.sampled_from(["mm*1000", "mm**9**9", "m^99", "kg/", "9**9**9"]))
def test_sheet_units_never_reach_pint_expressions(tail):
    df = plan_table("L9", [parse_factor(s) for s in ("A=1,2,3mm", "B=1,2,3mm")])
    df = df.rename(columns={"A_mm": f"A_{tail}"})
    df["efficiency_kg_min"] = 4.0
    with no_pint_expressions():
        try:
            read_results(df.to_csv(index=False), ["efficiency"])
        except ConfigError as exc:  # refused: with a message that names the column
            assert str(exc) and "A_" in str(exc), exc


# ---- bounds: nothing accepted by loading fails later -------------------------------------------------------
@fuzz(40)
@given(leaf=st.sampled_from(DIMENSIONAL + PLAIN),
       factor=st.sampled_from([1e300, 1e30, 1e9, 1e6, 1e3, 1e-3, 1e-6, 1e-9, 1e-30, 1e-300, -1.0]))
def test_scaled_values_are_refused_naming_the_field_or_run(leaf, factor):
    drive, line, key, value, dim = leaf
    if value.startswith('"'):
        num, unit = re.match(r'"([-+0-9.eE]+)\s*(.*)"', value).groups()
        new = json.dumps(f"{float(num) * factor!r} {unit}")
    else:
        new = repr(float(value) * factor)
    try:
        m = _load_text(_with(drive, line, new))
    except ConfigError as exc:
        assert key.rsplit(".", 1)[1] in str(exc) or key.split(".")[0] in str(exc), str(exc)
        return
    try:
        validate_machine(m)  # what `config validate` does after loading: a result or a GeometryError, no crash
    except GeometryError:
        return
    for v in m.model_dump().values():
        assert not (isinstance(v, float) and not math.isfinite(v))
    lo, hi = LIMITS[dim] if dim else (0.0, math.inf)
    assert lo < hi


def test_counts_and_coefficients_are_bounded():
    i = next(i for d, i, k, _, _ in PLAIN if d == "groove_cam" and k == "harvest.replicates")
    with pytest.raises(ConfigError, match=r"harvest.replicates: must be <= 1000"):
        _load_text(_with("groove_cam", i, "9200000000000000000"))
    i = next(i for d, i, k, _, _ in PLAIN if d == "groove_cam" and k == "push_rod.friction_coefficient")
    with pytest.raises(ConfigError, match=r"push_rod.friction_coefficient: must be <= 2"):
        _load_text(_with("groove_cam", i, "5.0"))
    with pytest.raises(ConfigError, match=r"push_rod.friction_coefficient: 1e\+300 is too large"):
        _load_text(_with("groove_cam", i, "1e300"))


# ---- NaN never reaches --json --------------------------------------------------------------------------
@fuzz(12)
@given(leaf=st.sampled_from([leaf for leaf in DIMENSIONAL if leaf[4] == "length" and leaf[0] == "groove_cam"
                             and not leaf[2].startswith(("plant", "driveline", "operation", "harvest"))]),
       factor=st.sampled_from([100.0, 10.0, 3.0, 0.3, 0.01]))
def test_kinematics_json_is_finite_json_or_an_error(leaf, factor):
    drive, line, key, value, _ = leaf
    num, unit = re.match(r'"([-+0-9.eE]+)\s*(.*)"', value).groups()
    path = WORK / "kin.toml"
    path.write_text(_with(drive, line, json.dumps(f"{float(num) * factor!r} {unit}")))
    r = runner.invoke(app, ["kinematics", "--json", "--config", str(path)])
    assert r.exit_code in (0, 2), r.output
    if r.exit_code == 0:
        assert "NaN" not in r.stdout and "Infinity" not in r.stdout
        json.loads(r.stdout, parse_constant=lambda c: pytest.fail(f"{c} in --json output"))


# ---- a byte-order mark -----------------------------------------------------------------------------------
@fuzz(6)
@given(drive=st.sampled_from(sorted(REFERENCE)), prefix=st.sampled_from(["", "\n", "# note\n", "   \n"]))
def test_a_utf8_bom_is_accepted(drive, prefix):
    text = prefix + REFERENCE[drive]
    plain = _load_text(text, "plain.toml")
    bom = _load_text("\ufeff" + text, "bom.toml")
    assert bom.model_dump() == plain.model_dump()


# ---- noisy errors -----------------------------------------------------------------------------------------
@fuzz(30)
@given(leaf=st.sampled_from(LEAVES), size=st.sampled_from([1_000, 100_000]),
       filler=st.sampled_from(["x", "9", "mm", ":a:", "[bold]"]))
def test_errors_never_echo_a_huge_value(leaf, size, filler):
    drive, line, key, _, _ = leaf
    value = json.dumps((filler * size)[:size])
    try:
        _load_text(_with(drive, line, value))
    except ConfigError as exc:
        assert len(str(exc)) < 2_000, (key, len(str(exc)))


@fuzz(10)
@given(text=st.sampled_from(["peak_force:A", ":a: :b:", ":thumbs_up:", "[bold]x[/]", "[red]", ":A"]))
def test_error_text_is_printed_as_written(text):
    """No rich markup and no emoji codes in what the user typed (``peak_force:A`` stays as written)."""
    r = runner.invoke(app, ["simulate", "--model", "mlsd", "--clearance", f"{text}=0.25mm"])
    assert r.exit_code == 2
    assert text in r.output or text.replace("[", "\\[") in r.output, r.output
    assert not re.search(r"[\U0001F000-\U0001FFFF]", r.output)


@fuzz(6)
@given(depth=st.sampled_from([100, 1000, 5000, 20000]), kind=st.sampled_from(["array", "table"]))
def test_deep_nesting_is_a_clean_error(depth, kind):
    value = "[" * depth + "]" * depth if kind == "array" else "{a = " * depth + "1" + "}" * depth
    path = WORK / "deep.toml"
    path.write_text(_with("groove_cam", DIMENSIONAL[0][1], value))
    with pytest.raises(ConfigError):
        load_machine(path)
    data = {"cam": {"speed": [[[[]]]]}}
    with pytest.raises(ConfigError):
        machine_from_dict(data, units_required=True)
