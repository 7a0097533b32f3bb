// A layer's tileset.json (3D Tiles, written with output.tileset) streamed by
// the 3D Tiles viewers people run: three.js with 3d-tiles-renderer, or
// CesiumJS. Everything comes from `terrabake serve`: the layer's tilejson and
// tileset, the tiles, and the libraries under /vendor/.
//
// URL parameters:
//   layer=NAME                 the layer (required)
//   renderer=three|cesium      which viewer (default three)
//   mode=normalmap|lowpoly|highres
//                              the tiles as written (default), without their
//                              normal maps, or their .hires.glb instead
//   az=DEG, el=DEG             sun azimuth (clockwise from north) and elevation (315, 35)
//   camAz=DEG, camEl=DEG       camera direction seen from the target (180, 45)
//   camDist=M                  camera distance from the target in metres (8000)
//   fov=DEG                    vertical field of view (40)
//   sse=PX                     screen-space error at which tiles refine (16)
//   center=LON,LAT             the target (default: the middle of the layer's bounds),
//                              at the middle height of the tileset's root volume
//
// The background is magenta, which no lit grey terrain is, so a screenshot
// tells gaps between tiles from terrain. Once every tile the view needs has
// loaded and the same tiles have been drawn for kStableFrames frames in a
// row, the page sets window.terrabakeReady =
// true and window.terrabakeStats = {visibleLevels, requestedLevels}: the
// zooms of the tiles drawn and of every .glb the page fetched. Anything that
// fails is reported with console.error.

const kBackground = [1, 0, 1];
const kStableFrames = 10;        // tiles loaded for this many frames in a row: ready
const kSunIntensity = 3.0;
const kAmbientIntensity = 0.3;

const params = new URLSearchParams(window.location.search);
const number = (name, fallback) => (params.has(name) ? Number(params.get(name)) : fallback);
const view = {
  layer: params.get('layer'),
  renderer: params.get('renderer') || 'three',
  mode: params.get('mode') || 'normalmap',
  sunAz: number('az', 315), sunEl: number('el', 35),
  camAz: number('camAz', 180), camEl: number('camEl', 45), camDist: number('camDist', 8000),
  fov: number('fov', 40), sse: number('sse', 16),
};
const status = (text) => { document.getElementById('status').textContent = text; };
const radians = (deg) => (deg * Math.PI) / 180;
// Levels of a box-bounded root's descendants searched for regions (its own
// children are one).
const kTargetSearchDepth = 3;

// East, north, up components of a direction at azimuth az (clockwise from north), elevation el.
function enuDirection(azDeg, elDeg) {
  const az = radians(azDeg);
  const el = radians(elDeg);
  return [Math.cos(el) * Math.sin(az), Math.cos(el) * Math.cos(az), Math.sin(el)];
}

// "…/12/2161/1448.glb" or "12/2161/1448.glb" -> 12
function levelOf(url) {
  const match = /(?:^|\/)(\d+)\/\d+\/\d+\.(?:hires\.)?glb(?:\?.*)?$/.exec(url);
  return match ? Number(match[1]) : null;
}

// The zooms of the tile URLs among `urls`, ascending, each once.
function levelsOf(urls) {
  const levels = new Set(urls.map(levelOf).filter((z) => z !== null));
  return [...levels].sort((a, b) => a - b);
}

async function fetchJson(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  return response.json();
}

// The layer's tileset URL and the target: lon, lat (radians) and height (metres).
async function layerTarget() {
  if (!view.layer) throw new Error('no layer: add ?layer=NAME to the URL');
  const tilejson = await fetchJson(`/${encodeURIComponent(view.layer)}/tilejson.json`);
  const tilesetUrl = tilejson.terrabake?.tileset;
  if (!tilesetUrl) throw new Error(`layer ${view.layer} has no tileset (tile it with output.tileset: true)`);
  const tileset = await fetchJson(tilesetUrl);
  // tilejson's center is the middle of the bounds, across the antimeridian too.
  const center = params.has('center') ? params.get('center').split(',').map(Number) : tilejson.center;
  return { tilesetUrl, lon: radians(center[0]), lat: radians(center[1]), height: targetHeight(tileset.root) };
}

