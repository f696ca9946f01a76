#!/usr/bin/python3
"""Judges a soak and chaos run of scripts/soak.sh and draws its plot.

Reads what soak.sh wrote into --out (samples.csv, events.csv, rates.txt,
load-*.json, reference/*.json, checks/*.json, metrics-final.txt,
chaos-plans.csv), prints the summary (also written to summary.txt), draws
soak.png (when matplotlib is installed) and exits 1 naming every check that
failed. The checks and their thresholds are described at the top of
scripts/soak.sh.
"""

import argparse
import csv
import glob
import json
import math
import os
import re
import shutil
import statistics
import sys

RSS_BAND = 0.05          # no RSS sample after warm-up more than 5 % above the first quarter's median
FD_BAND = 16             # descriptors: post-warm-up median +- 16
THREAD_BAND = 8          # threads: post-warm-up median +- 8
CREEP = 4                # median of the last quarter at most this above the first's
WARMUP_SHARE = 0.2       # warm-up: the first 20 % of the soak (after the measurement phase),
WARMUP_MIN_S = 30.0      # at least 30 s
WARMUP_MAX_S = 120.0     # and at most 2 minutes
BOARD_REL = 1e-5         # a board-computed value: within 1e-5 relative (docs/accel.md)
D_MIN = [0.0]            # the soak's end, minutes (for the plot)
RISK_KEYS = ("risk", "impact_factor", "expected_shelter", "casualty_probability")
# An answer's and a piece's risk, and what is derived from it alone (the risk
# per flight hour: risk / flight time): exact when all their samples are the
# CPU's bits, else within the board's bound.
TOTAL_RISK_KEYS = ("risk", "risk_per_flight_hour")


def parse_args():
    p = argparse.ArgumentParser()
    p.add_argument("--out", required=True)
    p.add_argument("--checks", required=True, help="directory of the checked answers")
    p.add_argument("--duration_s", type=float, required=True)
    p.add_argument("--soak_start_s", type=float, required=True)
    p.add_argument("--recovered", default="0")
    p.add_argument("--drain_rc", default="")
    p.add_argument("--hung", default="")
    p.add_argument("--command", default="")
    return p.parse_args()


