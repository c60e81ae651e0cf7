#!/usr/bin/env python3
"""Fast self-test of simulator family B's generator (scripts/simb/generate.py).

Run by scripts/test as `python scripts/test_simb.py out.test` (the argument is accepted and
ignored; -v prints every check). Generates a few cases into a temporary folder and checks: the files parse (metadata,
header, strictly increasing time, sample rate, voltages on the ADC's steps), determinism (same seed
-> same bytes; another seed -> other bytes), effect RMS within 10 % of its target, null cases
without an effect, the noise sigma, saturation's rail before the noise (the plateau scatters on
both sides of the rail), actuator ramps ending near the logged change, and the FSR402-like case's
resistance falling 5-15 % over the hold. Exits 1 on any failure.
"""

import hashlib
import json
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "simb"))
import generate as gen  # noqa: E402

SEED = 90210  # test-only seed base (the benchmark's is in scripts/bench-family-b)
FAIL = []
PASSED = [0]
VERBOSE = "-v" in sys.argv


def check(cond, what):
    if VERBOSE or not cond:
        print(("ok   " if cond else "FAIL ") + what)
    if cond:
        PASSED[0] += 1
    else:
        FAIL.append(what)


def parse_recording(path):
    meta, header, rows = {}, None, []
    with open(path) as f:
        for line in f:
            line = line.rstrip("\n")
            if line.startswith("#"):
                body = line[1:].strip()
                if "=" in body:
                    k, v = body.split("=", 1)
                    meta[k.strip()] = v.strip()
                continue
            if header is None:
                header = line.split(",")
                continue
            rows.append(line)
    data = np.array(",".join(rows).split(","), dtype=float).reshape(len(rows), len(header))
    return meta, header, data


