// riskplan-web's page: a plan's live view, from its event stream.
'use strict';

// Plans: the live view

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
  const path = frame.pathOf(t);
  rp.bestPath = path;
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
  if (u.wind) showWind(u.wind);
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
    rp.lastPlanRequest = request;
    const r = await api('POST', '/api/plans', request);
    rp.planId = r.id;
    watch(r.id);
  } catch (err) { setState('failed'); throw err; }
}

async function cancelPlan() {
  if (rp.planId) await api('POST', `/api/plans/${rp.planId}/cancel`);
}
