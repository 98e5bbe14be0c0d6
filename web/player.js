// Plays a .glb exported from the MPEG-4 face add-on: skinned meshes and/or morph targets, driven by the
// file's animation through three's AnimationMixer. URL parameters:
//   src=FILE.glb  the file (relative to this page or absolute)
//   clip=N        which animation (default 0)
//   t=SECONDS     start at this time (default 0)
//   paused=1      do not play: draw the frame at t and wait (the browser test's deterministic frames)
//   morph=NAME:W,NAME:W  hold these morph targets at these weights on every mesh that has them, over the
//                 animation (e.g. morph=jawOpen:1,eyeBlinkLeft:0.5 on a face exported with its ARKit shape keys)
// For scripts: window.player.seek(t), .play(), .pause(), .measure(frames), .morph(name, weight) (how many meshes
// have the target; the next drawn frame shows it); window.playerReady is true once a
// frame of the loaded file is on screen (after every seek too), window.playerError holds a failure's message.
import {
  AnimationMixer,
  Box3,
  Clock,
  Color,
  DirectionalLight,
  HemisphereLight,
  MeshStandardMaterial,
  PerspectiveCamera,
  Scene,
  SRGBColorSpace,
  Vector3,
  WebGLRenderer,
} from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";

const BACKGROUND = 0x1d1e22;
const FIELD_OF_VIEW = 30; // degrees, vertical: a portrait lens, little perspective distortion on the face
const MARGIN = 1.15; // room around the head's bounding box
// glTF's default material is a white metal, black without an environment; a matte skin shows the shape
const MATTE = new MeshStandardMaterial({ color: 0xc9a08a, roughness: 0.6, metalness: 0 });

const params = new URLSearchParams(location.search);
const status = document.getElementById("status");
const renderer = new WebGLRenderer({ antialias: true });
renderer.outputColorSpace = SRGBColorSpace;
renderer.setPixelRatio(window.devicePixelRatio);
renderer.setSize(window.innerWidth, window.innerHeight);
document.body.appendChild(renderer.domElement);

const scene = new Scene();
scene.background = new Color(BACKGROUND);
const camera = new PerspectiveCamera(FIELD_OF_VIEW, window.innerWidth / window.innerHeight, 0.01, 100);
scene.add(new HemisphereLight(0xf2f4ff, 0x3a3028, 0.9));
const key = new DirectionalLight(0xfff4e8, 2.6); // above and to the face's right, as a portrait key light
const fill = new DirectionalLight(0xe8eeff, 0.7);
scene.add(key, fill, key.target, fill.target);

let mixer = null;
let restBox = null; // the file's bounds at time 0: the camera frames these and does not follow the animation
let playing = false;
const clock = new Clock(false);

window.playerReady = false;
window.player = { seek, play, pause, measure, morph, duration: 0, clips: [] };
const held = new Map(); // morph target name -> weight, held over the animation

// Set a morph target's weight on every mesh that has one of that name (glTF's mesh.extras.targetNames, which
// three.js reads into morphTargetDictionary); returns how many meshes have it.
function morph(name, weight) {
  held.set(name, weight);
  return applyHeld();
}

function applyHeld() {
  let meshes = 0;
  scene.traverse((object) => {
    const index = object.morphTargetDictionary;
    if (!index) return;
    let found = false;
    for (const [name, weight] of held) {
      if (name in index) {
        object.morphTargetInfluences[index[name]] = weight;
        found = true;
      }
    }
    meshes += found;
  });
  return meshes;
}

function fail(message) {
  window.playerError = message;
  status.textContent = message;
}

function draw() {
  renderer.render(scene, camera);
}

// Resolves after the browser has presented the frame just drawn (two animation frames later).
function presented() {
  return new Promise((resolve) => requestAnimationFrame(() => requestAnimationFrame(resolve)));
}

