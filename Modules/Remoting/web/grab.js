// Grabbing the volume with XR input sources (controllers or tracked hands).
// select or squeeze held on an input source grabs. Each frame, while something grabs, the
// transform from the grabbing pose(s) at grab start to now is sent as `grab-move`:
// one input: T_now · T_start⁻¹; two inputs: the midpoint's translation, the rotation of the
// line between them and the ratio of their distances as uniform scale.
// When the set of grabbing inputs changes (second hand joins, one lets go) the grab is ended
// and restarted with the new set, so the server re-bases its placement on the current one.

import {
  add, getTranslation, invert, length, multiply, normalize, rotationBetween, scale, scaling, sub, translation,
} from './mat4.js';

export class GrabTracker {
  // sendInteraction(action, fields) sends an `interaction` message. claimSelect(event), if
  // given, is asked on each selectstart; when it returns true (the select pressed a button)
  // that select does not grab.
  constructor(sendInteraction, claimSelect = () => false) {
    this.sendInteraction = sendInteraction;
    this.claimSelect = claimSelect;
    this.claimed = new Set(); // input sources whose current select pressed a button
    this.held = new Map(); // inputSource -> Set of 'select' / 'squeeze' being held
    this.grabbing = [];    // input sources of the current grab, with start poses, or empty
  }

  attach(session) {
    const press = (kind) => (event) => {
      if (kind === 'select' && this.claimSelect(event)) {
        this.claimed.add(event.inputSource);
        return;
      }
      if (!this.held.has(event.inputSource)) this.held.set(event.inputSource, new Set());
      this.held.get(event.inputSource).add(kind);
    };
    const release = (kind) => (event) => {
      if (kind === 'select' && this.claimed.delete(event.inputSource)) return;
      const kinds = this.held.get(event.inputSource);
      kinds?.delete(kind);
      if (kinds && kinds.size === 0) this.held.delete(event.inputSource);
    };
    session.addEventListener('selectstart', press('select'));
    session.addEventListener('squeezestart', press('squeeze'));
    session.addEventListener('selectend', release('select'));
    session.addEventListener('squeezeend', release('squeeze'));
    session.addEventListener('inputsourceschange', (event) => {
      for (const source of event.removed) {
        this.held.delete(source);
        this.claimed.delete(source);
      }
    });
  }

  // Called once per XR frame. At most two inputs grab (the first two that were pressed).
  update(frame, referenceSpace) {
    const poseOf = (source) => {
      const pose = frame.getPose(source.gripSpace ?? source.targetRaySpace, referenceSpace);
      return pose ? Array.from(pose.transform.matrix) : null;
    };
    const wanted = [...this.held.keys()].slice(0, 2);
    const same = wanted.length === this.grabbing.length && wanted.every((s, i) => s === this.grabbing[i].source);
    if (!same) {
      if (this.grabbing.length) this.sendInteraction('grab-end');
      this.grabbing = [];
      const starts = wanted.map(poseOf);
      // Start only once every grabbing input is tracked; otherwise try again next frame.
      if (wanted.length && starts.every(Boolean)) {
        this.grabbing = wanted.map((source, i) => ({ source, start: starts[i] }));
        this.sendInteraction('grab-start');
      }
      return;
    }
    if (!this.grabbing.length) return;
    const now = this.grabbing.map((g) => poseOf(g.source));
    if (!now.every(Boolean)) return;
    const transform = this.grabbing.length === 1
      ? multiply(now[0], invert(this.grabbing[0].start))
      : twoHandTransform(this.grabbing.map((g) => g.start), now);
    if (transform) this.sendInteraction('grab-move', { transform });
  }

  end() {
    if (this.grabbing.length) this.sendInteraction('grab-end');
    this.grabbing = [];
    this.held.clear();
    this.claimed.clear();
  }
}

// T = translate(midNow) · rotation(lineStart → lineNow) · scale(|lineNow| / |lineStart|) · translate(−midStart)
function twoHandTransform(start, now) {
  const [a0, b0] = start.map(getTranslation);
  const [a1, b1] = now.map(getTranslation);
  const line0 = sub(b0, a0);
  const line1 = sub(b1, a1);
  if (length(line0) < 1e-4 || length(line1) < 1e-4) return null;
  const mid0 = scale(add(a0, b0), 0.5);
  const mid1 = scale(add(a1, b1), 0.5);
  const rotationAndScale = multiply(rotationBetween(normalize(line0), normalize(line1)), scaling(length(line1) / length(line0)));
  return multiply(translation(...mid1), multiply(rotationAndScale, translation(...scale(mid0, -1))));
}
