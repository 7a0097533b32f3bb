// A layer's elevation tiles (written with output.elevation) in MapLibre GL JS,
// as a web map shows them: a raster-dem source from /<layer>/elevation.json,
// drawn as hillshade and as 3D terrain. Everything comes from `terrabake
// serve`: the tilejson, the tiles, and MapLibre under /vendor/maplibre-gl/.
// The style has no glyphs, sprites or other sources.
//
// URL parameters:
//   layer=NAME              the layer (required)
//   sun=DEG                 direction the light comes from, clockwise from north (315)
//   terrain=on|off          3D terrain (on)
//   exaggeration=F          the terrain's vertical exaggeration (1)
//   pitch=DEG, bearing=DEG  camera tilt from straight down, and heading (50, 0)
//   zoom=Z, center=LON,LAT  the view (default: the layer's bounds fill the window)
//
// Drag to pan, right-drag or Ctrl-drag to tilt and turn. Once the style and
// every tile the view needs have loaded and the map is idle the page sets
// window.terrabakeReady = true and window.terrabakeStats = {elevationTiles}:
// the number of .elevation.png requests it made. Anything that fails is
// reported with console.error.

import * as maplibregl from '/vendor/maplibre-gl/maplibre-gl.mjs';

const kBackground = '#b4b4b4';

const params = new URLSearchParams(window.location.search);
const number = (name, fallback) => (params.has(name) ? Number(params.get(name)) : fallback);
const view = {
  layer: params.get('layer'),
  sun: number('sun', 315),
  terrain: params.get('terrain') !== 'off',
  exaggeration: number('exaggeration', 1),
  pitch: number('pitch', 50),
  bearing: number('bearing', 0),
};
const status = (text) => { document.getElementById('status').textContent = text; };

async function fetchJson(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  return response.json();
}

function elevationRequests() {
  return performance.getEntriesByType('resource').filter((entry) => /\.elevation\.png(?:\?.*)?$/.test(entry.name)).length;
}

// MapLibre recommends separate sources for hillshade and terrain (each keeps
// tiles of its own zooms); both read the same tiles.
function style(elevationUrl) {
  const sources = { hillshade: { type: 'raster-dem', url: elevationUrl } };
  if (view.terrain) sources.terrain = { type: 'raster-dem', url: elevationUrl };
  return {
    version: 8,
    sources,
    layers: [
      { id: 'background', type: 'background', paint: { 'background-color': kBackground } },
      {
        id: 'hillshade',
        type: 'hillshade',
        source: 'hillshade',
        paint: { 'hillshade-illumination-direction': view.sun, 'hillshade-illumination-anchor': 'map' },
      },
    ],
  };
}

async function main() {
  status('loading…');
  if (!view.layer) throw new Error('no layer: add ?layer=NAME to the URL');
  const elevationUrl = new URL(`/${encodeURIComponent(view.layer)}/elevation.json`, window.location.href).href;
  let elevation;
  try {
    elevation = await fetchJson(elevationUrl);
  } catch (error) {
    throw new Error(`layer ${view.layer} has no elevation tiles (tile it with --elevation terrarium): ${error.message}`);
  }
  const [west, south, east, north] = elevation.bounds;
  const camera = { pitch: view.pitch, bearing: view.bearing };
  if (params.has('zoom')) {
    camera.zoom = number('zoom', 0);
    camera.center = params.has('center') ? params.get('center').split(',').map(Number) : [(west + east) / 2, (south + north) / 2];
  } else {
    camera.bounds = [west, south, east, north];
  }

  const map = new maplibregl.Map({
    container: 'view',
    style: style(elevationUrl),
    ...camera,
    attributionControl: false,
    canvasContextAttributes: { preserveDrawingBuffer: true },
  });
  map.on('error', (event) => console.error(`terrabake MapLibre view: ${event.error?.message ?? event.error}`));
  await map.once('load');
  if (view.terrain) map.setTerrain({ source: 'terrain', exaggeration: view.exaggeration });
  // 'idle' (no camera or fade in progress, every tile the view asked for
  // loaded) may have come with 'load' already: draw once more to hear it.
  const idle = map.once('idle');
  map.triggerRepaint();
  await idle;
  window.terrabakeStats = { elevationTiles: elevationRequests() };
  status('');
  window.terrabakeReady = true;
}

main().catch((error) => {
  status(`error: ${error.message}`);
  console.error(`terrabake MapLibre view: ${error.stack || error}`);
});
