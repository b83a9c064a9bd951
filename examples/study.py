"""A whole fesim study from Python: simulate two trials of a virtual participant on the hand rig,
identify a Hammerstein model on one and validate it on the other, diagnose the first trial, and
render a second of it (README "Python"). Usage: python3 examples/study.py [OUT_DIR]"""
import os, sys
import fesim

out = sys.argv[1] if len(sys.argv) > 1 else "out/python_study"
os.makedirs(out, exist_ok=True)
rig = os.path.join(os.path.dirname(__file__), "..", "scenarios", "hand_rig.yaml")
trials = [fesim.simulate(rig, seed=s, duration_s=150)["measured"] for s in (1, 2)]
for k, t in enumerate(trials):
    fesim.write_trial(t, f"{out}/trial{k + 1}.csv")
fit = fesim.identify("hammerstein-mimo", [trials[0]], test=[trials[1]])
print("hammerstein-mimo, normalised error on trial 2:", fit["metrics"]["mean_normalised_error"])
d = fesim.diagnose([trials[0]], scenario=rig, threads=2, out=f"{out}/diagnosis")
print(f"diagnosis: {d['cause']} (confidence {d['confidence']:.2f}): {d['reason']}")
fesim.render(f"{out}/trial1.csv", scenario=rig, frames=f"{out}/frames", width=160, height=120, fps=2)
print("frames:", len(os.listdir(f"{out}/frames")), "written to", f"{out}/frames")
