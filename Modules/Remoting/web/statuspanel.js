// The connection and latency status inside an immersive session, where the page's DOM is not
// visible: the same lines as the desktop overlay, drawn on a small panel in the world, above a
// row of buttons for what the page's controls do (illumination model, transfer-function preset,
// cutting plane, reset placement), pressed with a hand ray or controller (air tap / trigger).
//
// Placement: not rigidly head-locked (uncomfortable, and it swims against the hologram) but
// "tag-along": the panel eases toward a point above the line of sight 1.25 m ahead and turns
// to face the viewer. 1.25 m is the near end of the zone Microsoft's comfort guidance gives as
// optimal for hologram placement, 1.25–5 m (learn.microsoft.com/windows/mixed-reality/design/
// comfort). The panel spans about 5°–13° above the gaze, inside the HoloLens 2's vertical field
// of view (about 29°), so it stays readable without covering the volume the user looks at.

import { createImageTexture, createProgram } from './glprogram.js';
import { add, cross, dot, getTranslation, length, normalize, scale, sub } from './mat4.js';

const PANEL_WIDTH_M = 0.40;
const DISTANCE_M = 1.25;
const RISE_M = 0.2;             // along the head's up axis
const FOLLOW_TIME_S = 0.25;     // exponential easing time constant
const SNAP_DISTANCE_M = 1.0;    // farther than this from its target (e.g. after a teleport): jump
const CANVAS_WIDTH = 1024;
const TEXT_HEIGHT = 256;
const BUTTON_ROW_HEIGHT = 112;
const CANVAS_HEIGHT = TEXT_HEIGHT + BUTTON_ROW_HEIGHT;
const PANEL_HEIGHT_M = (PANEL_WIDTH_M * CANVAS_HEIGHT) / CANVAS_WIDTH; // square texels: 0.1575 m
const BUTTON_MARGIN = 10;

const VERTEX_SHADER = `#version 300 es
uniform mat4 uWorldToClip;
uniform mat4 uPanelToWorld;
out vec2 vUv;
void main() {
  // A triangle strip over the unit square: (0,0), (1,0), (0,1), (1,1).
  vec2 corner = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1));
  vUv = corner;
  gl_Position = uWorldToClip * uPanelToWorld * vec4(corner - 0.5, 0.0, 1.0);
}`;

const FRAGMENT_SHADER = `#version 300 es
precision mediump float;
uniform sampler2D uPanel;
in vec2 vUv;
out vec4 outColor;
void main() {
  // The canvas is uploaded top row first and premultiplied.
  outColor = texture(uPanel, vec2(vUv.x, 1.0 - vUv.y));
}`;

export class StatusPanel {
  constructor(gl) {
    this.gl = gl;
    ({ program: this.program, uniforms: this.uniforms } = createProgram(gl, VERTEX_SHADER, FRAGMENT_SHADER,
      ['uWorldToClip', 'uPanelToWorld', 'uPanel']));
    this.vertexArray = gl.createVertexArray();
    this.texture = createImageTexture(gl);
    this.canvas = new OffscreenCanvas(CANVAS_WIDTH, CANVAS_HEIGHT);
    this.context = this.canvas.getContext('2d');
    this.text = null;
    this.buttons = [];      // [{id, label, enabled}] left to right
    this.hovered = null;    // id of the button a ray points at
    this.drawn = null;      // what the texture shows
    this.position = null;   // world, metres
    this.axes = null;       // the panel's unit x (right), y (up), z (toward the viewer)
    this.lastTime = null;
    this.panelToWorld = null;
  }

  // The status lines (updated on the page's status timer, a few times a second).
  setText(text) {
    this.text = text;
    this.redraw();
  }

  // Per XR frame. buttons: [{id, label, enabled}], left to right; hovered: the id of the
  // button under a ray (or null), drawn highlighted so the user sees what an air tap would press.
  setControls(buttons, hovered) {
    this.buttons = buttons;
    this.hovered = hovered;
    this.redraw();
  }

  buttonRect(index) {
    const width = CANVAS_WIDTH / Math.max(1, this.buttons.length);
    return { x: index * width + BUTTON_MARGIN, y: TEXT_HEIGHT + BUTTON_MARGIN,
      width: width - 2 * BUTTON_MARGIN, height: BUTTON_ROW_HEIGHT - 2 * BUTTON_MARGIN };
  }

