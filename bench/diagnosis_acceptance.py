#!/usr/bin/env python3
"""Why planted effects are missed, and what the acceptance thresholds could change at most.

Usage: diagnosis_acceptance.py --out OUT.md RECORD.json...

Each RECORD.json is a file written by `diagnosis_suite --json` (bench/diagnosis_suite.cc): per
data set its seed, kind, planted effects, effect/noise ratio, whether the verdict was right, and
the whole diagnosis.json (docs/diagnosis.md, "diagnosis.json"). A data set found in two records
(same seed, kind, planted effects and effect/noise ratio) counts once, from the record listed
first. OUT.md gets:

1. for every single planted in-library effect, the furthest stage its candidate reached
   (docs/diagnosis.md "Method"): not a candidate, not significant in the screen, not fitted,
   stopped by a rule (a parameter or the person at a bound, a normal person's variation, the
   signature shape), stopped by the statistics of its fit (training LR, held-out gain, own part)
   or passed — per mechanism;
2. the acceptance statistics re-decided over a grid of thresholds (training LR p_adj; held-out
   gain: Diebold–Mariano z or a clear gain; own part: z or a minimum gain) for every candidate
   whose fit reached the statistics, a planted data set counted right when its mechanism is
   accepted with the largest held-out gain of the accepted ones, a clean person wrong when any
   mechanism (not a control) is accepted; the best planted count for each number of clean persons
   named, and the thresholds that give it;
3. per-mechanism held-out thresholds from a reference cohort, judged out of sample: the data sets
   are grouped by draw (seed // 1000); for each draw, the clean persons of the *other* draws are
   the cohort, and a mechanism's threshold T_m is a quantile of its null — per cohort person the
   largest held-out gain of that mechanism's fits that pass every other shipped test (training
   LR, own part), 0 where it has none. The draw's data sets are then re-decided with the rules
   below; the sums over the draws are what a cohort of clean persons measured beforehand would
   give on persons it has not seen.

The re-decision is an upper bound on what thresholds alone can give: the suite's forward
selection, second round and the verdict's confidence rules are not replayed, and a candidate that
a threshold change would have fitted (screen, batches) is not. The file is written atomically.
"""
import argparse
import collections
import itertools
import json
import math
import os
import sys
import tempfile

# Decision texts of diagnosis/extension.cc and screening.cc → the stage a candidate reached,
# furthest last (a mechanism fitted at several joints counts at its furthest).
STAGES = ["not a candidate", "screen", "not fitted", "rule", "statistics", "passed"]
DECISION_PREFIXES = [
    ("score test not significant", "screen"),
    ("no direction kept", "screen"),
    ("not applicable", "not a candidate"),
    ("not fitted", "not fitted"),
    ("not judged", "not fitted"),
    ("its fit does not pass the robust training test", "statistics"),
    ("no held-out gain", "statistics"),
    ("its own part of the held-out gain", "statistics"),
    ("held-out gain below", "statistics"),
    ("passes", "passed"),
    ("dropped", "passed"),
]
# The acceptance as shipped (docs/diagnosis.md "Extension and acceptance"): LR p_adj < 0.01; the
# held-out gain significant at p_adj < 0.01 over 6 fits (z > 2.94) or above 10 %; its own part
# significant likewise or above 2 %.
SHIPPED = (0.01, 2.94, 0.10, 2.94, 0.02)
GRID = {"lr": (0.01, 0.1, 1.01), "z": (1.5, 2.0, 2.5, 2.94, 3.5, 4.0, 99.0),
        "gain": (0.02, 0.05, 0.10, 0.20), "own_z": (1.5, 2.0, 2.5, 2.94, 3.5, 99.0),
        "own": (0.02, 0.05, 0.10, 0.20, 9.0)}


def fail(msg):
    print(f"diagnosis_acceptance: {msg}", file=sys.stderr)
    sys.exit(1)


def read_records(paths):
    """Data sets of the records, each once (the first listed wins)."""
    seen = {}
    for path in paths:
        try:
            with open(path, encoding="utf-8") as f:
                records = json.load(f)
        except OSError as e:
            fail(f"{path}: cannot read ({e.strerror})")
        except json.JSONDecodeError as e:
            fail(f"{path}: not JSON (line {e.lineno}: {e.msg})")
        if not isinstance(records, list):
            fail(f"{path}: expected a list of data sets (diagnosis_suite --json)")
        for k, e in enumerate(records):
            for key in ("seed", "kind", "planted", "effect_ratio", "right", "diagnosis"):
                if key not in e:
                    fail(f"{path}: data set {k} has no key '{key}'")
            ident = (e["seed"], e["kind"], tuple(e["planted"]), round(e["effect_ratio"], 2))
            seen.setdefault(ident, e)
    return list(seen.values())


