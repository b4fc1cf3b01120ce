// crop4d's 4D viewer (docs/viewer.md): every session's cloud in the field frame, a time slider,
// colour by RGB / height above terrain / change between two dates, trajectories, measurement
// sites with their growth curves, the terrain surface, and distance/height measuring.
//
// Data (written by crop4d, src/crop4d/viewer/viewer_data.h) is read from ws/viewer/: scene.json,
// grids.bin, and per session an octree of tiles (src/crop4d/viewer/octree.h) that is loaded
// coarse first and refined where nodes are large on the screen, within a point budget.
//
// The page's state is window.crop4dViewer.state (read by the browser test and the bench).
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

const DATA = 'ws/viewer/';
const params = new URLSearchParams(location.search);
// Points drawn at most per frame, over all sessions shown.
const POINT_BUDGET = Number(params.get('budget') || 3000000);
// A node is refined while it covers more than this many pixels on the screen (its subsample
// holds up to 64 points per side: ~1.3 px spacing).
const REFINE_PIXELS = Number(params.get('refine') || 80);
const MAX_LOADS = 6;
const TINTS = [new THREE.Color(0xff9a3c), new THREE.Color(0x3cc8ff)];
const SESSION_COLOURS = [0xffd35c, 0x5cd6ff, 0xff6b8b, 0x8bff6b, 0xc58bff, 0xffa64d];

const state = {
  ready: false, error: null, dates: [], sessions: [], dateIndex: 0, compareIndex: 0,
  mode: 'one', colorBy: 'rgb', visibleSessions: [], loadedNodes: 0, visiblePoints: 0,
  frames: 0, firstFrameMs: null, fps: 0, selectedSite: null, measure: null,
};
const api = { state };
window.crop4dViewer = api;

const $ = (id) => document.getElementById(id);
const status = (text) => { $('status').textContent = text; };

function fail(error) {
  state.error = String(error && error.message || error);
  status('error: ' + state.error);
  console.error(error);
}

async function fetchOk(url, kind) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
  return kind === 'json' ? r.json() : r.arrayBuffer();
}

// ---- scene ---------------------------------------------------------------------------------
const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
renderer.setSize(window.innerWidth, window.innerHeight);
$('view').appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x1b1d1f);
const camera = new THREE.PerspectiveCamera(50, window.innerWidth / window.innerHeight, 0.01, 5000);
camera.up.set(0, 0, 1);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;
scene.add(new THREE.AmbientLight(0xffffff, 0.7));
const sun = new THREE.DirectionalLight(0xffffff, 0.8);
sun.position.set(1, -1, 2);
scene.add(sun);

const uniforms = {
  colorBy: { value: 0 },
  terrainTex: { value: null },
  changeTex: { value: null },
  grid: { value: new THREE.Vector4(0, 0, 1, 1) },
  heightRange: { value: 0.6 },
  changeRange: { value: 0.3 },
  // Points are drawn POINT_METRES wide in the field, at least MIN_POINT_PIXELS: close up the
  // dense cloud (~6 mm between points) closes, far away every point stays visible.
  pointScale: { value: 1.0 },
  minPointSize: { value: 1.5 },
};
const POINT_METRES = 0.008;

const vertexShader = `
uniform int colorBy;
uniform sampler2D terrainTex;
uniform sampler2D changeTex;
uniform vec4 grid;
uniform float heightRange;
uniform float changeRange;
uniform float pointScale;
uniform float minPointSize;
uniform vec3 tint;
uniform float tintMix;
varying vec3 vColor;
vec3 ramp(float t) {  // dark blue, green, yellow
  t = clamp(t, 0.0, 1.0);
  return mix(mix(vec3(0.15, 0.1, 0.45), vec3(0.1, 0.65, 0.45), smoothstep(0.0, 0.5, t)),
             vec3(0.98, 0.9, 0.15), smoothstep(0.5, 1.0, t));
}
vec3 diverging(float t) {  // red (lower), white, green (higher)
  t = clamp(t, -1.0, 1.0);
  return t < 0.0 ? mix(vec3(0.95), vec3(0.85, 0.1, 0.1), -t) : mix(vec3(0.95), vec3(0.05, 0.6, 0.15), t);
}
void main() {
  vec4 world = modelMatrix * vec4(position, 1.0);
  vec2 uv = (world.xy - grid.xy) / grid.zw;
  vec3 c = color;
  if (colorBy == 1) {
    c = ramp((world.z - texture2D(terrainTex, uv).r) / heightRange);
  } else if (colorBy == 2) {
    float d = texture2D(changeTex, uv).r;
    c = d < -900.0 ? vec3(0.45) : diverging(d / changeRange);
  }
  vColor = mix(c, tint, tintMix);
  vec4 view = viewMatrix * world;
  gl_Position = projectionMatrix * view;
  gl_PointSize = clamp(pointScale / max(-view.z, 1e-3), minPointSize, 8.0);
}`;
const fragmentShader = `
varying vec3 vColor;
void main() { gl_FragColor = vec4(vColor, 1.0); }`;

