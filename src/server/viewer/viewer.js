// terrabake viewer: shows one zoom level of a layer as glTF tiles, either the
// normal-mapped low-poly meshes ({y}.glb + {y}.png) or the full-resolution
// meshes ({y}.hires.glb), lit by one directional "sun" and a little ambient.
//
// Everything comes from `terrabake serve`: /layers.json, /<layer>/tilejson.json,
// the tiles, and three.js under /vendor/three/.
//
// URL parameters (all optional; the test uses them for a deterministic view):
//   layer=NAME            layer to show (default: the first of /layers.json)
//   z=N                   zoom level (default: the deepest with at most maxTiles tiles)
//   mode=normalmap|lowpoly|highres
//                         normal-mapped low-poly (default), low-poly without its
//                         normal map, or the high-res meshes
//   wireframe=0|1
//   az=DEG, el=DEG        sun azimuth (clockwise from north) and elevation (default 315, 35)
//   camAz=DEG, camEl=DEG  camera direction seen from the target (default 180 = from the
//                         south, 60 degrees above the horizon)
//   camDist=F             camera distance as a multiple of the distance that fits the tiles (1)
//   fov=DEG               vertical field of view (35)
//   width=PX, height=PX   fixed canvas size in CSS pixels at pixel ratio 1 (default: fill the window)
//   maxTiles=N            most tiles loaded, those nearest the layer centre (64)
//   center=LON,LAT        load the tiles nearest this point instead (degrees)
//
// The page renders only when something changes (no animation loop). Once every
// tile of the current view has loaded and a frame has been drawn it sets
// window.terrabakeReady = true and window.terrabakeStats = {triangles, tiles};
// window.terrabakeScreenPoint(lon, lat, height) gives where a point of the
// ellipsoid lands on the canvas, in CSS pixels from its top-left corner.
// Anything that fails to load is reported with console.error.
//
// A layer made with nodata.surface: cut (tilejson terrabake.nodata_surface)
// draws nothing where its normal maps have alpha 0: where the DEM has no data.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

const kDefaultMaxTiles = 64;
const kLoadConcurrency = 6;
const kBusyRetries = 120;       // a layer that bakes on demand answers 503 + Retry-After while it bakes
const kSunIntensity = 3.0;      // flat ground at 35 degrees elevation: ~0.25 linear
const kAmbientIntensity = 0.3;  // "a little": slopes facing away from the sun stay visible
const kAlbedo = 0.5;            // linear neutral grey; glTF says metallic 0, roughness 1
const kBackground = 0xaac8e6;   // never neutral grey, so terrain pixels are told apart by colour

const params = new URLSearchParams(window.location.search);

function numberParam(name, fallback) {
  if (!params.has(name)) return fallback;
  const value = Number(params.get(name));
  if (!Number.isFinite(value)) {
    console.error(`terrabake viewer: URL parameter ${name}=${params.get(name)} is not a number`);
    return fallback;
  }
  return value;
}

// center=LON,LAT as [lon, lat], or null.
function centerParam() {
  if (!params.has('center')) return null;
  const lonLat = params.get('center').split(',').map(Number);
  if (lonLat.length !== 2 || !lonLat.every(Number.isFinite)) {
    console.error(`terrabake viewer: URL parameter center=${params.get('center')} is not LON,LAT`);
    return null;
  }
  return lonLat;
}

const settings = {
  layer: params.get('layer'),
  zoom: params.has('z') ? numberParam('z', null) : null,
  highres: params.get('mode') === 'highres',
  normalMap: params.get('mode') !== 'lowpoly',
  wireframe: params.get('wireframe') === '1',
  sunAzimuthDeg: numberParam('az', 315),
  sunElevationDeg: numberParam('el', 35),
  cameraAzimuthDeg: numberParam('camAz', 180),
  cameraElevationDeg: numberParam('camEl', 60),
  cameraDistanceFactor: numberParam('camDist', 1),
  fovDeg: numberParam('fov', 35),
  maxTiles: Math.max(1, Math.floor(numberParam('maxTiles', kDefaultMaxTiles))),
  center: centerParam(),
  fixedWidth: params.has('width') ? numberParam('width', 960) : null,
  fixedHeight: params.has('height') ? numberParam('height', 640) : null,
};
if (params.has('mode') && !['normalmap', 'lowpoly', 'highres'].includes(params.get('mode'))) {
  console.error(`terrabake viewer: unknown mode '${params.get('mode')}' (normalmap, lowpoly or highres)`);
}

