// The monitor's 3D view of a URDF robot (docs/monitor.md, "The robot in 3D"): three.js and urdf-loader, served by
// dca's own web server from lua/dca/monitor/page/3d/node_modules (installed by scripts/setup with npm ci from
// its lockfile; nothing is fetched from the network). The robot is built from its URDF text; each sample of the
// link frames (7 numbers per frame: x y z qx qy qz qw, the child link in its parent link) places the joints.
// Primitive geometry (box, cylinder, sphere) is drawn; meshes are left out with a warning (the monitor serves
// no mesh files). monitor.js calls window.dcaRobot3d.show(urdf, frames) and .draw(row), row = [t, values...].
import * as THREE from 'three';
import URDFLoader from '/3d/node_modules/urdf-loader/src/URDFLoader.js';

const WIDTH = 480, HEIGHT = 360;
let view = null;

function warn(text) {
  const w = document.getElementById('robot-warn');
  if (w) w.textContent += (w.textContent ? '\n' : '') + text;
  console.warn(`dca monitor: ${text}`);
}

// Builds the scene of `urdf`; frames = [[parent, child], ...] in the order of the samples' values.
function show(urdf, frames) {
  const canvas = document.getElementById('robot3d');
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.setSize(WIDTH, HEIGHT, false);
  renderer.setClearColor(0xf4f6f8);
  const scene = new THREE.Scene();
  scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 2.0));
  const sun = new THREE.DirectionalLight(0xffffff, 1.5);
  sun.position.set(3, 5, 4);
  scene.add(sun);
  const loader = new URDFLoader();
  loader.loadMeshCb = (path, manager, material, done) => { warn(`mesh ${path} left out (not served)`); done(null); };
  const robot = loader.parse(urdf);
  const world = new THREE.Group();  // URDF is z up, three.js y up
  world.rotation.x = -Math.PI / 2;
  world.add(robot);
  scene.add(world);
  const grid = new THREE.GridHelper(2, 10, 0x90a4ae, 0xcfd8dc);
  scene.add(grid);
  // the camera on the robot's base, far enough for its reach (the size of the robot as the URDF places it, every
  // joint at its origin, in any direction): the same for live and replay, whatever the pose
  world.updateMatrixWorld(true);
  const size = Math.max(0.5, new THREE.Box3().setFromObject(world).getSize(new THREE.Vector3()).length());
  const target = new THREE.Vector3(0, 0.35 * size, 0);
  const camera = new THREE.PerspectiveCamera(40, WIDTH / HEIGHT, size / 100, size * 20);
  camera.position.copy(target).add(new THREE.Vector3(1, 0.55, 1.2).normalize().multiplyScalar(1.8 * size));
  camera.lookAt(target);
  grid.scale.setScalar(size);
  // each frame's child link: the object that carries it (the joint placing it, or the robot for the root)
  const carriers = frames.map(([parent, child]) => {
    const link = robot.links[child];
    if (!link) { warn(`frame ${parent} -> ${child}: no such link in the URDF`); return null; }
    return link === robot ? robot : link.parent;
  });
  view = { renderer, scene, camera, carriers, t: null };
  document.getElementById('robot-pane').hidden = false;
  renderer.render(scene, camera);
}

// Places every frame from row = [t, x, y, z, qx, qy, qz, qw, ...] and draws.
function draw(row) {
  if (!view || !row) return;
  view.carriers.forEach((o, i) => {
    if (!o) return;
    const v = row.slice(1 + 7 * i, 8 + 7 * i);
    if (v.length < 7 || v.some((x) => typeof x !== 'number')) return;
    o.position.set(v[0], v[1], v[2]);
    o.quaternion.set(v[3], v[4], v[5], v[6]);
  });
  view.t = row[0];
  const canvas = document.getElementById('robot3d');
  canvas.dataset.t = row[0].toFixed(6);
  document.getElementById('robot-t').textContent = `t = ${row[0].toFixed(3)} s`;
  view.renderer.render(view.scene, view.camera);
  canvas.dataset.frames = String((canvas.dataset.frames | 0) + 1);
}

window.dcaRobot3d = { show, draw };
if (window.dcaMonitor) window.dcaMonitor.dirty.robot = true;  // monitor.js shows what it already has