def stage_of(candidate):
    if candidate.get("shape_contradiction") or candidate.get("person_at_bound"):
        return "rule"
    decision = candidate.get("decision") or ""
    for prefix, stage in DECISION_PREFIXES:
        if decision.startswith(prefix):
            return stage
    return "rule" if candidate.get("fitted") or candidate.get("judged") else "screen"


def furthest_stage(data_set):
    mechanism = data_set["planted"][0]
    stages = [stage_of(c) for c in data_set["diagnosis"].get("candidates", [])
              if c.get("id") == mechanism]
    return max(stages, key=STAGES.index) if stages else "not a candidate"


def number(candidate, key, missing):
    value = candidate.get(key)
    return missing if value is None else value


def accepted(candidate, thresholds):
    lr, z, gain, own_z, own = thresholds
    g = number(candidate, "heldout_gain", 0.0)
    o = number(candidate, "heldout_own_gain", 0.0)
    return (number(candidate, "lr_p_adjusted", 1.0) < lr and g > 0.0 and
            (number(candidate, "heldout_z", 0.0) > z or g > gain) and
            (number(candidate, "heldout_own_z", 0.0) > own_z or o > own))


def judged_fits(data_set):
    """The candidates (not controls) whose fit reached the acceptance statistics."""
    return [c for c in data_set["diagnosis"].get("candidates", [])
            if not c.get("control") and stage_of(c) in ("statistics", "passed")]


def redecide(singles, cleans, thresholds):
    """(planted named right, clean persons named) with every statistics-stage fit re-decided."""
    right = 0
    for d in singles:
        ok = [c for c in judged_fits(d) if accepted(c, thresholds)]
        if ok and max(ok, key=lambda c: number(c, "heldout_gain", 0.0))["id"] == d["planted"][0]:
            right += 1
    named = sum(any(accepted(c, thresholds) for c in judged_fits(d)) for d in cleans)
    return right, named


# The rules of section 3, each (held-out gain, z, T_m) -> accepted, on top of the shipped
# training-LR and own-part tests: "or" can only add names to the shipped rule (a gain above the
# mechanism's cohort threshold counts as a clear gain when that is below the shipped 10 %),
# "instead" replaces the Diebold–Mariano test and the 10 % by the threshold, "and" can only remove.
COHORT_RULES = {
    "shipped or gain > T_m": lambda g, z, t: z > SHIPPED[1] or g > min(SHIPPED[2], t),
    "gain > T_m instead": lambda g, z, t: g > t,
    "shipped and gain > T_m": lambda g, z, t: (z > SHIPPED[1] or g > SHIPPED[2]) and g > t,
}
COHORT_QUANTILES = (0.9, 0.95, 1.0)


def draw_of(data_set):
    return data_set["seed"] // 1000


def passes_other_tests(candidate):
    """The shipped tests but the held-out gain's: training LR and the own part."""
    lr, _, _, own_z, own = SHIPPED
    o = number(candidate, "heldout_own_gain", 0.0)
    return (number(candidate, "lr_p_adjusted", 1.0) < lr and
            (number(candidate, "heldout_own_z", 0.0) > own_z or o > own))


def quantile(values, q):
    """The q-quantile of values by the nearest rank (q = 1: the largest)."""
    ordered = sorted(values)
    rank = min(max(1, math.ceil(q * len(ordered) - 1e-9)), len(ordered))
    return ordered[rank - 1]


def null_gains(cleans):
    """Per mechanism fitted on some clean person: per clean person, the largest held-out gain of
    that mechanism's fits that pass the other tests (0 where none does)."""
    return {m: [max([number(c, "heldout_gain", 0.0) for c in judged_fits(d)
                     if c["id"] == m and passes_other_tests(c)] + [0.0]) for d in cleans]
            for m in {c["id"] for d in cleans for c in judged_fits(d)}}


def cohort_thresholds(cohort, q):
    """T_m per mechanism: the q-quantile over the cohort persons of m's largest null gain."""
    return {m: quantile(null, q) for m, null in null_gains(cohort).items()}


def cohort_decide(data_set, thresholds, rule):
    ok = []
    for c in judged_fits(data_set):
        g = number(c, "heldout_gain", 0.0)
        t = thresholds.get(c["id"], 0.0)
        if passes_other_tests(c) and g > 0.0 and rule(g, number(c, "heldout_z", 0.0), t):
            ok.append(c)
    return ok


