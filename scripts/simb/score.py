#!/usr/bin/env python3
"""Scores `tipforge diagnose` runs on simulator family B's cases (docs/sim-family-b.md).

    score.py CASES_DIR RUN_DIR

CASES_DIR/<case>/ holds what generate.py wrote (case.json, trialN.csv, truth/trialN.csv);
RUN_DIR/<case>/ what `diagnose --out RUN_DIR/<case>` wrote (diagnosis.json, predictions/<stem>.csv);
RUN_DIR/<case>.status, written by scripts/bench-family-b, is "exit_code wall_seconds".
Prints markdown tables and writes RUN_DIR/summary.json.

Counting rules:
* recall: the case's effect is among findings[].effect. A case whose diagnose failed (non-zero
  exit or no diagnosis.json) counts as not found, and is listed as a failure.
* precision: over every effect named in the effect cases (the FSR402-like cases included, their
  effect is creep): a name equal to the case's effect is true, any other name (preload_mismatch
  too) is a false finding; each distinct name counts once per case.
* null cases: a null case with any finding is a false finding (count and list).
* model ratio: RMS(improved - clean_v) / RMS(baseline - clean_v), pooled over the case's trials,
  over the samples farther than 1 s from every logged load change; median over cases per effect.
"""

import json
import os
import sys

import numpy as np

EFFECTS = ["creep", "hysteresis", "second_time_constant", "baseline_drift", "saturation",
           "handling_spikes"]


def read_csv(path):
    """Header names and float rows of a CSV with '#' comment lines."""
    names, rows = None, []
    with open(path, encoding="utf-8-sig") as f:
        for line in f:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            if names is None:
                names = [c.strip().strip('"').lower() for c in line.split(",")]
                continue
            rows.append(line)
    if not rows:
        return names, np.zeros((0, len(names)))
    cells = ",".join(rows).replace('"', "").split(",")
    return names, np.array(cells, dtype=float).reshape(len(rows), len(names))


def col(names, data, name):
    return data[:, names.index(name)]


def model_ratio(case_dir, run_dir):
    """(ratio, rms_improved, rms_baseline, n_samples) or None when predictions are missing."""
    se_imp = se_base = 0.0
    n = 0
    stems = sorted(f[:-4] for f in os.listdir(case_dir) if f.startswith("trial") and f.endswith(".csv"))
    for stem in stems:
        pp = os.path.join(run_dir, "predictions", stem + ".csv")
        if not os.path.exists(pp):
            return None
        rn, rd = read_csv(os.path.join(case_dir, stem + ".csv"))
        tn, td = read_csv(os.path.join(case_dir, "truth", stem + ".csv"))
        pn, pd = read_csv(pp)
        t_rec, load = col(rn, rd, "time_s"), col(rn, rd, "load_g")
        changes = t_rec[1:][np.diff(load) != 0]
        tp = col(pn, pd, "time_s")
        clean = np.interp(tp, col(tn, td, "time_s"), col(tn, td, "clean_v"))
        keep = np.ones(tp.size, dtype=bool)
        for tc in changes:
            keep &= np.abs(tp - tc) > 1.0
        di = col(pn, pd, "improved")[keep] - clean[keep]
        db = col(pn, pd, "baseline")[keep] - clean[keep]
        se_imp += float(np.dot(di, di))
        se_base += float(np.dot(db, db))
        n += int(keep.sum())
    if n == 0 or se_base == 0.0:
        return None
    ri, rb = np.sqrt(se_imp / n), np.sqrt(se_base / n)
    return ri / rb, ri, rb, n


