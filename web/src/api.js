// The daemon's web API (docs/web.md): POST /api/<Service>/<Method> with the
// protobuf JSON of a chromosphere.v1 request; server-sent event streams; and
// the connection state the page shows (the daemon going away and returning).

export class ApiError extends Error {
  constructor(message, code, httpStatus) {
    super(message);
    this.code = code;
    this.httpStatus = httpStatus;
  }
}

const connectionListeners = new Set();
let connected = true;
let retryTimer = null;

export function onConnectionChange(listener) {
  connectionListeners.add(listener);
  return () => connectionListeners.delete(listener);
}

export function isConnected() {
  return connected;
}

function setConnected(value) {
  if (connected === value) return;
  connected = value;
  console.warn(value ? 'chromo: the daemon answers again' : 'chromo: the daemon does not answer');
  for (const listener of connectionListeners) listener(value);
  if (!value) scheduleReconnectProbe();
}

// While the daemon is away, ask /api/whoami every second until it answers.
function scheduleReconnectProbe() {
  if (retryTimer) return;
  retryTimer = setInterval(async () => {
    const status = await whoamiStatus();
    if (status === 200 || status === 401) {
      clearInterval(retryTimer);
      retryTimer = null;
      setConnected(true);
      if (status === 401) window.dispatchEvent(new Event('chromo:logged-out'));
    }
  }, 1000);
}

async function post(path, body, signal) {
  let reply;
  try {
    reply = await fetch(path, {
      method: 'POST',
      credentials: 'same-origin',
      headers: { 'Content-Type': 'application/json' },
      body: JSON.stringify(body ?? {}),
      signal,
    });
  } catch (error) {
    if (error.name === 'AbortError') throw error;  // the page gave up on it: not the daemon's absence
    if (await daemonAnswers()) {
      // One request failed (a connection closed under it) while the daemon is
      // there: this call fails, the page is not torn down as after an outage.
      console.warn(`chromo: ${path} failed (${error.message}) while the daemon answers`);
      throw new ApiError(`the request failed on its way (${error.message}); the daemon answers: try again`, 'UNAVAILABLE', 0);
    }
    setConnected(false);
    throw new ApiError(`the daemon does not answer (${error.message})`, 'UNAVAILABLE', 0);
  }
  setConnected(true);
  const text = await reply.text();
  let json;
  try {
    json = text ? JSON.parse(text) : {};
  } catch {
    throw new ApiError(`HTTP ${reply.status}: ${text.slice(0, 200)}`, 'INTERNAL', reply.status);
  }
  if (!reply.ok) {
    if (reply.status === 401 && path.startsWith('/api/')) window.dispatchEvent(new Event('chromo:logged-out'));
    throw new ApiError(json.error ?? `HTTP ${reply.status}`, json.code ?? 'UNKNOWN', reply.status);
  }
  return json;
}

// One unary call of chromosphere.v1: call('LedService', 'GetLedState', {}).
// `signal` (an AbortSignal, optional) lets the page drop a call it no longer needs.
export function call(service, method, request, signal) {
  return post(`/api/${service}/${method}`, request, signal);
}

export function login(token) {
  return post('/login', { token });
}

export function logout() {
  return post('/logout', {});
}

// GET /api/whoami's HTTP status, 0 when it does not answer.
async function whoamiStatus() {
  try {
    return (await fetch('/api/whoami', { credentials: 'same-origin', cache: 'no-store' })).status;
  } catch {
    return 0;
  }
}

// Whether the daemon is there (whoami answers 200 or 401).
async function daemonAnswers() {
  const status = await whoamiStatus();
  return status === 200 || status === 401;
}

// Whether this browser is logged in; a second try 250 ms after a failed one
// before the daemon counts as away (one dropped connection is not an outage).
export async function whoami() {
  for (let attempt = 1; attempt <= 2; ++attempt) {
    try {
      const reply = await fetch('/api/whoami', { credentials: 'same-origin', cache: 'no-store' });
      setConnected(true);
      return reply.status === 200;
    } catch {
      if (attempt === 1) await new Promise((resolve) => setTimeout(resolve, 250));
    }
  }
  setConnected(false);
  return false;
}

// A server-sent event stream: onMessage(json) per message, onFailure(error
// json) when the API ended it with an error. Reconnects after the daemon
// returns. Returns a function that closes it.
export function openStream(path, onMessage, onFailure) {
  let source = null;
  let closed = false;
  let reopenTimer = null;
  const open = () => {
    if (closed) return;
    source = new EventSource(path, { withCredentials: true });
    source.onmessage = (event) => {
      setConnected(true);
      onMessage(JSON.parse(event.data));
    };
    source.addEventListener('failure', (event) => {
      if (onFailure) onFailure(JSON.parse(event.data));
    });
    source.onerror = () => {
      source.close();
      whoami();  // tells the connection state whether the daemon is there
      if (!closed) reopenTimer = setTimeout(open, 1500);
    };
  };
  open();
  return () => {
    closed = true;
    clearTimeout(reopenTimer);
    if (source) source.close();
  };
}

// The URL of one of a session's files (GET /api/files/<session>/<path>).
export function fileUrl(sessionId, relativePath) {
  return `/api/files/${encodeURIComponent(sessionId)}/${relativePath.split('/').map(encodeURIComponent).join('/')}`;
}