function makeMaterial() {
  return new THREE.ShaderMaterial({
    uniforms: { ...uniforms, tint: { value: new THREE.Color(0xffffff) }, tintMix: { value: 0 } },
    vertexShader, fragmentShader, vertexColors: true,
  });
}

// ---- octree of one session -----------------------------------------------------------------
let loadsInFlight = 0;
const loadQueue = [];

function decodeTile(buffer, url) {
  const view = new DataView(buffer);
  const magic = String.fromCharCode(...new Uint8Array(buffer, 0, 4));
  if (magic !== 'C4DT' || view.getUint32(4, true) !== 1) throw new Error(`${url}: not a tile`);
  const n = view.getUint32(8, true);
  if (buffer.byteLength !== 48 + 9 * n) throw new Error(`${url}: truncated tile`);
  return {
    n,
    min: [view.getFloat64(16, true), view.getFloat64(24, true), view.getFloat64(32, true)],
    side: view.getFloat64(40, true),
    positions: new Uint16Array(buffer, 48, 3 * n),
    colors: new Uint8Array(buffer, 48 + 6 * n, 3 * n),
  };
}

class SessionCloud {
  constructor(session, index, colour) {
    this.session = session;
    this.group = new THREE.Group();
    this.material = makeMaterial();
    this.colour = colour;
    this.nodes = new Map();
    for (const info of index.nodes) {
      const node = { info, points: null, loading: false, children: [],
        centre: new THREE.Vector3(info.min[0] + info.side / 2, info.min[1] + info.side / 2,
          info.min[2] + info.side / 2),
        box: new THREE.Box3(new THREE.Vector3(...info.min),
          new THREE.Vector3(info.min[0] + info.side, info.min[1] + info.side, info.min[2] + info.side)) };
      this.nodes.set(info.name, node);
      const parent = this.nodes.get(info.name.slice(0, -1));
      if (parent) parent.children.push(node);
    }
    this.root = this.nodes.get('r');
    this.base = DATA + 'clouds/' + encodeURIComponent(session.id) + '/';
  }

  load(node) {
    if (node.loading || node.points) return;
    node.loading = true;
    loadQueue.push(async () => {
      const url = this.base + node.info.name + '.bin';
      const tile = decodeTile(await fetchOk(url), url);
      const geometry = new THREE.BufferGeometry();
      geometry.setAttribute('position', new THREE.BufferAttribute(tile.positions, 3, true));
      geometry.setAttribute('color', new THREE.BufferAttribute(tile.colors, 3, true));
      geometry.boundingSphere = new THREE.Sphere(new THREE.Vector3(0.5, 0.5, 0.5), Math.sqrt(3) / 2);
      geometry.boundingBox = new THREE.Box3(new THREE.Vector3(0, 0, 0), new THREE.Vector3(1, 1, 1));
      const points = new THREE.Points(geometry, this.material);
      points.position.set(...tile.min);
      points.scale.setScalar(tile.side);
      points.visible = false;
      points.userData.session = this.session.id;
      this.group.add(points);
      node.points = points;
      state.loadedNodes += 1;
      needsUpdate = true;
    });
    pumpLoads();
  }

