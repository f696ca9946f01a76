// riskplan-web's page: the frames, local metres or WGS84.
'use strict';

// Frames: the one place where the page's positions (Leaflet LatLngs) meet the
// API's. A map without geo-reference is shown in Leaflet's CRS.Simple in its
// local metres (lat = y north, lng = x east), so a scale bar in metres is
// exact; its requests are local. A geo-referenced map is shown in Leaflet's
// default CRS (EPSG:3857) in WGS84 latitudes and longitudes, and its requests
// carry the API's *_wgs84 fields: the server, which owns the projection,
// converts them; trajectories are drawn from its path_wgs84.

const DEG = Math.PI / 180;
const EARTH_RADIUS_M = 6371008.8;  // for a heading's arrow and a drag's direction only
const turn = (a, full) => ((a % full) + full) % full;
// The request field for a pose or point in either of the API's forms: a
// GeoPose or GeoPoint3 goes in the *_wgs84 twin ('start_wgs84').
const isWgs84 = (v) => v.lat_deg !== undefined;
const apiField = (name, value) => (isWgs84(value) ? name + '_wgs84' : name);

function frameFor(info) {
  const c = info.geo && info.bounds_wgs84 && info.bounds_wgs84.corners;
  return c && c.length === 4 ? geoFrame(info, c) : localFrame(info);
}

// Every frame has the same members:
//   crs, leafletCrs, mapOptions  what the L.map is made with
//   rect(x0, y0, w, h, geoBounds)  a local rectangle as LatLngBounds (geoBounds:
//                                  the server's WGS84 corners of it, when given)
//   pathOf(trajectory), sampleAt(sample), siteAt(landingSite): LatLngs to draw
//   pose(at, to, z)      the API's pose pressed at `at` (LatLng) heading towards
//                        `to` (null: north-east), at z m AMSL: a Pose, or a
//                        GeoPose on a geo-referenced map
//   poseAt(pose), poseBearing(pose)  where a pose is, and its direction of
//                        flight in radians clockwise from the screen's up (on a
//                        geo-referenced map a Pose too, as scripts may give one)
//   point(at, z)         the API's polyline point (Point3, GeoPoint3)
//   ahead(at, bearing, m)  the LatLng m metres from `at` in that direction
//   poseText(pose), cursorText(at)

function localFrame(info) {
  return {
    crs: 'Simple',
    leafletCrs: L.CRS.Simple,
    mapOptions: { minZoom: -8, maxZoom: 4 },
    rect: (x0, y0, w, h) => L.latLngBounds([y0, x0], [y0 + h, x0 + w]),
    pathOf: (t) => t.path.map((p) => [p.y, p.x]),
    sampleAt: (s) => [s.y, s.x],
    siteAt: (s) => [s.y, s.x],
    pose: (at, to, z) => ({
      x: at.lng, y: at.lat, z,
      theta: to ? turn(Math.atan2(to.lat - at.lat, to.lng - at.lng), 2 * Math.PI) : Math.PI / 4,
    }),
    poseAt: (p) => L.latLng(p.y, p.x),
    poseBearing: (p) => Math.PI / 2 - p.theta,
    point: (at, z) => ({ x: at.lng, y: at.lat, z }),
    ahead: (at, bearing, m) => L.latLng(at.lat + m * Math.cos(bearing), at.lng + m * Math.sin(bearing)),
    poseText: (p) => `(${p.x.toFixed(1)}, ${p.y.toFixed(1)}, ${p.z.toFixed(1)}) m, heading ${(p.theta * 180 / Math.PI).toFixed(0)}°`,
    cursorText: (at) => `x, y: ${at.lng.toFixed(0)}, ${at.lat.toFixed(0)} m`,
  };
}

