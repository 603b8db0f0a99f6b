"""Property-based fuzzing (hypothesis) of every place a user's input enters: machine descriptions, command-line
arguments and field sheets.  Whatever the input, the outcome is a result or one of berryshaker's own errors
(ConfigError, GeometryError: a message for the user, exit code 2), never another exception, a traceback or
a hang.  Kept small (about 20-40 s in all) so that it runs in CI with every change."""

from __future__ import annotations

import json
import math
import re
import tomllib
from pathlib import Path

import pytest
from fuzzing import REFERENCE, fuzz, toml_leaves, work_dir
from hypothesis import given
from hypothesis import strategies as st
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.config import load_machine, machine_warnings, validate_machine
from berryshaker.errors import ConfigError, GeometryError

runner = CliRunner()
WORK = work_dir("descriptions")
FUZZ = fuzz(200)


# ---- what a careless edit puts into a value --------------------------------------------------------------
UNITS = ["mm", "m", "km", "um", "deg", "rad", "rpm", "r/min", "Hz", "kg", "g", "t", "N/m", "N*s/m", "kN/mm",
         "GPa", "kg*m^2", "s", "%", "", "mm^2", "1/s", "degC", "dB", "furlong", "m**9**9", "(mm", "mm)", "N m/rad"]
numbers = st.one_of(
    st.integers(min_value=-(2**63), max_value=2**63 - 1),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1e-300, 1e300, 1e308, -0.0, 2**53 + 1, 1e-30, 1e30]),
)
number_text = st.one_of(numbers.map(lambda v: repr(v)), st.sampled_from(["1,5", "1.2.3", ".5", "5.", "1e", "--1",
                                                                         "0x10", "1_000", "9**9**9", "1/0"]))
unit_strings = st.builds(lambda n, sep, u: f"{n}{sep}{u}", number_text, st.sampled_from(["", " ", "  ", "\t"]),
                         st.sampled_from(UNITS))
scalars = st.one_of(numbers, st.booleans(), st.text(max_size=30), unit_strings)
toml_values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                           st.dictionaries(st.sampled_from(["a", "size", "x"]),
                                                                           inner, max_size=2)),
                           max_leaves=6)


def toml_literal(v) -> str:
    """A TOML literal for a Python value (strings as JSON-escaped basic strings)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_literal(x) for x in v) + "]"
    return "{ " + ", ".join(f"{k} = {toml_literal(x)}" for k, x in v.items()) + " }"


#: (line number, dotted key) of every `key = value` line of each reference description
LEAVES = {d: [(i, k) for i, k, _ in toml_leaves(t)] for d, t in REFERENCE.items()}


def mangle(original: str, how: int, value) -> str:
    """A unit-mangled or scaled version of an original value's TOML text."""
    m = re.match(r'^"([-+0-9.eE]+)\s*(.*)"$', original.strip())
    if not m:
        return toml_literal(value)
    num, unit = m.groups()
    try:
        big = f"{float(num) * 1e6!r}"
    except ValueError:  # "3-4-5" (a follower law's name)
        big = num + "e6"
    return json.dumps([f"{num}", f"{num} {unit}{unit}", f"{big} {unit}", f"-{num} {unit}",
                       f"{num} {UNITS[abs(hash(unit)) % len(UNITS)]}", f"{num}{unit}", f"{num} {unit.upper()}",
                       f"{num} / {unit}"][how % 8])


def mutated_text(drive: str, leaf: int, value, how: int | None) -> tuple[str, str]:
    lines = REFERENCE[drive].splitlines()
    i, key = LEAVES[drive][leaf % len(LEAVES[drive])]
    name, rest = lines[i].split("=", 1)
    original = rest.split("#", 1)[0]
    new = mangle(original, how, value) if how is not None else toml_literal(value)
    lines[i] = f"{name}= {new}"
    return "\n".join(lines) + "\n", key


def load_and_check(path: Path):
    """What `config validate` does: load, the drive's check, plausibility warnings; returns the machine."""
    m = load_machine(path)
    validate_machine(m)
    warnings = machine_warnings(m)
    assert m.DRIVE in REFERENCE and isinstance(warnings, list), (type(m), warnings)
    return m


# ---- (a) one-field mutations of the reference machines ---------------------------------------------------
@FUZZ
@given(drive=st.sampled_from(sorted(REFERENCE)), leaf=st.integers(0, 10_000), value=toml_values,
       how=st.one_of(st.none(), st.integers(0, 7)))
