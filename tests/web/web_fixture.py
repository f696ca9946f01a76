"""What the browser test and the web benchmark share: the real riskplan-server
and riskplan-web started on port 0 (their readiness lines give the ports), the
2 km demo-city written with riskplan-tool (local, and placed on WGS84), and Debian's
Chromium driven headless by Debian's chromedriver.

Nothing here sleeps to synchronise: every wait polls a condition up to a
generous deadline, so a loaded 2-core machine is slower but not wrong.
"""

import atexit
import json
import math
import os
import select
import shutil
import subprocess
import tempfile
import time
import urllib.request

# The 2 km demo-city of the integration tests (tests/integration/server_process.h)
# and poses on it that are admissible under the default model parameters.
SMALL_CITY_SIZE_M = 2000
SMALL_CITY_START = (300.0, 375.0, 240.0, 0.785)
SMALL_CITY_GOAL = (1700.0, 1625.0, 250.0, 0.785)
GEO_ORIGIN = (49.6, 6.1)  # where the geo-referenced copy is placed (Luxembourg)


def wait_for(condition, timeout_s, what):
    """Polls condition() until it returns a true value, which is returned."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.05)


def _remove_at_exit(path):
    """Removes a scratch file or directory when the script exits (also after a
    failed check), unless RISKPLAN_KEEP_TEST_FILES is set, to keep it for a look."""
    def remove():
        if os.environ.get("RISKPLAN_KEEP_TEST_FILES"):
            return
        if os.path.isdir(path):
            shutil.rmtree(path, ignore_errors=True)
        elif os.path.exists(path):
            os.unlink(path)
    atexit.register(remove)


def scratch_dir(prefix):
    """A new directory under the temp dir, removed when the script exits."""
    path = tempfile.mkdtemp(prefix=prefix)
    _remove_at_exit(path)
    return path


class Process:
    """A program started with its stdout read up to a readiness line."""

    def __init__(self, args, ready_prefix, timeout_s=120, log_path=None):
        if log_path is None:
            fd, log_path = tempfile.mkstemp(prefix="riskplan-web-test-", suffix=".log")
            os.close(fd)
            _remove_at_exit(log_path)
        self.log_path = log_path
        self.log = open(self.log_path, "wb")
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=self.log)
        self.address = None
        deadline = time.monotonic() + timeout_s
        out = b""
        while self.address is None:
            left = deadline - time.monotonic()
            if left <= 0 or self.proc.poll() is not None:
                self.stop()
                raise AssertionError(f"{args[0]} did not print '{ready_prefix}': {out!r} "
                                     f"{open(self.log_path, 'rb').read()[-2000:]!r}")
            r, _, _ = select.select([self.proc.stdout], [], [], min(left, 1.0))
            if r:
                chunk = os.read(self.proc.stdout.fileno(), 4096)
                out += chunk
                for line in out.decode(errors="replace").splitlines():
                    if line.startswith(ready_prefix):
                        self.address = line[len(ready_prefix):].strip()

    def stderr(self):
        return open(self.log_path, "rb").read().decode(errors="replace")

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()


def write_local_city(bin_dir, maps_dir):
    """The 2 km demo-city in its local metres only (no geo-reference)."""
    subprocess.run([os.path.join(bin_dir, "riskplan-tool"), "write-map",
                    f"--out={os.path.join(maps_dir, 'demo-city')}", f"--size_m={SMALL_CITY_SIZE_M}"],
                   check=True, stdout=subprocess.DEVNULL)
    return "demo-city"


def bilinear_wgs84(corners, x, y, size_m=SMALL_CITY_SIZE_M):
    """(lat, lon) of the local point (x, y) of a map at (0, 0) of size_m a side,
    interpolated between its WGS84 corners (south-west, south-east, north-east,
    north-west; ListMaps' bounds_wgs84): within centimetres on a 2 km map."""
    u, v = x / size_m, y / size_m
    w = ((1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v)
    return (sum(k * c[0] for k, c in zip(w, corners)), sum(k * c[1] for k, c in zip(w, corners)))


def ground_distance_m(a, b):
    """Great-circle distance between two (lat, lon) in degrees, m (a sphere:
    good to a few millimetres over metres)."""
    p1, p2 = math.radians(a[0]), math.radians(b[0])
    dp, dl = p2 - p1, math.radians(b[1] - a[1])
    h = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * 6371008.8 * math.asin(math.sqrt(h))


def write_geo_city(bin_dir, maps_dir, name="lux-demo"):
    """The 2 km demo-city as a bundle placed on WGS84 (docs/map-bundle.md, geo)."""
    out = os.path.join(maps_dir, name)
    subprocess.run([os.path.join(bin_dir, "riskplan-tool"), "write-map", f"--out={out}",
                    f"--size_m={SMALL_CITY_SIZE_M}"], check=True, stdout=subprocess.DEVNULL)
    manifest_path = os.path.join(out, "manifest.json")
    with open(manifest_path) as f:
        manifest = json.load(f)
    manifest["name"] = name
    manifest["geo"] = {"origin_lat_deg": GEO_ORIGIN[0], "origin_lon_deg": GEO_ORIGIN[1],
                       "crs": "test placement"}
    with open(manifest_path, "w") as f:
        json.dump(manifest, f)
    return name


def start_server(bin_dir, maps_dir, extra=()):
    return Process([os.path.join(bin_dir, "riskplan-server"), "--listen=127.0.0.1:0",
                    f"--maps={maps_dir}", "--metrics_listen=127.0.0.1:0", "--rpc_log=false",
                    *extra], "riskplan-server listening on ")


def start_gateway(bin_dir, server_address, extra=()):
    return Process([os.path.join(bin_dir, "riskplan-web"), "--listen=127.0.0.1:0",
                    f"--server={server_address}", *extra], "riskplan-web listening on ")


def metrics_address(server):
    """The address of the server's /metrics, from its metrics_listening event."""
    def find():
        for line in server.stderr().splitlines():
            if '"metrics_listening"' in line:
                return json.loads(line)["detail"]
        return None
    return wait_for(find, 60, "the server's metrics_listening event")


def metric(address, series):
    text = urllib.request.urlopen(f"http://{address}/metrics", timeout=30).read().decode()
    for line in text.splitlines():
        if line.startswith(series + " "):
            return float(line.split()[-1])
    return None


def chromium(download_dir=None, width=1400, height=900):
    """Headless Debian Chromium. Fails (it does not skip) when it is missing:
    the test command installs it (scripts/install-deps.sh)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    for path in ("/usr/bin/chromium", "/usr/bin/chromedriver"):
        if not os.path.exists(path):
            raise AssertionError(f"{path} is missing: install chromium and chromium-driver "
                                 "(bash scripts/install-deps.sh)")
    options = Options()
    # Root needs --no-sandbox; the rest keeps Chromium off the network.
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage",
                f"--window-size={width},{height}"):
        options.add_argument(arg)
    # The console's messages, for driver.get_log("browser").
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    profile = tempfile.mkdtemp(prefix="riskplan-chromium-")
    options.add_argument(f"--user-data-dir={profile}")
    options.binary_location = "/usr/bin/chromium"
    if download_dir:
        options.add_experimental_option("prefs", {
            "download.default_directory": download_dir,
            "download.prompt_for_download": False,
            "safebrowsing.enabled": False,
        })
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
    driver.set_script_timeout(60)
    driver.set_page_load_timeout(120)
    driver._riskplan_profile = profile
    return driver


def quit_chromium(driver):
    profile = getattr(driver, "_riskplan_profile", None)
    driver.quit()
    if profile:
        shutil.rmtree(profile, ignore_errors=True)