// corners: the map's WGS84 corners as ListMaps gives them, south-west,
// south-east, north-east, north-west.
function geoFrame(info, corners) {
  const lat = corners.map((g) => g.lat_deg), lon = corners.map((g) => g.lon_deg);
  // The WGS84 position of a local point, interpolated bilinearly between the
  // four corners (the page links no projection: over a map of kilometres the
  // azimuthal equidistant frame departs from it by centimetres). For what
  // has no WGS84 form from the server: the cursor's local readout, a layer
  // grid larger than the map.
  const mix = (v, u, w) => (1 - u) * (1 - w) * v[0] + u * (1 - w) * v[1] + u * w * v[2] + (1 - u) * w * v[3];
  const toLatLng = (x, y) => {
    const u = (x - info.x0_m) / info.width_m, w = (y - info.y0_m) / info.height_m;
    return L.latLng(mix(lat, u, w), mix(lon, u, w));
  };
  // Its exact inverse: Newton's method on the same bilinear form (nearly
  // affine, so two or three steps reach the last digit).
  const toLocal = (at) => {
    let u = 0.5, w = 0.5;
    for (let k = 0; k < 50; k++) {
      const fa = mix(lat, u, w) - at.lat, fo = mix(lon, u, w) - at.lng;
      const au = (1 - w) * (lat[1] - lat[0]) + w * (lat[2] - lat[3]);
      const aw = (1 - u) * (lat[3] - lat[0]) + u * (lat[2] - lat[1]);
      const ou = (1 - w) * (lon[1] - lon[0]) + w * (lon[2] - lon[3]);
      const ow = (1 - u) * (lon[3] - lon[0]) + u * (lon[2] - lon[1]);
      const det = au * ow - aw * ou;
      const du = (fa * ow - fo * aw) / det, dw = (au * fo - ou * fa) / det;
      u -= du; w -= dw;
      if (Math.abs(du) + Math.abs(dw) < 1e-14) break;
    }
    return { x: info.x0_m + u * info.width_m, y: info.y0_m + w * info.height_m };
  };
  // Leaflet places an image on a latitude/longitude box; a local rectangle's
  // edges are not quite parallels and meridians (the grid converges), so the
  // box takes each edge at the mean of its two corners.
  const box = (c) => L.latLngBounds(
    [(c[0].lat + c[1].lat) / 2, (c[0].lng + c[3].lng) / 2],
    [(c[2].lat + c[3].lat) / 2, (c[1].lng + c[2].lng) / 2]);
  const ofGeo = (g) => L.latLng(g.lat_deg, g.lon_deg);
  const same = (a, b) => Math.abs(a - b) < 1e-6;
  return {
    crs: 'EPSG:3857',
    leafletCrs: L.CRS.EPSG3857,
    mapOptions: { minZoom: 3, maxZoom: 22 },
    rect: (x0, y0, w, h, geoBounds) => {
      if (geoBounds && geoBounds.corners && geoBounds.corners.length === 4) return box(geoBounds.corners.map(ofGeo));
      if (same(x0, info.x0_m) && same(y0, info.y0_m) && same(w, info.width_m) && same(h, info.height_m)) {
        return box(corners.map(ofGeo));
      }
      return box([toLatLng(x0, y0), toLatLng(x0 + w, y0), toLatLng(x0 + w, y0 + h), toLatLng(x0, y0 + h)]);
    },
    pathOf: (t) => (t.path_wgs84 && t.path_wgs84.length ? t.path_wgs84.map(ofGeo) : t.path.map((p) => toLatLng(p.x, p.y))),
    sampleAt: (s) => (s.wgs84 ? ofGeo(s.wgs84) : toLatLng(s.x, s.y)),
    siteAt: (s) => (s.wgs84 ? ofGeo(s.wgs84) : toLatLng(s.x, s.y)),
    // Directions on the ground (Leaflet's Mercator shows them as they are):
    // north and east metres on a sphere, exact enough for a drag.
    pose: (at, to, z) => ({
      lat_deg: at.lat, lon_deg: at.lng, alt_m: z,
      heading_deg: to ? turn(Math.atan2((to.lng - at.lng) * Math.cos(at.lat * DEG), to.lat - at.lat) / DEG, 360) : 45,
    }),
    poseAt: (p) => (isWgs84(p) ? ofGeo(p) : toLatLng(p.x, p.y)),
    // A local theta is drawn as if grid north were true north (they differ
    // by the grid convergence, hundredths of a degree on a city's map).
    poseBearing: (p) => (isWgs84(p) ? p.heading_deg * DEG : Math.PI / 2 - p.theta),
    point: (at, z) => ({ lat_deg: at.lat, lon_deg: at.lng, alt_m: z }),
    ahead: (at, bearing, m) => L.latLng(at.lat + m * Math.cos(bearing) / EARTH_RADIUS_M / DEG,
      at.lng + m * Math.sin(bearing) / (EARTH_RADIUS_M * Math.cos(at.lat * DEG)) / DEG),
    poseText: (p) => (isWgs84(p)
      ? `${p.lat_deg.toFixed(6)}°, ${p.lon_deg.toFixed(6)}°, ${p.alt_m.toFixed(1)} m AMSL, heading ${p.heading_deg.toFixed(0)}° from north`
      : localFrame(info).poseText(p)),
    cursorText: (at) => {
      const p = toLocal(at);
      return `${at.lat.toFixed(6)}°, ${at.lng.toFixed(6)}° · x, y: ${p.x.toFixed(0)}, ${p.y.toFixed(0)} m`;
    },
    toLatLng, toLocal,
  };
}
