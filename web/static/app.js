// riskplan-web's page. Talks only to the gateway (same origin): /api/... for
// the calls (JSON forms of riskplan.v1's messages, docs/api.md) and
// /api/plans/ID/events for a plan's Server-Sent Events. A local map is shown
// in its metres (Leaflet's CRS.Simple), a geo-referenced one in WGS84
// (Leaflet's default EPSG:3857): see frames.js.
//
// The page's scripts, one concept each, are classic scripts that index.html
// loads in this order; they share one global scope, so each may use what the
// earlier ones declare when it loads, and anything of any of them in its
// functions: api.js (rp, calls and errors), colours.js, frames.js, map.js
// (the map and its layers), endpoints.js (start and goal), plans.js (the
// live view), evaluate.js (profiles, polylines, downloads), mission.js
// (QGroundControl missions uploaded and downloaded), flight.js (flight
// mode), wind.js, and this one,
// which starts the page once every other is loaded.
'use strict';

async function init() {
  const maps = (await api('GET', '/api/maps')).maps;
  rp.maps = maps;
  const select = $('map-select');
  for (const m of maps) select.add(new Option(`${m.name}${m.geo ? ' (WGS84)' : ''}`, m.name));
  const wanted = new URLSearchParams(location.search).get('map');
  if (wanted && maps.some((m) => m.name === wanted)) select.value = wanted;
  // Each map's time to be drawn, from its choice to the frame after its
  // layers (rp.timings; the browser test reports them).
  const show = () => guarded(async () => {
    const began = performance.now();
    await loadMap(maps.find((m) => m.name === select.value));
    await new Promise((resolve) => requestAnimationFrame(() => resolve()));
    if (rp.timings.firstMapMs === null) rp.timings.firstMapMs = performance.now();
    else rp.timings.mapSwitchMs.push(performance.now() - began);
  });
  select.addEventListener('change', show);
  // For the mission upload: shows the map `name` as a choice in the selector would.
  rp.showMap = async (name) => { select.value = name; await show(); };
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
  $('fly').onclick = () => guarded(startFlight);
  $('end-flight').onclick = () => guarded(endFlight);
  $('place-zone').onclick = togglePlacingZone;
  $('polygon-zone').onclick = () => guarded(togglePolygonZone);
  $('mission-file').onchange = (e) => {
    const file = e.target.files[0];
    e.target.value = '';  // the same file chosen again is a new upload
    if (file) guarded(() => uploadMission(file));
  };
  await show();
  rp.ready = true;
}

guarded(init);