window.terrabakeReady = false;
window.terrabakeStats = { triangles: 0, tiles: 0 };

// ---------------------------------------------------------------------------
// Page elements

const el = (id) => document.getElementById(id);
const ui = {
  view: el('view'),
  layer: el('layer'),
  zoom: el('zoom'),
  normalMap: el('normalmap'),
  wireframe: el('wireframe'),
  az: el('az'),
  azValue: el('az-value'),
  el: el('el'),
  elValue: el('el-value'),
  resetView: el('reset-view'),
  triangles: el('triangles'),
  tiles: el('tiles'),
  status: el('status'),
  tiles3d: el('tiles3d'),
  maplibre: el('maplibre'),
  meshRadios: document.querySelectorAll('input[name="mesh"]'),
};

function setStatus(text, isError = false) {
  ui.status.textContent = text;
  ui.status.classList.toggle('error', isError);
}

function reportError(message, error) {
  const detail = error ? `: ${error.message || error}` : '';
  console.error(`terrabake viewer: ${message}${detail}`);
  setStatus(`${message}${detail}`, true);
}

// ---------------------------------------------------------------------------
// Renderer, scene, camera, lights

const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.outputColorSpace = THREE.SRGBColorSpace;
renderer.toneMapping = THREE.NoToneMapping;
ui.view.appendChild(renderer.domElement);

const scene = new THREE.Scene();
scene.background = new THREE.Color(kBackground);

const camera = new THREE.PerspectiveCamera(settings.fovDeg, 1, 1, 1e6);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;  // no animation: a frame is drawn only when something changes
controls.addEventListener('change', () => {
  updateClipPlanes();
  render();
});

const sun = new THREE.DirectionalLight(0xffffff, kSunIntensity);
scene.add(sun);
scene.add(sun.target);
scene.add(new THREE.AmbientLight(0xffffff, kAmbientIntensity));

const tileRoot = new THREE.Group();  // children are in the reference tile's frame
scene.add(tileRoot);

// Unit vector in the common frame (glTF axes: +X east, +Y up, +Z south) that
// points from the ground towards azimuth (clockwise from north) and elevation.
function directionFromAngles(azimuthDeg, elevationDeg) {
  const az = THREE.MathUtils.degToRad(azimuthDeg);
  const elev = THREE.MathUtils.degToRad(elevationDeg);
  return new THREE.Vector3(Math.sin(az) * Math.cos(elev), Math.sin(elev), -Math.cos(az) * Math.cos(elev));
}

function updateSun() {
  // A directional light shines from its position towards its target; only the
  // direction matters. It is the same direction in every tile, because all tiles
  // are drawn in the reference tile's frame.
  sun.position.copy(directionFromAngles(settings.sunAzimuthDeg, settings.sunElevationDeg));
  sun.target.position.set(0, 0, 0);
  ui.azValue.textContent = `${settings.sunAzimuthDeg}°`;
  ui.elValue.textContent = `${settings.sunElevationDeg}°`;
}

function resize() {
  let width;
  let height;
  if (settings.fixedWidth && settings.fixedHeight) {
    width = settings.fixedWidth;
    height = settings.fixedHeight;
    renderer.setPixelRatio(1);
  } else {
    width = Math.max(1, ui.view.clientWidth);
    height = Math.max(1, ui.view.clientHeight);
    renderer.setPixelRatio(window.devicePixelRatio || 1);
  }
  renderer.setSize(width, height);
  camera.aspect = width / height;
  camera.updateProjectionMatrix();
}