  // Shows the nodes that matter for this camera, largest on the screen first, within `budget`
  // points; requests the ones not loaded yet. Returns the points shown.
  update(frustum, pixelFactor, budget) {
    for (const node of this.nodes.values()) if (node.points) node.points.visible = false;
    if (!this.group.visible || !this.root) return 0;
    let shown = 0;
    const queue = [{ node: this.root, size: Infinity }];
    while (queue.length) {
      let best = 0;
      for (let i = 1; i < queue.length; ++i) if (queue[i].size > queue[best].size) best = i;
      const { node } = queue.splice(best, 1)[0];
      if (!frustum.intersectsBox(node.box)) continue;
      if (shown + node.info.count > budget) break;
      if (!node.points) { this.load(node); continue; }
      node.points.visible = true;
      shown += node.info.count;
      for (const child of node.children) {
        const distance = Math.max(camera.position.distanceTo(child.centre) - child.info.side, 1e-3);
        const size = child.info.side * pixelFactor / distance;
        if (size > REFINE_PIXELS) queue.push({ node: child, size });
      }
    }
    return shown;
  }
}

function pumpLoads() {
  while (loadsInFlight < MAX_LOADS && loadQueue.length) {
    const job = loadQueue.shift();
    loadsInFlight += 1;
    job().catch(fail).finally(() => { loadsInFlight -= 1; pumpLoads(); });
  }
}

// ---- the field -----------------------------------------------------------------------------
let sceneInfo = null;
let clouds = [];
let grids = null;  // {terrain: Float32Array, tops: Map(id → Float32Array)}
const trajectories = new THREE.Group();
const sites = new THREE.Group();
let terrainMesh = null;
let needsUpdate = true;

function terrainAt(x, y) {
  const g = sceneInfo.grid;
  const i = Math.min(g.nx - 1, Math.max(0, Math.floor((x - g.min[0]) / g.cell)));
  const j = Math.min(g.ny - 1, Math.max(0, Math.floor((y - g.min[1]) / g.cell)));
  return grids.terrain[j * g.nx + i];
}

function floatTexture(values, g) {
  const tex = new THREE.DataTexture(values, g.nx, g.ny, THREE.RedFormat, THREE.FloatType);
  tex.minFilter = THREE.NearestFilter;
  tex.magFilter = THREE.NearestFilter;
  tex.needsUpdate = true;
  return tex;
}

function buildGrids(buffer) {
  const g = sceneInfo.grid;
  const cells = g.nx * g.ny;
  if (buffer.byteLength !== 4 * cells * g.layers.length) throw new Error('grids.bin: wrong size');
  const layer = (k) => new Float32Array(buffer, 4 * cells * k, cells);
  grids = { terrain: layer(0), tops: new Map() };
  g.layers.forEach((name, k) => { if (name.startsWith('top:')) grids.tops.set(name.slice(4), layer(k)); });
  uniforms.terrainTex.value = floatTexture(grids.terrain, g);
  uniforms.grid.value.set(g.min[0], g.min[1], g.nx * g.cell, g.ny * g.cell);
}

function buildTerrainMesh() {
  const g = sceneInfo.grid;
  const step = Math.max(1, Math.ceil(Math.max(g.nx, g.ny) / 400));
  const nx = Math.ceil(g.nx / step), ny = Math.ceil(g.ny / step);
  const positions = new Float32Array(nx * ny * 3);
  for (let j = 0; j < ny; ++j) for (let i = 0; i < nx; ++i) {
    const x = g.min[0] + (i * step + 0.5) * g.cell, y = g.min[1] + (j * step + 0.5) * g.cell;
    const k = 3 * (j * nx + i);
    positions[k] = x; positions[k + 1] = y; positions[k + 2] = terrainAt(x, y);
  }
  const indices = [];
  for (let j = 0; j + 1 < ny; ++j) for (let i = 0; i + 1 < nx; ++i) {
    const a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
    indices.push(a, b, d, a, d, c);
  }
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  geometry.setIndex(indices);
  geometry.computeVertexNormals();
  terrainMesh = new THREE.Mesh(geometry, new THREE.MeshLambertMaterial({
    color: 0x9a7b55, transparent: true, opacity: 0.75, side: THREE.DoubleSide }));
  terrainMesh.visible = $('show-terrain').checked;
  scene.add(terrainMesh);
}

function buildTrajectories() {
  sceneInfo.sessions.forEach((s, k) => {
    if (!s.trajectory || s.trajectory.length < 2) return;
    // Segments between consecutive poses; a jump of more than a metre (between row passes)
    // is not drawn.
    const segments = [];
    for (let i = 1; i < s.trajectory.length; ++i) {
      const a = s.trajectory[i - 1], b = s.trajectory[i];
      if (Math.hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]) > 1.0) continue;
      segments.push(new THREE.Vector3(...a), new THREE.Vector3(...b));
    }
    const geometry = new THREE.BufferGeometry().setFromPoints(segments);
    const line = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({
      color: SESSION_COLOURS[k % SESSION_COLOURS.length] }));
    line.userData.session = s.id;
    trajectories.add(line);
  });
  scene.add(trajectories);
}

