// riskplan-web's page: the Leaflet map, its overlays (the map's layers and
// the risk layer) and their legend.
'use strict';

// The map. Leaflet cannot change the CRS of a live map: a map of the other
// kind gets a new L.map, with its controls and layer groups.

let frame = null;
let map = null;
let layerControl = null;
const overlays = rp.overlays;  // name -> Leaflet layer
const legends = {};            // name -> HTML
// Layer groups of the live map.
let endpointLayers = null, trajectories = null, bestLayer = null, polylineLayer = null;
let missionLayer = null, missionRouteLayer = null;  // an uploaded mission's points, its legs planned
let flightLayer = null, zoneLayer = null, alertLayer = null;  // a flight: its route and aircraft, zones, alert

function makeMap() {
  if (map) map.remove();  // and every layer on it
  for (const name of Object.keys(overlays)) delete overlays[name];
  for (const name of Object.keys(legends)) delete legends[name];
  map = L.map('map', Object.assign({ crs: frame.leafletCrs, zoomSnap: 0.25, attributionControl: false }, frame.mapOptions));
  rp.leaflet = map;
  rp.crs = frame.crs;
  L.control.scale({ imperial: false, maxWidth: 160, position: 'bottomleft' }).addTo(map);
  layerControl = L.control.layers(null, null, { collapsed: false, position: 'topright' }).addTo(map);
  // The legend folds (a <details>): open, it covers the map's corner.
  const legend = L.control({ position: 'bottomright' });
  legend.onAdd = () => {
    const box = L.DomUtil.create('details', 'legend');
    box.id = 'legend-box';
    box.open = true;
    box.innerHTML = '<summary>Legend</summary><div id="legend"></div>';
    // Scrolling or clicking in it is not the map's.
    L.DomEvent.disableClickPropagation(box);
    L.DomEvent.disableScrollPropagation(box);
    return box;
  };
  legend.addTo(map);
  endpointLayers = { start: L.layerGroup().addTo(map), goal: L.layerGroup().addTo(map) };
  trajectories = L.layerGroup().addTo(map);   // earlier improvements, faded
  bestLayer = L.layerGroup().addTo(map);      // the newest
  polylineLayer = L.layerGroup().addTo(map);  // a drawn polyline
  missionLayer = L.layerGroup().addTo(map);
  missionRouteLayer = L.layerGroup().addTo(map);
  zoneLayer = L.layerGroup().addTo(map);
  flightLayer = L.layerGroup().addTo(map);
  alertLayer = L.layerGroup().addTo(map);
  map.on('overlayadd overlayremove', drawLegend);
  map.on('mousemove', (e) => { $('cursor').textContent = frame.cursorText(e.latlng); });
  map.on('mousedown', pressEndpoint);
  map.on('mousemove', dragEndpoint);
  map.on('mouseup', releaseEndpoint);
  map.on('click', addPolylinePoint);
  map.on('click', placeZoneAt);
}

// What the page draws over the layers: the mission and the plan.
const ROUTE_LEGEND =
  '<div class="item"><span class="key" style="background:#06c;border-radius:6px"></span>start, its line the heading</div>' +
  '<div class="item"><span class="key" style="background:#a0a;border-radius:6px"></span>goal, its line the heading</div>' +
  '<div class="item"><span class="line" style="border-color:#d00"></span>best trajectory so far</div>' +
  '<div class="item"><span class="line" style="border-color:#aaa"></span>earlier improvements (fainter: older)</div>' +
  '<div class="item"><span class="line" style="border-color:#06f;border-top-style:dashed"></span>drawn polyline</div>' +
  '<div class="item"><span class="key" style="background:#fc6;border-radius:6px"></span>mission point of an uploaded .plan</div>' +
  '<div class="item"><span class="line" style="border-color:#036;border-top-width:5px"></span>flight: the committed prefix</div>' +
  '<div class="item"><span class="line" style="border-color:#f60;border-top-style:dashed"></span>flight: the remainder, replanned as zones come</div>' +
  '<div class="item"><span class="key" style="background:#fff;border:3px solid #000;border-radius:6px"></span>the aircraft</div>' +
  '<div class="item"><span class="key" style="background:rgba(255,0,0,0.3);border-color:#c00;border-radius:6px"></span>no-fly zone placed in flight</div>';

