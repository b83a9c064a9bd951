"""bench/diagnosis_suite.cc: the Markdown record of a run, from diagnoses read back with --reuse.

The diagnoses are written here by hand (no data set is simulated or diagnosed: --reuse takes every
planned data set from the file), so the test checks what the suite counts as right — the planted
cause at its joint, `none` on a clean person, no mechanism at confidence ≥ 0.5 outside the library,
both of a pair — and the rates and lines it writes. Needs the built binary, whose path CTest passes
in FESIM_DIAGNOSIS_SUITE (tests/CMakeLists.txt).
"""
import json
import os
import subprocess

import pytest

SUITE = os.environ.get("FESIM_DIAGNOSIS_SUITE")
# `--suite foreign --mechanisms tremor --per 2 --clean 1 --outside 1 --pairs 1` plans seeds 1001,
# 1002 (tremor), 1003 (clean), 1004 (outside: wander) and 1005 (pair: fatigue + tremor).
OPTIONS = ["--suite", "foreign", "--mechanisms", "tremor", "--per", "2", "--clean", "1",
           "--outside", "1", "--pairs", "1"]


def diagnosis(cause, confidence, named, baseline=0.2, reference=0.4, extended=0.1):
    """A diagnosis.json as docs/diagnosis.md describes it, with what the Markdown reads."""
    return {"cause": cause, "confidence": confidence, "reason": "written by the test",
            "gain": 0.5, "baseline": {"heldout_nrmse": baseline},
            "reference": {"heldout_nrmse": reference},
            "extended": {"mechanisms": [label.split("@")[0] for label in named],
                         "parameters": {f"{label}:p": {"value": 1.0} for label in named},
                         "heldout_nrmse": extended}}


def data_set(seed, kind, planted, d, joint=None, ratio=2.0):
    e = {"seed": seed, "kind": kind, "planted": planted, "effect_ratio": ratio, "wall_s": 3.0,
         "planted_values": [], "right": None, "diagnosis": d}
    if joint:
        e["planted_joint"] = joint
    return e


@pytest.mark.skipif(SUITE is None, reason="FESIM_DIAGNOSIS_SUITE is set by CTest")
def test_rates_and_lines_of_reused_diagnoses(tmp_path):
    earlier = [
        data_set(1001, "single", ["tremor"],
                 diagnosis("tremor", 0.9, ["tremor@wrist_flexion"]), joint="wrist_flexion"),
        # the right mechanism at another joint than the planted one
        data_set(1002, "single", ["tremor"],
                 diagnosis("tremor", 0.8, ["tremor@mcp_flexion"]), joint="wrist_flexion"),
        data_set(1003, "clean", [], diagnosis("none", 0.7, [], baseline=0.3, reference=0.2),
                 ratio=0.0),
        # outside the library, named a mechanism at confidence ≥ 0.5
        data_set(1004, "outside", ["wander"], diagnosis("crosstalk", 0.62, ["crosstalk"])),
        data_set(1005, "pair", ["fatigue", "tremor"],
                 diagnosis("fatigue", 0.7, ["fatigue", "tremor@pip_flexion"])),
    ]
    old = tmp_path / "old.json"
    old.write_text(json.dumps(earlier), encoding="utf-8")
    md, js = tmp_path / "run.md", tmp_path / "run.json"
    r = subprocess.run([SUITE] + OPTIONS + ["--reuse", str(old), "--out", str(md), "--json",
                                            str(js)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    text = md.read_text(encoding="utf-8")
    assert "(5 of 5 data sets, 5 of them read from" in text
    assert "| tremor | 1/2 | 50 % | 1/2 | ≥ 80 % |" in text
    assert "| clean | 1/1 | 100 % | 1/1 | none ≥ 90 % |" in text
    assert "| outside | 0/1 | 0 % | 0/1 | never a mechanism at confidence ≥ 0.5 |" in text
    assert "| pair | 1/1 | 100 % | 1/1 | both named ≥ 80 % |" in text
    # the clean person's calibrated model against the black box: 0.3 / 0.2
    assert "held-out NRMSE 1.50–1.50 (median 1.50), within 1.5× on 1/1." in text
    assert ("| 1002 | single | tremor@wrist_flexion | 2.00 | tremor | tremor@mcp_flexion | 0.80 "
            "| 0.200 | 0.400 | 0.100 | 3.0 | **no** |") in text
    assert "| 1001 | single | tremor@wrist_flexion | 2.00 | tremor | tremor@wrist_flexion |" in text
    assert ("| 1005 | pair | fatigue+tremor | 2.00 | fatigue | fatigue+tremor@pip_flexion | 0.70 "
            "| 0.200 | 0.400 | 0.100 | 3.0 | yes |") in text
    # --json keeps each reused diagnosis as read and the suite's own judgement of it
    out = {e["seed"]: e for e in json.loads(js.read_text(encoding="utf-8"))}
    assert [out[s]["right"] for s in (1001, 1002, 1003, 1004, 1005)] == [True, False, True,
                                                                         False, True]
    assert out[1004]["diagnosis"] == earlier[3]["diagnosis"]


@pytest.mark.skipif(SUITE is None, reason="FESIM_DIAGNOSIS_SUITE is set by CTest")
def test_a_reused_data_set_of_another_kind_is_a_one_line_error_and_writes_nothing(tmp_path):
    old = tmp_path / "old.json"
    old.write_text(json.dumps([data_set(1003, "single", ["tremor"],
                                        diagnosis("none", 0.7, []))]), encoding="utf-8")
    md = tmp_path / "run.md"
    r = subprocess.run([SUITE] + OPTIONS + ["--reuse", str(old), "--out", str(md)],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0
    assert "data set 1003 is single tremor there, clean here" in r.stderr
    assert not md.exists()
