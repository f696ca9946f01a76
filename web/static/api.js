// riskplan-web's page, the first of its scripts: what the tests read (rp),
// the calls to the gateway, and how errors are shown. app.js says how the
// scripts fit together.
'use strict';

// What the tests and the latency measurement read.
const rp = window.rp = {
  map: null,            // the MapInfo shown
  crs: null,            // 'Simple' (local metres) or 'EPSG:3857' (WGS84)
  leaflet: null,        // the L.map, made anew when the CRS changes
  overlays: {},         // layer name -> Leaflet layer
  layersDrawn: {},      // layer name -> true once its image is on the map
  planId: null,
  state: 'idle',        // idle, starting, running, finished, failed, cancelled
  improvements: [],     // {id, risk, iterations, elapsed_s} per drawn update
  latencies: [],        // ms from the gateway reading an update to the page drawing it
  finalTrajectory: null,
  front: null,          // the newest risk-time front drawn (PlanUpdate.front)
  frontShown: null,     // the index in it of the route drawn in blue, once clicked
  profile: null,        // the last EvaluateRisk response drawn as a profile
  bestPath: null,       // the newest trajectory as drawn: [lat, lng] per point
  lastPlanRequest: null,
  downloads: [],        // file names saved
  // ms since the page's navigation began (performance.now()): the first
  // map drawn (its layers on the map, the frame after), and each later
  // map's switch (from the choice to its layers drawn).
  timings: { firstMapMs: null, mapSwitchMs: [] },
};

const $ = (id) => document.getElementById(id);
const nowMs = () => performance.timeOrigin + performance.now();

// ---------------------------------------------------------------------------
// Calls and errors

class ApiError extends Error {
  constructor(code, message, source) { super(message); this.code = code; this.source = source; }
}

// body: sent as JSON, or as it is when raw (a file's text).
async function api(method, path, body, raw) {
  const init = { method, headers: {} };
  if (body !== undefined) {
    init.body = raw ? body : JSON.stringify(body);
    init.headers['Content-Type'] = raw ? 'text/plain' : 'application/json';
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
  // At the top of the side panel and sticky there: in view wherever the
  // button that failed was.
  $('error').scrollIntoView({ block: 'nearest' });
}
$('error-close').onclick = () => clearError();
function clearError() { $('error').hidden = true; $('error-message').textContent = ''; }

async function guarded(fn) {
  try { clearError(); await fn(); } catch (err) { showError(err); }
}