function buildSites() {
  const marker = new THREE.SphereGeometry(0.04, 12, 8);
  for (const site of sceneInfo.sites) {
    const group = new THREE.Group();
    const ground = terrainAt(site.x, site.y);
    const bar = new THREE.Mesh(new THREE.CylinderGeometry(0.012, 0.012, 1, 8),
      new THREE.MeshLambertMaterial({ color: 0xffffff }));
    bar.rotation.x = Math.PI / 2;
    const ball = new THREE.Mesh(marker, new THREE.MeshLambertMaterial({ color: 0xff3b3b }));
    group.add(bar, ball);
    group.userData = { site, ground, bar, ball };
    ball.userData.site = site;
    sites.add(group);
  }
  scene.add(sites);
}

// The site bars show the canopy height of the date on the slider.
function updateSites() {
  const date = state.dates[state.dateIndex];
  for (const group of sites.children) {
    const { site, ground, bar, ball } = group.userData;
    const h = site.heights[date];
    const height = Number.isFinite(h) ? h : 0;
    bar.scale.set(1, Math.max(height, 1e-3), 1);
    bar.position.set(site.x, site.y, ground + height / 2);
    ball.position.set(site.x, site.y, ground + height);
    bar.visible = Number.isFinite(h);
  }
}

// ---- time slider and colouring ---------------------------------------------------------------
function shownSessionIds() {
  const ids = [sceneInfo.sessions[state.dateIndex].id];
  if (state.mode === 'two' && state.compareIndex !== state.dateIndex)
    ids.push(sceneInfo.sessions[state.compareIndex].id);
  return ids;
}

function updateChangeTexture() {
  const g = sceneInfo.grid;
  const later = grids.tops.get(sceneInfo.sessions[state.dateIndex].id);
  const earlier = grids.tops.get(sceneInfo.sessions[state.compareIndex].id);
  const change = new Float32Array(g.nx * g.ny);
  for (let k = 0; k < change.length; ++k) {
    const d = later[k] - earlier[k];
    change[k] = Number.isFinite(d) ? d : -999;
  }
  if (uniforms.changeTex.value) uniforms.changeTex.value.dispose();
  uniforms.changeTex.value = floatTexture(change, g);
  // The colour scale spans the 98th percentile of the change's size.
  uniforms.changeRange.value = scaleOf(Array.from(change).filter((d) => d > -900).map(Math.abs));
}

// The 98th percentile of `values` (≥ 0), rounded up to 5 cm; 0.3 m when there are none.
function scaleOf(values) {
  if (!values.length) return 0.3;
  values.sort((a, b) => a - b);
  const p = values[Math.min(values.length - 1, Math.floor(0.98 * values.length))];
  return Math.max(0.05, Math.ceil(p / 0.05) * 0.05);
}

// Height colouring spans the 98th percentile of the canopy top above the terrain of the date.
function updateHeightRange() {
  const top = grids.tops.get(sceneInfo.sessions[state.dateIndex].id);
  const heights = [];
  for (let k = 0; k < top.length; ++k) {
    const h = top[k] - grids.terrain[k];
    if (Number.isFinite(h)) heights.push(Math.max(h, 0));
  }
  uniforms.heightRange.value = scaleOf(heights);
}

function applyState() {
  const ids = shownSessionIds();
  state.visibleSessions = ids.slice();
  clouds.forEach((cloud) => {
    const k = ids.indexOf(cloud.session.id);
    cloud.group.visible = k >= 0;
    const two = state.mode === 'two' && ids.length === 2;
    cloud.material.uniforms.tintMix.value = two && state.colorBy === 'rgb' ? 0.55 : 0;
    cloud.material.uniforms.tint.value = TINTS[Math.max(k, 0)];
  });
  for (const line of trajectories.children) line.visible = $('show-trajectories').checked && ids.includes(line.userData.session);
  sites.visible = $('show-sites').checked;
  if (terrainMesh) terrainMesh.visible = $('show-terrain').checked;
  uniforms.colorBy.value = { rgb: 0, height: 1, change: 2 }[state.colorBy];
  if (state.colorBy === 'change') updateChangeTexture();
  if (state.colorBy === 'height') updateHeightRange();
  $('date-label').textContent = state.dates[state.dateIndex];
  $('compare-label').textContent = state.dates[state.compareIndex];
  $('compare-box').style.opacity = state.mode === 'two' || state.colorBy === 'change' ? 1 : 0.4;
  updateSites();
  updateLegend();
  if (state.selectedSite) showSite(state.selectedSite);
  needsUpdate = true;
}

