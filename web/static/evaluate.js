// riskplan-web's page: risk profiles, drawn polylines, and downloads.
'use strict';

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
      y: { title: { display: true, text: 'M, casualties per failure' }, ticks: { callback: (v) => Number(v).toExponential(1) } },
    },
    plugins: {
      legend: { labels: { boxWidth: 10 } },
      tooltip: { callbacks: { label: (c) => sampleText(rp.profile.samples[c.dataIndex]) } },
    },
    onHover: (e, items) => {
      if (!items.length || !rp.profile) return;
      const s = rp.profile.samples[items[0].index];
      profileMarker.setLatLng(frame.sampleAt(s)).addTo(map);
      $('sample').textContent = sampleText(s);
    },
  },
});

function sampleText(s) {
  return `${Number(s.arc_length_m).toFixed(0)} m, piece ${s.piece}: (${s.x.toFixed(0)}, ${s.y.toFixed(0)}, ${s.z.toFixed(0)}) m, ` +
    `M ${s.defined ? Number(s.risk).toExponential(3) : 'not defined'}, I ${Number(s.impact_factor).toExponential(2)} /m², ` +
    `S̃ ${Number(s.expected_shelter).toFixed(2)}, p_cas ${Number(s.casualty_probability).toFixed(3)}` +
    (s.ground_speed_mps !== undefined ? `, ground speed ${Number(s.ground_speed_mps).toFixed(1)} m/s` : '');
}

async function evaluate(trajectory) {
  const r = await api('POST', '/api/evaluate', Object.assign({ map: rp.map.name, include_samples: true }, windFields(), trajectory));
  if (r.wind) showWind(r.wind);
  rp.profile = r;
  profileChart.data.datasets[0].data = r.samples.map((s) => ({ x: s.arc_length_m, y: s.risk }));
  showChart('profile', true);
  profileChart.update('none');
  let text = `risk ${r.risk.toExponential(4)} casualties per flight, ${r.length_m.toFixed(0)} m, ` +
    `${r.risk_per_flight_hour.toExponential(2)} per flight hour, ${r.sample_count} samples; ` +
    (r.admissible ? 'admissible' : 'NOT admissible');
  if (r.wind && r.wind.speed_mps > 0) text += `; flight time ${r.flight_time_s.toFixed(0)} s in a wind of ${r.wind.speed_mps} m/s`;
  if (!r.admissible && r.first_violation) text += ': ' + r.first_violation.message;
  $('evaluation').textContent = text;
  return r;
}

let drawing = null;  // the polyline being drawn: {at (LatLng), z} per point

function startPolyline() {
  drawing = [];
  polylineLayer.clearLayers();
  map.doubleClickZoom.disable();
  $('evaluate-polyline').disabled = false;
  $('map').style.cursor = 'crosshair';
}
function addPolylinePoint(e) {
  if (!drawing) return;
  drawing.push({ at: e.latlng, z: Number($('altitude').value) });
  polylineLayer.clearLayers();
  L.polyline(drawing.map((p) => p.at), { color: '#06f', weight: 3, dashArray: '6 4', className: 'drawn-polyline' }).addTo(polylineLayer);
  for (const p of drawing) L.circleMarker(p.at, { radius: 3, color: '#06f' }).addTo(polylineLayer);
}
async function evaluatePolyline() {
  const points = drawing || [];
  drawing = null;
  map.doubleClickZoom.enable();
  $('map').style.cursor = '';
  $('evaluate-polyline').disabled = true;
  if (points.length < 2) throw new ApiError('INVALID_ARGUMENT', 'a polyline needs at least 2 points', 'page');
  const apiPoints = points.map((p) => frame.point(p.at, p.z));
  await evaluate({ [apiField('polyline', apiPoints[0])]: { points: apiPoints } });
}

// ---------------------------------------------------------------------------
// Downloads: the server samples the path (in WGS84 on a geo-referenced map),
// the gateway writes the file.

// The wind fields of a request (the plan's), for a download in the same wind.
function windOf(request) {
  const out = {};
  if (request && request.wind) out.wind = request.wind;
  if (request && request.wind_wgs84) out.wind_wgs84 = request.wind_wgs84;
  return out;
}

async function download(format) {
  const waypoints = rp.finalTrajectory ? rp.finalTrajectory.waypoints : rp.bestWaypoints;
  if (!waypoints) throw new ApiError('FAILED_PRECONDITION', 'plan a trajectory first', 'page');
  // A planned mission's .plan is the mission written back (mission.js).
  const mission = format === 'plan' && rp.mission && rp.mission.legEnds && rp.finalTrajectory;
  const res = mission ? await downloadMission() : await fetch(`/api/export?format=${format}`, {
    method: 'POST', headers: { 'Content-Type': 'application/json' },
    // In the plan's wind, so that the exported times are the plan's.
    body: JSON.stringify(Object.assign({ map: rp.map.name, waypoints: { poses: waypoints }, path_spacing_m: 25 },
      windOf(rp.lastPlanRequest))),
  });
  if (!res.ok) {
    const j = await res.json().catch(() => ({ code: 'HTTP_' + res.status, message: res.statusText }));
    throw new ApiError(j.code, j.message, j.source);
  }
  const name = mission ? `riskplan-mission-${rp.map.name}.plan` : `riskplan-${rp.map.name}.${format}`;
  const url = URL.createObjectURL(await res.blob());
  const a = document.createElement('a');
  a.href = url; a.download = name;
  document.body.appendChild(a); a.click(); a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
  rp.downloads.push(name);
}
