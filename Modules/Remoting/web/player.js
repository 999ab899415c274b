// HoloVolume player: connects to the remoting server, sends head poses (WebXR or the desktop
// orbit camera), decodes the stereo frames it gets back and draws them reprojected to the
// current pose. Protocol: Documentation/RemotingProtocol.md.

import * as protocol from './protocol.js';
import { Connection } from './connection.js';
import { FrameDecoder, canDecodeH264 } from './decoder.js';
import { Reprojector } from './reprojection.js';
import { OrbitCamera } from './desktop.js';
import { GrabTracker } from './grab.js';
import { StatusPanel } from './statuspanel.js';
import { getTranslation, multiply, normalize, sub } from './mat4.js';

const SENT_POSES_KEPT = 4096;    // about a minute of XR frames: a slow server answers old poses
const DRAWN_POSE_IDS_KEPT = 256;
const ERRORS_KEPT = 50;
const MAX_BUFFERED_BYTES = 64 * 1024; // skip a pose rather than queue behind a slow link
const FPS_WINDOW_MS = 2000;
const RECENT_ERROR_MS = 10000;

const pageOptions = new URLSearchParams(location.search);
const requestedRole = pageOptions.get('role') === 'spectator' ? 'spectator' : 'controller';
const codecs = canDecodeH264 ? ['jpeg', 'h264'] : ['jpeg'];

const ui = {
  canvas: document.getElementById('view'),
  status: document.getElementById('status'),
  enterAR: document.getElementById('enter-ar'),
  enterVR: document.getElementById('enter-vr'),
  illumination: document.getElementById('illumination'),
  preset: document.getElementById('preset'),
  cuttingPlane: document.getElementById('cutting-plane'),
  resetPlacement: document.getElementById('reset-placement'),
};

const state = {
  connection: 'connecting',
  retryAt: 0,
  connects: 0,
  welcome: null,
  stats: null,
  rttMs: null,
  framesReceived: 0,
  framesDecoded: 0,
  framesDrawn: 0,
  arrivals: [],            // receive times of recent frames, for the fps display
  // Starts at 1: a server that has no pose yet renders a default view labelled poseId 0. Keeps
  // counting across reconnects, so poseIds never repeat.
  nextPoseId: 1,
  sentPoses: new Map(),    // poseId -> {sentAt, mode, views}, oldest first
  sentPoseCount: 0,
  lastSentPoseId: null,
  lastHead: null,
  newestFrameId: -1,       // newest frame handed to the GPU; older decodes are dropped
  finishedFrameId: -1,     // newest frame acknowledged to the server (flow control)
  frame: null,             // {header, eyes, drawn} of the frame in the textures
  scene: null,             // {illuminationModel, preset, cuttingPlane} of the newest frame
  lastFrame: null,
  drawnPoseIds: [],
  lastDisplayedPoseId: 0,
  panelPresses: [],        // ids of the headset panel's buttons pressed, in order
  lastPoseToDisplayMs: null,
  errors: [],
  errorSeq: 0,
};

function recordError(source, message) {
  state.errors.push({ seq: ++state.errorSeq, source, message: String(message), time: performance.now() });
  if (state.errors.length > ERRORS_KEPT) state.errors.shift();
}
window.addEventListener('error', (event) => recordError('page', event.message));
window.addEventListener('unhandledrejection', (event) => recordError('page', event.reason?.message ?? event.reason));

const gl = ui.canvas.getContext('webgl2', { antialias: false, alpha: true, premultipliedAlpha: true });
if (!gl) recordError('page', 'WebGL2 is not available');
const reprojector = gl ? new Reprojector(gl) : null;
// The status lines inside an immersive session (the DOM is not visible there); `?status=off`
// in the page's URL hides them.
const statusPanel = gl ? new StatusPanel(gl) : null;
let headsetStatusVisible = pageOptions.get('status') !== 'off';
let xrMode = null; // 'immersive-ar' or 'immersive-vr' while a session runs
let cameraMoved = true;
let needsDraw = true;

const isController = () => state.welcome?.role === 'controller' && state.connection === 'connected';

// Connection and messages

