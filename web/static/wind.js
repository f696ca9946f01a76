// riskplan-web's page: the mean wind (risk model version 3). The user sets
// its speed and the direction it blows from; plans, evaluations and risk
// layers send it (windFields), and an arrow on the map shows the wind of the
// last answer (every answer echoes it, docs/api.md "Wind") or, before any,
// the one set. On a geo-referenced map the direction is from true north and
// goes as wind_wgs84; on a local one it is from the map's grid north.
'use strict';

// The request fields of the wind set on the page: {} in still air.
function windFields() {
  const speed = Number($('wind-speed').value);
  const from = Number($('wind-from').value);
  if (!(speed > 0)) return {};
  const w = { from: { speed_mps: speed, from_deg: from } };
  return rp.map && rp.map.geo ? { wind_wgs84: w } : { wind: w };
}

// The arrow: a Leaflet control in the map's top-right corner pointing where
// the air moves to, with the speed and the direction it blows from. The map
// is made anew for each map chosen (map.js, makeMap), so the control is put
// on the current one whenever it is not there yet.
const WindControl = L.Control.extend({
  options: { position: 'topright' },
  onAdd() {
    const div = L.DomUtil.create('div', 'legend wind-arrow');
    div.id = 'wind-arrow';
    div.hidden = true;
    return div;
  },
});
let windControlMap = null;
let shownWind = null;

function windArrow() {
  if (!map) return null;
  if (windControlMap !== map) {
    new WindControl().addTo(map);
    windControlMap = map;
  }
  return $('wind-arrow');
}

// Draws `w` (a WindReport, or the page's inputs as one): nothing in still air.
function showWind(w) {
  shownWind = w;
  const div = windArrow();
  if (!div) return;
  const speed = Number(w && w.speed_mps) || 0;
  if (!(speed > 0)) { div.hidden = true; div.innerHTML = ''; return; }
  // The direction it blows FROM, clockwise from north; the arrow points
  // downwind (from + 180). On a geo map the true direction is the one shown.
  const from = Number(w.from_true_deg !== undefined ? w.from_true_deg : w.from_deg) || 0;
  div.hidden = false;
  div.innerHTML =
    `<svg width="44" height="44" viewBox="-22 -22 44 44"><g transform="rotate(${(from + 180) % 360})">` +
    '<line x1="0" y1="16" x2="0" y2="-12" stroke="#111" stroke-width="3"/>' +
    '<polygon points="0,-19 -7,-8 7,-8" fill="#111"/></g></svg>' +
    `<div>wind ${speed.toFixed(1)} m/s</div><div>from ${from.toFixed(0)}°</div>`;
  div.title = `wind ${speed} m/s from ${from.toFixed(1)}° (${w.from_true_deg !== undefined ? 'true' : 'grid'} north)`;
}

// The inputs' wind, until an answer echoes the server's.
function showInputWind() {
  showWind({ speed_mps: Number($('wind-speed').value), from_deg: Number($('wind-from').value) });
}
$('wind-speed').addEventListener('input', showInputWind);
$('wind-from').addEventListener('input', showInputWind);
showInputWind();
// A map chosen in the selector is a new Leaflet map: the arrow follows it.
setInterval(() => { if (map && windControlMap !== map) showWind(shownWind); }, 500);