// The height to look at: the middle of the root's region. A root bounded by
// a box (a layer across the antimeridian or round a pole) has its centre
// below the surface by the sag of its width, hundreds of kilometres for a
// wide layer, where a camera a few kilometres from it sees no terrain: the
// highest top of the regions under it instead, or the box's centre's
// height where none is.
function targetHeight(root) {
  if (root.boundingVolume.region) return (root.boundingVolume.region[4] + root.boundingVolume.region[5]) / 2;
  const tops = [];
  const visit = (tile, depth) => {
    if (tile.boundingVolume.region) tops.push(tile.boundingVolume.region[5]);
    else if (depth < kTargetSearchDepth) (tile.children ?? []).forEach((child) => visit(child, depth + 1));
  };
  visit(root, 0);
  return tops.length > 0 ? Math.max(...tops) : boxCentreHeight(root.boundingVolume.box);
}

// The height of a box's centre (the root has no transform: the box is in
// ECEF) above the WGS84 ellipsoid along the radius, which differs from the
// height along the normal by well under a metre near the surface.
function boxCentreHeight(box) {
  const [x, y, z] = box;
  const a = 6378137.0;
  const b = 6356752.314245;
  const r = Math.hypot(x, y, z);
  const sinLat = z / r;
  const cosLat = Math.hypot(x, y) / r;
  return r - (a * b) / Math.hypot(b * cosLat, a * sinLat);
}

// Resolves once the view has been drawn kStableFrames times in a row with
// every tile it needs loaded and the same tiles shown. drawnState() is called
// after each draw: null while tiles load, else a key naming what is shown.
function whenStable(draw, drawnState) {
  return new Promise((resolve) => {
    let stable = 0;
    let previous = null;
    const frame = () => {
      draw();
      const state = drawnState();
      stable = state !== null && state === previous ? stable + 1 : 0;
      previous = state;
      if (stable >= kStableFrames) resolve();
      else requestAnimationFrame(frame);
    };
    requestAnimationFrame(frame);
  });
}

async function showWithThree(target) {
  const THREE = await import('three');
  const { TilesRenderer } = await import('3d-tiles-renderer');
  const { ReorientationPlugin } = await import('3d-tiles-renderer/three/plugins');

  const container = document.getElementById('view');
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.setSize(container.clientWidth, container.clientHeight);
  renderer.setClearColor(new THREE.Color(...kBackground));
  container.appendChild(renderer.domElement);

  // Reoriented: the target at the origin, +Y up, north towards -Z.
  const toThree = ([e, n, u]) => new THREE.Vector3(e, u, -n);
  const scene = new THREE.Scene();
  const sun = new THREE.DirectionalLight(0xffffff, kSunIntensity);
  sun.position.copy(toThree(enuDirection(view.sunAz, view.sunEl)));
  scene.add(sun, new THREE.AmbientLight(0xffffff, kAmbientIntensity));
  const camera = new THREE.PerspectiveCamera(view.fov, container.clientWidth / container.clientHeight, 10, 1e7);
  camera.position.copy(toThree(enuDirection(view.camAz, view.camEl)).multiplyScalar(view.camDist));
  camera.lookAt(0, 0, 0);

  const tiles = new TilesRenderer(target.tilesetUrl);
  tiles.registerPlugin(new ReorientationPlugin({ lat: target.lat, lon: target.lon, height: target.height, recenter: true }));
  if (view.mode === 'highres') {
    tiles.registerPlugin({ name: 'TERRABAKE_HIGH_RES', preprocessURL: (url) => url.replace(/(\/\d+)\.glb$/, '$1.hires.glb') });
  }
  tiles.addEventListener('load-model', ({ scene: model }) => {
    model.traverse((object) => {
      if (!object.material) return;
      if (view.mode === 'lowpoly') object.material.normalMap = null;
      object.material.needsUpdate = true;
    });
  });
  tiles.addEventListener('load-error', ({ url, error }) => console.error(`terrabake 3D Tiles view: ${url}: ${error?.message ?? error}`));
  tiles.errorTarget = view.sse;
  tiles.setCamera(camera);
  tiles.setResolutionFromRenderer(camera, renderer);
  scene.add(tiles.group);

  // Not tiles.loadProgress: it reads 1 while a tile's body is still downloading
  // or parsing once the renderer's queues have run dry (3d-tiles-renderer 0.5).
  const isLoading = () => {
    const { stats } = tiles;
    return stats.queued + stats.downloading + stats.parsing > 0 ||
      tiles.downloadQueue.running || tiles.parseQueue.running || tiles.processNodeQueue.running;
  };
  const shownUris = () => [...tiles.visibleTiles].map((tile) => tile.content?.uri ?? '').sort();
  await whenStable(
    () => {
      camera.updateMatrixWorld();
      tiles.update();
      renderer.render(scene, camera);
    },
    () => (tiles.root === null || tiles.visibleTiles.size === 0 || isLoading() ? null : shownUris().join(' ')));
  return { visibleLevels: levelsOf(shownUris()) };
}