def cohort_table(singles, cleans):
    draws = sorted({draw_of(d) for d in singles + cleans})
    lines = ["| rule | T_m quantile | planted named right | clean persons named | "
             "draws without a cohort |", "|---|---|---|---|---|"]
    shipped = redecide(singles, cleans, SHIPPED)
    lines.append(f"| shipped thresholds | — | {shipped[0]} | {shipped[1]} | — |")
    for name, rule in COHORT_RULES.items():
        for q in COHORT_QUANTILES:
            right = named = alone = 0
            for k in draws:
                cohort = [d for d in cleans if draw_of(d) != k]
                if not cohort:
                    alone += 1
                    continue
                thresholds = cohort_thresholds(cohort, q)
                for d in singles:
                    if draw_of(d) == k:
                        ok = cohort_decide(d, thresholds, rule)
                        best = max(ok, key=lambda c: number(c, "heldout_gain", 0.0), default=None)
                        right += best is not None and best["id"] == d["planted"][0]
                for d in cleans:
                    if draw_of(d) == k:
                        named += bool(cohort_decide(d, thresholds, rule))
            lines.append(f"| {name} | {q:g} | {right} | {named} | {alone} |")
    return lines


def threshold_table(cleans):
    """Per mechanism over all clean persons: how many have a null gain above 0, T_m at 0.95, 1."""
    nulls = null_gains(cleans)
    lines = [f"| mechanism | clean persons with a null gain > 0 (of {len(cleans)}) | T_m at 0.95 | "
             "T_m at 1 (the largest) |", "|---|---|---|---|"]
    for m in sorted(nulls):
        lines.append(f"| {m} | {sum(v > 0.0 for v in nulls[m])} | "
                     f"{quantile(nulls[m], 0.95):.4f} | {quantile(nulls[m], 1.0):.4f} |")
    return lines


def stage_table(singles):
    per = collections.defaultdict(collections.Counter)
    for d in singles:
        per[d["planted"][0]]["right" if d["right"] else furthest_stage(d)] += 1
    columns = ["right"] + [s for s in STAGES if s != "passed"] + ["passed"]
    lines = ["| mechanism | data sets | " + " | ".join(columns) + " |",
             "|---" * (len(columns) + 2) + "|"]
    total = collections.Counter()
    for m in sorted(per):
        total.update(per[m])
        lines.append(f"| {m} | {sum(per[m].values())} | " +
                     " | ".join(str(per[m][c]) for c in columns) + " |")
    lines.append(f"| all | {sum(total.values())} | " +
                 " | ".join(str(total[c]) for c in columns) + " |")
    return lines


def frontier_table(singles, cleans):
    best = {}
    for thresholds in itertools.product(*GRID.values()):
        right, named = redecide(singles, cleans, thresholds)
        if named not in best or right > best[named][0]:
            best[named] = (right, thresholds)
    shipped = redecide(singles, cleans, SHIPPED)
    lines = ["| clean persons named | planted named right | LR p_adj < | held-out z > | "
             "or gain > | own z > | or own > |", "|---|---|---|---|---|---|---|",
             f"| {shipped[1]} (shipped thresholds) | {shipped[0]} | " +
             " | ".join(f"{v:g}" for v in SHIPPED) + " |"]
    record = -1
    for named in sorted(best):
        right, t = best[named]
        if right <= record:
            continue  # not on the frontier: more clean persons named for no more right
        record = right
        lines.append(f"| {named} | {right} | " + " | ".join(f"{v:g}" for v in t) + " |")
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("records", nargs="+")
    args = parser.parse_args()
    data = read_records(args.records)
    singles = [d for d in data if d["kind"] == "single"]
    cleans = [d for d in data if d["kind"] == "clean"]
    if not singles or not cleans:
        fail("the records need single planted effects and clean persons "
             f"(found {len(singles)} and {len(cleans)})")
    text = "\n".join(
        ["# Diagnosis acceptance: where planted effects stop", "",
         "Generated by `python3 bench/diagnosis_acceptance.py --out " +
         args.out + " " + " ".join(args.records) + "` "
         f"({len(singles)} single planted effects, {len(cleans)} clean persons).", "",
         "## The furthest stage each planted mechanism's candidate reached", ""] +
        stage_table(singles) +
        ["", "## Thresholds re-decided (an upper bound: no forward selection, no new fits)", ""] +
        frontier_table(singles, cleans) +
        ["", "## Per-mechanism thresholds from a reference cohort (leave one draw out)", ""] +
        cohort_table(singles, cleans) + [""] + threshold_table(cleans) + [""])
    directory = os.path.dirname(os.path.abspath(args.out))
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".diagnosis_acceptance.")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, args.out)
    except BaseException:
        os.unlink(tmp)
        raise


if __name__ == "__main__":
    main()
