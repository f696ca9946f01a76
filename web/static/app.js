// riskplan-web's page. Talks only to the gateway (same origin): /api/... for
// the calls (JSON forms of riskplan.v1's messages, docs/api.md) and
// /api/plans/ID/events for a plan's Server-Sent Events. Coordinates are the
// map's local metres (Leaflet's CRS.Simple: lat = y north, lng = x east).
'use strict';

// What the tests and the latency measurement read.
const rp = window.rp = {
  map: null,            // the MapInfo shown
  layersDrawn: {},      // layer name -> true once its image is on the map
  planId: null,
  state: 'idle',        // idle, starting, running, finished, failed, cancelled
  improvements: [],     // {id, risk, iterations, elapsed_s} per drawn update
  latencies: [],        // ms from the gateway reading an update to the page drawing it
  finalTrajectory: null,
  profile: null,        // the last EvaluateRisk response drawn as a profile
  downloads: [],        // file names saved
};

const $ = (id) => document.getElementById(id);
const nowMs = () => performance.timeOrigin + performance.now();

// ---------------------------------------------------------------------------
// Calls and errors

class ApiError extends Error {
  constructor(code, message, source) { super(message); this.code = code; this.source = source; }
}

async function api(method, path, body) {
  const init = { method, headers: {} };
  if (body !== undefined) {
    init.body = JSON.stringify(body);
    init.headers['Content-Type'] = 'application/json';
  }
  const res = await fetch(path, init);
  const text = await res.text();
  let json = null;
  try { json = text ? JSON.parse(text) : null; } catch (e) { /* not JSON */ }
  if (!res.ok) {
    if (json && json.message !== undefined) throw new ApiError(json.code, json.message, json.source);
    throw new ApiError('HTTP_' + res.status, text || res.statusText, 'gateway');
  }
  return json;
}

// The message exactly as its author (the server, or the gateway) wrote it.
function showError(err) {
  $('error-code').textContent = err.code ? err.code + (err.source ? ' (' + err.source + ')' : '') + ':' : 'error:';
  $('error-message').textContent = err.message;
  $('error').hidden = false;
}
function clearError() { $('error').hidden = true; $('error-message').textContent = ''; }

async function guarded(fn) {
  try { clearError(); await fn(); } catch (err) { showError(err); }
}

// ---------------------------------------------------------------------------
// Colours

const VIRIDIS = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
const HOT = [[255, 255, 178], [254, 204, 92], [253, 141, 60], [240, 59, 32], [189, 0, 38]];
const GREENS = [[247, 252, 245], [199, 233, 192], [116, 196, 118], [35, 139, 69], [0, 68, 27]];

function ramp(stops, t) {
  t = Math.min(1, Math.max(0, t));
  const f = t * (stops.length - 1);
  const i = Math.min(stops.length - 2, Math.floor(f));
  const u = f - i;
  return stops[i].map((c, k) => Math.round(c + (stops[i + 1][k] - c) * u));
}
function cssGradient(stops) {
  return 'linear-gradient(to right,' + stops.map((c) => `rgb(${c.join(',')})`).join(',') + ')';
}

// A grid (row 0 the southernmost) drawn into an image, north up.
// colour(value) returns [r, g, b, a] or null (transparent).
function gridImage(nx, ny, values, colour) {
  const canvas = document.createElement('canvas');
  canvas.width = nx; canvas.height = ny;
  const ctx = canvas.getContext('2d');
  const img = ctx.createImageData(nx, ny);
  for (let j = 0; j < ny; j++) {
    const row = ny - 1 - j;
    for (let i = 0; i < nx; i++) {
      const c = colour(values[j * nx + i], i, j);
      const o = 4 * (row * nx + i);
      if (c) { img.data[o] = c[0]; img.data[o + 1] = c[1]; img.data[o + 2] = c[2]; img.data[o + 3] = c[3]; }
    }
  }
  ctx.putImageData(img, 0, 0);
  return canvas.toDataURL();
}