const connection = new Connection(protocol.webSocketURL(location), {
  onState(connectionState, detail) {
    state.connection = connectionState;
    state.retryAt = detail.retryAt ?? 0;
    if (connectionState === 'disconnected') {
      state.welcome = null;
      updateControls();
    }
  },
  onOpen() {
    // A restarted server counts frames from scratch, and H.264 must restart at a key frame.
    state.newestFrameId = -1;
    decoder.reset();
    state.finishedFrameId = -1; // after the reset, which finishes the abandoned frames
    connection.send(protocol.hello(requestedRole, codecs));
  },
  onText(text) {
    let message;
    try {
      message = protocol.parseText(text);
    } catch (e) {
      recordError('protocol', e.message);
      return;
    }
    if (message.type === 'welcome') onWelcome(message);
    else if (message.type === 'stats') state.stats = message;
    else if (message.type === 'pong' && Number.isFinite(message.clientTime)) state.rttMs = performance.now() - message.clientTime;
    else if (message.type === 'error') recordError('server', message.reason);
  },
  onBinary(buffer) {
    let frame;
    try {
      frame = protocol.parseFrame(buffer);
    } catch (e) {
      recordError('protocol', e.message);
      return;
    }
    state.framesReceived++;
    const now = performance.now();
    state.arrivals.push(now);
    while (state.arrivals[0] < now - FPS_WINDOW_MS) state.arrivals.shift();
    decoder.push(frame.header, frame.eyes);
  },
});

function onWelcome(welcome) {
  const firstWelcome = state.connects === 0;
  state.welcome = welcome;
  state.connection = 'connected';
  state.connects++;
  connection.established();
  // Turns the server's flow control on before the first frame: it sends no more than a couple
  // of frames ahead of what the decoders have finished.
  connection.send(protocol.decoded(0));
  if (firstWelcome && Array.isArray(welcome.volumeCenter) && Number.isFinite(welcome.volumeRadius)) {
    camera.aimAt(welcome.volumeCenter, welcome.volumeRadius);
  }
  fillSelect(ui.illumination, welcome.illuminationModels, welcome.illuminationModel);
  fillSelect(ui.preset, welcome.presets, welcome.preset);
  cameraMoved = true;
  updateControls();
}

const decoder = new FrameDecoder(({ header, images }) => {
  if (header.frameId <= state.newestFrameId) {
    images.left.close();
    images.right.close();
    return;
  }
  state.newestFrameId = header.frameId;
  const eyes = {};
  for (const e of header.eyes) eyes[e.eye] = { view: e.view, projection: e.projection };
  reprojector?.setFrame(eyes, header.volumeCenter ?? state.welcome?.volumeCenter ?? [0, 0, 0], images);
  images.left.close();
  images.right.close();
  state.framesDecoded++;
  if (header.scene) state.scene = header.scene;
  state.frame = { header, eyes, drawn: false };
  needsDraw = true;
}, (message) => recordError('decode', message), (frameId) => {
  if (frameId <= state.finishedFrameId || state.connection !== 'connected') return;
  state.finishedFrameId = frameId;
  connection.send(protocol.decoded(frameId));
});

setInterval(() => connection.send(protocol.ping(performance.now())), 1000);

function sendInteraction(action, fields) {
  if (isController()) connection.send(protocol.interaction(action, fields));
}

// views: [{eye: 'left', view, projection}, {eye: 'right', ...}]
function sendPose(mode, head, views) {
  if (!isController() || connection.bufferedAmount > MAX_BUFFERED_BYTES) return false;
  const poseId = state.nextPoseId++;
  const message = protocol.pose(poseId, mode, head, views);
  connection.send(message);
  state.sentPoses.set(poseId, { sentAt: performance.now(), mode, views: message.views });
  if (state.sentPoses.size > SENT_POSES_KEPT) state.sentPoses.delete(state.sentPoses.keys().next().value);
  state.sentPoseCount++;
  state.lastSentPoseId = poseId;
  state.lastHead = message.head;
  return true;
}

// Called after the current frame has been drawn; the first time counts as "displayed".
function frameDrawn() {
  const frame = state.frame;
  if (!frame || frame.drawn) return;
  frame.drawn = true;
  const { frameId, poseId, codec } = frame.header;
  state.framesDrawn++;
  state.drawnPoseIds.push(poseId);
  if (state.drawnPoseIds.length > DRAWN_POSE_IDS_KEPT) state.drawnPoseIds.shift();
  state.lastFrame = { frameId, poseId, codec, keyFrame: frame.header.keyFrame, volumeCenter: frame.header.volumeCenter,
    eyes: frame.header.eyes.map(({ eye, view, projection }) => ({ eye, view, projection })) };
  // Only the controller knows when it sent the pose; a spectator has no time to report. A
  // server refining a still view sends several frames for one pose: the first one drawn
  // measures the latency, later ones would only count how long the viewer held still.
  const sent = state.sentPoses.get(poseId);
  if (sent && isController() && poseId > state.lastDisplayedPoseId) {
    state.lastDisplayedPoseId = poseId;
    state.lastPoseToDisplayMs = performance.now() - sent.sentAt;
    connection.send(protocol.displayed(frameId, poseId, state.lastPoseToDisplayMs));
  }
}