function render() {
  renderer.render(scene, camera);
}

// Near and far planes follow the camera's distance to what it orbits, so
// terrain is neither clipped close up nor short of depth precision far away.
let sceneRadius = 1;
function updateClipPlanes() {
  const distance = camera.position.distanceTo(controls.target);
  camera.near = Math.max(0.5, distance * 0.002);
  camera.far = distance + 4 * sceneRadius;
  camera.updateProjectionMatrix();
}

// ---------------------------------------------------------------------------
// Tiles: which ones cover the layer, and where they sit

// Fractional tile column and row (counted from the north edge) of a point, and
// the grid size, for the schemes whose grid follows from lon/lat alone.
function schemeGrid(scheme, zoom) {
  if (scheme === 'webmercator') {
    const n = 2 ** zoom;
    return {
      cols: n,
      rows: n,
      tmsRows: false,
      col: (lonDeg) => ((lonDeg + 180) / 360) * n,
      row: (latDeg) => {
        const lat = THREE.MathUtils.degToRad(Math.max(-85.0511287798066, Math.min(85.0511287798066, latDeg)));
        return ((1 - Math.asinh(Math.tan(lat)) / Math.PI) / 2) * n;
      },
    };
  }
  if (scheme === 'geodetic') {
    const rows = 2 ** zoom;
    const sizeDeg = 180 / rows;
    return {
      cols: 2 * rows,
      rows,
      tmsRows: true,
      col: (lonDeg) => (lonDeg + 180) / sizeDeg,
      row: (latDeg) => (90 - latDeg) / sizeDeg,
    };
  }
  return null;
}

// Tiles of one zoom that cover the layer bounds, nearest the centre (or
// `center`, [lon, lat]) first, at most maxTiles. Mirrors
// tiling::Scheme::tilesCovering; the epsilon keeps a bound that lies on a tile
// edge (up to rounding) from adding the next tile.
function tilesCovering(tilejson, zoom, maxTiles, center = null) {
  const scheme = tilejson.terrabake?.scheme ?? 'webmercator';
  const grid = schemeGrid(scheme, zoom);
  if (!grid) {
    throw new Error(`scheme '${scheme}' is not supported by the viewer: its tile ranges do not follow from tilejson bounds`);
  }
  const [west, south, east0, north] = tilejson.bounds ?? [-180, -85.0511287798066, 180, 85.0511287798066];
  const east = east0 < west ? east0 + 360 : east0;  // bounds across the antimeridian
  const eps = 1e-9;
  const x0 = Math.floor(grid.col(west) + eps);
  const x1 = Math.ceil(grid.col(east) - eps) - 1;
  const r0 = Math.max(0, Math.floor(grid.row(north) + eps));
  const r1 = Math.min(grid.rows - 1, Math.ceil(grid.row(south) - eps) - 1);
  const centreCol = center ? grid.col(center[0]) : (grid.col(west) + grid.col(east)) / 2;
  const centreRow = center ? grid.row(center[1]) : (grid.row(north) + grid.row(south)) / 2;
  const tiles = [];
  for (let r = r0; r <= r1; ++r) {
    for (let xu = x0; xu <= x1; ++xu) {
      const x = ((xu % grid.cols) + grid.cols) % grid.cols;
      const y = grid.tmsRows ? grid.rows - 1 - r : r;
      const distance = Math.hypot(xu + 0.5 - centreCol, r + 0.5 - centreRow);
      tiles.push({ z: zoom, x, y, r, distance });
    }
  }
  tiles.sort((a, b) => a.distance - b.distance || a.r - b.r || a.x - b.x);
  return { tiles: tiles.slice(0, maxTiles), total: tiles.length };
}

function tileUrl(template, tile) {
  return template.replace('{z}', tile.z).replace('{x}', tile.x).replace('{y}', tile.y);
}