function updateLegend() {
  const legend = $('legend');
  if (state.colorBy === 'height') {
    legend.innerHTML = 'height above terrain: 0 <span class="ramp" style="background:linear-gradient(90deg,#261a73,#1aa673,#fae626)"></span> ' +
      uniforms.heightRange.value.toFixed(2) + ' m';
  } else if (state.colorBy === 'change') {
    const r = uniforms.changeRange.value.toFixed(2);
    legend.innerHTML = `canopy top ${state.dates[state.dateIndex]} − ${state.dates[state.compareIndex]}: −${r} m ` +
      '<span class="ramp" style="background:linear-gradient(90deg,#d91a1a,#f2f2f2,#0d9926)"></span> +' + r + ' m';
  } else if (state.mode === 'two') {
    legend.innerHTML = `<span style="color:#ff9a3c">■ ${state.dates[state.dateIndex]}</span> &nbsp; <span style="color:#3cc8ff">■ ${state.dates[state.compareIndex]}</span>`;
  } else {
    legend.textContent = 'RGB';
  }
}

// Turns the view about the target by `radians` (the bench orbits the camera with it).
api.rotate = (radians) => {
  const offset = camera.position.clone().sub(controls.target);
  offset.applyAxisAngle(new THREE.Vector3(0, 0, 1), radians);
  camera.position.copy(controls.target).add(offset);
  controls.update();
  needsUpdate = true;
};
api.setDate = (i) => { state.dateIndex = Math.max(0, Math.min(state.dates.length - 1, i)); $('date').value = state.dateIndex; applyState(); };
api.setCompare = (i) => { state.compareIndex = Math.max(0, Math.min(state.dates.length - 1, i)); $('compare').value = state.compareIndex; applyState(); };
api.setMode = (m) => { state.mode = m; $('mode').value = m; applyState(); };
api.setColorBy = (c) => { state.colorBy = c; $('color').value = c; applyState(); };

// ---- sites: growth curves --------------------------------------------------------------------
const DAY_MS = 86400000;
const dayOf = (date) => Date.parse(date + 'T00:00:00Z') / DAY_MS;

api.sites = () => (sceneInfo ? sceneInfo.sites : []);
api.showSite = (site) => showSite(site);

function showSite(site) {
  state.selectedSite = site;
  const panel = $('panel');
  panel.hidden = false;
  const heights = Object.entries(site.heights).map(([d, h]) => [dayOf(d), h, d]).sort((a, b) => a[0] - b[0]);
  const days = heights.map((h) => h[0]).concat(state.dates.map(dayOf));
  const d0 = Math.min(...days) - 3, d1 = Math.max(...days) + 3;
  let hmax = Math.max(0.05, ...heights.map((h) => h[1]));
  if (site.growth) hmax = Math.max(hmax, site.growth.asymptote_m);
  hmax *= 1.1;
  const W = 320, H = 180, L = 38, B = 24;
  const sx = (d) => L + (d - d0) / (d1 - d0) * (W - L - 8), sy = (h) => H - B - h / hmax * (H - B - 8);
  let svg = `<svg width="${W}" height="${H}" font-size="10" font-family="sans-serif">`;
  svg += `<line x1="${L}" y1="${H - B}" x2="${W - 8}" y2="${H - B}" stroke="#333"/><line x1="${L}" y1="8" x2="${L}" y2="${H - B}" stroke="#333"/>`;
  for (let k = 0; k <= 4; ++k) {
    const h = hmax * k / 4;
    svg += `<text x="${L - 4}" y="${sy(h) + 3}" text-anchor="end" fill="#333">${h.toFixed(2)}</text>`;
  }
  state.dates.forEach((d) => { svg += `<text x="${sx(dayOf(d))}" y="${H - 8}" text-anchor="middle" fill="#333">${d.slice(5)}</text>`; });
  if (site.growth) {
    const g = site.growth, mid = dayOf(g.midpoint_date);
    let path = '';
    for (let k = 0; k <= 80; ++k) {
      const d = d0 + (d1 - d0) * k / 80;
      const h = g.asymptote_m / (1 + Math.exp(-g.rate_per_day * (d - mid)));
      path += (k ? 'L' : 'M') + sx(d).toFixed(1) + ',' + sy(h).toFixed(1);
    }
    svg += `<path d="${path}" fill="none" stroke="#1a7f37" stroke-width="1.5"/>`;
  }
  const current = state.dates[state.dateIndex];
  for (const [d, h, date] of heights) {
    svg += `<circle cx="${sx(d)}" cy="${sy(h)}" r="${date === current ? 5 : 3.5}" fill="${date === current ? '#e8590c' : '#1c4e80'}"/>`;
  }
  svg += '</svg>';
  const now = site.heights[current];
  panel.innerHTML = `<h3>site ${site.id}</h3><div>canopy height on ${current}: ${Number.isFinite(now) ? now.toFixed(3) + ' m' : '—'}</div>` +
    svg + `<div>${site.growth ? `logistic fit: asymptote ${site.growth.asymptote_m.toFixed(3)} m, midpoint ${site.growth.midpoint_date}` : 'no growth fit'}</div>` +
    '<button type="button" id="panel-close">close</button>';
  $('panel-close').onclick = () => { panel.hidden = true; state.selectedSite = null; };
}

