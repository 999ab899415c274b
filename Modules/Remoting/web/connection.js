// One WebSocket to the server that reopens itself after a disconnect, with exponential backoff.
// The backoff only resets once the owner calls established() (after `welcome`), so a server that
// accepts the socket and closes it at once (wrong protocol, second controller race) is not hammered.

const FIRST_RETRY_MS = 500;
const MAX_RETRY_MS = 10000;

export class Connection {
  // handlers: onOpen(), onText(string), onBinary(ArrayBuffer), onState(state, detail)
  // state is 'connecting', 'open' (socket open, no welcome yet) or 'disconnected' (detail.retryAt).
  constructor(url, handlers) {
    this.url = url;
    this.handlers = handlers;
    this.socket = null;
    this.failures = 0;
  }

  start() {
    this.handlers.onState('connecting', {});
    const socket = new WebSocket(this.url);
    socket.binaryType = 'arraybuffer';
    this.socket = socket;
    socket.onopen = () => {
      this.handlers.onState('open', {});
      this.handlers.onOpen();
    };
    socket.onmessage = (event) => {
      if (typeof event.data === 'string') this.handlers.onText(event.data);
      else this.handlers.onBinary(event.data);
    };
    // onerror is always followed by onclose, which carries the code; retrying happens there.
    socket.onclose = (event) => {
      if (this.socket !== socket) return;
      this.socket = null;
      const delay = Math.min(MAX_RETRY_MS, FIRST_RETRY_MS * 2 ** this.failures) * (0.8 + 0.4 * Math.random());
      this.failures++;
      this.handlers.onState('disconnected', { code: event.code, reason: event.reason, retryAt: performance.now() + delay });
      setTimeout(() => this.start(), delay);
    };
  }

  established() {
    this.failures = 0;
  }

  get isOpen() {
    return this.socket !== null && this.socket.readyState === WebSocket.OPEN;
  }

  // Bytes queued but not yet sent; lets the caller skip a pose instead of building a backlog.
  get bufferedAmount() {
    return this.socket ? this.socket.bufferedAmount : 0;
  }

  send(message) {
    return this.sendText(JSON.stringify(message));
  }

  sendText(text) {
    if (!this.isOpen) return false;
    this.socket.send(text);
    return true;
  }
}
