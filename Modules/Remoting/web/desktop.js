// Desktop fallback camera: a stereo pair orbiting the volume centre.
// Mouse drag orbits, the wheel changes the distance. Views follow the WebXR conventions so the
// server and the reprojection treat them exactly like headset views.

import { invert, multiply, perspective, poseLookingAt, translation } from './mat4.js';

const HALF_IPD = 0.032;
const FOVY = (60 * Math.PI) / 180;
const NEAR = 0.01;
const FAR = 100;
const RADIANS_PER_PIXEL = 0.005;

export class OrbitCamera {
  // onChange() is called whenever user input moved the camera.
  constructor(element, onChange) {
    this.onChange = onChange;
    this.target = [0, 0, 0];
    this.radius = 0.1;
    this.distance = 0.3;
    this.yaw = 0;
    this.pitch = 0;
    this.enabled = false;
    this.dragging = null;

    element.addEventListener('pointerdown', (event) => {
      if (!this.enabled || event.button !== 0) return;
      element.setPointerCapture(event.pointerId);
      this.dragging = { x: event.clientX, y: event.clientY };
    });
    element.addEventListener('pointermove', (event) => {
      if (!this.dragging) return;
      this.yaw -= (event.clientX - this.dragging.x) * RADIANS_PER_PIXEL;
      this.pitch = clamp(this.pitch + (event.clientY - this.dragging.y) * RADIANS_PER_PIXEL, -1.5, 1.5);
      this.dragging = { x: event.clientX, y: event.clientY };
      this.onChange();
    });
    const endDrag = () => { this.dragging = null; };
    element.addEventListener('pointerup', endDrag);
    element.addEventListener('pointercancel', endDrag);
    element.addEventListener('wheel', (event) => {
      if (!this.enabled) return;
      event.preventDefault();
      this.distance = clamp(this.distance * Math.exp(event.deltaY * 0.001), 1.2 * this.radius, 30 * this.radius);
      this.onChange();
    }, { passive: false });
  }

  // Starts in front of the volume (on its +Z side), looking along −Z like a headset user at the origin.
  aimAt(center, radius) {
    this.target = center.slice();
    this.radius = radius;
    this.distance = 3 * radius;
    this.yaw = 0;
    this.pitch = 0;
  }

  // Symmetric projection for an eye viewport of aspect width/height.
  projection(aspect) {
    return perspective(FOVY, aspect, NEAR, FAR);
  }

  // Returns {head, views: [{eye, view, projection}]} for eyes of aspect width/height each.
  pose(aspect) {
    const c = Math.cos(this.pitch);
    const offset = [c * Math.sin(this.yaw), Math.sin(this.pitch), c * Math.cos(this.yaw)];
    const position = offset.map((o, i) => this.target[i] + this.distance * o);
    const head = poseLookingAt(position, this.target);
    const projection = this.projection(aspect);
    const eyeView = (dx) => invert(multiply(head, translation(dx, 0, 0)));
    return {
      head,
      views: [
        { eye: 'left', view: eyeView(-HALF_IPD), projection },
        { eye: 'right', view: eyeView(HALF_IPD), projection },
      ],
    };
  }
}

const clamp = (value, low, high) => Math.min(high, Math.max(low, value));