def score(cases_dir, run_dir):
    rows = []
    for name in sorted(os.listdir(cases_dir)):
        cj = os.path.join(cases_dir, name, "case.json")
        if not os.path.exists(cj):
            continue
        with open(cj) as f:
            case = json.load(f)
        rd = os.path.join(run_dir, name)
        status = os.path.join(run_dir, name + ".status")
        rc, wall = None, None
        if os.path.exists(status):
            with open(status) as f:
                parts = f.read().split()
            rc, wall = int(parts[0]), float(parts[1])
        dj = os.path.join(rd, "diagnosis.json")
        failed = (rc is not None and rc != 0) or not os.path.exists(dj)
        named = []
        if not failed:
            with open(dj) as f:
                diag = json.load(f)
            for fnd in diag.get("findings", []):
                e = fnd.get("effect")
                if e not in named:
                    named.append(e)
        ratio = None if failed else model_ratio(os.path.join(cases_dir, name), rd)
        rows.append(dict(case=name, effect=case["effect"], kind=case["kind"],
                         target_sigma=case["target_sigma"],
                         achieved_rms_sigma=case["achieved_rms_sigma"],
                         target_reached=case["target_reached"], protocol=case["protocol"],
                         loading=case["loading"], exit_code=rc, wall_s=wall, failed=failed,
                         named=named, ratio=None if ratio is None else ratio[0],
                         rms_improved_v=None if ratio is None else ratio[1],
                         rms_baseline_v=None if ratio is None else ratio[2]))
    return rows


def summarize(rows):
    eff_rows = [r for r in rows if r["effect"] != "null"]
    null_rows = [r for r in rows if r["effect"] == "null"]
    recall = {}
    for e in EFFECTS:
        rr = [r for r in eff_rows if r["effect"] == e and r["kind"] == "lab"]
        by = {}
        for m in sorted({r["target_sigma"] for r in rr}):
            sub = [r for r in rr if r["target_sigma"] == m]
            by[str(m)] = [sum(e in r["named"] for r in sub), len(sub)]
        by["all"] = [sum(e in r["named"] for r in rr), len(rr)]
        recall[e] = by
    fsr = [r for r in eff_rows if r["kind"] == "fsr402"]
    recall_fsr = [sum("creep" in r["named"] for r in fsr), len(fsr)]
    tp = sum(1 for r in eff_rows for n in r["named"] if n == r["effect"])
    fp = sum(1 for r in eff_rows for n in r["named"] if n != r["effect"])
    false_in_effect = sorted({n for r in eff_rows for n in r["named"] if n != r["effect"]})
    null_false = [dict(case=r["case"], named=r["named"]) for r in null_rows if r["named"]]
    ratios = {}
    for e in EFFECTS + ["fsr402", "null"]:
        if e == "fsr402":
            vals = [r["ratio"] for r in fsr if r["ratio"] is not None]
        elif e == "null":
            vals = [r["ratio"] for r in null_rows if r["ratio"] is not None]
        else:
            vals = [r["ratio"] for r in eff_rows
                    if r["effect"] == e and r["kind"] == "lab" and r["ratio"] is not None]
        ratios[e] = dict(median=float(np.median(vals)) if vals else None, n=len(vals))
    sat = recall["saturation"]["all"] if "saturation" in recall else [0, 0]
    walls = [r["wall_s"] for r in rows if r["wall_s"] is not None]
    return dict(
        cases=len(rows), effect_cases=len(eff_rows), null_cases=len(null_rows),
        failures=[r["case"] for r in rows if r["failed"]],
        recall=recall, recall_fsr402_creep=recall_fsr,
        precision=dict(true=tp, false=fp, value=(tp / (tp + fp)) if tp + fp else None,
                       false_names=false_in_effect),
        null_false_findings=dict(count=len(null_false), of=len(null_rows), cases=null_false),
        saturation_found=sat, model_ratio_median=ratios,
        wall_s=dict(total_of_cases=float(sum(walls)) if walls else None,
                    median=float(np.median(walls)) if walls else None,
                    max=float(max(walls)) if walls else None))


def fmt(x, spec="%.3f"):
    return "-" if x is None else spec % x


