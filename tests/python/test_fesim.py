"""The Python module `fesim` (python/module.cc), run by ctest (tests/CMakeLists.txt) with
PYTHONPATH at build/python and FESIM_SOURCE_DIR at the source tree."""
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

import fesim

SOURCE = os.environ["FESIM_SOURCE_DIR"]
RIG = os.path.join(SOURCE, "scenarios", "hand_rig.yaml")


@pytest.fixture(scope="module")
def short_rig(tmp_path_factory):
    """The hand rig with a 30 s step protocol (the rig file's stimulation block replaced)."""
    text = open(RIG).read()
    text = text[: text.index("stimulation:")] + (
        "stimulation:\n  duration_s: 30\n  type: steps\n  steps: [{time_s: 2, values_us: "
        "{ext: 200}}, {time_s: 8, values_us: {flex: 150}}, {time_s: 14, values_us: {ext: 100, "
        "flex: 100}}, {time_s: 20, values_us: {ext: 250}}, {time_s: 26, values_us: {flex: 0}}]\n"
        "sensors:\n  angles: {rate_hz: 60, noise_std_deg: 1.0, coordinates: [wrist_flexion, "
        "mcp_flexion]}\n")
    path = tmp_path_factory.mktemp("rig") / "short_rig.yaml"
    path.write_text(text)
    return str(path)


@pytest.fixture(scope="module")
def simulated(short_rig):
    return [fesim.simulate(short_rig, seed=s) for s in (3, 4)]


def test_a_trial_round_trips_through_csv_with_its_metadata_and_nan(tmp_path):
    t = fesim.Trial(np.array([0.0, 0.5, 1.0]),
                    {"u.ext": np.array([0.0, 100.0, 200.0]), "q.wrist_flexion": [0.1, np.nan, 0.3]},
                    {"subject": "P1"})
    assert len(t) == 3 and t.names == ["u.ext", "q.wrist_flexion"] and "u.ext" in t
    fesim.write_trial(t, str(tmp_path / "t.csv"))
    back = fesim.read_trial(str(tmp_path / "t.csv"))
    np.testing.assert_array_equal(back.time, t.time)
    np.testing.assert_array_equal(back["u.ext"], [0.0, 100.0, 200.0])
    assert math.isnan(back["q.wrist_flexion"][1])
    assert back.metadata["subject"] == "P1"
    fesim.write_trial(t, str(tmp_path / "t.sto"))
    assert "endheader" in (tmp_path / "t.sto").read_text()
    fesim.write_trial(t, str(tmp_path / "t.mat"))
    assert (tmp_path / "t.mat").read_bytes()[:6] == b"MATLAB"


def test_bad_input_raises_with_the_command_lines_one_line_message(tmp_path):
    with pytest.raises(RuntimeError, match="cannot open for reading"):
        fesim.read_trial(str(tmp_path / "missing.csv"))
    with pytest.raises(ValueError, match="not strictly increasing"):
        fesim.Trial(np.array([0.0, 0.0]))
    with pytest.raises(ValueError, match=r"unknown trial format '.txt' \(allowed: .csv, .sto, .mat\)"):
        fesim.write_trial(fesim.Trial(np.array([0.0])), str(tmp_path / "t.txt"))
    with pytest.raises(RuntimeError, match=r"unknown method 'nope' \(allowed: .*spline-oe"):
        fesim.identify("nope", [fesim.Trial(np.array([0.0]))])
    with pytest.raises(ValueError, match=r"duration_s: .* is outside \[0.001, 3600\]"):
        fesim.simulate(RIG, duration_s=-1)
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\nstimulation: {duration_s: -1, type: constant, values_us: {}}\n")
    with pytest.raises(RuntimeError, match=r"bad.yaml: stimulation.duration_s: -1 is outside"):
        fesim.simulate(str(bad))
    assert not (tmp_path / "t.txt").exists()


