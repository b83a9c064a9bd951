#!/usr/bin/env python3
"""How much of each planted effect the person calibration leaves, against its clean twin.

Usage: diagnosis_twins.py --out OUT.md RECORD.json...

Each RECORD.json is a file written by `diagnosis_suite --twin 1 --json` (either suite)
(bench/diagnosis_suite.cc): every data set with planted effects was diagnosed a second time without
them (its clean twin: the same person, stimulation, noise and dropouts) and carries `twin` with
the twin's whole diagnosis and, on the held-out trial, the planted effect's RMS, what the
calibrated model leaves of it and the twin's calibrated residual, all over the noise σ. A data set
found in two records (same seed, kind and planted effects) counts once, from the record listed
first; data sets without a twin are skipped. OUT.md gets, per single planted effect and per
mechanism:

- the oracle gain: (NRMSE_with − NRMSE_twin) / NRMSE_with of the two calibrated models' held-out
  NRMSE. Since the two data sets differ only by the effect, the twin's calibrated prediction plus
  the effect is the extended model an exact mechanism with the person of the effect-free
  calibration would give; its held-out gain over the calibrated model is the oracle gain, on the
  scale of every candidate's `heldout_gain` (docs/diagnosis.md, "Extension and acceptance");
- the clean null: the largest held-out gain of a mechanism's fit (not a control) on each twin —
  what misfit alone gives the same persons — and its upper quantiles;
- the planted mechanism's own fit on the data with the effect and on the twin (paired);
- the twins' verdicts (each a clean person).

An oracle gain below the clean null's quantile means the calibration left less of the effect than
the misfit gives a candidate on a clean person: no acceptance test on the held-out gain can name it
without naming clean persons. The file is written atomically.
"""
import argparse
import collections
import json
import os
import statistics
import sys
import tempfile


def fail(msg):
    print(f"diagnosis_twins: {msg}", file=sys.stderr)
    sys.exit(1)


def read_records(paths):
    seen, out = set(), []
    for path in paths:
        try:
            with open(path, encoding="utf-8") as f:
                data = json.load(f)
        except (OSError, json.JSONDecodeError) as e:
            fail(f"{path}: cannot read a diagnosis_suite --json record ({e})")
        if not isinstance(data, list):
            fail(f"{path}: expected a JSON array of data sets")
        for i, e in enumerate(data):
            for key in ("seed", "kind", "planted", "right", "diagnosis"):
                if key not in e:
                    fail(f"{path}: data set {i}: key '{key}' missing")
            if "twin" not in e:
                continue
            for key in ("heldout_effect_noise", "heldout_left_noise",
                        "heldout_twin_residual_noise", "diagnosis"):
                if key not in e["twin"]:
                    fail(f"{path}: data set {e['seed']}: twin key '{key}' missing")
            k = (e["seed"], e["kind"], tuple(e["planted"]))
            if k in seen:
                continue
            seen.add(k)
            out.append(e)
    return out


def candidate(diagnosis, id_, joint):
    """The fitted candidate `id_` (at `joint` when given) of largest held-out gain, or None."""
    best = None
    for c in diagnosis.get("candidates", []):
        if c.get("id") != id_ or (joint and c.get("joint") not in (None, joint)):
            continue
        if c.get("heldout_gain") is None:
            continue
        if best is None or c["heldout_gain"] > best["heldout_gain"]:
            best = c
    return best


def largest_mechanism_gain(diagnosis):
    gains = [c["heldout_gain"] for c in diagnosis.get("candidates", [])
             if not c.get("control") and c.get("heldout_gain") is not None]
    return max(gains) if gains else 0.0


def quantile(values, q):
    v = sorted(values)
    if not v:
        return float("nan")
    pos = q * (len(v) - 1)
    lo = int(pos)
    hi = min(lo + 1, len(v) - 1)
    return v[lo] + (v[hi] - v[lo]) * (pos - lo)


def pct(x):
    return "–" if x is None else f"{100 * x:.1f} %"


def analyse(sets):
    rows = []
    for e in sets:
        d, t = e["diagnosis"], e["twin"]
        base = d["baseline"]["heldout_nrmse"]
        twin_base = t["diagnosis"]["baseline"]["heldout_nrmse"]
        oracle = (base - twin_base) / base if base > 0 else float("nan")
        row = {"seed": e["seed"], "kind": e["kind"], "planted": "+".join(e["planted"]),
               "joint": e.get("planted_joint", ""), "right": e["right"], "cause": d["cause"],
               "effect": t["heldout_effect_noise"], "left": t["heldout_left_noise"],
               "misfit": t["heldout_twin_residual_noise"], "oracle": oracle,
               "twin_cause": t["diagnosis"]["cause"],
               "null": largest_mechanism_gain(t["diagnosis"])}
        if e["kind"] == "single":
            mine = candidate(d, e["planted"][0], row["joint"])
            theirs = candidate(t["diagnosis"], e["planted"][0], row["joint"])
            row["gain"] = mine["heldout_gain"] if mine else None
            row["twin_gain"] = theirs["heldout_gain"] if theirs else None
        rows.append(row)
    return rows


