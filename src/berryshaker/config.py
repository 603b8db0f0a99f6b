"""Reading machine descriptions: TOML (with units) -> the typed description of the machine's comb drive.

``[machine] drive = "..."`` picks the drive (:mod:`berryshaker.drives`; default ``groove_cam``, so files written
by berryshaker 0.1.0 still load).  Each drive's description class validates every value once, where the
machine is built (units and dimensions, ranges, clearance pairs and their geometric limits); everything
inside is SI.  A machine file gives every dimensional value with its unit (``speed = "120 rpm"``); a bare number
there is an error that shows the fix, and only dimensionless values (coefficients, fractions, counts, ratios)
are plain numbers.  The provenance tags written in the file's comments ([study], [assumed], [calibrated], [published]: from a
publication other than the study) are read
with the values and travel with them into every view (:func:`machine_table`).  A tag is checked against its value:
a value that differs from the reference machine's (the template ``config init`` writes) while its comment is still
the template's is the user's, tagged [user] (:func:`checked_tags`).

Geometric feasibility over the whole cycle (assembly, undercut) needs the kinematics and is checked by the
drive's ``check`` (``berryshaker config validate`` and every simulation call it before any work).
"""

from __future__ import annotations

import functools
import math
import re
import tomllib
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from berryshaker.drives import get_drive
from berryshaker.drives.base import MachineBase
from berryshaker.errors import ConfigError
from berryshaker.input_files import read_input_file
from berryshaker.quantity_fields import UNITS_REQUIRED, format_validation_error, plausibility_warnings

#: any drive's machine description
Machine = MachineBase

_TAG = re.compile(r"\[(study|assumed|calibrated|published)\b[^\]]*\]")
_MAX_FILE_BYTES = 1_000_000


def _drive_name(data: dict[str, Any], source: str) -> str:
    info = data.get("machine", {})
    if not isinstance(info, dict):
        raise ConfigError(f"invalid machine description {source}:\n  machine: expected a table ([machine])")
    name = info.get("drive", "groove_cam")
    if not isinstance(name, str):
        raise ConfigError(f"invalid machine description {source}:\n  machine.drive: expected a drive name")
    return name


def machine_from_dict(data: dict[str, Any], source: str = "<dict>", provenance: dict[str, str] | None = None,
                      units_required: bool = False):
    """Validate a nested dict into the description of its drive's machine.

    Parameters
    ----------
    data : dict
        The sections, as read from TOML (``units_required``) or as dumped by a description (SI numbers).
    source : str
        Where the data came from, for error messages.
    provenance : dict, optional
        Provenance tag per dotted key (:func:`provenance_tags`).
    units_required : bool
        The data is a user's file: a bare number in a dimensional field is an error showing the fix.

    Returns
    -------
    MachineBase
        The validated description (SI inside), of the class of its ``[machine] drive``.

    Raises
    ------
    ConfigError
        Every invalid value, one line each, with its dotted key.
    """
    if not isinstance(data, dict):
        raise ConfigError(f"invalid machine description {source}: expected a table of sections")
    drive = get_drive(_drive_name(data, source))
    try:
        machine = drive.machine_class.model_validate(data, context={UNITS_REQUIRED: units_required})
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source)) from None
    except RecursionError:
        raise ConfigError(f"invalid machine description {source}: values nested too deeply") from None
    if provenance:
        object.__setattr__(machine, "__provenance__", dict(provenance))
    return machine


def _key_comments(text: str) -> dict[str, str]:
    """The end-of-line comments of a TOML text per dotted key (the comment of the key's line and of the lines
    after it up to the next key), stripped."""
    comments: dict[str, str] = {}
    table = ""
    last_key = None
    for raw in text.splitlines():
        line = raw.strip()
        m = re.match(r"^\[([A-Za-z0-9_.\-]+)\]", line)
        if m:
            table, last_key = m.group(1), None
            continue
        m = re.match(r"^([A-Za-z0-9_\-]+)\s*=", line)
        if m:
            last_key = f"{table}.{m.group(1)}" if table else m.group(1)
            comments.setdefault(last_key, "")
        if "#" in raw and last_key:
            comments[last_key] = (comments[last_key] + " " + raw.split("#", 1)[1].strip()).strip()
    return comments


