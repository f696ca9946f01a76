#!/usr/bin/env python3
"""The page in a real browser: Debian's Chromium, headless, driven by
selenium through chromedriver, against the real riskplan-server (a 2 km
demo-city placed on WGS84) and the real riskplan-web, both on port 0.

In order, each step checking behaviour and numbers, never speed:
  1. the page loads and draws every layer (hillshade, density, shelter, no-fly,
     landing sites: one marker per site the server lists), the legend and the
     scale bar; the risk layer at a chosen height is drawn too;
  2. start and goal are set by clicks on the map, with a drag for the heading;
     the cursor's readout shows WGS84 on this geo-referenced map;
  3. a plan with an iteration budget streams: at least two improvements are
     drawn, their risks never increase, the plot holds one point per
     improvement, the iteration count reaches the budget, and the final
     trajectory's risk profile (EvaluateRisk per sample) gives the plan's risk;
  4. the trajectory downloads as GeoJSON, in WGS84 near the map's origin; a
     polyline drawn by three clicks is evaluated (its length, its profile);
  5. a second plan (ten minutes of budget) is cancelled from the page, and
     the server's riskplan_running_plans gauge goes from 1 back to 0;
  6. a start below the terrain: the page shows the server's error exactly as
     the riskplan CLI prints it;
  7. a screenshot, checked not to be blank;
  8. on a gateway whose one viewer slot another viewer holds, the page shows
     the gateway's refusal (--max_viewers) when its plan's stream is refused.

Usage: browser_test.py BIN_DIR OUT_DIR
"""

import glob
import http.client
import json
import math
import os
import socket
import struct
import threading
import subprocess
import sys
import tempfile
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import web_fixture as wf  # noqa: E402


def check(condition, what):
    if not condition:
        raise AssertionError(what)
    print(f"ok: {what}", flush=True)


def js(driver, expression):
    return driver.execute_script(f"return {expression};")