// enu_to_ecef of a tile as a Matrix4 (three keeps matrix elements as JS
// doubles, so all of this is double precision).
function enuToEcef(gltf, url) {
  const values = gltf.asset?.extras?.terrabake?.enu_to_ecef;
  if (!Array.isArray(values) || values.length !== 16 || !values.every(Number.isFinite)) {
    throw new Error(`${url}: asset.extras.terrabake.enu_to_ecef is missing or not 16 numbers`);
  }
  return new THREE.Matrix4().fromArray(values);  // column-major, as glTF stores it
}

// Alpha of a cut layer's normal maps says where the DEM has data; glTF gives
// a normal texture's alpha no meaning, so the fragment shader is told.
function discardWhereNoData(material) {
  material.onBeforeCompile = (shader) => {
    shader.fragmentShader = shader.fragmentShader.replace('#include <normal_fragment_maps>', [
      '#include <normal_fragment_maps>',
      '#ifdef USE_NORMALMAP',
      '  if ( texture2D( normalMap, vNormalMapUv ).a < 0.5 ) discard;',
      '#endif',
    ].join('\n'));
  };
  material.customProgramCacheKey = () => 'terrabake-cut';
}

// ECEF metres of a point given in degrees and metres above the WGS84 ellipsoid.
function geodeticToEcef(lonDeg, latDeg, height) {
  const a = 6378137;
  const f = 1 / 298.257223563;
  const e2 = f * (2 - f);
  const lon = THREE.MathUtils.degToRad(lonDeg);
  const lat = THREE.MathUtils.degToRad(latDeg);
  const n = a / Math.sqrt(1 - e2 * Math.sin(lat) ** 2);
  return new THREE.Vector3((n + height) * Math.cos(lat) * Math.cos(lon), (n + height) * Math.cos(lat) * Math.sin(lon),
    (n * (1 - e2) + height) * Math.sin(lat));
}

// Where a point lands on the canvas (CSS pixels from its top-left corner).
window.terrabakeScreenPoint = (lonDeg, latDeg, height = 0) => {
  if (!state.reference) return null;
  const ndc = geodeticToEcef(lonDeg, latDeg, height).applyMatrix4(state.reference).project(camera);
  const canvas = renderer.domElement;
  return { x: (ndc.x + 1) / 2 * canvas.clientWidth, y: (1 - ndc.y) / 2 * canvas.clientHeight };
};

// Inverse of a rigid transform [R t; 0 1]: [R^T -R^T t; 0 1], in doubles.
function rigidInverse(m) {
  const e = m.elements;
  const inv = new THREE.Matrix4();
  const o = inv.elements;
  for (let c = 0; c < 3; ++c) {
    for (let r = 0; r < 3; ++r) o[c * 4 + r] = e[r * 4 + c];
  }
  for (let r = 0; r < 3; ++r) {
    o[12 + r] = -(o[r] * e[12] + o[4 + r] * e[13] + o[8 + r] * e[14]);
  }
  o[3] = o[7] = o[11] = 0;
  o[15] = 1;
  return inv;
}

// ---------------------------------------------------------------------------
// Loading

const loader = new GLTFLoader();
const greyColour = new THREE.Color().setScalar(kAlbedo);  // linear working-space value

// Runs fn over items with at most `limit` at a time; resolves to the results in order.
async function mapPool(items, limit, fn) {
  const results = new Array(items.length);
  let next = 0;
  const worker = async () => {
    while (next < items.length) {
      const i = next++;
      results[i] = await fn(items[i], i);
    }
  };
  await Promise.all(Array.from({ length: Math.min(limit, items.length) }, worker));
  return results;
}