def test_one_field_mutation_is_a_machine_or_a_config_error(drive, leaf, value, how):
    """A machine, or an error that says where: loading names the field that was changed (or, for text that is no
    longer TOML, its line); the drive's own check (GeometryError) says what cannot be built."""
    text, key = mutated_text(drive, leaf, value, how)
    line = LEAVES[drive][leaf % len(LEAVES[drive])][0]
    path = WORK / "mutated.toml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    try:
        load_machine(path)
    except ConfigError as exc:
        msg = str(exc)
        where = f"at line {line + 1}," if "not valid TOML" in msg else key.rsplit(".", 1)[1]
        assert where in msg, (key, msg)
        return
    try:
        load_and_check(path)
    except (ConfigError, GeometryError) as exc:
        assert str(exc).strip(), key


@fuzz(40)
@given(data=st.binary(min_size=0, max_size=200), cut=st.integers(0, 4000))
def test_corrupted_files_are_config_errors(data, cut):
    """Truncated files, binary garbage spliced in, non-UTF-8 bytes."""
    raw = REFERENCE["groove_cam"].encode()
    path = WORK / "corrupt.toml"
    path.write_bytes(raw[:cut] + data + raw[cut:cut + 200])
    try:
        m = load_and_check(path)
    except (ConfigError, GeometryError) as exc:
        assert str(exc).strip() and "Traceback" not in str(exc), (cut, data)
    else:  # the garbage landed in a comment or a string the description does not read: still the reference drive
        assert m.DRIVE == "groove_cam", (cut, data)


# ---- (b) command-line argument variants ------------------------------------------------------------------
def _assert_clean_exit(r, args, json_out: bool = False):
    """Exit 0 (with valid JSON on stdout when ``json_out``) or exit 2 with a message; never a traceback."""
    assert r.exit_code in (0, 2), f"{args}: exit {r.exit_code}\n{r.output}\n{r.exception!r}"
    assert "Traceback" not in r.output, args
    if r.exit_code == 2:
        assert r.output.strip(), f"{args}: exit 2 without a message"
    elif json_out:
        json.loads(r.stdout)


pair_names = st.sampled_from(["A", "B", "C", "F", "a", "Z", "", "A ", "crank_pin"])
clearance_values = st.one_of(unit_strings, number_text, st.text(max_size=8),
                             st.sampled_from(["0.25mm", "0mm", "0.1 mm", "1e-30 mm", "3 mm", "-0.1mm", "inf mm"]))
clearance_specs = st.one_of(
    st.sampled_from(["none", "level1", "level2", "level3", "row1", "row16", "row0", "row17", "level4", "", ",", "=",
                     "A=", "=0.1mm", "A=0.1mm,A=0.2mm"]),
    st.lists(st.builds(lambda p, v: f"{p}={v}", pair_names, clearance_values), min_size=1, max_size=4)
    .map(",".join),
    st.text(max_size=20),
)


@fuzz(40)
@given(spec=clearance_specs)
def test_simulate_clearance_variants(spec):
    args = ["simulate", "--revolutions", "2", "--json", "--clearance", spec]
    r = runner.invoke(app, args)
    _assert_clean_exit(r, args, json_out=True)


@fuzz(40)
@given(drive=st.sampled_from(sorted(REFERENCE)), leaf=st.integers(0, 10_000), value=toml_values,
       how=st.one_of(st.none(), st.integers(0, 7)), command=st.sampled_from(["validate", "kinematics", "show"]),
       as_json=st.booleans())
def test_config_commands_on_mutated_files(drive, leaf, value, how, command, as_json):
    text, _ = mutated_text(drive, leaf, value, how)
    path = WORK / "cli.toml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    args = {"validate": ["config", "validate", str(path)], "kinematics": ["kinematics", "--config", str(path)],
            "show": ["config", "show", "--config", str(path)]}[command] + (["--json"] if as_json else [])
    r = runner.invoke(app, args)
    _assert_clean_exit(r, args, json_out=as_json)


@fuzz(30)
@given(args=st.lists(st.one_of(st.sampled_from(["--config", "--json", "--revolutions", "-n", "--model", "mlsd",
                                                "multibody", "--clearance", "--plot", "--allow-undercut", "x.toml",
                                                "/", "-1", "0", "1e9", "--", "-"]),
                               st.text(max_size=6)), max_size=4),
       command=st.sampled_from([["config", "validate"], ["kinematics"], ["config", "show"]]))
