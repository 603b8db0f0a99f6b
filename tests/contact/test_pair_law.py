"""The restitution velocity v_ref of the hysteresis contact laws (docs/contact.md sec. 6.4).

A single impact of a mass on the *compiled* law (the function the engine calls) is integrated to its rebound:

* at impact speeds v >= v_ref the restitution is the law's own (the same as with v_ref = 0) and independent of v
  (the hysteresis laws are self-similar in v);
* below v_ref the damping is that of an impact at v_ref: the hysteresis coefficient alpha = f(e)/v_ref is a
  material constant (Hunt & Crossley 1975) and, for small damping, the energy lost in one impact,
  (2/3) alpha v m v^2, gives 1 - e(v)^2 = (4/3) f(e) v / v_ref: the restitution rises to 1 as v -> 0, the loss
  of energy in proportion to v.
"""

from __future__ import annotations

import math

import pytest
from scipy.integrate import solve_ivp

from berryshaker.contact.conformal import hysteresis_factor
from berryshaker.contact.laws import get_law, slot_c
from berryshaker.contact.pair_law import (
    ELASTIC_MATERIALS,
    LUBRICATED_RESTITUTION_VELOCITY,
    PairGeometry,
    resolve_pair_contact,
    yield_velocity,
)
from berryshaker.errors import ConfigError

K, N, MASS = 1.2e9, 1.1, 1.5  # a steel pin in its bore (the reference machine's pin A law), coupler mass (kg)


def _restitution(law: str, v: float, v_ref: float, e: float = 0.9) -> float:
    """Rebound / impact speed of a mass MASS striking at v through the compiled law ``law``."""
    f = get_law(law).kernel

    def rhs(t, y):
        d, dd = y
        return [dd, -f(d, dd, v, K, N, e, v_ref, 0.0) / MASS if d > 0.0 else 0.0]

    back = lambda t, y: y[0]  # noqa: E731
    back.terminal, back.direction = True, -1
    t_end = 50.0 * (MASS * v ** (1 - N) / K) ** (1 / (N + 1))  # many contact durations
    sol = solve_ivp(rhs, [0.0, t_end], [0.0, v], method="DOP853", rtol=1e-11, atol=1e-20 * v, events=back,
                    first_step=1e-3 * t_end / 50.0)
    assert sol.t_events[0].size == 1, "no rebound"
    return -sol.y_events[0][0][1] / v


@pytest.mark.parametrize("law", ["lankarani_nikravesh", "hunt_crossley", "flores"])
def test_restitution_is_the_configured_one_at_and_above_v_ref(law):
    v_ref = 0.05
    e_ref = _restitution(law, v_ref, v_ref)
    for v in (v_ref, 0.2, 1.0):
        # the published law (v_ref = 0) at the same speed: identical
        assert _restitution(law, v, v_ref) == pytest.approx(_restitution(law, v, 0.0), abs=1e-9)
        assert _restitution(law, v, v_ref) == pytest.approx(e_ref, abs=1e-7)
    assert e_ref == pytest.approx(0.9, abs=0.02)  # these laws hit e = 0.9 within 2 % (tests/contact/test_force_laws.py)


@pytest.mark.parametrize("law", ["lankarani_nikravesh", "hunt_crossley", "flores"])
def test_restitution_rises_to_one_below_v_ref_as_hunt_crossley_predicts(law):
    v_ref, e = 0.05, 0.9
    f_e = float(hysteresis_factor(e, law))
    previous = _restitution(law, v_ref, v_ref)
    for ratio in (0.3, 0.1, 0.01, 1e-3):
        v = ratio * v_ref
        e_v = _restitution(law, v, v_ref)
        loss = 1.0 - e_v**2  # fraction of the impact energy dissipated
        predicted = 4.0 / 3.0 * f_e * ratio  # small-damping closed form, exact as v -> 0
        # first-order accurate: the relative error is of the order of the damping, alpha v = f(e) v / v_ref
        # (measured: -0.96 f(e) v / v_ref at v = 0.3 v_ref, -1.00 f(e) v / v_ref at 1e-3 v_ref)
        assert loss == pytest.approx(predicted, rel=1.1 * f_e * ratio + 1e-5), (law, ratio)
        assert loss < predicted
        assert previous < e_v < 1.0
        previous = e_v
    # without v_ref, a slow impact loses as much as a fast one (the behaviour the restitution velocity removes)
    assert _restitution(law, 1e-3 * v_ref, 0.0) == pytest.approx(_restitution(law, v_ref, 0.0), abs=1e-7)


