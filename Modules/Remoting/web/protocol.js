// HoloVolume remoting protocol, version 1 (Documentation/RemotingProtocol.md):
// building the client's text messages and parsing the server's "HVF1" binary frames.

export const PROTOCOL_VERSION = 1;
const CLIENT_NAME = 'holovolume-player/1';
const FRAME_MAGIC = 'HVF1';

// The socket is on the page's own origin; the token comes from the page's own URL. Without one
// (page opened through the cookie alone) the upgrade request carries the cookie instead.
export function webSocketURL(location) {
  const url = new URL('/ws', location.href);
  url.protocol = location.protocol === 'https:' ? 'wss:' : 'ws:';
  const token = new URLSearchParams(location.search).get('token');
  if (token) url.searchParams.set('token', token);
  return url.href;
}

export const hello = (role, codecs) =>
  ({ type: 'hello', protocol: PROTOCOL_VERSION, role, client: CLIENT_NAME, codecs });

// views: [{eye: 'left'|'right', view: [16], projection: [16]}, ...] in that order.
export const pose = (poseId, mode, head, views) =>
  ({ type: 'pose', poseId, mode, head: Array.from(head),
    views: views.map((v) => ({ eye: v.eye, view: Array.from(v.view), projection: Array.from(v.projection) })) });

export const interaction = (action, fields = {}) => ({ type: 'interaction', action, ...fields });

export const displayed = (frameId, poseId, poseToDisplayMs) =>
  ({ type: 'displayed', frameId, poseId, poseToDisplayMs });

// Flow control: every frame up to frameId is decoded or dropped (cumulative).
export const decoded = (frameId) => ({ type: 'decoded', frameId });

export const ping = (clientTime) => ({ type: 'ping', clientTime });

// Returns the message object, or throws when it is not a JSON object with a string `type`.
export function parseText(text) {
  const message = JSON.parse(text);
  if (!message || typeof message !== 'object' || typeof message.type !== 'string') {
    throw new Error('server message without a type');
  }
  return message;
}

const isMatrix = (m) => Array.isArray(m) && m.length === 16 && m.every(Number.isFinite);

// Returns {header, eyes: {left, right}} where each eye is {view, projection, data: Uint8Array}
// (a view into `buffer`), or throws with the reason the frame is unusable.
export function parseFrame(buffer) {
  const bytes = new Uint8Array(buffer);
  if (bytes.length < 8 || String.fromCharCode(...bytes.subarray(0, 4)) !== FRAME_MAGIC) {
    throw new Error('frame: bad magic');
  }
  const headerLength = new DataView(buffer).getUint32(4, true);
  if (8 + headerLength > bytes.length) throw new Error('frame: header runs past the message');
  const header = JSON.parse(new TextDecoder().decode(bytes.subarray(8, 8 + headerLength)));
  if (!Number.isInteger(header.frameId) || !Array.isArray(header.eyes)) {
    throw new Error('frame: header lacks frameId or eyes');
  }
  const payloadStart = 8 + headerLength;
  const eyes = {};
  for (const eye of header.eyes) {
    if ((eye.eye !== 'left' && eye.eye !== 'right') || !isMatrix(eye.view) || !isMatrix(eye.projection)) {
      throw new Error('frame: bad eye entry');
    }
    const { offset, length } = eye;
    if (!Number.isInteger(offset) || !Number.isInteger(length) || offset < 0 || length <= 0 ||
        payloadStart + offset + length > bytes.length) {
      throw new Error(`frame: ${eye.eye} payload out of range`);
    }
    eyes[eye.eye] = { view: eye.view, projection: eye.projection,
      data: bytes.subarray(payloadStart + offset, payloadStart + offset + length) };
  }
  if (!eyes.left || !eyes.right) throw new Error('frame: needs a left and a right eye');
  if (header.volumeCenter !== undefined &&
      !(Array.isArray(header.volumeCenter) && header.volumeCenter.length === 3 && header.volumeCenter.every(Number.isFinite))) {
    throw new Error('frame: bad volumeCenter');
  }
  return { header, eyes };
}