  // Redraws the texture only when what it shows changed.
  redraw() {
    if (this.text === null) return;
    const key = JSON.stringify([this.text, this.buttons, this.hovered]);
    if (key === this.drawn) return;
    this.drawn = key;
    const c = this.context;
    c.clearRect(0, 0, CANVAS_WIDTH, CANVAS_HEIGHT);
    // A dark translucent backing keeps the text legible on an opaque (VR) display; on the
    // HoloLens' additive display dark is transparent and only the text shows.
    c.fillStyle = 'rgba(0, 0, 0, 0.55)';
    c.fillRect(0, 0, CANVAS_WIDTH, TEXT_HEIGHT);
    const lines = this.text.split('\n');
    const lineHeight = Math.floor((TEXT_HEIGHT - 16) / Math.max(4, lines.length));
    c.font = `${Math.floor(lineHeight * 0.78)}px sans-serif`;
    c.textBaseline = 'top';
    c.fillStyle = '#e8f4ff';
    lines.forEach((line, i) => c.fillText(line, 14, 8 + i * lineHeight, CANVAS_WIDTH - 28));
    c.font = '34px sans-serif';
    c.textAlign = 'center';
    c.textBaseline = 'middle';
    this.buttons.forEach((button, i) => {
      const r = this.buttonRect(i);
      const hovered = button.enabled && button.id === this.hovered;
      c.fillStyle = hovered ? 'rgba(90, 160, 255, 0.85)' : 'rgba(40, 60, 90, 0.75)';
      c.fillRect(r.x, r.y, r.width, r.height);
      c.strokeStyle = hovered ? '#ffffff' : '#8fb8e8';
      c.lineWidth = hovered ? 5 : 2;
      c.strokeRect(r.x, r.y, r.width, r.height);
      c.fillStyle = button.enabled ? '#ffffff' : '#7f8c99';
      c.fillText(button.label, r.x + r.width / 2, r.y + r.height / 2, r.width - 16);
    });
    c.textAlign = 'start';
    const gl = this.gl;
    gl.bindTexture(gl.TEXTURE_2D, this.texture);
    gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
    gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, true);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA, gl.RGBA, gl.UNSIGNED_BYTE, this.canvas);
    gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
  }

  // Moves the panel toward its place for this head pose (`head`: world from head, column-major;
  // `timeMs`: the XR frame time).
  follow(head, timeMs) {
    const headPosition = getTranslation(head);
    const up = normalize([head[4], head[5], head[6]]);
    const forward = normalize([-head[8], -head[9], -head[10]]);
    const target = add(headPosition, add(scale(forward, DISTANCE_M), scale(up, RISE_M)));
    const dt = this.lastTime === null ? Infinity : Math.max(0, (timeMs - this.lastTime) / 1000);
    this.lastTime = timeMs;
    const away = this.position ? sub(target, this.position) : null;
    if (!away || length(away) > SNAP_DISTANCE_M || !Number.isFinite(dt)) {
      this.position = target;
    } else {
      this.position = add(this.position, scale(away, 1 - Math.exp(-dt / FOLLOW_TIME_S)));
    }
    // Upright (world +Y), facing the viewer: its +Z points at the head.
    const toHead = sub(headPosition, this.position);
    const z = normalize(Math.hypot(toHead[0], toHead[2]) > 1e-6 ? [toHead[0], 0, toHead[2]] : [0, 0, 1]);
    const x = normalize(cross([0, 1, 0], z));
    const y = cross(z, x);
    this.axes = { x, y, z };
    const [w, h, p] = [PANEL_WIDTH_M, PANEL_HEIGHT_M, this.position];
    this.panelToWorld = new Float32Array([
      x[0] * w, x[1] * w, x[2] * w, 0, y[0] * h, y[1] * h, y[2] * h, 0, z[0], z[1], z[2], 0, p[0], p[1], p[2], 1]);
  }

  // World position of a canvas point (pixels, top left origin) on the panel as last placed.
  worldPoint(px, py) {
    const { x, y } = this.axes;
    const u = (px / CANVAS_WIDTH - 0.5) * PANEL_WIDTH_M;
    const v = (0.5 - py / CANVAS_HEIGHT) * PANEL_HEIGHT_M;
    return add(this.position, add(scale(x, u), scale(y, v)));
  }

  // Where each button is, in the world (for tests and debugging).
  buttonCenters() {
    if (!this.axes) return [];
    return this.buttons.map((button, i) => {
      const r = this.buttonRect(i);
      return { id: button.id, label: button.label, enabled: button.enabled,
        center: this.worldPoint(r.x + r.width / 2, r.y + r.height / 2) };
    });
  }

  // The enabled button a ray (world origin, direction) hits, or null: the ray meets the
  // panel's plane in front of its origin, inside a button's rectangle.
  buttonAt(origin, direction) {
    if (!this.axes || !this.buttons.length) return null;
    const { x, y, z } = this.axes;
    const denominator = dot(direction, z);
    if (Math.abs(denominator) < 1e-6) return null;
    const t = dot(sub(this.position, origin), z) / denominator;
    if (t <= 0) return null;
    const offset = sub(add(origin, scale(direction, t)), this.position);
    const px = (dot(offset, x) / PANEL_WIDTH_M + 0.5) * CANVAS_WIDTH;
    const py = (0.5 - dot(offset, y) / PANEL_HEIGHT_M) * CANVAS_HEIGHT;
    const index = this.buttons.findIndex((button, i) => {
      const r = this.buttonRect(i);
      return button.enabled && px >= r.x && px <= r.x + r.width && py >= r.y && py <= r.y + r.height;
    });
    return index < 0 ? null : this.buttons[index].id;
  }

  // Draws the panel into the bound framebuffer's `viewport` for one eye (`worldToClip`:
  // that eye's projection·view), blended over what is there (premultiplied alpha).
  draw(viewport, worldToClip) {
    if (this.text === null || !this.panelToWorld) return;
    const gl = this.gl;
    gl.viewport(viewport.x, viewport.y, viewport.width, viewport.height);
    gl.useProgram(this.program);
    gl.bindVertexArray(this.vertexArray);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, this.texture);
    gl.uniform1i(this.uniforms.uPanel, 0);
    gl.uniformMatrix4fv(this.uniforms.uWorldToClip, false, new Float32Array(worldToClip));
    gl.uniformMatrix4fv(this.uniforms.uPanelToWorld, false, this.panelToWorld);
    gl.enable(gl.BLEND);
    gl.blendFunc(gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
    gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
    gl.disable(gl.BLEND);
  }
}
