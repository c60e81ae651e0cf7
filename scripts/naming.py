#!/usr/bin/env python3
"""Strict and honest naming (issue 16) over a folder of diagnosed cases.

Reads what scripts/bench-family-b leaves (target/simb/cases/<case>/case.json for the truth,
target/simb/run/<case>/diagnosis.json for the diagnosis); it is the project's own scorer, next to
the frozen scripts/simb/score.py, which it does not change.

  strict recall    the case's effect is a finding's `effect`
  honest recall    the case's effect is a finding's `effect` or among its `alternatives`
  strict precision over the findings of effect cases: the finding's `effect` is the case's
  honest precision ... or the case's effect is among the finding's alternatives
  null alternatives  null cases whose findings carry any alternative (bar: 0)

Magnitude filter: --min-sigma (default 1) keeps lab cases whose target is at least that many σ;
FSR402-like cases count as creep. Usage: scripts/naming.py [CASES RUN] [--min-sigma S]
"""
import json
import os
import sys


def main(argv):
    args = [a for a in argv if not a.startswith("--")]
    min_sigma = 1.0
    if "--min-sigma" in argv:
        min_sigma = float(argv[argv.index("--min-sigma") + 1])
        args = [a for a in args if a != argv[argv.index("--min-sigma") + 1]]
    cases = args[0] if args else "target/simb/cases"
    run = args[1] if len(args) > 1 else "target/simb/run"
    per = {}
    tot = dict(sr=0, hr=0, n=0, sp=0, hp=0, nf=0, null_alt=0, null_n=0, null_find=0, amb=0)
    for name in sorted(os.listdir(cases)):
        cj = os.path.join(cases, name, "case.json")
        if not os.path.exists(cj):
            continue
        case = json.load(open(cj))
        dj = os.path.join(run, name, "diagnosis.json")
        findings = json.load(open(dj)).get("findings", []) if os.path.exists(dj) else []
        truth = case["effect"]
        if truth == "null":
            tot["null_n"] += 1
            tot["null_find"] += bool(findings)
            tot["null_alt"] += any(f.get("alternatives") for f in findings)
            continue
        if case.get("kind") == "lab" and case.get("target_sigma", 0) < min_sigma:
            continue
        named = [f["effect"] for f in findings]
        alts = [a["effect"] for f in findings for a in f.get("alternatives", [])]
        strict = truth in named
        honest = strict or truth in alts
        label = truth + (" (FSR402-like)" if case.get("kind") == "fsr402" else "")
        p = per.setdefault(label, [0, 0, 0])
        p[0] += strict
        p[1] += honest
        p[2] += 1
        tot["sr"] += strict
        tot["hr"] += honest
        tot["n"] += 1
        for f in findings:
            tot["nf"] += 1
            tot["sp"] += f["effect"] == truth
            tot["hp"] += f["effect"] == truth or truth in [a["effect"] for a in f.get("alternatives", [])]
            tot["amb"] += bool(f.get("alternatives"))
    print("| effect (≥ %gσ) | strict | honest |" % min_sigma)
    print("|---|---|---|")
    for k, (s, h, n) in per.items():
        print("| %s | %d/%d | %d/%d |" % (k, s, n, h, n))
    r = lambda a, b: "%.2f" % (a / b) if b else "-"
    print("| all | %d/%d (%s) | %d/%d (%s) |" % (tot["sr"], tot["n"], r(tot["sr"], tot["n"]), tot["hr"], tot["n"], r(tot["hr"], tot["n"])))
    print()
    print("- precision over the %d findings of effect cases: strict %s, honest %s; findings with alternatives: %d"
          % (tot["nf"], r(tot["sp"], tot["nf"]), r(tot["hp"], tot["nf"]), tot["amb"]))
    print("- null cases with a finding: %d of %d; with an alternative: %d" % (tot["null_find"], tot["null_n"], tot["null_alt"]))


if __name__ == "__main__":
    main(sys.argv[1:])