function drawLegend() {
  const parts = [ROUTE_LEGEND];
  for (const name of Object.keys(legends)) {
    if (overlays[name] && map.hasLayer(overlays[name])) parts.push(legends[name]);
  }
  $('legend').innerHTML = parts.join('');
}

function scaleLegend(title, stops, ticks) {
  return `<div class="item"><b>${title}</b><div class="bar" style="background:${cssGradient(stops)}"></div>` +
    `<div class="ticks">${ticks.map((t) => `<span>${t}</span>`).join('')}</div></div>`;
}

function addOverlay(name, layer, shown, legendHtml) {
  removeOverlay(name);
  overlays[name] = layer;
  if (legendHtml) legends[name] = legendHtml;
  layerControl.addOverlay(layer, name);
  if (shown) layer.addTo(map);
  rp.layersDrawn[name] = true;
  drawLegend();
}

function removeOverlay(name) {
  if (!overlays[name]) return;
  layerControl.removeLayer(overlays[name]);
  map.removeLayer(overlays[name]);
  delete overlays[name];
  delete legends[name];
}

// A grid layer (GetMapLayer, GetRiskLayer) as an image at its place.
function rasterOverlay(layer, url) {
  return L.imageOverlay(url, frame.rect(layer.x0_m, layer.y0_m, layer.nx * layer.cell_m, layer.ny * layer.cell_m,
    layer.bounds_wgs84), { className: 'raster', opacity: 1 });
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
  const next = frameFor(info);
  const remake = !frame || next.crs !== frame.crs;
  frame = next;
  if (remake) {
    makeMap();
    // A pick or a polyline under way belonged to the other frame.
    picking = null; pressed = null; dragLine = null; drawing = null;
    $('evaluate-polyline').disabled = true;
    $('map').style.cursor = '';
  }
  rp.map = info;
  rp.layersDrawn = {};
  endpoints.start = endpoints.goal = null;
  drawEndpoint('start'); drawEndpoint('goal');
  clearMission();  // its points were on the map shown before
  removeOverlay('risk layer');
  const b = frame.rect(info.x0_m, info.y0_m, info.width_m, info.height_m, info.bounds_wgs84);
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
    L.circleMarker(frame.siteAt(s), { radius: 5, color: '#064', fillColor: '#2c2', fillOpacity: 0.9, className: 'landing-site' })
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
    // The track as the API's theta: counter-clockwise from east (grid).
    heading_rad: maxOver ? 0 : (90 - Number($('risk-heading').value)) * Math.PI / 180,
    ...windFields(),
  });
  if (layer.wind) showWind(layer.wind);
  const values = layer.risk.map(Number);  // "NaN" where M is not defined
  const [lo, hi] = decades(values);
  const url = gridImage(layer.nx, layer.ny, values, (v) => {
    if (!isFinite(v)) return [120, 120, 120, 90];
    if (!(v > 0)) return null;
    const c = ramp(HOT, (Math.log10(v) - lo) / (hi - lo));
    return [c[0], c[1], c[2], 190];
  });
  addOverlay('risk layer', rasterOverlay(layer, url), true,
    scaleLegend(`risk M at ${layer.height_agl_m} m above ground${layer.max_over_headings ? ' (max over headings)' : ''}${layer.wind && layer.wind.speed_mps > 0 ? ` in a wind of ${layer.wind.speed_mps} m/s` : ''}, casualties per failure`,
      HOT, Array.from({ length: hi - lo + 1 }, (_, k) => `1e${lo + k}`)) +
    '<div class="item"><span class="key" style="background:rgba(120,120,120,0.5)"></span>M not defined (impact outside the map)</div>');
}
