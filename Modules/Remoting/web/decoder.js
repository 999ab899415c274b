// Turns parsed frames into per-eye images that WebGL can upload: ImageBitmap for JPEG,
// VideoFrame for H.264 (one VideoDecoder per eye, since each eye is its own stream).
// Decoding is asynchronous and may finish out of order; the owner keeps the newest frameId.
// Every frame pushed is reported finished once it was decoded, dropped or skipped: the owner
// acknowledges that to the server, which sends no more than a small window ahead of it, so no
// backlog builds up in the decoders (a fast renderer would otherwise queue seconds there).
// Images are top row first; the reprojection shader flips, not the upload.

export const canDecodeH264 = typeof VideoDecoder === 'function';

export class FrameDecoder {
  // onDecoded({header, images: {left, right}}): the receiver owns the images and must close them.
  // onError(message): a frame could not be decoded.
  // onFinished(frameId): this frame and all before it are done with (cumulative).
  constructor(onDecoded, onError, onFinished = () => {}) {
    this.onDecoded = onDecoded;
    this.onError = onError;
    this.onFinished = onFinished;
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
    else {
      this.onError(`frame ${header.frameId}: unknown codec '${header.codec}'`);
      this.onFinished(header.frameId);
    }
  }

  async decodeJpeg(header, eyes) {
    const decode = (eye) => createImageBitmap(new Blob([eyes[eye].data], { type: 'image/jpeg' }));
    const results = await Promise.allSettled([decode('left'), decode('right')]);
    if (results.some((r) => r.status === 'rejected')) {
      results.forEach((r) => r.status === 'fulfilled' && r.value.close());
      this.onError(`frame ${header.frameId}: JPEG decode failed`);
    } else {
      this.onDecoded({ header, images: { left: results[0].value, right: results[1].value } });
    }
    this.onFinished(header.frameId);
  }

  decodeH264(header, eyes) {
    if (!canDecodeH264) {
      this.onError('H.264 frame but this browser has no VideoDecoder');
      this.onFinished(header.frameId);
      return;
    }
    if (typeof header.codecString !== 'string') {
      this.onError(`frame ${header.frameId}: H.264 without codecString`);
      this.onFinished(header.frameId);
      return;
    }
    if (header.codecString !== this.codecString) {
      this.closeVideo();
      this.codecString = header.codecString;
      this.needKeyFrame = true;
    }
    if (this.needKeyFrame && !header.keyFrame) {
      this.skippedWaitingForKey++;
      this.onFinished(header.frameId);
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
    this.onFinished(frame.timestamp);
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
    let newest = -1;
    for (const [id, entry] of this.pending) {
      entry.left?.close();
      entry.right?.close();
      newest = Math.max(newest, id);
    }
    this.pending.clear();
    if (newest >= 0) this.onFinished(newest); // abandoned: never coming out of the decoder
  }
}