async function loadCesium() {
  window.CESIUM_BASE_URL = '/vendor/cesium/';
  await new Promise((resolve, reject) => {
    const script = document.createElement('script');
    script.src = '/vendor/cesium/Cesium.js';
    script.onload = resolve;
    script.onerror = () => reject(new Error('cannot load /vendor/cesium/Cesium.js'));
    document.head.appendChild(script);
    const css = document.createElement('link');
    css.rel = 'stylesheet';
    css.href = '/vendor/cesium/Widgets/widgets.css';
    document.head.appendChild(css);
  });
  return window.Cesium;
}

async function showWithCesium(target) {
  const Cesium = await loadCesium();
  // Nothing from the network: no imagery, no terrain, no sky, no globe.
  const viewer = new Cesium.Viewer('view', {
    baseLayer: false, baseLayerPicker: false, geocoder: false, homeButton: false, sceneModePicker: false,
    navigationHelpButton: false, animation: false, timeline: false, fullscreenButton: false, infoBox: false,
    selectionIndicator: false, skyBox: false, skyAtmosphere: false, globe: false, useDefaultRenderLoop: false,
    contextOptions: { webgl: { preserveDrawingBuffer: true } },
  });
  const { scene } = viewer;
  scene.backgroundColor = new Cesium.Color(...kBackground, 1);
  scene.fog.enabled = false;
  viewer.resolutionScale = 1;
  scene.postProcessStages.fxaa.enabled = false;

  const origin = Cesium.Cartesian3.fromRadians(target.lon, target.lat, target.height);
  const enuToEcef = Cesium.Transforms.eastNorthUpToFixedFrame(origin);
  const toEcef = (enu) => Cesium.Cartesian3.normalize(
    Cesium.Matrix4.multiplyByPointAsVector(enuToEcef, new Cesium.Cartesian3(...enu), new Cesium.Cartesian3()), new Cesium.Cartesian3());
  const sunDirection = toEcef(enuDirection(view.sunAz, view.sunEl));
  scene.light = new Cesium.DirectionalLight({
    direction: Cesium.Cartesian3.negate(sunDirection, new Cesium.Cartesian3()), intensity: kSunIntensity,
  });

  const resource = new Cesium.Resource({
    url: target.tilesetUrl,
    // The high-res meshes in place of the low-poly ones, for comparison.
    proxy: view.mode === 'highres' ? { getURL: (url) => url.replace(/(\/\d+)\.glb$/, '$1.hires.glb') } : undefined,
  });
  const tileset = await Cesium.Cesium3DTileset.fromUrl(resource, { maximumScreenSpaceError: view.sse });
  tileset.imageBasedLighting.imageBasedLightingFactor = new Cesium.Cartesian2(kAmbientIntensity / kSunIntensity, kAmbientIntensity / kSunIntensity);
  if (view.mode === 'lowpoly') {
    tileset.customShader = new Cesium.CustomShader({
      fragmentShaderText: `void fragmentMain(FragmentInput fsInput, inout czm_modelMaterial material) {
        material.normalEC = normalize(fsInput.attributes.normalEC);
      }`,
    });
  }
  const shownUrls = new Set();
  tileset.tileVisible.addEventListener((tile) => shownUrls.add(tile.content?.url ?? ''));
  tileset.tileFailed.addEventListener((error) => console.error(`terrabake 3D Tiles view: ${error.url}: ${error.message}`));
  scene.primitives.add(tileset);
  viewer.camera.frustum.fov = radians(view.fov);
  viewer.camera.lookAt(origin, new Cesium.HeadingPitchRange(radians(view.camAz + 180), -radians(view.camEl), view.camDist));

  await whenStable(
    () => {
      shownUrls.clear();
      scene.render();
    },
    () => (tileset.tilesLoaded ? [...shownUrls].sort().join(' ') : null));
  return { visibleLevels: levelsOf([...shownUrls]) };
}

async function main() {
  status('loading…');
  const target = await layerTarget();
  const shown = view.renderer === 'cesium' ? await showWithCesium(target) : await showWithThree(target);
  const fetched = performance.getEntriesByType('resource').map((entry) => entry.name);
  window.terrabakeStats = { ...shown, requestedLevels: levelsOf(fetched) };
  status('');
  window.terrabakeReady = true;
}

main().catch((error) => {
  status(`error: ${error.message}`);
  console.error(`terrabake 3D Tiles view: ${error.stack || error}`);
});