// Desktop view: left and right eye side by side

const camera = new OrbitCamera(ui.canvas, () => { cameraMoved = true; needsDraw = true; });

function resizeCanvas() {
  const width = Math.max(2, Math.round(ui.canvas.clientWidth * devicePixelRatio));
  const height = Math.max(1, Math.round(ui.canvas.clientHeight * devicePixelRatio));
  if (ui.canvas.width === width && ui.canvas.height === height) return false;
  ui.canvas.width = width;
  ui.canvas.height = height;
  return true;
}

function desktopFrame() {
  requestAnimationFrame(desktopFrame);
  if (xrMode || !gl) return;
  if (resizeCanvas()) {
    cameraMoved = true;
    needsDraw = true;
  }
  const half = Math.floor(ui.canvas.width / 2);
  const height = ui.canvas.height;
  camera.enabled = isController();
  let views;
  if (isController()) {
    const pose = camera.pose(half / height);
    if (cameraMoved && sendPose('desktop', pose.head, pose.views)) cameraMoved = false;
    views = pose.views;
  } else if (state.frame) {
    // A spectator watches from where the frame was rendered, at its own aspect ratio.
    const projection = camera.projection(half / height);
    views = ['left', 'right'].map((eye) => ({ eye, view: state.frame.eyes[eye].view, projection }));
  }
  if (!needsDraw) return;
  needsDraw = false;
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  gl.viewport(0, 0, ui.canvas.width, height);
  gl.clearColor(0, 0, 0, 0);
  gl.clear(gl.COLOR_BUFFER_BIT);
  if (!views || !reprojector.hasFrame) return;
  reprojector.drawEye('left', { x: 0, y: 0, width: half, height }, views[0].view, views[0].projection);
  reprojector.drawEye('right', { x: half, y: 0, width: half, height }, views[1].view, views[1].projection);
  frameDrawn();
}
requestAnimationFrame(desktopFrame);

// WebXR

async function enterXR(mode) {
  const session = await navigator.xr.requestSession(mode, {
    requiredFeatures: ['local-floor'], optionalFeatures: ['hand-tracking'],
  });
  let referenceSpace;
  try {
    await gl.makeXRCompatible();
    session.updateRenderState({ baseLayer: new XRWebGLLayer(session, gl) });
    referenceSpace = await session.requestReferenceSpace('local-floor');
  } catch (e) {
    await session.end();
    throw e;
  }
  // A select that starts on a panel button presses it instead of grabbing the volume.
  const grab = new GrabTracker(sendInteraction, (event) => pressPanelButton(event, referenceSpace));
  grab.attach(session);
  xrInputSources = () => session.inputSources;
  xrMode = mode;
  statusPanel?.setText(statusText());
  session.addEventListener('end', () => {
    grab.end();
    xrMode = null;
    cameraMoved = true;
    needsDraw = true;
  });
  const onFrame = (time, frame) => {
    session.requestAnimationFrame(onFrame);
    drawXRFrame(time, frame, mode, referenceSpace, grab);
  };
  session.requestAnimationFrame(onFrame);
}

// The protocol wants exactly a left and a right view; a mono device sends its one view twice.
function stereoViews(views) {
  const left = views.find((v) => v.eye === 'left') ?? views[0];
  const right = views.find((v) => v.eye === 'right') ?? left;
  return [left, right].map((v, i) => ({
    eye: i ? 'right' : 'left', view: v.transform.inverse.matrix, projection: v.projectionMatrix,
  }));
}

function drawXRFrame(time, frame, mode, referenceSpace, grab) {
  const viewerPose = frame.getViewerPose(referenceSpace);
  if (!viewerPose) return;
  sendPose(mode, viewerPose.transform.matrix, stereoViews(viewerPose.views));
  if (isController()) grab.update(frame, referenceSpace);
  const layer = frame.session.renderState.baseLayer;
  gl.bindFramebuffer(gl.FRAMEBUFFER, layer.framebuffer);
  gl.clearColor(0, 0, 0, 0);
  gl.clear(gl.COLOR_BUFFER_BIT);
  if (reprojector.hasFrame) {
    for (const view of viewerPose.views) {
      reprojector.drawEye(view.eye === 'right' ? 'right' : 'left', layer.getViewport(view),
        view.transform.inverse.matrix, view.projectionMatrix);
    }
  }
  // Also before the first frame: "connecting" is worth seeing in the headset.
  if (headsetStatusVisible && statusPanel) {
    statusPanel.follow(viewerPose.transform.matrix, time);
    statusPanel.setControls(panelButtons(), hoveredButton(frame, referenceSpace));
    for (const view of viewerPose.views) {
      statusPanel.draw(layer.getViewport(view), multiply(view.projectionMatrix, view.transform.inverse.matrix));
    }
  }
  if (reprojector.hasFrame) frameDrawn();
}

