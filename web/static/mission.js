// riskplan-web's page: QGroundControl missions. A .plan uploaded from the
// page is read by the gateway (POST /api/mission/parse: geo/export's .plan
// reader, as `riskplan plan --mission` reads it; the page never parses a
// .plan itself), fills the form (the map that holds it, start and goal, the
// limits of its "riskplan" section) and is planned leg by leg (POST
// /api/mission/plans, its events as a plan's); the planned mission is
// downloaded as a .plan QGroundControl opens (POST /api/mission/export).
'use strict';

// What the page keeps of an uploaded mission: its file's name and text, the
// gateway's reading of it, and, once planned, the index of each leg's last
// waypoint in the final trajectory (for the download).
rp.mission = null;  // {name, text, parsed, legEnds}

function clearMission() {
  rp.mission = null;
  if (missionLayer) missionLayer.clearLayers();
  if (missionRouteLayer) missionRouteLayer.clearLayers();
  $('mission-text').textContent = 'no mission loaded';
  $('mission-progress').textContent = '';
}

// The geo-referenced map whose WGS84 corners hold (lat, lon), the shown one
// first.
function mapHolding(lat, lon) {
  const holds = (m) => {
    const c = m.bounds_wgs84 && m.bounds_wgs84.corners;
    if (!c || c.length !== 4) return false;
    const lats = c.map((g) => g.lat_deg), lons = c.map((g) => g.lon_deg);
    return lat >= Math.min(...lats) && lat <= Math.max(...lats) && lon >= Math.min(...lons) && lon <= Math.max(...lons);
  };
  if (rp.map && holds(rp.map)) return rp.map;
  return (rp.maps || []).find(holds) || null;
}

function describeMission(name, m) {
  const kinds = {};
  for (const p of m.points) kinds[p.kind] = (kinds[p.kind] || 0) + 1;
  const parts = Object.entries(kinds).map(([k, n]) => (n > 1 ? `${n} ${k}s` : `${n} ${k}`));
  let text = `${name}: ${m.points.length} points (${parts.join(', ')}), ${m.legs.length} leg${m.legs.length > 1 ? 's' : ''}`;
  if (m.limits) {
    const l = m.limits, said = [];
    if (l.max_flight_time_s > 0) said.push(`endurance ${l.max_flight_time_s} s`);
    if (l.max_risk_per_flight_hour > 0) said.push(`target level of safety ${l.max_risk_per_flight_hour} per flight hour`);
    if (l.objective === 'MIN_TIME') said.push('least flight time');
    if (l.pareto) said.push('risk–time front');
    text += `; limits from its riskplan section: ${said.length ? said.join(', ') : 'none'}`;
  }
  return text;
}

// The form from the mission's limits (the file's "riskplan" section).
function fillLimits(l) {
  $('max-flight-time').value = l.max_flight_time_s > 0 ? String(l.max_flight_time_s) : '0';
  $('enforce-los').checked = l.max_risk_per_flight_hour > 0;
  if (l.max_risk_per_flight_hour > 0) $('target-los').value = String(l.max_risk_per_flight_hour);
  $('objective').value = l.objective === 'MIN_TIME' ? 'MIN_TIME' : 'MIN_RISK';
  $('pareto').checked = !!l.pareto;
}

function drawMission(m) {
  missionLayer.clearLayers();
  L.polyline(m.points.map((p) => [p.lat_deg, p.lon_deg]), { color: '#a60', weight: 1.5, dashArray: '3 5' }).addTo(missionLayer);
  m.points.forEach((p) => {
    L.circleMarker([p.lat_deg, p.lon_deg], { radius: 6, color: '#a60', fillColor: '#fc6', fillOpacity: 1, className: 'mission-point' })
      .bindTooltip(`${p.name}: ${p.lat_deg.toFixed(6)}°, ${p.lon_deg.toFixed(6)}°, ${p.alt_m.toFixed(1)} m AMSL, heading ${p.heading_deg.toFixed(0)}°${p.heading_given ? '' : ' (chosen)'}`)
      .addTo(missionLayer);
  });
}

// A .plan chosen in the page's file field: read by the gateway, shown, planned.
async function uploadMission(file) {
  const text = await file.text();
  const parsed = await api('POST', '/api/mission/parse', text, true);
  const first = parsed.points[0];
  const holder = mapHolding(first.lat_deg, first.lon_deg);
  if (!holder) {
    throw new ApiError('FAILED_PRECONDITION', `${first.name} at (${first.lat_deg.toFixed(6)}, ${first.lon_deg.toFixed(6)}) is on none of the server's geo-referenced maps`, 'page');
  }
  if (holder !== rp.map) await rp.showMap(holder.name);
  clearMission();
  rp.mission = { name: file.name, text, parsed, legEnds: null };
  rp.setEndpoint('start', parsed.legs[0].start);
  rp.setEndpoint('goal', parsed.legs[parsed.legs.length - 1].goal);
  if (parsed.limits) fillLimits(parsed.limits);
  drawMission(parsed);
  $('mission-text').textContent = describeMission(file.name, parsed);
  await startPlan();
}

// The PlanRequest of a mission: the page's fields, without start and goal
// (the mission's points); the budget is each leg's.
async function startMissionPlan(request) {
  delete request.start; delete request.goal; delete request.start_wgs84; delete request.goal_wgs84;
  missionRouteLayer.clearLayers();
  rp.mission.legEnds = null;
  const r = await api('POST', '/api/mission/plans', { plan: rp.mission.text, request });
  $('mission-progress').textContent = `planning leg 1 of ${r.legs}`;
  return r;
}

// An event of a mission's leg (its "leg" and "legs"): a leg's final
// trajectory stays on the map while the next is planned.
function onMissionLeg(d, u) {
  $('mission-progress').textContent = u.final
    ? `leg ${d.leg + 1} of ${d.legs} planned${d.leg + 1 < d.legs ? `; planning leg ${d.leg + 2}` : ''}`
    : `planning leg ${d.leg + 1} of ${d.legs}`;
  if (!u.final || !u.trajectory || !u.trajectory.path || !u.trajectory.path.length) return;
  L.polyline(frame.pathOf(u.trajectory), { color: '#d00', weight: 3, className: 'mission-leg' }).addTo(missionRouteLayer);
  bestLayer.clearLayers();
  trajectories.clearLayers();
}

// The mission's final event: the legs joined, or the leg that failed.
function onMissionFinal(d) {
  if (!rp.mission) return;
  if (d.mission.leg_ends) {
    rp.mission.legEnds = d.mission.leg_ends;
    missionRouteLayer.clearLayers();
    $('mission-progress').textContent = `the mission's ${d.mission.legs} legs planned`;
  } else {
    $('mission-progress').textContent = `leg ${d.mission.failed_leg + 1} of ${d.mission.legs} could not be planned`;
  }
}

// The planned mission as a .plan: the mission's own items at their planned
// places, the route's samples between them, its limits in the "riskplan"
// section (read back with the mission when uploaded again).
async function downloadMission() {
  const t = rp.finalTrajectory;
  const body = {
    plan: rp.mission.text, leg_ends: rp.mission.legEnds,
    request: Object.assign({ map: rp.map.name, waypoints: { poses: t.waypoints } }, windOf(rp.lastPlanRequest)),
  };
  if (rp.lastPlanRequest && rp.lastPlanRequest.limits) body.limits = rp.lastPlanRequest.limits;
  return fetch('/api/mission/export', {
    method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body),
  });
}