// Camera and lights on the face: glTF faces look along +Z (Blender's -Y), so the camera sits on +Z.
function frame(box) {
  const centre = box.getCenter(new Vector3());
  const size = box.getSize(new Vector3());
  const halfHeight = Math.tan((FIELD_OF_VIEW * Math.PI) / 360);
  const fitHeight = size.y / 2 / halfHeight;
  const fitWidth = size.x / 2 / (halfHeight * camera.aspect);
  const distance = size.z / 2 + MARGIN * Math.max(fitHeight, fitWidth); // the box's front face fits the view
  camera.position.copy(centre).add(new Vector3(0, 0, distance));
  camera.near = distance / 20;
  camera.far = distance * 20;
  camera.lookAt(centre);
  camera.updateProjectionMatrix();
  key.position.copy(centre).add(new Vector3(-0.6, 0.8, 1).multiplyScalar(distance));
  fill.position.copy(centre).add(new Vector3(0.8, -0.1, 1).multiplyScalar(distance));
  key.target.position.copy(centre);
  fill.target.position.copy(centre);
}

function matteWhereNoMaterial(gltf) {
  const json = gltf.parser.json;
  gltf.scene.traverse((object) => {
    const where = object.isMesh && gltf.parser.associations.get(object);
    const primitive = where && json.meshes[where.meshes]?.primitives[where.primitives ?? 0];
    if (primitive && primitive.material === undefined) object.material = MATTE;
  });
}

async function seek(seconds) {
  window.playerReady = false;
  if (mixer) mixer.setTime(seconds);
  applyHeld();
  draw();
  await presented();
  window.playerReady = true;
}

function play() {
  if (playing) return;
  playing = true;
  clock.start();
  renderer.setAnimationLoop(() => {
    mixer?.update(clock.getDelta());
    applyHeld();
    draw();
  });
}

function pause() {
  playing = false;
  clock.stop();
  renderer.setAnimationLoop(null);
}

// Mean milliseconds per frame over `frames` frames, each one animation step and one draw, two ways:
// renderMs waits for the GPU (a one-pixel read) so it is the cost of a frame; intervalMs is the time between
// the browser's animation frames, which a display's refresh rate caps from below.
async function measure(frames = 120) {
  const wasPlaying = playing;
  pause();
  const gl = renderer.getContext();
  const pixel = new Uint8Array(4);
  const step = window.player.duration > 0 ? window.player.duration / frames : 1 / 60;
  let rendering = 0;
  const start = performance.now();
  for (let i = 0; i < frames; i++) {
    await new Promise((resolve) => requestAnimationFrame(resolve));
    const before = performance.now();
    mixer?.setTime(i * step);
    draw();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
    rendering += performance.now() - before;
  }
  const result = { frames, renderMs: rendering / frames, intervalMs: (performance.now() - start) / frames };
  window.playerFrameTime = result;
  if (wasPlaying) play();
  return result;
}

window.addEventListener("resize", () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  renderer.setSize(window.innerWidth, window.innerHeight);
  if (restBox) frame(restBox);
  draw();
});

async function load(src) {
  const gltf = await new GLTFLoader().loadAsync(src);
  matteWhereNoMaterial(gltf);
  scene.add(gltf.scene);
  mixer = new AnimationMixer(gltf.scene);
  const clips = gltf.animations;
  window.player.clips = clips.map((clip) => clip.name);
  const index = Number(params.get("clip") ?? 0);
  if (clips.length > 0) {
    if (!(index >= 0 && index < clips.length)) throw new Error(`clip ${params.get("clip")}: the file has ${clips.length}`);
    mixer.clipAction(clips[index]).play();
    window.player.duration = clips[index].duration;
  }
  mixer.setTime(0);
  restBox = new Box3().setFromObject(gltf.scene, true); // at rest: the held morphs come after, at the seek
  for (const item of (params.get("morph") ?? "").split(",").filter(Boolean)) {
    const [name, weight] = item.split(":");
    if (!(Number(weight) >= 0 && Number(weight) <= 1)) throw new Error(`morph ${item}: the weight must be 0 to 1`);
    if (morph(name, Number(weight)) === 0) throw new Error(`morph ${name}: no mesh in the file has this target`);
  }
  frame(restBox);
  status.hidden = true;
  await seek(Number(params.get("t") ?? 0));
  if (params.get("paused") !== "1") play();
}

const src = params.get("src");
if (!src) fail("no file: add ?src=FILE.glb to the address");
else load(src).catch((error) => fail(`${src}: ${error.message ?? error}`));
