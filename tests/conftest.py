import os

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")
# runs left to choose take the generic kernel here whatever this machine has compiled (multibody.specialised), so the
# suite exercises the same kernel everywhere; the tests of that choice remove it (tests/multibody/test_specialised.py)
os.environ["BERRYSHAKER_KERNEL"] = "generic"
# pytest-xdist workers start with COLUMNS=80 in their environment, and a rich Console made at import fixes its width
# from COLUMNS: drop it, so each command sees the width its test gives (CliRunner env), as in a serial run
os.environ.pop("COLUMNS", None)
os.environ.pop("LINES", None)


@pytest.fixture(scope="session")
def machine():
    from berryshaker.config import reference_machine

    return reference_machine()


@pytest.fixture
def machine_dict():
    import tomllib

    from berryshaker.config import reference_toml_text

    return tomllib.loads(reference_toml_text())


@pytest.fixture
def write_toml(tmp_path):
    """Write a nested dict as a machine TOML file and return its path."""

    def _write(data, name="machine.toml"):
        lines = []

        def emit(prefix, table):
            scalars = {k: v for k, v in table.items() if not isinstance(v, dict)}
            if prefix:
                lines.append(f"[{prefix}]")
            for k, v in scalars.items():
                if isinstance(v, str):
                    lines.append(f'{k} = "{v}"')
                elif isinstance(v, bool):
                    lines.append(f"{k} = {'true' if v else 'false'}")
                else:
                    lines.append(f"{k} = {v!r}")
            for k, v in table.items():
                if isinstance(v, dict):
                    emit(f"{prefix}.{k}" if prefix else k, v)

        emit("", data)
        p = tmp_path / name
        p.write_text("\n".join(lines) + "\n")
        return p

    return _write


def with_linear_springs(machine):
    """The machine with the linear clearance springs of berryshaker 0.1.0 (K_A = K_B = 1e8 N/m, K_C = K_F = 5e7 N/m,
    C_i = 2000 N s/m, IMPACT law): the linear-spring (study eq. 8) properties the MLSD tests check."""
    from berryshaker.config import machine_from_dict

    d = machine.model_dump()
    for p in machine.pair_names:
        pin = d["clearance"][p]["kind"] == "pin-in-bore"
        d["clearance"][p].update(law="impact", stiffness=5e7 if pin else 1e8, damping=2000.0, exponent=None)
    return machine_from_dict(d)


@pytest.fixture(scope="session")
def linear_machine(machine):
    """The reference machine with the 0.1.0 linear clearance springs (:func:`with_linear_springs`)."""
    return with_linear_springs(machine)


def linear_spring_toml_text(text: str) -> str:
    """A machine file's text with the 0.1.0 linear clearance springs in place of the steel contact law (every
    ``law = "lankarani_nikravesh"`` line becomes K = 1e8 N/m, C = 2000 N s/m, IMPACT).  Pipeline tests use it to
    halve the cost of every harvester run (0.26 against 0.56 s CPU); the steel contact itself is tested in
    tests/contact/test_pair_law_clearance.py and tests/multibody/test_impacts_convergence.py."""
    import re

    out, n = re.subn(r'law = "lankarani_nikravesh".*\n', 'stiffness = "1e8 N/m"\ndamping = "2000 N*s/m"\n', text)
    assert n >= 4, "the reference machine no longer names its clearance law as expected"
    return out


@pytest.fixture(scope="session")
def validation_cache(tmp_path_factory):
    """One run cache for the small validation machine's coupled runs, shared by tests/study/test_validation.py and
    tests/test_api.py (the same jobs, so the second caller reads them)."""
    return tmp_path_factory.mktemp("validation-cache")


@pytest.fixture(scope="session")
def small_harvest_machine():
    """The reference machine with one branch class: the cheapest description the virtual harvest and
    the validation run on."""
    from berryshaker.config import load_machine, machine_from_dict

    d = load_machine(None).model_dump()
    d["harvest"].update(branch_classes=(1.0,))
    return machine_from_dict(d)