def judge_rss(rss, fails, lines):
    """Judges the RSS samples after warm-up (kB, in time order): appends the
    summary's lines and, when the RSS grew, a failure. Returns the baseline.

    Growth is what a leak does: every sample is compared with the median of
    the first quarter of the samples, and one more than RSS_BAND above it
    fails. A fall (glibc giving the free top of a per-thread arena back to
    the system) is reported, not judged."""
    med = statistics.median(rss)
    dev = max(abs(x - med) for x in rss) / med
    base = statistics.median(rss[:max(1, len(rss) // 4)])
    growth = max(rss) / base - 1.0
    fall = 1.0 - min(rss) / base
    lines.append(f"  RSS: min {min(rss) / 1024:.1f} MB, median {med / 1024:.1f} MB, max "
                 f"{max(rss) / 1024:.1f} MB; spread (max - min) / median "
                 f"{100 * (max(rss) - min(rss)) / med:.1f} %, largest deviation from the "
                 f"median {100 * dev:.1f} %")
    lines.append(f"  RSS against the first quarter's median ({base / 1024:.1f} MB): highest "
                 f"{100 * growth:+.1f} % (allowed +{100 * RSS_BAND:.0f} %), lowest "
                 f"{-100 * fall:+.1f} % (memory given back: not judged)")
    if growth > RSS_BAND:
        fails.append(f"rss: grew {100 * growth:.1f} % above the first quarter's median after "
                     f"warm-up ({base / 1024:.1f} MB to {max(rss) / 1024:.1f} MB)")
    return base


def read_samples(path):
    rows = []
    with open(path) as f:
        for r in csv.DictReader(f):
            if r["phase"] == "dead":
                rows.append({"t": float(r["t_s"]), "phase": "dead"})
                continue
            rows.append({
                "t": float(r["t_s"]), "phase": r["phase"], "rss_kb": int(r["rss_kb"]),
                "fds": int(r["fds"]), "threads": int(r["threads"]),
                "shim_rss_kb": int(r["shim_b_rss_kb"] or 0),
                "running": r["running_plans"], "up": r["fpga_up"],
            })
    return rows


def read_events(path):
    with open(path) as f:
        return [(float(r["t_s"]), r["kind"], r["detail"]) for r in csv.DictReader(f)]


def parse_metrics(path):
    out = {}
    if not os.path.exists(path):
        return out
    for line in open(path):
        if line.startswith("#") or not line.strip():
            continue
        series, _, value = line.rstrip("\n").rpartition(" ")
        try:
            out[series] = float(value)
        except ValueError:
            pass
    return out


def labels(series):
    return dict(re.findall(r'(\w+)="([^"]*)"', series))


def quartile_medians(values):
    q = max(1, len(values) // 4)
    return statistics.median(values[:q]), statistics.median(values[-q:])


def flat(name, values, band, fails, lines):
    med = statistics.median(values)
    first, last = quartile_medians(values)
    lines.append(f"  {name}: min {min(values)}, median {med:g}, max {max(values)}; "
                 f"first-quarter median {first:g}, last-quarter median {last:g} "
                 f"(allowed: median +- {band}, creep <= {CREEP})")
    if max(values) > med + band or min(values) < med - band:
        fails.append(f"{name}: not flat after warm-up ({min(values)}..{max(values)}, "
                     f"median {med:g} +- {band})")
    if last - first > CREEP:
        fails.append(f"{name}: creeping up after warm-up (last-quarter median {last:g} vs "
                     f"first-quarter {first:g})")


def compare_answer(ref, got, where, stats):
    """Problems of one checked answer against the reference (empty: right)."""
    problems = []
    ref_samples = ref.get("samples", [])
    got_samples = got.get("samples", [])
    if len(ref_samples) != len(got_samples):
        return [f"{where}: {len(got_samples)} samples, reference {len(ref_samples)}"]
    exact_samples = []
    for i, (a, b) in enumerate(zip(ref_samples, got_samples)):
        if set(a) != set(b):
            problems.append(f"{where} sample {i}: fields {sorted(b)} vs {sorted(a)}")
            exact_samples.append(False)
            continue
        for k in a:
            if k not in RISK_KEYS and a[k] != b[k]:
                problems.append(f"{where} sample {i}: {k} = {b[k]!r}, reference {a[k]!r}")
        exact = all(a.get(k) == b.get(k) for k in RISK_KEYS)
        exact_samples.append(exact)
        if exact:
            stats["exact_samples"] += 1
            continue
        stats["board_samples"] += 1
        for k in RISK_KEYS:
            x, y = a.get(k, 0.0), b.get(k, 0.0)
            err = abs(y - x)
            rel = err / abs(x) if x else (0.0 if err == 0 else math.inf)
            stats["max_rel"] = max(stats["max_rel"], rel)
            if not (err <= BOARD_REL * abs(x)):
                problems.append(f"{where} sample {i}: {k} = {y!r}, reference {x!r} "
                                f"(relative error {rel:.3g} > {BOARD_REL:g})")
    # Pieces: everything but the risk exact; the risk exact when all of the
    # piece's samples are, else within the board's bound.
    ref_pieces, got_pieces = ref.get("pieces", []), got.get("pieces", [])
    if len(ref_pieces) != len(got_pieces):
        problems.append(f"{where}: {len(got_pieces)} pieces, reference {len(ref_pieces)}")
    else:
        first = 0
        for i, (a, b) in enumerate(zip(ref_pieces, got_pieces)):
            n = int(a.get("parts", 0))
            piece_exact = all(exact_samples[first:first + n])
            first += n
            for k in set(a) | set(b):
                if k in TOTAL_RISK_KEYS:
                    problems += risk_problem(f"{where} piece {i}", k, a.get(k, 0.0),
                                             b.get(k, 0.0), piece_exact)
                elif a.get(k) != b.get(k):
                    problems.append(f"{where} piece {i}: {k} = {b.get(k)!r}, reference {a.get(k)!r}")
    for k in set(ref) | set(got):
        if k in ("samples", "pieces"):
            continue
        if k in TOTAL_RISK_KEYS:
            problems += risk_problem(where, k, ref.get(k, 0.0), got.get(k, 0.0),
                                     all(exact_samples))
        elif ref.get(k) != got.get(k):
            problems.append(f"{where}: {k} = {got.get(k)!r}, reference {ref.get(k)!r}")
    return problems


def risk_problem(where, key, ref, got, must_be_exact):
    if must_be_exact:
        return [] if ref == got else [f"{where}: {key} = {got!r}, reference {ref!r} (all its "
                                      "samples were the CPU's bits, so it must be too)"]
    if abs(got - ref) <= BOARD_REL * abs(ref):
        return []
    return [f"{where}: {key} = {got!r}, reference {ref!r} (beyond {BOARD_REL:g} relative)"]


def plot(path, samples, events, soak_start, warm_end, soak_end, rss_base):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return "matplotlib not installed (python3-matplotlib): no plot"
    rows = [s for s in samples if s["phase"] != "dead"]
    t = [(s["t"] - soak_start) / 60.0 for s in rows]
    D_MIN[0] = (soak_end - soak_start) / 60.0
    fig, axes = plt.subplots(3, 1, figsize=(8, 6.4), sharex=True, dpi=100)
    series = [("RSS, MB", [s["rss_kb"] / 1024.0 for s in rows]),
              ("open descriptors", [s["fds"] for s in rows]),
              ("threads", [s["threads"] for s in rows])]
    kills = [(e[0] - soak_start) / 60.0 for e in events if e[1] == "shim_kill"]
    stops = [(e[0] - soak_start) / 60.0 for e in events if e[1] == "shim_stop"]
    for ax, (name, ys) in zip(axes, series):
        ax.axvspan(t[0] if t else 0, 0, color="0.92", lw=0)
        ax.axvspan(0, (warm_end - soak_start) / 60.0, color="0.85", lw=0)
        if t and t[-1] > D_MIN[0]:
            ax.axvspan(D_MIN[0], t[-1], color="0.92", lw=0)
        for k in kills:
            ax.axvline(k, color="tab:red", lw=0.6, alpha=0.5)
        for k in stops:
            ax.axvline(k, color="tab:orange", lw=0.6, alpha=0.5, ls="--")
        ax.plot(t, ys, ".-", color="tab:blue", ms=3, lw=1)
        ax.set_ylabel(name)
        ax.grid(alpha=0.3)
        lo, hi = min(ys), max(ys)
        pad = max(1.0, 0.1 * (hi - lo))
        ax.set_ylim(lo - pad, hi + pad)
    if rss_base:
        # Scaled to the soak (the start-up's lower values run off the axis),
        # so that the band and any drift inside it are visible.
        med = rss_base / 1024.0
        axes[0].axhspan(med * (1 - RSS_BAND), med * (1 + RSS_BAND), color="tab:green", alpha=0.12,
                        lw=0)
        axes[0].axhline(med * (1 + RSS_BAND), color="tab:green", lw=0.8)
        soak = [y for x, y in zip(t, series[0][1]) if x >= 0]
        lo = min(min(soak), med * (1 - RSS_BAND))
        hi = max(max(soak), med * (1 + RSS_BAND))
        axes[0].set_ylim(lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo))
    axes[0].set_title("riskplan-server under load and chaos. Light grey: measurement, and after the "
                      "end; grey: warm-up;\ngreen: RSS +-5 % of the first post-warm-up quarter's median "
                      "(the line: the most allowed);\nred: shim SIGKILL; orange: shim SIGSTOP", fontsize=9)
    axes[-1].set_xlabel("minutes since the soak started")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return None


def main():
    a = parse_args()
    out = a.out
    fails, lines = [], []
    D = a.duration_s
    soak_start = a.soak_start_s
    soak_end = soak_start + D
    warm_s = min(max(WARMUP_SHARE * D, WARMUP_MIN_S), WARMUP_MAX_S)
    warm_end = soak_start + warm_s

    lines.append(f"# Soak and chaos run: {a.command}")
    lines.append("")
    lines.append(open(os.path.join(out, "rates.txt")).read().strip())

    # --- memory, descriptors, threads ------------------------------------
    samples = read_samples(os.path.join(out, "samples.csv"))
    if any(s["phase"] == "dead" for s in samples):
        fails.append("server: the soak server died during the run")
    post = [s for s in samples if s["phase"] == "soak" and s["t"] >= warm_end]
    lines.append("")
    lines.append(f"## Resources (warm-up: measurement phase plus the first {warm_s:.0f} s of the "
                 f"soak; {len(post)} samples after it)")
    rss_base = None
    if len(post) < 4:
        fails.append(f"samples: only {len(post)} samples after warm-up")
    else:
        rss = [s["rss_kb"] for s in post]
        rss_base = judge_rss(rss, fails, lines)
        flat("fds", [s["fds"] for s in post], FD_BAND, fails, lines)
        flat("threads", [s["threads"] for s in post], THREAD_BAND, fails, lines)
        shim = [s["shim_rss_kb"] for s in post if s["shim_rss_kb"]]
        if shim:
            lines.append(f"  shim B (stopped, never killed) RSS: {min(shim) / 1024:.1f}.."
                         f"{max(shim) / 1024:.1f} MB (not judged)")
    every = max(1, len(samples) // 16)
    lines.append("  over time (t from the server's start; phase, RSS MB, fds, threads):")
    shown = samples[::every] + ([samples[-1]] if (len(samples) - 1) % every else [])
    for s in shown:
        if s["phase"] != "dead":
            lines.append(f"    t={s['t']:7.1f}s {s['phase']:7s} {s['rss_kb'] / 1024:7.1f} "
                         f"{s['fds']:4d} {s['threads']:4d}")

    # --- errors -----------------------------------------------------------
    lines.append("")
    lines.append("## Calls by status")
    for path in sorted(glob.glob(os.path.join(out, "load-*.json"))):
        name = os.path.basename(path)[5:-5]
        r = json.load(open(path))
        codes = r.get("codes", {})
        lines.append(f"  load {name}: sent {r['sent']}, completed {r['completed']}, "
                     f"{r['throughput_rps']:.1f} calls/s, latency p50 {r['latency_ms']['p50']:.1f} ms "
                     f"p99 {r['latency_ms']['p99']:.1f} ms max {r['latency_ms']['max']:.0f} ms; "
                     f"codes {codes}")
        shed = codes.get("CLIENT_OVERLOADED", 0)
        if shed:
            lines.append(f"    {shed} calls not sent (CLIENT_OVERLOADED: {100 * shed / (r['sent'] + shed):.1f} % "
                         f"of those due; the generator's in-flight bound was reached because the "
                         f"machine was slower than measured: not judged, they never reached the server)")
        bad = {k: v for k, v in codes.items() if k not in ("OK", "CLIENT_OVERLOADED")}
        if bad:
            fails.append(f"errors: load {name} got {bad}")
        if r["completed"] != r["sent"]:
            fails.append(f"errors: load {name} completed {r['completed']} of {r['sent']} calls")
    for name in ("eval-long", "eval-short", "plan", "ping"):
        if not os.path.exists(os.path.join(out, f"load-{name}.json")):
            fails.append(f"errors: load {name} wrote no report (see load-{name}.log)")
    metrics = parse_metrics(os.path.join(out, "metrics-final.txt"))
    if not metrics:
        fails.append("metrics: no final scrape of the server's metrics")
    chaos_rows = list(csv.reader(open(os.path.join(out, "chaos-plans.csv"))))
    deadline_rows = [r for r in chaos_rows if r and r[0] == "deadline"]
    killed_rows = [r for r in chaos_rows if r and r[0] == "killed"]
    server_codes = {}
    for series, v in metrics.items():
        if series.startswith("riskplan_rpcs_total{"):
            l = labels(series)
            server_codes[(l["method"], l["code"])] = int(v)
    lines.append("  server (riskplan_rpcs_total, the whole run): " + ", ".join(
        f"{m} {c} {n}" for (m, c), n in sorted(server_codes.items())))
    expected = 0
    for (m, c), n in server_codes.items():
        if c == "OK":
            continue
        if m == "PlanTrajectory" and c in ("DEADLINE_EXCEEDED", "CANCELLED"):
            expected += n
        else:
            fails.append(f"errors: the server answered {m} with {c} {n} times")
    lines.append(f"  documented: PlanTrajectory DEADLINE_EXCEEDED or CANCELLED for the "
                 f"{len(deadline_rows)} plans given a short deadline and the {len(killed_rows)} "
                 f"whose client was killed: {expected} on the server")
    if expected > len(deadline_rows) + len(killed_rows):
        fails.append(f"errors: {expected} plans ended DEADLINE_EXCEEDED or CANCELLED on the server, "
                     f"more than the {len(deadline_rows) + len(killed_rows)} the chaos cancelled")
    for r in deadline_rows:
        if r[1] != "1" or "DEADLINE_EXCEEDED" not in r[2]:
            fails.append(f"errors: a plan with a short deadline ended with exit code {r[1]}: {r[2]}")
    for r in killed_rows:
        if r[1] != "killed":
            fails.append(f"errors: a plan whose client was to be killed ended first: {r[2]}")

    # --- results ----------------------------------------------------------
    lines.append("")
    lines.append("## Results re-checked against the CPU-only server")
    stats = {"exact_samples": 0, "board_samples": 0, "max_rel": 0.0}
    answers, wrong, failed_calls = 0, 0, 0
    per_name = {}
    for path in sorted(glob.glob(os.path.join(a.checks, "*.json"))):
        name = os.path.basename(path)[:-5].split("-", 1)[1]
        if os.path.exists(path + ".err"):
            failed_calls += 1
            fails.append(f"errors: the check {os.path.basename(path)} failed: "
                         f"{open(path + '.err').read().strip()[:300]}")
            continue
        ref = json.load(open(os.path.join(out, "reference", name + ".json")))
        got = json.load(open(path))
        answers += 1
        problems = compare_answer(ref, got, os.path.basename(path), stats)
        per = per_name.setdefault(name, [0, 0])
        per[0] += 1
        if problems:
            wrong += 1
            per[1] += 1
            os.makedirs(os.path.join(out, "wrong"), exist_ok=True)
            shutil.copy(path, os.path.join(out, "wrong"))
            if wrong <= 5:
                fails.append("results: " + "; ".join(problems[:3]))
    for name, (n, w) in sorted(per_name.items()):
        lines.append(f"  {name}: {n} answers, {w} wrong")
    lines.append(f"  {answers} answers, {wrong} wrong, {failed_calls} failed calls; samples: "
                 f"{stats['exact_samples']} bit for bit, {stats['board_samples']} from a board "
                 f"(largest relative difference {stats['max_rel']:.2g}, allowed {BOARD_REL:g})")
    if wrong:
        fails.append(f"results: {wrong} wrong answers of {answers}")
    if answers == 0:
        fails.append("results: no answer was checked")

    # --- chaos ------------------------------------------------------------
    events = read_events(os.path.join(out, "events.csv"))
    count = {}
    for _, kind, _ in events:
        count[kind] = count.get(kind, 0) + 1
    lines.append("")
    lines.append("## Chaos")
    lines.append("  " + ", ".join(f"{k} {count.get(k, 0)}" for k in (
        "shim_kill", "shim_restart", "shim_restart_failed", "shim_stop", "shim_cont",
        "plan_deadline", "plan_client_kill")))
    for kind in ("shim_kill", "shim_stop", "plan_deadline", "plan_client_kill"):
        if count.get(kind, 0) < 1:
            fails.append(f"chaos: no {kind} event")
    if count.get("shim_restart_failed", 0):
        fails.append(f"chaos: shim A could not be restarted {count['shim_restart_failed']} times")
    workers = {}
    for series, v in metrics.items():
        l = labels(series)
        w = l.get("worker") or l.get("runner", "")
        if not w.startswith("fpga:"):
            continue
        name = series.split("{")[0].replace("riskplan_accel_", "")
        if name == "worker_state":
            if v == 1:
                workers.setdefault(w, {})["state"] = l["state"]
        else:
            workers.setdefault(w, {})[name] = int(v)
    for w, m in sorted(workers.items()):
        lines.append(f"  {w}: state {m.get('state')}, configurations {m.get('configurations_total', 0)}, "
                     f"failures {m.get('worker_failures_total', '?')}, "
                     f"state changes {m.get('worker_state_changes_total', '?')}, "
                     f"uploads {m.get('blob_uploads_total', 0)}, "
                     f"chunks taken over by stopped callers {m.get('worker_taken_over_total', 0)}, "
                     f"audited {m.get('audited_sites_total', 0)}, audit failures "
                     f"{m.get('audit_failures_total', 0)}")
        if not m.get("configurations_total"):
            fails.append(f"chaos: {w} evaluated nothing (the boards were not exercised)")
        if m.get("audit_failures_total"):
            fails.append(f"boards: {w} failed {m['audit_failures_total']} spot checks")
    if len(workers) != 2:
        fails.append(f"chaos: {len(workers)} FPGA workers in the metrics, expected 2")

    # --- recovery, hangs, drain -------------------------------------------
    lines.append("")
    lines.append(f"## End: workers up and no plan running within 60 s: "
                 f"{'yes' if a.recovered == '1' else 'no'}; drain on SIGTERM: exit {a.drain_rc}")
    if a.recovered != "1":
        fails.append("recovery: the shims' workers were not both up, or plans still ran, 60 s "
                     "after the chaos stopped")
    if a.drain_rc != "0":
        fails.append(f"drain: the server's exit on SIGTERM was {a.drain_rc}, not 0")
    if a.hung:
        fails.append(f"hang: load generators still running 120 s after the end:{a.hung}")

    note = plot(os.path.join(out, "soak.png"), samples, events, soak_start, warm_end, soak_end,
                rss_base)
    lines.append("")
    lines.append(f"plot: {note or os.path.join(out, 'soak.png')}")
    lines.append("")
    if fails:
        lines.append(f"SOAK FAILED ({len(fails)}):")
        lines += [f"  FAIL {f}" for f in fails]
    else:
        lines.append("SOAK PASSED: rss, fds, threads, errors, results, chaos, recovery, drain")
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    with open(os.path.join(out, "summary.txt"), "w") as f:
        f.write(text)
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