// Loads one .glb; returns {root, matrix, meshes} or null if it failed (reported).
// greenDown: the layer's normal maps have +Y of tangent space pointing south
// (tilejson terrabake.green = "down", DirectX style); three then reads them
// with normalScale.y = -1. cut: the layer was made with nodata.surface: cut,
// so texels whose normal-map alpha is 0 are not drawn.
async function loadTileGlb(url, kind, { greenDown = false, cut = false } = {}) {
  let gltf;
  for (let attempt = 0; ; ++attempt) {
    try {
      gltf = await loader.loadAsync(url);
      break;
    } catch (error) {
      // three's FileLoader rejects with an HttpError that carries the response.
      const response = error?.response;
      if (response?.status === 503 && attempt < kBusyRetries) {
        const waitS = Math.min(30, Math.max(0.2, Number(response.headers.get('Retry-After')) || 1));
        console.info(`terrabake viewer: ${url} is being baked; asking again in ${waitS} s`);
        await new Promise((resolve) => setTimeout(resolve, waitS * 1000));
        continue;
      }
      reportError(`cannot load ${kind} tile ${url}`, error);
      return null;
    }
  }
  let matrix;
  try {
    matrix = enuToEcef(gltf, url);
  } catch (error) {
    reportError('bad tile', error);
    return null;
  }
  const meshes = [];
  gltf.scene.traverse((object) => {
    if (!object.isMesh) return;
    const material = object.material;
    if (!material.isMeshStandardMaterial) {
      reportError(`${url}: expected a glTF PBR material, got ${material.type}`);
      return;
    }
    material.color.copy(greyColour);
    material.userData.normalMap = material.normalMap;
    if (kind === 'low-poly') {
      const map = material.normalMap;
      if (!map) {
        reportError(`${url}: the material has no normal map`);
      } else {
        // Normal maps are linear data; glTF's UV origin is the top-left (flipY false).
        // GLTFLoader sets both; say so loudly if that ever changes.
        if (map.colorSpace !== THREE.NoColorSpace || map.flipY !== false) {
          console.warn(`terrabake viewer: ${url}: normal map had colorSpace=${map.colorSpace} flipY=${map.flipY}; forcing linear, flipY false`);
          map.colorSpace = THREE.NoColorSpace;
          map.flipY = false;
          map.needsUpdate = true;
        }
        // With TANGENT attributes three uses the glTF tangent frame (green up, B = w * N x T)
        // and leaves normalScale at (1, 1).
        if (!object.geometry.attributes.tangent) {
          reportError(`${url}: no TANGENT attribute; three would fall back to derivative tangents`);
        }
        if (material.normalScale.x !== 1 || material.normalScale.y !== 1) {
          console.warn(`terrabake viewer: ${url}: normalScale was (${material.normalScale.x}, ${material.normalScale.y}); forcing (1, 1)`);
        }
        material.normalScale.set(1, greenDown ? -1 : 1);
        if (cut) discardWhereNoData(material);
      }
    }
    meshes.push(object);
  });
  const root = new THREE.Group();
  root.add(gltf.scene);
  root.matrixAutoUpdate = false;
  return { root, matrix, meshes };
}

const state = {
  layers: [],
  tilejson: null,
  tilejsonUrl: null,
  tiles: [],           // [{id, lowpoly, hires}] of the current zoom
  reference: null,     // inverse of the reference tile's enu_to_ecef
  referenceId: null,
  bounds: null,        // Box3 of the low-poly tiles in the common frame
  generation: 0,       // bumped on every layer/zoom change, so stale loads are dropped
  hiresLoading: null,  // promise while the high-res meshes load
};

function disposePart(part) {
  if (!part) return;
  tileRoot.remove(part.root);
  part.root.traverse((object) => {
    if (!object.isMesh) return;
    object.geometry.dispose();
    const material = object.material;
    material.userData.normalMap?.dispose();
    material.dispose();
  });
}

function clearTiles() {
  for (const tile of state.tiles) {
    disposePart(tile.lowpoly);
    disposePart(tile.hires);
  }
  state.tiles = [];
  state.reference = null;
  state.bounds = null;
  state.hiresLoading = null;
}

function placeInCommonFrame(part) {
  // relative = inverse(reference enu_to_ecef) * tile enu_to_ecef, in doubles;
  // three multiplies it with the camera in doubles too, so only small numbers
  // (metres from the reference tile) reach float32 on the GPU.
  part.root.matrix.multiplyMatrices(state.reference, part.matrix);
  part.root.matrixWorldNeedsUpdate = true;
  tileRoot.add(part.root);
}

