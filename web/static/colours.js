// riskplan-web's page: colour ramps, and grids drawn into images.
'use strict';

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