// Decades spanned by the positive values: [lo, hi] exponents.
function decades(values) {
  let lo = Infinity, hi = -Infinity;
  for (const v of values) if (v > 0 && isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  if (!isFinite(lo)) return [0, 1];
  const a = Math.floor(Math.log10(lo)), b = Math.ceil(Math.log10(hi));
  return [a, b > a ? b : a + 1];
}

// ---------------------------------------------------------------------------
// The map

const map = L.map('map', { crs: L.CRS.Simple, minZoom: -8, maxZoom: 4, zoomSnap: 0.25, attributionControl: false });
rp.leaflet = map;
L.control.scale({ imperial: false, maxWidth: 160, position: 'bottomleft' }).addTo(map);
const layerControl = L.control.layers(null, null, { collapsed: false, position: 'topright' }).addTo(map);
const overlays = {};       // name -> Leaflet layer
const legends = {};        // name -> HTML
const legend = L.control({ position: 'bottomright' });
legend.onAdd = () => { const d = L.DomUtil.create('div', 'legend'); d.id = 'legend'; return d; };
legend.addTo(map);
map.on('overlayadd overlayremove', drawLegend);

function drawLegend() {
  const parts = [];
  for (const name of Object.keys(legends)) {
    if (overlays[name] && map.hasLayer(overlays[name])) parts.push(legends[name]);
  }
  $('legend').innerHTML = parts.join('') || '<i>no layer shown</i>';
}

function scaleLegend(title, stops, ticks) {
  return `<div class="item"><b>${title}</b><div class="bar" style="background:${cssGradient(stops)}"></div>` +
    `<div class="ticks">${ticks.map((t) => `<span>${t}</span>`).join('')}</div></div>`;
}

function addOverlay(name, layer, shown, legendHtml) {
  if (overlays[name]) { layerControl.removeLayer(overlays[name]); map.removeLayer(overlays[name]); }
  overlays[name] = layer;
  if (legendHtml) legends[name] = legendHtml; else delete legends[name];
  layerControl.addOverlay(layer, name);
  if (shown) layer.addTo(map);
  rp.layersDrawn[name] = true;
  drawLegend();
}

function boundsOf(x0, y0, w, h) { return L.latLngBounds([y0, x0], [y0 + h, x0 + w]); }

function rasterOverlay(layer, url) {
  return L.imageOverlay(url, boundsOf(layer.x0_m, layer.y0_m, layer.nx * layer.cell_m, layer.ny * layer.cell_m),
    { className: 'raster', opacity: 1 });
}

async function fetchLayer(name) {
  return api('GET', `/api/layer?map=${encodeURIComponent(rp.map.name)}&layer=${name}&max_side_cells=400`);
}

function hillshade(layer) {
  const { nx, ny, values } = layer;
  const d = layer.cell_m;
  const z = (i, j) => values[Math.min(ny - 1, Math.max(0, j)) * nx + Math.min(nx - 1, Math.max(0, i))];
  // Light from the north-west, 45 degrees up.
  const L0 = [-0.5, 0.5, Math.SQRT1_2];
  return gridImage(nx, ny, values, (v, i, j) => {
    const dzdx = (z(i + 1, j) - z(i - 1, j)) / (2 * d);
    const dzdy = (z(i, j + 1) - z(i, j - 1)) / (2 * d);
    const n = Math.hypot(dzdx, dzdy, 1);
    const s = Math.max(0, (-dzdx * L0[0] - dzdy * L0[1] + L0[2]) / n);
    const g = Math.round(255 * s);
    return [g, g, g, 255];
  });
}

async function loadMap(info) {
  rp.map = info;
  rp.layersDrawn = {};
  const b = boundsOf(info.x0_m, info.y0_m, info.width_m, info.height_m);
  map.setMaxBounds(b.pad(0.5));
  map.fitBounds(b);
  const [density, shelter, terrain, nofly] = await Promise.all(
    ['POPULATION_DENSITY', 'SHELTER', 'TERRAIN', 'NO_FLY'].map(fetchLayer));

  addOverlay('terrain (hillshade)', rasterOverlay(terrain, hillshade(terrain)), true,
    `<div class="item"><b>terrain</b> ${info.terrain_min_m.toFixed(0)}–${info.terrain_max_m.toFixed(0)} m AMSL, lit from the north-west</div>`);

  const [lo, hi] = decades(density.values);
  addOverlay('population density', rasterOverlay(density, gridImage(density.nx, density.ny, density.values, (v) => {
    if (!(v > 0)) return null;
    const c = ramp(VIRIDIS, (Math.log10(v) - lo) / (hi - lo));
    return [c[0], c[1], c[2], 140];
  })), true, scaleLegend('population density, people per m²', VIRIDIS,
    Array.from({ length: hi - lo + 1 }, (_, k) => `1e${lo + k}`)));

  addOverlay('shelter', rasterOverlay(shelter, gridImage(shelter.nx, shelter.ny, shelter.values, (v) => {
    const c = ramp(GREENS, v / 10);
    return [c[0], c[1], c[2], 170];
  })), false, scaleLegend('shelter factor', GREENS, ['0', '5', '10']));

  addOverlay('no-fly zones', rasterOverlay(nofly, gridImage(nofly.nx, nofly.ny, nofly.values,
    (v) => (v > 0 ? [220, 0, 0, 150] : null))), true,
    '<div class="item"><span class="key" style="background:rgba(220,0,0,0.6)"></span>no-fly zone</div>');

  const sites = L.layerGroup(info.landing_sites.map((s) =>
    L.circleMarker([s.y, s.x], { radius: 5, color: '#064', fillColor: '#2c2', fillOpacity: 0.9, className: 'landing-site' })
      .bindTooltip(`${s.name || 'landing site'} (${s.x.toFixed(0)}, ${s.y.toFixed(0)}) m, terrain ${s.terrain_m.toFixed(0)} m`)));
  addOverlay('landing sites', sites, true,
    '<div class="item"><span class="key" style="background:#2c2;border-radius:6px"></span>landing site</div>');
}

async function showRiskLayer() {
  const info = rp.map;
  const maxOver = $('risk-max-headings').checked;
  // Cells kept modest: each costs one configuration risk, times the heading
  // bins with the maximum over headings.
  const side = maxOver ? 120 : 250;
  const stride = Math.max(1, Math.ceil(Math.max(info.nx, info.ny) / side));
  const layer = await api('POST', '/api/risk_layer', {
    map: info.name, stride, height_agl_m: Number($('risk-height').value), max_over_headings: maxOver,
  });
  const values = layer.risk.map(Number);  // "NaN" where M is not defined
  const [lo, hi] = decades(values);
  const url = gridImage(layer.nx, layer.ny, values, (v) => {
    if (!isFinite(v)) return [120, 120, 120, 90];
    if (!(v > 0)) return null;
    const c = ramp(HOT, (Math.log10(v) - lo) / (hi - lo));
    return [c[0], c[1], c[2], 190];
  });
  const overlay = L.imageOverlay(url, boundsOf(layer.x0_m, layer.y0_m, layer.nx * layer.cell_m, layer.ny * layer.cell_m),
    { className: 'raster' });
  addOverlay('risk layer', overlay, true,
    scaleLegend(`risk M at ${layer.height_agl_m} m above ground${layer.max_over_headings ? ' (max over headings)' : ''}, casualties per failure`,
      HOT, Array.from({ length: hi - lo + 1 }, (_, k) => `1e${lo + k}`)) +
    '<div class="item"><span class="key" style="background:rgba(120,120,120,0.5)"></span>M not defined (impact outside the map)</div>');
}

// On a geo-referenced map, the WGS84 position of a local point, interpolated
// bilinearly between the map's four corners as the server gave them: the
// page links no projection, and over a map of kilometres the azimuthal
// equidistant frame departs from that interpolation by centimetres. For
// display only: requests stay in local metres, and the server converts.
function approxWgs84(x, y) {
  const info = rp.map;
  const c = info.bounds_wgs84 && info.bounds_wgs84.corners;
  if (!info.geo || !c || c.length !== 4) return null;
  const u = (x - info.x0_m) / info.width_m, v = (y - info.y0_m) / info.height_m;
  // South-west, south-east, north-east, north-west.
  const mix = (k) => (1 - u) * (1 - v) * c[0][k] + u * (1 - v) * c[1][k] + u * v * c[2][k] + (1 - u) * v * c[3][k];
  return { lat: mix('lat_deg'), lon: mix('lon_deg') };
}

map.on('mousemove', (e) => {
  let text = `x, y: ${e.latlng.lng.toFixed(0)}, ${e.latlng.lat.toFixed(0)} m`;
  const g = approxWgs84(e.latlng.lng, e.latlng.lat);
  if (g) text += ` · ${g.lat.toFixed(5)}°, ${g.lon.toFixed(5)}°`;
  $('cursor').textContent = text;
});

// ---------------------------------------------------------------------------
// Start and goal: press, drag for the heading, release.

const endpoints = { start: null, goal: null };
rp.endpoints = endpoints;
const endpointLayers = { start: L.layerGroup().addTo(map), goal: L.layerGroup().addTo(map) };
let picking = null;  // 'start' | 'goal' | null
let pressed = null;  // the point pressed, while dragging
let dragLine = null;

function fmtPose(p) { return `(${p.x.toFixed(1)}, ${p.y.toFixed(1)}, ${p.z.toFixed(1)}) m, heading ${(p.theta * 180 / Math.PI).toFixed(0)}°`; }

function drawEndpoint(which) {
  const p = endpoints[which];
  const g = endpointLayers[which];
  g.clearLayers();
  if (!p) return;
  const colour = which === 'start' ? '#06c' : '#a0a';
  const len = Math.max(rp.map.width_m, rp.map.height_m) / 30;
  L.circleMarker([p.y, p.x], { radius: 7, color: colour, fillOpacity: 0.8, className: 'endpoint-' + which })
    .bindTooltip(which + ' ' + fmtPose(p)).addTo(g);
  L.polyline([[p.y, p.x], [p.y + len * Math.sin(p.theta), p.x + len * Math.cos(p.theta)]], { color: colour, weight: 3 }).addTo(g);
  $(which + '-text').textContent = which + ': ' + fmtPose(p);
}

// For scripts (the benchmark): a pose given exactly rather than by a click.
rp.setEndpoint = (which, pose) => { endpoints[which] = pose; drawEndpoint(which); };

function pick(which) {
  picking = which;
  map.dragging.disable();
  $('map').style.cursor = 'crosshair';
}

map.on('mousedown', (e) => {
  if (!picking) return;
  // With dragging off, the browser would select the page's text instead.
  L.DomEvent.preventDefault(e.originalEvent);
  pressed = e.latlng;
  dragLine = L.polyline([pressed, pressed], { color: '#333', dashArray: '4 4' }).addTo(map);
});
map.on('mousemove', (e) => { if (pressed && dragLine) dragLine.setLatLngs([pressed, e.latlng]); });
map.on('mouseup', (e) => {
  if (!picking || !pressed) return;
  const p0 = map.latLngToContainerPoint(pressed), p1 = map.latLngToContainerPoint(e.latlng);
  const dx = e.latlng.lng - pressed.lng, dy = e.latlng.lat - pressed.lat;
  // A click without a drag keeps the heading north-east.
  const theta = p0.distanceTo(p1) >= 5 ? (Math.atan2(dy, dx) + 2 * Math.PI) % (2 * Math.PI) : Math.PI / 4;
  endpoints[picking] = { x: pressed.lng, y: pressed.lat, z: Number($('altitude').value), theta };
  drawEndpoint(picking);
  if (dragLine) map.removeLayer(dragLine);
  dragLine = null; pressed = null; picking = null;
  map.dragging.enable();
  $('map').style.cursor = '';
});

// ---------------------------------------------------------------------------
// Plans: the live view

const trajectories = L.layerGroup().addTo(map);   // earlier improvements, faded
const bestLayer = L.layerGroup().addTo(map);      // the newest
let source = null;
let lastSeenId = 0;

const riskChart = new Chart($('risk-chart'), {
  type: 'line',
  data: { datasets: [{ label: 'best risk (casualties per flight)', data: [], stepped: 'after', borderColor: '#c33', pointRadius: 2 }] },
  options: {
    animation: false, maintainAspectRatio: false, parsing: false,
    scales: {
      x: { type: 'linear', title: { display: true, text: 'planner time, s' } },
      y: { ticks: { callback: (v) => Number(v).toExponential(1) } },
    },
    plugins: { legend: { labels: { boxWidth: 10 } } },
  },
});

function setState(s) {
  rp.state = s;
  $('state').textContent = s;
  const active = s === 'starting' || s === 'running' || s === 'reconnecting';
  $('plan').disabled = active;
  $('cancel').disabled = !active;
}

function drawTrajectory(t) {
  const path = t.path.map((p) => [p.y, p.x]);
  bestLayer.eachLayer((l) => { l.setStyle({ color: '#888', weight: 1, opacity: 0.5 }); trajectories.addLayer(l); });
  bestLayer.clearLayers();
  // Keep the picture (and the page's memory) bounded.
  const old = trajectories.getLayers();
  for (let k = 0; k + 30 < old.length; k++) trajectories.removeLayer(old[k]);
  L.polyline(path, { color: '#d00', weight: 3, className: 'best-trajectory' }).addTo(bestLayer);
}

function onUpdate(e) {
  const id = Number(e.lastEventId);
  if (id <= lastSeenId) return;  // already drawn before a reconnection
  lastSeenId = id;
  const d = JSON.parse(e.data);
  const u = d.update;
  $('iterations').textContent = u.iterations;
  $('improvements').textContent = u.improvements;
  const t = u.trajectory;
  if (t && t.path && t.path.length) {
    drawTrajectory(t);
    rp.bestWaypoints = t.waypoints;
    $('risk').textContent = `${t.risk.toExponential(4)} (${t.length_m.toFixed(0)} m, ${t.risk_per_flight_hour.toExponential(2)} per flight hour)`;
    riskChart.data.datasets[0].data.push({ x: u.elapsed_s, y: t.risk });
    riskChart.update('none');
    rp.improvements.push({ id, risk: t.risk, iterations: Number(u.iterations), elapsed_s: u.elapsed_s });
    for (const b of ['download-geojson', 'download-plan', 'download-kml']) $(b).disabled = false;
    // Drawn: the first animation frame after the map and the plot changed.
    requestAnimationFrame(() => rp.latencies.push(nowMs() - d.gateway_ms));
  }
  return u;
}

function closeSource() { if (source) { source.close(); source = null; } }

function watch(id) {
  closeSource();
  lastSeenId = 0;
  source = new EventSource(`/api/plans/${id}/events`);
  source.addEventListener('open', () => { if (rp.state === 'starting' || rp.state === 'reconnecting') setState('running'); });
  source.addEventListener('update', onUpdate);
  source.addEventListener('final', (e) => {
    const u = onUpdate(e);
    closeSource();
    setState('finished');
    if (u) {
      $('state').textContent = `finished: ${u.end_reason}, ${u.iterations} iterations`;
      if (u.trajectory) {
        rp.finalTrajectory = u.trajectory;
        guarded(() => evaluate({ waypoints: { poses: u.trajectory.waypoints } }));
      }
    }
  });
  source.addEventListener('failed', (e) => {
    const d = JSON.parse(e.data);
    closeSource();
    setState('failed');
    showError(new ApiError(d.code, d.message, 'server'));
  });
  source.addEventListener('cancelled', () => { closeSource(); setState('cancelled'); });
  // The link broke: the browser reconnects by itself with Last-Event-ID,
  // unless the gateway refused the stream.
  source.onerror = async () => {
    if (!source) return;
    if (source.readyState === EventSource.CONNECTING) { setState('reconnecting'); return; }
    closeSource();
    try {
      const s = await api('GET', '/api/status');
      if (s.viewers >= s.max_viewers) {
        showError(new ApiError('RESOURCE_EXHAUSTED',
          `this gateway holds at most ${s.max_viewers} event streams at once (--max_viewers) and all are open; try again when a viewer has closed`, 'gateway'));
      } else {
        showError(new ApiError('UNAVAILABLE', 'the event stream of the plan closed', 'gateway'));
      }
    } catch (err) { showError(err); }
    setState('failed');
  };
}

async function startPlan() {
  if (!endpoints.start || !endpoints.goal) throw new ApiError('INVALID_ARGUMENT', 'set a start and a goal on the map first', 'page');
  closeSource();
  trajectories.clearLayers(); bestLayer.clearLayers();
  riskChart.data.datasets[0].data = []; riskChart.update('none');
  rp.improvements = []; rp.finalTrajectory = null;
  $('iterations').textContent = '0'; $('improvements').textContent = '0'; $('risk').textContent = '–';
  setState('starting');
  try {
    const r = await api('POST', '/api/plans', {
      map: rp.map.name,
      start: endpoints.start, goal: endpoints.goal,
      algorithm: $('algorithm').value,
      budget: { time_ms: String(Number($('budget-ms').value)), iterations: String(Number($('budget-iterations').value)) },
      seed: String(Number($('seed').value)),
      // The server coalesces what it finds in between (newest wins): more
      // than about 20 pictures a second is more than anyone can follow.
      min_update_interval_ms: String(Number($('update-interval').value)),
    });
    rp.planId = r.id;
    watch(r.id);
  } catch (err) { setState('failed'); throw err; }
}

async function cancelPlan() {
  if (rp.planId) await api('POST', `/api/plans/${rp.planId}/cancel`);
}

// ---------------------------------------------------------------------------
// Evaluation: the risk profile along a trajectory, and drawn polylines.

const profileMarker = L.circleMarker([0, 0], { radius: 6, color: '#000', fillColor: '#ff0', fillOpacity: 1 });
const profileChart = new Chart($('profile-chart'), {
  type: 'line',
  data: { datasets: [{ label: 'configuration risk M along the path', data: [], borderColor: '#36c', pointRadius: 0, borderWidth: 1.5 }] },
  options: {
    animation: false, maintainAspectRatio: false, parsing: false,
    interaction: { mode: 'nearest', axis: 'x', intersect: false },
    scales: {
      x: { type: 'linear', title: { display: true, text: 'arc length, m' } },
      y: { ticks: { callback: (v) => Number(v).toExponential(1) } },
    },
    plugins: {
      legend: { labels: { boxWidth: 10 } },
      tooltip: { callbacks: { label: (c) => sampleText(rp.profile.samples[c.dataIndex]) } },
    },
    onHover: (e, items) => {
      if (!items.length || !rp.profile) return;
      const s = rp.profile.samples[items[0].index];
      profileMarker.setLatLng([s.y, s.x]).addTo(map);
      $('sample').textContent = sampleText(s);
    },
  },
});

function sampleText(s) {
  return `${Number(s.arc_length_m).toFixed(0)} m, piece ${s.piece}: (${s.x.toFixed(0)}, ${s.y.toFixed(0)}, ${s.z.toFixed(0)}) m, ` +
    `M ${s.defined ? Number(s.risk).toExponential(3) : 'not defined'}, I ${Number(s.impact_factor).toExponential(2)} /m², ` +
    `S̃ ${Number(s.expected_shelter).toFixed(2)}, p_cas ${Number(s.casualty_probability).toFixed(3)}`;
}

async function evaluate(trajectory) {
  const r = await api('POST', '/api/evaluate', Object.assign({ map: rp.map.name, include_samples: true }, trajectory));
  rp.profile = r;
  profileChart.data.datasets[0].data = r.samples.map((s) => ({ x: s.arc_length_m, y: s.risk }));
  profileChart.update('none');
  let text = `risk ${r.risk.toExponential(4)} casualties per flight, ${r.length_m.toFixed(0)} m, ` +
    `${r.risk_per_flight_hour.toExponential(2)} per flight hour, ${r.sample_count} samples; ` +
    (r.admissible ? 'admissible' : 'NOT admissible');
  if (!r.admissible && r.first_violation) text += ': ' + r.first_violation.message;
  $('evaluation').textContent = text;
  return r;
}

const polylineLayer = L.layerGroup().addTo(map);
let drawing = null;  // points of the polyline being drawn

function startPolyline() {
  drawing = [];
  polylineLayer.clearLayers();
  map.doubleClickZoom.disable();
  $('evaluate-polyline').disabled = false;
  $('map').style.cursor = 'crosshair';
}
map.on('click', (e) => {
  if (!drawing) return;
  drawing.push({ x: e.latlng.lng, y: e.latlng.lat, z: Number($('altitude').value) });
  polylineLayer.clearLayers();
  L.polyline(drawing.map((p) => [p.y, p.x]), { color: '#06f', weight: 3, dashArray: '6 4', className: 'drawn-polyline' }).addTo(polylineLayer);
  for (const p of drawing) L.circleMarker([p.y, p.x], { radius: 3, color: '#06f' }).addTo(polylineLayer);
});
async function evaluatePolyline() {
  const points = drawing || [];
  drawing = null;
  map.doubleClickZoom.enable();
  $('map').style.cursor = '';
  $('evaluate-polyline').disabled = true;
  if (points.length < 2) throw new ApiError('INVALID_ARGUMENT', 'a polyline needs at least 2 points', 'page');
  await evaluate({ polyline: { points } });
}

// ---------------------------------------------------------------------------
// Downloads: the server samples the path (in WGS84 on a geo-referenced map),
// the gateway writes the file.

async function download(format) {
  const waypoints = rp.finalTrajectory ? rp.finalTrajectory.waypoints : rp.bestWaypoints;
  if (!waypoints) throw new ApiError('FAILED_PRECONDITION', 'plan a trajectory first', 'page');
  const res = await fetch(`/api/export?format=${format}`, {
    method: 'POST', headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify({ map: rp.map.name, waypoints: { poses: waypoints }, path_spacing_m: 25 }),
  });
  if (!res.ok) {
    const j = await res.json().catch(() => ({ code: 'HTTP_' + res.status, message: res.statusText }));
    throw new ApiError(j.code, j.message, j.source);
  }
  const name = `riskplan-${rp.map.name}.${format}`;
  const url = URL.createObjectURL(await res.blob());
  const a = document.createElement('a');
  a.href = url; a.download = name;
  document.body.appendChild(a); a.click(); a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
  rp.downloads.push(name);
}

// ---------------------------------------------------------------------------

async function init() {
  const maps = (await api('GET', '/api/maps')).maps;
  const select = $('map-select');
  for (const m of maps) select.add(new Option(`${m.name}${m.geo ? ' (WGS84)' : ''}`, m.name));
  const wanted = new URLSearchParams(location.search).get('map');
  if (wanted && maps.some((m) => m.name === wanted)) select.value = wanted;
  const show = () => guarded(async () => {
    endpoints.start = endpoints.goal = null;
    drawEndpoint('start'); drawEndpoint('goal');
    if (overlays['risk layer']) { layerControl.removeLayer(overlays['risk layer']); map.removeLayer(overlays['risk layer']); delete overlays['risk layer']; delete legends['risk layer']; }
    await loadMap(maps.find((m) => m.name === select.value));
  });
  select.addEventListener('change', show);
  $('risk-show').onclick = () => guarded(showRiskLayer);
  $('set-start').onclick = () => pick('start');
  $('set-goal').onclick = () => pick('goal');
  $('plan').onclick = () => guarded(startPlan);
  $('cancel').onclick = () => guarded(cancelPlan);
  $('draw-polyline').onclick = startPolyline;
  $('evaluate-polyline').onclick = () => guarded(evaluatePolyline);
  $('download-geojson').onclick = () => guarded(() => download('geojson'));
  $('download-plan').onclick = () => guarded(() => download('plan'));
  $('download-kml').onclick = () => guarded(() => download('kml'));
  await show();
  rp.ready = true;
}

guarded(init);