async function loadLowPoly(generation, tilejson, tileIds) {
  const template = tilejson.terrabake?.mesh;
  if (!template) throw new Error('tilejson has no terrabake.mesh template: the layer has no meshes');
  const meshTemplate = new URL(template, state.tilejsonUrl).href.replace(/%7B/gi, '{').replace(/%7D/gi, '}');
  let loaded = 0;
  const parts = await mapPool(tileIds, kLoadConcurrency, async (id) => {
    const part = await loadTileGlb(tileUrl(meshTemplate, id), 'low-poly', {
      greenDown: tilejson.terrabake?.green === 'down',
      cut: tilejson.terrabake?.nodata_surface === 'cut',
    });
    if (generation === state.generation) setStatus(`loading low-poly tiles: ${++loaded}/${tileIds.length}`);
    return part;
  });
  if (generation !== state.generation) {
    parts.forEach(disposePart);  // a newer layer or zoom was asked for meanwhile
    return false;
  }
  state.tiles = tileIds.map((id, i) => ({ id, lowpoly: parts[i], hires: null }));
  const first = state.tiles.find((tile) => tile.lowpoly);
  if (!first) throw new Error('no tile of this zoom could be loaded');
  state.reference = rigidInverse(first.lowpoly.matrix);
  state.referenceId = first.id;
  for (const tile of state.tiles) {
    if (tile.lowpoly) placeInCommonFrame(tile.lowpoly);
  }
  tileRoot.updateMatrixWorld(true);
  // The view is fitted to the low-poly tiles in every mode, so the same URL
  // gives the same camera whichever meshes are shown.
  state.bounds = new THREE.Box3();
  for (const tile of state.tiles) {
    if (tile.lowpoly) state.bounds.expandByObject(tile.lowpoly.root);
  }
  return true;
}

function hiresTemplate() {
  // The high-res mesh sits next to the low-poly one: {y}.glb -> {y}.hires.glb.
  const template = state.tilejson.terrabake?.high_res_mesh ?? state.tilejson.terrabake.mesh.replace(/\.glb$/, '.hires.glb');
  return new URL(template, state.tilejsonUrl).href.replace(/%7B/gi, '{').replace(/%7D/gi, '}');
}

function loadHires() {
  if (state.hiresLoading) return state.hiresLoading;
  const generation = state.generation;
  const template = hiresTemplate();
  const wanted = state.tiles.filter((tile) => tile.lowpoly);
  let loaded = 0;
  state.hiresLoading = mapPool(wanted, kLoadConcurrency, async (tile) => {
    const part = await loadTileGlb(tileUrl(template, tile.id), 'high-res');
    if (generation !== state.generation) {
      disposePart(part);
      return;
    }
    setStatus(`loading high-res tiles: ${++loaded}/${wanted.length}`);
    if (!part) return;
    tile.hires = part;
    part.root.visible = settings.highres;  // the user may have gone back to low-poly meanwhile
    placeInCommonFrame(part);
  }).then(() => generation === state.generation);
  return state.hiresLoading;
}

// ---------------------------------------------------------------------------
// What is shown

function applyDisplay() {
  let triangles = 0;
  let tiles = 0;
  for (const tile of state.tiles) {
    const showHires = settings.highres;
    for (const [part, visible] of [[tile.lowpoly, !showHires], [tile.hires, showHires]]) {
      if (!part) continue;
      part.root.visible = visible;
      for (const mesh of part.meshes) {
        const material = mesh.material;
        const normalMap = !showHires && settings.normalMap ? material.userData.normalMap : null;
        if (material.normalMap !== normalMap || material.wireframe !== settings.wireframe) {
          material.normalMap = normalMap;
          material.wireframe = settings.wireframe;
          material.needsUpdate = true;
        }
        if (visible) {
          const geometry = mesh.geometry;
          triangles += (geometry.index ? geometry.index.count : geometry.attributes.position.count) / 3;
        }
      }
      if (visible) ++tiles;
    }
  }
  window.terrabakeStats = { triangles, tiles };
  ui.triangles.textContent = triangles.toLocaleString('en-US');
  ui.tiles.textContent = `${tiles}`;
}

