// riskplan-web's page: flight mode (docs/web.md, "Flight"). The gateway opens
// an in-flight session (the Fly RPC) for the start and goal on the page and
// flies a simulated aircraft along its plan, sped up; the page places
// circular no-fly zones by clicks (a click on a zone removes it) and draws
// each plan version the server makes: the committed prefix (what the
// aircraft will fly whatever happens) solid, the remainder dashed, the
// aircraft, and any alert with its emergency landing site and glide.
'use strict';

// What the tests read: the flight's id, every version and alert as they
// came, the refusals, the latest position, and how it ended.
rp.flight = null;  // {id, versions: [], alerts: [], refusals: [], position, ended, zones: {id: {x, y, radius_m}}}
let flightSource = null;
let placingZone = false;
let zoneCounter = 0;
let polygonZone = null;  // the vertices (LatLngs) of a polygon zone being drawn

const FLIGHT_REASONS = {
  FLIGHT_REASON_OPENED: 'the first plan',
  FLIGHT_REASON_PROGRESS: 'the commit point moved ahead',
  FLIGHT_REASON_ZONE_ADDED: 'a zone was added',
  FLIGHT_REASON_ZONE_REMOVED: 'a zone was removed',
  FLIGHT_REASON_ZONE_TIMED: "a zone's time began or ended",
  FLIGHT_REASON_WIND: 'the wind changed',
  FLIGHT_REASON_SEARCH: 'a later search found a better remainder',
  FLIGHT_REASON_OFF_ROUTE: 'the aircraft was off the route',
};
const ALERTS = {
  FLIGHT_ALERT_NO_REMAINDER: 'no admissible route from the commit point',
  FLIGHT_ALERT_INSIDE_ZONE: 'the aircraft or its committed route is inside a zone',
};

function setFlightButtons(flying) {
  $('fly').disabled = flying;
  $('end-flight').disabled = !flying;
  $('place-zone').disabled = !flying;
  $('polygon-zone').disabled = !flying;
  if (!flying) stopPolygonZone();
}

function closeFlightSource() { if (flightSource) { flightSource.close(); flightSource = null; } }

// The route's display path split at `until` m of arc length (the
// committed prefix, then the remainder), as LatLngs; the path's samples are
// close enough that straight lines between them measure the arc.
function splitRoute(route, until) {
  const at = frame.pathOf(route);
  const p = route.path;
  let walked = 0;
  for (let k = 0; k + 1 < p.length; k++) {
    const d = Math.hypot(p[k + 1].x - p[k].x, p[k + 1].y - p[k].y, p[k + 1].z - p[k].z);
    if (walked + d >= until) {
      const f = d > 0 ? (until - walked) / d : 0;
      const a = L.latLng(at[k]), b = L.latLng(at[k + 1]);
      const cut = L.latLng(a.lat + f * (b.lat - a.lat), a.lng + f * (b.lng - a.lng));
      return [at.slice(0, k + 1).concat([cut]), [cut].concat(at.slice(k + 1))];
    }
    walked += d;
  }
  return [at, [at[at.length - 1]]];
}

function drawVersion(v) {
  flightLayer.clearLayers();
  const [committed, remainder] = splitRoute(v.route, v.committed_until_m);
  L.polyline(remainder, { color: '#f60', weight: 3, dashArray: '8 6', className: 'flight-remainder' }).addTo(flightLayer);
  L.polyline(committed, { color: '#036', weight: 5, className: 'flight-committed' }).addTo(flightLayer);
  if (rp.flight.position) drawAircraft(rp.flight.position);
  const zones = v.active_zones.length ? v.active_zones.join(', ') : 'none';
  $('flight-state').textContent = `version ${v.version} (${FLIGHT_REASONS[v.reason] || v.reason}) at ${v.time_s.toFixed(1)} s: ` +
    `committed to ${v.committed_until_m.toFixed(0)} m, the remainder ${v.remainder.length_m.toFixed(0)} m; ` +
    `the route ${v.route.length_m.toFixed(0)} m, ${v.route.flight_time_s.toFixed(1)} s, risk ${v.route.risk.toExponential(3)}; zones: ${zones}`;
}