def test_random_arguments(args, command):
    """Random argument lists for the cheap commands: usage errors (typer's exit 2) or berryshaker's errors."""
    if "--plot" in args:  # writes figures; the output policy is tested elsewhere
        args = [a for a in args if a != "--plot"]
    r = runner.invoke(app, command + args)
    _assert_clean_exit(r, command + args)


# ---- (c) field sheets ------------------------------------------------------------------------------------
def _plan_csv() -> str:
    from berryshaker.experiment.field_sheet import parse_factor, plan_table

    df = plan_table("L9", [parse_factor(s) for s in ("A=0.25,0.5,0.75mm", "B=0.2,0.4,0.6mm", "C=0.1,0.15,0.2mm")],
                    randomize=True, seed=3)
    df["efficiency_kg_min"] = 4.0 - df["A_mm"]
    df["unripe_rate_pct"] = 3.0
    df["damage_rate_pct"] = 2.5
    df["duration_s"] = 60.0
    df["picked_mass_kg"] = 4.0
    return df.to_csv(index=False)


SHEET = _plan_csv()
cell_values = st.one_of(number_text, unit_strings, st.text(max_size=12), st.sampled_from(["", " ", "NA", "nan",
                                                                                          "-1", "1e309", "3,9"]))


def mutate_sheet(text: str, kind: int, row: int, col: int, value: str, cut: int) -> str:
    lines = text.strip("\n").split("\n")
    cells = [ln.split(",") for ln in lines]
    r = row % len(cells)
    c = col % len(cells[0])
    if kind == 0:  # one cell
        cells[r][c] = value.replace("\n", " ")
    elif kind == 1:  # a row dropped
        del cells[max(1, r)]
    elif kind == 2:  # a row duplicated
        cells.append(list(cells[max(1, r)]))
    elif kind == 3:  # a column dropped
        for ln in cells:
            if c < len(ln):
                del ln[c]
    elif kind == 4:  # a header renamed
        cells[0][c] = value.replace("\n", " ").replace(",", " ")
    elif kind == 5:  # a ragged row
        cells[r] = cells[r][: c] + [value.replace("\n", " ")]
    out = "\n".join(",".join(ln) for ln in cells) + "\n"
    if kind == 6:  # truncated file
        out = out[: cut % (len(out) + 1)]
    elif kind == 7:  # another separator
        out = out.replace(",", ";" if cut % 2 else "\t")
    return out


@fuzz(150)
@given(kind=st.integers(0, 7), row=st.integers(0, 20), col=st.integers(0, 30), value=cell_values,
       cut=st.integers(0, 2000), responses=st.sampled_from([["efficiency"], ["efficiency", "unripe", "damage"],
                                                            ["picked_mass_kg"], ["nope"]]))
def test_field_sheet_mutations_are_results_or_config_errors(kind, row, col, value, cut, responses):
    from berryshaker.experiment.field_sheet import read_results

    text = mutate_sheet(SHEET, kind, row, col, value, cut)
    try:
        fr = read_results(text, responses)
    except ConfigError as exc:
        assert str(exc).strip()
        return
    for name in responses:
        assert len(fr.responses[name]) == len(fr.levels)


def test_unmutated_inputs_pass():
    """The fuzzers start from inputs that are valid: the reference machines and a filled plan."""
    from berryshaker.experiment.field_sheet import read_results

    for drive, text in REFERENCE.items():
        path = WORK / f"{drive}.toml"
        path.write_text(text, encoding="utf-8")
        load_and_check(path)
        assert tomllib.loads(text)
    assert len(read_results(SHEET, ["efficiency"]).levels) == 9


@pytest.mark.parametrize("drive", sorted(REFERENCE))
def test_every_leaf_can_be_mutated(drive):
    """The mutation helper reaches every `key = value` line (so the fuzzer covers every field)."""
    keys = {key for _, key in LEAVES[drive]}
    assert {"cam.speed" if drive == "groove_cam" else "crank.speed", "harvest.seed", "clearance.C.size"} <= keys
    for leaf in range(len(LEAVES[drive])):
        text, key = mutated_text(drive, leaf, True, None)
        assert f"{key.rsplit('.', 1)[1]} = true" in text