// ---- picking and measuring -------------------------------------------------------------------
const raycaster = new THREE.Raycaster();
raycaster.params.Points.threshold = 0.03;
let measuring = false;
let picks = [];
const measureGroup = new THREE.Group();
scene.add(measureGroup);

function pointer(event) {
  const rect = renderer.domElement.getBoundingClientRect();
  return new THREE.Vector2((event.clientX - rect.left) / rect.width * 2 - 1,
    -(event.clientY - rect.top) / rect.height * 2 + 1);
}

function pickPoint(ndc) {
  raycaster.setFromCamera(ndc, camera);
  const targets = [];
  for (const cloud of clouds) if (cloud.group.visible) for (const p of cloud.group.children) if (p.visible) targets.push(p);
  if (terrainMesh && terrainMesh.visible) targets.push(terrainMesh);
  const hits = raycaster.intersectObjects(targets, false);
  return hits.length ? hits[0].point.clone() : null;
}

// The distance, horizontal distance and height difference between two points (field metres).
api.measureBetween = (pa, pb) => {
  const a = Array.isArray(pa) ? new THREE.Vector3(...pa) : pa;
  const b = Array.isArray(pb) ? new THREE.Vector3(...pb) : pb;
  const d = new THREE.Vector3().subVectors(b, a);
  state.measure = { a: a.toArray(), b: b.toArray(), distance: d.length(),
    horizontal: Math.hypot(d.x, d.y), height: d.z };
  measureGroup.clear();
  const line = new THREE.Line(new THREE.BufferGeometry().setFromPoints([a, b]),
    new THREE.LineBasicMaterial({ color: 0xffd35c, depthTest: false }));
  const dots = new THREE.Points(new THREE.BufferGeometry().setFromPoints([a, b]),
    new THREE.PointsMaterial({ color: 0xffd35c, size: 8, sizeAttenuation: false, depthTest: false }));
  measureGroup.add(line, dots);
  const panel = $('panel');
  panel.hidden = false;
  panel.innerHTML = `<h3>measurement</h3><div>distance ${state.measure.distance.toFixed(3)} m</div>` +
    `<div>horizontal ${state.measure.horizontal.toFixed(3)} m</div><div>height difference ${state.measure.height.toFixed(3)} m</div>`;
  return state.measure;
};

renderer.domElement.addEventListener('click', (event) => {
  if (!sceneInfo) return;
  const ndc = pointer(event);
  if (measuring) {
    const p = pickPoint(ndc);
    if (!p) return;
    picks.push(p);
    status(`picked ${picks.length}/2: ${p.x.toFixed(3)}, ${p.y.toFixed(3)}, ${p.z.toFixed(3)}`);
    if (picks.length === 2) { api.measureBetween(picks[0], picks[1]); picks = []; }
    return;
  }
  raycaster.setFromCamera(ndc, camera);
  const hit = raycaster.intersectObjects(sites.children.map((g) => g.userData.ball), false)[0];
  if (hit) showSite(hit.object.userData.site);
});

