// Draws a received eye image for the viewer's current eye pose (WebGL2).
// A frame rendered for an older pose is warped through one plane: the plane through the
// volume centre whose normal is the rendered eye's view direction. For each output pixel the
// current eye's ray is intersected with that plane and the hit point is projected with the
// rendered eye's projection·view to find the texel. With identical matrices every hit point
// projects back onto its own pixel, so the plain image comes out.

import { createImageTexture, createProgram } from './glprogram.js';
import { invert, multiply, normalize } from './mat4.js';

const VERTEX_SHADER = `#version 300 es
out vec2 vNdc;
void main() {
  // One triangle covering the viewport: (-1,-1), (3,-1), (-1,3).
  vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
  vNdc = p;
  gl_Position = vec4(p, 0.0, 1.0);
}`;

const FRAGMENT_SHADER = `#version 300 es
precision highp float;
uniform sampler2D uImage;
uniform mat4 uCurrentClipToWorld;  // inverse(projection · view) of the eye being drawn
uniform mat4 uFrameWorldToClip;    // projection · view the image was rendered with
uniform vec3 uPlanePoint;
uniform vec3 uPlaneNormal;
in vec2 vNdc;
out vec4 outColor;

void main() {
  // Two points of this pixel's ray: on the near plane (z=-1) and at clip depth 0. Clip depth 0
  // stays finite with an infinite far plane, where z=+1 would not.
  vec4 a = uCurrentClipToWorld * vec4(vNdc, -1.0, 1.0);
  vec4 b = uCurrentClipToWorld * vec4(vNdc, 0.0, 1.0);
  vec3 origin = a.xyz / a.w;
  vec3 direction = b.xyz / b.w - origin;
  float denominator = dot(direction, uPlaneNormal);
  float t = dot(uPlanePoint - origin, uPlaneNormal) / denominator;
  vec4 clip = uFrameWorldToClip * vec4(origin + t * direction, 1.0);
  vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
  bool inside = abs(denominator) > 1e-9 && t >= 0.0 && clip.w > 0.0 &&
                all(greaterThanEqual(uv, vec2(0.0))) && all(lessThanEqual(uv, vec2(1.0)));
  if (!inside) {
    outColor = vec4(0.0);
    return;
  }
  // Images are stored top row first: texture row 0 is the top of the picture.
  vec3 color = texture(uImage, vec2(uv.x, 1.0 - uv.y)).rgb;
  // Black is "no volume": with premultiplied alpha this composites additively over whatever
  // is behind (camera image on pass-through devices, page on desktop); opaque/additive
  // displays ignore alpha.
  outColor = vec4(color, max(color.r, max(color.g, color.b)));
}`;

export class Reprojector {
  constructor(gl) {
    this.gl = gl;
    ({ program: this.program, uniforms: this.uniforms } = createProgram(gl, VERTEX_SHADER, FRAGMENT_SHADER,
      ['uImage', 'uCurrentClipToWorld', 'uFrameWorldToClip', 'uPlanePoint', 'uPlaneNormal']));
    this.vertexArray = gl.createVertexArray();
    this.eyes = {};
    for (const eye of ['left', 'right']) {
      this.eyes[eye] = { texture: createImageTexture(gl), worldToClip: null, planeNormal: null };
    }
    this.planePoint = null;
  }

  get hasFrame() {
    return this.planePoint !== null;
  }

  // eyes: {left: {view, projection}, right: ...}, the matrices the images were rendered with;
  // planePoint: the volume centre (world); images: {left, right} (ImageBitmap or VideoFrame,
  // top row first), which the caller closes afterwards.
  setFrame(eyes, planePoint, images) {
    const gl = this.gl;
    gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
    gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
    for (const eye of ['left', 'right']) {
      const target = this.eyes[eye];
      gl.bindTexture(gl.TEXTURE_2D, target.texture);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA, gl.RGBA, gl.UNSIGNED_BYTE, images[eye]);
      const { view, projection } = eyes[eye];
      target.worldToClip = new Float32Array(multiply(projection, view));
      // The eye looks along its −Z; in world coordinates that axis is the view matrix's third row.
      target.planeNormal = new Float32Array(normalize([view[2], view[6], view[10]]));
    }
    this.planePoint = new Float32Array(planePoint);
  }

  // Draws `eye`'s image into viewport {x, y, width, height} of the bound framebuffer for an eye
  // now at `view`/`projection`. Pixels outside the warped image are left transparent black.
  drawEye(eye, viewport, view, projection) {
    if (!this.hasFrame) return;
    const clipToWorld = invert(multiply(projection, view));
    if (!clipToWorld) return;
    const gl = this.gl;
    const source = this.eyes[eye];
    gl.viewport(viewport.x, viewport.y, viewport.width, viewport.height);
    gl.useProgram(this.program);
    gl.bindVertexArray(this.vertexArray);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, source.texture);
    gl.uniform1i(this.uniforms.uImage, 0);
    gl.uniformMatrix4fv(this.uniforms.uCurrentClipToWorld, false, new Float32Array(clipToWorld));
    gl.uniformMatrix4fv(this.uniforms.uFrameWorldToClip, false, source.worldToClip);
    gl.uniform3fv(this.uniforms.uPlanePoint, this.planePoint);
    gl.uniform3fv(this.uniforms.uPlaneNormal, source.planeNormal);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }
}