def parse_truth(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
        lines = f.read().split()
    cols = list(zip(*(ln.split(",") for ln in lines)))
    return header, cols  # strings, so equality is exact


def digest(folder):
    h = hashlib.sha256()
    for root, _, files in sorted(os.walk(folder)):
        for fn in sorted(files):
            p = os.path.join(root, fn)
            h.update(os.path.relpath(p, folder).encode())
            with open(p, "rb") as f:
                h.update(f.read())
    return h.hexdigest()


def main():
    t0 = time.time()
    specs = {s["name"]: s for s in gen.case_list()}

    def pick(**kw):
        for s in specs.values():
            if all(s.get(k) == v for k, v in kw.items()):
                return s
        raise KeyError(kw)

    chosen = [pick(effect="creep", target_sigma=2, loading="hand"),
              pick(effect="second_time_constant", target_sigma=4, loading="actuator"),
              pick(effect="saturation", target_sigma=2, loading="hand"),
              pick(effect="null", loading="hand", protocol="200g"),
              pick(effect="null", loading="actuator"),
              pick(kind="fsr402")]
    with tempfile.TemporaryDirectory() as tmp:
        a, b, c = (os.path.join(tmp, x) for x in "abc")
        recs = {s["name"]: gen.generate_case(s, SEED, a) for s in chosen}

        # -- determinism --
        s0 = chosen[0]
        gen.generate_case(s0, SEED, b)
        gen.generate_case(s0, SEED + 1, c)
        da, db, dc = (digest(os.path.join(x, s0["name"])) for x in (a, b, c))
        check(da == db, "determinism: same seed, byte-identical case folder (%s)" % s0["name"])
        check(da != dc, "seed matters: another seed base gives other bytes (%s)" % s0["name"])

        for s in chosen:
            name = s["name"]
            d = os.path.join(a, name)
            with open(os.path.join(d, "case.json")) as f:
                case = json.load(f)
            p = case["params"]
            sig = p["sigma_v"]
            stems = sorted(x[:-4] for x in os.listdir(d) if x.endswith(".csv"))
            want = ["trial1"] if s["kind"] == "fsr402" else ["trial1", "trial2", "trial3"]
            check(stems == want, "%s: files %s" % (name, stems))
            tot_d2, tot_n, noise_res, n_all = 0.0, 0, [], 0
            for i, stem in enumerate(stems):
                meta, header, data = parse_recording(os.path.join(d, stem + ".csv"))
                th, tcols = parse_truth(os.path.join(d, "truth", stem + ".csv"))
                t, v, load = data[:, 0], data[:, 1], data[:, 2]
                ok_meta = (meta.get("divider") == "sensor_high"
                           and float(meta["sample_rate_hz"]) == p["fs"]
                           and float(meta["vcc_v"]) == p["vcc"] and float(meta["r_m_ohm"]) == p["rm"]
                           and int(meta["adc_bits"]) == p["bits"] and float(meta["vref_v"]) == p["vref"]
                           and (meta.get("loading") == "actuator") == (s["loading"] == "actuator"))
                check(ok_meta, "%s/%s: metadata %s" % (name, stem, meta))
                check(header == ["time_s", "voltage_v", "load_g"], "%s/%s: header" % (name, stem))
                dt = np.diff(t)
                check(bool(np.all(dt > 0)) and abs(np.median(dt) * p["fs"] - 1) < 1e-6,
                      "%s/%s: time strictly increasing at the sample rate" % (name, stem))
                full = 2 ** p["bits"] - 1
                cnt = v / p["vref"] * full
                check(bool(np.all(np.abs(cnt - np.rint(cnt)) < 1e-3)) and cnt.min() >= 0
                      and cnt.max() <= full, "%s/%s: voltages on the ADC's steps" % (name, stem))
                nchg = int(np.sum(np.diff(load) != 0))
                check(nchg == (2 if s["kind"] == "fsr402" else 10),
                      "%s/%s: %d logged load changes" % (name, stem, nchg))
                check(th == ["time_s", "clean_v", "clean_v_without"] and len(tcols[0]) == t.size,
                      "%s/%s: truth header and length" % (name, stem))
                clean = np.array(tcols[1], dtype=float)
                without = np.array(tcols[2], dtype=float)
                dd = clean - without
                tot_d2 += float(dd @ dd)
                tot_n += dd.size
                if s["effect"] == "null":
                    check(tcols[1] == tcols[2], "%s/%s: null case, clean_v == clean_v_without"
                          % (name, stem))
                else:
                    check(np.any(dd != 0), "%s/%s: the effect changes the signal" % (name, stem))
                inside = (cnt > 0.5) & (cnt < full - 0.5)
                noise_res.append((v - clean)[inside])
                n_all += t.size
                if s["effect"] == "saturation":
                    rail = case["solve"]["rail_v"]
                    plateau = np.abs(clean - rail) < 1e-6
                    check(clean.max() <= rail + 1e-6, "%s/%s: clean signal never above the rail"
                          % (name, stem))
                    above = np.mean(v[plateau] > rail)
                    below = np.mean(v[plateau] < rail)
                    check(plateau.sum() > 100 and above > 0.2 and below > 0.2,
                          "%s/%s: plateau samples scatter both sides of the rail "
                          "(%d samples, %.0f %% above, %.0f %% below)"
                          % (name, stem, plateau.sum(), 100 * above, 100 * below))
                if s["loading"] == "actuator":
                    tr = case["trials"][i]
                    tchg = t[1:][np.diff(load) != 0]
                    ends_ok = all(abs(ch["end_offset_s"]) <= 0.5 and 6 <= ch["dur_s"] <= 9
                                  for ch in tr["changes"])
                    check(ends_ok, "%s/%s: ramps of 6-9 s end within 0.5 s of the log (case.json)"
                          % (name, stem))
                    # from the signal: the noise-free response crosses half-way between the level
                    # before (10 s before the log) and after (10 s after) no later than 1 s after
                    # the logged change and not before the earliest possible ramp middle
                    cross_ok = []
                    for tc in tchg:
                        k = int(round(tc * p["fs"]))
                        pre = without[k - int(10 * p["fs"])]
                        post = without[k + int(10 * p["fs"])]
                        seg = without[k - int(10 * p["fs"]):k + int(10 * p["fs"])]
                        frac = (seg - pre) / (post - pre)
                        j = int(np.argmax(frac >= 0.5))
                        tx = (k - int(10 * p["fs"]) + j) / p["fs"]
                        cross_ok.append(tc - 5.5 <= tx <= tc + 1.0)
                    check(all(cross_ok), "%s/%s: the noise-free signal moves half-way within "
                          "[-5.5, +1] s of each logged change (%d of %d)"
                          % (name, stem, sum(cross_ok), len(cross_ok)))
                if s["kind"] == "fsr402":
                    kc = [int(round(x * p["fs"])) for x in t[1:][np.diff(load) != 0]]
                    end = slice(kc[1] - 1 - int(p["fs"]), kc[1])
                    r = lambda x: p["rm"] * (p["vcc"] / x - 1.0)
                    fall = 1.0 - r(clean[end].mean()) / r(without[end].mean())
                    check(0.05 <= fall <= 0.15, "%s: resistance falls %.1f %% over the hold "
                          "(creep vs none at its end; 5-15 %%)" % (name, 100 * fall))
                    early = r(clean[kc[0] + int(10 * p["fs"])])
                    check(r(clean[end].mean()) < early, "%s: resistance lower at the end of the "
                          "hold than 10 s after placement" % name)
            rms_sigma = np.sqrt(tot_d2 / tot_n) / sig
            if s["effect"] != "null" and s["kind"] == "lab":
                check(abs(rms_sigma - s["target_sigma"]) <= 0.1 * s["target_sigma"],
                      "%s (%s): effect RMS %.3f sigma, target %s sigma"
                      % (name, s["effect"], rms_sigma, s["target_sigma"]))
            if s["effect"] != "null":
                check(abs(rms_sigma - case["achieved_rms_sigma"]) <= 0.01 * case["achieved_rms_sigma"],
                      "%s: case.json's achieved RMS (%.3f) matches the truth files (%.3f)"
                      % (name, case["achieved_rms_sigma"], rms_sigma))
            res = np.concatenate(noise_res)
            if s["effect"] == "null":
                check(abs(res.std() / sig - 1) < 0.15, "%s: noise sigma %.4f V, drawn %.4f V"
                      % (name, res.std(), sig))
    print("test_simb: %d check(s) passed, %d failed, %.1f s" % (PASSED[0], len(FAIL), time.time() - t0))
    return 1 if FAIL else 0


if __name__ == "__main__":
    sys.exit(main())