$('measure').onclick = () => {
  measuring = !measuring;
  picks = [];
  $('measure').classList.toggle('active', measuring);
  if (!measuring) measureGroup.clear();
};

// ---- render loop -----------------------------------------------------------------------------
const frustum = new THREE.Frustum();
const projection = new THREE.Matrix4();
let fpsFrames = 0, fpsStart = performance.now();

function frame() {
  requestAnimationFrame(frame);
  if (!sceneInfo) return;
  if (needsUpdate) {
    needsUpdate = false;
    camera.updateMatrixWorld();
    projection.multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse);
    frustum.setFromProjectionMatrix(projection);
    const pixelFactor = renderer.domElement.height / (2 * Math.tan(THREE.MathUtils.degToRad(camera.fov) / 2));
    uniforms.pointScale.value = POINT_METRES * pixelFactor;
    let budget = POINT_BUDGET, shown = 0;
    for (const cloud of clouds) {
      const n = cloud.update(frustum, pixelFactor, budget);
      budget -= n; shown += n;
    }
    state.visiblePoints = shown;
  }
  renderer.render(scene, camera);
  state.frames += 1;
  if (state.firstFrameMs === null && state.visiblePoints > 0) state.firstFrameMs = performance.now();
  fpsFrames += 1;
  const now = performance.now();
  if (now - fpsStart > 1000) {
    state.fps = fpsFrames * 1000 / (now - fpsStart);
    fpsFrames = 0; fpsStart = now;
    status(`${state.visiblePoints.toLocaleString('en')} points shown, ${state.loadedNodes} tiles loaded, ${state.fps.toFixed(1)} fps`);
  }
}

controls.addEventListener('change', () => { needsUpdate = true; });
window.addEventListener('resize', () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight);
  needsUpdate = true;
});

async function main() {
  sceneInfo = await fetchOk(DATA + 'scene.json', 'json');
  if (!sceneInfo.sessions.length) throw new Error('scene.json: no session');
  state.sessions = sceneInfo.sessions.map((s) => s.id);
  state.dates = sceneInfo.sessions.map((s) => s.date);
  buildGrids(await fetchOk(DATA + sceneInfo.grid.file));
  const indices = await Promise.all(sceneInfo.sessions.map((s) => fetchOk(DATA + s.octree, 'json')));
  clouds = sceneInfo.sessions.map((s, k) => new SessionCloud(s, indices[k], SESSION_COLOURS[k % SESSION_COLOURS.length]));
  for (const cloud of clouds) scene.add(cloud.group);
  buildTerrainMesh();
  buildTrajectories();
  buildSites();
  if (sceneInfo.report) {
    $('report-link').href = 'ws/' + sceneInfo.report;
    $('report-link').hidden = false;
  }
  // The view: the whole field from the south, above.
  const g = sceneInfo.grid;
  const cx = g.min[0] + g.nx * g.cell / 2, cy = g.min[1] + g.ny * g.cell / 2;
  const extent = Math.max(g.nx, g.ny) * g.cell;
  const z0 = terrainAt(cx, cy);
  controls.target.set(cx, cy + 0.05 * extent, z0);
  camera.position.set(cx + 0.25 * extent, cy - 0.55 * extent, z0 + 0.4 * extent);
  controls.update();
  const last = state.dates.length - 1;
  $('date').max = last; $('compare').max = last;
  state.dateIndex = last;
  state.compareIndex = Math.max(0, last - 1);
  $('date').value = state.dateIndex; $('compare').value = state.compareIndex;
  $('date').addEventListener('input', () => api.setDate(Number($('date').value)));
  $('compare').addEventListener('input', () => api.setCompare(Number($('compare').value)));
  $('mode').addEventListener('change', () => api.setMode($('mode').value));
  $('color').addEventListener('change', () => api.setColorBy($('color').value));
  for (const id of ['show-trajectories', 'show-sites', 'show-terrain']) $(id).addEventListener('change', applyState);
  const initialDate = params.get('date');
  if (initialDate && state.dates.includes(initialDate)) state.dateIndex = state.dates.indexOf(initialDate);
  if (params.get('color')) state.colorBy = params.get('color');
  if (params.get('mode')) state.mode = params.get('mode');
  $('date').value = state.dateIndex; $('color').value = state.colorBy; $('mode').value = state.mode;
  applyState();
  state.ready = true;
}

requestAnimationFrame(frame);
main().catch(fail);