def table(rows, s):
    out = []
    out.append("## Family B: per case\n")
    out.append("| case | effect | target σ | achieved σ | protocol | loading | named by diagnose | "
               "improved/baseline RMS to clean | exit | wall s |")
    out.append("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        tgt = "fall" if r["kind"] == "fsr402" else str(r["target_sigma"])
        named = ", ".join(r["named"]) if r["named"] else ("FAILED" if r["failed"] else "(none)")
        out.append("| %s | %s | %s | %s%s | %s | %s | %s | %s | %s | %s |" % (
            r["case"], r["effect"] + (" (FSR402)" if r["kind"] == "fsr402" else ""), tgt,
            fmt(r["achieved_rms_sigma"], "%.2f"), "" if r["target_reached"] or r["effect"] == "null"
            else "*", r["protocol"], r["loading"], named, fmt(r["ratio"]),
            "-" if r["exit_code"] is None else r["exit_code"], fmt(r["wall_s"], "%.1f")))
    out.append("\n\\* target not reachable inside the description's ranges: the achieved RMS is "
               "what the case has (see case.json).\n")
    out.append("## Family B: summary\n")
    mags = sorted({m for e in s["recall"] for m in s["recall"][e] if m != "all"}, key=float)
    out.append("| effect | " + " | ".join("recall %sσ" % m for m in mags) +
               " | recall all | median improved/baseline |")
    out.append("|---|" + "---|" * len(mags) + "---|---|")
    for e, by in s["recall"].items():
        cells = ["%d/%d" % tuple(by[m]) if m in by else "-" for m in mags]
        rat = s["model_ratio_median"][e]
        out.append("| %s | %s | %d/%d | %s (n=%d) |" % (e, " | ".join(cells), by["all"][0], by["all"][1],
                                                         fmt(rat["median"]), rat["n"]))
    if s["recall_fsr402_creep"][1]:
        rat = s["model_ratio_median"]["fsr402"]
        out.append("| creep (FSR402-like) | " + " | ".join("-" for _ in mags) + " | %d/%d | %s (n=%d) |" % (
            s["recall_fsr402_creep"][0], s["recall_fsr402_creep"][1], fmt(rat["median"]), rat["n"]))
    rat = s["model_ratio_median"]["null"]
    out.append("| null | " + " | ".join("-" for _ in mags) + " | - | %s (n=%d) |" % (
        fmt(rat["median"]), rat["n"]))
    p = s["precision"]
    out.append("")
    out.append("- precision over the effects named in effect cases: %s (%d true, %d false%s)" % (
        fmt(p["value"]), p["true"], p["false"],
        ("; false names: " + ", ".join(p["false_names"])) if p["false_names"] else ""))
    nf = s["null_false_findings"]
    out.append("- null cases with a finding: %d of %d%s" % (
        nf["count"], nf["of"], ("; " + "; ".join("%s: %s" % (c["case"], ", ".join(c["named"]))
                                                  for c in nf["cases"])) if nf["cases"] else ""))
    out.append("- saturation found (rail before the noise): %d/%d" % tuple(s["saturation_found"]))
    out.append("- diagnose failures (non-zero exit or no diagnosis.json): %d%s" % (
        len(s["failures"]), (" (" + ", ".join(s["failures"]) + ")") if s["failures"] else ""))
    w = s["wall_s"]
    out.append("- diagnose wall time per case: median %s s, max %s s, sum %s s" % (
        fmt(w["median"], "%.1f"), fmt(w["max"], "%.1f"), fmt(w["total_of_cases"], "%.0f")))
    out.append("- model ratio: improved model's RMS error to the noise-free signal / the baseline's, "
               "outside ±1 s of each logged load change, pooled over a case's trials; median over cases")
    return "\n".join(out) + "\n"


def main(argv):
    if len(argv) != 3:
        print("usage: score.py CASES_DIR RUN_DIR", file=sys.stderr)
        return 2
    rows = score(argv[1], argv[2])
    s = summarize(rows)
    sys.stdout.write(table(rows, s))
    os.makedirs(argv[2], exist_ok=True)
    with open(os.path.join(argv[2], "summary.json"), "w") as f:
        json.dump(dict(summary=s, cases=rows), f, indent=1, sort_keys=True)
        f.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
