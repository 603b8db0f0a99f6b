"""The clearance-life section's tables of service life (the study step ``clearance_life``, docs/life.md "Life by
mechanism"): each joint's life from the new machine by its governing mechanism, and the fits (the drawing's and the
recommended), each with its new-machine clearance, load and life.  The renderer reads the records' attributes
(``berryshaker.study.life_drive_records.ClearanceLife``)."""

from __future__ import annotations

from berryshaker.report.html_blocks import _details, _Raw, _table
from berryshaker.user_text import html_text


def _fit_of(life, joint: str) -> str:
    """The fit the new machine has at a joint: the drawing's, else none (its described size)."""
    d = (life.drawing_fits or {}).get(joint)
    return d.fit if d is not None else "none (described size)"


def _mechanism_line(m) -> str:
    """One mechanism's hours as a short line of the life table."""
    from berryshaker.life.service_life import reads

    if m.hours is None:
        return f"{m.mechanism}: does not end the life ({m.note})"
    return f"{m.mechanism}: {reads(m.hours, m.lo, m.hi)}"


def life_parts(life) -> list[str]:
    """HTML parts: the growth from the described (worn) clearances, the worn-level note, the life of every joint by
    mechanism and the fits with their life.

    Parameters
    ----------
    life : ClearanceLife
        The step's record (clearances mm, hours h, forces N).

    Returns
    -------
    list of str
        HTML fragments: the life table, then the fits and the growth folded (the growth table alone for a record
        from before the life by mechanism).
    """
    rec = life.recommended
    growth = [_table(["joint", "clearance (worn level, mm)", f"after {life.horizon_h:g} h (mm)", "service limit (mm)",
                     "hours to the limit", "recommended fit"],
                    [[j, g.clearance_mm[0], g.clearance_mm[-1] if g.hours[-1] >= life.horizon_h else
                      f"at its limit after {g.hours[-1]:.0f} h", life.clearance_limit_mm[j],
                      "beyond the design life" if life.hours_to_limit[j] is None else life.hours_to_limit[j],
                      rec.fits.get(j, "")] for j, g in life.growth.items()])]
    if not life.life:
        return growth
    growth.append("<p class='small'>Clearance (worn level): the described size, a worn state the study tests; the new "
                  "machine's clearance is its fit's (below).  Service limit: "
                  + html_text(next(iter(life.life.values())).limit_rule) + ".</p>")
    parts = ["<h3>Service life of the new machine, by mechanism</h3>",
              _table(["joint", "fit (new machine)", "new clearance (mm)", "service life", "governing mechanism",
                     "dominant uncertainty", "other mechanisms"],
                    [[j, _fit_of(life, j), f"{L.start_mm:.3g}", L.reads, L.governing, L.uncertainty,
                      _Raw("<br>".join(html_text(_mechanism_line(m)) for m in L.mechanisms
                                       if m.mechanism != L.governing))]
                     for j, L in life.life.items()], left=(0, 1, 3, 4, 5, 6))]
    fits = [("drawing", life.drawing_fits or {}), ("recommended", life.recommended_fits or {})]
    rows = [[j, f"{src}: {fl.fit}", f"{fl.clearance_min_mm:.3g} .. {fl.clearance_max_mm:.3g} ({fl.clearance_mm:.3g})",
             fl.design_force_N, fl.life.reads, fl.life.governing]
            for src, d in fits for j, fl in sorted(d.items())]
    if rows:
        parts.append(_details("Fits (new machine): the drawing's and the recommended, each with its clearance, load "
                              "and life", [_table(["joint", "fit (new machine)", "clearance min .. max (mean), mm",
                                                   "static-equivalent force at the mean (N)", "service life",
                                                   "governing mechanism"], rows, left=(0, 1, 2, 4, 5))]))
    parts.append(_details("Clearance growth by wear from the described (worn) clearances", growth))
    return parts
