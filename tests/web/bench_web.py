#!/usr/bin/env python3
"""Measurements of riskplan-web (docs/benchmarks.md, "The web view"); not a
test: it judges nothing, it prints figures.

  latency  One headless Chromium page plans on the 8 km demo-city (RISK_RRT_STAR,
           time budget, every improvement streamed) PLANS times; the page stamps
           when each improvement is drawn (the first animation frame after the
           map and the plot changed) and the event carries when the gateway read
           it from the server's stream: p50, p95, max of the difference.
  viewers  N raw event-stream readers (one socket each, one thread reading all
           of them with select) watch two plans at once; every stream must be
           accepted and receive every event of its plan; per-event delivery
           latency (reader's receipt minus the gateway's read) p50/p95/max,
           and the gateway's CPU and memory while it serves them.

  screenshot  the picture of docs/web.md.

Usage: bench_web.py BIN_DIR latency [PLANS] | viewers N [N ...] | screenshot PNG
"""

import http.client
import json
import os
import selectors
import socket
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import web_fixture as wf  # noqa: E402

START = {"x": 1200, "y": 1500, "z": 250, "theta": 0.785}  # the README's mission
GOAL = {"x": 6800, "y": 6500, "z": 250, "theta": 0.785}


def percentile(values, p):
    values = sorted(values)
    if not values:
        return float("nan")
    k = min(len(values) - 1, max(0, int(round(p / 100 * (len(values) - 1)))))
    return values[k]


def summary(values):
    if not values:
        return "n=0"
    return (f"n={len(values)} p50={percentile(values, 50):.2f} ms "
            f"p95={percentile(values, 95):.2f} ms max={max(values):.2f} ms")


def post(address, path, body):
    host, port = address.rsplit(":", 1)
    c = http.client.HTTPConnection(host, int(port), timeout=60)
    c.request("POST", path, json.dumps(body), {"Content-Type": "application/json"})
    r = c.getresponse()
    data = r.read()
    c.close()
    if r.status >= 300:
        raise AssertionError(f"POST {path}: {r.status} {data!r}")
    return json.loads(data)


def start_8km(bin_dir, extra_gateway=()):
    maps = wf.scratch_dir("riskplan-bench-web-")
    subprocess.run([os.path.join(bin_dir, "riskplan-tool"), "write-map", f"--out={maps}/demo-city"],
                   check=True, stdout=subprocess.DEVNULL)
    server = wf.start_server(bin_dir, maps)
    gateway = wf.start_gateway(bin_dir, server.address, extra_gateway)
    return server, gateway


def latency(bin_dir, plans):
    server, gateway = start_8km(bin_dir)
    driver = wf.chromium()
    try:
        driver.get(f"http://{gateway.address}/")
        wf.wait_for(lambda: driver.execute_script("return window.rp && rp.ready === true"), 300,
                    "the page")
        for key, pose in (("start", START), ("goal", GOAL)):
            driver.execute_script(f"rp.setEndpoint('{key}', arguments[0]);", pose)
        driver.execute_script("document.getElementById('budget-ms').value = '5000';"
                              "document.getElementById('budget-iterations').value = '0';")
        samples, improvements = [], 0
        for k in range(plans):
            driver.execute_script("document.getElementById('seed').value = arguments[0];", str(k + 1))
            driver.execute_script("rp.latencies = [];")
            driver.execute_script("document.getElementById('plan').click();")
            wf.wait_for(lambda: driver.execute_script("return rp.state") in ("finished", "failed"),
                        300, "the plan")
            # The final event's frame, too.
            wf.wait_for(lambda: driver.execute_script("return rp.latencies.length") ==
                        driver.execute_script("return rp.improvements.length"), 30, "the last frame")
            lat = driver.execute_script("return rp.latencies")
            improvements += driver.execute_script("return rp.improvements.length")
            samples += lat
            print(f"plan {k + 1}: {len(lat)} improvements drawn, {summary(lat)}", flush=True)
        print(f"all: {improvements} improvements drawn over {plans} plans, {summary(samples)}")
    finally:
        wf.quit_chromium(driver)
        gateway.stop()
        server.stop()


