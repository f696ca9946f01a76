// riskplan-web's page: the mission's start and goal, set on the map.
'use strict';

// Start and goal: press, drag for the heading, release. Each is kept as the
// API's pose that the request carries (a Pose, or a GeoPose on a
// geo-referenced map).

const endpoints = { start: null, goal: null };
rp.endpoints = endpoints;
let picking = null;  // 'start' | 'goal' | null
let pressed = null;  // the point pressed, while dragging
let dragLine = null;

function drawEndpoint(which) {
  const p = endpoints[which];
  const g = endpointLayers[which];
  g.clearLayers();
  if (!p) { $(which + '-text').textContent = which + ': –'; return; }
  const colour = which === 'start' ? '#06c' : '#a0a';
  const len = Math.max(rp.map.width_m, rp.map.height_m) / 30;
  const at = frame.poseAt(p);
  L.circleMarker(at, { radius: 7, color: colour, fillOpacity: 0.8, className: 'endpoint-' + which })
    .bindTooltip(which + ' ' + frame.poseText(p)).addTo(g);
  L.polyline([at, frame.ahead(at, frame.poseBearing(p), len)], { color: colour, weight: 3 }).addTo(g);
  $(which + '-text').textContent = which + ': ' + frame.poseText(p);
}

// For scripts (the benchmark): a pose given exactly rather than by a click,
// a Pose (local metres) or, on a geo-referenced map, a GeoPose; the request
// carries it in its own form.
rp.setEndpoint = (which, pose) => { endpoints[which] = pose; drawEndpoint(which); };

function pick(which) {
  picking = which;
  map.dragging.disable();
  $('map').style.cursor = 'crosshair';
}

function pressEndpoint(e) {
  if (!picking) return;
  // With dragging off, the browser would select the page's text instead.
  L.DomEvent.preventDefault(e.originalEvent);
  pressed = e.latlng;
  dragLine = L.polyline([pressed, pressed], { color: '#333', dashArray: '4 4' }).addTo(map);
}
function dragEndpoint(e) { if (pressed && dragLine) dragLine.setLatLngs([pressed, e.latlng]); }
function releaseEndpoint(e) {
  if (!picking || !pressed) return;
  const p0 = map.latLngToContainerPoint(pressed), p1 = map.latLngToContainerPoint(e.latlng);
  // A click without a drag keeps the heading north-east.
  const to = p0.distanceTo(p1) >= 5 ? e.latlng : null;
  endpoints[picking] = frame.pose(pressed, to, Number($('altitude').value));
  drawEndpoint(picking);
  // A start or goal set by hand is a plan of its own, not the mission's.
  if (rp.mission) clearMission();
  if (dragLine) map.removeLayer(dragLine);
  dragLine = null; pressed = null; picking = null;
  map.dragging.enable();
  $('map').style.cursor = '';
}
