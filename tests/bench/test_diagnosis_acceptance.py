"""bench/diagnosis_acceptance.py: the stage a planted candidate stopped at, thresholds re-decided."""
import json
import os
import subprocess
import sys

SCRIPT = os.path.join(os.environ.get("FESIM_SOURCE_DIR", os.path.join(os.path.dirname(__file__),
                                                                       "..", "..")),
                      "bench", "diagnosis_acceptance.py")


def cand(id_, decision, gain=None, z=None, own=None, own_z=None, lr=1e-9, **extra):
    c = {"id": id_, "control": False, "decision": decision, "heldout_gain": gain,
         "heldout_z": z, "heldout_own_gain": own, "heldout_own_z": own_z, "lr_p_adjusted": lr,
         "shape_contradiction": None, "person_at_bound": None}
    c.update(extra)
    return c


def data_set(seed, kind, planted, right, candidates, ratio=2.0):
    return {"seed": seed, "kind": kind, "planted": planted, "effect_ratio": ratio, "right": right,
            "diagnosis": {"cause": "x", "candidates": candidates}}


def run(args):
    return subprocess.run([sys.executable, SCRIPT] + args, capture_output=True, text=True)


def test_stages_and_a_threshold_that_trades_a_clean_person_for_a_planted_effect(tmp_path):
    records = [
        data_set(1, "single", ["tremor"], True, [cand("tremor", "passes", 0.2, 5.0, 0.2, 5.0)]),
        # significant at z 2.5 (below the shipped 2.94), own part clear
        data_set(2, "single", ["delay"], False,
                 [cand("delay", "held-out gain below 10 % and not significant", 0.05, 2.5, 0.05,
                       4.0)]),
        data_set(3, "single", ["sensor_drift"], False,
                 [cand("sensor_drift", "the offset steps rather than drifts (...)", 0.2, 4.0, 0.2,
                       4.0, shape_contradiction="steps")]),
        data_set(4, "single", ["spasticity"], False,
                 [cand("spasticity", "score test not significant")]),
        # the same seed again with the same effect: counted once, from the first record
        data_set(1, "single", ["tremor"], False, [cand("tremor", "score test not significant")]),
        data_set(5, "clean", ["clean"], True,
                 [cand("crosstalk", "held-out gain below 10 % and not significant", 0.03, 2.2,
                       0.03, 3.0)], ratio=0.0),
        data_set(6, "clean", ["clean"], True,
                 [cand("fatigue", "held-out gain below 10 % and not significant", 0.04, 2.7,
                       0.04, 3.0), cand("arm_support", "passes", 0.3, 9.0, 0.3, 9.0,
                                        control=True)], ratio=0.0),
    ]
    a = tmp_path / "a.json"
    a.write_text(json.dumps(records[:4] + records[5:]), encoding="utf-8")
    b = tmp_path / "b.json"
    b.write_text(json.dumps([records[4]]), encoding="utf-8")
    out = tmp_path / "acc.md"
    r = run(["--out", str(out), str(a), str(b)])
    assert r.returncode == 0, r.stderr
    text = out.read_text(encoding="utf-8")
    assert "(4 single planted effects, 2 clean persons)" in text
    assert "| delay | 1 | 0 | 0 | 0 | 0 | 0 | 1 | 0 |" in text
    assert "| sensor_drift | 1 | 0 | 0 | 0 | 0 | 1 | 0 | 0 |" in text
    assert "| spasticity | 1 | 0 | 0 | 1 | 0 | 0 | 0 | 0 |" in text
    assert "| tremor | 1 | 1 | 0 | 0 | 0 | 0 | 0 | 0 |" in text
    # shipped: tremor alone, no clean person (the control does not count); a looser held-out z
    # names the delay as well; the clean persons' own parts (z 3.0, 3-4 %) pass only where the
    # delay's passes too, so naming them gains nothing: the frontier is one row
    assert "| 0 (shipped thresholds) | 1 | 0.01 | 2.94 | 0.1 | 2.94 | 0.02 |" in text
    frontier = [line for line in text.split("re-decided")[1].splitlines()
                if line.startswith("| ") and line[2].isdigit() and "shipped" not in line]
    assert len(frontier) == 1 and frontier[0].startswith("| 0 | 2 |"), frontier


def test_a_file_that_is_not_a_record_is_a_one_line_error_and_writes_nothing(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"seed": 1}', encoding="utf-8")
    out = tmp_path / "acc.md"
    r = run(["--out", str(out), str(bad)])
    assert r.returncode != 0 and r.stderr.strip().count("\n") == 0 and "bad.json" in r.stderr
    assert not out.exists()
    bad.write_text('[{"seed": 1, "kind": "single"}]', encoding="utf-8")
    r = run(["--out", str(out), str(bad)])
    assert r.returncode != 0 and "no key 'planted'" in r.stderr
    assert not out.exists()


def test_per_mechanism_thresholds_come_from_the_clean_persons_of_the_other_draws(tmp_path):
    not_significant = "held-out gain below 10 % and not significant"
    records = [
        # draw 1: a clean person whose crosstalk fit gains 5 % (its own part clear)
        data_set(1001, "clean", ["clean"], True,
                 [cand("crosstalk", not_significant, 0.05, 1.0, 0.05, 1.0)], ratio=0.0),
        # draw 2: a delay gaining 3 %, not significant — no clean person of draw 1 has a delay
        # fit, so its threshold is 0 — and a clean person whose crosstalk gains 4 %, below draw
        # 1's 5 %
        data_set(2001, "single", ["delay"], False,
                 [cand("delay", not_significant, 0.03, 1.0, 0.03, 1.0)]),
        data_set(2002, "clean", ["clean"], True,
                 [cand("crosstalk", not_significant, 0.04, 1.0, 0.04, 1.0)], ratio=0.0),
    ]
    a = tmp_path / "a.json"
    a.write_text(json.dumps(records), encoding="utf-8")
    out = tmp_path / "acc.md"
    r = run(["--out", str(out), str(a)])
    assert r.returncode == 0, r.stderr
    text = out.read_text(encoding="utf-8").split("reference cohort (leave one draw out)")[1]
    assert "| shipped thresholds | — | 0 | 0 | — |" in text
    # at the largest null: the delay is named (T = 0) and so is 1001 (5 % against draw 2's 4 %),
    # not 2002 (4 % against draw 1's 5 %)
    assert "| shipped or gain > T_m | 1 | 1 | 1 | 0 |" in text
    assert "| gain > T_m instead | 1 | 1 | 1 | 0 |" in text
    assert "| shipped and gain > T_m | 1 | 0 | 0 | 0 |" in text
    assert "| crosstalk | 2 | 0.0500 | 0.0500 |" in text