def png_pixels(data):
    """Width, height and the RGB(A) rows of an 8-bit non-interlaced PNG."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat = 8, b""
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and colour in (2, 6) and interlace == 0, "unexpected PNG format"
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    bpp = 3 if colour == 2 else 4
    raw = zlib.decompress(idat)
    stride = width * bpp
    rows, prev = [], bytearray(stride)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        prev = line
    return width, height, bpp, rows


def click_drag(driver, x_m, y_m, drag_px):
    """Presses the map at local (x_m, y_m), drags by drag_px = (right, up)
    pixels and releases."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    element = driver.find_element(By.ID, "map")
    point = js(driver, f"(() => {{ const p = rp.leaflet.latLngToContainerPoint([{y_m}, {x_m}]); "
                       "return [p.x, p.y]; })()")
    size = element.size
    # Selenium 4 offsets from the element's centre.
    dx, dy = point[0] - size["width"] / 2, point[1] - size["height"] / 2
    chain = ActionChains(driver).move_to_element_with_offset(element, dx, dy).click_and_hold()
    if drag_px != (0, 0):
        chain = chain.move_by_offset(drag_px[0] // 2, -drag_px[1] // 2)
        chain = chain.move_by_offset(drag_px[0] - drag_px[0] // 2, -(drag_px[1] - drag_px[1] // 2))
    chain.release().perform()


def set_value(driver, element_id, value):
    driver.execute_script(f"document.getElementById('{element_id}').value = arguments[0];",
                          str(value))


def click(driver, element_id):
    from selenium.webdriver.common.by import By
    driver.find_element(By.ID, element_id).click()


def set_endpoint(driver, which, pose):
    x, y, z, _ = pose
    set_value(driver, "altitude", z)
    click(driver, f"set-{which}")
    # 40 px right and 40 px up: a heading of 45 degrees (north-east).
    click_drag(driver, x, y, (40, 40))
    return wf.wait_for(lambda: js(driver, f"rp.endpoints.{which}"), 30, f"the {which} to be set")


def main():
    bin_dir, out_dir = sys.argv[1], sys.argv[2]
    os.makedirs(out_dir, exist_ok=True)
    work = tempfile.mkdtemp(prefix="riskplan-browser-test-")
    maps_dir = os.path.join(work, "maps")
    map_name = wf.write_geo_city(bin_dir, maps_dir)
    server = wf.start_server(bin_dir, maps_dir)
    gateway = wf.start_gateway(bin_dir, server.address, ["--heartbeat_ms=500"])
    downloads = os.path.join(work, "downloads")
    os.makedirs(downloads)
    driver = None
    try:
        metrics = wf.metrics_address(server)
        driver = wf.chromium(download_dir=downloads)
        driver.get(f"http://{gateway.address}/")
        wf.wait_for(lambda: js(driver, "window.rp && window.rp.ready === true"), 120,
                    "the page to load its map and layers")
        check(js(driver, "document.getElementById('error').hidden"), "the page loaded without error")

        # 1. Layers, legend, scale bar.
        drawn = js(driver, "rp.layersDrawn")
        for name in ("terrain (hillshade)", "population density", "shelter", "no-fly zones",
                     "landing sites"):
            check(drawn.get(name) is True, f"layer '{name}' drawn")
        images = js(driver, "Array.from(document.querySelectorAll('img.leaflet-image-layer'))"
                            ".filter(i => i.complete && i.naturalWidth > 0).length")
        check(images >= 3, f"{images} raster layers shown as images (hillshade, density, no-fly)")
        maps = json.loads(subprocess.run(
            ["curl", "-sf", f"http://{gateway.address}/api/maps"], check=True,
            capture_output=True).stdout)["maps"]
        sites = len(maps[0]["landing_sites"])
        markers = js(driver, "document.querySelectorAll('path.landing-site').length")
        check(sites > 0 and markers == sites, f"{markers} landing-site markers for {sites} sites")
        legend = js(driver, "document.getElementById('legend').textContent")
        check("population density" in legend and "no-fly zone" in legend and "landing site" in legend,
              "the legend names density, no-fly zones and landing sites")
        scale = js(driver, "document.querySelector('.leaflet-control-scale-line').textContent")
        check(scale.endswith(" m") or scale.endswith(" km"), f"a scale bar of '{scale}'")
        set_value(driver, "risk-height", 120)
        click(driver, "risk-show")
        wf.wait_for(lambda: js(driver, "rp.layersDrawn['risk layer'] === true"), 120,
                    "the risk layer")
        legend = js(driver, "document.getElementById('legend').textContent")
        check("risk M at 120 m above ground" in legend, "the risk layer at 120 m and its legend")

        # 2. Start and goal by clicks, with a drag for the heading.
        metres_per_px = js(driver, "(() => { const a = rp.leaflet.containerPointToLatLng([0, 0]),"
                                   " b = rp.leaflet.containerPointToLatLng([1, 0]);"
                                   " return b.lng - a.lng; })()")
        start = set_endpoint(driver, "start", wf.SMALL_CITY_START)
        goal = set_endpoint(driver, "goal", wf.SMALL_CITY_GOAL)
        for name, pose, want in (("start", start, wf.SMALL_CITY_START),
                                 ("goal", goal, wf.SMALL_CITY_GOAL)):
            check(abs(pose["x"] - want[0]) <= 2 * metres_per_px and
                  abs(pose["y"] - want[1]) <= 2 * metres_per_px and pose["z"] == want[2],
                  f"{name} at ({pose['x']:.1f}, {pose['y']:.1f}, {pose['z']}) by a click "
                  f"(wanted {want[:3]}, {metres_per_px:.2f} m per pixel)")
            check(abs(pose["theta"] - math.pi / 4) < 0.05,
                  f"{name} heading {pose['theta']:.3f} rad from the drag (north-east)")

        cursor = js(driver, "document.getElementById('cursor').textContent")
        check("°" in cursor, f"the cursor shows local and WGS84 positions: {cursor}")

        # 3. A plan with an iteration budget: improvements arrive and are drawn.
        iterations = 3000
        set_value(driver, "budget-ms", 0)
        set_value(driver, "budget-iterations", iterations)
        click(driver, "plan")
        wf.wait_for(lambda: js(driver, "rp.state") in ("finished", "failed"), 300,
                    "the plan to finish")
        error_text = js(driver, "document.getElementById('error').textContent")
        check(js(driver, "rp.state") == "finished", f"the plan finished (page error: {error_text!r})")
        improvements = js(driver, "rp.improvements")
        risks = [i["risk"] for i in improvements]
        check(len(improvements) >= 2, f"{len(improvements)} improvements drawn as they arrived")
        check(all(b <= a for a, b in zip(risks, risks[1:])),
              f"risk never increases: {risks[0]:.4e} ... {risks[-1]:.4e}")
        points = js(driver, "Chart.getChart('risk-chart').data.datasets[0].data.length")
        check(points == len(improvements), f"the plot holds {points} points, one per improvement")
        check(js(driver, "document.getElementById('iterations').textContent") == str(iterations),
              f"the iteration count reached {iterations}")
        check(js(driver, "document.querySelectorAll('path.best-trajectory').length") == 1,
              "the best trajectory is drawn on the map")
        final_risk = js(driver, "rp.finalTrajectory.risk")
        wf.wait_for(lambda: js(driver, "rp.profile !== null"), 120, "the final risk profile")
        profile = js(driver, "({risk: rp.profile.risk, n: rp.profile.samples.length,"
                             " drawn: Chart.getChart('profile-chart').data.datasets[0].data.length})")
        check(profile["n"] > 0 and profile["drawn"] == profile["n"],
              f"the risk profile draws {profile['drawn']} samples")
        check(abs(profile["risk"] - final_risk) <= 1e-9 * final_risk,
              f"EvaluateRisk of the final waypoints gives the plan's risk {final_risk:.6e}")
        check(final_risk == risks[-1], "the final risk is the last improvement's")

        # 4. Download the trajectory as GeoJSON.
        click(driver, "download-geojson")
        path = wf.wait_for(lambda: [p for p in glob.glob(os.path.join(downloads, "*.geojson"))],
                           60, "the GeoJSON download")[0]
        geojson = json.load(open(path))
        coords = []
        for feature in geojson.get("features", []):
            geometry = feature.get("geometry") or {}
            if geometry.get("type") == "LineString":
                coords += geometry["coordinates"]
        check(len(coords) >= 2, f"the GeoJSON ({os.path.basename(path)}) holds a line of "
                                f"{len(coords)} points")
        check(all(abs(c[0] - wf.GEO_ORIGIN[1]) < 0.05 and abs(c[1] - wf.GEO_ORIGIN[0]) < 0.05
                  for c in coords), "in WGS84, within the 2 km map placed at (49.6, 6.1)")

        # A polyline drawn by clicks, evaluated.
        driver.execute_script("rp.profile = null; document.getElementById('evaluation').textContent = '';")
        click(driver, "draw-polyline")
        corners = [(500.0, 500.0), (1000.0, 900.0), (1500.0, 1200.0)]
        set_value(driver, "altitude", 250)
        for x, y in corners:
            click_drag(driver, x, y, (0, 0))
        wf.wait_for(lambda: js(driver, "document.querySelectorAll('path.drawn-polyline').length") == 1,
                    30, "the drawn polyline")
        click(driver, "evaluate-polyline")
        wf.wait_for(lambda: js(driver, "rp.profile && rp.profile.samples.length > 0 && "
                                       "document.getElementById('evaluation').textContent"
                                       ".includes('samples')"), 120, "the polyline's evaluation")
        evaluation = js(driver, "document.getElementById('evaluation').textContent")
        length = js(driver, "rp.profile.length_m")
        want = sum(math.dist(a, b) for a, b in zip(corners, corners[1:]))
        check(abs(length - want) < 4 * 2 * metres_per_px,
              f"a 3-point polyline evaluated: {evaluation}")

        # 5. Cancel a long plan; the server's running-plans gauge drops.
        wf.wait_for(lambda: wf.metric(metrics, "riskplan_running_plans") == 0, 60,
                    "the first plan to leave the server's gauge")
        check(True, "no plan runs on the server")
        set_value(driver, "budget-ms", 600000)
        set_value(driver, "budget-iterations", 0)
        click(driver, "plan")
        wf.wait_for(lambda: js(driver, "rp.state === 'running' && rp.improvements.length > 0"), 120,
                    "the second plan to stream")
        wf.wait_for(lambda: wf.metric(metrics, "riskplan_running_plans") == 1, 60,
                    "the server's gauge to show the plan")
        check(True, "riskplan_running_plans is 1 while the plan runs")
        click(driver, "cancel")
        wf.wait_for(lambda: js(driver, "rp.state") == "cancelled", 60, "the page to say cancelled")
        check(True, "the page shows the plan cancelled")
        wf.wait_for(lambda: wf.metric(metrics, "riskplan_running_plans") == 0, 60,
                    "the server's gauge to drop")
        check(True, "riskplan_running_plans dropped to 0 after the cancel")

        # 6. The server's error, verbatim.
        bad = (wf.SMALL_CITY_START[0], wf.SMALL_CITY_START[1], 100.0, 0.785)
        start = set_endpoint(driver, "start", bad)
        set_value(driver, "budget-ms", 1000)
        click(driver, "plan")
        wf.wait_for(lambda: js(driver, "rp.state") == "failed", 60, "the plan to be refused")
        shown = js(driver, "document.getElementById('error-message').textContent")
        cli = subprocess.run(
            [os.path.join(bin_dir, "riskplan"), f"--server={server.address}", "plan",
             f"--map={map_name}",
             f"--start={start['x']!r},{start['y']!r},{start['z']!r},{start['theta']!r}",
             "--goal=" + ",".join(repr(v) for v in wf.SMALL_CITY_GOAL), "--budget_ms=1000"],
            capture_output=True, text=True, timeout=120)
        check(shown.startswith("start pose (") and "TERRAIN_COLLISION" in shown,
              f"the page shows: {shown}")
        check(f"INVALID_ARGUMENT: {shown}\n" in cli.stderr + cli.stdout,
              "exactly what the server told the CLI")
        code = js(driver, "document.getElementById('error-code').textContent")
        check(code.startswith("INVALID_ARGUMENT"), f"with its code: {code}")

        # 7. A screenshot that is not blank.
        shot = os.path.join(out_dir, "browser_test.png")
        driver.save_screenshot(shot)
        width, height, bpp, rows = png_pixels(open(shot, "rb").read())
        colours, non_white, total = set(), 0, 0
        for y in range(0, height, 4):
            row = rows[y]
            for x in range(0, width, 4):
                px = row[x * bpp:x * bpp + 3]
                colours.add(px)
                non_white += px != b"\xff\xff\xff"
                total += 1
        check(len(colours) > 100 and non_white > 0.3 * total,
              f"the screenshot {shot} ({width}x{height}) is not blank: {len(colours)} colours, "
              f"{100 * non_white / total:.0f}% not white")
        # 8. A gateway whose one viewer slot is taken: the page says so.
        full = wf.start_gateway(bin_dir, server.address, ["--max_viewers=1"])
        try:
            host, port = full.address.rsplit(":", 1)

            def post(path, body):  # a connection each: idle ones close after 2 s
                c = http.client.HTTPConnection(host, int(port), timeout=60)
                c.request("POST", path, body)
                data = c.getresponse().read()
                c.close()
                return data
            body = {"map": map_name, "budget": {"time_ms": "600000"},
                    "start": dict(zip("xyzt", wf.SMALL_CITY_START)),
                    "goal": dict(zip("xyzt", wf.SMALL_CITY_GOAL))}
            for key in ("start", "goal"):
                body[key]["theta"] = body[key].pop("t")
            held = json.loads(post("/api/plans", json.dumps(body)))["id"]
            viewer = socket.create_connection((host, int(port)), timeout=60)
            viewer.sendall(f"GET /api/plans/{held}/events HTTP/1.1\r\nHost: {host}\r\n\r\n"
                           .encode())
            check(viewer.recv(4096).startswith(b"HTTP/1.1 200"), "another viewer holds the one slot")
            # It keeps reading, as a browser would: a viewer that stops reading
            # is dropped once a write has waited 5 s.
            def drain():
                try:
                    while viewer.recv(1 << 16):
                        pass
                except OSError:
                    pass  # closed by this test
            threading.Thread(target=drain, daemon=True).start()
            driver.get(f"http://{full.address}/")
            wf.wait_for(lambda: js(driver, "window.rp && window.rp.ready === true"), 120, "the page")
            for key, pose in (("start", wf.SMALL_CITY_START), ("goal", wf.SMALL_CITY_GOAL)):
                driver.execute_script(f"rp.setEndpoint('{key}', arguments[0]);",
                                      dict(zip(("x", "y", "z", "theta"), pose)))
            set_value(driver, "budget-ms", 60000)
            click(driver, "plan")
            wf.wait_for(lambda: js(driver, "rp.state") == "failed", 120, "the refusal")
            shown = js(driver, "document.getElementById('error-message').textContent")
            check(shown == "this gateway holds at most 1 event streams at once (--max_viewers) and "
                           "all are open; try again when a viewer has closed",
                  f"the page shows the viewer limit: {shown}")
            post(f"/api/plans/{held}/cancel", "")
            post(f"/api/plans/{js(driver, 'rp.planId')}/cancel", "")
            viewer.close()
        finally:
            full.stop()
        print("PASS", flush=True)
    finally:
        if driver is not None:
            wf.quit_chromium(driver)
        gateway.stop()
        server.stop()


if __name__ == "__main__":
    main()
