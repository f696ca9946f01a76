#!/usr/bin/python3
"""Tables and plot of riskplan-bench-ompl's report (bench/ompl/run_record.h).

    python3 bench/ompl/plot_ompl_bench.py results.csv [--png out.png] [--title T]

Prints Markdown tables (per planner and budget: risk quartiles, share solved,
time to first solution, iterations; per scenario: median risk at each budget;
the time RISK_RRT_STAR needs to reach the best OMPL planner's 3-second median,
and whether the target is met: reached within --target_s, and the final median
at least --target_lower lower)
and, with --png, draws the median risk of every planner against time.

Risk at time t of a run: the best risk it had reported by t (its anytime
curve); +inf before its first solution, so unsolved runs count as worse than
any solved one and a median is +inf ("-") when fewer than half are solved.
Risks differ by scenario, so the pooled figures use the risk relative to the
scenario's reference: the lowest median-over-seeds 3-second risk of any planner
on it (1.00 = that median; lower is better).
"""
import argparse
import collections
import math
import sys

OURS = "RISK_RRT_STAR"
INF = float("inf")


def read_report(path):
    runs = {}  # (planner, scenario, seed) -> dict
    budget_runs = collections.defaultdict(dict)  # (planner, scenario, seed) -> {budget: risk}
    header = []
    errors = []
    loads = []  # 1-minute load average before each (scenario, seed) group

    def run(planner, scenario, seed):
        return runs.setdefault((planner, scenario, seed),
                               {"imp": [], "chk": {}, "run": None})

    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            if line.startswith("# load "):
                loads.append(float(line.split(":")[1].split()[0]))
                continue
            if line.startswith("#"):
                header.append(line)
                continue
            fields = line.split(",")
            kind, planner, scenario, seed = fields[0], fields[1], fields[2], int(fields[3])
            if kind == "imp":
                run(planner, scenario, seed)["imp"].append(
                    (float(fields[4]), float(fields[5]), int(fields[6])))
            elif kind == "chk":
                run(planner, scenario, seed)["chk"][float(fields[4])] = int(fields[5])
            elif kind == "run":
                run(planner, scenario, seed)["run"] = {
                    "budget": float(fields[4]), "solved": fields[5] == "1",
                    "elapsed": float(fields[6]), "iterations": int(fields[7]),
                    "vertices": int(fields[8]), "best": float(fields[9]),
                    "reeval": float(fields[10]), "admissible": fields[11] == "1",
                    "configurations": int(fields[12])}
            elif kind == "bud":
                budget_runs[(planner, scenario, seed)][float(fields[4])] = (
                    float(fields[6]) if fields[5] == "1" else INF)
            elif kind == "err":
                errors.append(line)
    runs = {k: v for k, v in runs.items() if v["run"] is not None}
    return runs, budget_runs, header, errors, loads


def risk_at(run, t):
    best = INF
    for elapsed, risk, _ in run["imp"]:
        if elapsed <= t:
            best = min(best, risk)
    return best


def quantile(values, q):
    """Linear-interpolation quantile; inf-aware (inf sorts last)."""
    v = sorted(values)
    if not v:
        return math.nan
    pos = q * (len(v) - 1)
    lo, hi = math.floor(pos), math.ceil(pos)
    if math.isinf(v[lo]) or math.isinf(v[hi]):
        return v[hi] if pos - lo > 0 else v[lo]
    return v[lo] + (v[hi] - v[lo]) * (pos - lo)


def median(values):
    return quantile(values, 0.5)


def fmt(x, digits=3):
    if isinstance(x, float) and (math.isinf(x) or math.isnan(x)):
        return "-"
    return f"{x:.{digits}g}" if abs(x) < 1e-3 else f"{x:.{digits}f}"


