#!/usr/bin/env python3
"""The page in a real browser: Debian's Chromium, headless, driven by
selenium through chromedriver, against the real riskplan-server (a 2 km
demo-city in local metres, and the same placed on WGS84) and the real
riskplan-web, both on port 0.

In order, each step checking behaviour and numbers, never speed:
  1. the page loads the local map in Leaflet's CRS.Simple and draws every
     layer (hillshade, density, shelter, no-fly, landing sites: one marker per
     site the server lists), the legend and the scale bar (in the map's
     metres); the risk layer at a chosen height is drawn too;
  2. start and goal are set by clicks on the map, with a drag for the heading;
     the cursor's readout shows the local position;
  3. a plan with an iteration budget streams: at least two improvements are
     drawn, their risks never increase, the plot holds one point per
     improvement, the iteration count reaches the budget, and the final
     trajectory's risk profile (EvaluateRisk per sample) gives the plan's risk;
  4. a polyline drawn by three clicks is evaluated (its length, its profile);
  5. a second plan (ten minutes of budget) is cancelled from the page, and
     the server's riskplan_running_plans gauge goes from 1 back to 0;
  6. a start below the terrain: the page shows the server's error exactly as
     the riskplan CLI prints it;
  7. a screenshot, checked not to be blank;
  8. the geo-referenced map, chosen in the page's selector, is shown in WGS84
     (Leaflet's EPSG:3857): every layer image (and the risk layer) placed at
     the server's WGS84 corners to 1e-6 degrees, the landing sites at their
     WGS84 positions, a scale bar in true metres, start and goal by clicks
     sent as start_wgs84 and goal_wgs84, a plan whose improvements never
     increase in risk and whose drawn trajectory starts and ends within a few
     metres of them, its GeoJSON download, a polyline drawn by clicks; then
     the local map again, in CRS.Simple;
  9. on a gateway whose one viewer slot another viewer holds, the page shows
     the gateway's refusal (--max_viewers) when its plan's stream is refused.

Also: no error in the browser's console on load (the favicon is there), the
charts say what they will show before there is anything to plot, the legend
explains the route, the start and the goal and folds, the improvement
history stays on the map in grey beside the newest in red, end reasons in
words, the target level of safety on the risk chart, an error box in view
at 1400x900, and a start outside the map refused before the plan starts.
The page's timings (the first map drawn after the page was opened, each map
switch) are printed and written to OUT_DIR/browser_timings.json: reported,
never asserted (docs/benchmarks.md).

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


def click_drag(driver, at, drag_px):
    """Presses the map at the page position at = (lat, lng) (on a local map
    (y, x) in metres), drags by drag_px = (right, up) pixels and releases."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    element = driver.find_element(By.ID, "map")
    point = js(driver, f"(() => {{ const p = rp.leaflet.latLngToContainerPoint([{at[0]!r}, {at[1]!r}]); "
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


def set_endpoint(driver, which, at, z):
    """Sets the start or goal by a click at the page position `at` (lat, lng)."""
    driver.execute_script(f"rp.endpoints.{which} = null;")
    set_value(driver, "altitude", z)
    click(driver, f"set-{which}")
    # 40 px right and 40 px up: a heading of 45 degrees (north-east).
    click_drag(driver, at, (40, 40))
    return wf.wait_for(lambda: js(driver, f"rp.endpoints.{which}"), 30, f"the {which} to be set")


def local_at(pose):
    """The page position of a local (x, y, ...) on a map in CRS.Simple."""
    return (pose[1], pose[0])


def select_map(driver, name):
    driver.execute_script("const s = document.getElementById('map-select'); s.value = arguments[0];"
                          " s.dispatchEvent(new Event('change'));", name)
    wf.wait_for(lambda: js(driver, f"rp.map && rp.map.name === {name!r} && "
                                   "rp.layersDrawn['landing sites'] === true"), 120,
                f"the page to show map {name}")
    check(js(driver, "document.getElementById('error').hidden"), f"map {name} shown without error")


def scale_metres_per_px(driver):
    """What the scale bar says: metres per pixel."""
    scale = js(driver, "(() => { const e = document.querySelector('.leaflet-control-scale-line');"
                       " return [e.textContent, e.getBoundingClientRect().width]; })()")
    value, unit = scale[0].split()
    return float(value) * (1000 if unit == "km" else 1) / scale[1], scale[0]


def plan_and_check(driver, iterations):
    """Plans with an iteration budget; checks the stream was drawn with risk
    never increasing. The improvements' risks."""
    set_value(driver, "budget-ms", 0)
    set_value(driver, "budget-iterations", iterations)
    driver.execute_script("rp.profile = null;")
    click(driver, "plan")
    wf.wait_for(lambda: js(driver, "rp.state") in ("finished", "failed"), 300,
                "the plan to finish")
    error_text = js(driver, "document.getElementById('error').hidden ? '' : "
                            "document.getElementById('error').textContent")
    check(js(driver, "rp.state") == "finished", f"the plan finished (page error: {error_text!r})")
    improvements = js(driver, "rp.improvements")
    risks = [i["risk"] for i in improvements]
    check(len(improvements) >= 2, f"{len(improvements)} improvements drawn as they arrived")
    check(all(b <= a for a, b in zip(risks, risks[1:])),
          f"risk never increases: {risks[0]:.4e} ... {risks[-1]:.4e}")
    return risks


def run_plan(driver, iterations):
    """Plans with an iteration budget and waits for the end; the page's state."""
    set_value(driver, "budget-ms", 0)
    set_value(driver, "budget-iterations", iterations)
    driver.execute_script("rp.profile = null;")
    click(driver, "plan")
    wf.wait_for(lambda: js(driver, "rp.state") in ("finished", "failed"), 300,
                "the plan to finish")
    error_text = js(driver, "document.getElementById('error').hidden ? '' : "
                            "document.getElementById('error').textContent")
    check(js(driver, "rp.state") == "finished", f"the plan finished (page error: {error_text!r})")


def check_limits_and_front(driver):
    """Endurance, the enforced target level of safety and the risk-time front
    set on the page: every trajectory shown honours them, the front has
    points and a click on one draws its route; an endurance no route can
    meet ends with the server's note on the page."""
    from selenium.webdriver.common.by import By

    endurance_s, tls = 130, 8e-6
    set_value(driver, "max-flight-time", endurance_s)
    set_value(driver, "target-los", tls)
    driver.execute_script("document.getElementById('enforce-los').checked = true;"
                          "document.getElementById('pareto').checked = true;")
    run_plan(driver, 3000)
    limits = js(driver, "rp.lastPlanRequest.limits")
    check(limits == {"max_flight_time_s": endurance_s, "max_risk_per_flight_hour": tls,
                     "pareto": True}, f"the plan was sent with the page's limits: {limits}")
    improvements = js(driver, "rp.improvements")
    check(len(improvements) >= 1, f"{len(improvements)} improvements within the limits")
    for i in improvements:
        if not (i["flight_time_s"] <= endurance_s and i["risk_per_flight_hour"] <= tls):
            raise AssertionError(f"an improvement outside the limits: {i}")
    check(True, f"every improvement flies at most {endurance_s} s (longest "
                f"{max(i['flight_time_s'] for i in improvements):.1f} s) and carries at most "
                f"{tls:g} per flight hour (highest "
                f"{max(i['risk_per_flight_hour'] for i in improvements):.2e})")
    final = js(driver, "rp.finalTrajectory")
    shown = js(driver, "document.getElementById('risk').textContent")
    shown_time = float(shown.split("flight time ")[1].split(" s")[0])
    shown_rph = float(shown.split(" s, ")[1].split(" per flight hour")[0])
    check(shown_time <= endurance_s and abs(shown_time - final["flight_time_s"]) <= 0.05 and
          shown_rph <= tls, f"the page shows a flight time within the endurance and a risk per "
                            f"flight hour within the target: {shown!r}")
    target = js(driver, "Chart.getChart('risk-chart').data.datasets[1]")
    check(f"target level of safety {tls:.0e}".replace("e-06", "e-6") in target["label"] and
          abs(target["data"][-1]["y"] - tls * final["flight_time_s"] / 3600) <=
          1e-9 * target["data"][-1]["y"],
          f"the risk chart draws the enforced target ({target['label']})")
    front = js(driver, "rp.front.map((t) => ({t: t.flight_time_s, r: t.risk, "
                       "n: t.path.length}))")
    circles = driver.find_elements(By.CSS_SELECTOR, "#front-chart circle.front-point")
    check(js(driver, "!document.getElementById('front-box').hidden") and len(front) >= 2 and
          len(circles) == len(front),
          f"the front chart shows {len(circles)} points ({len(front)} in the final front)")
    check(all(p["t"] <= endurance_s and p["r"] / (p["t"] / 3600) <= tls * (1 + 1e-9)
              for p in front), "every point of the front is within the limits")
    check(all(a["t"] <= b["t"] and a["r"] >= b["r"] for a, b in zip(front, front[1:])),
          "the front goes by increasing flight time and decreasing risk")
    k = len(circles) // 2
    circles[k].click()
    wf.wait_for(lambda: js(driver, "rp.frontShown") == k, 30, "the clicked point's route")
    drawn = js(driver, "rp.frontLayer.getLayers()[0].getLatLngs().map((p) => [p.lat, p.lng])")
    want = js(driver, f"frame.pathOf(rp.front[{k}]).map((p) => Array.isArray(p) ? p : [p.lat, p.lng])")
    check(drawn == want and len(drawn) == front[k]["n"] and
          js(driver, "document.querySelectorAll('path.front-route').length") == 1,
          f"clicking front point {k + 1} of {len(front)} ({front[k]['t']:.1f} s, risk "
          f"{front[k]['r']:.3e}) draws that route ({len(drawn)} points) in blue")
    other = (k + 1) % len(circles)
    circles[other].click()
    wf.wait_for(lambda: js(driver, "rp.frontShown") == other, 30, "another point's route")
    check(js(driver, "document.querySelectorAll('path.front-route').length") == 1,
          "a click on another point replaces the route shown")

    # An endurance below any route's flight time: the server's note, no trajectory.
    set_value(driver, "max-flight-time", 60)
    driver.execute_script("document.getElementById('enforce-los').checked = false;"
                          "document.getElementById('pareto').checked = false;")
    run_plan(driver, 3000)
    note = js(driver, "document.getElementById('limits-note').hidden ? '' : "
                      "document.getElementById('limits-note').textContent")
    check(note.startswith("no trajectory within the endurance (max_flight_time_s = 60 s): "
                          "the fastest trajectory found flies ") and
          float(note.rsplit(" ", 2)[1]) > 60,
          f"an endurance of 60 s is refused with the server's note: {note!r}")
    check(js(driver, "rp.improvements.length") == 0 and
          js(driver, "document.querySelectorAll('path.best-trajectory').length") == 0 and
          js(driver, "document.getElementById('risk').textContent") == "\u2013",
          "and no trajectory is drawn or shown")
    state = js(driver, "document.getElementById('state').textContent")
    check(state.startswith("finished: no admissible trajectory"), f"the end in words: {state!r}")
    set_value(driver, "max-flight-time", 0)
    set_value(driver, "target-los", "1e-6")


def mission_plan(corners, waypoint_x=1000.0, riskplan=None):
    """A QGroundControl .plan on the geo-referenced city: takeoff, a waypoint
    (yaw null: riskplan chooses), land; `riskplan` as its riskplan section."""
    def item(command, jump, x, y, alt):
        lat, lon = wf.bilinear_wgs84(corners, x, y)
        return {"type": "SimpleItem", "command": command, "frame": 0, "doJumpId": jump,
                "autoContinue": True, "params": [0, 0, 0, None, lat, lon, alt]}
    home = wf.bilinear_wgs84(corners, 300, 375)
    plan = {"fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
            "mission": {"version": 2, "firmwareType": 12, "vehicleType": 1, "cruiseSpeed": 18,
                        "hoverSpeed": 5, "plannedHomePosition": [home[0], home[1], 200],
                        "items": [item(22, 1, 300, 375, 240), item(16, 2, waypoint_x, 900, 250),
                                  item(21, 3, 1700, 1625, 250)]},
            "geoFence": {"version": 2, "circles": [], "polygons": []},
            "rallyPoints": {"version": 2, "points": []}}
    if riskplan is not None:
        plan["riskplan"] = riskplan
    return plan


def check_mission_upload_and_download(driver, work, downloads, corners, geo_name, local_name):
    """A .plan uploaded on the page (shown on the local map: the page moves to
    the geo-referenced map that holds it) fills the form with its limits and
    is planned leg by leg through its waypoint; the planned mission downloads
    as a .plan with the mission's own items and its limits, which the gateway
    reads back as the same mission; a file with a loiter is refused naming
    the item."""
    from selenium.webdriver.common.by import By

    select_map(driver, local_name)
    path = os.path.join(work, "survey.plan")
    with open(path, "w") as f:
        json.dump(mission_plan(corners, riskplan={"limits": {"max_flight_time_s": 400}}), f)
    set_value(driver, "budget-ms", 0)
    set_value(driver, "budget-iterations", 800)
    set_value(driver, "max-flight-time", 0)
    driver.execute_script("rp.improvements = []; rp.finalTrajectory = null; rp.profile = null;")
    driver.find_element(By.ID, "mission-file").send_keys(path)
    wf.wait_for(lambda: js(driver, "rp.mission !== null && rp.mission.legEnds !== null") or
                js(driver, "rp.state === 'failed'"), 300, "the uploaded mission to be planned")
    error_text = js(driver, "document.getElementById('error').hidden ? '' : "
                            "document.getElementById('error').textContent")
    check(js(driver, "rp.state") == "finished" and not error_text,
          f"the uploaded mission was planned (page error: {error_text!r})")
    check(js(driver, "rp.map.name") == geo_name and js(driver, "rp.crs") == "EPSG:3857",
          f"the page moved to {geo_name}, the geo-referenced map that holds the mission")
    described = js(driver, "document.getElementById('mission-text').textContent")
    check(described == "survey.plan: 3 points (1 takeoff, 1 waypoint, 1 land), 2 legs; limits "
                       "from its riskplan section: endurance 400 s",
          f"the page describes the mission: {described!r}")
    check(js(driver, "document.getElementById('max-flight-time').value") == "400" and
          js(driver, "rp.lastPlanRequest.limits") == {"max_flight_time_s": 400},
          "the endurance of the file's riskplan section filled the form and went with the plan")
    check(js(driver, "document.querySelectorAll('path.mission-point').length") == 3,
          "the mission's three points are drawn on the map")
    progress = js(driver, "document.getElementById('mission-progress').textContent")
    check(progress == "the mission's 2 legs planned", f"the page says: {progress!r}")
    t = js(driver, "rp.finalTrajectory")
    ends = js(driver, "rp.mission.legEnds")
    want = [wf.bilinear_wgs84(corners, x, y) for x, y in ((300, 375), (1000, 900), (1700, 1625))]
    at = [0, ends[0], ends[1]]
    off = [wf.ground_distance_m((t["waypoints_wgs84"][k]["lat_deg"], t["waypoints_wgs84"][k]["lon_deg"]), w)
           for k, w in zip(at, want)]
    check(len(ends) == 2 and ends[1] == len(t["waypoints"]) - 1 and max(off) < 1.0,
          f"the trajectory flies from the takeoff through the waypoint to the landing "
          f"(within {max(off):.2f} m of each)")
    check(t["flight_time_s"] <= 400, f"the mission flies {t['flight_time_s']:.1f} s, within its "
                                     "400 s endurance")
    shown = js(driver, "document.getElementById('risk').textContent")
    check(f"flight time {t['flight_time_s']:.1f} s" in shown, f"the page shows the mission: {shown!r}")
    check(js(driver, "document.querySelectorAll('path.best-trajectory').length") == 1,
          "the joined trajectory is drawn")

    # Downloaded: the mission written back, with its limits.
    for old in glob.glob(os.path.join(downloads, "*.plan")):
        os.unlink(old)
    click(driver, "download-plan")
    path = wf.wait_for(lambda: [p for p in glob.glob(os.path.join(downloads, "*.plan"))
                                if os.path.getsize(p) > 0], 60, "the .plan download")[0]
    written = wf.wait_for(lambda: _read_json(path), 30, "the downloaded .plan to be complete")
    items = written["mission"]["items"]
    check(os.path.basename(path) == f"riskplan-mission-{geo_name}.plan" and
          written["fileType"] == "Plan" and written["version"] == 1 and
          written["mission"]["version"] == 2 and items[0]["command"] == 22 and
          items[-1]["command"] == 21 and len(written["riskplan"]["mission_items"]) == 3,
          f"the downloaded {os.path.basename(path)} holds the takeoff, {len(items) - 2} route "
          "items and the landing, the mission's own three listed")
    check(written["riskplan"]["limits"]["max_flight_time_s"] == 400, "and the mission's limits")
    host_port = js(driver, "location.host")
    answer = subprocess.run(
        ["curl", "-s", "-H", "Content-Type: text/plain", "--data-binary", f"@{path}",
         f"http://{host_port}/api/mission/parse"], check=True, capture_output=True).stdout
    again = json.loads(answer)
    check("points" in again, f"the gateway reads the downloaded file: {answer[:300]!r}")
    check([p["kind"] for p in again["points"]] == ["takeoff", "waypoint", "land"] and
          again["limits"]["max_flight_time_s"] == 400,
          "the gateway reads it back as the same mission with its limits")

    # A file riskplan cannot plan: the error names the item; nothing is planned.
    bad = mission_plan(corners)
    bad["mission"]["items"][1]["command"] = 19
    path = os.path.join(work, "loiter.plan")
    with open(path, "w") as f:
        json.dump(bad, f)
    plan_before = js(driver, "rp.planId")
    driver.execute_script("document.getElementById('error').hidden = true;")
    driver.find_element(By.ID, "mission-file").send_keys(path)
    wf.wait_for(lambda: not js(driver, "document.getElementById('error').hidden"), 60,
                "the loiter to be refused")
    shown = js(driver, "document.getElementById('error-message').textContent")
    check(shown.startswith("mission item 1 (doJumpId 2): command 19 (NAV_LOITER_TIME) cannot be "
                           "planned by riskplan") and js(driver, "rp.planId") == plan_before and
          js(driver, "document.getElementById('error-code').textContent") ==
          "INVALID_ARGUMENT (gateway):", f"a loiter is refused naming the item: {shown!r}")
    driver.execute_script("document.getElementById('error').hidden = true;")
    set_value(driver, "max-flight-time", 0)


def _read_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


# The route's display path (local metres) with the arc length of each point:
# [[x, y, s], ...] (straight lines between samples, as the page splits it).
ROUTE_ARC_JS = """(route) => { let s = 0; return route.path.map((p, k) => {
  if (k > 0) { const q = route.path[k - 1]; s += Math.hypot(p.x - q.x, p.y - q.y, p.z - q.z); }
  return [p.x, p.y, s]; }); }"""


def check_flight(driver):
    """Flight mode on the local map: the gateway flies the page's start and
    goal; a zone placed by a click across the route ahead gives a new version
    whose route avoids it and whose committed prefix begins with the one
    before; a zone on the goal raises an alert with its emergency landing
    site; the flight ends from the page."""
    set_value(driver, "budget-ms", 1000)
    set_value(driver, "budget-iterations", 0)
    set_value(driver, "flight-speedup", 4)
    set_value(driver, "zone-radius", 120)
    click(driver, "fly")
    wf.wait_for(lambda: js(driver, "rp.flight && (rp.flight.versions.length > 0 || rp.flight.ended)"),
                120, "the flight's first plan version")
    check(js(driver, "rp.flight.ended") is None and
          js(driver, "rp.flight.versions[0].reason") == "FLIGHT_REASON_OPENED",
          "the flight opened with its first plan version")
    wf.wait_for(lambda: js(driver, "rp.flight.position && rp.flight.position.progress_m > 0 && "
                                   "document.querySelectorAll('path.aircraft').length === 1"),
                60, "the aircraft to move")
    check(js(driver, "document.querySelectorAll('path.flight-committed').length") == 1 and
          js(driver, "document.querySelectorAll('path.flight-remainder').length") == 1,
          "the committed prefix and the remainder are drawn, each its own line")

    # A zone across the route ahead: on the latest route, half way between
    # the commit point and the goal.
    v = js(driver, "rp.flight.versions[rp.flight.versions.length - 1]")
    arc = driver.execute_script(f"return ({ROUTE_ARC_JS})(arguments[0]);", v["route"])
    total = arc[-1][2]
    target = v["committed_until_m"] + 0.5 * (total - v["committed_until_m"])
    centre = min(arc, key=lambda p: abs(p[2] - target))
    check(total - v["committed_until_m"] > 600,
          f"the remainder ahead is {total - v['committed_until_m']:.0f} m long")
    click(driver, "place-zone")
    click_drag(driver, (centre[1], centre[0]), (0, 0))
    wf.wait_for(lambda: js(driver, "rp.flight.zones['zone-1'] !== undefined"), 60, "the zone to be sent")
    zone = js(driver, "rp.flight.zones['zone-1']")
    check(math.dist((zone["x"], zone["y"]), centre[:2]) < 5 and zone["radius_m"] == 120 and
          js(driver, "document.querySelectorAll('path.flight-zone').length") == 1,
          f"a zone of 120 m placed by a click at ({zone['x']:.0f}, {zone['y']:.0f}), on the route "
          f"{target - v['committed_until_m']:.0f} m past the commit point")
    before = [p for p in arc if math.dist(p[:2], (zone["x"], zone["y"])) <= zone["radius_m"]]
    check(len(before) > 0, f"the route before it crossed the zone ({len(before)} path points inside)")
    index = wf.wait_for(lambda: js(driver, "(() => { const k = rp.flight.versions.findIndex((v) => "
                                           "v.active_zones.includes('zone-1')); return k > 0 ? k : null; })()")
                        or (js(driver, "rp.flight.ended") and -1), 120,
                        "a plan version with the zone")
    check(index > 0, f"version {index + 1} came with the zone in force")
    new, old = js(driver, f"[rp.flight.versions[{index}], rp.flight.versions[{index - 1}]]")
    check(new["reason"] == "FLIGHT_REASON_ZONE_ADDED", f"made because the zone was added ({new['reason']})")
    inside = [p for p in new["route"]["path"]
              if math.dist((p["x"], p["y"]), (zone["x"], zone["y"])) <= zone["radius_m"]]
    check(not inside, f"its route avoids the zone: none of its {len(new['route']['path'])} path points "
                      f"within {zone['radius_m']} m of the centre")
    check(len(new["committed"]) >= len(old["committed"]) and
          new["committed"][:len(old["committed"])] == old["committed"],
          f"the committed prefix is unchanged: the new version's {len(new['committed'])} committed "
          f"poses begin with the {len(old['committed'])} before")
    wf.wait_for(lambda: "a zone was added" in js(driver, "document.getElementById('flight-state').textContent")
                or js(driver, "rp.flight.versions.length") > index + 1, 30, "the page to show the version")
    check(js(driver, "document.querySelectorAll('path.flight-committed').length") == 1 and
          js(driver, "document.querySelectorAll('path.flight-remainder').length") == 1,
          "the new version drawn: committed prefix and remainder")

    # A polygon zone by three clicks, off the route (the map's north-west
    # corner): sent in the map's frame, drawn, and in force in a later version.
    if not js(driver, "rp.flight.ended"):
        click(driver, "polygon-zone")
        triangle = [(150.0, 1750.0), (350.0, 1750.0), (250.0, 1900.0)]
        for x, y in triangle:
            click_drag(driver, (y, x), (0, 0))
        check(js(driver, "document.getElementById('polygon-zone').textContent") ==
              "Send the polygon (3 vertices)", "three vertices drawn")
        click(driver, "polygon-zone")
        wf.wait_for(lambda: js(driver, "rp.flight.zones['zone-2'] !== undefined"), 60,
                    "the polygon zone to be sent")
        vertices = js(driver, "rp.flight.zones['zone-2'].vertices")
        check(len(vertices) == 3 and all(math.dist((v["x"], v["y"]), w) < 5 for v, w in zip(vertices, triangle)) and
              js(driver, "document.querySelectorAll('path.flight-zone').length") == 2,
              f"a polygon zone of 3 vertices placed by clicks: {[(round(v['x']), round(v['y'])) for v in vertices]}")
        wf.wait_for(lambda: js(driver, "rp.flight.versions.some((v) => v.active_zones.includes('zone-2'))")
                    or js(driver, "rp.flight.ended"), 120, "a version with the polygon zone")
        check(js(driver, "rp.flight.versions.some((v) => v.active_zones.includes('zone-2'))"),
              "a later version has the polygon zone in force")

    # A zone on the goal: no remainder can reach it; the alert names the
    # emergency landing site.
    if not js(driver, "rp.flight.ended"):
        driver.execute_script(f"rp.addZoneAt({wf.SMALL_CITY_GOAL[0]!r}, {wf.SMALL_CITY_GOAL[1]!r});")
        alert = wf.wait_for(lambda: js(driver, "rp.flight.alerts.length > 0 && rp.flight.alerts[0]")
                            or js(driver, "rp.flight.ended"), 120, "an alert")
        check(isinstance(alert, dict) and alert.get("kind") == "FLIGHT_ALERT_NO_REMAINDER" and
              "NO_FLY_ZONE" in alert["detail"], f"an alert: {alert.get('detail') if isinstance(alert, dict) else alert}")
        shown = wf.wait_for(lambda: js(driver, "document.getElementById('flight-alerts').textContent"), 30,
                            "the alert on the page")
        landing = alert.get("landing")
        if landing and landing.get("site_pose"):
            check("emergency landing at" in shown and
                  js(driver, "document.querySelectorAll('path.emergency-landing').length") == 1,
                  f"the page shows the alert and its emergency landing site: {shown!r}")
        else:
            check(shown.startswith("ALERT"), f"the page shows the alert: {shown!r}")

    if not js(driver, "rp.flight.ended"):
        click(driver, "end-flight")
    ended = wf.wait_for(lambda: js(driver, "rp.flight.ended"), 60, "the flight to end")
    check(ended.get("message") in ("ended from the page", "the aircraft reached the goal"),
          f"the flight ended: {ended}")
    check(js(driver, "document.getElementById('fly').disabled") is False, "and may fly again")


def main():
    bin_dir, out_dir = sys.argv[1], sys.argv[2]
    os.makedirs(out_dir, exist_ok=True)
    work = wf.scratch_dir("riskplan-browser-test-")
    maps_dir = os.path.join(work, "maps")
    map_name = wf.write_local_city(bin_dir, maps_dir)
    geo_name = wf.write_geo_city(bin_dir, maps_dir)
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
        timings = {"first_map_ms": js(driver, "rp.timings.firstMapMs")}
        print(f"timing: the first map drawn {timings['first_map_ms']:.0f} ms after the page was "
              "opened", flush=True)
        severe = [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE"]
        check(not severe, f"no error in the browser's console on load: {severe}")
        check(js(driver, "document.getElementById('risk-chart-box').hidden && "
                         "document.getElementById('profile-chart-box').hidden"),
              "no empty chart before there is anything to plot")
        placeholder = js(driver, "document.getElementById('risk-chart-empty').innerText")
        check("best risk against planner time" in placeholder,
              f"the risk chart's place says what it will show: {placeholder!r}")
        check(js(driver, "rp.map.name") == map_name and js(driver, "rp.crs") == "Simple" and
              js(driver, "rp.leaflet.options.crs === L.CRS.Simple"),
              f"the local map {map_name} is shown in Leaflet's CRS.Simple")

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
        local_map = next(m for m in maps if m["name"] == map_name)
        check(not local_map.get("geo") and not local_map.get("bounds_wgs84"),
              f"{map_name} has no geo-reference")
        sites = len(local_map["landing_sites"])
        markers = js(driver, "document.querySelectorAll('path.landing-site').length")
        check(sites > 0 and markers == sites, f"{markers} landing-site markers for {sites} sites")
        legend = js(driver, "document.getElementById('legend').textContent")
        check("population density" in legend and "no-fly zone" in legend and "landing site" in legend,
              "the legend names density, no-fly zones and landing sites")
        for item in ("start, its line the heading", "goal, its line the heading",
                     "best trajectory so far", "earlier improvements"):
            check(item in legend, f"the legend explains '{item}'")
        open_height = js(driver, "document.getElementById('legend-box').getBoundingClientRect().height")
        driver.find_element("css selector", "#legend-box > summary").click()
        folded = js(driver, "[document.getElementById('legend-box').open, "
                            "document.getElementById('legend-box').getBoundingClientRect().height]")
        check(folded[0] is False and folded[1] < open_height / 3,
              f"the legend folds: {open_height:.0f} px open, {folded[1]:.0f} px folded")
        driver.find_element("css selector", "#legend-box > summary").click()
        check(js(driver, "document.getElementById('legend-box').open"), "and opens again")
        scale = js(driver, "document.querySelector('.leaflet-control-scale-line').textContent")
        check(scale.endswith(" m") or scale.endswith(" km"), f"a scale bar of '{scale}'")
        bar_m_per_px, scale = scale_metres_per_px(driver)
        map_m_per_px = wf.SMALL_CITY_SIZE_M / js(
            driver, f"rp.leaflet.latLngToContainerPoint([0, {wf.SMALL_CITY_SIZE_M}]).x - "
                    "rp.leaflet.latLngToContainerPoint([0, 0]).x")
        check(abs(bar_m_per_px / map_m_per_px - 1) < 0.02,
              f"the scale bar '{scale}' measures the map's metres ({bar_m_per_px:.3f} m per pixel, "
              f"the map {map_m_per_px:.3f})")
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
        start = set_endpoint(driver, "start", local_at(wf.SMALL_CITY_START), wf.SMALL_CITY_START[2])
        goal = set_endpoint(driver, "goal", local_at(wf.SMALL_CITY_GOAL), wf.SMALL_CITY_GOAL[2])
        for name, pose, want in (("start", start, wf.SMALL_CITY_START),
                                 ("goal", goal, wf.SMALL_CITY_GOAL)):
            check(abs(pose["x"] - want[0]) <= 2 * metres_per_px and
                  abs(pose["y"] - want[1]) <= 2 * metres_per_px and pose["z"] == want[2],
                  f"{name} at ({pose['x']:.1f}, {pose['y']:.1f}, {pose['z']}) by a click "
                  f"(wanted {want[:3]}, {metres_per_px:.2f} m per pixel)")
            check(abs(pose["theta"] - math.pi / 4) < 0.05,
                  f"{name} heading {pose['theta']:.3f} rad from the drag (north-east)")

        cursor = js(driver, "document.getElementById('cursor').textContent")
        check(cursor.startswith("x, y: ") and "°" not in cursor,
              f"the cursor shows the local position: {cursor}")

        # 3. A plan with an iteration budget: improvements arrive and are drawn.
        iterations = 3000
        risks = plan_and_check(driver, iterations)
        check("start" in js(driver, "rp.lastPlanRequest") and
              "start_wgs84" not in js(driver, "rp.lastPlanRequest"),
              "the plan's start and goal were sent in local metres")
        points = js(driver, "Chart.getChart('risk-chart').data.datasets[0].data.length")
        check(points == len(risks), f"the plot holds {points} points, one per improvement")
        check(js(driver, "document.getElementById('iterations').textContent") == str(iterations),
              f"the iteration count reached {iterations}")
        check(js(driver, "document.querySelectorAll('path.best-trajectory').length") == 1,
              "the best trajectory is drawn on the map")
        # The improvements before it stay on the map in grey (at most 30).
        history = js(driver, "Array.from(document.querySelectorAll('path.history-trajectory'))"
                             ".map((p) => p.getAttribute('stroke'))")
        check(len(history) == min(len(risks) - 1, 30) and len(history) >= 1 and
              all(c == "#888" for c in history),
              f"{len(history)} earlier improvements drawn in grey beside the newest in red "
              f"({len(risks)} improvements)")
        state = js(driver, "document.getElementById('state').textContent")
        check(state == f"finished: the budget was used up, {iterations} iterations",
              f"the end reason in words: {state!r}")
        side = js(driver, "document.getElementById('side').innerText")
        check("BUDGET_EXHAUSTED" not in side and "RISK_RRT_STAR" not in side,
              "no enum name in the side panel's text")
        target = js(driver, "(() => { const c = Chart.getChart('risk-chart'); return {"
                            " label: c.data.datasets[1].label, ys: c.data.datasets[1].data.map((p) => p.y),"
                            " shown: !document.getElementById('risk-chart-box').hidden}; })()")
        flight_s = js(driver, "rp.finalTrajectory.flight_time_s")
        check(target["shown"] and len(target["ys"]) == points and
              "target level of safety 1e-6 per flight hour" in target["label"] and
              abs(target["ys"][-1] - 1e-6 * flight_s / 3600) <= 1e-9 * target["ys"][-1],
              f"the risk chart draws the target level of safety for each trajectory's flight time "
              f"(last: {target['ys'][-1]:.3e} for {flight_s:.1f} s)")
        final_risk = js(driver, "rp.finalTrajectory.risk")
        wf.wait_for(lambda: js(driver, "rp.profile !== null"), 120, "the final risk profile")
        profile = js(driver, "({risk: rp.profile.risk, n: rp.profile.samples.length,"
                             " drawn: Chart.getChart('profile-chart').data.datasets[0].data.length})")
        check(profile["n"] > 0 and profile["drawn"] == profile["n"],
              f"the risk profile draws {profile['drawn']} samples")
        check(abs(profile["risk"] - final_risk) <= 1e-9 * final_risk,
              f"EvaluateRisk of the final waypoints gives the plan's risk {final_risk:.6e}")
        check(final_risk == risks[-1], "the final risk is the last improvement's")

        # 3b. Endurance, target level of safety and the risk-time front.
        check_limits_and_front(driver)

        # 3c. Flight mode: zones placed in flight, versions, an alert.
        check_flight(driver)

        # 4. A polyline drawn by clicks, evaluated.
        driver.execute_script("rp.profile = null; document.getElementById('evaluation').textContent = '';")
        click(driver, "draw-polyline")
        corners_m = [(500.0, 500.0), (1000.0, 900.0), (1500.0, 1200.0)]
        set_value(driver, "altitude", 250)
        for x, y in corners_m:
            click_drag(driver, (y, x), (0, 0))
        wf.wait_for(lambda: js(driver, "document.querySelectorAll('path.drawn-polyline').length") == 1,
                    30, "the drawn polyline")
        click(driver, "evaluate-polyline")
        wf.wait_for(lambda: js(driver, "rp.profile && rp.profile.samples.length > 0 && "
                                       "document.getElementById('evaluation').textContent"
                                       ".includes('samples')"), 120, "the polyline's evaluation")
        evaluation = js(driver, "document.getElementById('evaluation').textContent")
        length = js(driver, "rp.profile.length_m")
        want = sum(math.dist(a, b) for a, b in zip(corners_m, corners_m[1:]))
        check(abs(length - want) < 4 * 2 * metres_per_px,
              f"a 3-point polyline evaluated: {evaluation}")

        # 4b. The same polyline in a wind set on the page: the answer's wind
        # drawn as an arrow, each sample's ground speed, and a bad wind refused
        # with the server's message naming the field.
        def evaluate_drawn_polyline():
            click(driver, "draw-polyline")
            for x, y in corners_m:
                click_drag(driver, (y, x), (0, 0))
            click(driver, "evaluate-polyline")

        set_value(driver, "wind-speed", 8)
        set_value(driver, "wind-from", 270)
        driver.execute_script("rp.profile = null;")
        evaluate_drawn_polyline()
        wf.wait_for(lambda: js(driver, "rp.profile && rp.profile.wind && "
                                       "rp.profile.wind.speed_mps === 8"), 120,
                    "the polyline's evaluation in wind")
        arrow = js(driver, "document.getElementById('wind-arrow').textContent")
        check("wind 8.0 m/s" in arrow and "from 270" in arrow, f"the wind's arrow: {arrow!r}")
        speeds = js(driver, "rp.profile.samples.map(s => s.ground_speed_mps)")
        check(min(speeds) >= 18 - 8 - 1e-9 and max(speeds) <= 18 + 8 + 1e-9 and
              max(speeds) > 18, f"samples' ground speeds {min(speeds):.2f} .. {max(speeds):.2f} m/s")
        check("flight time" in js(driver, "document.getElementById('evaluation').textContent"),
              "the evaluation gives its flight time in wind")
        set_value(driver, "wind-speed", 20)
        evaluate_drawn_polyline()
        wf.wait_for(lambda: not js(driver, "document.getElementById('error').hidden"), 60,
                    "the too-strong wind to be refused")
        shown = js(driver, "document.getElementById('error-message').textContent")
        check("wind.from.speed_mps has value 20" in shown, f"the server's message: {shown!r}")
        set_value(driver, "wind-speed", 0)
        driver.execute_script("document.getElementById('error').hidden = true;")

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
        start = set_endpoint(driver, "start", local_at(bad), bad[2])
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
        box = js(driver, "(() => { const r = document.getElementById('error').getBoundingClientRect();"
                         " return [r.top, r.bottom, window.innerHeight, window.innerWidth]; })()")
        check(box[0] >= 0 and box[1] <= box[2],
              f"the error box is in view at {box[3]}x{box[2]} (top {box[0]:.0f}, bottom {box[1]:.0f})")
        # A start outside the map: the gateway refuses it before any plan.
        plans_before = js(driver, "rp.planId")
        driver.execute_script("rp.setEndpoint('start', {x: 5000, y: 375, z: 240, theta: 0.785});")
        click(driver, "plan")
        wf.wait_for(lambda: js(driver, "rp.state") == "failed" and not js(
            driver, "document.getElementById('error').hidden"), 60, "the refusal")
        shown = js(driver, "document.getElementById('error-message').textContent")
        check(shown.startswith("start (x, y) = (5000.0, 375.0) m is outside map") and
              js(driver, "rp.planId") == plans_before and
              js(driver, "document.getElementById('error-code').textContent") ==
              "INVALID_ARGUMENT (gateway):",
              f"a start outside the map is refused before a plan starts: {shown}")

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
        # 8. The geo-referenced map, in WGS84: Leaflet's default CRS (EPSG:3857).
        select_map(driver, geo_name)
        wf.wait_for(lambda: js(driver, "rp.timings.mapSwitchMs.length") >= 1, 60, "the switch's time")
        timings["switch_to_geo_map_ms"] = js(driver, "rp.timings.mapSwitchMs[0]")
        print(f"timing: the switch to {geo_name} drawn in {timings['switch_to_geo_map_ms']:.0f} ms",
              flush=True)
        check(js(driver, "rp.crs") == "EPSG:3857" and
              js(driver, "rp.leaflet.options.crs === L.CRS.EPSG3857"),
              f"the geo-referenced map {geo_name} is shown in EPSG:3857, a new Leaflet map")
        geo = next(m for m in maps if m["name"] == geo_name)
        corners = [(c["lat_deg"], c["lon_deg"]) for c in geo["bounds_wgs84"]["corners"]]

        def box(c):
            """The latitude/longitude box the page places a layer image on:
            each edge at the mean of its two corners (SW, SE, NE, NW)."""
            return [(c[0][0] + c[1][0]) / 2, (c[0][1] + c[3][1]) / 2,
                    (c[2][0] + c[3][0]) / 2, (c[1][1] + c[2][1]) / 2]

        def image_bounds():
            return js(driver, "Object.fromEntries(Object.entries(rp.overlays)"
                              ".filter(([n, l]) => l instanceof L.ImageOverlay).map(([n, l]) => {"
                              " const b = l.getBounds();"
                              " return [n, [b.getSouth(), b.getWest(), b.getNorth(), b.getEast()]]; }))")
        want = box(corners)
        # Each corner of the map lies within a metre of the box's (the local
        # grid's edges are not quite parallels and meridians).
        for c, b in zip(corners, [(want[0], want[1]), (want[0], want[3]), (want[2], want[3]),
                                  (want[2], want[1])]):
            check(wf.ground_distance_m(c, b) < 1.0,
                  f"corner {c} within {wf.ground_distance_m(c, b):.2f} m of the layers' box")
        bounds = image_bounds()
        for name in ("terrain (hillshade)", "population density", "shelter", "no-fly zones"):
            error = max(abs(a - b) for a, b in zip(bounds[name], want))
            check(error <= 1e-6, f"layer '{name}' at the map's bounds_wgs84 (off by {error:.1e} deg)")
        markers = js(driver, "rp.overlays['landing sites'].getLayers()"
                             ".map((m) => [m.getLatLng().lat, m.getLatLng().lng])")
        sites = [(s["wgs84"]["lat_deg"], s["wgs84"]["lon_deg"]) for s in geo["landing_sites"]]
        check(len(markers) == len(sites) and
              all(abs(a[0] - b[0]) < 1e-9 and abs(a[1] - b[1]) < 1e-9 for a, b in zip(markers, sites)),
              f"{len(markers)} landing sites at their WGS84 positions")
        bar_m_per_px, scale = scale_metres_per_px(driver)
        # The map's 2 km south edge on the screen: true metres on the ground.
        edge_px = js(driver, f"rp.leaflet.latLngToContainerPoint({list(corners[0])})"
                             f".distanceTo(rp.leaflet.latLngToContainerPoint({list(corners[1])}))")
        map_m_per_px = wf.SMALL_CITY_SIZE_M / edge_px
        check(abs(bar_m_per_px / map_m_per_px - 1) < 0.02,
              f"the scale bar '{scale}' gives true metres ({bar_m_per_px:.3f} m per pixel; the "
              f"map's 2 km edge {map_m_per_px:.3f})")
        set_value(driver, "risk-height", 120)
        click(driver, "risk-show")
        wf.wait_for(lambda: js(driver, "rp.layersDrawn['risk layer'] === true"), 120,
                    "the risk layer on the geo-referenced map")
        stride = max(1, math.ceil(max(geo["nx"], geo["ny"]) / 120))
        risk_layer = json.loads(subprocess.run(
            ["curl", "-sf", "-H", "Content-Type: application/json", "--data",
             json.dumps({"map": geo_name, "stride": stride, "height_agl_m": 120,
                         "max_over_headings": True}),
             f"http://{gateway.address}/api/risk_layer"], check=True, capture_output=True).stdout)
        want = box([(c["lat_deg"], c["lon_deg"]) for c in risk_layer["bounds_wgs84"]["corners"]])
        error = max(abs(a - b) for a, b in zip(image_bounds()["risk layer"], want))
        check(error <= 1e-6, f"the risk layer at its bounds_wgs84 (off by {error:.1e} deg)")

        m_per_px = map_m_per_px
        ends = {}
        for which, pose in (("start", wf.SMALL_CITY_START), ("goal", wf.SMALL_CITY_GOAL)):
            at = wf.bilinear_wgs84(corners, pose[0], pose[1])
            got = set_endpoint(driver, which, at, pose[2])
            off = wf.ground_distance_m(at, (got["lat_deg"], got["lon_deg"]))
            check(off <= 2 * m_per_px and got["alt_m"] == pose[2],
                  f"{which} at ({got['lat_deg']:.6f}, {got['lon_deg']:.6f}, {got['alt_m']}) by a "
                  f"click, {off:.1f} m from the wanted point ({m_per_px:.2f} m per pixel)")
            check(abs(got["heading_deg"] - 45) < 3,
                  f"{which} heading {got['heading_deg']:.2f} deg from north, from the drag")
            ends[which] = (got["lat_deg"], got["lon_deg"])
        cursor = js(driver, "document.getElementById('cursor').textContent")
        # The mouse was released 40 px east and 40 px north of the goal.
        local = [float(v) for v in cursor.split("x, y: ")[1].rstrip(" m").split(",")]
        want_xy = (wf.SMALL_CITY_GOAL[0] + 40 * m_per_px, wf.SMALL_CITY_GOAL[1] + 40 * m_per_px)
        check("°" in cursor and math.dist(local, want_xy) < 3 * m_per_px + 1,
              f"the cursor shows WGS84 and the local position: {cursor} (about {want_xy[0]:.0f}, "
              f"{want_xy[1]:.0f} expected)")

        risks = plan_and_check(driver, 3000)
        request = js(driver, "rp.lastPlanRequest")
        check("start_wgs84" in request and "goal_wgs84" in request and "start" not in request and
              "goal" not in request, "the plan's start and goal were sent as start_wgs84 and goal_wgs84")
        path = js(driver, "rp.bestPath.map((p) => [p.lat, p.lng])")
        first, last = wf.ground_distance_m(path[0], ends["start"]), wf.ground_distance_m(path[-1], ends["goal"])
        check(first < 3 and last < 3,
              f"the drawn trajectory starts {first:.3f} m from the requested start and ends "
              f"{last:.3f} m from the goal ({len(path)} points)")
        server_path = js(driver, "rp.finalTrajectory.path_wgs84.map((g) => [g.lat_deg, g.lon_deg])")
        check(path == server_path, "the trajectory is drawn from the server's path_wgs84")
        check(js(driver, "rp.finalTrajectory.risk") == risks[-1], "the final risk is the last improvement's")
        wf.wait_for(lambda: js(driver, "rp.profile !== null"), 120, "the final risk profile")
        check(abs(js(driver, "rp.profile.risk") - risks[-1]) <= 1e-9 * risks[-1],
              "EvaluateRisk of the final waypoints gives the plan's risk")

        # Its GeoJSON download.
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

        check(wf.ground_distance_m((coords[0][1], coords[0][0]), ends["start"]) < 3,
              "the GeoJSON starts at the requested start")

        # A polyline drawn by clicks on the geo-referenced map, sent in WGS84.
        driver.execute_script("rp.profile = null; document.getElementById('evaluation').textContent = '';")
        click(driver, "draw-polyline")
        for x, y in corners_m:
            click_drag(driver, wf.bilinear_wgs84(corners, x, y), (0, 0))
        wf.wait_for(lambda: js(driver, "document.querySelectorAll('path.drawn-polyline').length") == 1,
                    30, "the drawn polyline")
        click(driver, "evaluate-polyline")
        wf.wait_for(lambda: js(driver, "rp.profile && rp.profile.samples.length > 0 && "
                                       "document.getElementById('evaluation').textContent"
                                       ".includes('samples')"), 120, "the polyline's evaluation")
        length = js(driver, "rp.profile.length_m")
        want = sum(math.dist(a, b) for a, b in zip(corners_m, corners_m[1:]))
        check(abs(length - want) < 4 * 2 * m_per_px,
              f"a 3-point polyline evaluated: {length:.1f} m (about {want:.1f} m)")

        # 8b. A QGroundControl mission uploaded, planned, downloaded.
        check_mission_upload_and_download(driver, work, downloads, corners, geo_name, map_name)

        # And back to the local map: CRS.Simple again.
        select_map(driver, map_name)
        check(js(driver, "rp.crs") == "Simple" and js(driver, "rp.leaflet.options.crs === L.CRS.Simple")
              and js(driver, "rp.endpoints.start") is None,
              f"the local map {map_name} is shown in CRS.Simple again, its start cleared")

        with open(os.path.join(out_dir, "browser_timings.json"), "w") as f:
            json.dump(timings, f, indent=2)
        print(f"timings: {json.dumps(timings)}", flush=True)

        # 9. A gateway whose one viewer slot is taken: the page says so.
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
