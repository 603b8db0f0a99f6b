"""The drives' kinematics summary as a typed record (berryshaker.drives.kinematics_record): every drive's
``kinematics_summary`` reads back as a KinematicsSummary writing the same JSON; an unknown key is refused."""

from __future__ import annotations

import json

import pydantic
import pytest

from berryshaker.config import reference_machine
from berryshaker.drives import DRIVE_PACKAGES, get_drive
from berryshaker.drives.kinematics_record import KinematicsSummary


@pytest.mark.parametrize("name", list(DRIVE_PACKAGES))
def test_every_drives_summary_round_trips(name):
    m, drive = reference_machine(name), get_drive(name)
    summary = drive.kinematics_summary(m, drive.check(m))
    rec = KinematicsSummary.from_json(summary)
    assert json.dumps(rec.to_json()) == json.dumps(summary)  # values, types and the keys' order
    assert rec.combs["left"].swing_deg.max == summary["combs"]["left"]["swing_deg"]["max"]
    assert rec.drive.comb_frequency_hz == summary["drive"]["comb_frequency_hz"]
    assert (rec.cam is None) == ("cam" not in summary) and (rec.crank is None) == ("crank" not in summary)


def test_an_unknown_or_missing_key_is_refused():
    m, drive = reference_machine("groove_cam"), get_drive("groove_cam")
    summary = drive.kinematics_summary(m, drive.check(m))
    with pytest.raises(pydantic.ValidationError, match="wrong"):
        KinematicsSummary.from_json({**summary, "cam": {**summary["cam"], "wrong": 1}})
    with pytest.raises(pydantic.ValidationError, match="linkage"):
        KinematicsSummary.from_json({k: v for k, v in summary.items() if k != "linkage"})
