"""The registry's ``monotone`` flag (contact/laws.py) and the engine's use of it (multibody/contact_events.py).

A law flagged monotone lets the integrator bound the force inside a step by one evaluation at the step's largest
penetration and rate, and skip the interior-peak search of steps that cannot raise a recorded maximum.  A wrong
flag would hide peaks, so:

* every law that claims the flag never decreases as the penetration or its rate grows (hypothesis), and the
  one built-in law without it (ADAMS IMPACT) is shown to decrease somewhere, so the property is not vacuous;
* the skip changes nothing: a slider-crank run with a flagged law and with the same kernel registered unflagged
  (always searched) give bitwise equal peaks, first impacts and output samples.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from berryshaker.contact.laws import get_law, law_names, register_law, unregister_law

finite = dict(allow_nan=False, allow_infinity=False)


@settings(max_examples=300, deadline=None)
@given(pen=st.floats(1e-9, 1e-3, **finite), dpen=st.floats(0.0, 1e-3, **finite),
       rate=st.floats(-2.0, 2.0, **finite), drate=st.floats(0.0, 2.0, **finite),
       v_imp=st.floats(1e-4, 5.0, **finite), k=st.floats(1e6, 1e11, **finite), n=st.floats(1.0, 2.0, **finite),
       e=st.floats(0.05, 1.0, **finite), c=st.floats(0.0, 1e5, **finite), d=st.floats(1e-7, 1e-4, **finite))
def test_monotone_laws_never_decrease(pen, dpen, rate, drate, v_imp, k, n, e, c, d):
    for name in law_names():
        law = get_law(name)
        if not law.monotone:
            continue
        lo = law.kernel(pen, rate, v_imp, k, n, e, c, d)
        for p2, r2 in ((pen + dpen, rate), (pen, rate + drate), (pen + dpen, rate + drate)):
            hi = law.kernel(p2, r2, v_imp, k, n, e, c, d)
            assert hi >= lo * (1.0 - 1e-12), (name, pen, rate, p2, r2, lo, hi)


def test_the_flag_is_not_vacuous_impact_decreases_with_penetration():
    """IMPACT (unflagged): while separating, its damping ramps in with the penetration and outgrows the spring."""
    law = get_law("impact")
    assert not law.monotone
    k, n, cmax, d = 1e9, 1.5, 1e5, 1e-4
    f = [law.kernel(p, -0.01, 0.0, k, n, 0.0, cmax, d) for p in np.linspace(1e-6, 1e-4, 50)]
    assert min(np.diff(f)) < 0.0
    assert {"mlsd", "hertz", "hunt_crossley", "lankarani_nikravesh", "flores"} <= {
        nm for nm in law_names() if get_law(nm).monotone}


def test_the_interior_peak_skip_changes_nothing():
    from berryshaker.multibody.engine import simulate_mechanism
    from berryshaker.multibody.spec import load_mechanism, mechanism_from_dict

    data = load_mechanism(Path(__file__).parents[2] / "examples" / "slider_crank_clearance.toml").model_dump()
    flagged = simulate_mechanism(mechanism_from_dict(data), rtol=1e-6)
    ln = get_law("lankarani_nikravesh")
    assert ln.monotone
    register_law("ln_unflagged", ln.kernel, ln.uses, "Lankarani-Nikravesh, always searched (test)")
    try:
        for j in data["joints"]:
            if j.get("contact"):
                assert j["contact"]["law"] == "lankarani_nikravesh"
                j["contact"]["law"] = "ln_unflagged"
        searched = simulate_mechanism(mechanism_from_dict(data), rtol=1e-6)
    finally:
        unregister_law("ln_unflagged")
    assert np.array_equal(flagged.peaks, searched.peaks)
    assert np.array_equal(flagged.first, searched.first)
    assert np.array_equal(flagged.elements, searched.elements)
    assert np.array_equal(flagged.info[:3], searched.info[:3])


def _slider_crank_model():
    from berryshaker.multibody import layout as mb
    from berryshaker.multibody.engine import compile_mechanism
    from berryshaker.multibody.spec import load_mechanism

    cm = compile_mechanism(load_mechanism(Path(__file__).parents[2] / "examples" / "slider_crank_clearance.toml"))
    j = int(np.flatnonzero(cm.model.ftype == mb.FRC_REV_CL)[0])
    return cm.model, j


_MODEL = []


@settings(max_examples=300, deadline=None)
@given(p0=st.floats(-2e-6, 2e-6, **finite), p1=st.floats(-2e-6, 2e-6, **finite), d0=st.floats(-2.0, 2.0, **finite),
       d1=st.floats(-2.0, 2.0, **finite), h=st.floats(1e-8, 1e-5, **finite), v_imp=st.floats(1e-3, 3.0, **finite))
def test_step_bound_covers_the_interpolated_force(p0, p1, d0, d1, h, v_imp):
    """The bound is at least the force anywhere on the step's cubic Hermite penetration (1 001 points)."""
    from berryshaker.multibody import contact_events as mb

    if not _MODEL:
        _MODEL.append(_slider_crank_model())
    model, j = _MODEL[0]
    bound = mb._step_force_bound(model, j, v_imp, h, p0, d0, p1, d1)
    u = np.linspace(0.0, 1.0, 1001)
    pen = (2 * u**3 - 3 * u**2 + 1) * p0 + (u**3 - 2 * u**2 + u) * h * d0 + (-2 * u**3 + 3 * u**2) * p1 \
        + (u**3 - u**2) * h * d1
    rate = ((6 * u**2 - 6 * u) * p0 + (-6 * u**2 + 6 * u) * p1) / h + (3 * u**2 - 4 * u + 1) * d0 \
        + (3 * u**2 - 2 * u) * d1
    fflt, law = model.fflt, model.laws[model.fint[j, 3]]
    f = [law(p, r, v_imp, fflt[j, mb.FF_K], fflt[j, mb.FF_N], fflt[j, mb.FF_E], fflt[j, mb.FF_C], fflt[j, mb.FF_D])
         if p > 0 else 0.0 for p, r in zip(pen, rate)]
    assert bound >= max(f) * (1.0 - 1e-9)
    assert bound >= mb._interior_peak(model, j, v_imp, h, p0, d0, p1, d1)[0] * (1.0 - 1e-12)
