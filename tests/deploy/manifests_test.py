#!/usr/bin/env python3
"""Checks deploy/kubernetes against the server it deploys, so they cannot drift.

- The HorizontalPodAutoscaler scales on a pods metric that the Prometheus
  adapter's rule serves, from a series the server really exports.
- Its target leaves every replica's planning threads busy before it scales.
- The pod's termination grace period is longer than the server's own grace
  period, so that the kubelet's SIGKILL never cuts a drain short.

Usage: manifests_test.py SOURCE_DIR (exit 0 when every check holds; each
failure is printed with the file it is about).
"""
import re
import sys

import yaml


def main(source):
    failures = []

    def check(ok, message):
        if not ok:
            failures.append(message)

    server_yaml = f"{source}/deploy/kubernetes/riskplan-server.yaml"
    adapter_yaml = f"{source}/deploy/kubernetes/prometheus-adapter.yaml"
    with open(server_yaml) as f:
        docs = [d for d in yaml.safe_load_all(f) if d]
    by_kind = {d["kind"]: d for d in docs}
    for kind in ("Deployment", "Service", "HorizontalPodAutoscaler"):
        check(kind in by_kind, f"{server_yaml}: no {kind}")
    if failures:
        return failures

    with open(f"{source}/server/observability/metrics.cc") as f:
        exported = set(re.findall(r'\.Name\("([a-z_]+)"\)', f.read()))

    hpa = by_kind["HorizontalPodAutoscaler"]["spec"]
    pods = [m["pods"] for m in hpa["metrics"] if m["type"] == "Pods"]
    check(len(pods) == 1, f"{server_yaml}: the autoscaler has {len(pods)} pods metrics, not 1")
    if not pods:
        return failures
    metric = pods[0]["metric"]["name"]
    check(metric in exported,
          f"{server_yaml}: the autoscaler's metric {metric} is not one server/observability/metrics.cc exports")

    with open(adapter_yaml) as f:
        adapter = yaml.safe_load(f)
    rules = yaml.safe_load(adapter["data"]["config.yaml"])["rules"]
    served = {r["name"]["as"]: r for r in rules}
    check(metric in served, f"{adapter_yaml}: no rule serves {metric}")
    if metric in served:
        rule = served[metric]
        check(rule["seriesQuery"].startswith(metric + "{"),
              f"{adapter_yaml}: the rule for {metric} queries {rule['seriesQuery']}")
        check(set(rule["resources"]["overrides"]) == {"namespace", "pod"},
              f"{adapter_yaml}: a pods metric needs the namespace and pod labels")

    pod = by_kind["Deployment"]["spec"]["template"]["spec"]
    args = pod["containers"][0]["args"]
    flags = dict(a[2:].split("=", 1) for a in args if a.startswith("--") and "=" in a)
    target = float(pods[0]["target"]["averageValue"])
    threads = int(flags.get("plan_threads", "0"))
    check(threads >= 1, f"{server_yaml}: the Deployment sets no --plan_threads")
    check(target >= threads,
          f"{server_yaml}: target {target} missions per replica is below --plan_threads={threads}: "
          "it would scale out before a replica's planners are busy")
    grace_ms = int(flags.get("grace_period_ms", "10000"))
    check(pod["terminationGracePeriodSeconds"] * 1000 > grace_ms,
          f"{server_yaml}: terminationGracePeriodSeconds {pod['terminationGracePeriodSeconds']} "
          f"is not longer than --grace_period_ms={grace_ms}")
    return failures


if __name__ == "__main__":
    failures = main(sys.argv[1])
    for f in failures:
        print("FAIL:", f)
    if not failures:
        print("deploy/kubernetes agrees with the server")
    sys.exit(1 if failures else 0)