def test_simulate_returns_the_measured_trial_and_the_truth_seeded(short_rig, simulated):
    m = simulated[0]["measured"]
    assert m.time[-1] == pytest.approx(30.0, abs=1 / 60)
    assert {"u.ext", "u.flex", "q.wrist_flexion", "q.mcp_flexion"} <= set(m.names)
    assert m.metadata["scenario"] == "hand_rig"
    assert simulated[0]["stats"]["steps"] > 0
    # The same seed gives the same noise; another seed other noise, the same truth.
    again = fesim.simulate(short_rig, seed=3)["measured"]
    np.testing.assert_array_equal(again["q.wrist_flexion"], m["q.wrist_flexion"])
    other = simulated[1]
    assert not np.array_equal(other["measured"]["q.wrist_flexion"], m["q.wrist_flexion"])
    np.testing.assert_array_equal(other["truth"]["q.wrist_flexion"],
                                  simulated[0]["truth"]["q.wrist_flexion"])
    calls = []
    fesim.simulate(short_rig, seed=3, duration_s=2, progress=lambda f, s: calls.append(f))
    assert calls and calls[-1] == pytest.approx(1.0)


def test_identify_fits_on_one_trial_and_predicts_another():
    names = [n for n, _ in fesim.methods()]
    assert "hammerstein-mimo" in names and "full-model" in names
    # The rig's step grid (5 s steps): 30 steady-state points in 150 s.
    grid = [fesim.simulate(RIG, seed=s, duration_s=150)["measured"] for s in (1, 2)]
    fit = fesim.identify("hammerstein-mimo", [grid[0]], test=[grid[1]])
    assert "Omega: {value: " in fit["model_yaml"]
    omega = fit["parameters"]["Omega"]
    assert omega["unit"] == "rad/s" and omega["value"] > 0
    lo, hi = omega["ci95"]
    assert lo < omega["value"] < hi
    pred = fit["predictions"][0]  # at the angle sensor's rows (60 Hz) of the other trial
    assert "q.wrist_flexion" in pred and pred.time[-1] == pytest.approx(150.0, abs=1 / 60)
    # The model predicts the other trial's wrist better than its mean does.
    assert fit["metrics"]["mean_normalised_error"]["q.wrist_flexion"] < 1.0
    assert fit["discrete_models"] == []  # continuous-time: no .mat polynomials


def test_identify_gives_a_discrete_model_with_its_sample_time(simulated):
    m = simulated[0]["measured"]
    rows = np.isfinite(m["q.wrist_flexion"])  # the 60 Hz angle sensor's rows
    siso = fesim.Trial(m.time[rows], {"u.ext": m["u.ext"][rows],
                                      "q.wrist_flexion": m["q.wrist_flexion"][rows]})
    fit = fesim.identify("spline-oe", [siso])
    (d,) = fit["discrete_models"]
    assert d["sample_time_s"] == pytest.approx(1 / 60)
    assert d["inputs"] == ["u.ext"] and d["output"] == "q.wrist_flexion"
    assert d["A"] == [1.0] and d["F"][0] == 1.0 and len(d["breakpoints_u"][0]) == 101


def test_diagnose_gives_the_verdict_person_candidates_and_residuals(short_rig, simulated, tmp_path):
    d = fesim.diagnose([simulated[0]["measured"]], scenario=short_rig, threads=2,
                       out=str(tmp_path / "diag"))
    assert d["cause"] == "none"
    assert d["person"] and d["candidates"] and "reference" in d
    json_file = json.loads((tmp_path / "diag" / "diagnosis.json").read_text())
    assert json_file["cause"] == d["cause"]
    held = d["heldout"][0]
    r = held["residual_baseline"]["q.wrist_flexion"]
    np.testing.assert_allclose(
        r, held["measured"]["q.wrist_flexion"] - held["baseline"]["q.wrist_flexion"])
    assert np.nanstd(r) < 0.1  # rad: the calibrated model follows its person


def test_render_writes_png_frames_of_a_trial_object(simulated, tmp_path):
    m = simulated[0]["measured"]
    fesim.render(m, scenario=RIG, frames=str(tmp_path / "frames"), width=64, height=48, fps=0.5)
    assert len(os.listdir(tmp_path / "frames")) == 16  # 0, 2, …, 30 s
    with pytest.raises(RuntimeError, match=r"option --width: 3 must be in \[2, .*even for MP4"):
        fesim.render(m, scenario=RIG, out=str(tmp_path / "m.mp4"), width=3)


def test_the_example_study_runs(tmp_path):
    env = dict(os.environ)
    r = subprocess.run([sys.executable, os.path.join(SOURCE, "examples", "study.py"),
                        str(tmp_path / "study")], capture_output=True, text=True, env=env,
                       timeout=900)
    assert r.returncode == 0, r.stderr
    assert "diagnosis: " in r.stdout and "frames: " in r.stdout