def screenshot(bin_dir, path):
    """The picture of docs/web.md: a 5 s plan across the 8 km demo-city, placed
    on WGS84, with the risk layer at 100 m, the plot and the final profile."""
    maps = wf.scratch_dir("riskplan-bench-web-")
    subprocess.run([os.path.join(bin_dir, "riskplan-tool"), "write-map",
                    f"--out={maps}/demo-city-wgs84"], check=True, stdout=subprocess.DEVNULL)
    manifest = os.path.join(maps, "demo-city-wgs84", "manifest.json")
    m = json.load(open(manifest))
    m["name"] = "demo-city-wgs84"
    m["geo"] = {"origin_lat_deg": 49.58, "origin_lon_deg": 6.08, "crs": "demo placement"}
    json.dump(m, open(manifest, "w"))
    server = wf.start_server(bin_dir, maps)
    gateway = wf.start_gateway(bin_dir, server.address)
    driver = wf.chromium(width=1500, height=1180)
    try:
        driver.get(f"http://{gateway.address}/")
        wf.wait_for(lambda: driver.execute_script("return window.rp && rp.ready === true"), 300,
                    "the page")
        driver.execute_script("document.getElementById('risk-show').click();")
        wf.wait_for(lambda: driver.execute_script("return rp.layersDrawn['risk layer'] === true"),
                    300, "the risk layer")
        for key, pose in (("start", START), ("goal", GOAL)):
            driver.execute_script(f"rp.setEndpoint('{key}', arguments[0]);", pose)
        driver.execute_script("document.getElementById('budget-ms').value = '5000';"
                              "document.getElementById('budget-iterations').value = '0';"
                              "document.getElementById('plan').click();")
        wf.wait_for(lambda: driver.execute_script("return rp.state") in ("finished", "failed"), 300,
                    "the plan")
        wf.wait_for(lambda: driver.execute_script("return rp.profile !== null"), 120, "the profile")
        driver.save_screenshot(path)
        print(f"wrote {path}")
    finally:
        wf.quit_chromium(driver)
        gateway.stop()
        server.stop()