def fmt_risk(x):
    if math.isinf(x) or math.isnan(x):
        return "-"
    return f"{x:.3e}"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("report")
    ap.add_argument("--png")
    ap.add_argument("--title", default="")
    ap.add_argument("--budgets", default="0.1,0.3,1,3")
    ap.add_argument("--target_s", type=float, default=0.05,
                    help="target: RISK_RRT_STAR reaches the best OMPL median within this time")
    ap.add_argument("--target_lower", type=float, default=0.20,
                    help="target: RISK_RRT_STAR's final median at least this share lower")
    args = ap.parse_args()
    budgets = [float(b) for b in args.budgets.split(",")]
    final = budgets[-1]
    runs, budget_runs, header, errors, loads = read_report(args.report)
    planners = []
    for (p, _, _) in runs:
        if p not in planners:
            planners.append(p)
    planners.sort(key=lambda p: (p != OURS, p))
    scenarios = []
    for (_, s, _) in runs:
        if s not in scenarios:
            scenarios.append(s)

    def runs_of(p, s=None):
        return [r for (pp, ss, _), r in sorted(runs.items()) if pp == p and (s is None or ss == s)]

    # Reference per scenario: the lowest median 3-second risk of any planner.
    ref = {}
    for s in scenarios:
        meds = [median([risk_at(r, final) for r in runs_of(p, s)]) for p in planners]
        ref[s] = min(meds)
        if math.isinf(ref[s]):  # no planner solved half its runs: the best run instead
            ref[s] = min([risk_at(r, final) for p in planners for r in runs_of(p, s)])

    for line in header:
        print(line)
    if loads:
        print(f"# 1-minute load average over the run (2 cores): min {min(loads):.2f}, "
              f"median {median(loads):.2f}, max {max(loads):.2f}")
    for line in errors:
        print("ERROR:", line)

    # Agreement of the planners' own costs with EvaluateTrajectory.
    worst = 0.0
    inadmissible = 0
    solved_runs = 0
    for r in runs.values():
        info = r["run"]
        if not info["solved"]:
            continue
        solved_runs += 1
        if not info["admissible"]:
            inadmissible += 1
        worst = max(worst, abs(info["best"] - info["reeval"]) / info["best"])
    print(f"\nFinal trajectories re-evaluated with EvaluateTrajectory: {solved_runs} solved runs, "
          f"{inadmissible} inadmissible, largest relative difference of the planner's own cost "
          f"{worst:.2g}.\n")

    # Table 1: per planner and budget, pooled over scenarios and seeds.
    print("| planner | budget | risk / reference: median [Q1, Q3] | solved | "
          "first solution, s: median [Q1, Q3] | iterations: median |")
    print("|---|---:|---|---:|---|---:|")
    for p in planners:
        rs = runs_of(p)
        for b in budgets:
            at = [(risk_at(r, b), s) for (pp, s, _), r in sorted(runs.items()) if pp == p]
            rel = [risk / ref[s] if not math.isinf(risk) else INF for risk, s in at]
            solved = sum(1 for risk, _ in at if not math.isinf(risk))
            firsts_all = [r["imp"][0][0] if r["imp"] and r["imp"][0][0] <= b else INF for r in rs]
            iters = [r["chk"][b] for r in rs if b in r["chk"]]
            iters_txt = f"{median(iters):.0f}" if iters else "-"
            print(f"| {p} | {b:g} s | {fmt(median(rel))} [{fmt(quantile(rel, 0.25))}, "
                  f"{fmt(quantile(rel, 0.75))}] | {solved}/{len(rel)} | "
                  f"{fmt(median(firsts_all))} [{fmt(quantile(firsts_all, 0.25))}, "
                  f"{fmt(quantile(firsts_all, 0.75))}] | {iters_txt} |")

    # Table 2: per scenario, median risk at each budget.
    print("\nMedian risk over seeds (expected casualties per flight), per scenario:\n")
    cols = [f"{p} @{b:g}s" for p in planners for b in (budgets[1], final)]
    print("| scenario | reference | " + " | ".join(cols) + " |")
    print("|---|---:|" + "---:|" * len(cols))
    for s in scenarios:
        cells = []
        for p in planners:
            for b in (budgets[1], final):
                cells.append(fmt_risk(median([risk_at(r, b) for r in runs_of(p, s)])))
        print(f"| {s} | {fmt_risk(ref[s])} | " + " | ".join(cells) + " |")

    # Time RISK_RRT_STAR needs to reach the best OMPL planner's median at 3 s.
    ompl = [p for p in planners if p != OURS]
    if OURS in planners and ompl:
        print(f"\nTime {OURS} needs to reach the best OMPL planner's median risk at {final:g} s "
              "(its median-over-seeds curve; and the median over seeds of each run's time):\n")
        print(f"| scenario | best OMPL planner | its median @{final:g}s | {OURS} median curve "
              f"reaches it at | median over seeds of the run's time | {OURS} median @{final:g}s "
              f"| lower by | target (<= {args.target_s:g} s; >= {args.target_lower:.0%} lower) |")
        print("|---|---|---:|---:|---:|---:|---:|---|")
        times = []
        lowers = []
        for s in scenarios:
            best_p, target = None, INF
            for p in ompl:
                m = median([risk_at(r, final) for r in runs_of(p, s)])
                if m < target:
                    best_p, target = p, m
            ours = runs_of(OURS, s)
            events = sorted({e for r in ours for e, _, _ in r["imp"]})
            t_curve = INF
            if not math.isinf(target):
                for t in events:
                    if median([risk_at(r, t) for r in ours]) <= target:
                        t_curve = t
                        break
            per_run = []
            for r in ours:
                hit = [e for e, risk, _ in r["imp"] if risk <= target]
                per_run.append(hit[0] if hit else INF)
            times.append(t_curve)
            ours_final = median([risk_at(r, final) for r in ours])
            lower = 1.0 - ours_final / target if not math.isinf(target) else 1.0
            lowers.append(lower)
            met_t = t_curve <= args.target_s
            met_l = lower >= args.target_lower
            verdict = ("met" if met_t and met_l else
                       "not met: " + ", ".join(x for x, bad in (("time", not met_t),
                                                                 ("margin", not met_l)) if bad))
            print(f"| {s} | {best_p} | {fmt_risk(target)} | {fmt(t_curve)} s | "
                  f"{fmt(median(per_run))} s | {fmt_risk(ours_final)} | {lower:.0%} | {verdict} |")
        print(f"\nMedian over scenarios of the curve time: {fmt(median(times))} s; "
              f"scenarios reached within {args.target_s:g} s: "
              f"{sum(1 for t in times if t <= args.target_s)}/{len(times)}; "
              f"within 0.3 s: {sum(1 for t in times if t <= 0.3)}/{len(times)}; "
              f"within {final:g} s: {sum(1 for t in times if t <= final)}/{len(times)}. "
              f"{OURS}'s {final:g}-second median lower than the best OMPL planner's by "
              f"{min(lowers):.0%} to {max(lowers):.0%}; at least {args.target_lower:.0%} on "
              f"{sum(1 for x in lowers if x >= args.target_lower)}/{len(lowers)}.")

    # Cross-check: RISK_RRT_STAR's separate short-budget runs against its curve.
    if budget_runs:
        print(f"\n{OURS} runs with the smaller budgets themselves (median risk / reference), "
              "against the same budget read off the full-budget runs:\n")
        print("| budget | separate runs | read off the full-budget runs |")
        print("|---:|---:|---:|")
        for b in budgets[:-1]:
            sep = [v[b] / ref[s] for (p, s, _), v in budget_runs.items() if p == OURS and b in v]
            cur = [risk_at(r, b) / ref[s] for (p, s, _), r in runs.items() if p == OURS]
            print(f"| {b:g} s | {fmt(median(sep))} | {fmt(median(cur))} |")

    if args.png:
        plot(args.png, args.title, planners, scenarios, runs, ref, runs_of, final)