async function offerXR(button, mode) {
  if (!gl || !navigator.xr || !(await navigator.xr.isSessionSupported(mode).catch(() => false))) return;
  button.hidden = false;
  button.addEventListener('click', () => enterXR(mode).catch((e) => recordError('xr', `${mode}: ${e.message}`)));
}
offerXR(ui.enterAR, 'immersive-ar');
offerXR(ui.enterVR, 'immersive-vr');

// Controls: the page's own (desktop), and the same on the headset status panel

let xrInputSources = () => [];

// The scene as the newest frame shows it (the server's state), or as the welcome announced it.
function currentScene() {
  return {
    illuminationModel: state.scene?.illuminationModel ?? state.welcome?.illuminationModel,
    preset: state.scene?.preset ?? state.welcome?.preset,
    cuttingPlane: state.scene?.cuttingPlane ?? ui.cuttingPlane.checked,
  };
}

const nextOf = (values, current) => (Array.isArray(values) && values.length
  ? values[(values.indexOf(current) + 1) % values.length] : null);

function panelButtons() {
  const enabled = isController();
  const scene = currentScene();
  return [
    { id: 'illumination', label: `Light: ${scene.illuminationModel ?? '–'}`, enabled },
    { id: 'preset', label: `Preset: ${scene.preset ?? '–'}`, enabled },
    { id: 'cutting-plane', label: `Cut: ${scene.cuttingPlane ? 'on' : 'off'}`, enabled },
    { id: 'reset-placement', label: 'Reset placement', enabled },
  ];
}

// The target ray of an input source: its origin and −Z axis (WebXR's pointing direction).
function targetRay(frame, inputSource, referenceSpace) {
  const pose = frame.getPose(inputSource.targetRaySpace, referenceSpace);
  if (!pose) return null;
  const m = pose.transform.matrix;
  return { origin: [m[12], m[13], m[14]], direction: normalize([-m[8], -m[9], -m[10]]) };
}

function hoveredButton(frame, referenceSpace) {
  for (const inputSource of xrInputSources()) {
    const ray = targetRay(frame, inputSource, referenceSpace);
    const id = ray && statusPanel.buttonAt(ray.origin, ray.direction);
    if (id) return id;
  }
  return null;
}

// Called on selectstart: presses the panel button the input's ray points at, if any.
function pressPanelButton(event, referenceSpace) {
  if (!headsetStatusVisible || !statusPanel || !isController()) return false;
  const ray = targetRay(event.frame, event.inputSource, referenceSpace);
  const id = ray && statusPanel.buttonAt(ray.origin, ray.direction);
  if (!id) return false;
  const scene = currentScene();
  if (id === 'illumination') {
    const model = nextOf(state.welcome?.illuminationModels, scene.illuminationModel);
    if (model) selectControl(ui.illumination, model);
  } else if (id === 'preset') {
    const preset = nextOf(state.welcome?.presets, scene.preset);
    if (preset) selectControl(ui.preset, preset);
  } else if (id === 'cutting-plane') {
    ui.cuttingPlane.checked = !scene.cuttingPlane;
    ui.cuttingPlane.dispatchEvent(new Event('change'));
  } else if (id === 'reset-placement') {
    ui.resetPlacement.click();
  }
  state.panelPresses.push(id);
  return true;
}

// The DOM control stays the one place that sends the interaction.
function selectControl(select, value) {
  select.value = value;
  select.dispatchEvent(new Event('change'));
}

function fillSelect(select, values, current) {
  if (!Array.isArray(values)) return;
  select.replaceChildren(...values.map((value) => new Option(value, value, false, value === current)));
}

function volumeCenter() {
  return state.frame?.header.volumeCenter ?? state.welcome?.volumeCenter;
}

ui.illumination.addEventListener('change', () => sendInteraction('illumination', { model: ui.illumination.value }));
ui.preset.addEventListener('change', () => sendInteraction('transfer-function', { preset: ui.preset.value }));
ui.resetPlacement.addEventListener('click', () => sendInteraction('reset-placement'));
ui.cuttingPlane.addEventListener('change', () => {
  const center = volumeCenter();
  if (!ui.cuttingPlane.checked || !center || !state.lastHead) {
    ui.cuttingPlane.checked = false;
    sendInteraction('cutting-plane', { enabled: false });
    return;
  }
  // The normal points away from the viewer: the far half is kept, so the cut face is in view.
  const normal = normalize(sub(center, getTranslation(state.lastHead)));
  sendInteraction('cutting-plane', { enabled: true, origin: center, normal });
});

