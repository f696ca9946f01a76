#!/usr/bin/env python3
"""Side by side: the time from opening the page to its first map drawn, for
main's riskplan-web (its page) and this branch's, against one server on the
2 km demo-city written by riskplan-tool (as the browser test). Alternating
loads; medians. Usage: first_map_bench.py NEW_BIN OLD_WEB OLD_ASSETS LOADS"""
import os, statistics, sys, time
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import web_fixture as wf

new_bin, old_web, old_assets, loads = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
work = wf.scratch_dir("first-map-")
maps = os.path.join(work, "maps")
wf.write_local_city(new_bin, maps)
server = wf.start_server(new_bin, maps)
new = wf.start_gateway(new_bin, server.address)
old = wf.Process([old_web, "--listen=127.0.0.1:0", f"--server={server.address}",
                  f"--assets_dir={old_assets}"], "riskplan-web listening on ")
times = {"main": [], "branch": []}
driver = wf.chromium()
try:
    for k in range(loads):
        for name, gw in (("main", old), ("branch", new)):
            driver.get("about:blank")
            t0 = time.monotonic()
            driver.get(f"http://{gw.address}/")
            wf.wait_for(lambda: driver.execute_script("return window.rp && window.rp.ready === true"),
                        120, "the page")
            # rp.ready is set after the first map's layers are drawn (both versions).
            times[name].append((time.monotonic() - t0) * 1000)
            print(name, k, f"{times[name][-1]:.0f} ms", flush=True)
finally:
    wf.quit_chromium(driver)
    new.stop(); old.stop(); server.stop()
for name, v in times.items():
    print(f"{name}: median {statistics.median(v):.0f} ms over {len(v)} loads (min {min(v):.0f}, max {max(v):.0f})")