def plot(png, title, planners, scenarios, runs, ref, runs_of, final):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    grid = [0.005 * (final / 0.005) ** (i / 199) for i in range(200)]
    colours = {OURS: "#d62728", "RRTstar": "#1f77b4", "InformedRRTstar": "#17becf",
               "BITstar": "#2ca02c", "ABITstar": "#9467bd"}
    n = len(scenarios) + 1
    cols = 4
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.5 * rows), dpi=72)
    axes = axes.ravel()

    def curve(values_at):
        xs, ys = [], []
        for t in grid:
            m = values_at(t)
            if not math.isinf(m):
                xs.append(t)
                ys.append(m)
        return xs, ys

    ax = axes[0]
    for p in planners:
        def pooled(t, p=p, q=0.5):
            return quantile([risk_at(r, t) / ref[s] for (pp, s, _), r in runs.items()
                             if pp == p], q)
        xs, ys = curve(pooled)
        ax.plot(xs, ys, color=colours.get(p), label=p, lw=1.8)
        lo = [pooled(t, q=0.25) for t in xs]
        hi = [pooled(t, q=0.75) for t in xs]
        hi = [h if not math.isinf(h) else max(ys) * 2 for h in hi]
        ax.fill_between(xs, lo, hi, color=colours.get(p), alpha=0.12, lw=0)
    ax.set_title("all scenarios: risk / reference", fontsize=9)
    ax.set_ylim(0.9, 2.5)
    ax.axvline(0.3, color="grey", lw=0.6, ls=":")
    ax.legend(fontsize=7, loc="upper right")
    for i, s in enumerate(scenarios, start=1):
        ax = axes[i]
        for p in planners:
            xs, ys = curve(lambda t, p=p, s=s: median([risk_at(r, t) for r in runs_of(p, s)]))
            ax.plot(xs, [y * 1e6 for y in ys], color=colours.get(p), lw=1.4)
        ax.set_title(f"{s}: median risk (x1e-6)", fontsize=9)
        ax.axvline(0.3, color="grey", lw=0.6, ls=":")
    for i, ax in enumerate(axes):
        if i > len(scenarios):
            ax.axis("off")
            continue
        ax.set_xscale("log")
        ax.set_xlim(0.005, final)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="major", lw=0.3)
        if i // cols == rows - 1 or i + cols > len(scenarios):
            ax.set_xlabel("wall time, s", fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(png)
    print(f"\nplot: {png}", file=sys.stderr)


if __name__ == "__main__":
    main()
