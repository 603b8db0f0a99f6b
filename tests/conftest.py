import os

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


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
