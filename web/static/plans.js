// riskplan-web's page: a plan's live view, from its event stream.
'use strict';

// Plans: the live view

let source = null;
let lastSeenId = 0;

const riskChart = new Chart($('risk-chart'), {
  type: 'line',
  data: {
    datasets: [
      { label: 'best risk', data: [], stepped: 'after', borderColor: '#c33', pointRadius: 2 },
      // What the best trajectory may carry to meet the target level of
      // safety (a rate per flight hour) over its own flight time.
      { label: 'target level of safety × flight time', data: [], stepped: 'after', borderColor: '#2a2', borderDash: [6, 4], pointRadius: 0, borderWidth: 1.5 },
    ],
  },
  options: {
    animation: false, maintainAspectRatio: false, parsing: false,
    scales: {
      x: { type: 'linear', title: { display: true, text: 'planner time, s' } },
      y: { title: { display: true, text: 'casualties per flight' }, ticks: { callback: (v) => Number(v).toExponential(1) } },
    },
    plugins: { legend: { labels: { boxWidth: 10 } } },
  },
});

// The API's end reasons in words (the code stays in the tooltip).
const END_REASONS = {
  BUDGET_EXHAUSTED: 'the budget was used up',
  CONVERGED: 'converged: no better trajectory can be found',
  NO_SOLUTION: 'no admissible trajectory was found within the budget',
  SHUTDOWN: 'the server shut down; its best trajectory so far',
  CANCELLED: 'cancelled',
};
const endReasonText = (r) => END_REASONS[r] || String(r).toLowerCase().replace(/_/g, ' ');

// A chart's box is shown once it has something to draw; until then a line
// says what it will show.
function showChart(name, shown) {
  $(name + '-chart-box').hidden = !shown;
  $(name + '-chart-empty').hidden = shown;
}

// The target level of safety of the page's field, per flight hour.
function targetLevelOfSafety() {
  const v = Number($('target-los').value);
  if (!(v > 0) || !isFinite(v)) throw new ApiError('INVALID_ARGUMENT', `target level of safety has value '${$('target-los').value}'; it must be a number > 0 (casualties per flight hour, e.g. 1e-6)`, 'page');
  return v;
}

function setState(s) {
  rp.state = s;
  $('state').textContent = s;
  $('state').title = '';
  const active = s === 'starting' || s === 'running' || s === 'reconnecting';
  $('plan').disabled = active;
  $('cancel').disabled = !active;
}

// The most improvements kept on the map, the newest in red, the previous
// ones in grey fading with age.
const HISTORY_KEPT = 30;

function drawTrajectory(t) {
  const path = frame.pathOf(t);
  rp.bestPath = path;
  // The previous best joins the history. It leaves bestLayer first: a
  // group's clearLayers takes its layers off the map, wherever else they are.
  const previous = bestLayer.getLayers();
  bestLayer.clearLayers();
  for (const l of previous) {
    l.setStyle({ color: '#888', weight: 1.5, opacity: 0.6 });
    trajectories.addLayer(l);  // back on the map, in the history's group
    const el = l.getElement();
    if (el) { el.classList.remove('best-trajectory'); el.classList.add('history-trajectory'); }
  }
  // Keep the picture (and the page's memory) bounded; the older, the fainter.
  const old = trajectories.getLayers();
  for (let k = 0; k + HISTORY_KEPT < old.length; k++) trajectories.removeLayer(old[k]);
  const kept = trajectories.getLayers();
  kept.forEach((l, k) => l.setStyle({ opacity: 0.15 + 0.5 * (k + 1) / kept.length }));
  L.polyline(path, { color: '#d00', weight: 3, className: 'best-trajectory' }).addTo(bestLayer);
}

// The page's limits (PlanRequest.limits, docs/api.md "Limits"): none when
// every field is at its default.
function limitFields() {
  const t = Number($('max-flight-time').value);
  if (!(t >= 0) || !isFinite(t)) throw new ApiError('INVALID_ARGUMENT', `endurance has value '${$('max-flight-time').value}'; it must be a number >= 0 (s; 0: none)`, 'page');
  const limits = {};
  if (t > 0) limits.max_flight_time_s = t;
  if ($('enforce-los').checked) limits.max_risk_per_flight_hour = targetLevelOfSafety();
  if ($('objective').value !== 'MIN_RISK') limits.objective = $('objective').value;
  if ($('pareto').checked) limits.pareto = true;
  return Object.keys(limits).length ? { limits } : {};
}

