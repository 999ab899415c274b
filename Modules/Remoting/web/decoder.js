// Turns parsed frames into per-eye images that WebGL can upload: ImageBitmap for JPEG,
// VideoFrame for H.264 (one VideoDecoder per eye, since each eye is its own stream).
// Decoding is asynchronous and may finish out of order; the owner keeps the newest frameId.
// Images are top row first; the reprojection shader flips, not the upload.

export const canDecodeH264 = typeof VideoDecoder === 'function';

export class FrameDecoder {
  // onDecoded({header, images: {left, right}}): the receiver owns the images and must close them.
  // onError(message): a frame could not be decoded.
  constructor(onDecoded, onError) {
    this.onDecoded = onDecoded;
    this.onError = onError;
    this.video = { left: null, right: null };
    this.codecString = null;
    this.pending = new Map(); // frameId -> {header, left, right} while the two eyes decode
    this.needKeyFrame = true;
    this.skippedWaitingForKey = 0;
  }

  // After a (re)connect the next H.264 frame must be a key frame; decoders restart from it.
  reset() {
    this.needKeyFrame = true;
    this.closeVideo();
  }

  push(header, eyes) {
    if (header.codec === 'jpeg') this.decodeJpeg(header, eyes);
    else if (header.codec === 'h264') this.decodeH264(header, eyes);
    else this.onError(`frame ${header.frameId}: unknown codec '${header.codec}'`);
  }

  async decodeJpeg(header, eyes) {
    const decode = (eye) => createImageBitmap(new Blob([eyes[eye].data], { type: 'image/jpeg' }));
    const results = await Promise.allSettled([decode('left'), decode('right')]);
    if (results.some((r) => r.status === 'rejected')) {
      results.forEach((r) => r.status === 'fulfilled' && r.value.close());
      this.onError(`frame ${header.frameId}: JPEG decode failed`);
      return;
    }
    this.onDecoded({ header, images: { left: results[0].value, right: results[1].value } });
  }

  decodeH264(header, eyes) {
    if (!canDecodeH264) {
      this.onError('H.264 frame but this browser has no VideoDecoder');
      return;
    }
    if (typeof header.codecString !== 'string') {
      this.onError(`frame ${header.frameId}: H.264 without codecString`);
      return;
    }
    if (header.codecString !== this.codecString) {
      this.closeVideo();
      this.codecString = header.codecString;
      this.needKeyFrame = true;
    }
    if (this.needKeyFrame && !header.keyFrame) {
      this.skippedWaitingForKey++;
      return;
    }
    if (!this.video.left) this.openVideo();
    this.needKeyFrame = false;
    this.pending.set(header.frameId, { header, left: null, right: null });
    for (const eye of ['left', 'right']) {
      // The timestamp carries the frameId so that outputs can be matched to their header.
      this.video[eye].decode(new EncodedVideoChunk({
        type: header.keyFrame ? 'key' : 'delta', timestamp: header.frameId, data: eyes[eye].data,
      }));
    }
  }

  openVideo() {
    for (const eye of ['left', 'right']) {
      const decoder = new VideoDecoder({
        output: (frame) => this.videoOutput(eye, frame),
        error: (e) => this.videoError(eye, e),
      });
      // No `description`: the chunks are Annex B with in-band SPS/PPS.
      decoder.configure({ codec: this.codecString, optimizeForLatency: true });
      this.video[eye] = decoder;
    }
  }

  videoOutput(eye, frame) {
    const entry = this.pending.get(frame.timestamp);
    if (!entry) {
      frame.close();
      return;
    }
    entry[eye] = frame;
    if (!entry.left || !entry.right) return;
    // Both eyes of this frame are ready; anything older can no longer complete in order.
    for (const [id, older] of this.pending) {
      if (id > frame.timestamp) continue;
      this.pending.delete(id);
      if (id !== frame.timestamp) {
        older.left?.close();
        older.right?.close();
      }
    }
    this.onDecoded({ header: entry.header, images: { left: entry.left, right: entry.right } });
  }

  videoError(eye, error) {
    this.onError(`H.264 ${eye} eye: ${error.message}`);
    this.reset();
  }

  closeVideo() {
    for (const eye of ['left', 'right']) {
      const decoder = this.video[eye];
      if (decoder && decoder.state !== 'closed') decoder.close();
      this.video[eye] = null;
    }
    for (const entry of this.pending.values()) {
      entry.left?.close();
      entry.right?.close();
    }
    this.pending.clear();
  }
}