def cpu_seconds(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def rss_mb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def viewers(bin_dir, counts):
    top = max(counts)
    server, gateway = start_8km(bin_dir, [f"--max_viewers={top}", "--heartbeat_ms=1000"])
    host, port = gateway.address.rsplit(":", 1)
    try:
        for n in counts:
            ids = []
            for seed in (1, 2):
                ids.append(post(gateway.address, "/api/plans", {
                    "map": "demo-city", "start": START, "goal": GOAL,
                    "budget": {"time_ms": "15000"}, "seed": str(seed),
                    "min_update_interval_ms": "100"})["id"])
            socks, state = [], {}
            start_wall = time.time()
            sel = selectors.DefaultSelector()
            # Viewers join running plans as a reconnecting browser would, after
            # the events already sent: what is measured is the fan-out of new
            # improvements, not a catch-up on old ones.
            seen = {}
            for plan in ids:
                c = http.client.HTTPConnection(host, int(port), timeout=60)
                c.request("GET", f"/api/plans/{plan}")
                seen[plan] = json.loads(c.getresponse().read())["last_event_id"]
                c.close()
            for k in range(n):
                s = socket.create_connection((host, int(port)), timeout=60)
                plan = ids[k % 2]
                s.sendall(f"GET /api/plans/{plan}/events HTTP/1.1\r\nHost: {host}\r\n"
                          f"Last-Event-ID: {seen[plan]}\r\nConnection: close\r\n\r\n".encode())
                s.setblocking(False)
                sel.register(s, selectors.EVENT_READ, k)
                socks.append(s)
                state[k] = {"buf": bytearray(), "head": None, "events": [], "done": False}
            cpu0, t0 = cpu_seconds(gateway.proc.pid), time.monotonic()
            reader0 = time.process_time()
            received = 0
            rss_max = 0.0
            latencies = []
            timeline = []
            open_streams = n
            while open_streams and time.monotonic() - t0 < 120:
                for key, _ in sel.select(timeout=1.0):
                    k = key.data
                    st = state[k]
                    try:
                        data = key.fileobj.recv(1 << 18)
                    except BlockingIOError:
                        continue
                    now = time.time() * 1000
                    if not data:
                        st["done"] = True
                        sel.unregister(key.fileobj)
                        key.fileobj.close()
                        open_streams -= 1
                        continue
                    buf = st["buf"]
                    buf += data
                    received += len(data)
                    if st["head"] is None:
                        h = buf.find(b"\r\n\r\n")
                        if h < 0:
                            continue
                        st["head"] = bytes(buf[:buf.find(b"\r\n")]).decode()
                        st["head_ms"] = now
                        del buf[:h + 4]
                    # Events end with a blank line; the chunk framing lines in
                    # between hold neither pattern searched for. The type and
                    # the timestamp are at the start of each event.
                    pos = 0
                    while True:
                        end = buf.find(b"\n\n", pos)
                        if end < 0:
                            break
                        head = bytes(buf[pos:min(end, pos + 200)])
                        pos = end + 2
                        i = head.find(b"\nevent: ")
                        if i < 0:
                            continue
                        kind = head[i + 8:head.find(b"\n", i + 8)].decode()
                        j = head.find(b'"gateway_ms":')
                        if j >= 0:
                            sent = float(head[j + 13:head.find(b",", j)])
                            timeline.append((sent, now - sent))
                        st["events"].append(kind)
                    del buf[:pos]
                rss_max = max(rss_max, rss_mb(gateway.proc.pid))
            elapsed = time.monotonic() - t0
            # Timed: the events the gateway read once it had answered every
            # viewer's request (earlier ones are a catch-up, not a delivery).
            joined_ms = max(state[k].get("head_ms", float("inf")) for k in state)
            latencies = [l for t, l in timeline if t >= joined_ms]
            timeline = [(t - joined_ms, l) for t, l in timeline if t >= joined_ms]
            if os.environ.get("TIMELINE"):
                for second in range(0, 20):
                    lat = [l for t, l in timeline if second * 1000 <= t < (second + 1) * 1000]
                    if lat:
                        print(f"  events read by the gateway {second}-{second + 1} s after: {summary(lat)}")
            connect_s = joined_ms / 1000 - start_wall
            cpu = cpu_seconds(gateway.proc.pid) - cpu0
            accepted = sum(1 for k in state if state[k]["head"] and " 200 " in state[k]["head"] + " ")
            per_plan = {}
            complete = 0
            for k in state:
                evs = state[k]["events"]
                per_plan.setdefault(ids[k % 2], set()).add(len(evs))
                complete += bool(evs) and evs[-1] == "final"
            print(f"viewers={n}: accepted {accepted}/{n}, complete streams (ending with the final "
                  f"event) {complete}/{n}, events per stream by plan "
                  f"{ {p[:6]: sorted(v) for p, v in per_plan.items()} }, delivery of the events read after every viewer was answered {summary(latencies)}, "
                  f"of those read 2 s or more after {summary([l for t, l in timeline if t >= 2000])}, "
                  f"gateway CPU {100 * cpu / elapsed:.0f}% of one core over {elapsed:.1f} s, "
                  f"RSS max {rss_max:.0f} MB; every viewer answered {connect_s:.2f} s after the first connect; the readers received {received / 1e6:.0f} MB using "
                  f"{time.process_time() - reader0:.1f} s of CPU", flush=True)
    finally:
        gateway.stop()
        server.stop()


def main():
    bin_dir, what = sys.argv[1], sys.argv[2]
    if what == "latency":
        latency(bin_dir, int(sys.argv[3]) if len(sys.argv) > 3 else 5)
    elif what == "screenshot":
        screenshot(bin_dir, sys.argv[3])
    elif what == "viewers":
        viewers(bin_dir, [int(n) for n in sys.argv[3:]] or [50])
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main()