def test_yield_velocity_of_the_material_pairs():
    """Johnson (1985) sec. 11.4 quotes V_Y = 0.14 m/s for steel of Y = 1 GPa; our pairs have Y = H/3."""
    from berryshaker.contact.conformal import material_constants
    from berryshaker.contact.pair_law import PIN_DENSITY
    from berryshaker.contact.stiffness import effective_modulus

    es = effective_modulus(*material_constants("steel"), *material_constants("steel"))
    y = 1e9
    assert math.sqrt(26.0 * y * (y / es) ** 4 / PIN_DENSITY) == pytest.approx(0.14, abs=0.005)
    assert yield_velocity("steel-steel-lubricated") == pytest.approx(0.051, abs=0.001)  # H = 2 GPa
    assert yield_velocity("steel-on-bronze-greased") == pytest.approx(0.018, abs=0.001)  # H = 1 GPa
    assert yield_velocity("hardened-steel-dry") > yield_velocity("mild-steel-dry")
    for pair in ELASTIC_MATERIALS:
        assert 1e-3 < yield_velocity(pair) < 10.0


def test_pair_resolution_and_the_compiled_slot():
    from berryshaker.contact.wear import MATERIAL_PAIRS

    # a dry pair: the yield velocity; a lubricated pair: the published law (squeeze film) with its numerical floor
    # of 1 mm/s (tests/contact/test_pair_law_velocity_floor.py shows the statistics independent of it)
    dry = resolve_pair_contact("lankarani_nikravesh", PairGeometry("pin-in-bore", 1e-4, 0.02, 0.02, "mild-steel-dry"))
    assert dry.restitution_velocity == pytest.approx(yield_velocity("mild-steel-dry"))
    assert dry.tags["restitution_velocity"] == "derived"
    geom = PairGeometry("pin-in-bore", 1e-4, 0.02, 0.02, "steel-on-bronze-greased")
    c = resolve_pair_contact("lankarani_nikravesh", geom)
    assert c.restitution_velocity == LUBRICATED_RESTITUTION_VELOCITY and c.tags["restitution_velocity"] == "derived"
    assert 0.0 < LUBRICATED_RESTITUTION_VELOCITY < 0.1 * yield_velocity("steel-on-bronze-greased")
    for name, pair in MATERIAL_PAIRS.items():
        assert pair.lubricated == (name.endswith("-lubricated") or name.endswith("-greased"))
    assert c.engine_contact()["restitution_velocity"] == c.restitution_velocity
    c = resolve_pair_contact("lankarani_nikravesh", geom, restitution_velocity=0.1, tags={"restitution_velocity": "study"})
    assert (c.restitution_velocity, c.tags["restitution_velocity"]) == (0.1, "study")
    assert slot_c("lankarani_nikravesh", 2000.0, 0.1) == 0.1
    assert slot_c("impact", 2000.0, 0.1) == 2000.0  # a viscous law keeps its damping in the slot
    c = resolve_pair_contact("impact", geom, stiffness=1e8, damping=2000.0)
    assert c.restitution_velocity == 0.0
    with pytest.raises(ConfigError, match="restitution_velocity"):
        resolve_pair_contact("lankarani_nikravesh", geom, restitution_velocity=-1.0, field_prefix="clearance.C")


def test_machine_field_takes_engineering_units():
    from berryshaker.config import reference_machine

    m = reference_machine()
    data = m.model_dump(mode="json")
    data["clearance"]["C"]["restitution_velocity"] = "30 mm/s"
    m2 = type(m).model_validate(data)
    assert m2.pair_contact("C").restitution_velocity == pytest.approx(0.03)
    data["clearance"]["C"]["restitution_velocity"] = "30 mm"
    with pytest.raises(Exception, match="restitution_velocity"):
        type(m).model_validate(data)
