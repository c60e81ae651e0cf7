#!/usr/bin/env python3
"""scipy.optimize.curve_fit on the same step windows and the same pooled model as tipforge's lsq
fit; prints the side-by-side table with tipforge's lsq and the paper's grid search.

    bench_fit_scipy.py target/bench-fit/steps.json target/bench-fit/rust.json
"""
import json
import math
import sys
import time

import numpy as np
import scipy
from scipy.optimize import curve_fit


def pooled(step):
    trials = step["trials"]
    w = len(trials)
    rows_t, rows_i, rows_post, y = [], [], [], []
    for i, tr in enumerate(trials):
        t = np.asarray(tr["t"]); v = np.asarray(tr["v"])
        idx = list(range(tr["pre_end"])) + list(range(tr["post"], len(t)))
        for j in idx:
            rows_t.append(t[j] - tr["t_on"]); rows_i.append(i); rows_post.append(j >= tr["post"]); y.append(v[j])
    x = (np.asarray(rows_t), np.asarray(rows_i), np.asarray(rows_post))
    def model(xx, *p):
        s, i, post = xx[0], xx[1].astype(int), xx[2]
        v0 = np.asarray(p[:w])[i]; b = np.asarray(p[w:2 * w])[i]; k = p[2 * w]; tau = p[2 * w + 1]
        return v0 + post * (k + b * np.exp(-np.maximum(s, 0) / tau))
    # a fair start: pre-step levels, the step from them to the end level, τ from the 63 % time
    p0 = []
    for tr in trials:
        p0.append(float(np.mean(tr["v"][: tr["pre_end"]])))
    ends = [float(np.mean(tr["v"][-10:])) for tr in trials]
    k0 = float(np.mean([e - a for e, a in zip(ends, p0)]))
    tr0 = trials[0]
    t = np.asarray(tr0["t"]); v = np.asarray(tr0["v"])
    target = p0[0] + 0.632 * (ends[0] - p0[0])
    post = np.arange(tr0["post"], len(t))
    hit = post[np.argmax((v[post] - target) * np.sign(k0) >= 0)]
    tau0 = max(t[hit] - tr0["t_on"], 0.05)
    p0 += [-k0] * w + [k0, tau0]
    return model, x, np.asarray(y), p0, w


def eq4(step, curve):
    starts = [next(q for q, tt in enumerate(tr["t"]) if tt >= tr["t_log"]) for tr in step["trials"]]
    j = min(len(tr["t"]) - s for tr, s in zip(step["trials"], starts))
    s = 0.0
    for i, tr in enumerate(step["trials"]):
        for q in range(j):
            idx = starts[i] + q
            s += (tr["v"][idx] - curve(i, tr["t"][idx])) ** 2
    return math.sqrt(s / (j * len(step["trials"])))


def main(steps_path, rust_path):
    steps = json.load(open(steps_path))
    rust = json.load(open(rust_path))
    rows = []
    total = 0.0
    for step, rr in zip(steps, rust["rows"]):
        model, x, y, p0, w = pooled(step)
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            p, cov = curve_fit(model, x, y, p0=p0, maxfev=20000)
            times.append(time.perf_counter() - t0)
        ts = sorted(times)[len(times) // 2]
        total += ts
        k, tau = p[2 * w], p[2 * w + 1]
        t0s = []
        for i, tr in enumerate(step["trials"]):
            ratio = -p[w + i] / k
            t0s.append(tr["t_on"] + tau * math.log(ratio) if ratio > 0 else tr["t_on"])
        def curve(i, t):
            t0 = min(t0s[i], step["trials"][i]["t_on"])
            return p[i] if t < t0 else p[i] + k * (1 - math.exp(-(t - t0) / tau))
        rows.append((step, rr, ts, eq4(step, curve), k, tau))
    grids = [g["grid"] for g in rust["paper_total_s"]]
    print(f"# Fit benchmark: {rust['trials']} simulated trials, 0–1000 g, {rust['steps']} steps, {rust['samples']} samples (10 Hz after the mean filter)")
    print(f"scipy {scipy.__version__}, numpy {np.__version__}\n")
    head = "| step | lsq ms | lsq Eq.4 | scipy ms | scipy Eq.4 | " + " | ".join(f"paper {g}² ms | paper {g}² Eq.4" for g in grids) + " |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for step, rr, ts, e, k, tau in rows:
        cells = [f"{step['phase']} {step['index'] + 1}", f"{rr['lsq_seconds'] * 1e3:.3f}", f"{rr['lsq_eq4']:.5f}", f"{ts * 1e3:.1f}", f"{e:.5f}"]
        for pc in rr["paper"]:
            cells += [f"{pc['seconds'] * 1e3:.0f}", f"{pc['eq4']:.5f}"]
        print("| " + " | ".join(cells) + " |")
    lsq = rust["lsq_total_s"]
    print()
    print(f"| total | lsq {lsq * 1e3:.2f} ms | scipy curve_fit {total * 1e3:.1f} ms ({total / lsq:.0f}× lsq) | " + " | ".join(f"paper {g['grid']}² as described {g['seconds'] * 1e3:.0f} ms ({g['seconds'] / lsq:.0f}× lsq), with sufficient statistics {g['fast_seconds'] * 1e3:.1f} ms ({g['fast_seconds'] / lsq:.0f}×)" for g in rust["paper_total_s"]) + " |")
    worse = [r for r in rows if r[1]["lsq_eq4"] > r[3] * (1 + 1e-6)]
    print(f"\nlsq Eq.4 error ≤ scipy's on {len(rows) - len(worse)} of {len(rows)} steps; lsq ≤ paper's on {sum(1 for r in rows if all(r[1]['lsq_eq4'] <= pc['eq4'] for pc in r[1]['paper']))} of {len(rows)}")
    dev = max(max(abs(r[4] / r[1]['k'] - 1), abs(r[5] / r[1]['tau_s'] - 1)) for r in rows)
    print(f"largest relative difference between lsq and scipy parameters: {dev:.2e}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