function fitCamera() {
  if (!state.bounds || state.bounds.isEmpty()) return;
  const sphere = state.bounds.getBoundingSphere(new THREE.Sphere());
  camera.fov = settings.fovDeg;
  camera.updateProjectionMatrix();
  const vFov = THREE.MathUtils.degToRad(camera.fov);
  const hFov = 2 * Math.atan(Math.tan(vFov / 2) * camera.aspect);
  const distance = (sphere.radius / Math.sin(Math.min(vFov, hFov) / 2)) * settings.cameraDistanceFactor;
  const direction = directionFromAngles(settings.cameraAzimuthDeg, settings.cameraElevationDeg);
  camera.position.copy(sphere.center).addScaledVector(direction, distance);
  camera.up.set(0, 1, 0);
  camera.lookAt(sphere.center);
  controls.target.copy(sphere.center);
  controls.maxDistance = 20 * distance;
  sceneRadius = sphere.radius;
  controls.update();
  updateClipPlanes();
}

// Draws a frame, then flags the page ready once the browser has presented it.
function finish(generation) {
  applyDisplay();
  render();
  requestAnimationFrame(() => {
    requestAnimationFrame(() => {
      if (generation !== state.generation) return;
      render();
      window.terrabakeReady = true;
      const ref = state.referenceId;
      const missing = state.tiles.filter((t) => !t.lowpoly || (settings.highres && !t.hires)).length;
      setStatus(`${window.terrabakeStats.tiles} tiles at zoom ${ref.z}; frame of tile ${ref.z}/${ref.x}/${ref.y}` +
        (missing ? `; ${missing} failed` : ''), missing > 0);
    });
  });
}

async function showDisplay() {
  const generation = state.generation;
  window.terrabakeReady = false;
  if (settings.highres) {
    ui.normalMap.disabled = true;
    if (!(await loadHires())) return;
  } else {
    ui.normalMap.disabled = false;
  }
  if (generation === state.generation) finish(generation);
}

async function showZoom(zoom) {
  const generation = ++state.generation;
  window.terrabakeReady = false;
  clearTiles();
  settings.zoom = zoom;
  ui.zoom.value = `${zoom}`;
  try {
    const { tiles, total } = tilesCovering(state.tilejson, zoom, settings.maxTiles, settings.center);
    if (tiles.length === 0) throw new Error(`no tiles cover the layer at zoom ${zoom}`);
    if (total > tiles.length) {
      console.info(`terrabake viewer: zoom ${zoom} has ${total} tiles; showing the ${tiles.length} nearest the centre`);
    }
    if (!(await loadLowPoly(generation, state.tilejson, tiles))) return;
    fitCamera();
    await showDisplay();
  } catch (error) {
    if (generation === state.generation) reportError(`cannot show zoom ${zoom}`, error);
  }
}

function defaultZoom(tilejson) {
  const minZoom = tilejson.minzoom ?? 0;
  const maxZoom = tilejson.maxzoom ?? minZoom;
  for (let z = maxZoom; z >= minZoom; --z) {
    try {
      if (tilesCovering(tilejson, z, Infinity).total <= settings.maxTiles) return z;
    } catch {
      return maxZoom;
    }
  }
  return minZoom;
}

async function fetchJson(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  return response.json();
}