def provenance_tags(text: str) -> dict[str, str]:
    """Provenance tag per dotted key, read from a TOML text's end-of-line comments.

    ``stroke = "40 mm"  # h [assumed]`` under ``[cam]`` gives ``{"cam.stroke": "assumed"}``.

    Parameters
    ----------
    text : str
        The TOML text.

    Returns
    -------
    dict
        Dotted key -> tag (study, assumed, calibrated...).
    """
    tags: dict[str, str] = {}
    for key, comment in _key_comments(text).items():
        t = _TAG.search(comment)
        if t:
            tags[key] = t.group(1)
    return tags


def _same(a, b) -> bool:
    """Equal values of a description field (floats to 1e-9 relative: SI values converted from the file's units)."""
    if isinstance(a, float) and isinstance(b, float):
        return math.isclose(a, b, rel_tol=1e-9, abs_tol=0.0)
    if isinstance(a, (tuple, list)) and isinstance(b, (tuple, list)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    return type(a) is type(b) and a == b


def checked_tags(machine, text: str) -> dict[str, str]:
    """The provenance tags of a user's machine file, each checked against its value.

    A value that differs from the reference machine of its drive (the template ``berryshaker config init``
    writes, :func:`reference_toml_text`) is the user's: it is tagged ``user`` unless the user wrote its comment
    (a comment that is not the template's, with its own tag, is believed: ``[published: my test rig]``).  A value
    equal to the template's keeps the file's tag.  So ``speed = "140 rpm"  # omega [study]`` copied from the
    template and edited is ``[user]``, not ``[study]``.

    Parameters
    ----------
    machine : MachineBase
        The machine read from ``text``.
    text : str
        The file's TOML text.

    Returns
    -------
    dict
        Dotted key -> tag: the file's tags, and ``user`` for every value the file sets to other than the
        template's without a tag of its own.
    """
    tags = provenance_tags(text)
    template_text = reference_toml_text(machine.DRIVE)
    template = _reference_of(machine.DRIVE)
    mine, theirs = _key_comments(text), _key_comments(template_text)
    ref_values = {key: value for key, value, _info in _leaves(template)}
    for key, value, _info in _leaves(machine):
        if key not in mine or (key in ref_values and _same(value, ref_values[key])):
            continue  # not in the file (its default), or the template's value
        if mine[key] == theirs.get(key) or key not in tags:  # the template's comment, or no tag of the user's
            tags[key] = "user"
    return tags


@functools.lru_cache(maxsize=8)
def _reference_of(drive: str):
    """The reference machine of a drive (parsed once: it is the template tags are checked against)."""
    return load_machine(None, drive)


def reference_toml_text(drive: str = "groove_cam") -> str:
    """Text of a drive's built-in reference machine TOML (with its source annotations).

    Parameters
    ----------
    drive : str
        The drive's name (``berryshaker.drives``), e.g. "groove_cam" or "crank_rocker".

    Returns
    -------
    str
        The TOML text.
    """
    return get_drive(drive).reference_toml_text()


def _read_text(p: Path) -> str:
    data = read_input_file(p, "config file", _MAX_FILE_BYTES)  # a regular file of at most 1 MB, never blocking
    try:
        return data.decode("utf-8-sig")  # a byte-order mark (some Windows editors write one) is dropped
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{p}: not UTF-8 text (byte {exc.start}); save the file as UTF-8") from None


def load_machine(path: str | Path | None = None, drive: str = "groove_cam"):
    """Load a machine description from TOML; ``None`` gives the built-in reference machine of ``drive``.

    Every dimensional value must carry its unit (a bare number is an error naming the field and the fix);
    a UTF-8 byte-order mark is accepted.

    Parameters
    ----------
    path : str or Path, optional
        The TOML file; None: the built-in reference machine.
    drive : str
        The drive whose reference machine ``path=None`` gives.

    Returns
    -------
    MachineBase
        The validated description (SI inside), with its provenance tags.

    Raises
    ------
    ConfigError
        Unreadable file, not a regular file (a FIFO, a device, a folder) or larger than 1 MB
        (:func:`berryshaker.input_files.read_input_file`), invalid TOML (arrays or tables nested too deeply
        included), or invalid values.
    """
    if path is None:
        text, source = reference_toml_text(drive), f"(built-in reference machine, {drive})"
    else:
        p = Path(path)
        text, source = _read_text(p), str(p)
    text = text.removeprefix("\ufeff")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: not valid TOML ({_short_text(str(exc))})") from None
    except RecursionError:
        raise ConfigError(f"{source}: not valid TOML (arrays or tables nested too deeply)") from None
    machine = machine_from_dict(data, source, provenance_tags(text), units_required=True)
    if path is not None:  # a user's file: its tags checked against its values
        object.__setattr__(machine, "__provenance__", checked_tags(machine, text))
    return machine


def _short_text(text: str, limit: int = 200) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def machine_warnings(machine) -> list[str]:
    """Plausibility warnings of a machine description: one message per value that lies orders of magnitude
    outside engineering ranges (:func:`berryshaker.units.plausibility_warning`; e.g. a damping 10^6 times
    too large, a base radius in km), each naming its dotted key.  Empty for the reference machines.

    Parameters
    ----------
    machine : MachineBase
        The machine description.

    Returns
    -------
    list of str
        The warnings.
    """
    return plausibility_warnings(machine)


def validate_machine(machine, strict: bool = False, allow_undercut: bool = False) -> list[str]:
    """Everything a simulation checks before any work, plus plausibility: the drive's ``check`` (assembly
    over the cycle, undercut, ...) and :func:`machine_warnings`.

    Parameters
    ----------
    machine : MachineBase
        A loaded description (values, units, ranges and clearance limits were checked when it was built).
    strict : bool
        Turn plausibility warnings into an error (``berryshaker config validate --strict``).
    allow_undercut : bool
        Passed to the drive's check.

    Returns
    -------
    list of str
        The plausibility warnings (empty when everything is in range).

    Raises
    ------
    GeometryError
        The drive cannot run as described.
    ConfigError
        ``strict`` and at least one warning (all are listed).
    """
    from berryshaker.drives import drive_of

    drive_of(machine).check(machine, allow_undercut=allow_undercut)
    warnings = machine_warnings(machine)
    if strict and warnings:
        raise ConfigError("implausible values (--strict):\n  " + "\n  ".join(warnings))
    return warnings


def reference_machine(drive: str = "groove_cam"):
    """The built-in reference machine of a drive (groove cam: docs/study.md, reference machine).

    Parameters
    ----------
    drive : str
        The drive's name.

    Returns
    -------
    MachineBase
        The reference machine.
    """
    return load_machine(None, drive)


def value_tag(machine, key: str) -> str:
    """Provenance tag of a dotted key: study, assumed, calibrated, published, user (a value the user changed from
    the template, :func:`checked_tags`), or default (not set in the file).

    Parameters
    ----------
    machine : MachineBase
        The machine description.
    key : str
        The dotted key, e.g. "cam.stroke".

    Returns
    -------
    str
        The tag.
    """
    tags = getattr(machine, "__provenance__", None) or {}
    return tags.get(key, "default")


def _leaves(model: BaseModel, prefix: str = ""):
    """(dotted key, value, field info) of every value of a description, in file order."""
    for name, info in type(model).model_fields.items():
        value = getattr(model, name)
        key = f"{prefix}{name}"
        if isinstance(value, BaseModel):
            yield from _leaves(value, key + ".")
        elif isinstance(value, dict) and value and all(isinstance(v, BaseModel) for v in value.values()):
            for k, v in value.items():
                yield from _leaves(v, f"{key}.{k}.")
        else:
            yield key, value, info


def value_text(value, info) -> str:
    """A description value as ``config show`` prints it: in the field's engineering unit (every element of a tuple
    too), "auto" for a value left to the model, text and flags as they are.

    Parameters
    ----------
    value : object
        The value (SI).
    info : pydantic.fields.FieldInfo
        Its field (:func:`berryshaker.quantity_fields.field_display_unit` gives the unit).

    Returns
    -------
    str
        E.g. ``"20 mm"``, ``"(8, 16) mm"``, ``"0.3"`` (dimensionless), ``"auto"``.
    """
    from berryshaker.quantity_fields import field_display_unit
    from berryshaker.units import ENGINEERING_FACTORS

    unit = field_display_unit(info)
    factor = ENGINEERING_FACTORS.get(unit, 1.0) if unit else 1.0
    suffix = "" if unit in (None, "1") else f" {unit}"
    number = lambda v: f"{v / factor:.6g}" if isinstance(v, float) else str(v)  # noqa: E731
    if value is None:
        return "auto"
    if isinstance(value, float):
        return number(value) + suffix
    if isinstance(value, tuple) and value and all(isinstance(v, float) for v in value):
        return "(" + ", ".join(number(v) for v in value) + ")" + suffix
    return str(value)


def machine_table(machine) -> list[tuple[str, str, str]]:
    """(dotted key, value in engineering units, provenance tag) for every field of the machine, in file order.

    Parameters
    ----------
    machine : MachineBase
        The machine description.

    Returns
    -------
    list of (str, str, str)
        The rows; each value is text with its engineering unit ("80 mm", :func:`value_text`).
    """
    return [(key, value_text(value, info), value_tag(machine, key)) for key, value, info in _leaves(machine)]


def _restitution_velocity_text(machine, p: str, c) -> str:
    """``config show`` value of pair p's restitution velocity: the value and where it comes from."""
    from berryshaker.contact.pair_law import default_restitution_velocity

    v = c.restitution_velocity
    if not v > 0:
        return "0 m/s: e at every impact speed (the published law)"
    text = f"v_ref = {v:.3g} m/s"
    if c.tags.get("restitution_velocity") == "derived":
        mat = machine.clearance[p].geometry().material_pair
        from berryshaker.contact.wear import MATERIAL_PAIRS

        lubricated = mat in MATERIAL_PAIRS and MATERIAL_PAIRS[mat].lubricated
        if lubricated and v == default_restitution_velocity(mat)[0]:
            return (text + f" ({mat}, lubricated: numerical floor of the published law, results independent of it "
                    "below; docs/contact.md sec. 6.4): e for impacts at v_ref and faster; slower ones: the damping "
                    "at v_ref")
        text += f" (yield velocity of {mat})"
    return text + ": e for impacts at v_ref and faster; slower ones: the damping at v_ref (Hunt-Crossley, e -> 1 as v -> 0)"


def pair_contact_rows(machine) -> list[tuple[str, str, str]]:
    """(key, value, provenance tag) rows of every clearance pair's resolved contact law, for ``config show``.

    Per pair: the law, K (N/m^n) and n, the equivalent linear stiffness at the operating load, the damping
    (law and value) and the damping ramp depth, each tagged ``derived`` (from geometry and materials,
    :mod:`berryshaker.contact.pair_law`), ``assumed``/``study`` (the description's tag) or ``default``.

    Parameters
    ----------
    machine : MachineBase
        The machine description.

    Returns
    -------
    list of (str, str, str)
        The rows; each value is text with its unit.
    """
    from berryshaker.contact.pair_law import OPERATING_LOAD

    rows: list[tuple[str, str, str]] = []
    for p in machine.pair_names:
        pair = machine.clearance[p]
        key = f"(resolved) contact {p}"
        if pair.size <= 0:
            rows.append((key, "ideal joint (zero clearance): no contact law", "derived"))
            continue
        c = machine.pair_contact(p)
        tg = c.tags
        rows.append((f"{key} law", c.law, tg["law"]))
        basis = ""
        if c.geometry is not None:
            g = c.geometry
            basis = (f" (Johnson line contact, {g.material_pair}, d = {g.diameter * 1e3:g} mm, L = {g.length * 1e3:g} mm; "
                     f"fit {c.fit_force_range[0]:g}-{c.fit_force_range[1]:.3g} N, max error {c.fit_error:.0%}"
                     + (f"; {', '.join(g.assumed)} [assumed default]" if g.assumed else "") + ")")
        rows.append((f"{key} stiffness", f"K = {c.stiffness:.4g} N/m^{c.exponent:.4g}{basis}", tg["stiffness"]))
        rows.append((f"{key} exponent", f"n = {c.exponent:.4g}", tg["exponent"]))
        rows.append((f"{key} at {OPERATING_LOAD:g} N", f"k_tangent = {c.tangent_stiffness:.3g} N/m, "
                     f"k_secant = {c.secant_stiffness:.3g} N/m", "derived"))
        if c.uses("damping"):
            rows.append((f"{key} damping", f"viscous, c = {c.damping:g} N s/m", tg["damping"]))
        else:
            from berryshaker.contact.conformal import hysteresis_factor

            rows.append((f"{key} damping", f"hysteresis ({c.law}), restitution e = {c.restitution:g}, factor "
                         f"f(e) = {float(hysteresis_factor(c.restitution, c.law)):.4g}", tg["restitution"]))
            if c.uses("restitution_velocity"):
                rows.append((f"{key} restitution velocity", _restitution_velocity_text(machine, p, c),
                             tg.get("restitution_velocity", "default")))
        if c.uses("damping_depth"):
            rows.append((f"{key} damping ramp", f"full damping at {c.damping_depth * 1e3:g} mm", tg["damping_depth"]))
        else:
            rows.append((f"{key} damping ramp", "none: the hysteresis force K delta^n (f(e) delta'/v0) starts at "
                         "zero at first touch", "derived"))
    return rows