def report(rows, paths, command):
    nulls = [r["null"] for r in rows]
    q90, q95 = quantile(nulls, 0.90), quantile(nulls, 0.95)
    singles = [r for r in rows if r["kind"] == "single"]
    twins_none = sum(r["twin_cause"] == "none" for r in rows)
    md = [f"# Planted effects against their clean twins\n",
          f"Generated by `{command}` from {len(rows)} data sets with a twin "
          f"({', '.join(os.path.basename(p) for p in paths)}).\n",
          "## Clean null\n",
          f"Largest held-out gain of a mechanism's fit on each twin (misfit alone, {len(nulls)} "
          f"clean persons): median {pct(statistics.median(nulls))}, 90 % quantile {pct(q90)}, "
          f"95 % quantile {pct(q95)}, largest {pct(max(nulls))}. Twins' verdicts: `none` on "
          f"{twins_none} of {len(rows)}"
          + ("" if twins_none == len(rows) else " (" + ", ".join(
              f"{r['seed']} {r['twin_cause']}" for r in rows if r["twin_cause"] != "none") + ")")
          + ".\n",
          "## Per mechanism\n",
          "Single planted effects: held-out effect, what the calibration leaves of it and the "
          "twin's residual over the noise σ (medians); oracle gain (median); how many have an "
          "oracle gain above the clean null's 95 % quantile, and how many of those and of all "
          "are named.\n",
          "| mechanism | data sets | effect / σ | left / σ | left / effect | twin residual / σ | "
          "oracle gain | above the null | named of those | named |",
          "|---|---|---|---|---|---|---|---|---|---|"]
    by = collections.defaultdict(list)
    for r in singles:
        by[r["planted"]].append(r)
    tot = collections.Counter()
    for mech in sorted(by):
        rs = by[mech]
        above = [r for r in rs if r["oracle"] > q95]
        tot.update(n=len(rs), above=len(above), named_above=sum(r["right"] for r in above),
                   named=sum(r["right"] for r in rs))
        med = lambda k: statistics.median(r[k] for r in rs)  # noqa: E731
        ratio = statistics.median(r["left"] / r["effect"] for r in rs if r["effect"] > 0)
        md.append(f"| {mech} | {len(rs)} | {med('effect'):.2f} | {med('left'):.2f} | "
                  f"{ratio:.2f} | {med('misfit'):.2f} | {pct(med('oracle'))} | {len(above)} | "
                  f"{sum(r['right'] for r in above)} | {sum(r['right'] for r in rs)} |")
    md.append(f"| all | {tot['n']} | | | | | | {tot['above']} | {tot['named_above']} | "
              f"{tot['named']} |")
    md += ["", "## Data sets\n",
           "gain: the planted mechanism's fit (at the planted joint), on the data with the effect "
           "and on the twin (– not fitted); null: the twin's largest mechanism gain.\n",
           "| seed | kind | planted | named | right | effect / σ | left / σ | twin residual / σ | "
           "oracle gain | gain | gain on the twin | null | twin's cause |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: (r["kind"], r["planted"], r["seed"])):
        planted = r["planted"] + (f"@{r['joint']}" if r["joint"] else "")
        md.append(f"| {r['seed']} | {r['kind']} | {planted} | {r['cause']} | "
                  f"{'yes' if r['right'] else 'no'} | {r['effect']:.2f} | {r['left']:.2f} | "
                  f"{r['misfit']:.2f} | {pct(r['oracle'])} | {pct(r.get('gain'))} | "
                  f"{pct(r.get('twin_gain'))} | {pct(r['null'])} | {r['twin_cause']} |")
    return "\n".join(md) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("records", nargs="+")
    a = ap.parse_args()
    rows = analyse(read_records(a.records))
    if not rows:
        fail("no data set with a twin in " + ", ".join(a.records) +
             " (run diagnosis_suite --twin 1 --json)")
    command = "python3 bench/diagnosis_twins.py --out " + a.out + " " + " ".join(a.records)
    text = report(rows, a.records, command)
    folder = os.path.dirname(os.path.abspath(a.out))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".diagnosis_twins.")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, a.out)


if __name__ == "__main__":
    main()