async function showLayer(name, zoom) {
  const entry = state.layers.find((layer) => layer.name === name);
  if (!entry) {
    reportError(`no layer '${name}' in /layers.json (${state.layers.map((l) => l.name).join(', ') || 'none'})`);
    return;
  }
  const generation = ++state.generation;
  window.terrabakeReady = false;
  clearTiles();
  ui.layer.value = name;
  settings.layer = name;
  let tilejson;
  const tilejsonUrl = new URL(entry.tilejson, window.location.href).href;
  try {
    tilejson = await fetchJson(tilejsonUrl);
  } catch (error) {
    reportError(`cannot load the tilejson of layer '${name}'`, error);
    return;
  }
  if (generation !== state.generation) return;
  state.tilejson = tilejson;
  state.tilejsonUrl = tilejsonUrl;
  // A layer with a tileset (output.tileset) opens in the 3D Tiles viewers too.
  ui.tiles3d.hidden = !tilejson.terrabake?.tileset;
  for (const link of ui.tiles3d.querySelectorAll('a')) {
    link.href = `/viewer/tiles3d.html?${new URLSearchParams({ layer: name, renderer: link.dataset.renderer })}`;
  }
  // A layer with elevation tiles (output.elevation) opens in MapLibre too.
  ui.maplibre.hidden = !tilejson.terrabake?.elevation;
  ui.maplibre.querySelector('a').href = `/viewer/maplibre.html?${new URLSearchParams({ layer: name })}`;
  ui.zoom.replaceChildren();
  for (let z = tilejson.minzoom ?? 0; z <= (tilejson.maxzoom ?? 0); ++z) {
    ui.zoom.add(new Option(`${z}`, `${z}`));
  }
  const wanted = zoom ?? defaultZoom(tilejson);
  if (wanted < (tilejson.minzoom ?? 0) || wanted > (tilejson.maxzoom ?? 0)) {
    reportError(`layer '${name}' has zoom ${tilejson.minzoom}..${tilejson.maxzoom}, not ${wanted}`);
    return;
  }
  await showZoom(wanted);
}

// ---------------------------------------------------------------------------
// Controls

function syncControls() {
  for (const radio of ui.meshRadios) radio.checked = radio.value === (settings.highres ? 'highres' : 'lowpoly');
  ui.normalMap.checked = settings.normalMap;
  ui.normalMap.disabled = settings.highres;
  ui.wireframe.checked = settings.wireframe;
  ui.az.value = `${settings.sunAzimuthDeg}`;
  ui.el.value = `${settings.sunElevationDeg}`;
}

ui.layer.addEventListener('change', () => showLayer(ui.layer.value, null));
ui.zoom.addEventListener('change', () => showZoom(Number(ui.zoom.value)));
for (const radio of ui.meshRadios) {
  radio.addEventListener('change', () => {
    settings.highres = radio.value === 'highres' && radio.checked;
    showDisplay();
  });
}
ui.normalMap.addEventListener('change', () => {
  settings.normalMap = ui.normalMap.checked;
  applyDisplay();
  render();
});
ui.wireframe.addEventListener('change', () => {
  settings.wireframe = ui.wireframe.checked;
  applyDisplay();
  render();
});
for (const [input, key] of [[ui.az, 'sunAzimuthDeg'], [ui.el, 'sunElevationDeg']]) {
  input.addEventListener('input', () => {
    settings[key] = Number(input.value);
    updateSun();
    render();
  });
}
ui.resetView.addEventListener('click', () => {
  fitCamera();
  render();
});

if (settings.fixedWidth && settings.fixedHeight) {
  resize();
} else {
  new ResizeObserver(() => {
    resize();
    render();
  }).observe(ui.view);
  resize();
}

// ---------------------------------------------------------------------------
// Start

async function main() {
  syncControls();
  updateSun();
  try {
    // [{name, tilejson}, ...], or the same list as {"layers": [...]}.
    const list = await fetchJson('/layers.json');
    state.layers = Array.isArray(list) ? list : list?.layers;
  } catch (error) {
    reportError('cannot load the layer list', error);
    return;
  }
  if (!Array.isArray(state.layers) || state.layers.length === 0) {
    reportError('/layers.json lists no layers');
    return;
  }
  for (const layer of state.layers) ui.layer.add(new Option(layer.name, layer.name));
  await showLayer(settings.layer ?? state.layers[0].name, settings.zoom);
}

main();
