// Browser side of three_shading_test.mjs: loads one tile's .glb and
// .hires.glb with three.js's GLTFLoader and renders them, seen straight down
// through an orthographic camera and lit by one directional light, into a
// float render target (linear values: no tone mapping, no output colour space
// conversion). The page sets window.terrabakeReady once three.js has loaded;
// the test then calls window.terrabakeShading.render(options); options.meshes
// names further .glb files of the same tile (other low-poly meshes), rendered
// with the same camera and light.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

// Unit vector (glTF axes: +X east, +Y up, +Z south) from the ground towards
// azimuth (clockwise from north) and elevation; as the viewer has it.
function directionFromAngles(azimuthDeg, elevationDeg) {
  const az = THREE.MathUtils.degToRad(azimuthDeg);
  const elev = THREE.MathUtils.degToRad(elevationDeg);
  return new THREE.Vector3(Math.sin(az) * Math.cos(elev), Math.sin(elev), -Math.cos(az) * Math.cos(elev));
}

function onlyMesh(gltf, url, problems) {
  const meshes = [];
  gltf.scene.traverse((object) => { if (object.isMesh) meshes.push(object); });
  if (meshes.length !== 1) problems.push(`${url}: ${meshes.length} meshes, expected 1`);
  return meshes[0];
}

// Float32Array -> base64, in pieces (String.fromCharCode takes few arguments).
function toBase64(floats) {
  const bytes = new Uint8Array(floats.buffer, floats.byteOffset, floats.byteLength);
  let text = '';
  for (let i = 0; i < bytes.length; i += 0x8000) text += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(text);
}

// The tangent-space normal map of the low-poly mesh that gives back the
// high-res normals in a renderer whose per-pixel frame is
//   'per-vertex': B = normalize(interpolated w * cross(NORMAL, TANGENT))   (three.js; the bake, CONTRACT.md §4)
//   'per-pixel':  B = w * cross(normalize(interpolated NORMAL), normalize(interpolated TANGENT))
//                 (the frame the bake inverted before)
// computed here from the two meshes' attributes and rounded to 8 bits, as
// the browser hands the PNG to WebGL, and unrounded. Returns {bytes, floats}:
// RGBA, S x S, row 0 north.
function encodeNormalMap(low, highNormals, size, frame) {
  const index = low.index.array;
  const uvs = low.attributes.uv;
  const nrm = low.attributes.normal;
  const tan = low.attributes.tangent;
  const out = new Uint8Array(size * size * 4);
  const floats = new Float32Array(size * size * 4);
  const done = new Uint8Array(size * size);
  const v3 = (attr, i) => [attr.getX(i), attr.getY(i), attr.getZ(i)];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const norm = (a) => { const l = Math.hypot(a[0], a[1], a[2]); return [a[0] / l, a[1] / l, a[2] / l]; };
  const mix = (a, b, c, w) => [0, 1, 2].map((k) => w[0] * a[k] + w[1] * b[k] + w[2] * c[k]);
  for (let t = 0; t < index.length; t += 3) {
    const ids = [index[t], index[t + 1], index[t + 2]];
    const uv = ids.map((i) => [uvs.getX(i) * size - 0.5, uvs.getY(i) * size - 0.5]);  // in texel-centre units
    const n = ids.map((i) => v3(nrm, i));
    const tg = ids.map((i) => v3(tan, i));
    const w = ids.map((i) => tan.getW(i));
    const bv = ids.map((_, k) => cross(n[k], tg[k]).map((c) => c * w[k]));
    const det = (uv[1][0] - uv[0][0]) * (uv[2][1] - uv[0][1]) - (uv[2][0] - uv[0][0]) * (uv[1][1] - uv[0][1]);
    const i0 = Math.max(0, Math.floor(Math.min(uv[0][0], uv[1][0], uv[2][0])));
    const i1 = Math.min(size - 1, Math.ceil(Math.max(uv[0][0], uv[1][0], uv[2][0])));
    const j0 = Math.max(0, Math.floor(Math.min(uv[0][1], uv[1][1], uv[2][1])));
    const j1 = Math.min(size - 1, Math.ceil(Math.max(uv[0][1], uv[1][1], uv[2][1])));
    for (let j = j0; j <= j1; ++j) {
      for (let i = i0; i <= i1; ++i) {
        const texel = j * size + i;
        if (done[texel]) continue;
        const b1 = ((i - uv[0][0]) * (uv[2][1] - uv[0][1]) - (uv[2][0] - uv[0][0]) * (j - uv[0][1])) / det;
        const b2 = ((uv[1][0] - uv[0][0]) * (j - uv[0][1]) - (i - uv[0][0]) * (uv[1][1] - uv[0][1])) / det;
        const bary = [1 - b1 - b2, b1, b2];
        if (bary.some((b) => b < -1e-9)) continue;
        done[texel] = 1;
        const N = norm(mix(...n, bary));
        const T = norm(mix(...tg, bary));
        const B = frame === 'per-vertex'
          ? norm(mix(...bv, bary))
          : cross(N, T).map((c) => c * (bary[0] * w[0] + bary[1] * w[1] + bary[2] * w[2]));
        // x = inverse([T B N]) * h, by Cramer's rule.
        const h = highNormals.subarray(3 * texel, 3 * texel + 3);
        const d = dot(T, cross(B, N));
        const x = norm([dot(h, cross(B, N)) / d, dot(T, cross(h, N)) / d, dot(T, cross(B, h)) / d]);
        for (let k = 0; k < 3; ++k) {
          floats[4 * texel + k] = x[k] * 0.5 + 0.5;
          out[4 * texel + k] = Math.round(floats[4 * texel + k] * 255);
        }
        out[4 * texel + 3] = 255;
        floats[4 * texel + 3] = 1;
      }
    }
  }
  return { bytes: out, floats };
}