// The front (PlanUpdate.front) as points of risk against flight time; a
// click draws that point's route in blue.
function drawFront(front) {
  rp.front = front;
  const svg = $('front-chart');
  const W = 320, H = 170, pad = 36;
  const ts = front.map((t) => t.flight_time_s), rs = front.map((t) => t.risk);
  const t0 = Math.min(...ts), t1 = Math.max(...ts), r0 = Math.min(...rs), r1 = Math.max(...rs);
  const x = (t) => pad + (W - 2 * pad) * (t1 > t0 ? (t - t0) / (t1 - t0) : 0.5);
  const y = (r) => H - pad + (2 * pad - H) * (r1 > r0 ? (r - r0) / (r1 - r0) : 0.5);
  const ns = 'http://www.w3.org/2000/svg';
  svg.replaceChildren();
  const text = (tx, ty, s, anchor) => {
    const el = document.createElementNS(ns, 'text');
    el.setAttribute('x', tx); el.setAttribute('y', ty); el.setAttribute('font-size', '10');
    el.setAttribute('text-anchor', anchor || 'start'); el.textContent = s; svg.appendChild(el);
  };
  text(pad, H - 8, `${t0.toFixed(0)} s`); text(W - pad, H - 8, `${t1.toFixed(0)} s`, 'end');
  text(2, pad - 6, r1.toExponential(2)); text(2, H - pad + 12, r0.toExponential(2));
  front.forEach((t, k) => {
    const c = document.createElementNS(ns, 'circle');
    c.setAttribute('cx', x(t.flight_time_s)); c.setAttribute('cy', y(t.risk)); c.setAttribute('r', 4);
    c.setAttribute('fill', '#36c'); c.style.cursor = 'pointer';
    c.setAttribute('class', 'front-point'); c.dataset.index = k;
    const title = document.createElementNS(ns, 'title');
    title.textContent = `front ${k + 1}/${front.length}: ${t.flight_time_s.toFixed(1)} s, risk ${t.risk.toExponential(3)}, ${t.length_m.toFixed(0)} m`;
    c.appendChild(title);
    c.addEventListener('click', () => {
      if (!rp.frontLayer) rp.frontLayer = L.layerGroup().addTo(map);
      rp.frontLayer.clearLayers();
      if (t.path && t.path.length) L.polyline(frame.pathOf(t), { color: '#36c', weight: 3, className: 'front-route' }).addTo(rp.frontLayer);
      rp.frontShown = k;
    });
    svg.appendChild(c);
  });
  $('front-box').hidden = false;
}

function onUpdate(e) {
  const id = Number(e.lastEventId);
  if (id <= lastSeenId) return;  // already drawn before a reconnection
  lastSeenId = id;
  const d = JSON.parse(e.data);
  const u = d.update;
  if (u.wind) showWind(u.wind);
  $('iterations').textContent = u.iterations;
  $('improvements').textContent = u.improvements;
  if (u.front && u.front.length) drawFront(u.front);
  if (u.limits && u.limits.note) { $('limits-note').textContent = u.limits.note; $('limits-note').hidden = false; }
  if (d.mission) onMissionFinal(d);
  const t = u.trajectory;
  if (t && t.path && t.path.length) {
    drawTrajectory(t);
    rp.bestWaypoints = t.waypoints;
    $('risk').textContent = `${t.risk.toExponential(4)} (${t.length_m.toFixed(0)} m, flight time ${t.flight_time_s.toFixed(1)} s, ${t.risk_per_flight_hour.toExponential(2)} per flight hour)`;
    riskChart.data.datasets[0].data.push({ x: u.elapsed_s, y: t.risk });
    riskChart.data.datasets[1].data.push({ x: u.elapsed_s, y: rp.targetLevelOfSafety * t.flight_time_s / 3600 });
    showChart('risk', true);
    riskChart.update('none');
    rp.improvements.push({ id, risk: t.risk, iterations: Number(u.iterations), elapsed_s: u.elapsed_s,
      flight_time_s: t.flight_time_s, risk_per_flight_hour: t.risk_per_flight_hour, length_m: t.length_m });
    for (const b of ['download-geojson', 'download-plan', 'download-kml']) $(b).disabled = false;
    // Drawn: the first animation frame after the map and the plot changed.
    requestAnimationFrame(() => rp.latencies.push(nowMs() - d.gateway_ms));
  }
  if (d.leg !== undefined) onMissionLeg(d, u);
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
      $('state').textContent = `finished: ${endReasonText(u.end_reason)}, ${u.iterations} iterations`;
      $('state').title = u.end_reason;
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

// The PlanRequest of the page's fields: map, start, goal, algorithm,
// budget, seed, update interval, wind and limits (a flight's FlightOpen.plan
// too).
function planRequest() {
  const request = {
    map: rp.map.name,
    [apiField('start', endpoints.start)]: endpoints.start, [apiField('goal', endpoints.goal)]: endpoints.goal,
    algorithm: $('algorithm').value,
    budget: { time_ms: String(Number($('budget-ms').value)), iterations: String(Number($('budget-iterations').value)) },
    seed: String(Number($('seed').value)),
    // The server coalesces what it finds in between (newest wins): more
    // than about 20 pictures a second is more than anyone can follow.
    min_update_interval_ms: String(Number($('update-interval').value)),
  };
  Object.assign(request, windFields());
  Object.assign(request, limitFields());
  return request;
}

async function startPlan() {
  if (!endpoints.start || !endpoints.goal) throw new ApiError('INVALID_ARGUMENT', 'set a start and a goal on the map first', 'page');
  rp.targetLevelOfSafety = targetLevelOfSafety();
  closeSource();
  trajectories.clearLayers(); bestLayer.clearLayers();
  riskChart.data.datasets[0].label = 'best risk (casualties per flight)';
  riskChart.data.datasets[1].label = `target level of safety ${rp.targetLevelOfSafety.toExponential(0)} per flight hour × flight time`;
  for (const set of riskChart.data.datasets) set.data = [];
  riskChart.update('none');
  showChart('risk', false);
  rp.improvements = []; rp.finalTrajectory = null;
  if (rp.frontLayer) rp.frontLayer.clearLayers();
  rp.front = null; rp.frontShown = null;
  $('front-box').hidden = true; $('limits-note').hidden = true;
  $('iterations').textContent = '0'; $('improvements').textContent = '0'; $('risk').textContent = '–';
  setState('starting');
  try {
    const request = planRequest();
    rp.lastPlanRequest = request;
    const r = rp.mission ? await startMissionPlan(request) : await api('POST', '/api/plans', request);
    rp.planId = r.id;
    watch(r.id);
  } catch (err) { setState('failed'); throw err; }
}

async function cancelPlan() {
  if (rp.planId) await api('POST', `/api/plans/${rp.planId}/cancel`);
}