function drawAircraft(d) {
  const at = d.lat_deg !== undefined ? L.latLng(d.lat_deg, d.lon_deg) : L.latLng(d.y, d.x);
  if (!rp.flight.aircraft || !flightLayer.hasLayer(rp.flight.aircraft)) {
    rp.flight.aircraft = L.circleMarker(at, { radius: 7, color: '#000', fillColor: '#fff', fillOpacity: 1, weight: 3, className: 'aircraft' }).addTo(flightLayer);
  } else {
    rp.flight.aircraft.setLatLng(at);
  }
}

function showAlert(a) {
  const lines = [`ALERT at ${a.time_s.toFixed(1)} s: ${ALERTS[a.kind] || a.kind}: ${a.detail}`];
  alertLayer.clearLayers();
  if (a.landing && a.landing.site_pose) {
    const l = a.landing;
    lines.push(`emergency landing at ${l.site ? `'${l.site}'` : 'an unnamed site'} (${l.site_pose.x.toFixed(0)}, ${l.site_pose.y.toFixed(0)}) m: glide ${l.glide_distance_m.toFixed(0)} m, ${l.altitude_margin_m.toFixed(1)} m to spare`);
    L.circleMarker(frame.poseAt(l.site_pose), { radius: 9, color: '#c00', fillColor: '#ff0', fillOpacity: 1, className: 'emergency-landing' })
      .bindTooltip(lines[1]).addTo(alertLayer);
    if (l.glide && l.glide.length) L.polyline(l.glide.map((p) => frame.poseAt(p)), { color: '#c00', weight: 2, dashArray: '2 4' }).addTo(alertLayer);
  }
  $('flight-alerts').textContent = lines.join('\n');
}

function watchFlight(id) {
  closeFlightSource();
  let last = 0;
  const fresh = (e) => { const n = Number(e.lastEventId); if (n <= last) return false; last = n; return true; };
  flightSource = new EventSource(`/api/flights/${id}/events`);
  flightSource.addEventListener('version', (e) => {
    if (!fresh(e)) return;
    const v = JSON.parse(e.data).version;
    rp.flight.versions.push(v);
    // A new version is in force: an alert before it is over.
    alertLayer.clearLayers();
    $('flight-alerts').textContent = '';
    drawVersion(v);
  });
  flightSource.addEventListener('position', (e) => {
    if (!fresh(e)) return;
    rp.flight.position = JSON.parse(e.data);
    drawAircraft(rp.flight.position);
  });
  flightSource.addEventListener('alert', (e) => {
    if (!fresh(e)) return;
    const a = JSON.parse(e.data).alert;
    rp.flight.alerts.push(a);
    showAlert(a);
  });
  flightSource.addEventListener('refusal', (e) => {
    if (!fresh(e)) return;
    const r = JSON.parse(e.data).refusal;
    rp.flight.refusals.push(r);
    showError(new ApiError('INVALID_ARGUMENT', `${r.field}: ${r.message}`, 'server'));
  });
  flightSource.addEventListener('resumed', (e) => {
    if (!fresh(e)) return;
    $('flight-alerts').textContent = JSON.parse(e.data).message;
  });
  // The flight's last event (ended or failed): the stream closes, the buttons
  // and the zone tool go back to their rest.
  const finish = (e) => {
    const d = JSON.parse(e.data);
    rp.flight.ended = d;
    closeFlightSource();
    setFlightButtons(false);
    stopPlacingZone();
    return d;
  };
  flightSource.addEventListener('ended', (e) => {
    if (!fresh(e)) return;
    const d = finish(e);
    $('flight-state').textContent = `flight ended at ${d.time_s.toFixed(1)} s, ${d.progress_m.toFixed(0)} m flown: ${d.message}`;
  });
  flightSource.addEventListener('failed', (e) => {
    if (!fresh(e)) return;
    const d = finish(e);
    $('flight-state').textContent = 'the flight failed';
    showError(new ApiError(d.code, d.message, 'server'));
  });
}

async function startFlight() {
  if (!endpoints.start || !endpoints.goal) throw new ApiError('INVALID_ARGUMENT', 'set a start and a goal on the map first', 'page');
  const plan = planRequest();
  delete plan.min_update_interval_ms;
  const body = {
    open: { plan, commit_horizon_s: Number($('commit-horizon').value) },
    speedup: Number($('flight-speedup').value),
  };
  flightLayer.clearLayers(); zoneLayer.clearLayers(); alertLayer.clearLayers();
  $('flight-alerts').textContent = '';
  const r = await api('POST', '/api/flights', body);
  rp.flight = { id: r.id, versions: [], alerts: [], refusals: [], position: null, ended: null, zones: {}, aircraft: null };
  $('flight-state').textContent = 'opening the flight: its first plan';
  setFlightButtons(true);
  watchFlight(r.id);
}

