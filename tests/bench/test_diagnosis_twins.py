"""bench/diagnosis_twins.py: planted effects against their clean twins."""
import json
import os
import subprocess
import sys

SCRIPT = os.path.join(os.environ.get("FESIM_SOURCE_DIR", os.path.join(os.path.dirname(__file__),
                                                                       "..", "..")),
                      "bench", "diagnosis_twins.py")


def diagnosis(cause, nrmse, candidates):
    return {"cause": cause, "baseline": {"heldout_nrmse": nrmse}, "candidates": candidates}


def cand(id_, gain, joint=None, control=False):
    return {"id": id_, "joint": joint, "control": control, "heldout_gain": gain}


def data_set(seed, planted, right, nrmse, twin_nrmse, candidates, twin_candidates, effect=2.0,
             left=1.0, misfit=3.0, twin_cause="none", kind="single", joint=None):
    e = {"seed": seed, "kind": kind, "planted": planted, "right": right,
         "diagnosis": diagnosis("x", nrmse, candidates),
         "twin": {"heldout_effect_noise": effect, "heldout_left_noise": left,
                  "heldout_twin_residual_noise": misfit,
                  "diagnosis": diagnosis(twin_cause, twin_nrmse, twin_candidates)}}
    if joint:
        e["planted_joint"] = joint
    return e


def run(args):
    return subprocess.run([sys.executable, SCRIPT] + args, capture_output=True, text=True)


def test_oracle_gain_clean_null_and_counts_per_mechanism(tmp_path):
    records = [
        # oracle gain (0.20 − 0.10) / 0.20 = 50 %, far above every twin's largest gain
        data_set(1, ["tremor"], True, 0.20, 0.10, [cand("tremor", 0.45, "wrist_flexion"),
                                                   cand("tremor", 0.9, "mcp_flexion")],
                 [cand("crosstalk", 0.02), cand("arm_support", 0.5, control=True)],
                 joint="wrist_flexion"),
        # oracle gain 1 %: the calibration took the effect
        data_set(2, ["delay"], False, 0.100, 0.099, [cand("delay", 0.005)],
                 [cand("delay", 0.004), cand("fatigue", 0.06)]),
        data_set(3, ["delay"], False, 0.100, 0.098, [], [cand("unequal_muscle_dynamics", 0.04)],
                 twin_cause="unequal_muscle_dynamics"),
        # the same data set again (counted once) and one without a twin (skipped)
        data_set(1, ["tremor"], False, 0.5, 0.5, [], []),
    ]
    no_twin = dict(records[0])
    no_twin.pop("twin")
    no_twin["seed"] = 9
    a = tmp_path / "a.json"
    a.write_text(json.dumps(records[:3] + [no_twin]), encoding="utf-8")
    b = tmp_path / "b.json"
    b.write_text(json.dumps(records[3:]), encoding="utf-8")
    out = tmp_path / "tw.md"
    r = run(["--out", str(out), str(a), str(b)])
    assert r.returncode == 0, r.stderr
    text = out.read_text(encoding="utf-8")
    assert "from 3 data sets with a twin" in text
    # nulls 2 %, 6 %, 4 % (the control's 50 % does not count): 95 % quantile 5.8 %
    assert "median 4.0 %, 90 % quantile 5.6 %, 95 % quantile 5.8 %, largest 6.0 %" in text
    assert "`none` on 2 of 3 (3 unequal_muscle_dynamics)" in text
    assert "| delay | 2 | 2.00 | 1.00 | 0.50 | 3.00 | 1.5 % | 0 | 0 | 0 |" in text
    assert "| tremor | 1 | 2.00 | 1.00 | 0.50 | 3.00 | 50.0 % | 1 | 1 | 1 |" in text
    assert "| all | 3 | | | | | | 1 | 1 | 1 |" in text
    # the planted candidate at the planted joint, on the data and on the twin (not fitted: –)
    assert "| 1 | single | tremor@wrist_flexion | x | yes | 2.00 | 1.00 | 3.00 | 50.0 % | 45.0 % | " \
           "– | 2.0 % | none |" in text
    assert "| 2 | single | delay | x | no | 2.00 | 1.00 | 3.00 | 1.0 % | 0.5 % | 0.4 % | 6.0 % | " \
           "none |" in text


def test_a_record_without_twins_or_with_a_broken_twin_is_a_one_line_error(tmp_path):
    out = tmp_path / "tw.md"
    plain = tmp_path / "plain.json"
    e = data_set(1, ["delay"], False, 0.1, 0.1, [], [])
    e.pop("twin")
    plain.write_text(json.dumps([e]), encoding="utf-8")
    r = run(["--out", str(out), str(plain)])
    assert r.returncode != 0 and r.stderr.strip().count("\n") == 0 and "--twin 1" in r.stderr
    assert not out.exists()
    broken = tmp_path / "broken.json"
    e = data_set(1, ["delay"], False, 0.1, 0.1, [], [])
    e["twin"].pop("heldout_left_noise")
    broken.write_text(json.dumps([e]), encoding="utf-8")
    r = run(["--out", str(out), str(broken)])
    assert r.returncode != 0 and "heldout_left_noise" in r.stderr and "broken.json" in r.stderr
    assert not out.exists()
