"""The resolution floor (``diagnose(..., resolution_floor=)``, ``--resolution-floor``):
nothing is named where the nominal model already explains PV to within 0.5 % of its
spread."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import fast_pi_healthy as fp  # noqa: E402

from stictionbench.diagnosis import NominalModel, diagnose  # noqa: E402
from stictionbench.diagnosis.diagnose import RESOLUTION_FLOOR  # noqa: E402


@pytest.fixture(scope="module")
def clean_case():
    # a healthy tight loop, the PI every 0.25 s, neither noise nor load, the exact model
    # and its period: the reconstruction leaves a replay error of ~3e-4 of PV's spread,
    # on which a sensor lag of a fraction of a second is "significant" (intersample_op.md,
    # part C; read in docs/diagnosis.md)
    rec = fp.loop(8.0, 0.25, 201, noise=0.0, load=0.0)
    kc, ti = fp.simc(8.0)
    return rec, NominalModel(fp.GAIN, 8.0, fp.DEAD_TIME, kc, ti, 1.0, controller_period=0.25)


def test_a_clean_healthy_loop_gets_none_and_the_floor_says_what_it_held_back(clean_case):
    rec, model = clean_case
    off = diagnose(rec, model, resolution_floor=0.0)
    assert off.missing_physics != "none" and off.fit["nominal"] < RESOLUTION_FLOOR
    on = diagnose(rec, model)
    assert on.missing_physics == "none" and on.parameters == {}
    floor = on.details["resolution_floor"]
    assert floor["named_before"] == off.missing_physics
    assert floor["nominal_nrmse"] == pytest.approx(off.fit["nominal"])
    assert on.fit["improved"] == on.fit["nominal"]
    assert off.details["decided_by"] != "resolution_floor"
    assert on.details["decided_by"] == "resolution_floor"
    json.dumps(on.to_json(), allow_nan=False)  # the CLI's JSON holds it


def test_the_floor_leaves_a_noisy_recording_alone():
    # noise of a tenth of the package's default: the nominal's error is far above the floor
    rec = fp.loop(8.0, 1.0, 201, noise=0.05, load=1.0, valve=("valve=kano", "valve.S=3.0",
                                                                "valve.J=1.5"))
    kc, ti = fp.simc(8.0)
    model = NominalModel(fp.GAIN, 8.0, fp.DEAD_TIME, kc, ti, 1.0)
    d = diagnose(rec, model)
    assert d.fit["nominal"] > RESOLUTION_FLOOR and "resolution_floor" not in d.details
    assert d.missing_physics == diagnose(rec, model, resolution_floor=0.0).missing_physics


def test_cli_help_states_the_default_and_bad_values_exit_2(tmp_path):
    help_text = subprocess.run([sys.executable, "-m", "stictionbench.cli", "diagnose", "-h"],
                               capture_output=True, text=True).stdout
    assert f"default {RESOLUTION_FLOOR:g}" in " ".join(help_text.split())
    csv = tmp_path / "r.csv"
    fp.loop(8.0, 1.0, 201).to_frame()[["t", "SP", "PV", "OP"]].to_csv(csv, index=False)
    out = tmp_path / "o.json"
    for bad in ("-1", "nan", "inf"):
        p = subprocess.run([sys.executable, "-m", "stictionbench.cli", "diagnose", str(csv),
                            "--json", str(out), "--resolution-floor", bad],
                           capture_output=True, text=True)
        assert p.returncode == 2, p.stderr
        assert len(p.stderr.strip().splitlines()) == 1 and not out.exists()
        assert "--resolution-floor" in p.stderr