async function endFlight() {
  if (rp.flight) await api('POST', `/api/flights/${rp.flight.id}/end`);
}

function stopPlacingZone() {
  placingZone = false;
  $('place-zone').textContent = 'Place a zone';
  $('map').style.cursor = '';
}

function togglePlacingZone() {
  if (placingZone) { stopPlacingZone(); return; }
  if (polygonZone) stopPolygonZone();
  placingZone = true;
  $('place-zone').textContent = 'Placing: click on the map';
  $('map').style.cursor = 'crosshair';
}

// The local point of a LatLng (zones are in the map's local frame).
function localOf(at) { return frame.toLocal ? frame.toLocal(at) : { x: at.lng, y: at.lat }; }

// A zone sent, drawn, and removed by a click on it.
async function sendZone(zone, shape) {
  await api('POST', `/api/flights/${rp.flight.id}/inputs`, { add_zone: zone });
  rp.flight.zones[zone.id] = zone.circle || zone.polygon;
  shape.addTo(zoneLayer);
  shape.on('click', (e) => {
    L.DomEvent.stopPropagation(e);
    guarded(async () => {
      await api('POST', `/api/flights/${rp.flight.id}/inputs`, { remove_zone: { id: zone.id } });
      delete rp.flight.zones[zone.id];
      zoneLayer.removeLayer(shape);
    });
  });
}

async function addZone(at) {
  const radius = Number($('zone-radius').value);
  const c = localOf(at);
  const id = `zone-${++zoneCounter}`;
  await sendZone({ id, circle: { x: c.x, y: c.y, radius_m: radius } },
    L.circle(at, { radius, color: '#c00', fillColor: '#f00', fillOpacity: 0.25, weight: 2, className: 'flight-zone' })
      .bindTooltip(`${id}: ${radius} m (click to remove)`));
}

function placeZoneAt(e) {
  if (polygonZone && rp.flight && !rp.flight.ended) {
    polygonZone.push(e.latlng);
    polygonPreview.setLatLngs(polygonZone);
    if (!zoneLayer.hasLayer(polygonPreview)) polygonPreview.addTo(zoneLayer);
    $('polygon-zone').textContent = `Send the polygon (${polygonZone.length} vertices)`;
    return;
  }
  if (!placingZone || !rp.flight || rp.flight.ended) return;
  stopPlacingZone();
  guarded(() => addZone(e.latlng));
}

// A polygon zone: the button starts it, clicks on the map add its vertices
// (in either order, not closed), the button again sends it.
const polygonPreview = L.polygon([], { color: '#c00', dashArray: '4 4', fillOpacity: 0.1, weight: 1 });
function stopPolygonZone() {
  polygonZone = null;
  if (zoneLayer && zoneLayer.hasLayer(polygonPreview)) zoneLayer.removeLayer(polygonPreview);
  $('polygon-zone').textContent = 'Draw a polygon zone';
  if (!placingZone) $('map').style.cursor = '';
}
async function togglePolygonZone() {
  if (!polygonZone) {
    stopPlacingZone();
    polygonZone = [];
    $('polygon-zone').textContent = 'Send the polygon (0 vertices)';
    $('map').style.cursor = 'crosshair';
    return;
  }
  const vertices = polygonZone;
  stopPolygonZone();
  if (vertices.length < 3) throw new ApiError('INVALID_ARGUMENT', `a polygon zone needs at least 3 vertices; ${vertices.length} given`, 'page');
  const id = `zone-${++zoneCounter}`;
  await sendZone({ id, polygon: { vertices: vertices.map((at) => localOf(at)) } },
    L.polygon(vertices, { color: '#c00', fillColor: '#f00', fillOpacity: 0.25, weight: 2, className: 'flight-zone' })
      .bindTooltip(`${id}: a polygon of ${vertices.length} vertices (click to remove)`));
}

// For scripts: a zone placed at a local point exactly, as a click there would.
rp.addZoneAt = (x, y) => addZone(frame.toLatLng ? frame.toLatLng(x, y) : L.latLng(y, x));