// The normal map as WebGL gets it: the PNG decoded by the browser, 8 bits.
function textureBytes(texture) {
  const { width, height } = texture.image;
  const canvas = new OffscreenCanvas(width, height);
  const context = canvas.getContext('2d', { colorSpace: 'srgb' });
  context.drawImage(texture.image, 0, 0);
  return context.getImageData(0, 0, width, height).data;
}

async function render(options) {
  const { lowPolyUrl, highResUrl, width, height, sunAzimuthDeg, sunElevationDeg, sunIntensity } = options;
  const meshUrls = options.meshes || {};  // name -> .glb of the same tile with another low-poly mesh
  const problems = [];
  const info = {};
  const loader = new GLTFLoader();
  const [lowGltf, highGltf, ...otherGltfs] = await Promise.all(
    [lowPolyUrl, highResUrl, ...Object.values(meshUrls)].map((url) => loader.loadAsync(url)));
  const low = onlyMesh(lowGltf, lowPolyUrl, problems);
  const high = onlyMesh(highGltf, highResUrl, problems);
  const others = Object.keys(meshUrls).map((name, k) => {
    otherGltfs[k].scene.updateMatrixWorld(true);
    return { name, mesh: onlyMesh(otherGltfs[k], meshUrls[name], problems) };
  });
  if (!low || !high || others.some((o) => !o.mesh)) return { problems };
  lowGltf.scene.updateMatrixWorld(true);
  highGltf.scene.updateMatrixWorld(true);

  // What GLTFLoader made of the files: the material CONTRACT.md §5 describes,
  // the normal map as linear data with glTF's UV origin, and the TANGENT
  // attribute, so three uses the glTF frame rather than derivatives.
  const material = low.material;
  if (!material.isMeshStandardMaterial) problems.push(`low-poly material is ${material.type}, expected MeshStandardMaterial`);
  if (!material.normalMap) problems.push('low-poly material has no normal map');
  if (material.metalness !== 0 || material.roughness !== 1) {
    problems.push(`low-poly material has metalness ${material.metalness}, roughness ${material.roughness}; expected 0 and 1`);
  }
  if (!material.color.equals(new THREE.Color(1, 1, 1))) problems.push(`low-poly base colour is ${material.color.toArray()}, expected white`);
  if (material.normalScale.x !== 1 || material.normalScale.y !== 1) problems.push(`normalScale is (${material.normalScale.toArray()}), expected (1, 1)`);
  if (!low.geometry.attributes.tangent) problems.push('low-poly mesh has no TANGENT attribute');
  if (material.normalMap && (material.normalMap.colorSpace !== THREE.NoColorSpace || material.normalMap.flipY !== false)) {
    problems.push(`normal map has colorSpace '${material.normalMap.colorSpace}', flipY ${material.normalMap.flipY}; expected linear data, flipY false`);
  }
  if (!high.material.isMeshStandardMaterial || high.material.normalMap) problems.push('high-res material is not a MeshStandardMaterial without a normal map');
  if (!low.matrixWorld.equals(high.matrixWorld)) problems.push('the two meshes have different node transforms');
  for (const { name, mesh } of others) {
    if (!mesh.matrixWorld.equals(high.matrixWorld)) problems.push(`${name}: node transform differs from the high-res mesh's`);
    if (!mesh.material.normalMap || !mesh.geometry.attributes.tangent) problems.push(`${name}: no normal map or no TANGENT attribute`);
  }
  if (problems.length) return { problems };
  const size = material.normalMap.image.width;
  info.normalMapSize = [material.normalMap.image.width, material.normalMap.image.height];
  info.triangles = { lowPoly: low.geometry.index.count / 3, highRes: high.geometry.index.count / 3 };
  for (const { name, mesh } of others) info.triangles[name] = mesh.geometry.index.count / 3;

  // n_high of every texel: high-res vertex (i, j) sits at UV ((i + 0.5) / S, (j + 0.5) / S).
  const highNormals = new Float32Array(size * size * 3);
  {
    const uv = high.geometry.attributes.uv;
    const normal = high.geometry.attributes.normal;
    const seen = new Uint8Array(size * size);
    for (let v = 0; v < uv.count; ++v) {
      const i = Math.round(uv.getX(v) * size - 0.5);
      const j = Math.round(uv.getY(v) * size - 0.5);
      if (i < 0 || j < 0 || i >= size || j >= size) continue;
      seen[j * size + i] = 1;
      highNormals.set([normal.getX(v), normal.getY(v), normal.getZ(v)], 3 * (j * size + i));
    }
    if (seen.some((s) => !s)) problems.push('the high-res mesh lacks a vertex at some texel centre');
  }

  // The renderer: one sample a pixel, nothing after the lights.
  const renderer = new THREE.WebGLRenderer({ antialias: false });
  renderer.setPixelRatio(1);
  renderer.setSize(width, height);
  renderer.toneMapping = THREE.NoToneMapping;
  renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
  renderer.setClearColor(0x000000, 0);
  document.body.appendChild(renderer.domElement);
  const target = new THREE.WebGLRenderTarget(width, height, {
    type: THREE.FloatType, format: THREE.RGBAFormat, minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter,
    depthBuffer: true, generateMipmaps: false,
  });

  // Straight down onto the low-poly mesh's footprint: image x east, image y south.
  const box = new THREE.Box3().setFromObject(low);
  const centre = box.getCenter(new THREE.Vector3());
  const extent = box.getSize(new THREE.Vector3());
  const camera = new THREE.OrthographicCamera(-extent.x / 2, extent.x / 2, extent.z / 2, -extent.z / 2, 1, extent.y + 2000);
  camera.position.set(centre.x, box.max.y + 1000, centre.z);
  camera.up.set(0, 0, -1);
  camera.lookAt(centre.x, box.min.y, centre.z);
  camera.updateMatrixWorld();
  info.footprintM = [extent.x, extent.z];

  const scene = new THREE.Scene();  // no background, no environment, no ambient light
  const sunDirection = directionFromAngles(sunAzimuthDeg, sunElevationDeg);
  const sun = new THREE.DirectionalLight(0xffffff, sunIntensity);
  sun.position.copy(sunDirection);
  sun.target.position.set(0, 0, 0);
  scene.add(sun, sun.target);

  const pixels = new Float32Array(width * height * 4);
  // Renders one mesh; resolves to the red channel, rows from the top, NaN where the mesh is not.
  const shade = (mesh, meshMaterial) => {
    const copy = new THREE.Mesh(mesh.geometry, meshMaterial);
    copy.matrixAutoUpdate = false;
    copy.matrix.copy(mesh.matrixWorld);
    scene.add(copy);
    renderer.setRenderTarget(target);
    renderer.clear();
    renderer.render(scene, camera);
    renderer.readRenderTargetPixels(target, 0, 0, width, height, pixels);
    renderer.setRenderTarget(null);
    scene.remove(copy);
    const red = new Float32Array(width * height);
    for (let y = 0; y < height; ++y) {
      for (let x = 0; x < width; ++x) {
        const p = 4 * ((height - 1 - y) * width + x);
        red[y * width + x] = pixels[p + 3] > 0.5 ? pixels[p] : NaN;
      }
    }
    return toBase64(red);
  };
  const withNormalMap = (map) => {
    const m = material.clone();
    m.normalMap = map;
    return m;
  };
  const dataTexture = (data) => {
    const type = data instanceof Float32Array ? THREE.FloatType : THREE.UnsignedByteType;
    const texture = new THREE.DataTexture(data, size, size, THREE.RGBAFormat, type);
    for (const key of ['minFilter', 'magFilter', 'wrapS', 'wrapT', 'flipY', 'colorSpace', 'generateMipmaps']) {
      texture[key] = material.normalMap[key];
    }
    texture.needsUpdate = true;
    return texture;
  };

  // The normal maps a per-vertex and a per-pixel frame need, made here, and
  // how far the first is from the PNG as the browser decoded it.
  const perVertex = encodeNormalMap(low.geometry, highNormals, size, 'per-vertex');
  const perPixel = encodeNormalMap(low.geometry, highNormals, size, 'per-pixel');
  const differing = [];  // texels where the two frames' maps differ by more than one step
  {
    const png = textureBytes(material.normalMap);
    let maxStep = 0;
    let beyondOne = 0;
    for (let texel = 0; texel < size * size; ++texel) {
      let step = 0;
      let frameStep = 0;
      for (let k = 0; k < 3; ++k) {
        step = Math.max(step, Math.abs(png[4 * texel + k] - perVertex.bytes[4 * texel + k]));
        frameStep = Math.max(frameStep, Math.abs(perPixel.bytes[4 * texel + k] - perVertex.bytes[4 * texel + k]));
      }
      maxStep = Math.max(maxStep, step);
      if (step > 1) ++beyondOne;
      if (frameStep > 1) differing.push(texel);
    }
    info.pngVsPerVertexJs = { maxStep, beyondOne, texels: size * size };
  }

  const white = new THREE.MeshLambertMaterial({ color: 0xffffff });
  // Unlit: the height of the surface (metres up the tile's frame, which the
  // camera looks straight down) in red.
  const heightMaterial = new THREE.ShaderMaterial({
    vertexShader: `varying float vHeight;
      void main() {
        vec4 world = modelMatrix * vec4(position, 1.0);
        vHeight = world.y;
        gl_Position = projectionMatrix * viewMatrix * world;
      }`,
    fragmentShader: `varying float vHeight;
      void main() { gl_FragColor = vec4(vHeight, 0.0, 0.0, 1.0); }`,
  });
  const renders = {
    normalmap: shade(low, material),
    lowpoly: shade(low, withNormalMap(null)),
    highres: shade(high, high.material),
    lambert: shade(high, white),
    perVertexJs: shade(low, withNormalMap(dataTexture(perVertex.bytes))),
    perVertexFloat: shade(low, withNormalMap(dataTexture(perVertex.floats))),
    perPixelJs: shade(low, withNormalMap(dataTexture(perPixel.bytes))),
    greenFlipped: shade(low, (() => { const m = withNormalMap(material.normalMap); m.normalScale.set(1, -1); return m; })()),
    lowpolyFlat: shade(low, (() => { const m = withNormalMap(null); m.flatShading = true; return m; })()),
    lowpolyHeight: shade(low, heightMaterial),
    highresHeight: shade(high, heightMaterial),
  };
  // The other meshes of the tile, each with its own normal map, without it
  // (interpolated vertex normals, as the viewer's low-poly mode), and flat
  // shaded (each triangle's own normal: the geometry alone).
  for (const { name, mesh } of others) {
    renders[`${name}_normalmap`] = shade(mesh, mesh.material);
    const bare = mesh.material.clone();
    bare.normalMap = null;
    renders[`${name}_lowpoly`] = shade(mesh, bare);
    const flat = bare.clone();
    flat.flatShading = true;
    renders[`${name}_flat`] = shade(mesh, flat);
    renders[`${name}_height`] = shade(mesh, heightMaterial);
  }

  // Lambert shading expected from the high-res normals at every pixel centre,
  // max(0, n . sun) with n the normal interpolated over the high-res triangle
  // under it, as the GPU interpolates it (affinely: orthographic camera);
  // NaN where the high-res mesh is not.
  const expected = new Float32Array(width * height).fill(NaN);
  {
    const position = high.geometry.attributes.position;
    const normal = high.geometry.attributes.normal;
    const index = high.geometry.index.array;
    const normalMatrix = new THREE.Matrix3().getNormalMatrix(high.matrixWorld);
    const xy = new Float64Array(2 * position.count);
    const nl = new Float64Array(3 * position.count);
    const p = new THREE.Vector3();
    const n = new THREE.Vector3();
    for (let v = 0; v < position.count; ++v) {
      p.fromBufferAttribute(position, v).applyMatrix4(high.matrixWorld);
      n.fromBufferAttribute(normal, v).applyMatrix3(normalMatrix);
      xy[2 * v] = ((p.x - box.min.x) / extent.x) * width;    // pixels from the west edge
      xy[2 * v + 1] = ((p.z - box.min.z) / extent.z) * height;  // pixels from the north edge
      nl[3 * v] = n.x;
      nl[3 * v + 1] = n.y;
      nl[3 * v + 2] = n.z;
    }
    for (let t = 0; t < index.length; t += 3) {
      const [a, b, c] = [index[t], index[t + 1], index[t + 2]];
      const [ax, ay, bx, by, cx, cy] = [xy[2 * a], xy[2 * a + 1], xy[2 * b], xy[2 * b + 1], xy[2 * c], xy[2 * c + 1]];
      const det = (bx - ax) * (cy - ay) - (cx - ax) * (by - ay);
      const x0 = Math.max(0, Math.floor(Math.min(ax, bx, cx) - 0.5));
      const x1 = Math.min(width - 1, Math.ceil(Math.max(ax, bx, cx) - 0.5));
      const y0 = Math.max(0, Math.floor(Math.min(ay, by, cy) - 0.5));
      const y1 = Math.min(height - 1, Math.ceil(Math.max(ay, by, cy) - 0.5));
      for (let y = y0; y <= y1; ++y) {
        for (let x = x0; x <= x1; ++x) {
          const pixel = y * width + x;
          if (!Number.isNaN(expected[pixel])) continue;
          const px = x + 0.5;
          const py = y + 0.5;
          const wb = ((px - ax) * (cy - ay) - (cx - ax) * (py - ay)) / det;
          const wc = ((bx - ax) * (py - ay) - (px - ax) * (by - ay)) / det;
          const wa = 1 - wb - wc;
          if (wa < -1e-9 || wb < -1e-9 || wc < -1e-9) continue;
          n.set(wa * nl[3 * a] + wb * nl[3 * b] + wc * nl[3 * c],
            wa * nl[3 * a + 1] + wb * nl[3 * b + 1] + wc * nl[3 * c + 1],
            wa * nl[3 * a + 2] + wb * nl[3 * b + 2] + wc * nl[3 * c + 2]).normalize();
          expected[pixel] = Math.max(0, n.dot(sunDirection));
        }
      }
    }
  }
  renders.expected = toBase64(expected);

  renderer.dispose();
  target.dispose();
  return { problems, info, width, height, size, renders, differing };
}

window.terrabakeShading = { render };
window.terrabakeReady = true;