function updateControls() {
  const enabled = isController();
  for (const control of [ui.illumination, ui.preset, ui.cuttingPlane, ui.resetPlacement]) control.disabled = !enabled;
}
updateControls();

// Status overlay

const fmt = (value, digits = 0) => (Number.isFinite(value) ? value.toFixed(digits) : '–');

function statusText() {
  const now = performance.now();
  const connectionLine = state.connection === 'disconnected'
    ? `disconnected, retrying in ${fmt(Math.max(0, state.retryAt - now) / 1000, 1)} s`
    : state.connection;
  const welcome = state.welcome;
  const stats = state.stats ?? {};
  const recent = state.arrivals.filter((t) => t > now - FPS_WINDOW_MS).length;
  const poseToDisplay = welcome?.role === 'controller' ? state.lastPoseToDisplayMs : stats.poseToDisplayMs;
  // A recent error only: in a headset a stale one would stay in view for the whole session.
  const lastError = state.errors.findLast((e) => e.time > now - RECENT_ERROR_MS);
  return [
    `${connectionLine} · ${welcome?.role ?? requestedRole} · ${welcome?.codec ?? '–'} · ${xrMode ?? 'desktop'}`,
    `frames ${fmt((recent * 1000) / FPS_WINDOW_MS, 1)} fps · pose-to-display ${fmt(poseToDisplay)} ms · rtt ${fmt(state.rttMs)} ms`,
    `server render ${fmt(stats.renderMs)} · denoise ${fmt(stats.denoiseMs)} · encode ${fmt(stats.encodeMs)} · send ${fmt(stats.sendMs, 1)} ms`,
    `dropped ${fmt(stats.droppedFrames)} · clients ${fmt(stats.clients)}`,
    ...(lastError ? [`last error (${lastError.source}): ${lastError.message}`] : []),
  ].join('\n');
}
setInterval(() => {
  const text = statusText();
  ui.status.textContent = text;
  if (xrMode) statusPanel?.setText(text);
}, 250);

// Read-only mirrors for tests and debugging: every value is a copy of the player's own state.

const copy = (value) => (value == null ? null : structuredClone(value));
Object.defineProperty(window, 'holovolumePlayer', {
  value: Object.freeze({
    get state() { return state.connection; },
    get requestedRole() { return requestedRole; },
    get role() { return state.welcome?.role ?? null; },
    get codec() { return state.welcome?.codec ?? null; },
    get mode() { return xrMode ?? 'desktop'; },
    get connects() { return state.connects; },
    get welcome() { return copy(state.welcome); },
    get stats() { return copy(state.stats); },
    get rttMs() { return state.rttMs; },
    get framesReceived() { return state.framesReceived; },
    get framesDecoded() { return state.framesDecoded; },
    get framesDrawn() { return state.framesDrawn; },
    get framesSkippedWaitingForKey() { return decoder.skippedWaitingForKey; },
    get lastFrame() { return copy(state.lastFrame); },
    get drawnPoseIds() { return state.drawnPoseIds.slice(); },
    get sentPoseIds() { return state.sentPoseCount; },
    get lastSentPoseId() { return state.lastSentPoseId; },
    get lastPoseToDisplayMs() { return state.lastPoseToDisplayMs; },
    get errors() { return copy(state.errors); },
    // The pose message sent with this poseId ({sentAt, mode, views}), while still kept.
    sentPose(poseId) { return copy(state.sentPoses.get(poseId)); },
    // The status panel drawn in the headset: {visible, text, position (world, m)}.
    get headsetStatus() {
      return { visible: headsetStatusVisible, text: statusPanel?.text ?? null, position: copy(statusPanel?.position) };
    },
    showHeadsetStatus(visible) { headsetStatusVisible = Boolean(visible); },
    get headsetButtons() { return statusPanel ? copy(statusPanel.buttonCenters()) : []; },
    get hoveredHeadsetButton() { return statusPanel?.hovered ?? null; },
    get panelPresses() { return state.panelPresses.slice(); },
    get scene() { return copy(state.scene); },
    // Sends raw text on the socket, to test the server's answer to malformed messages.
    debugSend(text) { return connection.sendText(String(text)); },
  }),
});

connection.start();
